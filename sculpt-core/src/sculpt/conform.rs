//! Conforming tessellation of a patch network: the patches of a reconstructed scan
//! (`reconstruct::network`) meshed as one watertight, consistently oriented surface.
//!
//! **The network.** Patches that share a side hold the same boundary control points
//! along it (the fit makes every boundary control point one unknown, so the two copies
//! are the same bits, and they survive the document's JSON). [`Network::of`] finds the
//! shared sides from that alone: the control row of each side of the unit square (its
//! points and weights, bit for bit), in either direction, held by exactly two sides of
//! two different patches, on clamped knots (so the row is the boundary curve) that
//! agree along the side. No distance tolerance decides what is shared.
//!
//! **Sampling.** Each patch gets a uniform `n x n` grid of flat cells whose chord error
//! (measured as [`GridPlan`](super::tessellate::GridPlan) does, [`chord_errors`]) is
//! within the detail's tolerance relative to the whole object's size (the bounding-box
//! diagonal of all the patches, [`Detail::tolerance`]): a small patch on a large object
//! needs few triangles ([`NetworkPlan`]). A shared side takes the larger of its two
//! patches' counts and is sampled once, from its first holder (the canonical side):
//! both patches put the same 3D points (same bits) at the same parameters along it. A
//! side's ends are the corner control points themselves (a clamped surface interpolates
//! them), which every patch meeting at that corner holds bit for bit, so the corners
//! weld too. Where a patch's sides have its own count the patch is a regular grid;
//! otherwise its boundary samples and inner grid points are triangulated by Delaunay in
//! the patch's unit square (convex, so its hull is the square's four sides with every
//! boundary sample on it). Triangles run counter-clockwise in `uv`, so `du x dv` is
//! their normal; a network whose neighbours run each shared side in opposite
//! directions (the reconstruction orients them so) is a consistently oriented surface.
//! Shared vertices carry the mean of the normals of the patches that meet there.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use spade::{DelaunayTriangulation, Point2, Triangulation};

use super::surface::{ParamSurface, extent_sampled, normal_from};
use super::tessellate::{Detail, GRID_MARGIN, MAX_GRID, SideVertex, chord_errors};
use crate::mesh::{MeshSink, MeshVertex, PatchKey};
use crate::nurbs::NurbsSurface;
use crate::tolerance::{CONFORM_KNOT_EPS, FIXED_SIDE_SNAP};

/// Where a patch side lies in the network: the shared side's id and whether the patch
/// runs it against the canonical direction (its first holder's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SideLink {
    /// Index into [`Network::sides`].
    pub side: usize,
    /// True when this patch's parameter along the side runs the other way.
    pub reversed: bool,
}

/// The shared sides of a set of patches (see the module documentation).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Network {
    /// Per patch, its four sides (0 `u = 0`, 1 `u = 1`, 2 `v = 0`, 3 `v = 1`, as in
    /// the tessellator): the shared side each lies on, if any.
    pub links: Vec<[Option<SideLink>; 4]>,
    /// Per shared side, its two holders `(patch, side)`, the canonical one first.
    pub sides: Vec<[(usize, usize); 2]>,
}

/// The boundary control row of side `k` (0 `u = 0`, 1 `u = 1`, 2 `v = 0`, 3 `v = 1`)
/// as bits (x, y, z, weight per point), the side's degree and its knots along the side
/// normalised to `[0, 1]`; `None` when the knots across the side are not clamped (the
/// row is then not the boundary curve).
fn side_row(s: &NurbsSurface, k: usize) -> Option<(Vec<[u64; 4]>, usize, Vec<f64>)> {
    let (across, along) = if k < 2 {
        (s.knots_u(), s.knots_v())
    } else {
        (s.knots_v(), s.knots_u())
    };
    if !across.is_clamped() {
        return None;
    }
    let (cu, cv) = (s.count_u(), s.count_v());
    let at = |t: usize| match k {
        0 => (0, t),
        1 => (cu - 1, t),
        2 => (t, 0),
        _ => (t, cv - 1),
    };
    let count = if k < 2 { cv } else { cu };
    let row = (0..count)
        .map(|t| {
            let (i, j) = at(t);
            let p = s.control_point(i, j);
            [p.x, p.y, p.z, s.weight(i, j)].map(f64::to_bits)
        })
        .collect();
    let (a, b) = along.domain();
    let knots = along
        .knots()
        .iter()
        .map(|x| (x - a) / (b - a))
        .collect::<Vec<_>>();
    Some((row, along.degree(), knots))
}

impl Network {
    /// The shared sides of `surfaces`: each side's control row, held bit for bit (in
    /// either direction) by exactly two sides of two different patches whose knots
    /// along it agree. A row that reads the same both ways (a side collapsed to a
    /// point) is never shared.
    pub fn of(surfaces: &[&NurbsSurface]) -> Self {
        type Holder = (usize, usize, bool, Vec<f64>);
        let mut by_row: HashMap<(Vec<[u64; 4]>, usize), Vec<Holder>> = HashMap::new();
        for (p, s) in surfaces.iter().enumerate() {
            for k in 0..4 {
                let Some((row, degree, knots)) = side_row(s, k) else {
                    continue;
                };
                let back: Vec<[u64; 4]> = row.iter().rev().copied().collect();
                if back == row {
                    continue;
                }
                let (key, reversed) = if row <= back {
                    (row, false)
                } else {
                    (back, true)
                };
                let knots = if reversed {
                    knots.iter().rev().map(|x| 1.0 - x).collect()
                } else {
                    knots
                };
                by_row
                    .entry((key, degree))
                    .or_default()
                    .push((p, k, reversed, knots));
            }
        }
        let mut pairs: Vec<[Holder; 2]> = by_row
            .into_values()
            .filter_map(|v| <[Holder; 2]>::try_from(v).ok())
            .filter(|[a, b]| {
                a.0 != b.0
                    && a.3.len() == b.3.len()
                    && a.3
                        .iter()
                        .zip(&b.3)
                        .all(|(x, y)| (x - y).abs() <= CONFORM_KNOT_EPS)
            })
            .map(|mut pair| {
                pair.sort_by_key(|h| (h.0, h.1));
                pair
            })
            .collect();
        pairs.sort_by_key(|[a, _]| (a.0, a.1));
        let mut links = vec![[None; 4]; surfaces.len()];
        let mut sides = Vec::with_capacity(pairs.len());
        for (id, [a, b]) in pairs.into_iter().enumerate() {
            links[a.0][a.1] = Some(SideLink {
                side: id,
                reversed: false,
            });
            links[b.0][b.1] = Some(SideLink {
                side: id,
                reversed: a.2 != b.2,
            });
            sides.push([(a.0, a.1), (b.0, b.1)]);
        }
        Self { links, sides }
    }

    /// True when no side is shared: the patches are separate surfaces.
    pub fn is_empty(&self) -> bool {
        self.sides.is_empty()
    }

    /// True when patch `p` shares at least one side.
    pub fn holds(&self, p: usize) -> bool {
        self.links
            .get(p)
            .is_some_and(|l| l.iter().any(Option::is_some))
    }
}

/// How finely each patch of a network is cut at one detail.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetworkPlan {
    /// Per patch, its cells per direction.
    pub cells: Vec<u32>,
    /// Per shared side, its samples' intervals: the larger of its two patches' cells.
    pub side_cells: Vec<u32>,
}

/// The bounding-box diagonal of the patches (each sampled on a 9 x 9 grid).
pub fn object_size(surfaces: &[&NurbsSurface]) -> f64 {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for s in surfaces {
        let e = extent_sampled(*s, 8);
        lo = lo.min(e.min);
        hi = hi.max(e.max);
    }
    if lo.cmple(hi).all() {
        (hi - lo).length()
    } else {
        0.0
    }
}

/// The cells per direction of a uniform grid on `surface` whose every cell, drawn as
/// two flat triangles, is within `goal` of the surface ([`chord_errors`], largest over
/// the cells; the error of a smooth patch falls as `1 / n^2`), at most [`MAX_GRID`].
pub fn cells_for(surface: &dyn ParamSurface, goal: f64) -> u32 {
    if !(goal > 0.0 && goal.is_finite()) {
        return MAX_GRID;
    }
    let worst = |n: u32| chord_errors(surface, n).into_iter().fold(0.0, f64::max);
    let probe = 2u32;
    let d = worst(probe);
    if !d.is_finite() {
        return MAX_GRID;
    }
    let mut n = ((f64::from(probe) * (d / goal).sqrt()).ceil() as u32).clamp(1, MAX_GRID);
    loop {
        let e = worst(n);
        if e <= goal || n >= MAX_GRID || !e.is_finite() {
            return if e.is_finite() { n } else { MAX_GRID };
        }
        let next = (f64::from(n) * (e / goal).sqrt() * 1.05).ceil() as u32;
        n = next.clamp(n + 1, MAX_GRID);
    }
}

impl NetworkPlan {
    /// Plans every patch for the detail's chord tolerance relative to the object's size
    /// ([`object_size`]), with `GRID_MARGIN` as the per-target grids have.
    pub fn new(surfaces: &[&NurbsSurface], network: &Network, detail: Detail) -> Self {
        let goal = detail.tolerance(object_size(surfaces)) * GRID_MARGIN;
        let cells: Vec<u32> = surfaces
            .iter()
            .map(|s| cells_for(*s as &dyn ParamSurface, goal))
            .collect();
        let side_cells = network
            .sides
            .iter()
            .map(|[a, b]| cells[a.0].max(cells[b.0]))
            .collect();
        Self { cells, side_cells }
    }

    /// The intervals along side `k` of patch `p`.
    fn side_count(&self, network: &Network, p: usize, k: usize) -> u32 {
        match network.links[p][k] {
            Some(l) => self.side_cells[l.side],
            None => self.cells[p],
        }
    }
}

/// The point of the unit square at parameter `t` along side `k` (in the patch's own
/// direction: increasing `v` on sides 0 and 1, increasing `u` on 2 and 3).
fn side_uv(k: usize, t: f64) -> DVec2 {
    match k {
        0 => DVec2::new(0.0, t),
        1 => DVec2::new(1.0, t),
        2 => DVec2::new(t, 0.0),
        _ => DVec2::new(t, 1.0),
    }
}

/// The corner control point at the unit square's corner `uv` (each coordinate 0 or 1).
fn corner_point(s: &NurbsSurface, uv: DVec2) -> DVec3 {
    let i = if uv.x > 0.5 { s.count_u() - 1 } else { 0 };
    let j = if uv.y > 0.5 { s.count_v() - 1 } else { 0 };
    s.control_point(i, j)
}

/// A sample: position and unit normal.
type Sample = (DVec3, DVec3);

fn sample(s: &NurbsSurface, uv: DVec2) -> Sample {
    let sp = ParamSurface::eval(s, uv);
    let p = if uv.x.fract() == 0.0 && uv.y.fract() == 0.0 {
        corner_point(s, uv)
    } else {
        sp.p
    };
    (p, normal_from(s, uv, &sp))
}

/// The vertices of one shared side, in its canonical direction (its first holder's),
/// with the parameter of each for a holder running the side the other way.
#[derive(Debug, Clone, PartialEq)]
pub struct SharedSide {
    /// The vertices, by increasing canonical parameter, from `t = 0` to `t = 1`.
    pub vertices: Vec<SideVertex>,
    /// Per vertex, its parameter along the side running the other way.
    pub back: Vec<f64>,
}

impl SharedSide {
    /// The vertices in the direction patch `p` runs side `k` (`None`: the side is not
    /// shared).
    pub fn own(
        sides: &[SharedSide],
        network: &Network,
        p: usize,
        k: usize,
    ) -> Option<Vec<SideVertex>> {
        let link = network.links.get(p)?[k]?;
        let side = sides.get(link.side)?;
        Some(if link.reversed {
            side.vertices
                .iter()
                .zip(&side.back)
                .rev()
                .map(|(v, &t)| SideVertex { t, ..*v })
                .collect()
        } else {
            side.vertices.clone()
        })
    }
}

/// The vertices of every shared side ([`shared_side`] with `extra[side]` and
/// `height(side, point)`).
pub fn shared_sides(
    surfaces: &[&NurbsSurface],
    network: &Network,
    plan: &NetworkPlan,
    extra: &[Vec<(f64, f64)>],
    height: impl Fn(usize, DVec3) -> f64,
) -> Vec<SharedSide> {
    (0..network.sides.len())
        .map(|id| {
            let extra = extra.get(id).map(Vec::as_slice).unwrap_or(&[]);
            shared_side(surfaces, network, plan, id, extra, |p| height(id, p))
        })
        .collect()
}

/// The vertices of shared side `id`: `side_cells + 1` uniform samples, plus the
/// canonical parameters `extra` (each with its parameter running the other way; one
/// within [`FIXED_SIDE_SNAP`] of a parameter already there, or at an end, is left out:
/// the two holders' ends of one groove crossing the side, each projected onto its own
/// patch, differ by the inverters' convergence and become one vertex, onto which both
/// tessellations move their ends),
/// each at the canonical holder's point (a corner: its control point) with the mean of
/// both patches' normals, displaced along it by `height(point)` (zero at the side's
/// ends, the corners, which every patch meeting there holds).
pub fn shared_side(
    surfaces: &[&NurbsSurface],
    network: &Network,
    plan: &NetworkPlan,
    id: usize,
    extra: &[(f64, f64)],
    height: impl Fn(DVec3) -> f64,
) -> SharedSide {
    let [(pa, ka), (pb, kb)] = network.sides[id];
    let count = plan.side_cells[id];
    let mut params: Vec<(f64, f64)> = (0..=count)
        .map(|i| {
            (
                f64::from(i) / f64::from(count),
                f64::from(count - i) / f64::from(count),
            )
        })
        .collect();
    for &(t, back) in extra {
        let k = params.partition_point(|q| q.0 < t);
        let near = |j: usize| {
            params
                .get(j)
                .is_some_and(|q| (q.0 - t).abs() <= FIXED_SIDE_SNAP)
        };
        if t > 0.0 && t < 1.0 && !near(k) && !(k > 0 && near(k - 1)) {
            params.insert(k, (t, back));
        }
    }
    let flip = network.links[pb][kb].is_some_and(|l| l.reversed);
    let vertices = params
        .iter()
        .map(|&(t, _)| {
            let (point, na) = sample(surfaces[pa], side_uv(ka, t));
            let tb = if flip { 1.0 - t } else { t };
            let nb = sample(surfaces[pb], side_uv(kb, tb)).1;
            let normal = (na + nb).try_normalize().unwrap_or(na);
            let h = if t > 0.0 && t < 1.0 {
                height(point)
            } else {
                0.0
            };
            SideVertex {
                t,
                point,
                normal,
                height: if h.is_finite() { h } else { 0.0 },
            }
        })
        .collect();
    SharedSide {
        vertices,
        back: params.into_iter().map(|q| q.1).collect(),
    }
}

/// The canonical parameters (with their parameters running the other way) that the
/// holders of shared side `id` add to it: `own(patch, side)`, in the holder's own
/// direction, for the holders that give any (a carved patch: its cells' corners).
pub fn holder_params(
    network: &Network,
    id: usize,
    own: impl Fn(usize, usize) -> Option<Vec<f64>>,
) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for (p, k) in network.sides[id] {
        let reversed = network.links[p][k].is_some_and(|l| l.reversed);
        for t in own(p, k).unwrap_or_default() {
            out.push(if reversed { (1.0 - t, t) } else { (t, 1.0 - t) });
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// The vertices of patch `p`'s side `k` in its own direction: the shared side's, or
/// `cells + 1` uniform samples of its own where the side is not shared.
fn side_vertices(
    surfaces: &[&NurbsSurface],
    network: &Network,
    plan: &NetworkPlan,
    sides: &[SharedSide],
    p: usize,
    k: usize,
) -> Vec<SideVertex> {
    if let Some(own) = SharedSide::own(sides, network, p, k) {
        return own;
    }
    let count = plan.side_count(network, p, k);
    (0..=count)
        .map(|i| {
            let t = f64::from(i) / f64::from(count);
            let (point, normal) = sample(surfaces[p], side_uv(k, t));
            SideVertex {
                t,
                point,
                normal,
                height: 0.0,
            }
        })
        .collect()
}

/// The triangles of one patch: its vertices (position, normal, uv) and index triples,
/// counter-clockwise in `uv`.
type PatchTriangles = (Vec<(DVec3, DVec3, DVec2)>, Vec<[u32; 3]>);

/// Triangulates patch `p` (see the module documentation).
fn patch_triangles(
    surfaces: &[&NurbsSurface],
    network: &Network,
    plan: &NetworkPlan,
    sides: &[SharedSide],
    p: usize,
) -> PatchTriangles {
    let s = surfaces[p];
    let n = plan.cells[p].max(1);
    let sides: [Vec<SideVertex>; 4] =
        std::array::from_fn(|k| side_vertices(surfaces, network, plan, sides, p, k));
    let mut verts: Vec<(DVec3, DVec3, DVec2)> = Vec::new();
    // Boundary, counter-clockwise from (0, 0): side 2 forward, 1 forward, 3 back, 0 back
    // (each side's last vertex is the next side's first and is skipped).
    let walk: [(usize, bool); 4] = [(2, false), (1, false), (3, true), (0, true)];
    for (k, back) in walk {
        let list = &sides[k];
        let m = list.len() - 1;
        for i in 0..m {
            let v = list[if back { m - i } else { i }];
            verts.push((v.position(), v.normal, side_uv(k, v.t)));
        }
    }
    let boundary = verts.len();
    let inv = 1.0 / f64::from(n);
    for j in 1..n {
        for i in 1..n {
            let uv = DVec2::new(f64::from(i) * inv, f64::from(j) * inv);
            let (pt, nm) = sample(s, uv);
            verts.push((pt, nm, uv));
        }
    }
    let regular = sides.iter().all(|l| l.len() as u32 == n + 1);
    let tris = if regular {
        grid_triangles(n, boundary, &verts)
    } else {
        delaunay_triangles(&verts)
    };
    (verts, tris)
}

/// The vertex index of grid node `(i, j)` of a regular patch laid out as in
/// [`patch_triangles`] (boundary walk, then inner nodes row by row).
fn grid_index(n: u32, boundary: usize, i: u32, j: u32) -> u32 {
    let b = if j == 0 {
        Some(i)
    } else if i == n {
        Some(n + j)
    } else if j == n {
        Some(3 * n - i)
    } else if i == 0 {
        Some((4 * n - j) % (4 * n))
    } else {
        None
    };
    match b {
        Some(b) => b,
        None => boundary as u32 + (j - 1) * (n - 1) + (i - 1),
    }
}

/// Two triangles per cell of a regular patch, split along the shorter 3D diagonal.
fn grid_triangles(n: u32, boundary: usize, verts: &[(DVec3, DVec3, DVec2)]) -> Vec<[u32; 3]> {
    let mut tris = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = grid_index(n, boundary, i, j);
            let b = grid_index(n, boundary, i + 1, j);
            let c = grid_index(n, boundary, i, j + 1);
            let d = grid_index(n, boundary, i + 1, j + 1);
            let pos = |k: u32| verts[k as usize].0;
            if pos(a).distance_squared(pos(d)) <= pos(b).distance_squared(pos(c)) {
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            } else {
                tris.push([a, b, c]);
                tris.push([b, d, c]);
            }
        }
    }
    tris
}

/// The Delaunay triangulation of the vertices' `uv` (all inside the unit square, its
/// four corners among them), counter-clockwise.
fn delaunay_triangles(verts: &[(DVec3, DVec3, DVec2)]) -> Vec<[u32; 3]> {
    let mut dt: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
    let mut handle_to_vertex = Vec::with_capacity(verts.len());
    for (k, v) in verts.iter().enumerate() {
        if let Ok(h) = dt.insert(Point2::new(v.2.x, v.2.y)) {
            let h = h.index();
            if handle_to_vertex.len() <= h {
                handle_to_vertex.resize(h + 1, u32::MAX);
            }
            handle_to_vertex[h] = k as u32;
        }
    }
    dt.inner_faces()
        .map(|f| f.vertices().map(|v| handle_to_vertex[v.fix().index()]))
        .filter(|t| t.iter().all(|&k| k != u32::MAX))
        .collect()
}

/// Writes the patches `which` selects, each as one sink patch under `key_of(patch)`,
/// and returns the triangles written per selected patch (in `which`'s order).
pub fn write_network(
    surfaces: &[&NurbsSurface],
    network: &Network,
    plan: &NetworkPlan,
    which: &[usize],
    key_of: impl Fn(usize) -> PatchKey,
    sink: &mut dyn MeshSink,
) -> Vec<usize> {
    let sides = shared_sides(surfaces, network, plan, &[], |_, _| 0.0);
    write_network_with(surfaces, network, plan, &sides, which, key_of, sink)
}

/// [`write_network`] with the shared sides' vertices given ([`shared_sides`]: where
/// carved patches add their cells' corners and displace the sides).
pub fn write_network_with(
    surfaces: &[&NurbsSurface],
    network: &Network,
    plan: &NetworkPlan,
    sides: &[SharedSide],
    which: &[usize],
    key_of: impl Fn(usize) -> PatchKey,
    sink: &mut dyn MeshSink,
) -> Vec<usize> {
    let made: Vec<(usize, PatchTriangles)> = which
        .iter()
        .map(|&p| (p, patch_triangles(surfaces, network, plan, sides, p)))
        .collect();
    // Corners: the mean normal over every patch meeting there (they share the corner
    // control point, bit for bit).
    let mut corner_normals: HashMap<[u64; 3], DVec3> = HashMap::new();
    let corners = [DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y];
    for (p, s) in surfaces.iter().enumerate() {
        if !network.holds(p) {
            continue;
        }
        for c in corners {
            let (pt, nm) = sample(s, c);
            // Keyed as the corner is written (`SideVertex::position`: no `-0.0`).
            *corner_normals
                .entry((pt + DVec3::ZERO).to_array().map(f64::to_bits))
                .or_insert(DVec3::ZERO) += nm;
        }
    }
    made.into_iter()
        .map(|(p, (verts, tris))| {
            sink.begin_patch(key_of(p));
            for (pt, nm, uv) in &verts {
                let is_corner = uv.x.fract() == 0.0 && uv.y.fract() == 0.0;
                let nm = if is_corner {
                    corner_normals
                        .get(&pt.to_array().map(f64::to_bits))
                        .and_then(|n| n.try_normalize())
                        .unwrap_or(*nm)
                } else {
                    *nm
                };
                let pos = if pt.is_finite() { *pt } else { DVec3::ZERO };
                sink.push_vertex(MeshVertex {
                    position: pos.as_vec3().to_array(),
                    normal: nm.as_vec3().to_array(),
                    uv: uv.as_vec2().to_array(),
                });
            }
            for t in &tris {
                sink.push_triangle(t[0], t[1], t[2]);
            }
            sink.end_patch();
            tris.len()
        })
        .collect()
}
