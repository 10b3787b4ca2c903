//! Strokes as built: their pieces, the cached stroke surfaces, and the surfaces for
//! IGES export.

use super::*;

/// A stroke as built: its pieces and the key of each, under which the tessellator and
/// the stroke-surface cache know it ([`Document::strokes_on`]).
#[derive(Debug, Clone)]
pub(super) struct Built {
    pub(super) keys: Vec<u64>,
    pub(super) pieces: StrokePieces,
    /// Per piece, the target it is carved into: the stroke's own, or on a patch
    /// network the patch its run fell on ([`crate::sculpt::network_stroke`]).
    pub(super) targets: Vec<TargetId>,
}

impl Built {
    /// The pieces with their keys.
    pub(super) fn refs(&self) -> impl Iterator<Item = StrokeRef<'_>> {
        self.keys.iter().copied().zip(&self.pieces.pieces)
    }

    /// The pieces carved into `target`, with their keys.
    pub(super) fn refs_on(&self, target: TargetId) -> impl Iterator<Item = StrokeRef<'_>> {
        self.refs()
            .zip(&self.targets)
            .filter(move |(_, t)| **t == target)
            .map(|(r, _)| r)
    }

    /// Each piece's target and footprint bounds.
    pub(super) fn areas(&self) -> impl Iterator<Item = (TargetId, Rect)> + '_ {
        self.targets
            .iter()
            .copied()
            .zip(self.pieces.pieces.iter().map(|p| p.bounds))
    }
}

/// The pieces of the strokes on `target`, in order, with their keys (see
/// [`Document::strokes_on`]).
pub(super) fn pieces_on<'a>(
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
pub(super) fn strokes_at<'a>(
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
pub(super) fn fixed_sides(sides: &[SharedSide], network: &Network, k: usize) -> FixedSides {
    std::array::from_fn(|s| SharedSide::own(sides, network, k, s))
}

/// A stroke piece's cached surface: the pieces (keys, document order, itself included)
/// whose bounds met its own when it was trimmed, and the surface (`None` when the piece
/// is too degenerate to have one).
#[derive(Debug, Clone)]
pub(super) struct CachedSurface {
    pub(super) overlaps: Vec<u64>,
    pub(super) surface: Option<Arc<StrokeSurface>>,
}

/// The stroke-surface cache: filled through `&self` (exports take `&Document`), hence
/// the lock; cloning a document clones the cache.
#[derive(Debug, Default)]
pub(super) struct SurfaceCache(Mutex<HashMap<u64, CachedSurface>>);

impl SurfaceCache {
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<u64, CachedSurface>> {
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

impl Document {
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
                visible_faces(&crate::sculpt::stroke::union(&regions))
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
    pub(super) fn piece_name(&self, key: u64) -> String {
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
    pub(super) fn piece_target(&self, key: u64) -> Option<TargetId> {
        self.strokes.iter().find_map(|s| {
            let b = self.built.get(&s.id)?;
            let k = b.keys.iter().position(|&x| x == key)?;
            b.targets.get(k).copied()
        })
    }

    /// Builds a stroke's pieces on `target` and the target of each: on a patch network
    /// the stroke is projected onto the whole network ([`build_on_network`]), otherwise
    /// onto `target` alone ([`StrokePieces::build`]). The snap distance is `target`'s.
    pub(super) fn build_pieces(
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
    /// overlapping it (see [`crate::sculpt::stroke_surface`]); `None` for an unknown key or a
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
