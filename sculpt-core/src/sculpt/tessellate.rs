//! Tessellation of a sculpted target into a [`MeshSink`], crack-free and incremental.
//!
//! The target's UV square is cut into the root cells of its [`UvMap`]; each root cell is
//! one output patch. A patch is a constrained Delaunay triangulation (spade) in UV of:
//! - the corners of the quadtree leaves in the cell (exterior leaves draw the target;
//!   boundary leaves are subdivided to the depth cap near every outline);
//! - the **hidden-region outline** (the union of all stroke footprints on the target) as
//!   constraint edges: boundary leaves are clipped exactly along it, so the trimmed target
//!   and the stroke surfaces meet along one polyline, with no gap and no overlap;
//! - each stroke's **centreline** as constraint edges, so a V groove's bottom is a mesh
//!   edge at exactly the tool depth;
//! - each stroke's **groove wall** as strips along the stroke
//!   ([`Stroke::wall_segments`]): rows at the profile's sample fractions of the
//!   half-width (more for curved profiles and at final detail) and rungs across the
//!   stroke at every centreline sample, as constraint edges. Leaf corners inside the
//!   strip are left out, so each wall quad spans one sample step along the stroke and
//!   one profile interval across it, and its vertices lie on the profile's sample lines.
//!
//! Every vertex is placed at `S(uv) + h(uv) N(uv)`: `h = 0` on the target and along the
//! outline, and inside footprints the strokes combine in order like real carving: carving
//! lowers to `min(h, -depth)`, embossing raises to `max(h, height)`. Overlapping strokes
//! therefore give the union of the removed (or added) volumes, and the deeper groove wins
//! in an overlap. This is the paper's mutual trimming of overlapping stroke surfaces
//! (sec. 4.3) done once, in the target's UV map, for any number of strokes.
//!
//! **No cracks.** Points on a cell side are a deterministic function of both neighbours:
//! uniform at the finer side's leaf level, plus the crossings of outline and centreline
//! segments with the side line, computed by one formula from the global segment list.
//! Both cells therefore put identical vertices on their common side. For a surface closed
//! in u or v the two seam sides are treated as neighbours; strokes wrap across the seam
//! (their centrelines split exactly on it, [`Stroke::centre_segments`]), and the
//! outline edges where a wrapped footprint was cut into the square are not rims.
//!
//! **Incremental.** Each patch's inputs are hashed; after an edit only patches whose hash
//! changed are triangulated and written (the sink replaces them by key).

use super::hidden::HiddenRegion;
use super::jordan::{Location, NodeClass, Rect, Region};
use super::stroke::{Mode, Stroke};
use super::surface::{ParamSurface, SurfaceExtent, extent, normal_from};
use super::uvmap::UvMap;
use crate::mesh::{MeshSink, MeshVertex, PatchKey};
use crate::tolerance::{
    FINAL_CHORD_FRACTION, INTERACTIVE_CHORD_FRACTION, MESH_MERGE_EPS, MESH_SNAP_EPS,
    MESH_ZERO_COORD, NORMAL_MERGE, POLE_RING_PARAM, POLE_SIDE_REL, UV_PAD,
};
use glam::{DVec2, DVec3};
use rustc_hash::FxHasher;
use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};

/// How finely boundary nodes are subdivided.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Detail {
    /// Coarse, while a stroke is live.
    Interactive,
    /// Fine, for the finished render and for export.
    Final,
}

impl Detail {
    /// Quadtree levels below the root grid that boundary nodes reach.
    pub fn cap(self) -> u8 {
        match self {
            Detail::Interactive => 2,
            Detail::Final => 3,
        }
    }

    /// Chord tolerance of the tessellated target, as a fraction of its size (bounding
    /// box diagonal): 0.2 % while sculpting, 0.1 % for the final render and export.
    pub fn chord_fraction(self) -> f64 {
        match self {
            Detail::Interactive => INTERACTIVE_CHORD_FRACTION,
            Detail::Final => FINAL_CHORD_FRACTION,
        }
    }

    /// The stated tessellation tolerance (metres) for a target of size `size` (its
    /// bounding-box diagonal): the mesh of the bare target lies within this distance of
    /// the surface. [`GridPlan`] cuts the target by the measured chord error, with a
    /// margin, so that the mesh honours it.
    pub fn tolerance(self, size: f64) -> f64 {
        self.chord_fraction() * size
    }

    /// Profile sample fractions (of the half-width) inserted between centre and rim.
    fn profile_lines(self, curved: bool) -> &'static [f64] {
        match (self, curved) {
            (Detail::Interactive, false) => &[],
            (Detail::Interactive, true) => &[0.5],
            (Detail::Final, false) => &[0.5],
            (Detail::Final, true) => &[0.25, 0.5, 0.75, 0.9],
        }
    }
}

/// Largest root grid, cells per side.
pub const MAX_GRID: u32 = 64;

/// Smallest root grid, cells per side: root cells are the unit of incremental
/// re-tessellation, so even a flat target is cut into `8 x 8` of them to keep an edit's
/// work local.
pub const MIN_GRID: u32 = 8;

/// The deviation the grid is planned for, as a fraction of the stated tolerance: the
/// chord error is measured at cell midpoints, where it peaks for smooth patches; the
/// margin covers higher-order terms between them.
pub(crate) const GRID_MARGIN: f64 = 0.8;

/// Most root cells refined beyond this many levels by [`GridPlan`].
pub const MAX_REFINE: u8 = 4;

/// How a target is cut for tessellation: an `n x n` root grid, and per root the
/// quadtree level its leaves reach at least, so that every cell, drawn as two flat
/// triangles, deviates from the surface by at most `GRID_MARGIN * tol`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridPlan {
    /// Root cells per side.
    pub n: u32,
    /// Per root (row-major), the minimum leaf level.
    pub min_levels: Vec<u8>,
}

impl GridPlan {
    /// Plans the grid for a chord tolerance `tol` (metres).
    ///
    /// The chord error is measured, not estimated from derivative bounds: at every
    /// cell's edge midpoints and centre, the distance along the surface normal between
    /// the surface and the chord through the cell's corners (both diagonals at the
    /// centre) ([`chord_errors`]). Tangential parametric distortion (a clamped knot
    /// vector, a rational weight) moves no vertex off the surface and does not count.
    /// The uniform root grid `n` ([`MIN_GRID`] to [`MAX_GRID`]) is grown until 95 % of the cells
    /// hold (the error of a smooth patch falls as `1 / n^2`); the cells that still do
    /// not (creases, tight spots) are refined by `log2(error / goal)` levels, at most
    /// [`MAX_REFINE`] (the error falls at least by half per level).
    pub fn new(surface: &dyn ParamSurface, tol: f64) -> Self {
        let goal = tol * GRID_MARGIN;
        if !(goal > 0.0 && goal.is_finite()) {
            return Self::uniform(MAX_GRID);
        }
        let quantile = |e: &[f64]| {
            let mut v = e.to_vec();
            v.sort_by(f64::total_cmp);
            v[(v.len() * 95 / 100).min(v.len() - 1)]
        };
        let probe = 4u32;
        let d = quantile(&chord_errors(surface, probe));
        if !d.is_finite() {
            return Self::uniform(MAX_GRID);
        }
        let mut n =
            ((f64::from(probe) * (d / goal).sqrt()).ceil() as u32).clamp(MIN_GRID, MAX_GRID);
        loop {
            let errors = chord_errors(surface, n);
            let q = quantile(&errors);
            if q <= goal || n >= MAX_GRID {
                let min_levels = errors
                    .iter()
                    .map(|&e| {
                        if e <= goal {
                            0
                        } else if e.is_finite() {
                            ((e / goal).log2().ceil() as u8).min(MAX_REFINE)
                        } else {
                            MAX_REFINE
                        }
                    })
                    .collect();
                return Self { n, min_levels };
            }
            let next = (f64::from(n) * (q / goal).sqrt() * 1.05).ceil() as u32;
            n = next.clamp(n + 1, MAX_GRID);
        }
    }

    fn uniform(n: u32) -> Self {
        Self {
            n,
            min_levels: vec![0; (n * n) as usize],
        }
    }
}

/// The chord error (metres, along the normal) of each cell of an `n x n` grid of flat
/// cells over the surface (row-major), measured at its edge midpoints and centre (see
/// [`GridPlan::new`]); infinite where the surface is not finite.
pub fn chord_errors(surface: &dyn ParamSurface, n: u32) -> Vec<f64> {
    let n = n.max(1) as usize;
    let m = 2 * n + 1;
    let h = 0.5 / n as f64;
    let mut grid = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            let uv = DVec2::new(i as f64 * h, j as f64 * h).min(DVec2::ONE);
            let sp = surface.eval(uv);
            grid.push((sp.p, normal_from(surface, uv, &sp)));
        }
    }
    let at = |i: usize, j: usize| grid[j * m + i];
    let off = |mid: (DVec3, DVec3), a: DVec3, b: DVec3| mid.1.dot(mid.0 - (a + b) * 0.5).abs();
    let mut out = Vec::with_capacity(n * n);
    for cj in 0..n {
        for ci in 0..n {
            let (i, j) = (2 * ci + 1, 2 * cj + 1);
            let c = at(i, j);
            let e = [
                off(at(i, j - 1), at(i - 1, j - 1).0, at(i + 1, j - 1).0),
                off(at(i, j + 1), at(i - 1, j + 1).0, at(i + 1, j + 1).0),
                off(at(i - 1, j), at(i - 1, j - 1).0, at(i - 1, j + 1).0),
                off(at(i + 1, j), at(i + 1, j - 1).0, at(i + 1, j + 1).0),
                off(c, at(i - 1, j - 1).0, at(i + 1, j + 1).0),
                off(c, at(i + 1, j - 1).0, at(i - 1, j + 1).0),
            ];
            let worst = e.iter().fold(0.0f64, |w, &x| {
                if x.is_finite() {
                    w.max(x)
                } else {
                    f64::INFINITY
                }
            });
            out.push(worst);
        }
    }
    out
}

/// A stroke as the tessellator sees it: a stable id (for change detection) and the
/// projected stroke.
pub type StrokeRef<'a> = (u64, &'a Stroke);

/// Figures from one tessellation pass.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TessStats {
    /// Patches triangulated and written in this pass.
    pub patches_written: usize,
    /// Triangles written in this pass.
    pub triangles_written: usize,
    /// Triangles in the whole current mesh.
    pub triangles_total: usize,
}

/// The tessellation state of one target at one level of detail.
#[derive(Debug, Clone)]
pub struct TargetTessellation {
    key: u32,
    detail: Detail,
    extent: SurfaceExtent,
    /// The sides of the square (0 u-min, 1 u-max, 2 v-min, 3 v-max) that are poles:
    /// the whole side maps to one point.
    poles: [bool; 4],
    /// The displacement at each pole in the last pass (bits), to rewrite the cells
    /// around a pole when a stroke far along it in parameter changes it.
    pole_heights: [u64; 4],
    map: UvMap,
    /// The union of the footprints of the strokes seen, in order, as components:
    /// applying a stroke unions its footprint with the components it meets; undo pops.
    hidden: HiddenRegion,
    /// The roots each stroke touches (see [`Stroke::piece_bounds`]), by stroke id.
    touched: HashMap<u64, Vec<u32>>,
    /// The strokes touching each root, in application order.
    root_strokes: Vec<Vec<u64>>,
    signatures: Vec<Option<u64>>,
    triangles: Vec<usize>,
}

#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Kind {
    Plain,
    Rim,
}

/// Global constraint polylines of a target, indexed by root cell.
struct Segments {
    segs: Vec<([DVec2; 2], Kind)>,
    by_root: Vec<Vec<u32>>,
}

impl TargetTessellation {
    /// Starts the tessellation of a target (patch keys use `key` in their high bits),
    /// with the grid [`GridPlan::new`] plans for the detail's tolerance.
    pub fn new(surface: &dyn ParamSurface, key: u32, detail: Detail) -> Self {
        let extent = extent(surface);
        let plan = GridPlan::new(surface, detail.tolerance(extent.diagonal()));
        Self::with_grid(surface, key, detail, &plan)
    }

    /// [`Self::new`] with the grid already planned (planning costs a few thousand
    /// surface evaluations: plan once per target and detail).
    pub fn with_grid(
        surface: &dyn ParamSurface,
        key: u32,
        detail: Detail,
        plan: &GridPlan,
    ) -> Self {
        let extent = extent(surface);
        let mut map = UvMap::new(plan.n.clamp(1, MAX_GRID));
        map.set_min_levels(&plan.min_levels);
        map.set_wrap(extent.closed_u, extent.closed_v);
        let n = map.n();
        Self {
            key,
            detail,
            extent,
            poles: pole_sides(surface, &extent),
            pole_heights: [0; 4],
            signatures: vec![None; (n * n) as usize],
            triangles: vec![0; (n * n) as usize],
            root_strokes: vec![Vec::new(); (n * n) as usize],
            map,
            hidden: HiddenRegion::default(),
            touched: HashMap::new(),
        }
    }

    /// The UV vector map.
    pub fn map(&self) -> &UvMap {
        &self.map
    }

    /// The union of all footprints (the region where the target is hidden), as one
    /// region (built on each call: the view keeps it as components, see
    /// [`super::hidden`]).
    pub fn hidden(&self) -> Region {
        self.hidden.region()
    }

    /// Triangles in the current mesh of this target.
    pub fn triangle_count(&self) -> usize {
        self.triangles.iter().sum()
    }

    /// The level of detail.
    pub fn detail(&self) -> Detail {
        self.detail
    }

    /// The patch key of root cell `root`.
    pub fn patch_key(&self, root: u32) -> PatchKey {
        (u64::from(self.key) << 32) | u64::from(root)
    }

    /// Memory held by the map and bookkeeping, bytes (excluding the written mesh).
    pub fn memory_bytes(&self) -> usize {
        self.map.memory_bytes()
            + self.hidden.memory_bytes()
            + self
                .touched
                .values()
                .map(|t| t.len() * 4 + 32)
                .sum::<usize>()
            + self
                .root_strokes
                .iter()
                .map(|r| r.len() * 8 + 24)
                .sum::<usize>()
            + self.signatures.len() * 16
            + self.triangles.len() * 8
    }

    /// Brings the sink up to date with `strokes` (in application order) and rewrites
    /// the patches whose inputs changed. Like [`Self::update_strokes`], and when
    /// `changed` is `None` every root is re-checked (a change the view cannot see, such
    /// as a stroke rebuilt under the same id); otherwise the roots meeting `changed`
    /// are re-checked too.
    pub fn update(
        &mut self,
        surface: &dyn ParamSurface,
        strokes: &[StrokeRef<'_>],
        changed: Option<Rect>,
        sink: &mut dyn MeshSink,
    ) -> TessStats {
        let n = self.map.n();
        let extra: Vec<u32> = (0..n * n)
            .filter(|&r| changed.is_none_or(|c| c.touches(&self.map.node(r).rect)))
            .collect();
        self.update_inner(surface, strokes, &extra, sink)
    }

    /// Brings the sink up to date with `strokes` (in application order), doing work only
    /// where something changed since the last call. The view remembers the strokes it
    /// last saw: strokes applied since (a new suffix) have their footprints unioned into
    /// the hidden region, strokes undone since are popped. The dirty roots are those
    /// the added or removed strokes touch plus those met by an outline segment that
    /// changed; they are reclassified, and they and their neighbours (whose shared
    /// sides may change) are re-checked: a patch is rewritten only when its input
    /// signature changed.
    pub fn update_strokes(
        &mut self,
        surface: &dyn ParamSurface,
        strokes: &[StrokeRef<'_>],
        sink: &mut dyn MeshSink,
    ) -> TessStats {
        self.update_inner(surface, strokes, &[], sink)
    }

    fn update_inner(
        &mut self,
        surface: &dyn ParamSurface,
        strokes: &[StrokeRef<'_>],
        extra: &[u32],
        sink: &mut dyn MeshSink,
    ) -> TessStats {
        let n = self.map.n();
        let roots = (n * n) as usize;
        let fresh = self.signatures.iter().all(Option::is_none);
        let mut dirty = vec![fresh; roots];
        for &r in extra {
            dirty[r as usize] = true;
        }
        // The strokes added and removed since the last call.
        let common = self
            .hidden
            .ids()
            .zip(strokes)
            .take_while(|(u, s)| *u == s.0)
            .count();
        let edited = common < self.hidden.len() || common < strokes.len();
        self.hidden.set_tracking(!fresh);
        while self.hidden.len() > common {
            let Some(id) = self.hidden.pop() else { break };
            for r in self.touched.remove(&id).unwrap_or_default() {
                dirty[r as usize] = true;
                self.root_strokes[r as usize].retain(|&x| x != id);
            }
        }
        for &(id, s) in &strokes[common..] {
            self.hidden.push(id, &s.footprint);
            let touched = self.roots_touched(s);
            for &r in &touched {
                dirty[r as usize] = true;
                self.root_strokes[r as usize].push(id);
            }
            self.touched.insert(id, touched);
        }
        // Roots met by an outline segment that appeared or disappeared.
        let changed = self.hidden.take_changed();
        if !fresh && edited {
            for s in changed {
                self.for_roots_meeting(s, |r| dirty[r as usize] = true);
            }
        }
        // The poles: one displacement each, from every stroke, whichever cell reaches
        // it; a change rewrites the whole row of cells around the pole.
        // Sized for the vertices of a whole pass (about half the triangles) so that it
        // seldom grows.
        let mut cache = EvalCache::with_capacity_and_hasher(
            (self.triangles.iter().sum::<usize>() / 2).max(4 * roots),
            Default::default(),
        );
        let mut pole_rows = Vec::new();
        for side in (0..4).filter(|&k| self.poles[k]) {
            let uv = pole_uv(side);
            let (p, nrm, h) = pole_point(surface, strokes, side);
            cache.insert((uv.x.to_bits(), uv.y.to_bits()), (p, nrm, h, None));
            if h.to_bits() != self.pole_heights[side] {
                self.pole_heights[side] = h.to_bits();
                pole_rows.push(side);
            }
        }
        for r in 0..n * n {
            if pole_rows.iter().any(|&side| self.root_on_side(r, side)) {
                dirty[r as usize] = true;
            }
        }
        // The grading looks up to `GRADING_REACH` root cells beyond a node (see
        // `uvmap::GRADING_REACH`): the two rings of roots around a dirty one are
        // reclassified too, and those whose leaves changed are re-checked.
        let reclassify = self.grow_with_corners(&self.grow_with_corners(&dirty));
        for r in (0..n * n).filter(|&r| reclassify[r as usize]) {
            let near = self.hidden.local(self.reach_of(r));
            let edit = self.map.update_roots(&near, [r], self.detail.cap());
            if !edit.is_empty() {
                dirty[r as usize] = true;
            }
        }
        // Re-check the dirty roots and their neighbours; index segments one ring wider.
        let recheck = self.grow(&dirty);
        let indexed = self.grow(&recheck);
        let by_id: FxMap<u64, &Stroke> = strokes.iter().map(|&(id, s)| (id, s)).collect();
        let segments = self.segments(strokes, &indexed);
        let mut stats = TessStats::default();
        let mut here: Vec<StrokeRef<'_>> = Vec::new();
        for root in (0..n * n).filter(|&r| recheck[r as usize]) {
            here.clear();
            here.extend(
                self.root_strokes[root as usize]
                    .iter()
                    .filter_map(|id| by_id.get(id).map(|&s| (*id, s))),
            );
            let input = self.patch_input(root, &here, &segments);
            let mut h = FxHasher::default();
            input.hash_into(&mut h);
            for (id, _) in &here {
                id.hash(&mut h);
            }
            for side in (0..4).filter(|&k| self.root_on_side(root, k) && self.poles[k]) {
                self.pole_heights[side].hash(&mut h);
            }
            let sig = h.finish();
            if self.signatures[root as usize] == Some(sig) {
                continue;
            }
            let tris = self.write_patch(surface, root, input, &here, &mut cache, sink);
            self.signatures[root as usize] = Some(sig);
            self.triangles[root as usize] = tris;
            stats.patches_written += 1;
            stats.triangles_written += tris;
        }
        stats.triangles_total = self.triangles.iter().sum();
        stats
    }

    /// The roots a stroke touches: those meeting one of its pieces' bounds.
    fn roots_touched(&self, s: &Stroke) -> Vec<u32> {
        let n = self.map.n();
        let mut mask = vec![false; (n * n) as usize];
        for r in s.piece_bounds() {
            let r = Rect::new(r.min - DVec2::splat(UV_PAD), r.max + DVec2::splat(UV_PAD));
            for root in self.roots_near(&r) {
                if self.map.node(root).rect.touches(&r) {
                    mask[root as usize] = true;
                }
            }
        }
        (0..n * n).filter(|&r| mask[r as usize]).collect()
    }

    /// Calls `f` for every root whose closed rectangle meets the segment.
    fn for_roots_meeting(&self, s: [DVec2; 2], mut f: impl FnMut(u32)) {
        for root in self.roots_near(&Rect::of_segment(s[0], s[1])) {
            if self.map.node(root).rect.meets_segment(s[0], s[1]) {
                f(root);
            }
        }
    }

    /// The roots of the grid cells under `r`, widened by one cell (a rectangle ending
    /// on a cell side belongs to both cells).
    fn roots_near(&self, r: &Rect) -> impl Iterator<Item = u32> + '_ {
        let n = self.map.n();
        let cell = |x: f64| ((x * n as f64).floor().max(0.0) as u32).min(n - 1);
        let (i0, i1) = (
            cell(r.min.x).saturating_sub(1),
            (cell(r.max.x) + 1).min(n - 1),
        );
        let (j0, j1) = (
            cell(r.min.y).saturating_sub(1),
            (cell(r.max.y) + 1).min(n - 1),
        );
        (j0..=j1).flat_map(move |j| (i0..=i1).map(move |i| self.map.root(i, j)))
    }

    /// The rectangles a classification of root `root`'s nodes may ask about: the root
    /// widened by two root cells (more than [`super::uvmap::GRADING_REACH`] of its
    /// largest node), with its copies one period over on a closed surface.
    fn reach_of(&self, root: u32) -> Vec<Rect> {
        let rect = self.map.node(root).rect;
        let reach = (rect.max - rect.min) * 2.0;
        let wide = Rect::new(rect.min - reach, rect.max + reach);
        let shifts = |closed: bool| {
            if closed {
                vec![-1.0, 0.0, 1.0]
            } else {
                vec![0.0]
            }
        };
        let mut out = Vec::new();
        for dv in shifts(self.extent.closed_v) {
            for du in shifts(self.extent.closed_u) {
                let d = DVec2::new(du, dv);
                out.push(Rect::new(wide.min + d, wide.max + d));
            }
        }
        out
    }

    /// The mask grown by one ring of neighbours (across the seams of closed surfaces).
    fn grow(&self, mask: &[bool]) -> Vec<bool> {
        let mut out = mask.to_vec();
        for (r, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
            for side in 0..4 {
                if let Some((nb, _)) = self.neighbour(r as u32, side) {
                    out[nb as usize] = true;
                }
            }
        }
        out
    }

    /// The mask grown by the eight surrounding roots (across the seams of closed
    /// surfaces).
    fn grow_with_corners(&self, mask: &[bool]) -> Vec<bool> {
        let mut out = mask.to_vec();
        for (r, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
            let r = r as u32;
            let row = [
                Some(r),
                self.neighbour(r, 0).map(|x| x.0),
                self.neighbour(r, 1).map(|x| x.0),
            ];
            for c in row.into_iter().flatten() {
                out[c as usize] = true;
                for side in [2, 3] {
                    if let Some((nb, _)) = self.neighbour(c, side) {
                        out[nb as usize] = true;
                    }
                }
            }
        }
        out
    }

    /// True when root cell `root` lies along side `side` of the square (0 u-min, 1 u-max,
    /// 2 v-min, 3 v-max).
    fn root_on_side(&self, root: u32, side: usize) -> bool {
        let n = self.map.n();
        let (i, j) = (root % n, root / n);
        match side {
            0 => i == 0,
            1 => i + 1 == n,
            2 => j == 0,
            _ => j + 1 == n,
        }
    }

    /// True when the segment lies on a pole (a side of the square that is one point).
    fn on_pole(&self, s: &[DVec2; 2]) -> bool {
        let [a, b] = s.map(|p| pole_of(self.poles, p));
        a.is_some() && a == b
    }

    /// The outline, centreline and groove-wall segments ([`Stroke::wall_segments`]: the
    /// walls are triangulated as strips along the stroke), indexed for the roots in
    /// `mask`.
    fn segments(&self, strokes: &[StrokeRef<'_>], mask: &[bool]) -> Segments {
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
        for (s, kind) in hidden.chain(centres) {
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

    /// The neighbour root across `side` (0 u-min, 1 u-max, 2 v-min, 3 v-max), wrapping
    /// across the seam of a closed surface.
    fn neighbour(&self, root: u32, side: u8) -> Option<(u32, u8)> {
        let n = self.map.n();
        let (i, j) = (root % n, root / n);
        let (cu, cv) = (self.extent.closed_u, self.extent.closed_v);
        let r = match side {
            0 if i > 0 => (i - 1, j),
            0 if cu => (n - 1, j),
            1 if i + 1 < n => (i + 1, j),
            1 if cu => (0, j),
            2 if j > 0 => (i, j - 1),
            2 if cv => (i, n - 1),
            3 if j + 1 < n => (i, j + 1),
            3 if cv => (i, 0),
            _ => return None,
        };
        Some((self.map.root(r.0, r.1), side ^ 1))
    }

    fn patch_input(&self, root: u32, strokes: &[StrokeRef<'_>], segments: &Segments) -> PatchInput {
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
                let ia = input.point(a, kind);
                let ib = input.point(b, kind);
                if ia != ib {
                    input.constraints.push(([ia, ib], kind));
                }
            }
        }
        input
    }

    fn write_patch(
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
            let uv = super::surface::clamp_uv(DVec2::new(p.x, p.y));
            let (s, n, h, deepest) = evaluate(cache, surface, strokes, self.poles, uv);
            // A pole takes its one displacement even where an outline reaches it.
            let on_rim =
                rims.contains(&(p.x.to_bits(), p.y.to_bits())) && pole_of(self.poles, uv).is_none();
            let (h, deepest) = if on_rim { (0.0, None) } else { (h, deepest) };
            verts.push(PatchVertex {
                surface_point: s,
                normal: n,
                uv,
                height: h,
                sculpted: h != 0.0 || on_rim,
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
    fn emit_patch(
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
}

impl TargetTessellation {
    /// The fast path for a cell with only its four corners: two triangles, split along
    /// the shorter 3D diagonal.
    fn write_quad(
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
                let (s, n, h, deepest) = evaluate(cache, surface, strokes, self.poles, uv);
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
}

/// A vertex of a patch before it is written.
struct PatchVertex {
    /// `S(uv)`.
    surface_point: DVec3,
    /// The target's unit normal at `uv`.
    normal: DVec3,
    uv: DVec2,
    /// The combined displacement along the normal.
    height: f64,
    /// Displaced, or on a rim: its triangles may see different normals.
    sculpted: bool,
    /// Where displaced (off the rims), the stroke that sets `height` (its id) and the
    /// centreline segment giving it its depth ([`Stroke::gradient_segment`]).
    deepest: Option<(u64, usize)>,
}

/// The normals at the three corners of triangle `t`, each the exact normal of the
/// sculpted surface at that vertex as seen from inside the triangle.
///
/// A triangle with no sculpted vertex, or with a corner outside the hidden region, takes
/// the target normals. Otherwise the stroke
/// that shapes the triangle is the one that wins the carve/emboss combination of
/// [`height`] at its displaced corners, where they agree, or else at its centroid (none:
/// the bare target, as outside a rim). The normal of
/// `P = S + h N` with `h = -depth` (carve) or `+depth` (emboss) is `N - grad h`, with
/// the gradient of the stroke's depth taken along the target ([`Stroke::depth_gradient`],
/// on the centroid's side of the centreline where the vertex lies on it) and the term
/// `h dN` of the target's curvature left out (the tool depth is small against the radius
/// of curvature). Pole vertices keep the pole's normal. `segments` holds, per vertex, the
/// [`Stroke::gradient_segment`] of each stroke asked so far (shared by the patch's
/// triangles).
fn corner_normals(
    strokes: &[StrokeRef<'_>],
    poles: [bool; 4],
    verts: &[PatchVertex],
    t: [u32; 3],
    segments: &mut GradientSegments,
) -> [DVec3; 3] {
    let vs = t.map(|i| &verts[i as usize]);
    let plain = vs.map(|v| v.normal);
    // A corner off every footprint and off the rims puts the triangle outside the
    // hidden region (the rims are constraints of the triangulation): the bare target,
    // even where a stroke's exact depth reaches past its footprint polygon (a tapered
    // end), which would tilt the rim's normals over the flat target.
    if vs.iter().any(|v| !v.sculpted) {
        return plain;
    }
    let centroid = (vs[0].uv + vs[1].uv + vs[2].uv) / 3.0;
    // The centroid of the corners' surface points stands for S(centroid): it is only
    // used to pick the stroke and the side of its centreline.
    let inside = (vs[0].surface_point + vs[1].surface_point + vs[2].surface_point) / 3.0;
    // The stroke that wins at the displaced corners where they agree (the triangle lies
    // in its groove: rims are constraints of the triangulation), else at the centroid.
    let mut ids = vs.iter().filter_map(|v| v.deepest.map(|d| d.0));
    let agreed = ids.next().filter(|&id| ids.all(|other| other == id));
    let k = match agreed.and_then(|id| strokes.iter().position(|s| s.0 == id)) {
        Some(k) => k,
        None => match winner(strokes, centroid, inside) {
            Some(k) => k,
            None => return plain,
        },
    };
    let stroke = strokes[k].1;
    let sign = match stroke.tool.mode {
        Mode::Carve => 1.0,
        Mode::Emboss => -1.0,
    };
    std::array::from_fn(|c| {
        let v = vs[c];
        if !v.sculpted || pole_of(poles, v.uv).is_some() {
            return v.normal;
        }
        let own = v.deepest.filter(|d| d.0 == strokes[k].0).map(|d| d.1);
        let segment = match own.map(Some).or_else(|| segments.get(t[c], k)) {
            Some(seg) => seg,
            None => {
                let seg = stroke.gradient_segment(v.uv, v.surface_point);
                segments.put(t[c], k, seg);
                seg
            }
        };
        let g = stroke.depth_gradient_from(segment, v.uv, v.surface_point, inside, v.normal);
        let along = g - v.normal * g.dot(v.normal);
        (v.normal + along * sign)
            .try_normalize()
            .filter(|n| n.is_finite())
            .unwrap_or(v.normal)
    })
}

/// Per vertex of a patch, the [`Stroke::gradient_segment`] of each stroke asked so far:
/// the first stroke's in `first`, others (where grooves meet) in `more`.
struct GradientSegments {
    first: Vec<Option<(usize, Option<usize>)>>,
    /// The later strokes' segments, by (vertex, stroke); the first one put wins.
    more: FxMap<(u32, usize), Option<usize>>,
}

impl GradientSegments {
    fn get(&self, vertex: u32, stroke: usize) -> Option<Option<usize>> {
        match self.first[vertex as usize] {
            Some((k, seg)) if k == stroke => Some(seg),
            Some(_) => self.more.get(&(vertex, stroke)).copied(),
            None => None,
        }
    }

    fn put(&mut self, vertex: u32, stroke: usize, segment: Option<usize>) {
        match self.first[vertex as usize] {
            None => self.first[vertex as usize] = Some((stroke, segment)),
            Some(_) => {
                self.more.entry((vertex, stroke)).or_insert(segment);
            }
        }
    }
}

/// The index of the stroke that sets [`height`] at `uv` (`p` on the target near
/// `S(uv)`), if any; a stroke counts where its depth is positive.
fn winner(strokes: &[StrokeRef<'_>], uv: DVec2, p: DVec3) -> Option<usize> {
    let mut h: f64 = 0.0;
    let mut win = None;
    for (k, (_, s)) in strokes.iter().enumerate() {
        if !s.bounds.contains(uv) {
            continue;
        }
        let d = s.depth_at(uv, p);
        if d > 0.0 {
            let next = match s.tool.mode {
                Mode::Carve => h.min(-d),
                Mode::Emboss => h.max(d),
            };
            if next != h {
                h = next;
                win = Some(k);
            }
        }
    }
    win
}

/// `S(uv)`, the normal and the combined displacement, through the pass's cache. A
/// parameter on a pole (see [`pole_sides`]) is evaluated at the pole's one parameter
/// ([`pole_uv`]), so that every cell meeting the pole puts it at one point.
fn evaluate(
    cache: &mut EvalCache,
    surface: &dyn ParamSurface,
    strokes: &[StrokeRef<'_>],
    poles: [bool; 4],
    uv: DVec2,
) -> Evaluated {
    if let Some(side) = pole_of(poles, uv) {
        let uv = pole_uv(side);
        return *cache
            .entry((uv.x.to_bits(), uv.y.to_bits()))
            .or_insert_with(|| {
                let (p, n, h) = pole_point(surface, strokes, side);
                (p, n, h, None)
            });
    }
    *cache
        .entry((uv.x.to_bits(), uv.y.to_bits()))
        .or_insert_with(|| {
            let sp = surface.eval(uv);
            let (h, deepest) = height_and_deepest(strokes, uv, sp.p);
            (sp.p, normal_from(surface, uv, &sp), h, deepest)
        })
}

/// The combined displacement along the normal at `p = S(uv)`: strokes in order, carving
/// lowers to `min(h, -depth)`, embossing raises to `max(h, height)`. A stroke acts only
/// inside its footprint (outline included), so the sculpted part ends exactly at the
/// hidden region's outline.
pub fn height(strokes: &[StrokeRef<'_>], uv: DVec2, p: DVec3) -> f64 {
    height_and_deepest(strokes, uv, p).0
}

/// [`height`], and the stroke that sets it (its id) with the centreline segment that
/// gives it its depth there.
fn height_and_deepest(
    strokes: &[StrokeRef<'_>],
    uv: DVec2,
    p: DVec3,
) -> (f64, Option<(u64, usize)>) {
    let mut h: f64 = 0.0;
    let mut deepest = None;
    for &(id, s) in strokes {
        if !s.bounds.contains(uv) {
            continue;
        }
        let (d, segment) = s.deepest_segment(uv, p);
        if d > 0.0 && s.footprint.locate(uv) != Location::Outside {
            let next = match s.tool.mode {
                Mode::Carve => h.min(-d),
                Mode::Emboss => h.max(d),
            };
            if next != h {
                deepest = segment.map(|k| (id, k));
            }
            h = next;
        }
    }
    (h, deepest)
}

/// The sides of the square (0 u-min, 1 u-max, 2 v-min, 3 v-max) whose points all
/// coincide (within [`POLE_SIDE_REL`] of the target's size): the poles of a sphere.
fn pole_sides(surface: &dyn ParamSurface, extent: &SurfaceExtent) -> [bool; 4] {
    let tol = POLE_SIDE_REL * extent.diagonal();
    let side = |k: usize| {
        let at = |t: f64| {
            surface
                .eval(match k {
                    0 => DVec2::new(0.0, t),
                    1 => DVec2::new(1.0, t),
                    2 => DVec2::new(t, 0.0),
                    _ => DVec2::new(t, 1.0),
                })
                .p
        };
        let first = at(0.0);
        first.is_finite() && (1..=8).all(|i| at(f64::from(i) / 8.0).distance(first) <= tol)
    };
    [side(0), side(1), side(2), side(3)]
}

/// The one parameter a pole on side `side` is evaluated at: the side's midpoint.
fn pole_uv(side: usize) -> DVec2 {
    match side {
        0 => DVec2::new(0.0, 0.5),
        1 => DVec2::new(1.0, 0.5),
        2 => DVec2::new(0.5, 0.0),
        _ => DVec2::new(0.5, 1.0),
    }
}

/// Flips the fins that a pole leaves in a cell's triangulation.
///
/// A pole (a side of the square that is one point) collapses every triangle with a
/// vertex on it and its two other vertices on one meridian (the same `u` for a pole at
/// `v = 0` or `1`, the same `v` for one at `u = 0` or `1`) onto that meridian: a fin of
/// no area. Where two cells share the meridian as a side, each made such a fin over the
/// same three points, so the edge from the lower side vertex to the pole was used by
/// four triangles (non-manifold at a sphere's pole at final detail). Each fin is
/// flipped with its neighbour across one of its two pole edges (one that is no
/// constraint and whose quadrilateral is convex in `uv`), so that both new triangles
/// span two meridians. The cell's outline is unchanged, so it stays crack-free against
/// its neighbours.
fn unfold_pole_fins(
    uvs: &[DVec2],
    poles: [bool; 4],
    is_constraint: impl Fn(u32, u32) -> bool,
    tris: &mut [[u32; 3]],
) {
    let uv = |i: u32| uvs[i as usize];
    let on_pole = |i: u32| pole_of(poles, uv(i));
    let ccw = |a: u32, b: u32, c: u32| (uv(b) - uv(a)).perp_dot(uv(c) - uv(a)) > 0.0;
    let third = |t: [u32; 3], a: u32, b: u32| t.into_iter().find(|&i| i != a && i != b);
    for f in 0..tris.len() {
        let t = tris[f];
        let Some(k) = (0..3).find(|&k| on_pole(t[k]).is_some()) else {
            continue;
        };
        // The fin in counter-clockwise order (q, x, y), q on the pole.
        let (q, x, y) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let Some(side) = on_pole(q) else { continue };
        let meridian = |i: u32| if side >= 2 { uv(i).x } else { uv(i).y };
        let same_meridian = |a: u32, b: u32| (meridian(a) - meridian(b)).abs() <= MESH_SNAP_EPS;
        if on_pole(x).is_some() || on_pole(y).is_some() || !same_meridian(x, y) {
            continue;
        }
        for a in [x, y] {
            if is_constraint(a, q) {
                continue;
            }
            let neighbour =
                (0..tris.len()).find(|&g| g != f && tris[g].contains(&a) && tris[g].contains(&q));
            let Some(g) = neighbour else { continue };
            let Some(w) = third(tris[g], a, q) else {
                continue;
            };
            if on_pole(w).is_some() || same_meridian(w, x) {
                continue;
            }
            // Flip the diagonal a-q of the quadrilateral to the other one.
            let new = if a == x {
                [[x, y, w], [y, q, w]]
            } else {
                [[q, x, w], [x, y, w]]
            };
            if new.iter().all(|&[i, j, k]| ccw(i, j, k)) {
                tris[f] = new[0];
                tris[g] = new[1];
                break;
            }
        }
    }
}

/// The pole side `uv` lies on, if any (within [`MESH_SNAP_EPS`]: a cell side summed from
/// the grid may stop one rounding short of the square's side).
fn pole_of(poles: [bool; 4], uv: DVec2) -> Option<usize> {
    let near = |a: f64, b: f64| (a - b).abs() <= MESH_SNAP_EPS;
    let on = [
        near(uv.x, 0.0),
        near(uv.x, 1.0),
        near(uv.y, 0.0),
        near(uv.y, 1.0),
    ];
    (0..4).find(|&k| poles[k] && on[k])
}

/// [`height`] at a pole `p`: each stroke's depth from the 3D point alone (the pole is
/// in a footprint wherever it lies within the stroke's half-width), since the footprint
/// in the square meets the pole's side along part of it only.
/// The point, normal and displacement of the pole on side `side`.
fn pole_point(
    surface: &dyn ParamSurface,
    strokes: &[StrokeRef<'_>],
    side: usize,
) -> (DVec3, DVec3, f64) {
    let uv = pole_uv(side);
    let p = surface.eval(uv).p;
    // The normal: the mean of the normals on a small ring round the pole (at the pole
    // itself one derivative vanishes and the cross product is rounding noise).
    let ring: DVec3 = (0..8)
        .map(|k| {
            let t = f64::from(k) / 8.0;
            let (a, b) = (POLE_RING_PARAM, 1.0 - POLE_RING_PARAM);
            let q = match side {
                0 => DVec2::new(a, t),
                1 => DVec2::new(b, t),
                2 => DVec2::new(t, a),
                _ => DVec2::new(t, b),
            };
            normal_from(surface, q, &surface.eval(q))
        })
        .sum();
    let n = ring
        .try_normalize()
        .unwrap_or_else(|| normal_from(surface, uv, &surface.eval(uv)));
    (p, n, pole_height(strokes, p))
}

fn pole_height(strokes: &[StrokeRef<'_>], p: DVec3) -> f64 {
    let mut h: f64 = 0.0;
    for (_, s) in strokes {
        let d = s.depth_at_point(p);
        if d > 0.0 {
            h = match s.tool.mode {
                Mode::Carve => h.min(-d),
                Mode::Emboss => h.max(d),
            };
        }
    }
    h
}

/// Surface point, normal and displacement per parameter (bit pattern), shared by the
/// patches of one pass so that side and corner vertices are evaluated once.
type EvalCache = HashMap<(u64, u64), Evaluated, BuildHasherDefault<FxHasher>>;

/// `S(uv)`, the target's normal, the combined displacement and the stroke setting it
/// (see [`PatchVertex::deepest`]).
type Evaluated = (DVec3, DVec3, f64, Option<(u64, usize)>);

/// A hash map with rustc's [`FxHasher`] (Fx: parameters are not adversarial, and
/// SipHash dominated the cache's cost).
type FxMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

struct PatchInput {
    rect: Rect,
    points: Vec<(DVec2, Kind)>,
    index: FxMap<(u64, u64), usize>,
    /// The first and last point of each [`MESH_MERGE_EPS`] grid cell (chained through
    /// `next_near` in order of insertion), to find near-duplicates.
    near: FxMap<(i64, i64), (usize, usize)>,
    /// Per point, the next point of its merge cell (`usize::MAX`: none).
    next_near: Vec<usize>,
    constraints: Vec<([usize; 2], Kind)>,
    interior_hidden: bool,
}

/// Orientation of `c` against the line `a -> b` (twice the signed triangle area).
fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// Parameter of the foot of `p` on the segment `a-b` when `p` lies within
/// [`MESH_SNAP_EPS`] of its interior.
fn on_segment(p: DVec2, a: DVec2, b: DVec2) -> Option<f64> {
    let d = b - a;
    let l2 = d.length_squared();
    if l2 == 0.0 {
        return None;
    }
    let t = (p - a).dot(d) / l2;
    (t > 0.0 && t < 1.0 && p.distance(a + d * t) <= MESH_SNAP_EPS).then_some(t)
}

impl PatchInput {
    fn new(rect: Rect) -> Self {
        let mut me = Self {
            rect,
            points: Vec::new(),
            index: FxMap::default(),
            near: FxMap::default(),
            next_near: Vec::new(),
            constraints: Vec::new(),
            interior_hidden: false,
        };
        for c in [
            rect.min,
            DVec2::new(rect.max.x, rect.min.y),
            DVec2::new(rect.min.x, rect.max.y),
            rect.max,
        ] {
            me.point(c, Kind::Plain);
        }
        me
    }

    fn point(&mut self, p: DVec2, kind: Kind) -> usize {
        // spade merges -0.0 with 0.0 and rejects subnormal-scale coordinates: the
        // index must agree, so such values become 0.0.
        let p = DVec2::new(p.x, p.y).map(|x| if x.abs() < MESH_ZERO_COORD { 0.0 } else { x });
        let key = (p.x.to_bits(), p.y.to_bits());
        let cell = (
            (p.x / MESH_MERGE_EPS).floor() as i64,
            (p.y / MESH_MERGE_EPS).floor() as i64,
        );
        let existing = self.index.get(&key).copied().or_else(|| {
            (-1..=1)
                .flat_map(|dx| (-1..=1).map(move |dy| (cell.0 + dx, cell.1 + dy)))
                .filter_map(|c| self.near.get(&c))
                .flat_map(|&(first, _)| {
                    std::iter::successors(Some(first), |&i| {
                        Some(self.next_near[i]).filter(|&n| n != usize::MAX)
                    })
                })
                .find(|&i| self.points[i].0.distance(p) <= MESH_MERGE_EPS)
        });
        if let Some(i) = existing {
            if kind == Kind::Rim {
                self.points[i].1 = Kind::Rim;
            }
            return i;
        }
        let i = self.points.len();
        self.points.push((p, kind));
        self.index.insert(key, i);
        self.next_near.push(usize::MAX);
        match self.near.get_mut(&cell) {
            Some((_, last)) => {
                self.next_near[*last] = i;
                *last = i;
            }
            None => {
                self.near.insert(cell, (i, i));
            }
        }
        i
    }

    /// Makes the constraints a planar straight-line graph: every crossing of two
    /// constraint segments becomes a vertex (on the outline when either segment is),
    /// and segments are split at the vertices lying on them. spade's own splitting
    /// (`add_constraint_and_split`) asserts on shallow crossings whose computed split
    /// point is off both lines, as where a stroke's centreline leaves its own
    /// footprint at a hooked, tapered end. Two passes catch crossings through new
    /// vertices; what rounding leaves is skipped by [`Self::triangulate`].
    fn resolve_crossings(&mut self) {
        for _ in 0..2 {
            if !self.split_pass() {
                break;
            }
        }
        let mut seen = std::collections::HashSet::<_, BuildHasherDefault<FxHasher>>::default();
        self.constraints
            .retain(|&([a, b], _)| a != b && seen.insert((a.min(b), a.max(b))));
    }

    /// One pass of [`Self::resolve_crossings`]: true when a crossing added a vertex.
    fn split_pass(&mut self) -> bool {
        let m = self.constraints.len();
        let boxes: Vec<Rect> = self
            .constraints
            .iter()
            .map(|&([a, b], _)| Rect::of_segment(self.points[a].0, self.points[b].0))
            .collect();
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by(|&i, &j| boxes[i].min.x.total_cmp(&boxes[j].min.x));
        let mut splits: Vec<Vec<(f64, usize)>> = vec![Vec::new(); m];
        let mut added = false;
        for (k, &i) in order.iter().enumerate() {
            for &j in &order[k + 1..] {
                if boxes[j].min.x > boxes[i].max.x {
                    break;
                }
                if boxes[i].touches(&boxes[j]) {
                    added |= self.split_pair(i, j, &mut splits);
                }
            }
        }
        let old = std::mem::take(&mut self.constraints);
        for (([a, b], kind), mut cuts) in old.into_iter().zip(splits) {
            cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut prev = a;
            for (_, v) in cuts.into_iter().chain(std::iter::once((1.0, b))) {
                if v != prev {
                    self.constraints.push(([prev, v], kind));
                    prev = v;
                }
            }
        }
        added
    }

    /// Records where constraints `i` and `j` meet: an end of one on the other, or a
    /// proper crossing (a new vertex). True when a vertex was added.
    fn split_pair(&mut self, i: usize, j: usize, splits: &mut [Vec<(f64, usize)>]) -> bool {
        let ([a0, a1], ka) = self.constraints[i];
        let ([b0, b1], kb) = self.constraints[j];
        let (a, b) = (self.points[a0].0, self.points[a1].0);
        let (c, d) = (self.points[b0].0, self.points[b1].0);
        let mut touching = false;
        for (k, ends, (s0, s1), (e0, e1), kind) in [
            (i, [(b0, c), (b1, d)], (a, b), (a0, a1), ka),
            (j, [(a0, a), (a1, b)], (c, d), (b0, b1), kb),
        ] {
            for (v, p) in ends {
                if v != e0
                    && v != e1
                    && let Some(t) = on_segment(p, s0, s1)
                {
                    splits[k].push((t, v));
                    touching = true;
                    // An end on the outline is on the rim (a groove wall's rung ending
                    // where collinear rim points were merged into one outline edge).
                    if kind == Kind::Rim {
                        self.points[v].1 = Kind::Rim;
                    }
                }
            }
        }
        let shared = a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1;
        if touching || shared {
            return false;
        }
        let (o1, o2) = (orient(c, d, a), orient(c, d, b));
        let (o3, o4) = (orient(a, b, c), orient(a, b, d));
        if !(o1 * o2 < 0.0 && o3 * o4 < 0.0) {
            return false;
        }
        let (t, u) = (o1 / (o1 - o2), o3 / (o3 - o4));
        let p = a + (b - a) * t;
        if !p.is_finite() {
            return false;
        }
        let p = p.clamp(self.rect.min, self.rect.max);
        let kind = if ka == Kind::Rim || kb == Kind::Rim {
            Kind::Rim
        } else {
            Kind::Plain
        };
        // A crossing at an end is that end.
        let end = [(a0, a), (a1, b), (b0, c), (b1, d)]
            .into_iter()
            .find(|&(_, q)| q.distance(p) <= MESH_SNAP_EPS);
        let v = match end {
            Some((v, _)) => v,
            None => self.point(p, kind),
        };
        if v != a0 && v != a1 {
            splits[i].push((t, v));
        }
        if v != b0 && v != b1 {
            splits[j].push((u, v));
        }
        end.is_none()
    }

    /// The constrained Delaunay triangulation of the points and constraints, built
    /// point by point in input order: deterministic, so an incremental tessellation
    /// equals a fresh one bit for bit (spade's bulk loader inserts the vertices it
    /// defers in hash-set order, which varies from run to run). Never panics:
    /// constraints still crossing after [`Self::resolve_crossings`] (rounding at
    /// near-coincident crossings) are left out, as are points spade cannot take.
    fn triangulate(&mut self) -> ConstrainedDelaunayTriangulation<Point2<f64>> {
        self.resolve_crossings();
        // Bulk loading keeps the vertex order (the points are distinct: `point` merges
        // repeats) and is several times faster than inserting one by one; it refuses
        // only invalid coordinates, for which the one-by-one insertion below skips the
        // offending points.
        let vertices: Vec<Point2<f64>> = self
            .points
            .iter()
            .map(|(p, _)| Point2::new(p.x, p.y))
            .collect();
        let edges: Vec<[usize; 2]> = self
            .constraints
            .iter()
            .map(|&(e, _)| e)
            .filter(|e| e[0] != e[1])
            .collect();
        if let Ok(cdt) =
            ConstrainedDelaunayTriangulation::try_bulk_load_cdt(vertices, edges, |_| {})
            && cdt.num_vertices() == self.points.len()
        {
            return cdt;
        }
        let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
        let handles: Vec<_> = self
            .points
            .iter()
            .map(|(p, _)| cdt.insert(Point2::new(p.x, p.y)).ok())
            .collect();
        for &([a, b], _) in &self.constraints {
            if let (Some(a), Some(b)) = (handles[a], handles[b])
                && a != b
            {
                cdt.try_add_constraint(a, b);
            }
        }
        cdt
    }

    fn hash_into(&self, h: &mut impl Hasher) {
        for (p, k) in &self.points {
            p.x.to_bits().hash(h);
            p.y.to_bits().hash(h);
            (*k == Kind::Rim).hash(h);
        }
        self.constraints.hash(h);
        self.interior_hidden.hash(h);
    }
}

fn rect_strictly_contains(r: &Rect, p: DVec2) -> bool {
    p.x > r.min.x && p.x < r.max.x && p.y > r.min.y && p.y < r.max.y
}

/// Where segment `s` meets the line `u = fixed` (or `v = fixed` when `along_u`): the
/// other coordinate, computed from the segment's canonical (sorted) end order so that
/// both cells sharing the line get the same bits. Ends lying on the line count too.
fn side_crossings(s: [DVec2; 2], fixed: f64, along_u: bool) -> Vec<f64> {
    let (mut a, mut b) = (s[0], s[1]);
    if (b.x, b.y) < (a.x, a.y) {
        std::mem::swap(&mut a, &mut b);
    }
    let (fa, fb, oa, ob) = if along_u {
        (a.y, b.y, a.x, b.x)
    } else {
        (a.x, b.x, a.y, b.y)
    };
    let mut out = Vec::new();
    if fa == fixed {
        out.push(oa);
    }
    if fb == fixed {
        out.push(ob);
    }
    if (fa < fixed && fb > fixed) || (fa > fixed && fb < fixed) {
        out.push(oa + (ob - oa) * (fixed - fa) / (fb - fa));
    }
    out
}

/// The part of segment `s` inside the closed rectangle, with ends on the sides computed
/// by [`side_crossings`] (so they match the side points exactly).
fn clip_segment(s: [DVec2; 2], r: &Rect) -> Option<(DVec2, DVec2)> {
    let d = s[1] - s[0];
    let mut cuts: Vec<(f64, DVec2)> = Vec::new();
    if r.contains(s[0]) {
        cuts.push((0.0, s[0]));
    }
    if r.contains(s[1]) {
        cuts.push((1.0, s[1]));
    }
    for (fixed, along_u, lo, hi) in [
        (r.min.x, false, r.min.y, r.max.y),
        (r.max.x, false, r.min.y, r.max.y),
        (r.min.y, true, r.min.x, r.max.x),
        (r.max.y, true, r.min.x, r.max.x),
    ] {
        for o in side_crossings(s, fixed, along_u) {
            if o < lo || o > hi {
                continue;
            }
            let p = if along_u {
                DVec2::new(o, fixed)
            } else {
                DVec2::new(fixed, o)
            };
            let t = if d.length_squared() > 0.0 {
                (p - s[0]).dot(d) / d.length_squared()
            } else {
                0.0
            };
            cuts.push((t, p));
        }
    }
    if cuts.len() < 2 {
        return None;
    }
    cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (a, b) = (cuts[0].1, cuts[cuts.len() - 1].1);
    if a == b {
        return None;
    }
    // A convex cell: the piece between the extreme cuts is inside.
    Some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::mesh::PatchMesh;
    use crate::sculpt::stroke::{Profile, StrokeInput, Tool};
    use crate::sculpt::surface::TargetSurface;
    use crate::sculpt::surface::test_surfaces::{plane, sphere, wavy};
    use crate::tolerance::{
        EXPORT_WELD_EPS, F32_EPS, GROOVE_TOL, MESH_DEPTH_TOL, MESH_HIT_EPS, TEST_WELD_EPS,
    };

    fn tool(mode: Mode, profile: Profile) -> Tool {
        Tool {
            profile,
            width: 0.1,
            depth: 0.02,
            mode,
            taper: 0.05,
        }
    }

    fn stroke(s: &TargetSurface, a: DVec3, b: DVec3, t: Tool) -> Stroke {
        let samples = (0..40)
            .map(|i| {
                let f = i as f64 / 39.0;
                (f, a.lerp(b, f))
            })
            .collect();
        Stroke::build(s, &StrokeInput { samples, tool: t }, 0.2).unwrap()
    }

    /// Depth below the plane z = 0 of the first hit of a ray coming down at (x, y).
    fn depth_at(mesh: &PatchMesh, x: f64, y: f64) -> f64 {
        let t = mesh
            .first_hit([x, y, 1.0], [0.0, 0.0, -1.0])
            .expect("a hit");
        t - 1.0
    }

    #[test]
    fn carved_groove_on_a_plane_has_tool_depth_and_no_cracks() {
        let s = plane(1.0);
        let a = stroke(
            &s,
            DVec3::new(0.2, 0.5, 0.0),
            DVec3::new(0.8, 0.5, 0.0),
            tool(Mode::Carve, Profile::V),
        );
        for detail in [Detail::Interactive, Detail::Final] {
            let mut tess = TargetTessellation::new(&s, 0, detail);
            let mut mesh = PatchMesh::new();
            tess.update(&s, &[(1, &a)], None, &mut mesh);
            // Groove bottom at the tool depth, half depth half-way to the rim, flat outside.
            assert_near!(depth_at(&mesh, 0.5, 0.5), 0.02, F32_EPS);
            assert_near!(depth_at(&mesh, 0.43, 0.5 + 0.025), 0.01, MESH_DEPTH_TOL);
            assert_near!(depth_at(&mesh, 0.5, 0.6), 0.0, F32_EPS);
            assert_near!(depth_at(&mesh, 0.1, 0.1), 0.0, F32_EPS);
            // Crack-free: the only open edges are the outer border of the square.
            let w = mesh.welded(EXPORT_WELD_EPS);
            let r = w.edge_report();
            assert_eq!(r.non_manifold, 0);
            assert_eq!(r.misoriented, 0);
            let border: usize = w
                .triangles
                .iter()
                .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
                .filter(|&(a, b)| {
                    let (p, q) = (
                        w.vertices[a as usize].position,
                        w.vertices[b as usize].position,
                    );
                    let on =
                        |x: f32| x.abs() < EXPORT_WELD_EPS || (x - 1.0).abs() < EXPORT_WELD_EPS;
                    (on(p[0]) && p[0] == q[0]) || (on(p[1]) && p[1] == q[1])
                })
                .count();
            assert_eq!(
                r.boundary, border,
                "{detail:?}: open edges inside the square"
            );
        }
    }

    #[test]
    fn crossing_grooves_take_the_deeper_and_emboss_rises() {
        let s = plane(1.0);
        let a = stroke(
            &s,
            DVec3::new(0.2, 0.5, 0.0),
            DVec3::new(0.8, 0.5, 0.0),
            tool(Mode::Carve, Profile::V),
        );
        let mut deep = tool(Mode::Carve, Profile::U);
        deep.depth = 0.03;
        let b = stroke(
            &s,
            DVec3::new(0.5, 0.2, 0.0),
            DVec3::new(0.5, 0.8, 0.0),
            deep,
        );
        let c = stroke(
            &s,
            DVec3::new(0.2, 0.2, 0.0),
            DVec3::new(0.4, 0.3, 0.0),
            tool(Mode::Emboss, Profile::U),
        );
        let mut tess = TargetTessellation::new(&s, 0, Detail::Final);
        let mut mesh = PatchMesh::new();
        tess.update(&s, &[(1, &a), (2, &b), (3, &c)], None, &mut mesh);
        assert_near!(depth_at(&mesh, 0.5, 0.5), 0.03, F32_EPS);
        // On a's axis, 0.03 from b's axis: b (U, r/w = 0.6) is 0.03 * 0.8 = 0.024 deep,
        // a's V bottom is 0.02: the deeper wins. (The U profile is sampled at a few
        // fractions of its half-width: its chord error is a few percent of the depth.)
        assert_near!(depth_at(&mesh, 0.53, 0.5), 0.024, MESH_HIT_EPS);
        assert_near!(depth_at(&mesh, 0.3, 0.25), -0.02, GROOVE_TOL);
        assert_eq!(mesh.welded(EXPORT_WELD_EPS).edge_report().non_manifold, 0);
    }

    #[test]
    fn only_changed_patches_are_rewritten() {
        let s = wavy(0.02);
        let a = stroke(
            &s,
            DVec3::new(0.2, 0.2, 0.0),
            DVec3::new(0.3, 0.2, 0.0),
            tool(Mode::Carve, Profile::V),
        );
        let b = stroke(
            &s,
            DVec3::new(0.7, 0.7, 0.0),
            DVec3::new(0.8, 0.7, 0.0),
            tool(Mode::Carve, Profile::V),
        );
        let mut tess = TargetTessellation::new(&s, 0, Detail::Interactive);
        let mut mesh = PatchMesh::new();
        let first = tess.update(&s, &[(1, &a)], None, &mut mesh);
        assert_eq!(
            first.patches_written,
            (tess.map().n() * tess.map().n()) as usize
        );
        let second = tess.update(&s, &[(1, &a), (2, &b)], Some(b.bounds), &mut mesh);
        assert!(second.patches_written > 0 && second.patches_written < first.patches_written / 2);
        // The incremental mesh equals a fresh one.
        let mut fresh = PatchMesh::new();
        TargetTessellation::new(&s, 0, Detail::Interactive).update(
            &s,
            &[(1, &a), (2, &b)],
            None,
            &mut fresh,
        );
        for ((ka, pa), (kb, pb)) in mesh.patches().zip(fresh.patches()) {
            assert_eq!(ka, kb);
            assert!(pa == pb, "patch {ka}: {pa:?}\n{pb:?}");
        }
        assert_eq!(mesh, fresh);
    }

    #[test]
    fn carved_sphere_is_watertight() {
        let s = sphere(1.0);
        let t = Tool {
            profile: Profile::V,
            width: 0.3,
            depth: 0.05,
            mode: Mode::Carve,
            taper: 0.1,
        };
        let a = stroke(
            &s,
            DVec3::new(-1.0, -0.3, 0.3),
            DVec3::new(-0.2, -1.0, -0.2),
            t.clone(),
        );
        let b = stroke(
            &s,
            DVec3::new(-0.6, -1.0, 0.3),
            DVec3::new(-1.0, 0.1, -0.3),
            t.clone(),
        );
        // Across the seam (u = 0 = 1 at -x): the groove wraps, still watertight.
        let c = stroke(
            &s,
            DVec3::new(-0.9, 0.45, 0.1),
            DVec3::new(-0.9, -0.4, -0.1),
            t,
        );
        assert_eq!(
            (c.bounds.min.x, c.bounds.max.x),
            (0.0, 1.0),
            "{:?}",
            c.bounds
        );
        let mut tess = TargetTessellation::new(&s, 0, Detail::Final);
        let mut mesh = PatchMesh::new();
        tess.update(&s, &[(1, &a), (2, &b), (3, &c)], None, &mut mesh);
        let r = mesh.welded(EXPORT_WELD_EPS).edge_report();
        assert!(r.is_watertight(), "{r:?}");
        let (v, _) = mesh.merged();
        assert!(
            v.iter()
                .all(|v| v.position.iter().chain(&v.normal).all(|x| x.is_finite()))
        );
    }

    /// The uv distance from `uv` to the nearest segment of `outline`.
    fn outline_distance(outline: &[[DVec2; 2]], uv: DVec2) -> f64 {
        outline
            .iter()
            .map(|s| super::super::jordan::point_segment_distance(uv, s[0], s[1]))
            .fold(f64::INFINITY, f64::min)
    }

    /// Triangles of a welded mesh as uv triangles (on `plane(1.0)` the position is the uv).
    fn uv_triangles(mesh: &PatchMesh) -> (Vec<[DVec2; 3]>, Vec<[u32; 3]>) {
        let w = mesh.welded(EXPORT_WELD_EPS);
        let uv = |i: u32| {
            let p = w.vertices[i as usize].position;
            DVec2::new(f64::from(p[0]), f64::from(p[1]))
        };
        (
            w.triangles.iter().map(|t| t.map(uv)).collect(),
            w.triangles.clone(),
        )
    }

    fn longest_edge(t: &[DVec2; 3]) -> f64 {
        (0..3)
            .map(|k| t[k].distance(t[(k + 1) % 3]))
            .fold(0.0, f64::max)
    }

    /// Regression for issue 20 (sawtooth rims: long thin fans ran from a groove's fine
    /// rim to the coarse root grid). The criterion, at both details, for a V and a U
    /// groove and a curved stroke on a plane:
    /// - every triangle with a vertex on the rim (the footprint outline) has all its
    ///   edges at most `RIM_REACH` times the rim spacing `h` (the larger of the longest
    ///   outline segment and the side of a leaf at the depth cap), shorter than a root
    ///   cell's side;
    /// - every triangle's size (longest edge) is at most `GRADE (h + d)`, `d` its
    ///   distance from the rim: sizes grow with the distance from the rim, one quadtree
    ///   level at a time (the balanced tree), not in a jump from the rim to a root cell
    ///   (a fan with a vertex on the rim and a root cell's side fails both checks).
    #[test]
    fn mesh_is_graded_from_the_rim_to_the_root_grid() {
        const RIM_REACH: f64 = 2.0;
        const GRADE: f64 = 2.5;
        let s = plane(1.0);
        let curved = {
            let samples = (0..60)
                .map(|i| {
                    let f = i as f64 / 59.0;
                    let a = f * 2.5;
                    (f, DVec3::new(0.5 + 0.3 * a.cos(), 0.5 + 0.3 * a.sin(), 0.0))
                })
                .collect();
            Stroke::build(
                &s,
                &StrokeInput {
                    samples,
                    tool: tool(Mode::Carve, Profile::V),
                },
                0.2,
            )
            .unwrap()
        };
        let straight_u = stroke(
            &s,
            DVec3::new(0.15, 0.3, 0.0),
            DVec3::new(0.85, 0.45, 0.0),
            tool(Mode::Carve, Profile::U),
        );
        let mut checked = 0;
        for st in [&curved, &straight_u] {
            for detail in [Detail::Interactive, Detail::Final] {
                let mut tess = TargetTessellation::new(&s, 0, detail);
                let mut mesh = PatchMesh::new();
                tess.update(&s, &[(1, st)], None, &mut mesh);
                let outline = tess.hidden().segments().to_vec();
                let n = f64::from(tess.map().n());
                let leaf = 1.0 / (n * f64::from(1u32 << detail.cap()));
                let rim_spacing = outline
                    .iter()
                    .map(|s| s[0].distance(s[1]))
                    .fold(0.0, f64::max);
                let h = rim_spacing.max(leaf);
                // A fan to the root grid would fail the test.
                assert!(1.0 / n > RIM_REACH * h, "{detail:?}: the test cannot fail");
                let (tris, _) = uv_triangles(&mesh);
                let on_rim = |p: DVec2| outline_distance(&outline, p) <= F32_EPS;
                for t in &tris {
                    if t.iter().any(|&p| on_rim(p)) {
                        checked += 1;
                        assert!(
                            longest_edge(t) <= RIM_REACH * h,
                            "{detail:?}: a triangle at the rim spans {} (rim spacing {h}): {t:?}",
                            longest_edge(t)
                        );
                    }
                }
                // Sizes grow with the distance from the rim, not in jumps.
                let mut worst: f64 = 0.0;
                for t in &tris {
                    let d = t
                        .iter()
                        .map(|&p| outline_distance(&outline, p))
                        .fold(f64::INFINITY, f64::min);
                    worst = worst.max(longest_edge(t) / (h + d));
                }
                assert!(
                    worst <= GRADE,
                    "{detail:?}: a triangle {worst} x (h + its distance)"
                );
                assert!(
                    worst <= GRADE,
                    "{detail:?}: neighbouring triangles differ {worst}x"
                );
            }
        }
        assert!(checked > 100, "only {checked} rim triangles");
    }

    /// Issue 20: normals come from the exact geometry, split at sharp edges. On a plane,
    /// a straight V groove's walls are planes: away from the tapered ends every corner
    /// of a wall triangle carries exactly its face's normal (no averaging across the
    /// crease or the rim), the flat target carries +z, and each bottom vertex is written
    /// twice, once per wall.
    #[test]
    fn v_groove_normals_are_exact_and_split_at_the_crease_and_rims() {
        let s = plane(1.0);
        let a = stroke(
            &s,
            DVec3::new(0.2, 0.5, 0.0),
            DVec3::new(0.8, 0.5, 0.0),
            tool(Mode::Carve, Profile::V),
        );
        for detail in [Detail::Interactive, Detail::Final] {
            let mut tess = TargetTessellation::new(&s, 0, detail);
            let mut mesh = PatchMesh::new();
            tess.update(&s, &[(1, &a)], None, &mut mesh);
            let (mut walls, mut flat, mut bottom) = (0, 0, Vec::new());
            for (_, patch) in mesh.patches() {
                for t in &patch.triangles {
                    let v = t.map(|i| patch.vertices[i as usize]);
                    let p = v.map(|v| DVec3::from_array(v.position.map(f64::from)));
                    let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                    let middle = p.iter().all(|q| q.x > 0.3 && q.x < 0.7);
                    let sunk = p.iter().any(|q| q.z < -f64::from(TEST_WELD_EPS));
                    for c in &v {
                        let n = DVec3::from_array(c.normal.map(f64::from));
                        if !sunk && p.iter().all(|q| (q.y - 0.5).abs() > 0.06) {
                            assert!(n.distance(DVec3::Z) < F32_EPS, "{detail:?}: flat {n}");
                            flat += 1;
                        }
                        if sunk && middle {
                            assert!(
                                n.distance(face) < MESH_DEPTH_TOL,
                                "{detail:?}: {n} on face {face} at {p:?}"
                            );
                            // The wall's slope: depth over half-width.
                            assert_near!(n.y.abs() / n.z, 0.02 / 0.05, MESH_DEPTH_TOL);
                            walls += 1;
                        }
                        if middle && (f64::from(c.position[2]) + 0.02).abs() < F32_EPS {
                            bottom.push(c.position.map(f32::to_bits));
                        }
                    }
                }
            }
            assert!(walls > 50 && flat > 50, "{detail:?}: {walls} {flat}");
            // Each bottom vertex appears with two normals (as two written vertices).
            let mut verts: Vec<([u32; 3], [u32; 3])> = Vec::new();
            for (_, patch) in mesh.patches() {
                for v in &patch.vertices {
                    if bottom.contains(&v.position.map(f32::to_bits)) {
                        verts.push((v.position.map(f32::to_bits), v.normal.map(f32::to_bits)));
                    }
                }
            }
            verts.sort_unstable();
            verts.dedup();
            let mut positions: Vec<[u32; 3]> = verts.iter().map(|v| v.0).collect();
            positions.dedup();
            assert!(positions.len() > 4, "{detail:?}: {}", positions.len());
            assert_eq!(
                verts.len(),
                2 * positions.len(),
                "{detail:?}: crease not split {verts:?}"
            );
        }
    }

    /// Issue 20: groove walls are triangulated as strips along the stroke. On a plane,
    /// a straight groove's profile sample lines are lines of constant distance from the
    /// centreline; every triangle inside the groove has its corners on those lines
    /// (leaf corners inside the strip are left out; the root grid's corners, which every
    /// cell keeps, are the exception), spans one profile interval across the stroke and
    /// at most one sample step along it. The quadtree's leaf corners, which the groove
    /// kept before, sat between the lines and failed this.
    #[test]
    fn groove_walls_are_strips_along_the_stroke() {
        let s = plane(1.0);
        let mut checked = 0;
        for profile in [Profile::V, Profile::U] {
            let a = stroke(
                &s,
                DVec3::new(0.2, 0.5, 0.0),
                DVec3::new(0.8, 0.5, 0.0),
                tool(Mode::Carve, profile.clone()),
            );
            let step = a
                .centre_uv
                .windows(2)
                .map(|w| w[0].distance(w[1]))
                .fold(0.0, f64::max);
            let hw = a.half_width[a.half_width.len() / 2];
            for detail in [Detail::Interactive, Detail::Final] {
                let mut levels = vec![0.0];
                levels.extend_from_slice(detail.profile_lines(profile.is_curved()));
                levels.push(1.0);
                let level_of = |y: f64| {
                    let f = (y - 0.5).abs() / hw;
                    levels.iter().position(|&l| (l - f).abs() <= F32_EPS / hw)
                };
                let mut tess = TargetTessellation::new(&s, 0, detail);
                let mut mesh = PatchMesh::new();
                tess.update(&s, &[(1, &a)], None, &mut mesh);
                let n = f64::from(tess.map().n());
                let on_grid = |x: f64| ((x * n).round() - x * n).abs() <= F32_EPS * n;
                let (tris, _) = uv_triangles(&mesh);
                for t in &tris {
                    let centre = (t[0] + t[1] + t[2]) / 3.0;
                    let inside =
                        (centre.y - 0.5).abs() < hw && t.iter().all(|p| p.x > 0.3 && p.x < 0.7);
                    if !inside || t.iter().any(|p| on_grid(p.x) && on_grid(p.y)) {
                        continue;
                    }
                    let lv: Vec<usize> = t
                        .iter()
                        .map(|p| {
                            level_of(p.y).unwrap_or_else(|| {
                                panic!("{profile:?} {detail:?}: corner {p} off the profile lines")
                            })
                        })
                        .collect();
                    let (lo, hi) = (lv.iter().min().unwrap(), lv.iter().max().unwrap());
                    assert!(
                        hi - lo <= 1,
                        "{profile:?} {detail:?}: {t:?} spans {lo}..{hi}"
                    );
                    let (x0, x1) = t
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                            (a.min(p.x), b.max(p.x))
                        });
                    assert!(
                        x1 - x0 <= step + F32_EPS,
                        "{profile:?} {detail:?}: {t:?} along"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 200, "only {checked} groove triangles");
    }
}
