//! Strokes on a patch network (issue 30): a stroke is projected onto the whole network,
//! not onto the one patch selected, and carves one continuous groove across the shared
//! sides it crosses, each patch holding its piece in its own UV map.
//!
//! 1. The wand polyline is resampled as for one target ([`resample`], a quarter of the
//!    tool width) and every sample is projected onto **every patch** whose control
//!    points' bounding box, widened by the snap distance, holds it (a NURBS patch lies
//!    in the convex hull of its control points, P&T sec. 4.4, so no other patch can be
//!    nearer than the snap distance), through each patch's certified inverter
//!    ([`TargetSurface::closest_point`]); the nearest foot wins (the lower patch index on
//!    a tie). Samples farther than the snap distance from every patch are off the
//!    network.
//! 2. The samples are cut into **runs** on one patch each. Where consecutive samples
//!    fall on patches `A` then `B`, the wand path between them is bisected for the
//!    point where the nearer patch changes (local projections seeded at the two feet),
//!    and the crossing point `X` is the foot on `A` of the bisection's end nearer `B`
//!    (clamped onto the shared side, where the stroke passes over it); `A`'s run ends
//!    at `X` and `B`'s run starts there.
//! 3. Each run is built on its patch as a stroke of its own
//!    ([`StrokePieces::build_ends`]), **tapered only at the stroke's own ends**: where a
//!    run ends at a crossing its piece ends bluntly at full depth, so the depth field
//!    (measured in 3D from the centreline) runs on across the side into the next piece.
//!    A stroke whose samples all fall on one patch is built there from its own input,
//!    exactly as on a single target.
//!
//! The shared sides between carved patches take the displacement of the strokes of
//! both holders ([`super::conform`], `Document::tessellate`), so the network stays
//! watertight.

use super::stroke::{MAX_INPUT_SAMPLES, StrokeInput, StrokePieces, resample};
use super::surface::TargetSurface;
use crate::error::{Error, Result, StrokeRejection};
use glam::{DVec2, DVec3};

/// A stroke built on a network: per run, the patch index and its pieces, in drawing
/// order.
#[derive(Debug, Clone)]
pub struct NetworkStroke {
    /// `(patch, pieces)` per run on one patch.
    pub parts: Vec<(usize, StrokePieces)>,
    /// Runs that carved nothing (too short, or an empty footprint).
    pub dropped: usize,
}

/// Bisection steps that find where the wand path passes from one patch's side of the
/// network to the other's (the sample spacing over `2^12`).
const CROSSING_STEPS: usize = 12;

/// Where the wand path from `from` (a sample nearest patch `a`, its foot's parameter)
/// to `to` (nearest `b`) passes over their shared side: the point of the segment where
/// the nearer patch changes, found by bisection with local projections seeded at the
/// two feet, and the foot on `a` of its end nearer `b` (clamped onto `a`'s side).
fn crossing(
    a: &TargetSurface,
    b: &TargetSurface,
    from: (DVec3, DVec2),
    to: (DVec3, DVec2),
) -> DVec3 {
    let (mut lo, mut hi) = (from.0, to.0);
    for _ in 0..CROSSING_STEPS {
        let mid = lo.lerp(hi, 0.5);
        let da = a
            .closest_point_near(mid, [false; 2], from.1, from.1)
            .distance;
        let db = b.closest_point_near(mid, [false; 2], to.1, to.1).distance;
        if da <= db {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // `hi` lies just past the switch, nearer `b`: its foot on `a` is clamped onto
    // `a`'s side (on it exactly, as a stroke's feet stop on a side).
    a.closest_point_near(hi, [false; 2], from.1, from.1).point
}

/// The bounding box of a patch's control points, widened by `snap`.
fn reach(t: &TargetSurface, snap: f64) -> (DVec3, DVec3) {
    let s = t.surface();
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for j in 0..s.count_v() {
        for i in 0..s.count_u() {
            let p = s.control_point(i, j);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo - DVec3::splat(snap), hi + DVec3::splat(snap))
}

/// Builds `input` on the network of `patches` (see the module docs); `snap` is the
/// largest distance between a wand sample and the network for the sample to count as
/// on it. Errors as [`StrokePieces::build`] on patch `fallback` (the one selected) for
/// bad input, or when no run carves anything.
pub fn build_on_network(
    patches: &[&TargetSurface],
    fallback: usize,
    input: &StrokeInput,
    snap: f64,
) -> Result<NetworkStroke> {
    let tool = &input.tool;
    let finite = input
        .samples
        .iter()
        .all(|(t, p)| t.is_finite() && p.is_finite());
    let Some(&default) = patches.get(fallback) else {
        return Err(Error::StrokeRejected(StrokeRejection::OffSurface));
    };
    if tool.validate().is_err()
        || !finite
        || input.samples.len() > MAX_INPUT_SAMPLES
        || input.samples.len() < 2
    {
        // The single-target pipeline names what is wrong.
        let pieces = StrokePieces::build(default, input, snap)?;
        return Ok(NetworkStroke {
            dropped: pieces.dropped,
            parts: vec![(fallback, pieces)],
        });
    }
    let raw: Vec<DVec3> = input.samples.iter().map(|s| s.1).collect();
    let pts = resample(&raw, tool.width * 0.25);
    let boxes: Vec<(DVec3, DVec3)> = patches.iter().map(|t| reach(t, snap)).collect();
    // Per sample, the nearest patch and its foot's parameter.
    let feet: Vec<Option<(usize, DVec2)>> = pts
        .iter()
        .map(|&p| {
            let mut best: Option<(f64, usize, DVec2)> = None;
            for (k, t) in patches.iter().enumerate() {
                let (lo, hi) = boxes[k];
                if p.cmplt(lo).any() || p.cmpgt(hi).any() {
                    continue;
                }
                let pr = t.closest_point(p);
                if pr.distance <= snap
                    && pr.uv.is_finite()
                    && best.is_none_or(|b| pr.distance < b.0)
                {
                    best = Some((pr.distance, k, pr.uv));
                }
            }
            best.map(|b| (b.1, b.2))
        })
        .collect();
    let mut on: Vec<usize> = feet.iter().flatten().map(|f| f.0).collect();
    on.sort_unstable();
    on.dedup();
    if let [only] = on[..] {
        let pieces = StrokePieces::build(patches[only], input, snap)?;
        return Ok(NetworkStroke {
            dropped: pieces.dropped,
            parts: vec![(only, pieces)],
        });
    }
    // Runs: (patch, points, tapered start, tapered end).
    let mut runs: Vec<(usize, Vec<DVec3>, bool, bool)> = Vec::new();
    let mut prev: Option<(usize, DVec2)> = None;
    let mut last = DVec3::ZERO;
    for (&p, foot) in pts.iter().zip(&feet) {
        match (prev, *foot) {
            (_, None) => {
                if let Some(r) = runs.last_mut() {
                    r.3 = true;
                }
                prev = None;
            }
            (Some((a, uv_a)), Some((b, uv_b))) if a != b => {
                let x = crossing(patches[a], patches[b], (last, uv_a), (p, uv_b));
                if let Some(r) = runs.last_mut() {
                    r.1.push(x);
                    r.3 = false;
                }
                runs.push((b, vec![x, p], false, true));
                prev = *foot;
            }
            (Some(_), Some(_)) => {
                if let Some(r) = runs.last_mut() {
                    r.1.push(p);
                }
                prev = *foot;
            }
            (None, Some((b, _))) => {
                runs.push((b, vec![p], true, true));
                prev = *foot;
            }
        }
        last = p;
    }
    let mut parts = Vec::new();
    let mut dropped = 0;
    let mut refused = None;
    for (patch, points, start, end) in runs {
        let samples = points
            .iter()
            .enumerate()
            .map(|(k, &p)| (k as f64, p))
            .collect();
        let run = StrokeInput {
            samples,
            tool: tool.clone(),
        };
        match StrokePieces::build_ends(patches[patch], &run, snap, [start, end]) {
            Ok(pieces) => {
                dropped += pieces.dropped;
                parts.push((patch, pieces));
            }
            Err(e) => {
                dropped += 1;
                refused = Some(e);
            }
        }
    }
    if parts.is_empty() {
        return Err(refused.unwrap_or(Error::StrokeRejected(StrokeRejection::OffSurface)));
    }
    Ok(NetworkStroke { parts, dropped })
}
