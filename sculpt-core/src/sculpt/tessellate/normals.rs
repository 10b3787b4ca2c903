//! Shading normals: per triangle corner, the exact normal of the sculpted surface as
//! seen from inside the triangle.

use super::StrokeRef;
use super::height::{FxMap, winner};
use super::poles::pole_of;
use crate::sculpt::stroke::Mode;
use glam::{DVec2, DVec3};

/// A vertex of a patch before it is written.
pub(super) struct PatchVertex {
    /// `S(uv)`.
    pub(super) surface_point: DVec3,
    /// The target's unit normal at `uv`.
    pub(super) normal: DVec3,
    pub(super) uv: DVec2,
    /// The combined displacement along the normal.
    pub(super) height: f64,
    /// Displaced, or on a rim: its triangles may see different normals.
    pub(super) sculpted: bool,
    /// Where displaced (off the rims), the stroke that sets `height` (its id) and the
    /// centreline segment giving it its depth ([`Stroke::gradient_segment`](crate::sculpt::stroke::Stroke::gradient_segment)).
    pub(super) deepest: Option<(u64, usize)>,
}

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
pub(super) fn corner_normals(
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
pub(super) struct GradientSegments {
    pub(super) first: Vec<Option<(usize, Option<usize>)>>,
    /// The later strokes' segments, by (vertex, stroke); the first one put wins.
    pub(super) more: FxMap<(u32, usize), Option<usize>>,
}

impl GradientSegments {
    pub(super) fn get(&self, vertex: u32, stroke: usize) -> Option<Option<usize>> {
        match self.first[vertex as usize] {
            Some((k, seg)) if k == stroke => Some(seg),
            Some(_) => self.more.get(&(vertex, stroke)).copied(),
            None => None,
        }
    }

    pub(super) fn put(&mut self, vertex: u32, stroke: usize, segment: Option<usize>) {
        match self.first[vertex as usize] {
            None => self.first[vertex as usize] = Some((stroke, segment)),
            Some(_) => {
                self.more.entry((vertex, stroke)).or_insert(segment);
            }
        }
    }
}
