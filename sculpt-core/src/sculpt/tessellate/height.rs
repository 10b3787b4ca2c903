//! The height field: the combined displacement of the strokes along the target's
//! normal, and the pass's evaluation cache.

use super::StrokeRef;
use super::poles::{pole_of, pole_point, pole_uv};
use crate::sculpt::jordan::Location;
use crate::sculpt::stroke::Mode;
use crate::sculpt::surface::{ParamSurface, normal_from};
use crate::tolerance::ON_EDGE_EPS;
use glam::{DVec2, DVec3};
use rustc_hash::FxHasher;
use std::collections::HashMap;
use std::hash::BuildHasherDefault;

/// The index of the stroke that sets [`height`] at `uv` (`p` on the target near
/// `S(uv)`), if any; a stroke counts where its depth is positive.
pub(super) fn winner(strokes: &[StrokeRef<'_>], uv: DVec2, p: DVec3) -> Option<usize> {
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
pub(super) fn evaluate(
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
/// strictly inside its footprint (and on the sides of the square, where a wrapped
/// footprint was cut), so the sculpted part ends exactly at the hidden region's outline, and on a stroke's outline inside an earlier stroke's footprint
/// (a step where a ridge crosses a groove) the earlier height holds: the step's mesh
/// vertices all lie on its low (or high) side, whichever stroke came first.
pub fn height(strokes: &[StrokeRef<'_>], uv: DVec2, p: DVec3) -> f64 {
    height_and_deepest(strokes, uv, p).0
}

/// [`height`], and the stroke that sets it (its id) with the centreline segment that
/// gives it its depth there.
pub(super) fn height_and_deepest(
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
        // On the square's sides an outline is where a wrapped footprint was cut (a seam
        // or a pole): the stroke goes on across it and acts there.
        let acts = match s.footprint.locate(uv) {
            Location::Inside => true,
            Location::OnBoundary => {
                let near_side = |x: f64| x <= ON_EDGE_EPS || x >= 1.0 - ON_EDGE_EPS;
                near_side(uv.x) || near_side(uv.y)
            }
            Location::Outside => false,
        };
        if d > 0.0 && acts {
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

/// Surface point, normal and displacement per parameter (bit pattern), shared by the
/// patches of one pass so that side and corner vertices are evaluated once.
pub(super) type EvalCache = HashMap<(u64, u64), Evaluated, BuildHasherDefault<FxHasher>>;

/// `S(uv)`, the target's normal, the combined displacement and the stroke setting it
/// (see [`PatchVertex::deepest`]).
pub(super) type Evaluated = (DVec3, DVec3, f64, Option<(u64, usize)>);

/// A hash map with rustc's [`FxHasher`] (Fx: parameters are not adversarial, and
/// SipHash dominated the cache's cost).
pub(super) type FxMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;
