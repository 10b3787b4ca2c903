//! The document: target surfaces and the strokes applied to them, in order, with undo
//! and redo of every step back to the start, a versioned JSON file format, tessellation
//! into [`MeshSink`]s and export.
//!
//! This is the API the interaction state machine and `replay` call:
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::mesh::PatchMesh;
//! use sculpt_core::nurbs::NurbsSurface;
//! use sculpt_core::sculpt::document::Document;
//! use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
//! use sculpt_core::sculpt::tessellate::Detail;
//!
//! // A flat 1 m square target.
//! let plane = NurbsSurface::new(1, 1, vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0],
//!     vec![vec![DVec3::ZERO, DVec3::Y], vec![DVec3::X, DVec3::new(1.0, 1.0, 0.0)]], None)?;
//! let mut doc = Document::new();
//! let target = doc.add_target("plane", plane);
//! let tool = Tool { profile: Profile::V, width: 0.05, depth: 0.01, mode: Mode::Carve, taper: 0.02 };
//! let samples = (0..=50).map(|i| (i as f64 / 100.0, DVec3::new(0.2 + 0.012 * i as f64, 0.5, 0.001))).collect();
//! let stroke = doc.apply_stroke(target, StrokeInput { samples, tool })?;
//!
//! let mut gpu_like = PatchMesh::new(); // vr-app passes its GPU-buffer sink here
//! let stats = doc.tessellate(Detail::Interactive, &mut gpu_like);
//! assert!(stats.triangles_total > 0);
//!
//! doc.undo();                          // the groove disappears ...
//! assert_eq!(doc.strokes().len(), 0);
//! doc.redo();                          // ... and comes back
//! assert_eq!(doc.strokes()[0].id, stroke);
//!
//! let bytes = doc.to_json();
//! let again = Document::from_json(&bytes)?;
//! assert_eq!(again.strokes().len(), 1);
//! # Ok::<(), sculpt_core::Error>(())
//! ```
//!
//! # File format (`wandsculpt-document`, version 1)
//!
//! ```json
//! {
//!   "format": "wandsculpt-document",
//!   "version": 1,
//!   "description": "optional free text",
//!   "targets": [
//!     {"id": 1, "name": "patch", "surface": {"degree_u": 3, "degree_v": 3, "knots_u": [..],
//!      "knots_v": [..], "control_points": [[[x, y, z], ..], ..], "weights": [[..]]}}
//!   ],
//!   "strokes": [
//!     {"id": 2, "target": 1,
//!      "tool": {"profile": "v", "width": 0.03, "depth": 0.008, "mode": "carve", "taper": 0.02},
//!      "samples": [[t, x, y, z], ..]}
//!   ]
//! }
//! ```
//!
//! Surfaces use the kernel's schema ([`crate::nurbs`]). `profile` is `"v"`, `"u"` or
//! `{"custom": [[x, f], ..]}`; `mode` is `"carve"` or `"emboss"`; `taper` is optional
//! (default 0). Samples are wand positions in metres with their time in seconds. Ids are
//! unique positive integers; a stroke names a target listed before it. Unknown fields,
//! other versions, duplicate ids, dangling targets and strokes that the sculpting rules
//! reject are errors that say which entry is wrong. Scene files are documents.

use super::conform::{
    Network, NetworkPlan, SharedSide, holder_params, shared_side, write_network_with,
};
use super::jordan::Rect;
use super::network_stroke::build_on_network;
use super::stroke::{StrokeInput, StrokePieces, Tool};
use super::stroke_surface::StrokeSurface;
use super::surface::{TargetSurface, extent};
use super::tessellate::{
    Detail, FixedSides, GridPlan, StrokeRef, TargetTessellation, TessStats, pole_height,
};
use crate::error::{ControlNetError, DocumentError, Error, Result, StrokeRejection};
use crate::formats::iges::{Face, IgesSurface, NurbsPatch};
use crate::mesh::{MeshSink, PatchMesh};
use crate::nurbs::NurbsSurface;
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The format tag of document files.
pub const FORMAT: &str = "wandsculpt-document";
/// The document format version this build writes and reads.
pub const VERSION: u32 = 1;
/// Largest document accepted by [`Document::from_json`], bytes.
pub const MAX_DOCUMENT_BYTES: usize = 256 << 20;
/// Most targets a document holds: the reader refuses more, and an edit that would add
/// one more (a sketch) is rejected ([`DocumentError::TooManyTargets`]). The paper's
/// scenes and the demo have one; a scanned object (`sculpt-tools reconstruct`) has one
/// per quad of its patch network: the kitten scan at K = 80 has 478.
pub const MAX_TARGETS: usize = 4096;
/// Most strokes a document holds: the reader refuses more, and a stroke beyond it is
/// rejected ([`DocumentError::TooManyStrokes`]). The paper's scenes have at most 7; a
/// stroke every 5 s for 8 hours is 5,760.
pub const MAX_STROKES: usize = 10_000;
/// Most wand samples of one stroke ([`StrokeRejection::TooManySamples`]): the
/// sculpting layer's [`MAX_INPUT_SAMPLES`](super::stroke::MAX_INPUT_SAMPLES), five
/// times the interaction's default `max_samples`. The paper's scenes have at most 200.
pub const MAX_STROKE_SAMPLES: usize = super::stroke::MAX_INPUT_SAMPLES;
/// Most wand samples of all strokes of a document together
/// ([`DocumentError::TooManySamples`]); at about 120 bytes a sample in the saved JSON,
/// strokes this size stay below [`MAX_DOCUMENT_BYTES`]. The paper's scenes have at
/// most 540.
pub const MAX_DOCUMENT_SAMPLES: usize = 2_000_000;
/// Most control points of a target surface: the surface reader's
/// [`MAX_JSON_CONTROL_POINTS`](crate::nurbs::surface::MAX_JSON_CONTROL_POINTS) (a
/// 256 x 256 net), checked for documents' targets as for surface files; a sketch fit
/// has at most [`SKETCH_MAX_CONTROL`](crate::editor::SKETCH_MAX_CONTROL) squared.
/// The paper's scenes have at most 224.
pub const MAX_TARGET_CONTROL_POINTS: usize = crate::nurbs::surface::MAX_JSON_CONTROL_POINTS;

/// Identifies a target surface in a document: how every part of the program refers to
/// a target (strokes, the editor's results, the live preview, replay metrics).
pub type TargetId = u64;

/// The first id a new document hands out: its first target's id.
pub const FIRST_ID: u64 = 1;

/// A target's position in [`Document::targets`] (0 first), not its id.
///
/// Only people count targets this way: the HUD shows the position and a select
/// command (a button, a key, a pose log's command) names one. Everything that refers
/// to a target (edits, the journal, strokes, the editor's results) uses its
/// [`TargetId`].
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct TargetIndex(pub u32);

impl std::fmt::Display for TargetIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}
/// Identifies a stroke in a document.
pub type StrokeId = u64;

/// A target surface.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetRecord {
    /// Its id.
    pub id: TargetId,
    /// A name for people.
    pub name: String,
    /// The NURBS surface (never modified by sculpting).
    pub surface: NurbsSurface,
    /// The surface with its cached inverter, through which every projection onto this
    /// target goes; built once with the record (the surface never changes after).
    target: TargetSurface,
}

impl TargetRecord {
    /// A record for `surface`, with its inverter built.
    fn new(id: TargetId, name: String, surface: NurbsSurface) -> Self {
        let target = TargetSurface::new(&surface);
        Self {
            id,
            name,
            surface,
            target,
        }
    }

    /// The surface with its cached certified inverter (see [`TargetSurface`]): project
    /// onto this target through it.
    pub fn target_surface(&self) -> &TargetSurface {
        &self.target
    }
}

/// A stroke as the user made it.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeRecord {
    /// Its id.
    pub id: StrokeId,
    /// The target it was applied to.
    pub target: TargetId,
    /// The wand samples and tool.
    pub input: StrokeInput,
}

#[derive(Debug, Clone, PartialEq)]
enum Step {
    Target(TargetRecord),
    Stroke(StrokeRecord),
    Deform(DeformRecord),
}

mod deform;
pub use deform::{DeformRecord, MAX_DEFORMS, carry_stroke};

/// Targets, strokes, history and the derived sculpting state.
#[derive(Debug, Clone, Default)]
pub struct Document {
    targets: Vec<TargetRecord>,
    strokes: Vec<StrokeRecord>,
    /// Lattice deformations applied since the base, in order ([`Self::apply_deform`]).
    deforms: Vec<DeformRecord>,
    redo: Vec<Step>,
    next_id: u64,
    /// Steps with ids up to this are the document's base (made before its first edit,
    /// or loaded): undo stops there ([`Self::seal_history`]).
    history_floor: u64,
    built: HashMap<StrokeId, Built>,
    views: HashMap<(TargetId, Detail), TargetTessellation>,
    /// Areas changed since the last tessellation, per target and detail
    /// (`None` inside: the whole target).
    dirty: HashMap<(TargetId, Detail), Option<Rect>>,
    /// Targets removed since the last tessellation at each detail, with their patches.
    removed: Vec<(Detail, Vec<u64>)>,
    /// The grid of each target at each detail, planned once.
    grids: HashMap<(TargetId, Detail), GridPlan>,
    /// The stroke being drawn, shown at interactive detail only (never saved or undone).
    preview: Option<(TargetId, Built)>,
    /// Preview pieces so far (each gets a fresh key, so the tessellator sees it change).
    preview_serial: u64,
    /// Pieces after the first of document strokes so far (each gets a fresh key).
    piece_serial: u64,
    /// Stroke surfaces, built lazily when first asked for (export, stroke meshes).
    surfaces: SurfaceCache,
    /// Wand samples of all strokes in [`Self::strokes`] (for [`MAX_DOCUMENT_SAMPLES`]).
    samples_total: usize,
    /// The conforming tessellation of the targets that form a patch network, per
    /// detail ([`super::conform`]).
    conform: HashMap<Detail, ConformState>,
}

/// The patch network of the targets at one detail and what of it is in the sink.
#[derive(Debug, Clone)]
struct ConformState {
    /// The targets (ids, in order) the network was found among.
    ids: Vec<TargetId>,
    network: Network,
    plan: NetworkPlan,
    /// Per target index, the triangles of its conforming patch in the sink (`None`:
    /// not written).
    written: Vec<Option<usize>>,
    /// The shared sides' vertices as last written (empty before the first pass).
    sides: Vec<SharedSide>,
    /// Per target index, whether it was carved (meshed by its own tessellation, with
    /// fixed shared sides) in the last pass.
    carved: Vec<bool>,
}

/// The key of a target's one patch when it is tessellated as part of a network (its
/// index in the high bits, as every patch key of a target, and a root no grid has).
pub fn conform_key(target: usize) -> u64 {
    ((target as u64) << 32) | u64::from(u32::MAX)
}

/// A stroke as built: its pieces and the key of each, under which the tessellator and
/// the stroke-surface cache know it ([`Document::strokes_on`]).
#[derive(Debug, Clone)]
struct Built {
    keys: Vec<u64>,
    pieces: StrokePieces,
    /// Per piece, the target it is carved into: the stroke's own, or on a patch
    /// network the patch its run fell on ([`super::network_stroke`]).
    targets: Vec<TargetId>,
}

impl Built {
    /// The pieces with their keys.
    fn refs(&self) -> impl Iterator<Item = StrokeRef<'_>> {
        self.keys.iter().copied().zip(&self.pieces.pieces)
    }

    /// The pieces carved into `target`, with their keys.
    fn refs_on(&self, target: TargetId) -> impl Iterator<Item = StrokeRef<'_>> {
        self.refs()
            .zip(&self.targets)
            .filter(move |(_, t)| **t == target)
            .map(|(r, _)| r)
    }

    /// Each piece's target and footprint bounds.
    fn areas(&self) -> impl Iterator<Item = (TargetId, Rect)> + '_ {
        self.targets
            .iter()
            .copied()
            .zip(self.pieces.pieces.iter().map(|p| p.bounds))
    }
}

/// The pieces of the strokes on `target`, in order, with their keys (see
/// [`Document::strokes_on`]).
fn pieces_on<'a>(
    strokes: &'a [StrokeRecord],
    built: &'a HashMap<StrokeId, Built>,
    target: TargetId,
) -> impl Iterator<Item = StrokeRef<'a>> {
    strokes
        .iter()
        .filter_map(|s| built.get(&s.id))
        .flat_map(move |b| b.refs_on(target))
}

/// The pieces the tessellator carves into `target` at `detail`: the document's, and
/// at interactive detail the preview's.
fn strokes_at<'a>(
    strokes: &'a [StrokeRecord],
    built: &'a HashMap<StrokeId, Built>,
    preview: &'a Option<(TargetId, Built)>,
    target: TargetId,
    detail: Detail,
) -> Vec<StrokeRef<'a>> {
    pieces_on(strokes, built, target)
        .chain(
            preview
                .iter()
                .filter(|_| detail == Detail::Interactive)
                .flat_map(move |(_, built)| built.refs_on(target)),
        )
        .collect()
}

/// The fixed sides of network patch `k`: its shared sides' vertices in its own
/// direction.
fn fixed_sides(sides: &[SharedSide], network: &Network, k: usize) -> FixedSides {
    std::array::from_fn(|s| SharedSide::own(sides, network, k, s))
}

/// A stroke piece's cached surface: the pieces (keys, document order, itself included)
/// whose bounds met its own when it was trimmed, and the surface (`None` when the piece
/// is too degenerate to have one).
#[derive(Debug, Clone)]
struct CachedSurface {
    overlaps: Vec<u64>,
    surface: Option<Arc<StrokeSurface>>,
}

/// The stroke-surface cache: filled through `&self` (exports take `&Document`), hence
/// the lock; cloning a document clones the cache.
#[derive(Debug, Default)]
struct SurfaceCache(Mutex<HashMap<u64, CachedSurface>>);

impl SurfaceCache {
    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<u64, CachedSurface>> {
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl Clone for SurfaceCache {
    fn clone(&self) -> Self {
        Self(Mutex::new(self.lock().clone()))
    }
}

/// Preview strokes' pieces take keys from here up; document strokes never get this far.
pub const PREVIEW_IDS: StrokeId = 1 << 62;
/// The pieces of a document stroke after its first take keys from here up (the first
/// piece's key is the stroke's id): above [`PREVIEW_IDS`] and every preview key.
pub const PIECE_KEYS: u64 = 3 << 62;

/// How far (metres) a wand sample may be from the target and still count as on it:
/// twice the tool width, but at least 5 % of the target's size.
pub fn snap_distance(tool: &Tool, target_size: f64) -> f64 {
    (2.0 * tool.width).max(0.05 * target_size)
}

impl Document {
    /// An empty document.
    pub fn new() -> Self {
        Self {
            next_id: FIRST_ID,
            ..Self::default()
        }
    }

    /// The targets, in order.
    pub fn targets(&self) -> &[TargetRecord] {
        &self.targets
    }

    /// The target at `index` in [`Document::targets`], if there is one.
    pub fn target_at(&self, index: TargetIndex) -> Option<&TargetRecord> {
        self.targets.get(index.0 as usize)
    }

    /// The target with id `id`, if there is one.
    pub fn target(&self, id: TargetId) -> Option<&TargetRecord> {
        self.targets.iter().find(|t| t.id == id)
    }

    /// The targets' ids, in order.
    pub fn target_ids(&self) -> Vec<TargetId> {
        self.targets.iter().map(|t| t.id).collect()
    }

    /// The strokes, in the order they were applied.
    pub fn strokes(&self) -> &[StrokeRecord] {
        &self.strokes
    }

    /// The projected stroke of a stroke id: its pieces (see [`StrokePieces`]).
    pub fn stroke(&self, id: StrokeId) -> Option<&StrokePieces> {
        self.built.get(&id).map(|b| &b.pieces)
    }

    /// The keys of a stroke's pieces, in the order of [`StrokePieces::pieces`], as
    /// [`Self::strokes_on`] lists them: the first is the stroke's id.
    pub fn piece_keys(&self, id: StrokeId) -> Option<&[u64]> {
        self.built.get(&id).map(|b| b.keys.as_slice())
    }

    /// Adds a target surface (undoable) and returns its id.
    pub fn add_target(&mut self, name: &str, surface: NurbsSurface) -> TargetId {
        let id = self.fresh_id();
        self.redo.clear();
        self.push_target(TargetRecord::new(id, name.to_string(), surface));
        id
    }

    /// Adds a target surface (undoable) like [`Self::add_target`], within the caps: a
    /// document holding [`MAX_TARGETS`] already, or a surface of more than
    /// [`MAX_TARGET_CONTROL_POINTS`], is refused and the document is unchanged.
    pub fn try_add_target(&mut self, name: &str, surface: NurbsSurface) -> Result<TargetId> {
        self.check_target_caps(&surface)?;
        Ok(self.add_target(name, surface))
    }

    /// Checks that one more target, `surface`, fits the caps ([`MAX_TARGETS`],
    /// [`MAX_TARGET_CONTROL_POINTS`]).
    pub fn check_target_caps(&self, surface: &NurbsSurface) -> Result<()> {
        if self.targets.len() >= MAX_TARGETS {
            return Err(Error::Document(DocumentError::TooManyTargets {
                max: MAX_TARGETS,
            }));
        }
        let count = surface.count_u() * surface.count_v();
        if count > MAX_TARGET_CONTROL_POINTS {
            return Err(Error::InvalidControlNet(ControlNetError::TooMany {
                count,
                max: MAX_TARGET_CONTROL_POINTS,
            }));
        }
        Ok(())
    }

    /// Checks that one more stroke of `samples` wand samples fits the caps
    /// ([`MAX_STROKES`], [`MAX_STROKE_SAMPLES`], [`MAX_DOCUMENT_SAMPLES`]); the edit
    /// path asks this before it journals a stroke, and every stroke added is checked.
    pub fn check_stroke_caps(&self, samples: usize) -> Result<()> {
        if self.strokes.len() >= MAX_STROKES {
            return Err(Error::Document(DocumentError::TooManyStrokes {
                max: MAX_STROKES,
            }));
        }
        if samples > MAX_STROKE_SAMPLES {
            return Err(Error::StrokeRejected(StrokeRejection::TooManySamples {
                count: samples,
                max: MAX_STROKE_SAMPLES,
            }));
        }
        let total = self.samples_total.saturating_add(samples);
        if total > MAX_DOCUMENT_SAMPLES {
            return Err(Error::Document(DocumentError::TooManySamples {
                total,
                max: MAX_DOCUMENT_SAMPLES,
            }));
        }
        Ok(())
    }

    /// Projects and applies a stroke to a target (undoable). A stroke the rules reject
    /// (see [`StrokePieces::build`]) or beyond the caps ([`Self::check_stroke_caps`]) leaves
    /// the document unchanged and says why.
    pub fn apply_stroke(&mut self, target: TargetId, input: StrokeInput) -> Result<StrokeId> {
        let record = StrokeRecord {
            id: self.next_id.max(1),
            target,
            input,
        };
        self.push_stroke(record.clone())?;
        self.next_id = record.id + 1;
        self.redo.clear();
        Ok(record.id)
    }

    /// Makes everything now in the document its base, which [`Self::undo`] never
    /// removes (the default surface of a new session, a loaded scene).
    pub fn seal_history(&mut self) {
        self.history_floor = self.next_id.saturating_sub(1);
    }

    /// Undoes the last step; false when there is nothing to undo (the base, see
    /// [`Self::seal_history`], is never undone).
    pub fn undo(&mut self) -> bool {
        // Ids are strictly increasing, so every base step is older than every edit.
        let floor = self.history_floor;
        let last_stroke = self.strokes.last().map(|s| s.id).filter(|&id| id > floor);
        let last_target = self.targets.last().map(|t| t.id).filter(|&id| id > floor);
        let last_deform = self.deforms.last().map(|d| d.id).filter(|&id| id > floor);
        // Steps are strictly ordered by id: undo whichever came last.
        let last = [(last_stroke, 0), (last_target, 1), (last_deform, 2)]
            .into_iter()
            .filter_map(|(id, kind)| id.map(|id| (id, kind)))
            .max();
        let step = match last {
            Some((_, 0)) => self.pop_stroke(),
            Some((_, 1)) => self.pop_target(),
            Some(_) => self.pop_deform(),
            None => None,
        };
        match step {
            Some(step) => {
                self.redo.push(step);
                true
            }
            None => false,
        }
    }

    /// Redoes the last undone step; false when there is nothing to redo.
    pub fn redo(&mut self) -> bool {
        match self.redo.pop() {
            Some(Step::Target(t)) => {
                self.push_target(t);
                true
            }
            Some(Step::Stroke(s)) => {
                // It was valid when first applied and nothing under it changed.
                self.push_stroke(s).is_ok()
            }
            Some(Step::Deform(d)) => self.push_deform(d),
            None => false,
        }
    }

    /// True when [`Self::undo`] would do something.
    pub fn can_undo(&self) -> bool {
        let floor = self.history_floor;
        self.strokes.last().is_some_and(|s| s.id > floor)
            || self.targets.last().is_some_and(|t| t.id > floor)
            || self.deforms.last().is_some_and(|d| d.id > floor)
    }

    /// True when [`Self::redo`] would do something.
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    fn fresh_id(&mut self) -> u64 {
        let id = self.next_id.max(1);
        self.next_id = id + 1;
        id
    }

    fn push_target(&mut self, t: TargetRecord) {
        for detail in [Detail::Interactive, Detail::Final] {
            self.dirty.insert((t.id, detail), None);
            self.grids
                .entry((t.id, detail))
                .or_insert_with(|| plan_grid(&t.surface, detail));
        }
        self.next_id = self.next_id.max(t.id + 1);
        self.targets.push(t);
    }

    fn pop_target(&mut self) -> Option<Step> {
        let t = self.targets.pop()?;
        for detail in [Detail::Interactive, Detail::Final] {
            self.dirty.remove(&(t.id, detail));
            if let Some(view) = self.views.remove(&(t.id, detail)) {
                let n = view.map().n();
                self.removed
                    .push((detail, (0..n * n).map(|r| view.patch_key(r)).collect()));
            }
        }
        Some(Step::Target(t))
    }

    fn push_stroke(&mut self, record: StrokeRecord) -> Result<()> {
        self.check_stroke_caps(record.input.samples.len())?;
        if self.strokes.iter().any(|s| s.id == record.id) {
            return Err(Error::Document(DocumentError::StrokeId { id: record.id }));
        }
        let target =
            self.targets
                .iter()
                .find(|t| t.id == record.target)
                .ok_or(Error::NotFound {
                    kind: "target",
                    id: record.target,
                })?;
        let (pieces, targets) = self.build_pieces(target, &record.input)?;
        let keys: Vec<u64> = std::iter::once(record.id)
            .chain((1..pieces.pieces.len()).map(|_| {
                self.piece_serial += 1;
                PIECE_KEYS + self.piece_serial
            }))
            .collect();
        let built = Built {
            keys,
            pieces,
            targets,
        };
        self.mark_built_dirty(&built);
        self.built.insert(record.id, built);
        self.next_id = self.next_id.max(record.id + 1);
        self.samples_total += record.input.samples.len();
        self.strokes.push(record);
        Ok(())
    }

    fn pop_stroke(&mut self) -> Option<Step> {
        let s = self.strokes.pop()?;
        self.samples_total -= s.input.samples.len();
        if let Some(built) = self.built.remove(&s.id) {
            let mut surfaces = self.surfaces.lock();
            for key in &built.keys {
                surfaces.remove(key);
            }
            drop(surfaces);
            self.mark_built_dirty(&built);
        }
        Some(Step::Stroke(s))
    }

    /// Marks the area of every piece of `built` dirty on its target.
    fn mark_built_dirty(&mut self, built: &Built) {
        for (t, area) in built.areas() {
            self.mark_dirty(t, area);
        }
    }

    fn mark_dirty(&mut self, target: TargetId, area: Rect) {
        for detail in [Detail::Interactive, Detail::Final] {
            let entry = self.dirty.entry((target, detail)).or_insert(Some(area));
            if let Some(r) = entry {
                *r = Rect::new(r.min.min(area.min), r.max.max(area.max));
            }
        }
    }

    /// Shows `input` on `target` as the stroke being drawn: it is carved into the
    /// [`Detail::Interactive`] tessellation (only the cells it touches, and the cells of
    /// the preview it replaces, are rewritten) but it is not part of the document: not
    /// in [`Self::strokes`], the history, the final detail, the exports or the JSON.
    /// A stroke the sculpting layer rejects clears the preview and says why. The preview
    /// is carved in pieces as the stroke will be ([`StrokePieces`]).
    pub fn set_preview(&mut self, target: TargetId, input: &StrokeInput) -> Result<()> {
        self.clear_preview();
        let record = self
            .targets
            .iter()
            .find(|t| t.id == target)
            .ok_or(Error::NotFound {
                kind: "target",
                id: target,
            })?;
        let (pieces, targets) = self.build_pieces(record, input)?;
        let keys = (0..pieces.pieces.len())
            .map(|_| {
                self.preview_serial += 1;
                PREVIEW_IDS + self.preview_serial
            })
            .collect();
        let built = Built {
            keys,
            pieces,
            targets,
        };
        self.mark_built_dirty(&built);
        self.preview = Some((target, built));
        Ok(())
    }

    /// Removes the preview stroke, if any.
    pub fn clear_preview(&mut self) {
        if let Some((_, built)) = self.preview.take() {
            self.mark_built_dirty(&built);
        }
    }

    /// The preview stroke's pieces and its target.
    pub fn preview(&self) -> Option<(TargetId, &StrokePieces)> {
        self.preview.as_ref().map(|(t, b)| (*t, &b.pieces))
    }

    /// The strokes on one target, in order, as the tessellator takes them: every piece
    /// of each stroke in drawing order, keyed by its piece key (a stroke's first piece
    /// by the stroke's id, see [`Self::piece_keys`]).
    pub fn strokes_on(&self, target: TargetId) -> Vec<StrokeRef<'_>> {
        pieces_on(&self.strokes, &self.built, target).collect()
    }

    /// Brings `sink` up to date at `detail`: the first call writes every patch, later
    /// calls only the patches changed since (strokes applied, undone or redone; targets
    /// added or removed). Use one sink per detail.
    pub fn tessellate(&mut self, detail: Detail, sink: &mut dyn MeshSink) -> TessStats {
        let mut stats = TessStats::default();
        self.removed.retain(|(d, keys)| {
            if *d == detail {
                for &k in keys {
                    sink.remove_patch(k);
                }
                false
            } else {
                true
            }
        });
        let conformal = self.conform_pass(detail, sink, &mut stats);
        for (k, t) in self.targets.iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                continue;
            }
            let key = (t.id, detail);
            let changed = self.dirty.remove(&key);
            // A carved network patch's view is made by the conform pass: fresh until
            // its first update.
            let fresh = self
                .views
                .get(&key)
                .is_none_or(TargetTessellation::is_fresh);
            if !fresh && changed.is_none() {
                stats.triangles_total += self.views[&key].triangle_count();
                continue;
            }
            let plan = grid_of(&self.grids, t, detail);
            let view = self.views.entry(key).or_insert_with(|| {
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan)
            });
            let strokes = strokes_at(&self.strokes, &self.built, &self.preview, t.id, detail);
            let s = view.update_strokes(&t.surface, &strokes, sink);
            stats.patches_written += s.patches_written;
            stats.triangles_written += s.triangles_written;
            stats.triangles_total += s.triangles_total;
        }
        stats
    }

    /// Forgets what was written to the sinks so far: the next [`Document::tessellate`]
    /// at each detail writes every patch again, as into new, empty sinks.
    pub fn forget_sinks(&mut self) {
        self.views.clear();
        self.conform.clear();
        self.dirty.clear();
        self.removed.clear();
    }

    /// The number of patches a full tessellation at `detail` writes (for progress).
    pub fn patch_count(&self, detail: Detail) -> usize {
        let conformal = self.conformal(&self.network(), detail);
        self.targets
            .iter()
            .enumerate()
            .map(|(k, t)| {
                if conformal.get(k) == Some(&true) {
                    return 1;
                }
                let n = self.grid(t, detail).n;
                (n * n) as usize
            })
            .sum()
    }

    /// The patch network the targets form ([`Network::of`]; empty when no two share a
    /// side, as for every document of one target).
    pub fn network(&self) -> Network {
        let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
        Network::of(&surfaces)
    }

    /// Per target index, whether it is tessellated as part of `network` at `detail`:
    /// it shares a side and carries no stroke (nor, at interactive detail, the
    /// preview). Empty when the network is.
    fn conformal(&self, network: &Network, detail: Detail) -> Vec<bool> {
        if network.is_empty() {
            return Vec::new();
        }
        self.targets
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let previewed = detail == Detail::Interactive
                    && self
                        .preview
                        .as_ref()
                        .is_some_and(|(_, b)| b.targets.contains(&t.id));
                network.holds(k)
                    && !previewed
                    && pieces_on(&self.strokes, &self.built, t.id).next().is_none()
            })
            .collect()
    }

    /// Writes the network's patches that need it ([`Self::conformal`] targets not yet
    /// in the sink), removes the per-target patches of targets that became conformal
    /// and the conforming patches of those that no longer are. Returns
    /// [`Self::conformal`].
    fn conform_pass(
        &mut self,
        detail: Detail,
        sink: &mut dyn MeshSink,
        stats: &mut TessStats,
    ) -> Vec<bool> {
        let ids: Vec<TargetId> = self.targets.iter().map(|t| t.id).collect();
        if self.conform.get(&detail).is_none_or(|c| c.ids != ids) {
            if let Some(old) = self.conform.remove(&detail) {
                for (k, w) in old.written.iter().enumerate() {
                    if w.is_some() {
                        sink.remove_patch(conform_key(k));
                    }
                }
            }
            let network = self.network();
            let plan = if network.is_empty() {
                NetworkPlan {
                    cells: Vec::new(),
                    side_cells: Vec::new(),
                }
            } else {
                let surfaces: Vec<&NurbsSurface> =
                    self.targets.iter().map(|t| &t.surface).collect();
                NetworkPlan::new(&surfaces, &network, detail)
            };
            let written = vec![None; ids.len()];
            self.conform.insert(
                detail,
                ConformState {
                    ids,
                    network,
                    plan,
                    written,
                    sides: Vec::new(),
                    carved: Vec::new(),
                },
            );
        }
        let Some(mut state) = self.conform.remove(&detail) else {
            return Vec::new();
        };
        let conformal = self.conformal(&state.network, detail);
        self.carve_sides(detail, &mut state, &conformal);
        let mut to_write = Vec::new();
        for (k, t) in self.targets.iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                if let Some(view) = self.views.remove(&(t.id, detail)) {
                    let n = view.map().n();
                    for r in 0..n * n {
                        sink.remove_patch(view.patch_key(r));
                    }
                }
                self.dirty.remove(&(t.id, detail));
                match state.written[k] {
                    Some(tris) => stats.triangles_total += tris,
                    None => to_write.push(k),
                }
            } else if state.written[k].take().is_some() {
                sink.remove_patch(conform_key(k));
            }
        }
        if !to_write.is_empty() {
            let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
            let tris = write_network_with(
                &surfaces,
                &state.network,
                &state.plan,
                &state.sides,
                &to_write,
                conform_key,
                sink,
            );
            for (k, n) in to_write.into_iter().zip(tris) {
                state.written[k] = Some(n);
                stats.patches_written += 1;
                stats.triangles_written += n;
                stats.triangles_total += n;
            }
        }
        self.conform.insert(detail, state);
        conformal
    }

    /// The shared sides of the network for this pass (issue 30, watertight after
    /// strokes). A network patch that carries strokes (or the preview) is *carved*: it
    /// is meshed by its own tessellation with its shared sides fixed to the network's
    /// vertices, to which its cells' corners along them are added, displaced by the
    /// strokes of both holders ([`pole_height`]: the depth from the 3D point). The sides
    /// of carved patches (now or in the last pass) are recomputed when the carved set
    /// changed or one of their holders is dirty; the conformal patches along a side that
    /// changed are rewritten, the carved ones take their sides
    /// ([`TargetTessellation::set_fixed_sides`]) and are marked dirty when they changed.
    fn carve_sides(&mut self, detail: Detail, state: &mut ConformState, conformal: &[bool]) {
        let count = self.targets.len();
        let carved: Vec<bool> = (0..count)
            .map(|k| state.network.holds(k) && conformal.get(k) == Some(&false))
            .collect();
        for (k, t) in self.targets.iter().enumerate().filter(|(k, _)| carved[*k]) {
            let plan = grid_of(&self.grids, t, detail);
            self.views.entry((t.id, detail)).or_insert_with(|| {
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan)
            });
        }
        let first = state.sides.len() != state.network.sides.len();
        let set_changed = carved != state.carved;
        let stirred = |k: usize| {
            (carved[k] || state.carved.get(k) == Some(&true))
                && (set_changed || self.dirty.contains_key(&(self.targets[k].id, detail)))
        };
        let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
        let mut changed = vec![false; count];
        for id in 0..state.network.sides.len() {
            let [(a, _), (b, _)] = state.network.sides[id];
            if !(first || stirred(a) || stirred(b)) {
                continue;
            }
            let side = self.side_of(&surfaces, state, &carved, id, Some(detail), |k| {
                self.views.get(&(self.targets[k].id, detail))
            });
            if state.sides.get(id) != Some(&side) {
                changed[a] = true;
                changed[b] = true;
                match state.sides.get_mut(id) {
                    Some(s) => *s = side,
                    None => state.sides.push(side),
                }
            }
        }
        for k in 0..count {
            if !changed[k] {
                continue;
            }
            if carved[k] {
                let id = self.targets[k].id;
                let sides = fixed_sides(&state.sides, &state.network, k);
                if let Some(view) = self.views.get_mut(&(id, detail))
                    && view.set_fixed_sides(sides)
                {
                    self.dirty.entry((id, detail)).or_insert(None);
                }
            } else if conformal.get(k) == Some(&true) && state.written[k].is_some() {
                // Rewritten below, with the new sides (the sink replaces it by key).
                state.written[k] = None;
            }
        }
        state.carved = carved;
    }

    /// Shared side `id` for the carved set `carved`: the carved holders' side parameters
    /// ([`TargetTessellation::side_params`], from `view_of`) added, displaced by both
    /// holders' strokes (with the preview where `preview_at` names the detail).
    fn side_of<'v>(
        &self,
        surfaces: &[&NurbsSurface],
        state: &ConformState,
        carved: &[bool],
        id: usize,
        preview_at: Option<Detail>,
        view_of: impl Fn(usize) -> Option<&'v TargetTessellation>,
    ) -> SharedSide {
        let on = |k: usize| -> Vec<StrokeRef<'_>> {
            let id = self.targets[k].id;
            match preview_at {
                Some(detail) => strokes_at(&self.strokes, &self.built, &self.preview, id, detail),
                None => pieces_on(&self.strokes, &self.built, id).collect(),
            }
        };
        let extra = holder_params(&state.network, id, |p, k| {
            carved[p]
                .then(|| view_of(p).map(|v| v.side_params(k, &on(p))))
                .flatten()
        });
        let [(a, _), (b, _)] = state.network.sides[id];
        let strokes: Vec<StrokeRef<'_>> = [a, b]
            .into_iter()
            .filter(|&k| carved[k])
            .flat_map(on)
            .collect();
        shared_side(surfaces, &state.network, &state.plan, id, &extra, |p| {
            if strokes.is_empty() {
                0.0
            } else {
                pole_height(&strokes, p)
            }
        })
    }

    /// The root grid of a target at a detail (chosen when the target was added).
    fn grid(&self, t: &TargetRecord, detail: Detail) -> std::borrow::Cow<'_, GridPlan> {
        grid_of(&self.grids, t, detail)
    }

    /// The whole sculpted mesh at `detail`, freshly tessellated.
    pub fn mesh(&self, detail: Detail) -> PatchMesh {
        let mut mesh = PatchMesh::new();
        let network = self.network();
        let conformal = self.conformal(&network, detail);
        let carved: Vec<bool> = (0..self.targets.len())
            .map(|k| network.holds(k) && conformal.get(k) == Some(&false))
            .collect();
        let mut views: HashMap<usize, TargetTessellation> = HashMap::new();
        for (k, t) in self.targets.iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                continue;
            }
            let plan = self.grid(t, detail);
            views.insert(
                k,
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan),
            );
        }
        if !network.is_empty() {
            let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
            let state = ConformState {
                ids: Vec::new(),
                plan: NetworkPlan::new(&surfaces, &network, detail),
                network,
                written: Vec::new(),
                sides: Vec::new(),
                carved: Vec::new(),
            };
            let sides: Vec<SharedSide> = (0..state.network.sides.len())
                .map(|id| self.side_of(&surfaces, &state, &carved, id, None, |k| views.get(&k)))
                .collect();
            let which: Vec<usize> = (0..conformal.len()).filter(|&k| conformal[k]).collect();
            write_network_with(
                &surfaces,
                &state.network,
                &state.plan,
                &sides,
                &which,
                conform_key,
                &mut mesh,
            );
            for (k, view) in views.iter_mut() {
                if carved[*k] {
                    view.set_fixed_sides(fixed_sides(&sides, &state.network, *k));
                }
            }
        }
        for (k, t) in self.targets.iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                continue;
            }
            if let Some(view) = views.get_mut(&k) {
                view.update_strokes(&t.surface, &self.strokes_on(t.id), &mut mesh);
            }
        }
        mesh
    }

    /// Memory held by the derived state (projected strokes, UV maps), bytes.
    pub fn memory_bytes(&self) -> usize {
        self.built
            .values()
            .map(|b| b.pieces.memory_bytes())
            .sum::<usize>()
            + self
                .views
                .values()
                .map(TargetTessellation::memory_bytes)
                .sum::<usize>()
    }

    /// Every surface for IGES export: each target as trimmed faces (the domain minus
    /// the strokes' footprints, entity 144) or whole (128) when untouched, and each
    /// stroke surface ([`StrokeSurface`]: cubic along the stroke) trimmed by its
    /// visible faces (144) where other strokes remove part of it, or whole (128).
    /// Strokes without a stroke surface (degenerate) and stroke surfaces wholly removed
    /// by others are left out.
    pub fn iges_surfaces(&self) -> Vec<IgesSurface> {
        let mut out = Vec::new();
        for t in &self.targets {
            let strokes = self.strokes_on(t.id);
            let faces = (!strokes.is_empty()).then(|| {
                let regions: Vec<_> = strokes.iter().map(|s| &s.1.footprint).collect();
                visible_faces(&super::stroke::union(&regions))
            });
            out.push(IgesSurface {
                name: t.name.clone(),
                patch: patch_of(&t.surface),
                faces,
            });
            for (key, surface) in self.stroke_surfaces(t.id) {
                let faces = (!surface.trim().is_empty()).then(|| visible_faces(surface.trim()));
                if faces.as_ref().is_some_and(Vec::is_empty) {
                    continue;
                }
                out.push(IgesSurface {
                    name: self.piece_name(key),
                    patch: patch_of(surface.surface()),
                    faces,
                });
            }
        }
        out
    }

    /// The name of a stroke piece in exports: `stroke<id>` for a stroke's first piece,
    /// `stroke<id>-<k>` for its k-th (counting from 1).
    fn piece_name(&self, key: u64) -> String {
        self.strokes
            .iter()
            .find_map(|s| {
                let k = self.built.get(&s.id)?.keys.iter().position(|&x| x == key)?;
                Some(if k == 0 {
                    format!("stroke{}", s.id)
                } else {
                    format!("stroke{}-{}", s.id, k + 1)
                })
            })
            .unwrap_or_else(|| format!("stroke{key}"))
    }

    /// The target of the stroke piece with key `key` (the one it is carved into).
    fn piece_target(&self, key: u64) -> Option<TargetId> {
        self.strokes.iter().find_map(|s| {
            let b = self.built.get(&s.id)?;
            let k = b.keys.iter().position(|&x| x == key)?;
            b.targets.get(k).copied()
        })
    }

    /// Builds a stroke's pieces on `target` and the target of each: on a patch network
    /// the stroke is projected onto the whole network ([`build_on_network`]), otherwise
    /// onto `target` alone ([`StrokePieces::build`]). The snap distance is `target`'s.
    fn build_pieces(
        &self,
        target: &TargetRecord,
        input: &StrokeInput,
    ) -> Result<(StrokePieces, Vec<TargetId>)> {
        let snap = snap_distance(&input.tool, target.surface.size());
        let network = self.network();
        let index = self.targets.iter().position(|t| t.id == target.id);
        match index.filter(|&k| network.holds(k)) {
            Some(k) => {
                let patches: Vec<&TargetSurface> = self.targets.iter().map(|t| &t.target).collect();
                let built = build_on_network(&patches, k, input, snap)?;
                let mut pieces = Vec::new();
                let mut targets = Vec::new();
                for (patch, part) in built.parts {
                    targets.extend(std::iter::repeat_n(
                        self.targets[patch].id,
                        part.pieces.len(),
                    ));
                    pieces.extend(part.pieces);
                }
                Ok((
                    StrokePieces {
                        pieces,
                        dropped: built.dropped,
                    },
                    targets,
                ))
            }
            None => {
                let pieces = StrokePieces::build(&target.target, input, snap)?;
                let targets = vec![target.id; pieces.pieces.len()];
                Ok((pieces, targets))
            }
        }
    }

    /// The stroke surface of a stroke piece (by its key, see [`Self::strokes_on`]; a
    /// stroke's first piece has the stroke's id), trimmed against the pieces
    /// overlapping it (see [`super::stroke_surface`]); `None` for an unknown key or a
    /// piece too degenerate to have one. Built on first use and cached; only pieces
    /// whose overlaps changed (an overlapping stroke applied or undone) are trimmed
    /// again.
    pub fn stroke_surface(&self, key: u64) -> Option<Arc<StrokeSurface>> {
        self.stroke_surfaces(self.piece_target(key)?)
            .into_iter()
            .find(|(k, _)| *k == key)
            .map(|(_, s)| s)
    }

    /// The stroke surfaces of every stroke piece on a target with their keys, in
    /// document order (pieces without one are left out). See [`Self::stroke_surface`].
    pub fn stroke_surfaces(&self, target: TargetId) -> Vec<(u64, Arc<StrokeSurface>)> {
        let Some(t) = self.targets.iter().find(|t| t.id == target) else {
            return Vec::new();
        };
        let strokes = self.strokes_on(target);
        let ext = extent(&t.surface);
        let closed = [ext.closed_u, ext.closed_v];
        let mut cache = self.surfaces.lock();
        let mut out = Vec::new();
        for (k, &(id, stroke)) in strokes.iter().enumerate() {
            let overlaps: Vec<u64> = strokes
                .iter()
                .filter(|(_, o)| bounds_meet(&o.bounds, &stroke.bounds, closed))
                .map(|(oid, _)| *oid)
                .collect();
            let entry = cache.entry(id).or_insert_with(|| CachedSurface {
                overlaps: Vec::new(),
                surface: StrokeSurface::build(&t.target, stroke).ok().map(Arc::new),
            });
            if let Some(surface) = &mut entry.surface {
                if entry.overlaps != overlaps {
                    Arc::make_mut(surface).trim_against(&t.target, &strokes, k, closed);
                    entry.overlaps = overlaps;
                }
                out.push((id, Arc::clone(surface)));
            }
        }
        out
    }

    /// Tessellates the visible part of one stroke piece's surface (by its key, see
    /// [`Self::stroke_surface`]) through its UV map at `detail` into `sink`, as one
    /// patch keyed by [`stroke_patch_key`]. Returns the triangles written (0, and
    /// nothing written, when the piece has no surface).
    pub fn stroke_surface_mesh(&self, key: u64, detail: Detail, sink: &mut dyn MeshSink) -> usize {
        self.stroke_surface(key)
            .map_or(0, |s| s.tessellate(detail, stroke_patch_key(key), sink))
    }

    /// [`Self::stroke_surface_mesh`] for every stroke piece of the document. Returns the
    /// triangles written.
    pub fn stroke_surfaces_mesh(&self, detail: Detail, sink: &mut dyn MeshSink) -> usize {
        self.targets
            .iter()
            .flat_map(|t| self.stroke_surfaces(t.id))
            .map(|(id, s)| s.tessellate(detail, stroke_patch_key(id), sink))
            .sum()
    }
}

/// The patch key of a stroke piece's surface mesh (by the piece's key, see
/// [`Document::strokes_on`]): the high bit set, so it never meets a target patch's key
/// (a later piece's key, from [`PIECE_KEYS`], has it set already).
pub fn stroke_patch_key(stroke: u64) -> u64 {
    (1 << 63) | stroke
}

/// True when two strokes' parameter bounds meet, also across the seams of closed
/// directions.
fn bounds_meet(a: &Rect, b: &Rect, closed: [bool; 2]) -> bool {
    let shift = |c: bool| if c { vec![-1.0, 0.0, 1.0] } else { vec![0.0] };
    shift(closed[0]).into_iter().any(|dx| {
        shift(closed[1]).into_iter().any(|dy| {
            let d = DVec2::new(dx, dy);
            Rect::new(a.min + d, a.max + d).touches(b)
        })
    })
}

/// A kernel surface in the IGES writer's layout.
fn patch_of(s: &NurbsSurface) -> NurbsPatch {
    NurbsPatch {
        degree_u: s.degree_u(),
        degree_v: s.degree_v(),
        knots_u: s.knots_u().knots().to_vec(),
        knots_v: s.knots_v().knots().to_vec(),
        control_points: s.control_points(),
        weights: s.is_rational().then(|| s.weights()),
    }
}

/// The planned grid of a target, or a fresh plan when none was made.
fn grid_of<'a>(
    grids: &'a HashMap<(TargetId, Detail), GridPlan>,
    t: &TargetRecord,
    detail: Detail,
) -> std::borrow::Cow<'a, GridPlan> {
    match grids.get(&(t.id, detail)) {
        Some(plan) => std::borrow::Cow::Borrowed(plan),
        None => std::borrow::Cow::Owned(plan_grid(&t.surface, detail)),
    }
}

/// The grid of a target at a detail's stated tolerance.
fn plan_grid(surface: &NurbsSurface, detail: Detail) -> GridPlan {
    GridPlan::new(surface, detail.tolerance(extent(surface).diagonal()))
}

/// The domain minus the hidden region, as faces with holes.
fn visible_faces(hidden: &super::jordan::Region) -> Vec<Face> {
    use i_overlay::core::overlay_rule::OverlayRule;
    let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let holes = super::stroke::region_to_contours(hidden);
    let shapes = super::stroke::domain_overlay(&[square], &holes, OverlayRule::Difference);
    let to = |c: &Vec<[f64; 2]>| c.iter().map(|p| DVec2::new(p[0], p[1])).collect::<Vec<_>>();
    shapes
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| Face {
            outer: to(&s[0]),
            holes: s[1..].iter().map(to).collect(),
        })
        .collect()
}

// ---- JSON ----

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DocumentJson {
    format: String,
    version: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    description: Option<String>,
    targets: Vec<TargetJson>,
    strokes: Vec<StrokeJson>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetJson {
    id: u64,
    name: String,
    surface: NurbsSurface,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StrokeJson {
    id: u64,
    target: u64,
    tool: Tool,
    samples: Vec<[f64; 4]>,
}

#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<serde_json::Value>,
}

impl Document {
    /// The document as JSON bytes (format of the module docs). Undo history is not saved.
    pub fn to_json(&self) -> Vec<u8> {
        let doc = DocumentJson {
            format: FORMAT.into(),
            version: VERSION,
            description: None,
            targets: self
                .targets
                .iter()
                .map(|t| TargetJson {
                    id: t.id,
                    name: t.name.clone(),
                    surface: t.surface.clone(),
                })
                .collect(),
            strokes: self
                .strokes
                .iter()
                .map(|s| StrokeJson {
                    id: s.id,
                    target: s.target,
                    tool: s.input.tool.clone(),
                    samples: s
                        .input
                        .samples
                        .iter()
                        .map(|(t, p)| [*t, p.x, p.y, p.z])
                        .collect(),
                })
                .collect(),
        };
        serde_json::to_vec_pretty(&doc).unwrap_or_default()
    }

    /// Reads a document, replaying every stroke; rejects bad files with a clear error.
    pub fn from_json(bytes: &[u8]) -> Result<Self> {
        if bytes.len() > MAX_DOCUMENT_BYTES {
            return Err(Error::Document(DocumentError::TooLarge {
                bytes: bytes.len(),
                max: MAX_DOCUMENT_BYTES,
            }));
        }
        let header: Header = serde_json::from_slice(bytes)
            .map_err(|e| Error::Document(DocumentError::NotAnObject(e.into())))?;
        if header.format.as_deref() != Some(FORMAT) {
            return Err(Error::Document(DocumentError::Format {
                expected: FORMAT,
                found: header.format.as_deref().map(crate::error::Excerpt::new),
            }));
        }
        match header.version.as_ref().and_then(serde_json::Value::as_u64) {
            Some(v) if v == u64::from(VERSION) => {}
            other => {
                return Err(Error::Document(DocumentError::Version {
                    found: other,
                    supported: VERSION,
                }));
            }
        }
        let json: DocumentJson = serde_json::from_slice(bytes)
            .map_err(|e| Error::Document(DocumentError::Schema(e.into())))?;
        if json.targets.len() > MAX_TARGETS {
            return Err(Error::Document(DocumentError::TooManyTargets {
                max: MAX_TARGETS,
            }));
        }
        if json.strokes.len() > MAX_STROKES {
            return Err(Error::Document(DocumentError::TooManyStrokes {
                max: MAX_STROKES,
            }));
        }
        let mut doc = Document::new();
        for t in json.targets {
            if t.id == 0 || doc.targets.iter().any(|o| o.id == t.id) {
                return Err(Error::Document(DocumentError::TargetId { id: t.id }));
            }
            // Surfaces are read with the surface reader's caps; this is the same cap.
            doc.check_target_caps(&t.surface)?;
            doc.push_target(TargetRecord::new(t.id, t.name, t.surface));
        }
        for s in json.strokes {
            if s.id == 0 || doc.targets.iter().any(|t| t.id == s.id) {
                return Err(Error::Document(DocumentError::StrokeId { id: s.id }));
            }
            let input = StrokeInput {
                samples: s
                    .samples
                    .iter()
                    .map(|a| (a[0], DVec3::new(a[1], a[2], a[3])))
                    .collect(),
                tool: s.tool,
            };
            let id = s.id;
            doc.push_stroke(StrokeRecord {
                id,
                target: s.target,
                input,
            })
            .map_err(|e| {
                Error::Document(DocumentError::Stroke {
                    id,
                    error: Box::new(e),
                })
            })?;
        }
        doc.next_id = doc
            .targets
            .iter()
            .map(|t| t.id)
            .chain(doc.strokes.iter().map(|s| s.id))
            .max()
            .unwrap_or(0)
            + 1;
        // A loaded document has no history: what it holds is the base.
        doc.seal_history();
        Ok(doc)
    }
}
