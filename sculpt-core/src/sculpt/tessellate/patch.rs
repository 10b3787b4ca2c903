//! One patch (root cell): its input (side points, leaf corners, constraint segments
//! clipped to the cell), its triangulation and evaluation, and how it is written to the
//! sink.

use super::clip::{clip_segment, rect_strictly_contains, side_crossings};
use super::height::{EvalCache, FxMap, evaluate};
use super::input::{Kind, PatchInput};
use super::normals::{GradientSegments, PatchVertex, corner_normals};
use super::poles::{pole_of, unfold_pole_fins};
use super::{StrokeRef, TargetTessellation};
use crate::mesh::{MeshSink, MeshVertex};
use crate::sculpt::jordan::{Location, NodeClass, Rect};
use crate::sculpt::stroke::Stroke;
use crate::sculpt::surface::ParamSurface;
use crate::tolerance::{MESH_MERGE_EPS, NORMAL_MERGE};
use glam::{DVec2, DVec3};
use rustc_hash::FxHasher;
use spade::Triangulation;
use spade::handles::FixedVertexHandle;
use std::hash::BuildHasherDefault;

/// The steps where strokes of the other mode cross: the outline segments of each stroke
/// that lie inside the footprint of an earlier stroke of the other mode (a ridge
/// embossed over a groove, a groove carved through a ridge). The combined height is
/// discontinuous there (the later stroke's depth is zero on its outline, the earlier
/// one's is not), so the step must run along mesh edges: as constraints, the step is a
/// straight band of the later stroke's wall instead of a staircase of the triangles
/// that straddle it. A stroke does not act on its own outline ([`super::height`]), so
/// the vertices on a step take the earlier stroke's height and the band lies inside
/// the later footprint.
pub(super) fn step_segments(strokes: &[StrokeRef<'_>]) -> Vec<[DVec2; 2]> {
    let mut out = Vec::new();
    for (k, (_, later)) in strokes.iter().enumerate() {
        let earlier: Vec<&Stroke> = strokes[..k]
            .iter()
            .map(|(_, s)| *s)
            .filter(|s| s.tool.mode != later.tool.mode && s.bounds.touches(&later.bounds))
            .collect();
        if earlier.is_empty() {
            continue;
        }
        out.extend(later.footprint.segments().iter().copied().filter(|seg| {
            let mid = (seg[0] + seg[1]) * 0.5;
            earlier
                .iter()
                .any(|s| s.bounds.contains(mid) && s.footprint.locate(mid) == Location::Inside)
        }));
    }
    out
}

/// Global constraint polylines of a target, indexed by root cell.
pub(super) struct Segments {
    pub(super) segs: Vec<([DVec2; 2], Kind)>,
    pub(super) by_root: Vec<Vec<u32>>,
}

impl TargetTessellation {
    /// The outline, centreline and groove-wall segments ([`Stroke::wall_segments`]: the
    /// walls are triangulated as strips along the stroke), indexed for the roots in
    /// `mask`.
    pub(super) fn segments(&self, strokes: &[StrokeRef<'_>], mask: &[bool]) -> Segments {
        let n = self.map.n();
        let mut by_root = vec![Vec::new(); (n * n) as usize];
        let mut segs: Vec<([DVec2; 2], Kind)> = Vec::new();
        let near = |r: &Rect| self.roots_near(r).any(|root| mask[root as usize]);
        // Outline edges lying on a seam are where a wrapped footprint was cut into the
        // square, not a rim: the groove runs on across them.
        // So are those on a pole, a side of the square that is one point.
        let on_seam = |s: &[DVec2; 2]| {
            let on = |a: f64, b: f64, side: f64| a == b && a == side;
            let [p0, p1, p2, p3] = self.poles;
            ((self.extent.closed_u || p0) && on(s[0].x, s[1].x, 0.0))
                || ((self.extent.closed_u || p1) && on(s[0].x, s[1].x, 1.0))
                || ((self.extent.closed_v || p2) && on(s[0].y, s[1].y, 0.0))
                || ((self.extent.closed_v || p3) && on(s[0].y, s[1].y, 1.0))
        };
        let mut outline = Vec::new();
        self.hidden.segments_where(near, |s| {
            if !on_seam(&s) {
                outline.push((s, Kind::Rim));
            }
        });
        let hidden = outline.into_iter();
        let centres = strokes
            .iter()
            .filter(|(id, _)| {
                self.touched
                    .get(id)
                    .is_none_or(|t| t.iter().any(|&r| mask[r as usize]))
            })
            .flat_map(|(_, s)| {
                let fracs = self.detail.profile_lines(s.tool.profile.is_curved());
                s.centre_segments()
                    .iter()
                    .copied()
                    .chain(s.wall_segments(fracs))
            })
            .filter(|w| !self.on_pole(w))
            .map(|w| (w, Kind::Plain));
        let steps = step_segments(strokes)
            .into_iter()
            .filter(|w| !on_seam(w) && !self.on_pole(w))
            .map(|w| (w, Kind::Plain));
        for (s, kind) in hidden.chain(centres).chain(steps) {
            if !near(&Rect::of_segment(s[0], s[1])) {
                continue;
            }
            let k = segs.len() as u32;
            segs.push((s, kind));
            self.for_roots_meeting(s, |root| {
                if mask[root as usize] {
                    by_root[root as usize].push(k);
                }
            });
        }
        // A canonical order, by geometry: the polygon boolean may renumber an outline's
        // segments when another footprint joins it far away, and a root whose
        // segments did not change must get the same input (same vertex order).
        let key = |k: &u32| {
            let (s, kind) = segs[*k as usize];
            (
                [s[0].x, s[0].y, s[1].x, s[1].y].map(f64::to_bits),
                kind == Kind::Rim,
            )
        };
        for list in &mut by_root {
            list.sort_by_key(key);
        }
        Segments { segs, by_root }
    }

    pub(super) fn patch_input(
        &self,
        root: u32,
        strokes: &[StrokeRef<'_>],
        segments: &Segments,
    ) -> PatchInput {
        let rect = self.map.node(root).rect;
        let mut input = PatchInput::new(rect);
        // Leaf corners inside a stroke's strip are left out: the strip's rows and rungs
        // (constraints, below) triangulate the groove wall as strips along the stroke.
        // Both cells sharing a side decide alike, since the strokes reaching a side
        // point are listed for both.
        let off_strips = |c: DVec2| !strokes.iter().any(|(_, s)| s.in_strip(c));
        // Sides: the leaf corners that both cells have along the side (the tree is
        // graded, so the finer cell loses at most one corner per coarse leaf, and a
        // cell whose neighbour is subdivided keeps its side), plus segment crossings.
        for side in 0u8..4 {
            let mut corners = self.map.side_params(root, side);
            let mut others: Vec<&[u32]> = vec![&segments.by_root[root as usize]];
            if let Some((nb, nb_side)) = self.neighbour(root, side) {
                let theirs = self.map.side_params(nb, nb_side);
                corners.retain(|p| theirs.binary_search_by(|q| q.total_cmp(p)).is_ok());
                others.push(&segments.by_root[nb as usize]);
            }
            let (fixed, lo, hi, along_u) = match side {
                0 => (rect.min.x, rect.min.y, rect.max.y, false),
                1 => (rect.max.x, rect.min.y, rect.max.y, false),
                2 => (rect.min.y, rect.min.x, rect.max.x, true),
                _ => (rect.max.y, rect.min.x, rect.max.x, true),
            };
            let at = |p: f64| {
                if along_u {
                    DVec2::new(p, fixed)
                } else {
                    DVec2::new(fixed, p)
                }
            };
            // A fixed side: its given vertices only (see `sides`).
            if let Some(list) = self.fixed_here(root, side) {
                for v in list
                    .iter()
                    .filter(|v| v.t >= lo - MESH_MERGE_EPS && v.t <= hi + MESH_MERGE_EPS)
                {
                    input.point(at(v.t), Kind::Plain);
                }
                continue;
            }
            let mut params: Vec<(f64, Kind)> = corners
                .into_iter()
                .filter(|&p| p >= lo && p <= hi && off_strips(at(p)))
                .map(|p| (p, Kind::Plain))
                .collect();
            // The seam: the side of a closed surface takes the crossings of both copies.
            let closed = if side < 2 {
                self.extent.closed_u
            } else {
                self.extent.closed_v
            };
            let seam_shift = (closed && (fixed == 0.0 || fixed == 1.0)).then_some(1.0 - fixed);
            for list in others {
                for &k in list {
                    let (s, kind) = segments.segs[k as usize];
                    for line in std::iter::once(fixed).chain(seam_shift) {
                        for p in side_crossings(s, line, along_u) {
                            if p >= lo && p <= hi {
                                params.push((p, kind));
                            }
                        }
                    }
                }
            }
            for (p, kind) in params {
                input.point(at(p), kind);
            }
        }
        // Leaf corners inside the cell.
        for (_, leaf) in self.map.leaves_of(root) {
            let r = leaf.rect;
            for c in [
                r.min,
                DVec2::new(r.max.x, r.min.y),
                DVec2::new(r.min.x, r.max.y),
                r.max,
            ] {
                // An exterior leaf meets no outline: its corners lie outside every
                // footprint, so outside every strip.
                if rect_strictly_contains(&rect, c)
                    && (leaf.class == NodeClass::Exterior || off_strips(c))
                {
                    input.point(c, Kind::Plain);
                }
            }
            if leaf.class == NodeClass::Interior && leaf.level == 0 {
                input.interior_hidden = true;
            }
        }
        // Constraint segments clipped to the cell.
        for &k in &segments.by_root[root as usize] {
            let (s, kind) = segments.segs[k as usize];
            if let Some((a, b)) = clip_segment(s, &rect) {
                let (a, b) = (
                    self.snap_to_fixed_sides(root, &rect, a),
                    self.snap_to_fixed_sides(root, &rect, b),
                );
                let ia = input.point(a, kind);
                let ib = input.point(b, kind);
                if ia != ib {
                    input.constraints.push(([ia, ib], kind));
                }
            }
        }
        input
    }

    pub(super) fn write_patch(
        &self,
        surface: &dyn ParamSurface,
        root: u32,
        input: PatchInput,
        strokes: &[StrokeRef<'_>],
        cache: &mut EvalCache,
        sink: &mut dyn MeshSink,
    ) -> usize {
        if input.points.len() == 4 && input.constraints.is_empty() {
            return self.write_quad(surface, root, &input, strokes, cache, sink);
        }
        let mut input = input;
        let cdt = input.triangulate();
        let rims: std::collections::HashSet<(u64, u64), BuildHasherDefault<FxHasher>> = input
            .points
            .iter()
            .filter(|(_, k)| *k == Kind::Rim)
            .map(|(p, _)| (p.x.to_bits(), p.y.to_bits()))
            .collect();
        // Evaluate every vertex: S(uv) + h N(uv).
        let mut verts: Vec<PatchVertex> = Vec::with_capacity(cdt.num_vertices());
        for v in cdt.vertices() {
            let p = v.position();
            let uv = crate::sculpt::surface::clamp_uv(DVec2::new(p.x, p.y));
            let rim = rims.contains(&(p.x.to_bits(), p.y.to_bits()));
            let (s, n, h, deepest, fixed) = self.vertex_at(cache, surface, strokes, uv);
            // A pole takes its one displacement even where an outline reaches it, and a
            // fixed vertex its given one.
            let on_rim = rim && fixed.is_none() && pole_of(self.poles, uv).is_none();
            let (h, deepest) = if on_rim { (0.0, None) } else { (h, deepest) };
            let displaced = fixed.is_some_and(|f| f != 0.0 || rim);
            verts.push(PatchVertex {
                surface_point: s,
                normal: n,
                uv,
                height: h,
                sculpted: h != 0.0 || on_rim || displaced,
                deepest,
            });
        }
        let mut tris = Vec::with_capacity(cdt.num_inner_faces());
        for f in cdt.inner_faces() {
            let [a, b, c] = f.vertices().map(|v| v.fix().index() as u32);
            tris.push([a, b, c]);
        }
        if self.poles.contains(&true) {
            let uvs: Vec<DVec2> = verts.iter().map(|v| v.uv).collect();
            let is_constraint = |a: u32, b: u32| {
                cdt.exists_constraint(
                    FixedVertexHandle::from_index(a as usize),
                    FixedVertexHandle::from_index(b as usize),
                )
            };
            unfold_pole_fins(&uvs, self.poles, is_constraint, &mut tris);
        }
        self.emit_patch(root, &verts, &tris, strokes, sink);
        tris.len()
    }

    /// Writes a patch, with each triangle corner's normal taken from the exact geometry
    /// on that triangle's side ([`corner_normals`]): a vertex whose triangles see
    /// different normals (a V groove's crease, a rim, where two grooves meet) is written
    /// once per normal, at the same position, so the edge shades sharp. Only vertices
    /// used by a triangle are written, in order of first use.
    pub(super) fn emit_patch(
        &self,
        root: u32,
        verts: &[PatchVertex],
        tris: &[[u32; 3]],
        strokes: &[StrokeRef<'_>],
        sink: &mut dyn MeshSink,
    ) {
        sink.begin_patch(self.patch_key(root));
        // The normals written for each input vertex, with their output indices: the
        // first in `written`, any others (creases, rims) in `more_written`.
        // (`more_written` is keyed by vertex, in the order written: a list scanned for
        // every corner made a patch's time grow with the square of its creases.)
        let mut written: Vec<Option<(DVec3, u32)>> = vec![None; verts.len()];
        let mut more_written: FxMap<u32, Vec<(DVec3, u32)>> = FxMap::default();
        // Per input vertex, the gradient segment of each stroke asked so far.
        let mut segments = GradientSegments {
            first: vec![None; verts.len()],
            more: FxMap::default(),
        };
        for t in tris {
            let normals = corner_normals(strokes, self.poles, verts, *t, &mut segments);
            let mut out = [0u32; 3];
            for k in 0..3 {
                let v = &verts[t[k] as usize];
                let close = |n: &DVec3| n.distance(normals[k]) <= NORMAL_MERGE;
                let same = match written[t[k] as usize] {
                    Some((n, i)) if close(&n) => Some(i),
                    Some(_) => more_written
                        .get(&t[k])
                        .and_then(|m| m.iter().find(|(n, _)| close(n)))
                        .map(|m| m.1),
                    None => None,
                };
                out[k] = match same {
                    Some(i) => i,
                    None => {
                        let pos = v.surface_point + v.normal * v.height;
                        let pos = if pos.is_finite() { pos } else { DVec3::ZERO };
                        let i = sink.push_vertex(MeshVertex {
                            position: pos.as_vec3().to_array(),
                            normal: normals[k].as_vec3().to_array(),
                            uv: v.uv.as_vec2().to_array(),
                        });
                        match written[t[k] as usize] {
                            None => written[t[k] as usize] = Some((normals[k], i)),
                            Some(_) => more_written.entry(t[k]).or_default().push((normals[k], i)),
                        }
                        i
                    }
                };
            }
            sink.push_triangle(out[0], out[1], out[2]);
        }
        sink.end_patch();
    }
    /// The fast path for a cell with only its four corners: two triangles, split along
    /// the shorter 3D diagonal.
    pub(super) fn write_quad(
        &self,
        surface: &dyn ParamSurface,
        root: u32,
        input: &PatchInput,
        strokes: &[StrokeRef<'_>],
        cache: &mut EvalCache,
        sink: &mut dyn MeshSink,
    ) -> usize {
        // Corner order of PatchInput::new: (min), (max.x, min.y), (min.x, max.y), (max).
        let v: Vec<PatchVertex> = input
            .points
            .iter()
            .map(|(p, _)| {
                let uv = *p;
                let (s, n, h, deepest, _) = self.vertex_at(cache, surface, strokes, uv);
                PatchVertex {
                    surface_point: s,
                    normal: n,
                    uv,
                    height: h,
                    sculpted: h != 0.0,
                    deepest,
                }
            })
            .collect();
        let pos = |i: usize| v[i].surface_point + v[i].normal * v[i].height;
        let tris = if pos(0).distance_squared(pos(3)) <= pos(1).distance_squared(pos(2)) {
            [[0, 1, 3], [0, 3, 2]]
        } else {
            [[0, 1, 2], [1, 3, 2]]
        };
        self.emit_patch(root, &v, &tris, strokes, sink);
        2
    }

    /// [`evaluate`], or the fixed vertex at `uv` ([`Self::fixed_at`]): its written
    /// position as the surface point with no displacement (`s + n * 0.0` is `s` bit for
    /// bit, [`super::SideVertex::position`] having no `-0.0`), and its displacement last.
    fn vertex_at(
        &self,
        cache: &mut EvalCache,
        surface: &dyn ParamSurface,
        strokes: &[StrokeRef<'_>],
        uv: DVec2,
    ) -> (DVec3, DVec3, f64, Option<(u64, usize)>, Option<f64>) {
        match self.fixed_at(uv) {
            Some(v) => (v.position(), v.normal, 0.0, None, Some(v.height)),
            None => {
                let (s, n, h, deepest) = evaluate(cache, surface, strokes, self.poles, uv);
                (s, n, h, deepest, None)
            }
        }
    }

    /// `p` (a constraint's end in root `root`) moved onto the nearest fixed vertex of
    /// the root's span when it lies on a fixed side.
    fn snap_to_fixed_sides(&self, root: u32, rect: &Rect, p: DVec2) -> DVec2 {
        (0u8..4).fold(p, |p, side| {
            if self.fixed_here(root, side).is_none() {
                return p;
            }
            let (lo, hi) = if side < 2 {
                (rect.min.y, rect.max.y)
            } else {
                (rect.min.x, rect.max.x)
            };
            self.snap_to_fixed(side as usize, p, lo, hi)
        })
    }
}
