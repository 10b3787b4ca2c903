//! Strokes as built: their pieces and the keys of each (the stroke surfaces made from
//! them are a view's, [`crate::sculpt::view`]).

use super::*;

/// A stroke as built: its pieces and the key of each, under which the tessellator and
/// the stroke-surface cache know it ([`Document::strokes_on`]).
#[derive(Debug, Clone)]
pub(crate) struct Built {
    pub(crate) keys: Vec<u64>,
    pub(crate) pieces: StrokePieces,
    /// Per piece, the target it is carved into: the stroke's own, or on a patch
    /// network the patch its run fell on ([`crate::sculpt::network_stroke`]).
    pub(crate) targets: Vec<TargetId>,
    /// The document revision it was built at (0: a view's preview); a view's cached
    /// stroke surfaces of its pieces are valid for this build only.
    pub(crate) revision: u64,
}

impl Built {
    /// The pieces with their keys.
    pub(crate) fn refs(&self) -> impl Iterator<Item = StrokeRef<'_>> {
        self.keys.iter().copied().zip(&self.pieces.pieces)
    }

    /// The pieces carved into `target`, with their keys.
    pub(crate) fn refs_on(&self, target: TargetId) -> impl Iterator<Item = StrokeRef<'_>> {
        self.refs()
            .zip(&self.targets)
            .filter(move |(_, t)| **t == target)
            .map(|(r, _)| r)
    }
}

/// The pieces of the strokes on `target`, in order, with their keys (see
/// [`Document::strokes_on`]).
pub(crate) fn pieces_on<'a>(
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
pub(crate) fn strokes_at<'a>(
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
pub(crate) fn fixed_sides(sides: &[SharedSide], network: &Network, k: usize) -> FixedSides {
    std::array::from_fn(|s| SharedSide::own(sides, network, k, s))
}

impl Document {
    /// The name of a stroke piece in exports: `stroke<id>` for a stroke's first piece,
    /// `stroke<id>-<k>` for its k-th (counting from 1).
    pub(crate) fn piece_name(&self, key: u64) -> String {
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
    pub(crate) fn piece_target(&self, key: u64) -> Option<TargetId> {
        self.strokes.iter().find_map(|s| {
            let b = self.built.get(&s.id)?;
            let k = b.keys.iter().position(|&x| x == key)?;
            b.targets.get(k).copied()
        })
    }

    /// Builds a stroke's pieces on `target` and the target of each: on a patch network
    /// the stroke is projected onto the whole network ([`build_on_network`]), otherwise
    /// onto `target` alone ([`StrokePieces::build`]). The snap distance is `target`'s.
    pub(crate) fn build_pieces(
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
}

impl Document {
    /// The build revision of each piece of [`Self::strokes_on`]`(target)`, in the
    /// same order.
    pub(crate) fn piece_builds_on(&self, target: TargetId) -> Vec<u64> {
        self.strokes
            .iter()
            .filter_map(|s| self.built.get(&s.id))
            .flat_map(|b| b.refs_on(target).map(move |_| b.revision))
            .collect()
    }

    /// Every piece of the document as built: `(key, build revision)`.
    pub(crate) fn piece_builds(&self) -> std::collections::HashSet<(u64, u64)> {
        self.built
            .values()
            .flat_map(|b| b.keys.iter().map(move |&k| (k, b.revision)))
            .collect()
    }

    /// The pieces the tessellator carves into `target` at `detail`: the document's,
    /// and at interactive detail a view's `preview`.
    pub(crate) fn strokes_at<'a>(
        &'a self,
        preview: &'a Option<(TargetId, Built)>,
        target: TargetId,
        detail: Detail,
    ) -> Vec<StrokeRef<'a>> {
        strokes_at(&self.strokes, &self.built, preview, target, detail)
    }
}
