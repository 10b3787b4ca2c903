//! A view's stroke surfaces ([`StrokeSurface`]: one per stroke piece, trimmed by the
//! pieces overlapping it), built when first asked for and kept while the piece's build
//! stands, and the IGES export and stroke meshes made from them.

use super::{CachedSurface, DocumentView};
use crate::formats::iges::IgesSurface;
use crate::mesh::MeshSink;
use crate::sculpt::document::{
    Document, TargetId, bounds_meet, patch_of, stroke_patch_key, visible_faces,
};
use crate::sculpt::stroke_surface::StrokeSurface;
use crate::sculpt::surface::extent;
use crate::sculpt::tessellate::Detail;
use std::sync::Arc;

impl DocumentView {
    /// Every surface for IGES export: each target as trimmed faces (the domain minus
    /// the strokes' footprints, entity 144) or whole (128) when untouched, and each
    /// stroke surface ([`StrokeSurface`]: cubic along the stroke) trimmed by its
    /// visible faces (144) where other strokes remove part of it, or whole (128).
    /// Strokes without a stroke surface (degenerate) and stroke surfaces wholly removed
    /// by others are left out.
    pub fn iges_surfaces(&mut self, doc: &Document) -> Vec<IgesSurface> {
        let mut out = Vec::new();
        for t in doc.targets() {
            let strokes = doc.strokes_on(t.id);
            let faces = (!strokes.is_empty()).then(|| {
                let regions: Vec<_> = strokes.iter().map(|s| &s.1.footprint).collect();
                visible_faces(&crate::sculpt::stroke::union(&regions))
            });
            out.push(IgesSurface {
                name: t.name.clone(),
                patch: patch_of(&t.surface),
                faces,
            });
            for (key, surface) in self.stroke_surfaces(doc, t.id) {
                let faces = (!surface.trim().is_empty()).then(|| visible_faces(surface.trim()));
                if faces.as_ref().is_some_and(Vec::is_empty) {
                    continue;
                }
                out.push(IgesSurface {
                    name: doc.piece_name(key),
                    patch: patch_of(surface.surface()),
                    faces,
                });
            }
        }
        out
    }

    /// The stroke surface of a stroke piece (by its key, see [`Document::strokes_on`];
    /// a stroke's first piece has the stroke's id), trimmed against the pieces
    /// overlapping it (see [`crate::sculpt::stroke_surface`]); `None` for an unknown
    /// key or a piece too degenerate to have one. Built on first use and cached; only
    /// pieces whose overlaps changed (an overlapping stroke applied or undone) are
    /// trimmed again.
    pub fn stroke_surface(&mut self, doc: &Document, key: u64) -> Option<Arc<StrokeSurface>> {
        let target = doc.piece_target(key)?;
        self.stroke_surfaces(doc, target)
            .into_iter()
            .find(|(k, _)| *k == key)
            .map(|(_, s)| s)
    }

    /// The stroke surfaces of every stroke piece on a target with their keys, in
    /// document order (pieces without one are left out). See [`Self::stroke_surface`].
    pub fn stroke_surfaces(
        &mut self,
        doc: &Document,
        target: TargetId,
    ) -> Vec<(u64, Arc<StrokeSurface>)> {
        self.prune_surfaces(doc);
        let Some(t) = doc.target(target) else {
            return Vec::new();
        };
        let strokes = doc.strokes_on(target);
        let builds = doc.piece_builds_on(target);
        let ext = extent(&t.surface);
        let closed = [ext.closed_u, ext.closed_v];
        let mut out = Vec::new();
        for (k, (&(id, stroke), &build)) in strokes.iter().zip(&builds).enumerate() {
            let overlaps: Vec<u64> = strokes
                .iter()
                .filter(|(_, o)| bounds_meet(&o.bounds, &stroke.bounds, closed))
                .map(|(oid, _)| *oid)
                .collect();
            let entry = self
                .surfaces
                .entry((id, build))
                .or_insert_with(|| CachedSurface {
                    overlaps: Vec::new(),
                    surface: StrokeSurface::build(t.target_surface(), stroke)
                        .ok()
                        .map(Arc::new),
                });
            if let Some(surface) = &mut entry.surface {
                if entry.overlaps != overlaps {
                    Arc::make_mut(surface).trim_against(t.target_surface(), &strokes, k, closed);
                    entry.overlaps = overlaps;
                }
                out.push((id, Arc::clone(surface)));
            }
        }
        out
    }

    /// Drops the cached stroke surfaces of pieces no longer in `doc` as built (undone,
    /// or rebuilt by a deformation), once per document revision.
    fn prune_surfaces(&mut self, doc: &Document) {
        if self.surfaces_seen == Some(doc.revision()) {
            return;
        }
        self.surfaces_seen = Some(doc.revision());
        let live = doc.piece_builds();
        self.surfaces.retain(|key, _| live.contains(key));
    }

    /// Tessellates the visible part of one stroke piece's surface (by its key, see
    /// [`Self::stroke_surface`]) through its UV map at `detail` into `sink`, as one
    /// patch keyed by [`stroke_patch_key`]. Returns the triangles written (0, and
    /// nothing written, when the piece has no surface).
    pub fn stroke_surface_mesh(
        &mut self,
        doc: &Document,
        key: u64,
        detail: Detail,
        sink: &mut dyn MeshSink,
    ) -> usize {
        self.stroke_surface(doc, key)
            .map_or(0, |s| s.tessellate(detail, stroke_patch_key(key), sink))
    }

    /// [`Self::stroke_surface_mesh`] for every stroke piece of the document. Returns the
    /// triangles written.
    pub fn stroke_surfaces_mesh(
        &mut self,
        doc: &Document,
        detail: Detail,
        sink: &mut dyn MeshSink,
    ) -> usize {
        let mut triangles = 0;
        for t in doc.targets() {
            for (id, s) in self.stroke_surfaces(doc, t.id) {
                triangles += s.tessellate(detail, stroke_patch_key(id), sink);
            }
        }
        triangles
    }
}
