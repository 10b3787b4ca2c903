//! The document: target surfaces and the strokes applied to them, in order, with undo
//! and redo of every step back to the start, a versioned JSON file format, tessellation
//! into [`MeshSink`](crate::mesh::MeshSink)s (through a view) and export.
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
//! use sculpt_core::sculpt::view::DocumentView;
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
//! // What is drawn is a view's: it syncs from `&doc` and keeps the tessellation.
//! let mut view = DocumentView::new();
//! let mut gpu_like = PatchMesh::new(); // vr-app passes its GPU-buffer sink here
//! let stats = view.tessellate(&doc, Detail::Interactive, &mut gpu_like);
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
//!   ],
//!   "paints": [
//!     {"target": 1, "attribute": "colour", "value": [0.8, 0.3, 0.15], "radius": 0.03,
//!      "samples": [[x, y, z], ..]}
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
//! `paints` (absent when nothing is painted) are paint strokes
//! ([`crate::paint::PaintEdit`]), applied again in order on loading.
//!
//! # The model and its views
//!
//! A `Document` is the model and its history only: targets, strokes, deformations,
//! paint, solids, the undo and redo stacks and the ids. What is drawn from it (the
//! tessellation of each target at each detail with its UV map, the grids, the patch
//! network's conforming state, the stroke being drawn, the stroke surfaces) is derived
//! state and lives in a [`DocumentView`](super::view::DocumentView), which reads the
//! document through `&Document` and syncs from the revisions it records
//! ([`Document::revision`], [`Document::target_revision`]).
//!
//! Each stroke's pieces as built ([`Document::stroke`], [`Document::strokes_on`]) stay
//! in the model, because the model's own edits need them: a stroke is accepted only
//! once it builds (the sculpting rules reject it otherwise, [`StrokePieces::build`]), a
//! redone stroke is built again, and a deformation is refused when a carried stroke no
//! longer builds. Building is the validation, so its result is kept
//! with the stroke; the pieces' keys are the names views, exports and the tessellator
//! share. Views never build document strokes again; only the preview, which the model
//! never holds, is built by a view ([`Document::build_stroke`]).

use super::conform::{
    Network, NetworkPlan, SharedSide, holder_params, shared_side, write_network_with,
};
use super::jordan::Rect;
use super::network_stroke::build_on_network;
use super::stroke::{StrokeInput, StrokePieces, Tool};
use super::surface::{TargetSurface, extent};
use super::tessellate::{Detail, FixedSides, GridPlan, StrokeRef, TargetTessellation, pole_height};
use crate::error::{ControlNetError, DocumentError, Error, Result, StrokeRejection};
use crate::formats::iges::{Face, NurbsPatch};
use crate::mesh::PatchMesh;
use crate::nurbs::NurbsSurface;
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// The format tag of document files.
pub const FORMAT: &str = "wandsculpt-document";
/// The document format version this build writes and reads.
pub const VERSION: u32 = 1;
/// Largest document accepted by [`Document::from_json`], bytes.
pub const MAX_DOCUMENT_BYTES: usize = 256 << 20;
pub use super::ids::MAX_TARGETS;
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

pub use super::ids::TargetId;

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
    /// A solid target added or a stroke on one ([`solid`]).
    Solid(SolidStep),
    Paint(Box<PaintRecord>),
}

mod deform;
mod json;
mod paint;
pub use paint::{MAX_PAINTS, PaintRecord};
mod pieces;
mod solid;
mod tessellation;
pub use deform::{DeformRecord, MAX_DEFORMS, carry_stroke};
use pieces::*;
pub(crate) use pieces::{Built, fixed_sides};
pub use solid::{MAX_SOLIDS, SolidRecord, SolidStep};
pub(crate) use tessellation::{
    ConformState, bounds_meet, grid_of, patch_of, plan_grid, visible_faces,
};
pub use tessellation::{conform_key, stroke_patch_key};

/// Targets, strokes and their history: the model. What is drawn from it (tessellation
/// views, grids, the preview, stroke surfaces) is a [`DocumentView`](super::view::DocumentView)'s.
///
/// The one derived thing the model keeps is each stroke's pieces as built: a stroke is
/// accepted only once it builds (the sculpting rules reject it otherwise, and a
/// deformation is refused when a carried stroke no longer builds), so building is part
/// of every stroke edit, and the pieces' keys are the names exports and views share.
/// Views read the pieces; they never build document strokes again.
///
/// Every change is recorded as revisions ([`Self::revision`]; per target, when its
/// geometry was last put in place and when the pieces on it last changed), from which
/// a view syncs without `&mut Document`.
#[derive(Debug, Clone, Default)]
pub struct Document {
    targets: Vec<TargetRecord>,
    strokes: Vec<StrokeRecord>,
    /// Lattice deformations applied since the base, in order ([`Self::apply_deform`]).
    deforms: Vec<DeformRecord>,
    /// Paint strokes applied since the base, in order ([`Self::apply_paint`]).
    paints: Vec<PaintRecord>,
    redo: Vec<Step>,
    next_id: u64,
    /// Steps with ids up to this are the document's base (made before its first edit,
    /// or loaded): undo stops there ([`Self::seal_history`]).
    history_floor: u64,
    /// Each stroke as built (its pieces and their keys): see the type's docs.
    built: HashMap<StrokeId, Built>,
    /// Pieces after the first of document strokes so far (each gets a fresh key).
    piece_serial: u64,
    /// Wand samples of all strokes in [`Self::strokes`] (for [`MAX_DOCUMENT_SAMPLES`]).
    samples_total: usize,
    /// Solid targets ([`solid`]) and the ids of their steps (adding one, a stroke on
    /// one), in history order.
    solids: Vec<SolidRecord>,
    solid_history: Vec<u64>,
    /// Bumped by every change ([`Self::revision`]).
    revision: u64,
    /// Per target: the revision its geometry was put in place at (added, redone or
    /// deformed) and the revision the pieces carved into it last changed at.
    target_revs: HashMap<TargetId, TargetRevision>,
}

/// When a target last changed ([`Document::target_revision`]), in
/// [`Document::revision`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TargetRevision {
    /// The revision its surface was put in place at: added, redone or deformed. A view
    /// whose mesh of it is older drops that mesh and writes it whole.
    pub geometry: u64,
    /// The revision the pieces carved into it (or its geometry) last changed at.
    pub touched: u64,
}

/// The next revision of any document in this process: a counter shared by all
/// documents (an atomic, so documents on several threads stay unique), so that
/// revisions name one state of one document's history (see [`Document::revision`]).
/// Revisions never reach a file or an output.
fn next_revision() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
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
        let last_solid = self.last_solid_step().filter(|&id| id > floor);
        let last_paint = self.paints.last().map(|p| p.id).filter(|&id| id > floor);
        // Steps are strictly ordered by id: undo whichever came last.
        let last = [
            (last_stroke, 0),
            (last_target, 1),
            (last_deform, 2),
            (last_solid, 3),
            (last_paint, 4),
        ]
        .into_iter()
        .filter_map(|(id, kind)| id.map(|id| (id, kind)))
        .max();
        let step = match last {
            Some((_, 0)) => self.pop_stroke(),
            Some((_, 1)) => self.pop_target(),
            Some((_, 2)) => self.pop_deform(),
            Some((_, 3)) => self.pop_solid_step(),
            Some(_) => self.pop_paint(),
            None => None,
        };
        match step {
            Some(step) => {
                self.bump();
                self.redo.push(step);
                true
            }
            None => false,
        }
    }

    /// Redoes the last undone step; false when there is nothing to redo.
    pub fn redo(&mut self) -> bool {
        let done = self.redo_step();
        if done {
            self.bump();
        }
        done
    }

    /// [`Self::redo`] before the revision is raised.
    fn redo_step(&mut self) -> bool {
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
            Some(Step::Solid(s)) => self.push_solid_step(s),
            Some(Step::Paint(p)) => self.push_paint(*p),
            None => false,
        }
    }

    /// True when [`Self::undo`] would do something.
    pub fn can_undo(&self) -> bool {
        let floor = self.history_floor;
        self.strokes.last().is_some_and(|s| s.id > floor)
            || self.targets.last().is_some_and(|t| t.id > floor)
            || self.deforms.last().is_some_and(|d| d.id > floor)
            || self.last_solid_step().is_some_and(|id| id > floor)
            || self.paints.last().is_some_and(|p| p.id > floor)
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
        self.put_geometry(t.id);
        self.next_id = self.next_id.max(t.id + 1);
        self.targets.push(t);
    }

    fn pop_target(&mut self) -> Option<Step> {
        let t = self.targets.pop()?;
        self.bump();
        self.target_revs.remove(&t.id);
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
        self.bump();
        let built = Built {
            keys,
            pieces,
            targets,
            revision: self.revision,
        };
        self.touch_built(&built);
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
            self.touch_built(&built);
        }
        Some(Step::Stroke(s))
    }

    /// Records that the pieces of `built` changed on their targets (a new revision).
    fn touch_built(&mut self, built: &Built) {
        self.bump();
        for &t in &built.targets {
            if let Some(r) = self.target_revs.get_mut(&t) {
                r.touched = self.revision;
            }
        }
    }

    /// Records that `target`'s geometry was (re)put in place (a new revision).
    fn put_geometry(&mut self, target: TargetId) {
        self.bump();
        self.target_revs.insert(
            target,
            TargetRevision {
                geometry: self.revision,
                touched: self.revision,
            },
        );
    }

    /// The document's revision: a number every change (a step applied, undone or
    /// redone, a target added or read) raises. Revisions are unique in the process
    /// (one counter shared by all documents): equal revisions mean the same document at the same point
    /// (or a clone made there), never two different models, so a view handed another
    /// document sees every target as new rather than mistaking it for one it drew.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Moves the document to a new revision ([`next_revision`]).
    fn bump(&mut self) {
        self.revision = next_revision();
    }

    /// When target `id` last changed; `None` for a target not in the document.
    pub fn target_revision(&self, id: TargetId) -> Option<TargetRevision> {
        self.target_revs.get(&id).copied()
    }

    /// Builds `input` on `target` as [`Self::apply_stroke`] would, without applying
    /// it: its pieces and the target each is carved into (on a patch network, maybe a
    /// neighbour). Views build the stroke being drawn this way
    /// ([`DocumentView::set_preview`](super::view::DocumentView::set_preview)).
    pub fn build_stroke(
        &self,
        target: TargetId,
        input: &StrokeInput,
    ) -> Result<(StrokePieces, Vec<TargetId>)> {
        let record = self.target(target).ok_or(Error::NotFound {
            kind: "target",
            id: target,
        })?;
        self.build_pieces(record, input)
    }

    /// The strokes on one target, in order, as the tessellator takes them: every piece
    /// of each stroke in drawing order, keyed by its piece key (a stroke's first piece
    /// by the stroke's id, see [`Self::piece_keys`]).
    pub fn strokes_on(&self, target: TargetId) -> Vec<StrokeRef<'_>> {
        pieces_on(&self.strokes, &self.built, target).collect()
    }

    /// Memory held by the strokes as built (their projected pieces), bytes; a view's
    /// own is [`DocumentView::memory_bytes`](super::view::DocumentView::memory_bytes).
    pub fn memory_bytes(&self) -> usize {
        self.built
            .values()
            .map(|b| b.pieces.memory_bytes())
            .sum::<usize>()
    }
}
