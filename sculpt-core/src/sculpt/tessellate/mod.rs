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

mod clip;
mod grid;
mod height;
mod input;
mod normals;
mod patch;
mod poles;
mod roots;
mod sides;
#[cfg(test)]
mod tests;

pub(crate) use grid::GRID_MARGIN;
pub use grid::{GridPlan, MAX_GRID, MAX_REFINE, MIN_GRID, chord_errors};
pub use height::height;
pub(crate) use poles::pole_height;
pub use sides::{FixedSides, SideVertex};

use super::hidden::HiddenRegion;
use super::jordan::{Rect, Region};
use super::stroke::Stroke;
use super::surface::{ParamSurface, SurfaceExtent, extent};
use super::uvmap::UvMap;
use crate::mesh::{MeshSink, PatchKey};
use crate::tolerance::{FINAL_CHORD_FRACTION, INTERACTIVE_CHORD_FRACTION};
use height::{EvalCache, FxMap};
use poles::{pole_point, pole_sides, pole_uv};
use rustc_hash::FxHasher;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

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
    /// Vertices fixed along the sides of the square ([`Self::set_fixed_sides`]).
    fixed: FixedSides,
    /// The fixed sides changed since the last pass (their cells are rewritten).
    fixed_changed: [bool; 4],
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
            fixed: Default::default(),
            fixed_changed: [false; 4],
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

    /// True before the first update (nothing written yet).
    pub fn is_fresh(&self) -> bool {
        self.signatures.iter().all(Option::is_none)
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
        let fixed_changed = std::mem::take(&mut self.fixed_changed);
        for r in 0..n * n {
            if pole_rows.iter().any(|&side| self.root_on_side(r, side))
                || (0..4).any(|side| fixed_changed[side] && self.root_on_side(r, side))
            {
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
            self.hash_fixed(root, &mut h);
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
}
