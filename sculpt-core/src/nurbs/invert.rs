//! Point inversion and closest points on surfaces (P&T section 6.1, eqs. 6.5 to 6.7).
//!
//! # How it works
//!
//! [`SurfaceInverter`] is built once per surface (`surface.inverter()`), and answers any
//! number of queries without re-tessellating:
//!
//! 1. **Cached bounding hierarchy.** The surface is split into Bezier patches (knot
//!    refinement, P&T A5.4), each patch is subdivided by de Casteljau into a few
//!    sub-patches (about 16 per surface length, at most 16 per span), and each sub-patch
//!    ("leaf") keeps the axis-aligned box of its control points and a thin oriented box
//!    in a frame fitted to it. Weights are positive, so the boxes contain the sub-patch
//!    (convex-hull property). A binary tree over the leaf grid holds the unions; each
//!    inner node stores its two children's boxes side by side, so one SSE2 pass gives
//!    both lower bounds.
//! 2. **Branch and bound.** A query walks the tree nearest box first and skips every box
//!    farther than the best distance found so far. The leaves it reaches are collected
//!    with the lower bound their oriented box gives, and their Bezier corners (surface
//!    points, so free upper bounds) tighten the best distance before any Newton run.
//!    The collected leaves are then solved in increasing order of their bound, stopping
//!    at the first bound no smaller than the best distance. Every skip compares a lower
//!    bound of a sub-patch's distance (convex hull) with the distance to a real surface
//!    point, so a closer point is never skipped.
//! 3. **Exclusion tests.** A leaf whose derivative cone shows that `(S - P) . S_u` (or
//!    `. S_v`) cannot vanish inside it holds no stationary point and is skipped (see
//!    `Leaf`); the domain corners are always candidates. Once a run has converged, a
//!    leaf whose distance net (step 6) has no coefficient below zero holds nothing
//!    closer and is skipped for good (most leaves after the first are such neighbours
//!    of the answer's leaf), and a leaf that holds the converged answer is left to the
//!    certificate (its run would only find the answer again).
//! 4. **Bounded Newton per leaf.** In each remaining leaf, Newton's method on
//!    `f(u,v) = |S(u,v) - P|^2 / 2` (the system of eq. 6.5 with the Jacobian of eq. 6.6,
//!    update eq. 6.7) runs inside the leaf's parameter box. When a step wants to leave
//!    the box, the variable that hits the bound is fixed there (an active set) and the
//!    iteration continues along the boundary curve, so minima on the edge of the
//!    domain, and corners, are found exactly. A halving line search keeps every step
//!    descending, and an indefinite Hessian is shifted to positive definite.
//!    The start is the nearest point of the bilinear patch through the leaf's corners.
//!    A run that stops on its leaf's edge (the minimum lies beyond) goes on with Newton
//!    on the whole domain from there; the leaf holding that minimum is then left to the
//!    certificate.
//!    Leaves on a domain edge whose interior holds no stationary point run Newton along
//!    that edge alone, unless the box of that side (its Bezier control points) is no
//!    closer than the best distance. A leaf that holds two local minima (one on a domain
//!    edge, say) needs no second run: the certificate finds the other one. Each Newton
//!    step evaluates `S` and its derivatives from the Bezier
//!    patches converted once to power form (`power.rs`): a few Horner sweeps, with no
//!    span search and no basis-function divisions.
//! 5. **Polish.** A last Newton run on the whole domain starts from the best leaf answer;
//!    in closed directions (the seam of a sphere or torus) it wraps around instead of
//!    stopping at the seam.
//! 6. **Global certificate.** A Newton run finds *a* local minimum of its leaf; a query
//!    near a centre of curvature can see two in one leaf, and the farther one may be the
//!    one found. So the answer is proven global, or beaten: for every leaf the search
//!    reached whose box could still hold a closer point, `g = w^2 (|S - P|^2 - d*^2)`
//!    must be `>= 0`. A leaf whose `g` is convex (an O(1) test from precomputed bounds
//!    of its second differences) has one minimum, the answer or its own run's, and is
//!    cleared at once; otherwise the Bernstein net of `g` (`distance_net.rs`) clears it
//!    when no coefficient is negative; or when the net rises monotonically away from one
//!    side (a query beyond a domain edge) and that side's net, a curve's, clears it;
//!    or when the net is convex and its tangent plane at the answer stays above zero;
//!    or else it is split in four, up to `MAX_CERTIFY_DEPTH` levels, where a bounded
//!    Newton run from the lowest coefficient decides. A closer point found on the way becomes the answer and the certificate
//!    runs again. Points closer by less than `CERTIFY_TOL` (1e-10 m) are not sought.
//!
//! Stopping rules are P&T's: point coincidence `|S - P| <= POINT_EPS` (criterion 1),
//! zero cosine `|S_u . (S - P)| <= COSINE_EPS |S_u| |S - P|` and the same for `v`
//! (criterion 2, on the directions not held at a bound; also met when the tangential
//! residual `|S_u . (S - P)| / |S_u|` is below `POINT_EPS / 1000`, where `|S - P|` is too
//! small for the cosine to resolve), and a full Newton step that moves the point by
//! less than `POINT_EPS` (criterion 3).
//!
//! Poles (an edge collapsed to a point, where `S_u` or `S_v` vanishes) need nothing
//! special: a vanishing derivative satisfies its cosine test, and the shifted Hessian
//! keeps the step finite.

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

use glam::{DVec2, DVec3, DVec4};

use super::distance_net::{
    DistanceNets, MAX_SIDE, convex_bound_at, curve_clears, is_convex, monotone_side, net_min,
    side_net, split4,
};
use super::power::PowerPatches;
use super::surface::{NurbsSurface, SurfaceDerivs};
use crate::tolerance::{CERTIFY_TOL, COSINE_EPS, POINT_EPS};

/// Newton iterations per run before giving up.
const MAX_ITERS: u32 = 40;
/// Step halvings in the line search.
const MAX_HALVINGS: u32 = 30;

/// The answer to a closest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// The parameter `(u, v)` of the closest point found.
    pub uv: DVec2,
    /// `S(u, v)`.
    pub point: DVec3,
    /// `|S(u, v) - P|`.
    pub distance: f64,
    /// Newton iterations spent on this query (all runs together).
    pub iterations: u32,
    /// True when the final Newton run stopped by one of P&T's criteria (rather than by
    /// the iteration cap or a stalled line search).
    pub converged: bool,
    /// True when `uv` lies on an edge of the domain that is not a seam.
    pub on_boundary: bool,
    /// How the answer was obtained: proven global, or which exit left it unproven.
    pub certificate: Certificate,
}

/// How a [`Projection`] was obtained: [`Certificate::Certified`] when the Bernstein-net
/// certificate proved that no point of the surface is closer (by more than
/// `CERTIFY_TOL`, 1e-10 m), otherwise the exit that left the answer unproven. An
/// unproven answer is still the best point the search found, usually the true one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Certificate {
    /// Proven global: every leaf that could hold a closer point was cleared by its
    /// distance net (or its convexity, or its one-sided net).
    Certified,
    /// The certificate round spent its split budget (`MAX_CERTIFY_SPLITS` net
    /// splits): a sub-patch was settled by a bounded Newton run, which proves nothing.
    SplitBudgetSpent,
    /// A sub-patch was split down to `MAX_CERTIFY_DEPTH` levels and settled by a
    /// bounded Newton run, which proves nothing.
    DepthCap,
    /// The certificate found a closer point `MAX_CERTIFY_ROUNDS` times in a row; the
    /// last one was not certified in turn.
    TooManyImprovements,
    /// A degree above 5 in `u` or `v`: the nets (degree `2p x 2q`) are not built.
    DegreeAboveFive,
    /// More than `MAX_NET_COEFFICIENTS` (2^20) net coefficients: the nets are not
    /// built.
    TooManyNetCoefficients,
    /// The surface could not be split into Bezier patches: no nets (never happens for
    /// a valid surface).
    NoBezierForm,
    /// A local answer by request ([`SurfaceInverter::newton_from`]): no global search.
    Local,
    /// A non-finite query point (or seed of [`SurfaceInverter::newton_from`]): no
    /// answer, `distance` is infinite.
    InvalidQuery,
}

impl Certificate {
    /// Every kind, in declaration order (for counting them).
    pub const ALL: [Certificate; 9] = [
        Certificate::Certified,
        Certificate::SplitBudgetSpent,
        Certificate::DepthCap,
        Certificate::TooManyImprovements,
        Certificate::DegreeAboveFive,
        Certificate::TooManyNetCoefficients,
        Certificate::NoBezierForm,
        Certificate::Local,
        Certificate::InvalidQuery,
    ];

    /// True only for [`Certificate::Certified`].
    pub fn is_certified(self) -> bool {
        self == Certificate::Certified
    }
}

/// A Newton run's result.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    uv: DVec2,
    point: DVec3,
    dist2: f64,
    iters: u32,
    converged: bool,
    /// The run ended on a bound of its box that lies inside the domain (a leaf edge):
    /// a constrained answer of the leaf, not a stationary point of the surface.
    on_leaf_edge: bool,
}

impl Candidate {
    /// Takes the surface point `point = S(uv)` as the answer when it is closer to `p`
    /// (a corner: not a stationary point, so the final polish runs from it).
    #[inline]
    fn offer_point(&mut self, uv: DVec2, point: DVec3, p: DVec3) {
        let dist2 = point.distance_squared(p);
        if dist2 < self.dist2 {
            *self = Candidate {
                uv,
                point,
                dist2,
                iters: self.iters,
                converged: false,
                on_leaf_edge: true,
            };
        }
    }
}

/// What the search learnt of one leaf it reached.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Reached {
    /// No interior minimum: the leaf was not solved, or its run did not converge inside.
    Open,
    /// The interior minimum the leaf's Newton run converged to.
    Minimum(DVec2),
    /// Its distance net proved that no point of the leaf is closer than the best
    /// distance at the time, less [`CERTIFY_TOL`]. The best distance only decreases, so
    /// the proof stands for the final answer: the certificate skips the leaf.
    Cleared,
}

/// The leaves one query's search reached (those whose boxes could hold a point closer
/// than the best so far), with what the search learnt of each. The certificate only
/// needs these leaves: every other one was skipped by a lower bound no smaller than a
/// real surface point's distance. A leaf whose net is convex is cleared by its tangent
/// plane at the recorded minimum, with no new run.
#[derive(Debug, Clone, Copy)]
struct Visited {
    leaves: [(u32, Reached); 16],
    len: usize,
    /// More leaves were reached than recorded: the certificate walks the tree instead.
    overflow: bool,
}

impl Visited {
    fn new() -> Self {
        Self {
            leaves: [(0, Reached::Open); 16],
            len: 0,
            overflow: false,
        }
    }

    fn reach(&mut self, leaf: u32) {
        if self.len < self.leaves.len() {
            self.leaves[self.len] = (leaf, Reached::Open);
            self.len += 1;
        } else {
            self.overflow = true;
        }
    }

    fn record(&mut self, leaf: usize, what: Reached) {
        if let Some(entry) = self.leaves[..self.len]
            .iter_mut()
            .rev()
            .find(|e| e.0 as usize == leaf)
        {
            entry.1 = what;
        }
    }

    fn get(&self, leaf: usize) -> Reached {
        self.leaves[..self.len]
            .iter()
            .find(|e| e.0 as usize == leaf)
            .map_or(Reached::Open, |e| e.1)
    }
}

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
struct Leaf {
    uv_lo: DVec2,
    uv_hi: DVec2,
    frame: [DVec3; 3],
    obb: (DVec3, DVec3),
    du: (DVec3, DVec3),
    dv: (DVec3, DVec3),
    /// Corner points `S(lo, lo), S(hi, lo), S(lo, hi), S(hi, hi)` (Bezier corners).
    corners: [DVec3; 4],
}

impl Leaf {
    /// A Newton start for `p`: the parameter of the nearest point of the bilinear patch
    /// through the leaf's corners (two Gauss-Newton steps, no surface evaluation).
    #[inline]
    fn estimate(&self, p: DVec3) -> DVec2 {
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

    /// A leaf that excludes nothing: world frame, box `[lo, hi]`.
    fn whole(uv_lo: DVec2, uv_hi: DVec2, lo: DVec3, hi: DVec3) -> Self {
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
type SideBoxes = [(DVec3, DVec3); 4];

#[inline]
fn to_frame(frame: &[DVec3; 3], x: DVec3) -> DVec3 {
    DVec3::new(frame[0].dot(x), frame[1].dot(x), frame[2].dot(x))
}

/// True when `r . d` has one strict sign for all `r` in `[r_lo, r_hi]`, `d` in `[d.0, d.1]`
/// (interval arithmetic).
#[inline]
fn sign_is_fixed(r_lo: DVec3, r_hi: DVec3, d: (DVec3, DVec3)) -> bool {
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
const LEAF: u32 = 1 << 31;

/// Stack entries of the tree walks. A depth-first walk that pushes both children of a
/// node holds at most one entry per level plus one. The tree bisects an `lu x lv` grid
/// of leaves, so it is `ceil(log2 lu) + ceil(log2 lv)` levels deep: at most 16 within
/// [`MAX_LEAVES`], and at most 33 for any grid whose leaf indices fit below [`LEAF`].
const STACK_LEN: usize = 36;

/// Leaves the hierarchy aims to stay within: the leaf size grows on big surfaces, down
/// to one leaf per Bezier patch.
const MAX_LEAVES: usize = 16_384;

/// An inner node of the tree: the boxes of its two children side by side, lane `k` for
/// child `k`, so both lower bounds come from one pass that the compiler runs on SSE2
/// pairs.
#[derive(Debug, Clone, Copy)]
struct Node {
    /// `lo[axis][k]` and `hi[axis][k]`: the box of child `k`.
    lo: [[f64; 2]; 3],
    hi: [[f64; 2]; 3],
    /// Child `k`: a node index, or [`LEAF`] `|` a leaf index.
    child: [u32; 2],
}

impl Node {
    /// The squared distances from `p` to the two children's boxes (zero inside).
    #[inline(always)]
    fn child_dist2(&self, p: DVec3) -> [f64; 2] {
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

/// Cached acceleration structure for closest-point queries on one surface.
///
/// Owns a copy of the surface, so it can be stored next to it freely.
#[derive(Debug, Clone)]
pub struct SurfaceInverter {
    surface: NurbsSurface,
    /// Inner nodes of the tree; the walk starts at `root`.
    nodes: Vec<Node>,
    /// Node 0, or [`LEAF`] `|` 0 when the tree is one leaf.
    root: u32,
    leaves: Vec<Leaf>,
    /// The side boxes of each leaf (kept apart: only edge leaves read them).
    sides: Vec<SideBoxes>,
    domain_lo: DVec2,
    domain_hi: DVec2,
    closed: [bool; 2],
    /// The four domain corners and their points.
    corners: [(DVec2, DVec3); 4],
    /// The Bezier patches in power form, for fast Newton steps (`None` only when the
    /// Bezier form is unavailable or too big; B-spline evaluation is used then).
    power: Option<PowerPatches>,
    /// The distance nets of the leaves, for the global certificate (`None` for degrees
    /// above 5 or very big surfaces, see [`MAX_NET_COEFFICIENTS`]).
    nets: Option<DistanceNets>,
    /// Why `nets` is `None` (the certificate every answer then carries).
    no_nets: Certificate,
}

/// Largest number of net coefficients kept for the certificate (40 bytes each).
const MAX_NET_COEFFICIENTS: usize = 1 << 20;

/// Subdivision depth of a leaf's net before the certificate settles for a Newton run.
const MAX_CERTIFY_DEPTH: u32 = 6;

/// Certificate rounds per query: each round that finds a closer point starts another
/// from it; the answer of the last round is left unproven.
const MAX_CERTIFY_ROUNDS: u32 = 4;

/// Net splits one certificate round may make before every patch left is settled by a
/// Newton run (bounds the work where the distance is nearly constant: a query near a
/// sphere's centre, or over a pole, where the parametrisation degenerates).
const MAX_CERTIFY_SPLITS: u32 = 16;

/// One certificate round: the query, the answer to beat, and the splits left.
struct Probe<'a> {
    p: DVec3,
    best: &'a Candidate,
    splits_left: std::cell::Cell<u32>,
    /// The exit that settled a sub-patch without proof, if one did.
    unproven: std::cell::Cell<Option<Certificate>>,
}

/// A (sub-)patch's net of `g` with its parameter box and clearing threshold.
#[derive(Clone, Copy)]
struct NetPatch<'a> {
    net: &'a [f64],
    /// Net rows and columns.
    size: (usize, usize),
    lo: DVec2,
    hi: DVec2,
    /// A coefficient at or above this proves nothing closer there (see
    /// `DistanceNets::query`).
    threshold: f64,
}

fn box_dist2(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
}

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
fn split_uniform(pts: &[DVec4], pieces: usize) -> Vec<Vec<DVec4>> {
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

impl NurbsSurface {
    /// Builds the cached closest-point structure for this surface.
    pub fn inverter(&self) -> SurfaceInverter {
        SurfaceInverter::new(self)
    }

    /// [`SurfaceInverter::newton_from`] without building the inverter's hierarchy and
    /// certificate nets: a local closest point (P&T eq. 6.6 with its stopping
    /// criteria), for a caller that asks one surface only a few local questions.
    pub fn newton_closest(&self, p: DVec3, seed_uv: DVec2) -> Projection {
        SurfaceInverter::unbuilt(self).newton_from(p, seed_uv)
    }
}

impl SurfaceInverter {
    /// Builds the bounding hierarchy (see the module docs). Cost: one knot refinement
    /// and a de Casteljau subdivision; a few microseconds for a bicubic 6x6 patch.
    pub fn new(surface: &NurbsSurface) -> Self {
        let mut inv = Self::unbuilt(surface);
        inv.build();
        inv
    }

    /// The inverter's fields without the hierarchy: enough for local Newton only.
    fn unbuilt(surface: &NurbsSurface) -> Self {
        let (u0, u1) = surface.domain_u();
        let (v0, v1) = surface.domain_v();
        Self {
            surface: surface.clone(),
            nodes: Vec::new(),
            root: LEAF,
            leaves: Vec::new(),
            sides: Vec::new(),
            domain_lo: DVec2::new(u0, v0),
            domain_hi: DVec2::new(u1, v1),
            closed: [surface.is_closed_u(), surface.is_closed_v()],
            corners: [(u0, v0), (u0, v1), (u1, v0), (u1, v1)]
                .map(|(u, v)| (DVec2::new(u, v), surface.point(u, v))),
            power: None,
            nets: None,
            no_nets: Certificate::NoBezierForm,
        }
    }

    /// The surface this inverter answers for.
    pub fn surface(&self) -> &NurbsSurface {
        &self.surface
    }

    /// The power-form patches, when built.
    #[cfg(test)]
    pub(crate) fn power(&self) -> Option<&PowerPatches> {
        self.power.as_ref()
    }

    /// `S` and its derivatives to second order at `uv` (clamped into the domain).
    #[inline]
    fn derivs(&self, uv: DVec2) -> SurfaceDerivs {
        match &self.power {
            Some(pp) => pp.derivatives(uv),
            None => self.surface.derivatives(uv.x, uv.y),
        }
    }

    /// Number of leaf sub-patches in the hierarchy.
    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    fn build(&mut self) {
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

    /// The closest point of the surface to `p` (global: branch and bound over the
    /// cached hierarchy, then Newton; see the module docs).
    ///
    /// A non-finite `p` gives `distance = f64::INFINITY`, `converged = false` and the
    /// domain's first corner: never NaN.
    pub fn closest_point(&self, p: DVec3) -> Projection {
        if !p.is_finite() {
            return self.invalid_query();
        }
        let mut solved = Visited::new();
        let best = self.search(p, None, &mut solved);
        self.finish(p, best, &solved)
    }

    /// Like [`Self::closest_point`], but first runs Newton from `seed_uv` (for example
    /// the previous sample of a stroke). The seed's answer bounds the search, so most of
    /// the hierarchy is skipped; the result is still the global closest point.
    pub fn closest_point_from(&self, p: DVec3, seed_uv: DVec2) -> Projection {
        if !p.is_finite() {
            return self.invalid_query();
        }
        let seed = if seed_uv.is_finite() {
            self.newton(p, seed_uv, self.domain_lo, self.domain_hi, self.closed)
        } else {
            self.newton(
                p,
                (self.domain_lo + self.domain_hi) * 0.5,
                self.domain_lo,
                self.domain_hi,
                self.closed,
            )
        };
        let mut solved = Visited::new();
        let best = self.search(p, Some(seed), &mut solved);
        self.finish(p, best, &solved)
    }

    /// Local Newton only, from `seed_uv`, on the whole domain (wrapping in closed
    /// directions): the fast path for tracking a point that moves a little. It finds a
    /// local minimum of the distance, which need not be the global one.
    pub fn newton_from(&self, p: DVec3, seed_uv: DVec2) -> Projection {
        if !p.is_finite() || !seed_uv.is_finite() {
            return self.invalid_query();
        }
        let c = self.newton(p, seed_uv, self.domain_lo, self.domain_hi, self.closed);
        self.to_projection(c, Certificate::Local)
    }

    /// Closest points for many query points, in parallel (rayon) when the `parallel`
    /// feature is on (the default). Output order matches input order.
    pub fn closest_points(&self, points: &[DVec3]) -> Vec<Projection> {
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            // One rayon task per chunk of queries (a few hundred microseconds of work)
            // keeps the scheduling overhead negligible and the cores balanced.
            const CHUNK: usize = 256;
            let mut out = vec![self.invalid_query(); points.len()];
            out.par_chunks_mut(CHUNK)
                .zip(points.par_chunks(CHUNK))
                .for_each(|(answers, queries)| {
                    for (a, &p) in answers.iter_mut().zip(queries) {
                        *a = self.closest_point(p);
                    }
                });
            out
        }
        #[cfg(not(feature = "parallel"))]
        {
            points.iter().map(|&p| self.closest_point(p)).collect()
        }
    }

    /// Closest points for consecutive samples of a stroke: each query is seeded with the
    /// previous answer ([`Self::closest_point_from`]).
    pub fn closest_points_along(&self, points: &[DVec3]) -> Vec<Projection> {
        let mut out: Vec<Projection> = Vec::with_capacity(points.len());
        for &p in points {
            let pr = match out.last() {
                Some(prev) if prev.distance.is_finite() => self.closest_point_from(p, prev.uv),
                _ => self.closest_point(p),
            };
            out.push(pr);
        }
        out
    }

    fn invalid_query(&self) -> Projection {
        let uv = self.domain_lo;
        Projection {
            uv,
            point: self.surface.point_uv(uv),
            distance: f64::INFINITY,
            iterations: 0,
            converged: false,
            on_boundary: true,
            certificate: Certificate::InvalidQuery,
        }
    }

    fn to_projection(&self, c: Candidate, certificate: Certificate) -> Projection {
        let eps = crate::tolerance::DOMAIN_EDGE_REL * (self.domain_hi - self.domain_lo);
        let on = |k: usize| {
            !self.closed[k]
                && (c.uv[k] <= self.domain_lo[k] + eps[k] || c.uv[k] >= self.domain_hi[k] - eps[k])
        };
        Projection {
            uv: c.uv,
            point: c.point,
            distance: c.dist2.sqrt(),
            iterations: c.iters,
            converged: c.converged,
            on_boundary: on(0) || on(1),
            certificate,
        }
    }

    /// Polishes the best leaf answer on the whole domain, proves it global (or finds
    /// the closer point the leaf runs missed, see [`Self::certify`]) and converts it.
    fn finish(&self, p: DVec3, best: Candidate, solved: &Visited) -> Projection {
        let polished = self.polish(p, best);
        let (answer, certificate) = self.certify(p, polished, solved);
        self.to_projection(answer, certificate)
    }

    /// A last Newton run on the whole domain from a leaf answer (wrapping in closed
    /// directions); the better of the two.
    fn polish(&self, p: DVec3, best: Candidate) -> Candidate {
        if best.converged && !best.on_leaf_edge && !self.closed[0] && !self.closed[1] {
            // Already a converged answer of the whole-domain problem.
            return best;
        }
        let polished = self.newton(p, best.uv, self.domain_lo, self.domain_hi, self.closed);
        // Rounding: the polish evaluates with the power form, which can differ from the
        // point routine (corners) in the last digit. `|S - P|^2` carries an absolute
        // error of a few ulps of `|S|` and `|P|` times `|S - P|`: for a query within
        // 1e-7 of a corner a relative tolerance alone rejects the converged polish.
        let noise = 8.0
            * f64::EPSILON
            * best.dist2.sqrt()
            * (p.abs().max_element() + best.point.abs().max_element());
        let mut out = if polished.dist2 <= best.dist2 * (1.0 + crate::tolerance::REL_EPS) + noise {
            polished
        } else {
            best
        };
        out.iters = best.iters + polished.iters;
        out
    }

    /// The global certificate (see `distance_net`): proves that no point of the surface
    /// is closer to `p` than `best` by more than [`CERTIFY_TOL`], or finds one and
    /// starts again from it.
    ///
    /// A leaf's Newton run finds one local minimum; when a sub-patch holds two (a query
    /// near a centre of curvature), the other can be the global one. For every leaf whose
    /// box could still hold a closer point, the Bernstein net of
    /// `g = w^2 (|S - P|^2 - |S* - P|^2)` decides: no negative coefficient proves the
    /// leaf clear; a net monotone across the box leaves its minimum on one side, whose
    /// own net (a curve's) decides the same way; a convex `g` is cleared by its tangent
    /// plane at the answer (or at the box's own Newton minimum, which is the closer
    /// point if there is one); otherwise
    /// the net is split in four and each quarter is decided the same way, down to
    /// [`MAX_CERTIFY_DEPTH`] levels, where a bounded Newton run has the last word.
    ///
    /// Returns the answer with how it was obtained: [`Certificate::Certified`], or the
    /// exit that left it unproven (a Newton run had the last word, the rounds ran out,
    /// or the surface has no nets).
    fn certify(&self, p: DVec3, mut best: Candidate, solved: &Visited) -> (Candidate, Certificate) {
        let Some(nets) = &self.nets else {
            return (best, self.no_nets);
        };
        for _ in 0..MAX_CERTIFY_ROUNDS {
            let probe = Probe {
                p,
                best: &best,
                splits_left: std::cell::Cell::new(MAX_CERTIFY_SPLITS),
                unproven: std::cell::Cell::new(None),
            };
            let Some(closer) = self.find_closer(nets, &probe, solved) else {
                let certificate = probe.unproven.get().unwrap_or(Certificate::Certified);
                return (best, certificate);
            };
            let iters = best.iters;
            best = self.polish(p, closer);
            best.iters += iters;
        }
        (best, Certificate::TooManyImprovements)
    }

    /// A point closer than `best` by more than [`CERTIFY_TOL`] in a leaf that cannot be
    /// cleared, or `None` when every leaf is cleared. Only the leaves the search reached
    /// can hold a closer point; when there were too many to record, the tree is walked.
    fn find_closer(
        &self,
        nets: &DistanceNets,
        probe: &Probe<'_>,
        visited: &Visited,
    ) -> Option<Candidate> {
        let (p, best) = (probe.p, probe.best);
        if !visited.overflow {
            return visited.leaves[..visited.len]
                .iter()
                .find_map(|&(index, what)| self.closer_in_leaf(nets, probe, index as usize, what));
        }
        let mut stack = [(self.root, 0.0f64); STACK_LEN];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (entry, bound) = stack[top];
            if bound >= best.dist2 {
                continue;
            }
            if entry & LEAF != 0 {
                let index = (entry & !LEAF) as usize;
                let found = self.closer_in_leaf(nets, probe, index, visited.get(index));
                if found.is_some() {
                    return found;
                }
                continue;
            }
            let node = &self.nodes[entry as usize];
            let d2 = node.child_dist2(p);
            for k in 0..2 {
                stack[top] = (node.child[k], d2[k]);
                top += 1;
            }
        }
        None
    }

    /// Decides one leaf, given what the search learnt of it.
    fn closer_in_leaf(
        &self,
        nets: &DistanceNets,
        probe: &Probe<'_>,
        index: usize,
        what: Reached,
    ) -> Option<Candidate> {
        let run = match what {
            Reached::Cleared => return None,
            Reached::Minimum(uv) => Some(uv),
            Reached::Open => None,
        };
        let (p, best) = (probe.p, probe.best);
        let leaf = &self.leaves[index];
        if box_dist2(to_frame(&leaf.frame, p), leaf.obb.0, leaf.obb.1) >= best.dist2 {
            return None;
        }
        // A convex leaf has one minimum: the answer, when it lies in the leaf, or the
        // one the search's run found in it. Either clears the leaf without a net.
        if best.converged
            && (run.is_some() || self.holds(leaf, best.uv))
            && nets.leaf_is_convex(index, p, best.dist2)
        {
            return None;
        }
        let (m1, n1) = nets.size();
        let mut buf = [0.0; MAX_SIDE * MAX_SIDE];
        let net = &mut buf[..m1 * n1];
        let threshold = nets.query(index, p, best.dist2, CERTIFY_TOL, net);
        let patch = NetPatch {
            net,
            size: (m1, n1),
            lo: leaf.uv_lo,
            hi: leaf.uv_hi,
            threshold,
        };
        self.closer_in_net(probe, &patch, run, 0)
    }

    /// `uv`, then its copies one period away in the closed directions (across a seam).
    fn copies(&self, uv: DVec2) -> impl Iterator<Item = DVec2> {
        let period = self.domain_hi - self.domain_lo;
        let shifts: &[f64] = if self.closed[0] || self.closed[1] {
            &[0.0, -1.0, 1.0]
        } else {
            &[0.0]
        };
        let closed = self.closed;
        shifts.iter().map(move |&shift| {
            let mut copy = uv;
            for k in 0..2 {
                if closed[k] {
                    copy[k] += shift * period[k];
                }
            }
            copy
        })
    }

    /// True when the leaf's parameter box holds `uv` (or its copy across a seam).
    fn holds(&self, leaf: &Leaf, uv: DVec2) -> bool {
        let period = self.domain_hi - self.domain_lo;
        (0..2).all(|k| {
            let inside = |x: f64| x >= leaf.uv_lo[k] && x <= leaf.uv_hi[k];
            inside(uv[k])
                || (self.closed[k] && (inside(uv[k] + period[k]) || inside(uv[k] - period[k])))
        })
    }

    /// Decides one (sub-)patch with its net (see [`Self::certify`]); `hint` is a known
    /// minimum of the patch (the search's run in a leaf).
    fn closer_in_net(
        &self,
        probe: &Probe<'_>,
        patch: &NetPatch<'_>,
        hint: Option<DVec2>,
        depth: u32,
    ) -> Option<Candidate> {
        let NetPatch {
            net,
            size: (m1, n1),
            lo,
            hi,
            threshold,
        } = *patch;
        let (p, best) = (probe.p, probe.best);
        if net_min(net) >= threshold {
            return None;
        }
        let local = |uv: DVec2| ((uv - lo) / (hi - lo)).clamp(DVec2::ZERO, DVec2::ONE);
        // `g` monotone across the patch (a query beyond a domain edge, whose answer lies
        // on the edge): the side that holds its minimum decides, by its own net.
        if let Some(side) = monotone_side(net, m1, n1) {
            let mut edge = [0.0; MAX_SIDE];
            let len = side_net(net, m1, n1, side, &mut edge);
            let k = side.along();
            let at = self.copies(best.uv).chain(hint).map(|uv| local(uv)[k]);
            if curve_clears(&edge[..len], threshold, at) {
                return None;
            }
        }
        let convex = is_convex(net, m1, n1);
        if convex {
            // The tangent plane at the answer (or its copy across a seam), clamped into
            // the box, then at the patch's known minimum.
            for uv in self.copies(best.uv).chain(hint) {
                let st = local(uv);
                if convex_bound_at(net, m1, n1, st.x, st.y) >= threshold {
                    return None;
                }
            }
        }
        // Out of depth or of the query's split budget: a bounded Newton run decides.
        let last = depth >= MAX_CERTIFY_DEPTH || probe.splits_left.get() == 0;
        if convex || last {
            // The box's own minimum, from its smallest coefficient.
            let k = (0..m1 * n1)
                .min_by(|&a, &b| net[a].total_cmp(&net[b]))
                .unwrap_or(0);
            let st = DVec2::new(
                (k / n1) as f64 / (m1 - 1) as f64,
                (k % n1) as f64 / (n1 - 1) as f64,
            );
            let c = self.newton(p, lo + st * (hi - lo), lo, hi, [false; 2]);
            if c.dist2.sqrt() < best.dist2.sqrt() - CERTIFY_TOL {
                return Some(c);
            }
            let st = local(c.uv);
            if convex && convex_bound_at(net, m1, n1, st.x, st.y) >= threshold {
                return None;
            }
            if last {
                // Settled by the Newton run alone: no proof for this sub-patch.
                if probe.unproven.get().is_none() {
                    probe.unproven.set(Some(if depth >= MAX_CERTIFY_DEPTH {
                        Certificate::DepthCap
                    } else {
                        Certificate::SplitBudgetSpent
                    }));
                }
                return None;
            }
        }
        probe.splits_left.set(probe.splits_left.get() - 1);
        // Quarter nets on the stack, sized for bicubic patches when they fit.
        if m1 * n1 <= 49 {
            self.closer_in_quarters::<49>(probe, patch, depth)
        } else {
            self.closer_in_quarters::<{ MAX_SIDE * MAX_SIDE }>(probe, patch, depth)
        }
    }

    /// Splits a patch's net in four and decides each quarter, the lowest first. `L` is
    /// the length of the stack buffers (at least `m1 * n1`).
    fn closer_in_quarters<const L: usize>(
        &self,
        probe: &Probe<'_>,
        patch: &NetPatch<'_>,
        depth: u32,
    ) -> Option<Candidate> {
        let (lo, hi, (m1, n1)) = (patch.lo, patch.hi, patch.size);
        let mid = (lo + hi) * 0.5;
        let boxes = [
            (lo, mid),
            (DVec2::new(mid.x, lo.y), DVec2::new(hi.x, mid.y)),
            (DVec2::new(lo.x, mid.y), DVec2::new(mid.x, hi.y)),
            (mid, hi),
        ];
        let mut quarters = [[0.0; L]; 4];
        split4(patch.net, m1, n1, &mut quarters);
        let mut order = [0usize, 1, 2, 3];
        let mins = quarters.each_ref().map(|q| net_min(&q[..m1 * n1]));
        order.sort_unstable_by(|&a, &b| mins[a].total_cmp(&mins[b]));
        for q in order {
            let quarter = NetPatch {
                net: &quarters[q][..m1 * n1],
                lo: boxes[q].0,
                hi: boxes[q].1,
                ..*patch
            };
            let found = self.closer_in_net(probe, &quarter, None, depth + 1);
            if found.is_some() {
                return found;
            }
        }
        None
    }

    /// The closer of `start` and the domain corners. The corners are candidates of their
    /// own (a minimum there need not be a stationary point of any leaf), and they make a
    /// cheap first bound.
    fn best_corner(&self, p: DVec3, start: Option<Candidate>) -> Candidate {
        let mut best = start.unwrap_or(Candidate {
            uv: self.domain_lo,
            point: DVec3::ZERO,
            dist2: f64::INFINITY,
            iters: 0,
            converged: false,
            on_leaf_edge: true,
        });
        for &(uv, point) in &self.corners {
            best.offer_point(uv, point, p);
        }
        best
    }

    /// Branch and bound over the hierarchy; `start` is an optional starting answer.
    ///
    /// Two phases. The walk collects the leaves whose boxes could hold a closer point
    /// than the best so far, and tightens that bound on the way with the leaves' corner
    /// points (Bezier corners are surface points, so they cost no Newton run). Then the
    /// collected leaves are solved in increasing order of their lower bound, stopping at
    /// the first bound no smaller than the best answer. Every skip compares a lower bound
    /// of the distance to a sub-patch with the distance to a real surface point, so no
    /// closer point is ever skipped.
    fn search(&self, p: DVec3, start: Option<Candidate>, solved: &mut Visited) -> Candidate {
        let mut best = self.best_corner(p, start);
        let mut iters = best.iters;
        // Leaves to solve: (lower bound of the squared distance, leaf index).
        let mut found = [(0.0f64, 0u32); 16];
        let mut n_found = 0;
        // Entries to visit with the lower bound of their squared distance.
        let mut stack = [(self.root, 0.0f64); STACK_LEN];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (entry, bound) = stack[top];
            if bound >= best.dist2 {
                continue;
            }
            if entry & LEAF != 0 {
                let index = entry & !LEAF;
                let leaf = &self.leaves[index as usize];
                let p_local = to_frame(&leaf.frame, p);
                let bound = box_dist2(p_local, leaf.obb.0, leaf.obb.1);
                if bound >= best.dist2 {
                    continue;
                }
                let [c00, c10, c01, c11] = leaf.corners;
                let (lo, hi) = (leaf.uv_lo, leaf.uv_hi);
                best.offer_point(lo, c00, p);
                best.offer_point(DVec2::new(hi.x, lo.y), c10, p);
                best.offer_point(DVec2::new(lo.x, hi.y), c01, p);
                best.offer_point(hi, c11, p);
                found[n_found] = (bound, index);
                n_found += 1;
                solved.reach(index);
                if n_found == found.len() {
                    self.solve_leaves(p, &mut found, &mut best, &mut iters, solved);
                    n_found = 0;
                }
                continue;
            }
            let node = &self.nodes[entry as usize];
            let d2 = node.child_dist2(p);
            // Push the farther child first so the nearer one is examined first; a child
            // no nearer than the best point so far is written but not kept. Branch-free:
            // which child is nearer is a coin toss to the branch predictor. The stack
            // holds at most one entry per level of the tree plus one (`STACK_LEN`).
            let nearer = usize::from(d2[1] < d2[0]);
            for k in [1 - nearer, nearer] {
                stack[top] = (node.child[k], d2[k]);
                top += usize::from(d2[k] < best.dist2);
            }
        }
        self.solve_leaves(p, &mut found[..n_found], &mut best, &mut iters, solved);
        best.iters = iters;
        best
    }

    /// Runs the leaf Newton searches for the collected `leaves` (bound, index), nearest
    /// bound first, while a bound is below the best distance.
    fn solve_leaves(
        &self,
        p: DVec3,
        leaves: &mut [(f64, u32)],
        best: &mut Candidate,
        iters: &mut u32,
        solved: &mut Visited,
    ) {
        leaves.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for &(bound, index) in leaves.iter() {
            if bound >= best.dist2 {
                break;
            }
            if best.converged {
                // A leaf that holds a stationary answer (the seed's, or one on a shared
                // side) would only find it again: the certificate decides the leaf.
                if !best.on_leaf_edge && self.holds(&self.leaves[index as usize], best.uv) {
                    continue;
                }
                // Most leaves left are neighbours of the answer's leaf with nothing
                // closer in them: the distance net proves that with one dot product per
                // coefficient, more cheaply than their Newton runs.
                if self.net_clears(p, index as usize, best.dist2) {
                    solved.record(index as usize, Reached::Cleared);
                    continue;
                }
            }
            let before = best.dist2;
            if let Some(uv) = self.solve_leaf(p, index as usize, best, iters, true) {
                solved.record(index as usize, Reached::Minimum(uv));
            }
            // The leaf's run stopped on its edge: the minimum lies beyond, usually in the
            // next leaf. Newton on the whole domain goes on from there, more cheaply
            // than that leaf's own run from its bilinear start; the leaf is then left
            // to the certificate, as it holds the answer.
            if best.on_leaf_edge && best.dist2 < before {
                let c = self.newton(p, best.uv, self.domain_lo, self.domain_hi, self.closed);
                *iters += c.iters;
                if c.dist2 < best.dist2 {
                    *best = c;
                }
            }
        }
    }

    /// True when the leaf's distance net has no coefficient below its threshold: no
    /// point of the leaf is closer to `p` than `sqrt(f_star) - CERTIFY_TOL`.
    fn net_clears(&self, p: DVec3, index: usize, f_star: f64) -> bool {
        let Some(nets) = &self.nets else {
            return false;
        };
        let (low, threshold) = nets.query_min(index, p, f_star, CERTIFY_TOL);
        low >= threshold
    }

    /// The Newton runs of one leaf: its interior (when the exclusion test allows a
    /// stationary point there), and each side on a domain edge that could be closer than
    /// `best`. With `prune` false, every run is made (the reference the tests compare
    /// the pruned search with).
    fn solve_leaf(
        &self,
        p: DVec3,
        index: usize,
        best: &mut Candidate,
        iters: &mut u32,
        prune: bool,
    ) -> Option<DVec2> {
        let leaf = &self.leaves[index];
        let p_local = to_frame(&leaf.frame, p);
        let (r_lo, r_hi) = (leaf.obb.0 - p_local, leaf.obb.1 - p_local);
        let fixed_u = prune && sign_is_fixed(r_lo, r_hi, leaf.du);
        let fixed_v = prune && sign_is_fixed(r_lo, r_hi, leaf.dv);
        let mut interior_uv = None;
        let start = leaf.estimate(p);
        let ran_interior = !fixed_u && !fixed_v;
        if ran_interior {
            let c = self.newton(p, start, leaf.uv_lo, leaf.uv_hi, [false; 2]);
            *iters += c.iters;
            if c.converged {
                interior_uv = Some(c.uv);
            }
            let on_domain_edge = |uv: DVec2| {
                (0..2).any(|k| {
                    !self.closed[k] && (uv[k] <= self.domain_lo[k] || uv[k] >= self.domain_hi[k])
                })
            };
            let slid_along_edge = on_domain_edge(start) && on_domain_edge(c.uv);
            if c.dist2 < best.dist2 {
                *best = c;
            }
            // A start on a domain edge can stay on the edge, at a minimum of the edge, and
            // miss an interior minimum of the same leaf (both are local minima of the
            // domain): run again from the leaf's centre. With the certificate's nets
            // there is no need: it proves the leaf holds nothing closer, or finds it.
            if slid_along_edge && !(prune && self.nets.is_some()) {
                let centre = (leaf.uv_lo + leaf.uv_hi) * 0.5;
                let c = self.newton(p, centre, leaf.uv_lo, leaf.uv_hi, [false; 2]);
                *iters += c.iters;
                if c.dist2 < best.dist2 {
                    *best = c;
                }
            }
        }
        // Leaves on an edge of the domain also search that edge by itself: a minimum on
        // the boundary curve is then found even when the leaf's interior holds another
        // local minimum.
        for (side, (k, at_hi)) in [(0, false), (0, true), (1, false), (1, true)]
            .into_iter()
            .enumerate()
        {
            // Along a side u = const only v moves, so f_v must vanish there.
            let fixed = if k == 0 { fixed_v } else { fixed_u };
            if fixed || !self.edge_leaf(leaf, k, at_hi) {
                continue;
            }
            // No point of this side is closer than the best answer so far.
            let (side_lo, side_hi) = self.sides[index][side];
            if prune && box_dist2(p_local, side_lo, side_hi) >= best.dist2 {
                continue;
            }
            // The interior run already converged onto this very edge.
            let edge_value = if at_hi { leaf.uv_hi[k] } else { leaf.uv_lo[k] };
            if prune && interior_uv.is_some_and(|uv| uv[k] == edge_value) {
                continue;
            }
            // The interior run found the leaf's minimum, unless the leaf holds two; the
            // certificate's nets then find the other one.
            if prune && ran_interior && self.nets.is_some() {
                continue;
            }
            let (mut lo, mut hi) = (leaf.uv_lo, leaf.uv_hi);
            if at_hi {
                lo[k] = hi[k];
            } else {
                hi[k] = lo[k];
            }
            let c = self.newton(p, start, lo, hi, [false; 2]);
            *iters += c.iters;
            if c.dist2 < best.dist2 {
                *best = c;
            }
        }
        interior_uv
    }

    /// The closest point with no pruning at all: the domain corners, then every leaf's
    /// interior and domain-edge sides from its bilinear start, then the polish. Slow; the
    /// reference that proves the bounds of [`Self::search`] skip nothing.
    #[cfg(test)]
    fn closest_point_exhaustive(&self, p: DVec3) -> Projection {
        let mut best = self.best_corner(p, None);
        let mut iters = 0;
        let mut solved = Visited::new();
        solved.overflow = true;
        for index in 0..self.leaves.len() {
            if let Some(uv) = self.solve_leaf(p, index, &mut best, &mut iters, false) {
                solved.record(index, Reached::Minimum(uv));
            }
        }
        best.iters = iters;
        self.finish(p, best, &solved)
    }

    /// True when the leaf's side `at_hi` in direction `k` lies on a domain edge that is
    /// not a seam.
    #[inline]
    fn edge_leaf(&self, leaf: &Leaf, k: usize, at_hi: bool) -> bool {
        !self.closed[k]
            && if at_hi {
                leaf.uv_hi[k] >= self.domain_hi[k]
            } else {
                leaf.uv_lo[k] <= self.domain_lo[k]
            }
    }

    /// Bounded Newton with an active set (see the module docs).
    #[inline]
    fn newton(&self, p: DVec3, start: DVec2, lo: DVec2, hi: DVec2, wrap: [bool; 2]) -> Candidate {
        // Leaf runs never wrap: their copy has no wrap-around code at all.
        if wrap == [false; 2] {
            self.bounded_newton::<false>(p, start, lo, hi, wrap)
        } else {
            self.bounded_newton::<true>(p, start, lo, hi, wrap)
        }
    }

    /// [`Self::newton`], with `WRAP` false when no direction wraps.
    fn bounded_newton<const WRAP: bool>(
        &self,
        p: DVec3,
        start: DVec2,
        lo: DVec2,
        hi: DVec2,
        wrap: [bool; 2],
    ) -> Candidate {
        let wrap = if WRAP { wrap } else { [false; 2] };
        let mut uv = start.clamp(lo, hi);
        let mut d = self.derivs(uv);
        let mut r = d.point - p;
        let mut f = r.length_squared();
        let mut iters = 0;
        let mut converged = false;
        // Squared forms of the tests, so the loop takes no square roots.
        const POINT_EPS2: f64 = POINT_EPS * POINT_EPS;
        const RESIDUAL_EPS2: f64 = crate::tolerance::RESIDUAL_EPS * crate::tolerance::RESIDUAL_EPS;
        // Rounding scale of f (see `noise` below).
        let p_scale = p.abs().max_element();
        loop {
            if f <= POINT_EPS2 {
                converged = true;
                break;
            }
            let g = DVec2::new(d.du.dot(r), d.dv.dot(r));
            let mut free = [true; 2];
            for k in 0..2 {
                if !wrap[k] && ((uv[k] <= lo[k] && g[k] > 0.0) || (uv[k] >= hi[k] && g[k] < 0.0)) {
                    free[k] = false;
                }
            }
            let lens2 = [d.du.length_squared(), d.dv.length_squared()];
            // Zero cosine, |g_k| <= tol |S_k| |S - P|, or a tangential residual
            // |g_k| / |S_k| below POINT_EPS / 1000 (when |S - P| is small the cosine
            // cannot be resolved further, but the point is exact).
            let cos_small = move |k: usize, tol: f64| {
                let g2 = g[k] * g[k];
                g2 <= tol * tol * lens2[k] * f || g2 <= RESIDUAL_EPS2 * lens2[k]
            };
            if (0..2).all(|k| !free[k] || cos_small(k, COSINE_EPS)) {
                converged = true;
                break;
            }
            if iters >= MAX_ITERS {
                break;
            }
            iters += 1;
            let h00 = lens2[0] + d.duu.dot(r);
            let h01 = d.du.dot(d.dv) + d.duv.dot(r);
            let h11 = lens2[1] + d.dvv.dot(r);
            let newton = match free {
                [true, true] => newton_step_2(h00, h01, h11, g),
                [true, false] => DVec2::new(newton_step_1(h00, lens2[0], g.x), 0.0),
                [false, true] => DVec2::new(0.0, newton_step_1(h11, lens2[1], g.y)),
                [false, false] => DVec2::ZERO,
            };
            let project = |c: DVec2| {
                let mut c = c;
                for k in 0..2 {
                    c[k] = if wrap[k] {
                        lo[k] + (c[k] - lo[k]).rem_euclid(hi[k] - lo[k])
                    } else {
                        c[k].clamp(lo[k], hi[k])
                    };
                }
                c
            };
            // Rounding noise of f: r = S - P loses the digits of |S| and |P|.
            let noise = 8.0 * f64::EPSILON * f.sqrt() * (p_scale + d.point.abs().max_element());
            let mut accepted = false;
            for attempt in 0..2 {
                let step = if attempt == 0 {
                    // Skip a projected Newton step that does not descend (it can turn
                    // uphill where a bound cuts it).
                    if !wrap[0] && !wrap[1] && g.dot(project(uv + newton) - uv) >= 0.0 {
                        continue;
                    }
                    newton
                } else {
                    // The fallback: the gradient scaled by the Hessian diagonal.
                    let scaled = |k: usize, h: f64, jtj: f64| {
                        let den = h.max(jtj);
                        if free[k] && den > 0.0 {
                            -g[k] / den
                        } else {
                            0.0
                        }
                    };
                    DVec2::new(scaled(0, h00, lens2[0]), scaled(1, h11, lens2[1]))
                };
                let mut t = 1.0;
                for _ in 0..MAX_HALVINGS {
                    let cand = project(uv + step * t);
                    if cand == uv {
                        break;
                    }
                    let dc = self.derivs(cand);
                    let rc = dc.point - p;
                    let fc = rc.length_squared();
                    // Accept descent, and changes within rounding noise of f (near the
                    // minimum f stops resolving the last digits while g still improves).
                    if fc <= f + noise {
                        let moved2 = (dc.point - d.point).length_squared();
                        uv = cand;
                        d = dc;
                        r = rc;
                        f = fc;
                        accepted = true;
                        if moved2 <= POINT_EPS2 && t == 1.0 && attempt == 0 {
                            converged = true;
                        }
                        break;
                    }
                    t *= 0.5;
                }
                if accepted {
                    break;
                }
            }
            if converged {
                break;
            }
            if !accepted {
                // No descent left: a numerical minimum. Accept it if the cosines are
                // small to a looser tolerance.
                converged =
                    (0..2).all(|k| !free[k] || cos_small(k, crate::tolerance::LOOSE_COSINE_EPS));
                break;
            }
        }
        let on_leaf_edge = (0..2).any(|k| {
            !wrap[k]
                && ((uv[k] <= lo[k] && lo[k] > self.domain_lo[k])
                    || (uv[k] >= hi[k] && hi[k] < self.domain_hi[k]))
        });
        Candidate {
            uv,
            point: d.point,
            dist2: f,
            iters,
            converged,
            on_leaf_edge,
        }
    }
}

/// The 2x2 Newton step `-H^{-1} g`, with `H` shifted to positive definite if needed.
#[inline]
fn newton_step_2(h00: f64, h01: f64, h11: f64, g: DVec2) -> DVec2 {
    let tr = h00 + h11;
    let det = h00 * h11 - h01 * h01;
    // Clearly positive definite (`lmin / lmax > 1e-12`, as `det = lmin lmax` and
    // `tr = lmin + lmax`): no eigenvalues needed.
    if h00 > 0.0 && det > crate::tolerance::POS_DEF_REL * tr * tr && det.is_finite() {
        return DVec2::new(
            -(h11 * g.x - h01 * g.y) / det,
            -(h00 * g.y - h01 * g.x) / det,
        );
    }
    let disc = ((h00 - h11) * (h00 - h11) + 4.0 * h01 * h01).sqrt();
    let lmin = 0.5 * (tr - disc);
    let lmax = 0.5 * (tr + disc);
    let mut shift = 0.0;
    if lmin.is_nan() || lmin <= crate::tolerance::SINGULAR_REL * lmax.abs() {
        shift = -lmin
            + crate::tolerance::HESSIAN_SHIFT_REL * lmax.abs().max(crate::tolerance::DIVISOR_MIN);
    }
    let (a, b, c) = (h00 + shift, h01, h11 + shift);
    let det = a * c - b * b;
    if det.is_nan() || det <= 0.0 || !det.is_finite() {
        return DVec2::ZERO;
    }
    DVec2::new(-(c * g.x - b * g.y) / det, -(a * g.y - b * g.x) / det)
}

/// The 1D Newton step `-g / h`, falling back to Gauss-Newton when `h <= 0`.
#[inline]
fn newton_step_1(h: f64, jtj: f64, g: f64) -> f64 {
    let den = if h > crate::tolerance::SINGULAR_REL * jtj {
        h
    } else {
        jtj.max(h.abs())
    };
    if den > 0.0 && den.is_finite() {
        -g / den
    } else {
        0.0
    }
}

/// The answer to a closest-point query on a curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveProjection {
    /// The parameter `u` of the closest point.
    pub u: f64,
    /// `C(u)`.
    pub point: DVec3,
    /// `|C(u) - P|`.
    pub distance: f64,
    /// Newton iterations spent.
    pub iterations: u32,
    /// True when the final run stopped by P&T's criteria.
    pub converged: bool,
}

impl super::curve::NurbsCurve {
    /// The closest point of the curve to `p` (point inversion, P&T eq. 6.3):
    /// Newton on `f(u) = C'(u) . (C(u) - P) = 0` with the update
    /// `u <- u - f / (C'' . (C - P) + |C'|^2)`, bounded and line-searched, run in every
    /// sub-segment whose control-polygon box could hold a closer point than the best so
    /// far (Bezier segments by refinement, each split in four); both ends are
    /// candidates too. Non-finite `p` gives `distance = f64::INFINITY`.
    pub fn closest_point(&self, p: DVec3) -> CurveProjection {
        let (a, b) = self.domain();
        let mut best = CurveProjection {
            u: a,
            point: self.point(a),
            distance: f64::INFINITY,
            iterations: 0,
            converged: false,
        };
        if !p.is_finite() {
            return best;
        }
        for u in [a, b] {
            let q = self.point(u);
            if q.distance(p) < best.distance {
                best = CurveProjection {
                    u,
                    point: q,
                    distance: q.distance(p),
                    iterations: 0,
                    converged: true,
                };
            }
        }
        let pieces: Vec<(f64, f64, DVec3, DVec3)> = match self.bezier_pieces(4) {
            Some(v) => v,
            None => {
                let (lo, hi) = self.homogeneous().iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), q| (lo.min(q.truncate() / q.w), hi.max(q.truncate() / q.w)),
                );
                vec![(a, b, lo, hi)]
            }
        };
        let mut order: Vec<(f64, usize)> = pieces
            .iter()
            .enumerate()
            .map(|(k, pc)| (box_dist2(p, pc.2, pc.3), k))
            .collect();
        order.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut iters = 0;
        for (lb, k) in order {
            if lb >= best.distance * best.distance {
                break;
            }
            let (lo, hi, _, _) = pieces[k];
            let c = self.newton_1d(p, 0.5 * (lo + hi), lo, hi);
            iters += c.iterations;
            if c.distance < best.distance {
                best = c;
            }
        }
        // Polish on the whole domain.
        let c = self.newton_1d(p, best.u, a, b);
        if c.distance <= best.distance * (1.0 + crate::tolerance::REL_EPS) {
            best = c;
        }
        best.iterations += iters;
        best
    }

    /// Sub-segments `(u0, u1, box_lo, box_hi)`: each Bezier segment split in `split`.
    fn bezier_pieces(&self, split: usize) -> Option<Vec<(f64, f64, DVec3, DVec3)>> {
        let kv = self.knots();
        let x = NurbsSurface::bezier_insertions(kv);
        let (k, pw) = super::refine::refine_pw(kv, self.homogeneous(), &x).ok()?;
        let p = self.degree();
        let mut out = Vec::new();
        for s in p..pw.len() {
            if k[s] >= k[s + 1] {
                continue;
            }
            let seg = &pw[s - p..=s];
            for (t, piece) in split_uniform(seg, split).iter().enumerate() {
                let (lo, hi) = piece.iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), q| (lo.min(q.truncate() / q.w), hi.max(q.truncate() / q.w)),
                );
                let at = |i: usize| k[s] + (k[s + 1] - k[s]) * i as f64 / split as f64;
                let u1 = if t + 1 == split { k[s + 1] } else { at(t + 1) };
                out.push((at(t), u1, lo, hi));
            }
        }
        Some(out)
    }

    /// Bounded 1D Newton for eq. 6.3 with a halving line search on `|C - P|^2`.
    fn newton_1d(&self, p: DVec3, start: f64, lo: f64, hi: f64) -> CurveProjection {
        let mut u = start.clamp(lo, hi);
        let mut d = self.derivatives(u);
        let mut r = d.point - p;
        let mut f = r.length_squared();
        let mut iters = 0;
        let mut converged = false;
        while iters < MAX_ITERS {
            let g = d.d1.dot(r);
            let rl = f.sqrt();
            let l1 = d.d1.length();
            let active = (u <= lo && g > 0.0) || (u >= hi && g < 0.0);
            if rl <= POINT_EPS
                || active
                || g.abs() <= COSINE_EPS * l1 * rl
                || g.abs() <= crate::tolerance::RESIDUAL_EPS * l1
            {
                converged = true;
                break;
            }
            iters += 1;
            let h = d.d2.dot(r) + l1 * l1;
            let step = if h > crate::tolerance::SINGULAR_REL * l1 * l1 {
                -g / h
            } else {
                -g / (l1 * l1).max(crate::tolerance::DIVISOR_MIN)
            };
            let noise =
                8.0 * f64::EPSILON * rl * (p.abs().max_element() + d.point.abs().max_element());
            let mut t = 1.0;
            let mut accepted = false;
            for _ in 0..MAX_HALVINGS {
                let c = (u + step * t).clamp(lo, hi);
                if c == u {
                    break;
                }
                let dc = self.derivatives(c);
                let rc = dc.point - p;
                if rc.length_squared() <= f + noise {
                    let moved = dc.point.distance(d.point);
                    (u, d, r, f) = (c, dc, rc, rc.length_squared());
                    accepted = true;
                    converged = moved <= POINT_EPS && t == 1.0;
                    break;
                }
                t *= 0.5;
            }
            if converged || !accepted {
                break;
            }
        }
        CurveProjection {
            u,
            point: d.point,
            distance: f.sqrt(),
            iterations: iters,
            converged,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nurbs::NurbsSurface;
    use crate::tolerance::{EXACT_EPS, FIT_EPS, INVERSION_EPS, POINT_EPS, within};

    /// SplitMix64, so the stress test needs no extra crates.
    struct Rng(u64);
    impl Rng {
        fn unit(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn in_range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.unit()
        }
    }

    /// A wavy patch of degree 2 or 3 with random interior knots, random heights, and
    /// random weights when `rational`.
    fn wavy(rng: &mut Rng, rational: bool) -> NurbsSurface {
        let degree = |rng: &mut Rng| if rng.unit() < 0.5 { 2 } else { 3 };
        let (p, q) = (degree(rng), degree(rng));
        let count = |rng: &mut Rng, d: usize| d + 1 + (rng.unit() * 5.0) as usize;
        let (nu, nv) = (count(rng, p), count(rng, q));
        let knots = |rng: &mut Rng, d: usize, n: usize| {
            let mut inner: Vec<f64> = (0..n - d - 1).map(|_| rng.in_range(0.05, 0.95)).collect();
            inner.sort_by(f64::total_cmp);
            let mut k = vec![0.0; d + 1];
            k.extend(inner);
            k.extend(vec![1.0; d + 1]);
            k
        };
        let (ku, kv) = (knots(rng, p, nu), knots(rng, q, nv));
        let net = (0..nu)
            .map(|i| {
                (0..nv)
                    .map(|j| {
                        let jitter =
                            DVec3::new(rng.in_range(-0.05, 0.05), rng.in_range(-0.05, 0.05), 0.0);
                        DVec3::new(
                            i as f64 / (nu - 1) as f64,
                            j as f64 / (nv - 1) as f64,
                            rng.in_range(-0.4, 0.4),
                        ) + jitter
                    })
                    .collect()
            })
            .collect();
        let weights = rational.then(|| {
            (0..nu)
                .map(|_| (0..nv).map(|_| rng.in_range(0.4, 2.5)).collect())
                .collect()
        });
        NurbsSurface::new(p, q, ku, kv, net, weights).expect("valid surface")
    }

    /// Query points where pruning is riskiest: just off the surface at leaf borders and
    /// corners (several leaves tie on their bounds), just outside the domain edges and
    /// corners (edge runs, side boxes), anywhere around the patch, and far away.
    fn hard_query(rng: &mut Rng, s: &NurbsSurface, inv: &SurfaceInverter) -> DVec3 {
        let leaf = &inv.leaves[(rng.unit() * inv.leaves.len() as f64) as usize];
        let pick = |rng: &mut Rng, k: usize| match (rng.unit() * 3.0) as u32 {
            0 => leaf.uv_lo[k],
            1 => leaf.uv_hi[k],
            _ => rng.in_range(leaf.uv_lo[k], leaf.uv_hi[k]),
        };
        let uv = DVec2::new(pick(rng, 0), pick(rng, 1))
            + DVec2::new(rng.in_range(-1e-7, 1e-7), rng.in_range(-1e-7, 1e-7)); // not a tolerance: a random perturbation of the query
        let uv = s.clamp_uv(uv);
        let d = s.derivatives(uv.x, uv.y);
        let n = s.normal(uv.x, uv.y);
        match (rng.unit() * 5.0) as u32 {
            0 => d.point + n * rng.in_range(-1e-6, 1e-6), // not a tolerance: a random offset of the query
            1 => d.point + n * rng.in_range(-0.3, 0.3),
            2 => {
                // Beyond the domain edge the point lies on, or beside it.
                let out = DVec2::new(
                    if uv.x <= 0.0 {
                        -1.0
                    } else if uv.x >= 1.0 {
                        1.0
                    } else {
                        0.0
                    },
                    if uv.y <= 0.0 {
                        -1.0
                    } else if uv.y >= 1.0 {
                        1.0
                    } else {
                        0.0
                    },
                );
                let tangent = d.du.normalize_or_zero() * out.x + d.dv.normalize_or_zero() * out.y;
                d.point + tangent * rng.in_range(0.0, 0.3) + n * rng.in_range(-0.2, 0.2)
            }
            3 => DVec3::new(
                rng.in_range(-0.6, 1.6),
                rng.in_range(-0.6, 1.6),
                rng.in_range(-0.8, 0.8),
            ),
            _ => {
                let dir = DVec3::new(
                    rng.in_range(-1.0, 1.0),
                    rng.in_range(-1.0, 1.0),
                    rng.in_range(-1.0, 1.0),
                );
                DVec3::splat(0.5) + dir.normalize_or(DVec3::Z) * rng.in_range(3.0, 300.0)
            }
        }
    }

    /// Regression for the pruned search (leaf-corner bounds, nearest-bound-first order
    /// with its early stop, side boxes that skip edge runs) and for seeded queries: on
    /// 9,600 hard queries neither may ever be farther than the unpruned reference that
    /// runs Newton in every leaf and along every domain edge. (An earlier attempt to skip
    /// the sub-patch holding the seed failed once in 9,600 such queries.)
    /// The piecewise bilinear surface through a grid, with uniform clamped knots.
    fn degree_one(pts: Vec<Vec<DVec3>>) -> NurbsSurface {
        let knots = |n: usize| {
            let mut k = vec![0.0];
            k.extend((0..n).map(|i| i as f64 / (n - 1) as f64));
            k.push(1.0);
            k
        };
        let (nu, nv) = (pts.len(), pts[0].len());
        NurbsSurface::new(1, 1, knots(nu), knots(nv), pts, None).expect("valid grid")
    }

    /// Regression: a surface with more Bezier patches than `MAX_LEAVES` hung the build
    /// (the leaf size kept doubling while every patch was already one leaf).
    #[test]
    fn more_patches_than_the_leaf_cap_build_and_invert() {
        let n = 130; // 129 x 129 = 16,641 bilinear patches
        let pts: Vec<Vec<DVec3>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                        DVec3::new(x, y, 0.05 * (9.0 * x).sin() * (7.0 * y).cos())
                    })
                    .collect()
            })
            .collect();
        let s = degree_one(pts);
        let inv = s.inverter();
        assert!(inv.leaf_count() > MAX_LEAVES);
        for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.93, 0.71)] {
            let on = s.point(u, v);
            let pr = inv.closest_point(on + DVec3::Z * 0.001);
            assert!(pr.distance <= 0.001 + EXACT_EPS, "{pr:?}");
        }
    }

    /// The walks' fixed stacks hold one entry per tree level plus one: the deepest
    /// trees (a long strip, and a grid at the leaf cap) must fit, or a dropped push would
    /// skip part of the surface.
    #[test]
    fn the_deepest_trees_fit_the_walk_stacks() {
        fn depth(inv: &SurfaceInverter, entry: u32) -> usize {
            if entry & LEAF != 0 {
                return 0;
            }
            let node = inv.nodes[entry as usize];
            1 + depth(inv, node.child[0]).max(depth(inv, node.child[1]))
        }
        for (nu, nv) in [(2000, 2), (130, 130)] {
            let pts: Vec<Vec<DVec3>> = (0..nu)
                .map(|i| {
                    (0..nv)
                        .map(|j| DVec3::new(i as f64, j as f64, ((i * j) % 3) as f64))
                        .collect()
                })
                .collect();
            let inv = degree_one(pts).inverter();
            let d = depth(&inv, inv.root);
            // A balanced bisection: at most two levels over log2 of the leaf count.
            let balanced = inv.leaf_count().next_power_of_two().ilog2() as usize + 2;
            assert!(d <= balanced, "depth {d}, {} leaves", inv.leaf_count());
            assert!(d < STACK_LEN, "depth {d}");
        }
    }

    /// Each answer says how it was obtained: proven on an ordinary patch, and the exit
    /// by name where the certificate cannot run (degree 6 has no nets) or was not asked
    /// for (local Newton, a non-finite query).
    #[test]
    fn answers_name_their_certificate() {
        let mut rng = Rng(0x5EED_0014);
        let s = wavy(&mut rng, true);
        let inv = s.inverter();
        let p = DVec3::new(0.4, 0.6, 0.3);
        assert_eq!(inv.closest_point(p).certificate, Certificate::Certified);
        let seeded = inv.closest_point_from(p, DVec2::new(0.9, 0.1));
        assert_eq!(seeded.certificate, Certificate::Certified);
        let local = inv.newton_from(p, DVec2::new(0.9, 0.1));
        assert_eq!(local.certificate, Certificate::Local);
        // The surface's own Newton, without the hierarchy, lands on the same point
        // (the built inverter evaluates through its power form: last bits differ).
        let own = s.newton_closest(p, DVec2::new(0.9, 0.1));
        assert_eq!(own.certificate, Certificate::Local);
        assert!(own.uv.distance(local.uv) < FIT_EPS, "{own:?} {local:?}");
        assert!((own.distance - local.distance).abs() < FIT_EPS);
        let bad = inv.closest_point(DVec3::new(f64::NAN, 0.0, 0.0));
        assert_eq!(bad.certificate, Certificate::InvalidQuery);
        // Degree 6 along u: nets of side 13 exceed MAX_SIDE.
        let row = |x: f64| vec![DVec3::new(x, 0.0, 0.0), DVec3::new(x, 1.0, 0.1)];
        let net: Vec<Vec<DVec3>> = (0..7).map(|i| row(i as f64 / 6.0)).collect();
        let mut ku = vec![0.0; 7];
        ku.extend([1.0; 7]);
        let sextic = NurbsSurface::new(6, 1, ku, vec![0.0, 0.0, 1.0, 1.0], net, None)
            .expect("valid surface");
        let pr = sextic.inverter().closest_point(p);
        assert_eq!(pr.certificate, Certificate::DegreeAboveFive);
        assert!(pr.converged);
    }

    #[test]
    fn pruned_search_never_loses_to_the_exhaustive_reference() {
        let mut rng = Rng(0x5EED_2026);
        let mut checked = 0;
        for k in 0..40 {
            let s = wavy(&mut rng, k % 2 == 1);
            let inv = s.inverter();
            for _ in 0..240 {
                let p = hard_query(&mut rng, &s, &inv);
                let reference = inv.closest_point_exhaustive(p);
                let got = inv.closest_point(p);
                assert!(
                    within(got.distance - reference.distance, POINT_EPS),
                    "surface {k}, p = {p:?}: pruned {got:?} vs exhaustive {reference:?}"
                );
                assert!(got.converged, "surface {k}, p = {p:?}: {got:?}");
                let seed = DVec2::new(rng.unit(), rng.unit());
                let seeded = inv.closest_point_from(p, seed);
                assert!(
                    within(seeded.distance - reference.distance, POINT_EPS),
                    "surface {k}, p = {p:?}, seed {seed:?}: {seeded:?} vs {reference:?}"
                );
                // Seeded from the answer itself (a stroke that stands still).
                let again = inv.closest_point_from(p, got.uv);
                assert!(within(again.distance - reference.distance, POINT_EPS));
                checked += 1;
            }
        }
        assert_eq!(checked, 9_600);
    }

    /// The certificate on its own: started from the farther of two local minima in one
    /// sub-patch (the answer a single Newton run gave before the certificate existed),
    /// it must find the closer one. Surfaces and queries from the brute-force stress
    /// (`tests/nurbs_inversion.rs`, seeds `0x5EED_7777` and `0x5EED_8888`).
    #[test]
    fn the_certificate_finds_the_closer_of_two_minima_in_one_sub_patch() {
        let cases = [
            (
                include_str!("../../tests/data/two-minima-7777.json"),
                DVec3::new(0.14254816814439428, 0.7308498353856546, -0.405004002983505),
                DVec2::new(0.029900237998824058, 0.6363834357135493),
                0.18909275928916175,
            ),
            (
                include_str!("../../tests/data/two-minima-8888.json"),
                DVec3::new(0.5125582972693886, 0.530029542421877, 0.006136924500610902),
                DVec2::new(0.41903973422145674, 0.26001628760683676),
                0.0938234741809953,
            ),
        ];
        for (json, p, wrong_uv, brute_force) in cases {
            let s = NurbsSurface::from_json(json).expect("valid surface");
            let inv = s.inverter();
            let wrong = inv.newton(p, wrong_uv, inv.domain_lo, inv.domain_hi, inv.closed);
            assert!(wrong.converged && wrong.dist2.sqrt() > brute_force + INVERSION_EPS);
            let mut visited = Visited::new();
            visited.overflow = true;
            let (fixed, _) = inv.certify(p, wrong, &visited);
            assert!(
                fixed.dist2.sqrt() <= brute_force + POINT_EPS,
                "{} vs brute force {brute_force}",
                fixed.dist2.sqrt()
            );
        }
    }
}
