//! The cached bounding hierarchy of a [`SurfaceInverter`] (step 1 of the module docs):
//! leaves (Bezier sub-patches with their boxes and derivative cones) and the binary tree
//! of boxes over them.

use glam::{DVec2, DVec3, DVec4};

use super::{Certificate, SurfaceInverter};
use crate::nurbs::distance_net::{DistanceNets, MAX_SIDE};
use crate::nurbs::power::PowerPatches;
/// A sub-patch: its parameter box and boxes bounding the directions of its partial
/// derivatives.
///
/// For positive weights the derivative of a rational Bezier curve is a non-negative
/// combination of the differences `P_j - P_i`, `i < j`, of its control points
/// (Sederberg and Wang's rational hodograph: `B'_j B_i - B'_i B_j >= 0` for `j > i`).
/// In a patch the row "control points" along `u` lie in the boxes of the rows, so `S_u`
/// is a non-negative combination of vectors in `du` (the union of the differences of the
/// row boxes), and likewise `S_v` with `dv`. If `(S - P) . d` has one sign for every
/// `S` in the leaf box and `d` in `du`, then `f_u` never vanishes in the leaf: it holds
/// no stationary point, and no minimum on a side where `u` is free.
///
/// Everything is kept in a local orthonormal frame `(t1, t2, n)` fitted to the leaf (its
/// mean `u` direction and normal), where the control points make a thin oriented box
/// `obb`: a much tighter distance bound than the axis-aligned box of the tree nodes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Leaf {
    pub(super) uv_lo: DVec2,
    pub(super) uv_hi: DVec2,
    pub(super) frame: [DVec3; 3],
    pub(super) obb: (DVec3, DVec3),
    pub(super) du: (DVec3, DVec3),
    pub(super) dv: (DVec3, DVec3),
    /// Corner points `S(lo, lo), S(hi, lo), S(lo, hi), S(hi, hi)` (Bezier corners).
    pub(super) corners: [DVec3; 4],
}

impl Leaf {
    /// A Newton start for `p`: the parameter of the nearest point of the bilinear patch
    /// through the leaf's corners (two Gauss-Newton steps, no surface evaluation).
    #[inline]
    pub(super) fn estimate(&self, p: DVec3) -> DVec2 {
        let [c00, c10, c01, c11] = self.corners;
        let mut st = DVec2::splat(0.5);
        for _ in 0..2 {
            let (s, t) = (st.x, st.y);
            let b = c00 * ((1.0 - s) * (1.0 - t))
                + c10 * (s * (1.0 - t))
                + c01 * ((1.0 - s) * t)
                + c11 * (s * t);
            let bs = (c10 - c00) * (1.0 - t) + (c11 - c01) * t;
            let bt = (c01 - c00) * (1.0 - s) + (c11 - c10) * s;
            let r = b - p;
            let (a, m, c) = (bs.dot(bs), bs.dot(bt), bt.dot(bt));
            let det = a * c - m * m;
            if det <= crate::tolerance::BILINEAR_SINGULAR_REL * (a * c) || det.is_nan() {
                break;
            }
            let (g0, g1) = (bs.dot(r), bt.dot(r));
            st -= DVec2::new((c * g0 - m * g1) / det, (a * g1 - m * g0) / det);
            st = st.clamp(DVec2::ZERO, DVec2::ONE);
        }
        self.uv_lo + st * (self.uv_hi - self.uv_lo)
    }

    /// A leaf that excludes nothing: display frame, box `[lo, hi]`.
    pub(super) fn whole(uv_lo: DVec2, uv_hi: DVec2, lo: DVec3, hi: DVec3) -> Self {
        // A box of all differences contains zero: the sign test never fires.
        let all = (lo - hi, hi - lo);
        let c = (lo + hi) * 0.5;
        Leaf {
            uv_lo,
            uv_hi,
            frame: [DVec3::X, DVec3::Y, DVec3::Z],
            obb: (lo, hi),
            du: all,
            dv: all,
            corners: [c; 4],
        }
    }

    /// The leaf of a `p1 x q1` Bezier piece (row-major, homogeneous), with the
    /// axis-aligned box of its control points and the boxes of its four sides in the
    /// leaf's frame (see [`SideBoxes`]).
    fn from_piece(
        piece: &[DVec4],
        p1: usize,
        q1: usize,
        uv_lo: DVec2,
        uv_hi: DVec2,
    ) -> (Self, (DVec3, DVec3), SideBoxes) {
        let cart: Vec<DVec3> = piece.iter().map(|h| h.truncate() / h.w).collect();
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for c in &cart {
            lo = lo.min(*c);
            hi = hi.max(*c);
        }
        let at = |i: usize, j: usize| cart[i * q1 + j];
        let (pl, ql) = (p1 - 1, q1 - 1);
        let tu = at(pl, 0) + at(pl, ql) - at(0, 0) - at(0, ql);
        let tv = at(0, ql) + at(pl, ql) - at(0, 0) - at(pl, 0);
        let n = tu.cross(tv);
        let frame = match (tu.try_normalize(), n.try_normalize()) {
            (Some(t1), Some(n)) => [t1, n.cross(t1), n],
            _ => [DVec3::X, DVec3::Y, DVec3::Z],
        };
        let local: Vec<DVec3> = cart.iter().map(|c| to_frame(&frame, *c)).collect();
        let mut olo = DVec3::splat(f64::INFINITY);
        let mut ohi = DVec3::splat(f64::NEG_INFINITY);
        for c in &local {
            olo = olo.min(*c);
            ohi = ohi.max(*c);
        }
        let rows = group_boxes(&local, p1, q1, true);
        let cols = group_boxes(&local, p1, q1, false);
        let leaf = Leaf {
            uv_lo,
            uv_hi,
            frame,
            obb: (olo, ohi),
            du: difference_box(&rows),
            dv: difference_box(&cols),
            corners: [at(0, 0), at(pl, 0), at(0, ql), at(pl, ql)],
        };
        // The sides are Bezier curves whose control points are the net's first and
        // last rows and columns: their boxes bound the sides (convex hull).
        let sides = [rows[0], rows[pl], cols[0], cols[ql]];
        (leaf, (lo, hi), sides)
    }
}

/// Boxes of a leaf's four sides `u = lo, u = hi, v = lo, v = hi`, in the leaf's frame.
/// A side's box bounds its distance from below, so the extra Newton run along a domain
/// edge is skipped when that side cannot beat the best answer so far.
pub(super) type SideBoxes = [(DVec3, DVec3); 4];

#[inline]
pub(super) fn to_frame(frame: &[DVec3; 3], x: DVec3) -> DVec3 {
    DVec3::new(frame[0].dot(x), frame[1].dot(x), frame[2].dot(x))
}

/// True when `r . d` has one strict sign for all `r` in `[r_lo, r_hi]`, `d` in `[d.0, d.1]`
/// (interval arithmetic).
#[inline]
pub(super) fn sign_is_fixed(r_lo: DVec3, r_hi: DVec3, d: (DVec3, DVec3)) -> bool {
    let (a, b, c, e) = (r_lo * d.0, r_lo * d.1, r_hi * d.0, r_hi * d.1);
    let lo = a.min(b).min(c.min(e));
    let hi = a.max(b).max(c.max(e));
    lo.element_sum() > 0.0 || hi.element_sum() < 0.0
}

/// The box of all differences `P_j - P_i`, `i < j`, of points in consecutive groups
/// (`groups[i]` is the box of group `i`).
fn difference_box(groups: &[(DVec3, DVec3)]) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..groups.len() {
        for j in i + 1..groups.len() {
            lo = lo.min(groups[j].0 - groups[i].1);
            hi = hi.max(groups[j].1 - groups[i].0);
        }
    }
    (lo, hi)
}

/// The boxes of the rows (`along_u`) or columns of a row-major `p1 x q1` patch.
fn group_boxes(piece: &[DVec3], p1: usize, q1: usize, along_u: bool) -> Vec<(DVec3, DVec3)> {
    let (outer, inner) = if along_u { (p1, q1) } else { (q1, p1) };
    (0..outer)
        .map(|a| {
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for b in 0..inner {
                let c = if along_u {
                    piece[a * q1 + b]
                } else {
                    piece[b * q1 + a]
                };
                lo = lo.min(c);
                hi = hi.max(c);
            }
            (lo, hi)
        })
        .collect()
}

/// Marks a leaf in a child slot or a stack entry of the tree walk; the other bits are
/// the leaf's index.
pub(super) const LEAF: u32 = 1 << 31;

/// Stack entries of the tree walks. A depth-first walk that pushes both children of a
/// node holds at most one entry per level plus one. The tree bisects an `lu x lv` grid
/// of leaves, so it is `ceil(log2 lu) + ceil(log2 lv)` levels deep: at most 16 within
/// [`MAX_LEAVES`], and at most 33 for any grid whose leaf indices fit below [`LEAF`].
pub(super) const STACK_LEN: usize = 36;

/// Leaves the hierarchy aims to stay within: the leaf size grows on big surfaces, down
/// to one leaf per Bezier patch.
pub(super) const MAX_LEAVES: usize = 16_384;

/// An inner node of the tree: the boxes of its two children side by side, lane `k` for
/// child `k`, so both lower bounds come from one pass that the compiler runs on SSE2
/// pairs.
#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    /// `lo[axis][k]` and `hi[axis][k]`: the box of child `k`.
    pub(super) lo: [[f64; 2]; 3],
    pub(super) hi: [[f64; 2]; 3],
    /// Child `k`: a node index, or [`LEAF`] `|` a leaf index.
    pub(super) child: [u32; 2],
}

impl Node {
    /// The squared distances from `p` to the two children's boxes (zero inside).
    #[inline(always)]
    pub(super) fn child_dist2(&self, p: DVec3) -> [f64; 2] {
        // Comparisons rather than `f64::max`, whose NaN rule costs four instructions a
        // lane: every value here is finite.
        let max = |a: f64, b: f64| if a > b { a } else { b };
        let p = p.to_array();
        let mut d2 = [0.0; 2];
        for axis in 0..3 {
            let (lo, hi) = (self.lo[axis], self.hi[axis]);
            for k in 0..2 {
                let d = max(max(lo[k] - p[axis], p[axis] - hi[k]), 0.0);
                d2[k] += d * d;
            }
        }
        d2
    }
}

/// Largest number of net coefficients kept for the certificate (40 bytes each).
pub(super) const MAX_NET_COEFFICIENTS: usize = 1 << 20;

/// Splits a Bezier polygon at `t` (de Casteljau), returning both halves.
fn split_bezier(pts: &[DVec4], t: f64) -> (Vec<DVec4>, Vec<DVec4>) {
    let n = pts.len();
    let mut work = pts.to_vec();
    let mut left = Vec::with_capacity(n);
    let mut right = vec![DVec4::ZERO; n];
    left.push(work[0]);
    right[n - 1] = work[n - 1];
    for r in 1..n {
        for i in 0..n - r {
            work[i] = work[i] * (1.0 - t) + work[i + 1] * t;
        }
        left.push(work[0]);
        right[n - 1 - r] = work[n - 1 - r];
    }
    (left, right)
}

/// Splits a Bezier polygon into `pieces` equal parameter pieces.
pub(super) fn split_uniform(pts: &[DVec4], pieces: usize) -> Vec<Vec<DVec4>> {
    let mut out = Vec::with_capacity(pieces);
    let mut rest = pts.to_vec();
    for k in 0..pieces - 1 {
        let t = 1.0 / (pieces - k) as f64;
        let (a, b) = split_bezier(&rest, t);
        out.push(a);
        rest = b;
    }
    out.push(rest);
    out
}

/// Subdivides a `(p+1) x (q+1)` Bezier patch (row-major, `i` along `u`) into
/// `su x sv` pieces; returns them indexed `[a * sv + c]`, each row-major.
fn split_patch(patch: &[DVec4], p1: usize, q1: usize, su: usize, sv: usize) -> Vec<Vec<DVec4>> {
    // Split along u: each column j is a polygon of p1 points.
    let cols: Vec<Vec<Vec<DVec4>>> = (0..q1)
        .map(|j| {
            let col: Vec<DVec4> = (0..p1).map(|i| patch[i * q1 + j]).collect();
            split_uniform(&col, su)
        })
        .collect();
    let mut out = Vec::with_capacity(su * sv);
    for a in 0..su {
        // Strip a: p1 rows, each row of q1 points.
        let rows: Vec<Vec<Vec<DVec4>>> = (0..p1)
            .map(|i| {
                let row: Vec<DVec4> = (0..q1).map(|j| cols[j][a][i]).collect();
                split_uniform(&row, sv)
            })
            .collect();
        for c in 0..sv {
            let mut piece = Vec::with_capacity(p1 * q1);
            for row in &rows {
                piece.extend_from_slice(&row[c]);
            }
            out.push(piece);
        }
    }
    out
}

/// The non-empty knot spans `(index, start, end)` of a Bezier-form knot vector.
fn spans(knots: &[f64], p: usize, n: usize) -> Vec<(usize, f64, f64)> {
    (p..=n)
        .filter(|&k| knots[k] < knots[k + 1])
        .map(|k| (k, knots[k], knots[k + 1]))
        .collect()
}

impl SurfaceInverter {
    pub(super) fn build(&mut self) {
        let s = &self.surface;
        let (p, q) = (s.degree_u(), s.degree_v());
        // Bezier form cannot fail for a valid surface: every insertion stays within
        // multiplicity p. Should it ever fail, fall back to one leaf per original span
        // bounded by the whole control net (still correct, only slower).
        let Ok(bz) = s.to_bezier_form() else {
            let (lo, hi) = s.control_bounds();
            self.leaves
                .push(Leaf::whole(self.domain_lo, self.domain_hi, lo, hi));
            self.sides.push([(lo, hi); 4]);
            self.root = LEAF;
            return;
        };
        let (n_u, n_v) = (bz.count_u(), bz.count_v());
        let spans_u = spans(bz.knots_u().knots(), p, n_u - 1);
        let spans_v = spans(bz.knots_v().knots(), q, n_v - 1);
        self.power = PowerPatches::new(&bz, &spans_u, &spans_v, s.is_rational());
        let pw = bz.homogeneous();
        let cart = |i: usize, j: usize| {
            let h = pw[i * n_v + j];
            h.truncate() / h.w
        };
        // Control-polygon lengths of each span, the longest over the other direction:
        // they bound the arc length of the iso-curves in that span.
        let len_u: Vec<f64> = spans_u
            .iter()
            .map(|&(ku, _, _)| {
                (0..n_v)
                    .map(|j| {
                        (ku - p..ku)
                            .map(|i| cart(i + 1, j).distance(cart(i, j)))
                            .sum::<f64>()
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        let len_v: Vec<f64> = spans_v
            .iter()
            .map(|&(kv, _, _)| {
                (0..n_u)
                    .map(|i| {
                        (kv - q..kv)
                            .map(|j| cart(i, j + 1).distance(cart(i, j)))
                            .sum::<f64>()
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        // Split every span into pieces no longer than a target length (a fraction of
        // the surface size), at most 16 per span, keeping the tree modest for big nets.
        // Small leaves are nearly flat, so most pass the certificate's O(1) convexity
        // test and need no net (see `certify`).
        let total_len = len_u.iter().sum::<f64>().max(len_v.iter().sum::<f64>());
        let mut target = total_len / 16.0;
        let pieces_of = |len: &[f64], target: f64| -> Vec<usize> {
            len.iter()
                .map(|&l| {
                    if target > 0.0 {
                        ((l / target).ceil() as usize).clamp(1, 16)
                    } else {
                        1
                    }
                })
                .collect()
        };
        let (mut su, mut sv) = (pieces_of(&len_u, target), pieces_of(&len_v, target));
        while su.iter().sum::<usize>() * sv.iter().sum::<usize>() > MAX_LEAVES
            && su.iter().chain(&sv).any(|&n| n > 1)
        {
            target *= 2.0;
            su = pieces_of(&len_u, target);
            sv = pieces_of(&len_v, target);
        }
        let offsets = |s: &[usize]| -> Vec<usize> {
            s.iter()
                .scan(0, |acc, &x| {
                    let o = *acc;
                    *acc += x;
                    Some(o)
                })
                .collect()
        };
        let (off_u, off_v) = (offsets(&su), offsets(&sv));
        let (lu, lv): (usize, usize) = (su.iter().sum(), sv.iter().sum());
        let coefficients = lu * lv * (2 * p + 1) * (2 * q + 1);
        let mut nets = (coefficients <= MAX_NET_COEFFICIENTS)
            .then(|| DistanceNets::new(p + 1, q + 1, lu * lv))
            .flatten();
        self.no_nets = if nets.is_some() {
            Certificate::Certified
        } else if 2 * p + 1 > MAX_SIDE || 2 * q + 1 > MAX_SIDE {
            Certificate::DegreeAboveFive
        } else {
            Certificate::TooManyNetCoefficients
        };
        let mut leaf_boxes = vec![(DVec3::ZERO, DVec3::ZERO); lu * lv];
        let mut side_data = vec![[(DVec3::ZERO, DVec3::ZERO); 4]; lu * lv];
        let mut leaf_data = Vec::new();
        leaf_data.resize(
            lu * lv,
            Leaf::whole(DVec2::ZERO, DVec2::ZERO, DVec3::ZERO, DVec3::ZERO),
        );
        for (a, &(ku, ua, ub)) in spans_u.iter().enumerate() {
            for (c, &(kv, va, vb)) in spans_v.iter().enumerate() {
                let mut patch = Vec::with_capacity((p + 1) * (q + 1));
                for i in ku - p..=ku {
                    for j in kv - q..=kv {
                        patch.push(pw[i * n_v + j]);
                    }
                }
                let pieces = split_patch(&patch, p + 1, q + 1, su[a], sv[c]);
                for sa in 0..su[a] {
                    for sc in 0..sv[c] {
                        let piece = &pieces[sa * sv[c] + sc];
                        let (gi, gj) = (off_u[a] + sa, off_v[c] + sc);
                        // Exact span ends, so edge leaves meet the domain edge exactly.
                        let lerp = |x: f64, y: f64, t: usize, n: usize| {
                            if t == n {
                                y
                            } else {
                                x + (y - x) * t as f64 / n as f64
                            }
                        };
                        let fu = |t: usize| lerp(ua, ub, t, su[a]);
                        let fv = |t: usize| lerp(va, vb, t, sv[c]);
                        let uv_lo = DVec2::new(fu(sa), fv(sc));
                        let uv_hi = DVec2::new(fu(sa + 1), fv(sc + 1));
                        let (leaf, aabb, sides) =
                            Leaf::from_piece(piece, p + 1, q + 1, uv_lo, uv_hi);
                        leaf_data[gi * lv + gj] = leaf;
                        if let Some(nets) = nets.as_mut() {
                            nets.set(gi * lv + gj, piece);
                        }
                        side_data[gi * lv + gj] = sides;
                        leaf_boxes[gi * lv + gj] = aabb;
                    }
                }
            }
        }
        self.leaves = leaf_data;
        self.sides = side_data;
        self.nets = nets;
        self.nodes.reserve(lu * lv);
        self.root = self.build_node(&leaf_boxes, lv, 0, lu, 0, lv).0;
    }

    /// Builds the subtree for leaf-grid rows `i0..i1`, columns `j0..j1` (halving the
    /// longer side); returns its entry (a node index, or [`LEAF`] `|` a leaf index) and
    /// box.
    fn build_node(
        &mut self,
        boxes: &[(DVec3, DVec3)],
        lv: usize,
        i0: usize,
        i1: usize,
        j0: usize,
        j1: usize,
    ) -> (u32, DVec3, DVec3) {
        if i1 - i0 == 1 && j1 - j0 == 1 {
            let leaf = i0 * lv + j0;
            let (lo, hi) = boxes[leaf];
            return (LEAF | leaf as u32, lo, hi);
        }
        let idx = self.nodes.len() as u32;
        self.nodes.push(Node {
            lo: [[0.0; 2]; 3],
            hi: [[0.0; 2]; 3],
            child: [0; 2],
        });
        let children = if i1 - i0 >= j1 - j0 {
            let im = (i0 + i1) / 2;
            [
                self.build_node(boxes, lv, i0, im, j0, j1),
                self.build_node(boxes, lv, im, i1, j0, j1),
            ]
        } else {
            let jm = (j0 + j1) / 2;
            [
                self.build_node(boxes, lv, i0, i1, j0, jm),
                self.build_node(boxes, lv, i0, i1, jm, j1),
            ]
        };
        let node = &mut self.nodes[idx as usize];
        for (k, &(entry, lo, hi)) in children.iter().enumerate() {
            node.child[k] = entry;
            for axis in 0..3 {
                node.lo[axis][k] = lo[axis];
                node.hi[axis][k] = hi[axis];
            }
        }
        let [(_, lo0, hi0), (_, lo1, hi1)] = children;
        (idx, lo0.min(lo1), hi0.max(hi1))
    }
}
