//! What is drawn from a [`Document`]: its tessellation into mesh sinks at each detail
//! (the targets' tessellation views with their UV maps, the grids planned for them,
//! the conforming patch network), the stroke being drawn (the preview), and the stroke
//! surfaces the exports and stroke meshes use.
//!
//! A [`DocumentView`] is derived state only. It reads the document through `&Document`
//! and brings itself up to date from the revisions the document records
//! ([`Document::revision`], [`Document::target_revision`]): a target whose geometry
//! revision differs from the one its mesh was made at is written whole (its old patches
//! removed), one whose pieces changed is rewritten where they did, a target no longer
//! in the document has its patches removed. Nothing here edits the model, so drawing
//! needs no `&mut Document`, and any number of views (one per set of sinks: the
//! window's, the headset's, an export's) follow one document.
//!
//! The strokes' pieces are the document's, not a view's: a stroke is accepted only
//! once it builds (see [`Document`]), so the view reads them as built. The preview is
//! built here ([`Document::build_stroke`]) and never reaches the model.
//!
//! A view follows the document it was synced with (and clones of it made together
//! with a clone of the view). For another document, start a new view or call
//! [`DocumentView::forget_sinks`] with new, empty sinks.
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::mesh::PatchMesh;
//! use sculpt_core::nurbs::NurbsSurface;
//! use sculpt_core::sculpt::document::Document;
//! use sculpt_core::sculpt::tessellate::Detail;
//! use sculpt_core::sculpt::view::DocumentView;
//!
//! let plane = NurbsSurface::new(1, 1, vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0],
//!     vec![vec![DVec3::ZERO, DVec3::Y], vec![DVec3::X, DVec3::new(1.0, 1.0, 0.0)]], None)?;
//! let mut doc = Document::new();
//! let target = doc.add_target("plane", plane);
//! let doc = doc; // drawing needs only a shared reference
//! let mut view = DocumentView::new();
//! let mut sink = PatchMesh::new();
//! view.tessellate(&doc, Detail::Final, &mut sink);
//! assert!(view.uv_map(target, Detail::Final).is_some());
//! assert_eq!(view.tessellate(&doc, Detail::Final, &mut sink).patches_written, 0);
//! # Ok::<(), sculpt_core::Error>(())
//! ```

mod surfaces;
mod tessellation;

use super::document::{
    Built, ConformState, Document, PREVIEW_IDS, TargetId, TargetRevision, conform_key, plan_grid,
};
use super::stroke::{StrokeInput, StrokePieces};
use super::stroke_surface::StrokeSurface;
use super::tessellate::{Detail, GridPlan, TargetTessellation};
use super::uvmap::UvMap;
use crate::error::Result;
use crate::solid::SolidPreview;
use std::collections::{HashMap, HashSet};
use std::sync::Arc;

/// The derived state of drawing one document into one set of sinks (see the module
/// docs).
#[derive(Debug, Clone, Default)]
pub struct DocumentView {
    /// The tessellation view of each target at each detail.
    views: HashMap<(TargetId, Detail), TargetTessellation>,
    /// The document's revisions of each target when its view was last synced.
    drawn: HashMap<(TargetId, Detail), TargetRevision>,
    /// Targets to rewrite at the next tessellation at a detail.
    dirty: HashSet<(TargetId, Detail)>,
    /// Patches of targets removed (or whose geometry was replaced) to take out of the
    /// sink of a detail at its next tessellation.
    removed: Vec<(Detail, Vec<u64>)>,
    /// The grid of each target at each detail, planned for its geometry.
    grids: HashMap<(TargetId, Detail), GridPlan>,
    /// The stroke being drawn, shown at interactive detail only.
    preview: Option<(TargetId, Built)>,
    /// Preview pieces so far (each gets a fresh key, so the tessellator sees it change).
    preview_serial: u64,
    /// The stroke being drawn on a solid target: the blocks it changes, meshed
    /// ([`SolidTarget::preview`](crate::solid::SolidTarget::preview)).
    solid_preview: Option<(TargetId, SolidPreview)>,
    /// The conforming tessellation of the targets that form a patch network, per
    /// detail ([`crate::sculpt::conform`]).
    conform: HashMap<Detail, ConformState>,
    /// Stroke surfaces by piece key and the document revision the piece was built at.
    surfaces: HashMap<(u64, u64), CachedSurface>,
    /// The document revision the stroke-surface cache was last pruned at.
    surfaces_seen: Option<u64>,
}

/// A stroke piece's cached surface: the pieces (keys, document order, itself included)
/// whose bounds met its own when it was trimmed, and the surface (`None` when the piece
/// is too degenerate to have one).
#[derive(Debug, Clone)]
struct CachedSurface {
    overlaps: Vec<u64>,
    surface: Option<Arc<StrokeSurface>>,
}

impl DocumentView {
    /// A view that has drawn nothing: its first tessellation at each detail writes
    /// every patch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Brings the view's record of `doc` at `detail` up to date from the document's
    /// revisions: targets gone or with new geometry have their patches queued for
    /// removal and their grids planned again; those whose pieces changed are marked
    /// dirty.
    fn sync(&mut self, doc: &Document, detail: Detail) {
        let stale: Vec<(TargetId, Detail)> = self
            .drawn
            .iter()
            .filter(|&(&(id, d), was)| {
                d == detail
                    && doc
                        .target_revision(id)
                        .is_none_or(|now| now.geometry != was.geometry)
            })
            .map(|(&key, _)| key)
            .collect();
        for key in stale {
            self.drawn.remove(&key);
            self.dirty.remove(&key);
            self.grids.remove(&key);
            if let Some(view) = self.views.remove(&key) {
                let n = view.map().n();
                self.removed
                    .push((detail, (0..n * n).map(|r| view.patch_key(r)).collect()));
            }
        }
        for t in doc.targets() {
            let key = (t.id, detail);
            let Some(now) = doc.target_revision(t.id) else {
                continue;
            };
            if self.drawn.get(&key) != Some(&now) {
                self.dirty.insert(key);
                self.drawn.insert(key, now);
            }
            self.grids
                .entry(key)
                .or_insert_with(|| plan_grid(&t.surface, detail));
        }
    }

    /// Shows `input` on `target` as the stroke being drawn. On a solid target the
    /// blocks it changes are meshed with it ([`Self::solid_preview`], shown by the
    /// solid's view). On a NURBS target it is carved into the
    /// [`Detail::Interactive`] tessellation (only the cells it touches, and the cells of
    /// the preview it replaces, are rewritten) but it is not part of the document: not
    /// in [`Document::strokes`], the history, the final detail, the exports or the JSON.
    /// A stroke the sculpting layer rejects clears the preview and says why. The preview
    /// is carved in pieces as the stroke will be ([`StrokePieces`]).
    pub fn set_preview(
        &mut self,
        doc: &Document,
        target: TargetId,
        input: &StrokeInput,
    ) -> Result<()> {
        if let Some(record) = doc.solid(target) {
            // The same stroke with fewer samples: its evaluated blocks are reused.
            let previous = self
                .solid_preview
                .take()
                .filter(|(t, _)| *t == target)
                .map(|(_, p)| p);
            self.clear_preview();
            doc.check_stroke_caps(input.samples.len())?;
            let preview = record.solid.preview(input, previous)?;
            self.solid_preview = Some((target, preview));
            return Ok(());
        }
        self.clear_preview();
        let (pieces, targets) = doc.build_stroke(target, input)?;
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
            revision: 0,
        };
        self.mark_dirty(&built);
        self.preview = Some((target, built));
        Ok(())
    }

    /// Removes the preview stroke, if any.
    pub fn clear_preview(&mut self) {
        self.solid_preview = None;
        if let Some((_, built)) = self.preview.take() {
            self.mark_dirty(&built);
        }
    }

    /// The preview stroke on a solid target and the target: what a solid's view shows
    /// at interactive detail in place of the blocks it changes. [`Self::set_preview`]
    /// on a solid sets it; a NURBS target's preview is [`Self::preview`].
    pub fn solid_preview(&self) -> Option<(TargetId, &SolidPreview)> {
        self.solid_preview.as_ref().map(|(t, p)| (*t, p))
    }

    /// The preview stroke's pieces and its target.
    pub fn preview(&self) -> Option<(TargetId, &StrokePieces)> {
        self.preview.as_ref().map(|(t, b)| (*t, &b.pieces))
    }

    /// Marks the targets of `built`'s pieces dirty at the interactive detail (where the
    /// preview is shown).
    fn mark_dirty(&mut self, built: &Built) {
        for &t in &built.targets {
            self.dirty.insert((t, Detail::Interactive));
        }
    }

    /// The UV vector map sculpting uses for `target` at `detail`: the quadtree of the
    /// target's tessellation view (its grid planned for the detail's tolerance of the
    /// surface's extent, wrapped on closed sides, updated with the strokes' footprints),
    /// the one the renderer's mesh and the quadtree overlay show. `None` before this
    /// view tessellated the document at `detail`, and for a target drawn as one patch
    /// of a conforming network (uncarved: it has no quadtree).
    pub fn uv_map(&self, target: TargetId, detail: Detail) -> Option<&UvMap> {
        self.views
            .get(&(target, detail))
            .filter(|v| !v.is_fresh())
            .map(TargetTessellation::map)
    }

    /// Forgets what was written to the sinks so far: the next
    /// [`DocumentView::tessellate`] at each detail writes every patch again, as into
    /// new, empty sinks. The preview stays.
    pub fn forget_sinks(&mut self) {
        self.views.clear();
        self.conform.clear();
        self.drawn.clear();
        self.dirty.clear();
        self.removed.clear();
    }

    /// Forgets what was written to the sink of `detail` only (see
    /// [`Self::forget_sinks`]): the next [`DocumentView::tessellate`] at `detail`
    /// writes every patch again; the other detail's sink stays as it is. A renderer
    /// that drew something else into that sink (the live lattice preview) puts the
    /// document back this way.
    pub fn forget_sink(&mut self, detail: Detail) {
        self.views.retain(|&(_, d), _| d != detail);
        self.conform.remove(&detail);
        self.drawn.retain(|&(_, d), _| d != detail);
        self.dirty.retain(|&(_, d)| d != detail);
        self.removed.retain(|(d, _)| *d != detail);
    }

    /// Starts over for another document in the same sinks: every patch this view
    /// wrote (targets' and conforming patches, at each detail) is taken out of its sink
    /// at the next [`DocumentView::tessellate`] at that detail, which then writes the
    /// document it is given whole. The preview goes too. A cluster node that replaces
    /// its document does this, so its sinks hold nothing of the old one.
    pub fn start_over(&mut self) {
        for ((_, detail), view) in self.views.drain() {
            let n = view.map().n();
            self.removed
                .push((detail, (0..n * n).map(|r| view.patch_key(r)).collect()));
        }
        for (detail, state) in self.conform.drain() {
            let keys = state
                .written
                .iter()
                .enumerate()
                .filter(|(_, w)| w.is_some())
                .map(|(k, _)| conform_key(k))
                .collect();
            self.removed.push((detail, keys));
        }
        self.drawn.clear();
        self.dirty.clear();
        self.grids.clear();
        self.preview = None;
        self.solid_preview = None;
    }

    /// Memory held by the view's tessellation (its UV maps and height fields), bytes.
    pub fn memory_bytes(&self) -> usize {
        self.views
            .values()
            .map(TargetTessellation::memory_bytes)
            .sum()
    }
}
