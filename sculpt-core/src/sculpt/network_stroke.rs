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
//!    at `X` and `B`'s run starts there. Before that, the wand path between the two
//!    samples is searched for patches it passes over in between (`passed_over`:
//!    global projections of midpoints, bisected towards the change of patch down to
//!    the minimum stroke length): a stroke that clips the corner of a third patch `C`
//!    between two samples on `A` and `B` gets a run on `C` too (`A`, `X`, `C`, `X'`,
//!    `B`), so every run on the network is carved. Runs no longer than the minimum
//!    stroke length are dropped and counted in [`NetworkStroke::dropped`].
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

/// A sample's nearest patch and its foot's parameter (in the patch's unit square).
type Foot = (usize, DVec2);

/// The nearest of `patches` to `p` and its foot, over those whose widened control
/// boxes `boxes` ([`reach`]) hold `p`, through each one's certified inverter (the lower
/// index on a tie); `None` when none lies within `snap`.
fn nearest(
    patches: &[&TargetSurface],
    boxes: &[(DVec3, DVec3)],
    p: DVec3,
    snap: f64,
) -> Option<Foot> {
    let mut best: Option<(f64, usize, DVec2)> = None;
    for (k, t) in patches.iter().enumerate() {
        let (lo, hi) = boxes[k];
        if p.cmplt(lo).any() || p.cmpgt(hi).any() {
            continue;
        }
        let pr = t.closest_point(p);
        if pr.distance <= snap
            && pr.uv_in_square.is_finite()
            && best.is_none_or(|b| pr.distance < b.0)
        {
            best = Some((pr.distance, k, pr.uv_in_square));
        }
    }
    best.map(|b| (b.1, b.2))
}

/// The wand points, in order, between `from` (a point and its foot) and `to` (nearest
/// another patch) whose nearest patch is a third one: the segment is bisected towards
/// the change of patch (global projections, [`nearest`]) until it is `min_len` long,
/// and split at every midpoint nearest a third patch, so a patch the path passes over
/// between two samples (a corner clipped) is found unless its run is shorter than a
/// stroke can be. A midpoint off the network ends the search there (the path leaves
/// the network between the samples; the crossing is then found between the two).
fn passed_over(
    patches: &[&TargetSurface],
    boxes: &[(DVec3, DVec3)],
    snap: f64,
    from: (DVec3, Foot),
    to: (DVec3, Foot),
    min_len: f64,
    out: &mut Vec<(DVec3, Foot)>,
) {
    if from.1.0 == to.1.0 || from.0.distance(to.0) <= min_len {
        return;
    }
    let p = from.0.lerp(to.0, 0.5);
    let Some(mid) = nearest(patches, boxes, p, snap) else {
        return;
    };
    if mid.0 == from.1.0 {
        passed_over(patches, boxes, snap, (p, mid), to, min_len, out);
    } else if mid.0 == to.1.0 {
        passed_over(patches, boxes, snap, from, (p, mid), min_len, out);
    } else {
        passed_over(patches, boxes, snap, from, (p, mid), min_len, out);
        out.push((p, mid));
        passed_over(patches, boxes, snap, (p, mid), to, min_len, out);
    }
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
    let feet: Vec<Option<Foot>> = pts
        .iter()
        .map(|&p| nearest(patches, &boxes, p, snap))
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
            (Some(from), Some(to)) if from.0 != to.0 => {
                // The patches the wand path passes over between the two samples, in
                // order: a corner it clips between samples gets its run too.
                let mut stops = vec![(last, from)];
                let min_len = tool.width * crate::tolerance::MIN_STROKE_LEN_REL;
                passed_over(
                    patches,
                    &boxes,
                    snap,
                    (last, from),
                    (p, to),
                    min_len,
                    &mut stops,
                );
                stops.push((p, to));
                for w in stops.windows(2) {
                    let [(q, (a, uv_a)), (r, (b, uv_b))] = [w[0], w[1]];
                    let x = crossing(patches[a], patches[b], (q, uv_a), (r, uv_b));
                    if let Some(run) = runs.last_mut() {
                        run.1.push(x);
                        run.3 = false;
                    }
                    runs.push((b, vec![x, r], false, true));
                }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nurbs::NurbsSurface;
    use crate::sculpt::stroke::Tool;

    /// Side of each of the 2 x 2 patches (metres).
    const SIDE: f64 = 0.1;

    /// The height of the network over `(x, y)`: a saddle, so the closest points are not
    /// vertical drops.
    fn height(x: f64, y: f64) -> f64 {
        0.8 * (x - SIDE).powi(2) - 0.6 * (y - SIDE).powi(2) + 0.3 * x * y
    }

    /// The cubic Bernstein coefficient `a` of `(x - SIDE)^2` on `[x0, x0 + SIDE]`
    /// (`t^2` has coefficients `a (a - 1) / 6`), the ends computed as the samples
    /// themselves so that neighbours hold the same bits.
    fn square_coefficient(x0: f64, a: usize) -> f64 {
        let s = x0 - SIDE;
        match a {
            0 => s * s,
            3 => (s + SIDE) * (s + SIDE),
            _ => {
                let t = a as f64;
                s * s + 2.0 * s * SIDE * t / 3.0 + SIDE * SIDE * t * (t - 1.0) / 6.0
            }
        }
    }

    /// A 2 x 2 network of bicubic Bezier patches over `[0, 0.2]^2`, patch `(i, j)` at
    /// index `2 j + i`, that is exactly the smooth saddle [`height`] (its Bernstein
    /// coefficients), so the network has no creases and neighbours hold the same bits
    /// along their shared sides.
    fn network() -> Vec<TargetSurface> {
        let knots = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        let mut out = Vec::new();
        for j in 0..2 {
            for i in 0..2 {
                let (x0, y0) = (i as f64 * SIDE, j as f64 * SIDE);
                let at = |a: usize| match a {
                    0 => 0.0,
                    3 => SIDE,
                    _ => a as f64 * SIDE / 3.0,
                };
                let net: Vec<Vec<DVec3>> = (0..4)
                    .map(|a| {
                        (0..4)
                            .map(|b| {
                                let (x, y) = (x0 + at(a), y0 + at(b));
                                let z = 0.8 * square_coefficient(x0, a)
                                    - 0.6 * square_coefficient(y0, b)
                                    + 0.3 * x * y;
                                DVec3::new(x, y, z)
                            })
                            .collect()
                    })
                    .collect();
                let s = NurbsSurface::new(3, 3, knots.clone(), knots.clone(), net, None)
                    .expect("valid patch");
                out.push(TargetSurface::new(&s));
            }
        }
        out
    }

    /// The closest point to `p` over all `patches` by brute force, independent of the
    /// inverter: per patch, the nearest of a 41 x 41 grid, then a 9 x 9 grid about the
    /// best parameter, shrunk fourfold per round; the nearest patch's answer. Returns
    /// the patch and the point.
    fn brute_closest(patches: &[TargetSurface], p: DVec3) -> (usize, DVec3) {
        let mut best = (f64::INFINITY, 0, DVec3::ZERO);
        for (k, t) in patches.iter().enumerate() {
            let s = t.surface();
            let dist = |uv: DVec2| s.point(uv.x, uv.y).distance(p);
            let n = 40;
            let mut uv = DVec2::ZERO;
            for a in 0..=n {
                for b in 0..=n {
                    let q = DVec2::new(a as f64, b as f64) / n as f64;
                    if dist(q) < dist(uv) {
                        uv = q;
                    }
                }
            }
            let mut radius = 0.05;
            for _ in 0..14 {
                let centre = uv;
                for a in -4..=4 {
                    for b in -4..=4 {
                        let q = (centre + DVec2::new(a as f64, b as f64) * radius / 4.0)
                            .clamp(DVec2::ZERO, DVec2::ONE);
                        if dist(q) < dist(uv) {
                            uv = q;
                        }
                    }
                }
                radius /= 4.0;
            }
            if dist(uv) < best.0 {
                best = (dist(uv), k, s.point(uv.x, uv.y));
            }
        }
        (best.1, best.2)
    }

    /// The wand path past the network's middle corner: the line
    /// `x + y = 2 SIDE + offset` from `x = 0.04 + phase`, `s` metres of `x` along it,
    /// hovering 3 mm above the network.
    fn wand(offset: f64, phase: f64, s: f64) -> DVec3 {
        let x = 0.04 + phase + s;
        let y = 2.0 * SIDE + offset - x;
        DVec3::new(x, y, height(x, y) + 0.003)
    }

    /// The distance from `q` to the polyline `line`.
    fn to_polyline(line: &[DVec3], q: DVec3) -> f64 {
        if let [only] = line {
            return only.distance(q);
        }
        line.windows(2)
            .map(|w| {
                let d = w[1] - w[0];
                let t =
                    ((q - w[0]).dot(d) / d.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                (w[0] + d * t).distance(q)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Regression (issue 30): a stroke that clips a patch's corner, running over it for
    /// less than the sample spacing, lost that run: its samples jumped from one patch
    /// straight to the diagonal one, and the corner patch got no piece. Straight
    /// strokes 3 mm above the saddle network pass the middle corner at offsets and
    /// phases; every point of the wand path whose true closest point over the network
    /// (brute force) lies on a patch must lie on the centreline of a piece on that
    /// patch, and nothing is dropped.
    #[test]
    fn a_stroke_clipping_a_patch_corner_carves_the_corner() {
        let owned = network();
        let patches: Vec<&TargetSurface> = owned.iter().collect();
        let tool = Tool {
            width: 0.01,
            ..Tool::default()
        };
        let mut clipped = 0;
        for offset in [0.0005, 0.001, 0.0015] {
            for phase in [0.0, 0.0007, 0.0013, 0.0019] {
                let at = |s: f64| wand(offset, phase, s);
                let samples: Vec<(f64, DVec3)> =
                    (0..=40).map(|k| (k as f64, at(0.003 * k as f64))).collect();
                let input = StrokeInput {
                    samples,
                    tool: tool.clone(),
                };
                let built = build_on_network(&patches, 0, &input, 0.02).expect("carved");
                assert_eq!(built.dropped, 0, "offset {offset}, phase {phase}");
                let carved: Vec<usize> = built.parts.iter().map(|p| p.0).collect();
                let mut seen = [false; 4];
                for k in 0..=240 {
                    let (patch, foot) = brute_closest(&owned, at(0.12 * k as f64 / 240.0));
                    // A foot on a shared side or corner lies on every holder: it must
                    // lie on some piece's centreline.
                    let near = built
                        .parts
                        .iter()
                        .flat_map(|(_, pieces)| &pieces.pieces)
                        .map(|piece| to_polyline(&piece.centre, foot))
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        near <= 0.05 * tool.width,
                        "offset {offset}, phase {phase}: the foot {foot} is {near} m from \
                         the pieces"
                    );
                    // A foot inside a patch needs a piece on that patch.
                    let inside = (foot.x - SIDE).abs() > 1e-6 && (foot.y - SIDE).abs() > 1e-6; // not a tolerance: off the sides x, y = SIDE
                    if inside {
                        seen[patch] = true;
                        assert!(
                            carved.contains(&patch),
                            "offset {offset}, phase {phase}: the foot {foot} inside patch \
                             {patch} has no piece there (pieces on {carved:?})"
                        );
                    }
                }
                clipped += usize::from(seen[3]);
            }
        }
        // The reference saw the corner patch under every stroke.
        assert_eq!(clipped, 12);
    }

    /// Issue 30, watertight after strokes: the corner-clipping stroke carved through
    /// the document leaves the 2 x 2 network one surface at final detail: one body,
    /// every edge used by two triangles running it opposite ways except the outer
    /// boundary's (Euler characteristic 1, a disc), and the clipped corner patch
    /// carved to the tool's depth under the wand.
    #[test]
    fn a_carved_corner_keeps_the_network_watertight_at_final() {
        use crate::editor::{self, Applied};
        use crate::interaction::{Edit, StrokeEdit, StrokeSample};
        use crate::mesh::PatchMesh;
        use crate::sculpt::document::Document;
        use crate::sculpt::tessellate::Detail;
        use std::collections::HashMap;

        let mut doc = Document::new();
        for (k, t) in network().iter().enumerate() {
            doc.add_target(&format!("patch {k}"), t.surface().clone());
        }
        assert_eq!(doc.network().sides.len(), 4);
        let before = doc.mesh(Detail::Final);
        let (offset, phase) = (0.001, 0.0013);
        let samples = (0..=40)
            .map(|k| StrokeSample {
                t: 0.01 * f64::from(k),
                position: wand(offset, phase, 0.003 * f64::from(k)),
            })
            .collect();
        let tool = Tool {
            width: 0.01,
            ..Tool::default()
        };
        let depth = tool.depth;
        let ids = doc.target_ids();
        let edit = Edit::Stroke(StrokeEdit::new(ids[2], tool, samples));
        let applied = editor::apply(&mut doc, &edit);
        assert!(
            matches!(applied, Applied::Stroke { dropped: 0, .. }),
            "{applied:?}"
        );
        for k in [1, 2, 3] {
            assert!(!doc.strokes_on(ids[k]).is_empty(), "patch {k}");
        }
        let after = doc.mesh(Detail::Final);
        // Vertices merged by their bits; edges counted per direction.
        let tris = |m: &PatchMesh| -> Vec<[[u32; 3]; 3]> {
            m.patches()
                .flat_map(|(_, p)| {
                    p.triangles
                        .iter()
                        .map(|t| t.map(|i| p.vertices[i as usize].position.map(f32::to_bits)))
                        .collect::<Vec<_>>()
                })
                .collect()
        };
        let faces = tris(&after);
        let mut directed: HashMap<([u32; 3], [u32; 3]), usize> = HashMap::new();
        for f in &faces {
            for k in 0..3 {
                *directed.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
            }
        }
        let mut vertices: Vec<[u32; 3]> = faces.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let on_rim = |p: [u32; 3]| {
            let [x, y] = [p[0], p[1]].map(|b| f64::from(f32::from_bits(b)));
            [x, y]
                .iter()
                .any(|c| c.abs() < 1e-6 || (c - 2.0 * SIDE).abs() < 1e-6) // not a tolerance: f32 positions on the outer rim
        };
        let mut edges = 0;
        for (&(a, b), &n) in &directed {
            assert_eq!(n, 1, "an edge used twice the same way");
            let back = directed.get(&(b, a)).copied().unwrap_or(0);
            if back == 0 {
                assert!(on_rim(a) && on_rim(b), "an open edge inside: {a:?} {b:?}");
                edges += 2;
            } else {
                edges += 1;
            }
        }
        let euler = vertices.len() as i64 - (edges / 2) as i64 + faces.len() as i64;
        assert_eq!(euler, 1);
        // Carved on the corner patch: a ray down at a true foot inside patch 3.
        let foot = (0..=100)
            .map(|k| {
                brute_closest(
                    &network(),
                    wand(offset, phase, 0.05 + 0.0002 * f64::from(k)),
                )
            })
            .find(|&(patch, f)| patch == 3 && f.x > SIDE + 2e-4 && f.y > SIDE + 2e-4) // not a tolerance: inside the patch
            .expect("the path passes over patch 3")
            .1;
        let hit = |m: &PatchMesh| {
            m.first_hit((foot + DVec3::Z * 0.02).to_array(), [0.0, 0.0, -1.0])
                .expect("the ray meets the mesh")
        };
        let carved = hit(&after) - hit(&before);
        eprintln!("carved at {foot} on the corner patch: {carved} (tool {depth})");
        assert!(carved >= 0.5 * depth, "carved {carved} of {depth}");
    }
}
