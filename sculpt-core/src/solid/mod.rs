//! Solid targets: an implicit solid ([`crate::implicit`], a JSON solid document or a
//! `.vm` model) that chisel strokes carve through.
//!
//! A [`SolidTarget`] is its model's field omega (positive inside, the paper's
//! convention: Shin, Kim and Sheen 2007) combined, stroke by stroke, with each stroke's
//! swept tool solid ([`tool::SweptTool`]) by R-functions: a carve is `min(omega, -g)`
//! (AND NOT), an emboss `max(omega, g)` (OR), the min/max system R_1 of sec. 2.2.2.
//! Unlike a groove trimmed into a NURBS surface, a groove deeper than the wall opens a
//! hole.
//!
//! The field is meshed on a grid over the solid's box ([`blocks`]), in blocks of
//! [`blocks::BLOCK`] cells that are meshed alone and welded by grid edge, so the mesh is
//! closed and manifold. A stroke looks only at the blocks its tool's box meets and
//! re-meshes only those whose corner values it changes; the other blocks keep their
//! meshes, which weld to the new ones by grid edge as before. A block is first bounded
//! by interval arithmetic over its box ([`Tape::simplify`]): one that is surely all
//! outside (or all inside, away from the grid's faces) is decided without corner
//! values, the rest evaluated on the tape pruned for the box. The corner values of the
//! blocks a stroke reaches are kept, so the next stroke there combines only its own
//! tool into them, and the tool is evaluated only at corners it can change
//! ([`SweptTool::apply`]: a distance bound per segment, per sub-box and per corner).
//! The result equals the plain evaluation of every corner against every segment
//! ([`SolidTarget::remesh_reference`]) bit for bit.
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::solid::SolidTarget;
//! use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
//!
//! let plate = r#"{"version": 1, "solid": {"box": {"min": [-0.3, -0.3, -0.01], "max": [0.3, 0.3, 0.01]}}}"#;
//! let mut solid = SolidTarget::new(plate, 64)?;
//! let before = solid.mesh();
//! let tool = Tool { profile: Profile::V, width: 0.08, depth: 0.05, mode: Mode::Carve, taper: 0.0 };
//! let samples = (0..=10).map(|i| (i as f64, DVec3::new(-0.1 + 0.02 * i as f64, 0.0, 0.01))).collect();
//! solid.cut(7, &StrokeInput { samples, tool })?;
//! // The groove is deeper than the 2 cm plate: a hole (one handle more).
//! assert_eq!(sculpt_core::solid::euler_characteristic(&before), 2);
//! assert_eq!(sculpt_core::solid::euler_characteristic(&solid.mesh()), 0);
//! # Ok::<(), sculpt_core::solid::SolidError>(())
//! ```

pub mod blocks;
pub mod tool;

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use crate::implicit::Model;
use crate::implicit::interval::Interval;
use crate::implicit::tape::Tape;
use crate::mesh::{MeshSink, MeshVertex, PatchKey, WeldedMesh};
use crate::sculpt::stroke::{Mode, StrokeInput};
use crate::tolerance::{
    SOLID_BOUNDS_DEPTH, SOLID_BOUNDS_SAMPLES, SOLID_MARGIN_CELLS, SOLID_NORMAL_STEP_CELLS,
    SOLID_RAY_BISECTIONS, SOLID_RAY_STEP_CELLS, SOLID_SEARCH_HALF_SIZE,
};
use blocks::{BlockMesh, GridFrame, TetTable};
use tool::SweptTool;

/// Fewest and most grid cells along a solid's longest side.
pub const CELLS_RANGE: std::ops::RangeInclusive<usize> = 8..=1024;
/// The default cells along a solid's longest side.
pub const DEFAULT_CELLS: usize = 128;
/// Most strokes one solid holds.
pub const MAX_SOLID_CUTS: usize = 10_000;

pub use crate::error::{ModelError, SolidError};

/// One stroke applied to a solid.
#[derive(Debug, Clone, PartialEq)]
pub struct Cut {
    /// The stroke's id in its document.
    pub id: u64,
    /// The stroke as made (wand samples and tool).
    pub input: StrokeInput,
    /// Its tool solid.
    pub tool: SweptTool,
}

/// Most blocks whose corner values a solid keeps for the next stroke (16^3 cells:
/// 4,913 f32 values, about 20 kB, a block; 40 MB in all).
pub const MAX_CACHED_BLOCKS: usize = 2048;

/// What a stroke did to the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Remeshed {
    /// Blocks the tool's box reaches (each looked at).
    pub reached: usize,
    /// Of those, blocks whose values changed, re-meshed (the rest keep their mesh).
    pub blocks: usize,
    /// Of the reached, blocks decided by interval arithmetic alone.
    pub pruned: usize,
}

/// An implicit solid with the strokes carved into it (see the module docs).
#[derive(Debug, Clone)]
pub struct SolidTarget {
    text: String,
    tape: Tape,
    frame: GridFrame,
    table: TetTable,
    meshes: Vec<BlockMesh>,
    cuts: Vec<Cut>,
    /// Each block's meshing stamp ([`Self::block_stamps`]).
    stamps: Vec<u64>,
    /// Corner values of blocks a stroke reached, for the strokes in `cuts` (at most
    /// [`MAX_CACHED_BLOCKS`]): the next stroke there combines only its own tool.
    values: HashMap<usize, Vec<f32>>,
    /// Process-unique number of the solid's current strokes (new at every change of
    /// `cuts`), so a preview's evaluated values are used only on the solid they came from.
    revision: u64,
}

/// One block's new state from [`SolidTarget::remesh`].
struct Redone {
    /// The block.
    b: usize,
    /// Its new mesh, `None` when its mesh stays.
    mesh: Option<BlockMesh>,
    /// Its corner values, `None` when interval arithmetic decided it.
    values: Option<Vec<f32>>,
    /// Whether interval arithmetic decided it.
    pruned: bool,
}

/// The next block meshing stamp ([`SolidTarget::block_stamps`]): one counter for the
/// process (an atomic, so solids on several threads stay unique). Stamps start at 1, so a
/// view's 0 means "not written".
fn next_stamp() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl PartialEq for SolidTarget {
    fn eq(&self, other: &Self) -> bool {
        self.text == other.text && self.frame == other.frame && self.cuts == other.cuts
    }
}

impl SolidTarget {
    /// Reads `text` (a solid document or a `.vm` model, [`Model::from_text`]), finds
    /// its box and meshes it on a grid of `cells` along the box's longest side.
    pub fn new(text: &str, cells: usize) -> Result<Self, SolidError> {
        if !CELLS_RANGE.contains(&cells) {
            return Err(SolidError::Cells {
                cells,
                min: *CELLS_RANGE.start(),
                max: *CELLS_RANGE.end(),
            });
        }
        let tape = Model::from_text(text)?.tape_positive_inside();
        let (lo, hi) = solid_bounds(&tape).ok_or(SolidError::Empty {
            half_size: SOLID_SEARCH_HALF_SIZE,
        })?;
        let size = hi - lo;
        // Pad by the margin so the surface stays off the grid's outer layer.
        let h = size.max_element() / (cells - 2 * SOLID_MARGIN_CELLS) as f64;
        let pad = DVec3::splat(h * SOLID_MARGIN_CELLS as f64);
        let n = ((size + 2.0 * pad) / h)
            .ceil()
            .to_array()
            .map(|k| (k as usize).max(1));
        let frame = GridFrame { lo: lo - pad, h, n };
        let nb = frame.blocks();
        let mut solid = Self {
            text: text.to_string(),
            tape,
            frame,
            table: TetTable::new(),
            meshes: vec![BlockMesh::default(); nb[0] * nb[1] * nb[2]],
            cuts: Vec::new(),
            stamps: vec![0; nb[0] * nb[1] * nb[2]],
            values: HashMap::new(),
            revision: next_stamp(),
        };
        solid.remesh_all();
        Ok(solid)
    }

    /// The model's text, as given.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The grid: box corner, cell size and cells per axis.
    pub fn frame(&self) -> &GridFrame {
        &self.frame
    }

    /// Cells along the longest side (what [`Self::new`] was given).
    pub fn cells(&self) -> usize {
        self.frame.n.iter().copied().max().unwrap_or(0)
    }

    /// The strokes applied, in order.
    pub fn cuts(&self) -> &[Cut] {
        &self.cuts
    }

    /// The combined field at `p` (positive inside), as the mesh samples it.
    pub fn eval(&self, p: DVec3) -> f32 {
        let pf = p.as_vec3().to_array();
        let mut v = self.tape.eval_point(pf);
        apply_cuts(&self.cuts, DVec3::from(pf.map(f64::from)), &mut v);
        v
    }

    /// Carves (or embosses) the stroke `input` with id `id` and re-meshes the blocks its
    /// tool reaches. Samples must lie within [`crate::sculpt::document::snap_distance`]
    /// of the solid's surface. A refused stroke leaves the solid unchanged.
    pub fn cut(&mut self, id: u64, input: &StrokeInput) -> Result<Remeshed, SolidError> {
        if self.cuts.len() >= MAX_SOLID_CUTS {
            return Err(SolidError::TooManyCuts {
                max: MAX_SOLID_CUTS,
            });
        }
        let tool = self.tool_of(input)?;
        let touched = self.blocks_of(&tool);
        self.cuts.push(Cut {
            id,
            input: input.clone(),
            tool,
        });
        Ok(self.remesh(&touched, true, true))
    }

    /// The tool solid of `input` on this solid (samples within
    /// [`crate::sculpt::document::snap_distance`] of the surface).
    fn tool_of(&self, input: &StrokeInput) -> Result<SweptTool, SolidError> {
        let size = self.frame.h * self.cells() as f64;
        let snap = crate::sculpt::document::snap_distance(&input.tool, size);
        let margin = self.frame.h * SOLID_MARGIN_CELLS as f64;
        SweptTool::new(&self.tape, input, snap, margin)
    }

    /// What [`Self::cut`] of `input` would make of the blocks it changes, leaving the
    /// solid as it is: the live groove shown while a stroke is drawn. The blocks'
    /// values before the stroke are taken from the kept values, from `previous` (the
    /// preview of the same stroke with fewer samples, on the solid as it is now) or
    /// evaluated; the new preview keeps them for the next one. Each block's mesh equals
    /// the one [`Self::cut`] would give it. A stroke `cut` would refuse is refused.
    pub fn preview(
        &self,
        input: &StrokeInput,
        previous: Option<SolidPreview>,
    ) -> Result<SolidPreview, SolidError> {
        let cut = Cut {
            id: 0,
            input: input.clone(),
            tool: self.tool_of(input)?,
        };
        let mut base = previous
            .filter(|p| p.revision == self.revision)
            .map(|p| p.base)
            .unwrap_or_default();
        let nb = self.frame.blocks();
        let touched = self.blocks_of(&cut.tool);
        let job = |&b: &usize| {
            let idx = [b % nb[0], (b / nb[0]) % nb[1], b / (nb[0] * nb[1])];
            let before = match (self.values.get(&b), base.get(&b)) {
                (Some(v), _) | (None, Some(v)) => Some(v.clone()),
                (None, None) => None,
            };
            let (after, fresh) = match before {
                Some(mut values) => {
                    let m = self.block_size(idx);
                    let changed = cut.tool.apply(&self.block_points(idx), m, &mut values);
                    (changed.then_some(values), None)
                }
                None => {
                    let fresh = self.evaluate(idx);
                    let after = self.evaluate_with(idx, Some(&cut));
                    (after.filter(|a| Some(a) != fresh.as_ref()), fresh)
                }
            };
            let mesh = after.map(|v| self.frame.march(idx, &v, &self.table));
            (b, mesh, fresh)
        };
        #[cfg(feature = "parallel")]
        let done: Vec<(usize, Option<BlockMesh>, Option<Vec<f32>>)> = {
            use rayon::prelude::*;
            touched.par_iter().map(job).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let done: Vec<(usize, Option<BlockMesh>, Option<Vec<f32>>)> =
            touched.iter().map(job).collect();
        let mut blocks = Vec::new();
        for (b, mesh, fresh) in done {
            if let Some(v) = fresh.filter(|_| base.len() < MAX_CACHED_BLOCKS) {
                base.insert(b, v);
            }
            if let Some(mesh) = mesh.filter(|m| *m != self.meshes[b]) {
                blocks.push((b, mesh, next_stamp()));
            }
        }
        Ok(SolidPreview {
            cut,
            blocks,
            base,
            revision: self.revision,
        })
    }

    /// Writes block `k` of `preview` ([`SolidPreview::blocks`]) into `sink` as the
    /// patch `key`, as [`Self::write_block`] writes the solid's own blocks, with normals
    /// from the field with the previewed stroke; a block with no triangles is removed
    /// from `sink` instead. Returns whether a patch was written.
    pub fn write_preview_block(
        &self,
        preview: &SolidPreview,
        k: usize,
        key: PatchKey,
        sink: &mut dyn MeshSink,
    ) -> bool {
        let Some((_, block, _)) = preview.blocks.get(k) else {
            sink.remove_patch(key);
            return false;
        };
        let field = |p: DVec3| {
            let mut v = self.eval(p);
            let pf = DVec3::from(p.as_vec3().to_array().map(f64::from));
            apply_cut(&preview.cut, pf, &mut v);
            v
        };
        self.write_mesh(block, key, sink, field)
    }

    /// Removes the last stroke and re-meshes where it was (evaluating those blocks
    /// again from the model and the strokes left); it is returned.
    pub fn uncut(&mut self) -> Option<Cut> {
        let cut = self.cuts.pop()?;
        let touched = self.blocks_of(&cut.tool);
        self.remesh(&touched, false, true);
        Some(cut)
    }

    /// Puts back a stroke taken by [`Self::uncut`].
    pub fn recut(&mut self, cut: Cut) -> Remeshed {
        let touched = self.blocks_of(&cut.tool);
        self.cuts.push(cut);
        self.remesh(&touched, true, true)
    }

    /// Re-evaluates and re-meshes every block (what [`Self::new`] does; a stroke
    /// re-meshes only the blocks it changes, and gives the same mesh). Forgets the
    /// corner values kept for strokes.
    pub fn remesh_all(&mut self) -> Remeshed {
        self.values.clear();
        let all: Vec<usize> = (0..self.meshes.len()).collect();
        self.remesh(&all, false, false)
    }

    /// Re-evaluates every block the plain way, the reference the fast paths must equal:
    /// each corner of each block not decided by interval arithmetic takes the model's
    /// value and then, stroke by stroke, [`SweptTool::value_among`] over every segment
    /// reaching the block, with no bound on the tool; then every block is re-meshed.
    /// Forgets the kept corner values.
    pub fn remesh_reference(&mut self) {
        self.values.clear();
        self.revision = next_stamp();
        let nb = self.frame.blocks();
        for b in 0..self.meshes.len() {
            let idx = [b % nb[0], (b / nb[0]) % nb[1], b / (nb[0] * nb[1])];
            let values = self.reference_values(b);
            self.meshes[b] = values.map_or_else(BlockMesh::default, |v| {
                self.frame.march(idx, &v, &self.table)
            });
            self.stamps[b] = next_stamp();
        }
    }

    /// Block `b`'s corner values (x fastest over its corner range) as kept for the next
    /// stroke, if kept (blocks a stroke reached and interval arithmetic did not decide).
    pub fn block_values(&self, b: usize) -> Option<&[f32]> {
        self.values.get(&b).map(Vec::as_slice)
    }

    /// Block `b`'s corner values the plain way ([`Self::remesh_reference`]); `None`
    /// when interval arithmetic decides the block (or `b` is out of range).
    pub fn reference_values(&self, b: usize) -> Option<Vec<f32>> {
        let nb = self.frame.blocks();
        if b >= self.meshes.len() {
            return None;
        }
        let idx = [b % nb[0], (b / nb[0]) % nb[1], b / (nb[0] * nb[1])];
        let (box_lo, box_hi) = self.block_box(idx);
        let cuts: Vec<(&Cut, Vec<usize>)> = self
            .cuts
            .iter()
            .filter_map(|c| {
                let segments = c.tool.segments_near(box_lo, box_hi);
                (!segments.is_empty()).then_some((c, segments))
            })
            .collect();
        let only_carves = cuts.iter().all(|(c, _)| c.tool.mode == Mode::Carve);
        let pruned = self.decide(idx, cuts.is_empty(), only_carves)?;
        let points = self.block_points(idx);
        let mut values = vec![0f32; points.len()];
        pruned.eval_points(&points, &mut values);
        for (p, v) in points.iter().zip(values.iter_mut()) {
            let p = DVec3::from(p.map(f64::from));
            for (c, segments) in &cuts {
                let g = c.tool.value_among(p, segments.iter().copied());
                combine(c.tool.mode, g, v);
            }
        }
        Some(values)
    }

    /// The whole mesh, welded: closed, 2-manifold, wound outward.
    pub fn mesh(&self) -> WeldedMesh {
        blocks::weld(self.meshes.iter())
    }

    /// Blocks per axis, and each block's mesh (x fastest).
    pub fn block_meshes(&self) -> ([usize; 3], &[BlockMesh]) {
        (self.frame.blocks(), &self.meshes)
    }

    /// Each block's meshing stamp (x fastest, as [`Self::block_meshes`]): a number
    /// unique in the process for each time a block is meshed, so equal stamps mean the
    /// same block mesh, in this solid or a clone of it. A view keeps the stamps it wrote
    /// and writes again only the blocks whose stamp differs; it needs no `&mut` to the
    /// solid, and a solid swapped for another is never mistaken for it.
    pub fn block_stamps(&self) -> &[u64] {
        &self.stamps
    }

    /// The outward unit normal of the combined field at `p`: minus its gradient, by
    /// central differences of [`Self::eval`] with a step of
    /// [`SOLID_NORMAL_STEP_CELLS`] cells (the tool functions have no tape to
    /// differentiate); zero where the differences vanish.
    pub fn normal(&self, p: DVec3) -> DVec3 {
        field_normal(|q| self.eval(q), p, self.frame.h)
    }

    /// Where the ray `origin + t dir` (`dir` a unit vector, `t >= 0`) first enters the
    /// solid: marched through the grid's box in steps of [`SOLID_RAY_STEP_CELLS`] cells
    /// on [`Self::eval`], the step where the field turns positive bisected
    /// [`SOLID_RAY_BISECTIONS`] times. Returns `t`, the point and the outward normal
    /// there ([`Self::normal`]); `None` when the ray misses (or starts inside).
    pub fn cast(&self, origin: DVec3, dir: DVec3) -> Option<(f64, DVec3, DVec3)> {
        let f = &self.frame;
        let lo = f.lo;
        let hi = f.lo + DVec3::from(f.n.map(|k| k as f64)) * f.h;
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            let (ta, tb) = ((lo[a] - origin[a]) / dir[a], (hi[a] - origin[a]) / dir[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if t0.is_nan() || t0 > t1 {
            return None;
        }
        let step = f.h * SOLID_RAY_STEP_CELLS;
        let inside = |t: f64| self.eval(origin + dir * t) > 0.0;
        if inside(t0) {
            return None;
        }
        let mut t = t0;
        while t < t1 {
            let next = (t + step).min(t1);
            if inside(next) {
                let (mut a, mut b) = (t, next);
                for _ in 0..SOLID_RAY_BISECTIONS {
                    let m = 0.5 * (a + b);
                    if inside(m) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                let p = origin + dir * b;
                return Some((b, p, self.normal(p)));
            }
            t = next;
        }
        None
    }

    /// Writes block `b`'s mesh (an index into [`Self::block_meshes`]) into `sink` as the
    /// patch `key`, with the field's normals ([`Self::normal`]) and no surface
    /// parameter; a block with no triangles is removed from `sink` instead. Returns
    /// whether a patch was written. Blocks share their vertices' positions and normals
    /// bit for bit where they meet (both come from the grid edge alone), so the drawn
    /// mesh shows no seam.
    pub fn write_block(&self, b: usize, key: PatchKey, sink: &mut dyn MeshSink) -> bool {
        let Some(block) = self.meshes.get(b) else {
            sink.remove_patch(key);
            return false;
        };
        self.write_mesh(block, key, sink, |p| self.eval(p))
    }

    /// Writes `block` into `sink` as the patch `key` with the normals of the field
    /// `field` ([`field_normal`]), or removes the patch when `block` has no triangles.
    fn write_mesh(
        &self,
        block: &BlockMesh,
        key: PatchKey,
        sink: &mut dyn MeshSink,
        field: impl Fn(DVec3) -> f32,
    ) -> bool {
        if block.triangles.is_empty() {
            sink.remove_patch(key);
            return false;
        }
        sink.begin_patch(key);
        for &(_, position) in &block.vertices {
            let n = field_normal(&field, DVec3::from(position.map(f64::from)), self.frame.h);
            sink.push_vertex(MeshVertex {
                position,
                normal: n.as_vec3().to_array(),
                uv: [0.0; 2],
            });
        }
        for t in &block.triangles {
            sink.push_triangle(t[0], t[1], t[2]);
        }
        sink.end_patch();
        true
    }

    /// The blocks the box of `tool` reaches, widened by a cell so that a corner on a
    /// block face the box passes within f32 rounding of is re-evaluated in both blocks.
    fn blocks_of(&self, tool: &SweptTool) -> Vec<usize> {
        let (lo, hi) = tool.bounds();
        let pad = DVec3::splat(self.frame.h);
        let nb = self.frame.blocks();
        let Some((first, last)) = self.frame.blocks_in(lo - pad, hi + pad) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for k in first[2]..=last[2] {
            for j in first[1]..=last[1] {
                for i in first[0]..=last[0] {
                    out.push(i + nb[0] * (j + nb[1] * k));
                }
            }
        }
        out
    }

    /// Re-evaluates the blocks `which` and re-meshes those whose values changed. With
    /// `last_only`, a block whose corner values are kept combines only the last cut
    /// into them ([`SweptTool::apply`]); the others are evaluated from the model and
    /// every cut ([`Self::evaluate`]). With `keep`, the values are kept for the next
    /// stroke.
    fn remesh(&mut self, which: &[usize], last_only: bool, keep: bool) -> Remeshed {
        self.revision = next_stamp();
        let nb = self.frame.blocks();
        let last = self.cuts.last().filter(|_| last_only);
        let job = |&b: &usize| -> Redone {
            let idx = [b % nb[0], (b / nb[0]) % nb[1], b / (nb[0] * nb[1])];
            if let (Some(cut), Some(old)) = (last, self.values.get(&b)) {
                let mut values = old.clone();
                let points = self.block_points(idx);
                let m = self.block_size(idx);
                let mesh = cut
                    .tool
                    .apply(&points, m, &mut values)
                    .then(|| self.frame.march(idx, &values, &self.table));
                return Redone {
                    b,
                    mesh,
                    values: Some(values),
                    pruned: false,
                };
            }
            let values = self.evaluate(idx);
            let mesh = values.as_ref().map_or_else(BlockMesh::default, |v| {
                self.frame.march(idx, v, &self.table)
            });
            Redone {
                b,
                pruned: values.is_none(),
                mesh: (mesh != self.meshes[b]).then_some(mesh),
                values,
            }
        };
        #[cfg(feature = "parallel")]
        let done: Vec<Redone> = {
            use rayon::prelude::*;
            which.par_iter().map(job).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let done: Vec<Redone> = which.iter().map(job).collect();
        if keep && self.values.len() + done.len() > MAX_CACHED_BLOCKS {
            let now: HashSet<usize> = which.iter().copied().collect();
            self.values.retain(|b, _| now.contains(b));
        }
        let mut r = Remeshed {
            reached: which.len(),
            blocks: 0,
            pruned: 0,
        };
        for d in done {
            r.pruned += usize::from(d.pruned);
            if let Some(mesh) = d.mesh {
                r.blocks += 1;
                self.meshes[d.b] = mesh;
                self.stamps[d.b] = next_stamp();
            }
            match d.values {
                Some(v) if keep && self.values.len() < MAX_CACHED_BLOCKS => {
                    self.values.insert(d.b, v);
                }
                _ => {
                    self.values.remove(&d.b);
                }
            }
        }
        r
    }

    /// The box of block `b` (metres, its corners as the field reads them).
    fn block_box(&self, b: [usize; 3]) -> (DVec3, DVec3) {
        let (lo, hi) = self.frame.block_corners(b);
        let (plo, phi) = (self.frame.corner(lo), self.frame.corner(hi));
        (
            DVec3::from(plo.map(f64::from)),
            DVec3::from(phi.map(f64::from)),
        )
    }

    /// Corners per axis of block `b`.
    fn block_size(&self, b: [usize; 3]) -> [usize; 3] {
        let (lo, hi) = self.frame.block_corners(b);
        [0, 1, 2].map(|a| hi[a] - lo[a] + 1)
    }

    /// The positions of block `b`'s corners, x fastest.
    fn block_points(&self, b: [usize; 3]) -> Vec<[f32; 3]> {
        let (lo, hi) = self.frame.block_corners(b);
        let m = self.block_size(b);
        let mut points = Vec::with_capacity(m[0] * m[1] * m[2]);
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    points.push(self.frame.corner([i, j, k]));
                }
            }
        }
        points
    }

    /// The model's tape pruned for block `b`, or `None` when interval arithmetic over
    /// the block's box decides it: surely outside with only carves reaching it (carving
    /// only removes material, so it stays empty), or surely inside, away from the grid's
    /// faces, with no cut reaching it (full). Either way it has no triangles.
    fn decide(&self, b: [usize; 3], no_cuts: bool, only_carves: bool) -> Option<Tape> {
        let f = &self.frame;
        let (lo, hi) = f.block_corners(b);
        let (plo, phi) = (f.corner(lo), f.corner(hi));
        let region = [0, 1, 2].map(|a| Interval::new(plo[a], phi[a]));
        let (range, pruned) = self.tape.simplify(region);
        if !range.nan {
            let on_face = (0..3).any(|a| lo[a] == 0 || hi[a] == f.n[a]);
            if (range.hi <= 0.0 && only_carves) || (range.lo > 0.0 && !on_face && no_cuts) {
                return None;
            }
        }
        Some(pruned)
    }

    /// Block `b`'s corner values from the model and every cut reaching it (each
    /// combined by [`SweptTool::apply`], equal to the plain way,
    /// [`Self::reference_values`]); `None` when interval arithmetic decides it.
    fn evaluate(&self, b: [usize; 3]) -> Option<Vec<f32>> {
        self.evaluate_with(b, None)
    }

    /// [`Self::evaluate`] with `extra` as one cut more, after the others.
    fn evaluate_with(&self, b: [usize; 3], extra: Option<&Cut>) -> Option<Vec<f32>> {
        let (box_lo, box_hi) = self.block_box(b);
        let reaching = |c: &&Cut| !c.tool.segments_near(box_lo, box_hi).is_empty();
        let cuts: Vec<&Cut> = self.cuts.iter().chain(extra).filter(reaching).collect();
        let only_carves = cuts.iter().all(|c| c.tool.mode == Mode::Carve);
        let pruned = self.decide(b, cuts.is_empty(), only_carves)?;
        let points = self.block_points(b);
        let m = self.block_size(b);
        let mut values = vec![0f32; points.len()];
        pruned.eval_points(&points, &mut values);
        for c in cuts {
            c.tool.apply(&points, m, &mut values);
        }
        Some(values)
    }
}

/// The outward unit normal of `field` (positive inside) at `p`: minus its gradient by
/// central differences with a step of [`SOLID_NORMAL_STEP_CELLS`] cells of edge `h`;
/// zero where the differences vanish.
fn field_normal(field: impl Fn(DVec3) -> f32, p: DVec3, h: f64) -> DVec3 {
    let d = h * SOLID_NORMAL_STEP_CELLS;
    let g = DVec3::new(
        f64::from(field(p + DVec3::X * d) - field(p - DVec3::X * d)),
        f64::from(field(p + DVec3::Y * d) - field(p - DVec3::Y * d)),
        f64::from(field(p + DVec3::Z * d) - field(p - DVec3::Z * d)),
    );
    (-g).normalize_or_zero()
}

/// A stroke shown on a solid before it is applied ([`SolidTarget::preview`]).
#[derive(Debug, Clone)]
pub struct SolidPreview {
    /// The stroke as a cut (id 0).
    cut: Cut,
    /// The blocks whose mesh the stroke changes: block, its mesh with the stroke, and a
    /// meshing stamp (process-unique, as [`SolidTarget::block_stamps`]).
    blocks: Vec<(usize, BlockMesh, u64)>,
    /// The values of blocks before the stroke that the solid did not keep.
    base: HashMap<usize, Vec<f32>>,
    /// The solid's revision they belong to.
    revision: u64,
}

impl SolidPreview {
    /// The blocks whose mesh the stroke changes, with their meshes and meshing stamps
    /// (a view writes a block again when its stamp differs from the one it wrote).
    pub fn blocks(&self) -> impl Iterator<Item = (usize, &BlockMesh, u64)> {
        self.blocks.iter().map(|(b, m, s)| (*b, m, *s))
    }

    /// The previewed stroke as a cut.
    pub fn cut(&self) -> &Cut {
        &self.cut
    }
}

/// Every cut in order at `p`.
fn apply_cuts(cuts: &[Cut], p: DVec3, v: &mut f32) {
    for c in cuts {
        apply_cut(c, p, v);
    }
}

/// One cut at `p`: carve `min(v, -g)`, emboss `max(v, g)` where the tool reaches.
fn apply_cut(c: &Cut, p: DVec3, v: &mut f32) {
    combine(c.tool.mode, c.tool.value(p), v);
}

/// The R_1 combination of the field value `v` with the tool's value `g` (none: the
/// tool does not reach, `v` stays).
fn combine(mode: Mode, g: Option<f64>, v: &mut f32) {
    if let Some(g) = g {
        let g = g as f32;
        *v = match mode {
            Mode::Carve => v.min(-g),
            Mode::Emboss => v.max(g),
        };
    }
}

/// A box holding every point where `tape` (positive inside) may be positive, found by
/// subdividing a cube of half side [`SOLID_SEARCH_HALF_SIZE`] around the origin
/// [`SOLID_BOUNDS_DEPTH`] times and keeping the cells whose interval reaches above 0
/// (interval arithmetic bounds the f32 values, [`crate::implicit::interval`]); `None`
/// when no cell may be inside.
pub fn solid_bounds(tape: &Tape) -> Option<(DVec3, DVec3)> {
    let mut cells = vec![(
        DVec3::splat(-SOLID_SEARCH_HALF_SIZE),
        DVec3::splat(SOLID_SEARCH_HALF_SIZE),
    )];
    let may_be_inside = |lo: DVec3, hi: DVec3| {
        let r = tape.eval_interval([0, 1, 2].map(|a| Interval::new(lo[a] as f32, hi[a] as f32)));
        r.nan || r.hi > 0.0
    };
    for _ in 0..SOLID_BOUNDS_DEPTH {
        let mut next = Vec::new();
        for (lo, hi) in cells {
            let mid = (lo + hi) / 2.0;
            for octant in 0..8 {
                let pick = |a: usize, bit: usize| {
                    if octant >> bit & 1 == 0 {
                        (lo[a], mid[a])
                    } else {
                        (mid[a], hi[a])
                    }
                };
                let (x, y, z) = (pick(0, 0), pick(1, 1), pick(2, 2));
                let (l, h) = (DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1));
                if may_be_inside(l, h) {
                    next.push((l, h));
                }
            }
        }
        cells = next;
        if cells.is_empty() {
            return None;
        }
    }
    let lo = cells.iter().fold(DVec3::INFINITY, |a, c| a.min(c.0));
    let hi = cells.iter().fold(DVec3::NEG_INFINITY, |a, c| a.max(c.1));
    Some(tighten(tape, lo, hi))
}

/// `lo..hi` shrunk to the inside points of a grid of [`SOLID_BOUNDS_SAMPLES`] points a
/// side, padded by two spacings (R-function intervals are loose, `docs/implicit.md`,
/// so the interval box alone can be much larger than the solid); `lo..hi` itself when
/// no sample is inside.
fn tighten(tape: &Tape, lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    let n = SOLID_BOUNDS_SAMPLES;
    let step = (hi - lo) / (n - 1) as f64;
    let mut points = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = lo + step * DVec3::new(i as f64, j as f64, k as f64);
                points.push(p.as_vec3().to_array());
            }
        }
    }
    let mut values = vec![0f32; points.len()];
    tape.eval_points(&points, &mut values);
    let (mut a, mut b) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for (p, v) in points.iter().zip(&values) {
        if *v > 0.0 {
            let p = DVec3::from(p.map(f64::from));
            a = a.min(p);
            b = b.max(p);
        }
    }
    if a.cmpgt(b).any() {
        return (lo, hi);
    }
    ((a - 2.0 * step).max(lo), (b + 2.0 * step).min(hi))
}

/// V - E + F of a triangle mesh (2 for a sphere, 0 for a torus: 2 - 2 genus for one
/// closed surface).
pub fn euler_characteristic(mesh: &WeldedMesh) -> i64 {
    let mut edges = HashSet::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    mesh.vertices.len() as i64 - edges.len() as i64 + mesh.triangles.len() as i64
}
