//! The pipeline of [`StrokePieces::build`]: validation, projection onto the target
//! split at basin jumps into pieces, rims and footprint of each piece (steps 1 and 3
//! to 5 of the [module docs](super)).

use super::polygon::{
    Buckets, bounds_of, clip_to_box, domain_overlay, period_shifts, region_from_shapes,
    wrapped_segments,
};
use super::{MAX_INPUT_SAMPLES, Stroke, StrokeInput, StrokePieces, Tool, reject, resample};
use crate::error::{Result, StrokeRejection};
use crate::sculpt::jordan::{Rect, signed_area};
use crate::sculpt::surface::{
    ParamSurface, SurfacePoint, TargetSurface, extent_sampled, normal_at, unwrap_near, wrap_uv,
};
use crate::tolerance::BASIN_JUMP_RATIO;
use glam::{DVec2, DVec3};
use i_overlay::core::overlay_rule::OverlayRule;

/// A run of the projected centreline: feet (unwrapped parameter, point) in order.
type Run = Vec<(DVec2, DVec3)>;

/// Chords of the surface path between two feet that [`basin_jump`] measures.
const JUMP_PATH_SEGMENTS: usize = 8;

impl StrokePieces {
    /// Runs the pipeline of the module docs and carves every run of the projected
    /// centreline: one [`Stroke`] per run at least the minimum stroke length long
    /// (`tool.width * MIN_STROKE_LEN_REL`), in drawing order; shorter runs (and runs
    /// whose footprint is empty after clipping) are dropped and counted in
    /// [`Self::dropped`]. `snap` is the largest distance between a wand sample and the
    /// surface for the sample to count as on it (metres). A stroke with no piece left
    /// is rejected.
    pub fn build(target: &TargetSurface, input: &StrokeInput, snap: f64) -> Result<Self> {
        Self::build_ends(target, input, snap, [true, true])
    }

    /// [`Self::build`] with the stroke's start and end tapered only where `taper` says
    /// (a piece of a stroke on a patch network ends bluntly, at full depth, where the
    /// stroke runs on into the neighbouring patch, so that the groove is continuous
    /// across the shared side). Pieces split off at basin jumps taper at the jumps.
    pub fn build_ends(
        target: &TargetSurface,
        input: &StrokeInput,
        snap: f64,
        taper: [bool; 2],
    ) -> Result<Self> {
        let (tool, closed, runs) = project_runs(target, input, snap)?;
        let first = runs.iter().position(|r| !r.is_empty());
        let last = runs.iter().rposition(|r| !r.is_empty());
        let min_len = tool.width * crate::tolerance::MIN_STROKE_LEN_REL;
        let mut pieces = Vec::new();
        let mut dropped = 0;
        let mut refused = None;
        for (k, run) in runs.iter().enumerate().filter(|(_, r)| !r.is_empty()) {
            let ends = [taper[0] || Some(k) != first, taper[1] || Some(k) != last];
            let mut run = through_poles(run);
            let run_len: f64 = run.windows(2).map(|w| w[0].1.distance(w[1].1)).sum();
            if run.len() < 2 || run_len <= min_len {
                dropped += 1;
                continue;
            }
            // A piece whose end comes back to its start is a loop: it is closed with one
            // more segment and carved without tapered ends, one continuous groove.
            let (first, last) = (run[0], run[run.len() - 1]);
            let is_loop = run.len() > 3
                && run_len > 2.0 * tool.width
                && first.1.distance(last.1) <= 0.5 * tool.width;
            if is_loop && first.1.distance(last.1) > crate::tolerance::POINT_EPS {
                run.push((unwrap_near(first.0, last.0, closed), first.1));
            }
            match Stroke::from_centreline(target, tool.clone(), run, closed, is_loop, ends) {
                Ok(piece) => pieces.push(piece),
                Err(e) => {
                    dropped += 1;
                    refused = Some(e);
                }
            }
        }
        if pieces.is_empty() {
            return Err(refused.unwrap_or_else(|| reject(StrokeRejection::OffSurface)));
        }
        Ok(Self { pieces, dropped })
    }
}

impl Stroke {
    /// [`StrokePieces::build`] for a stroke that must carve as one piece: its one piece,
    /// or [`StrokeRejection::Pieces`] when the projection falls into several (use
    /// [`StrokePieces::build`] to carve them all).
    pub fn build(target: &TargetSurface, input: &StrokeInput, snap: f64) -> Result<Self> {
        let built = StrokePieces::build(target, input, snap)?;
        let count = built.pieces.len();
        match <[Stroke; 1]>::try_from(built.pieces) {
            Ok([piece]) => Ok(piece),
            Err(_) => Err(reject(StrokeRejection::Pieces { pieces: count })),
        }
    }

    /// The piece along the feet `run`; `ends` says which of its ends taper (an end that
    /// does not is blunt, with a round cap).
    fn from_centreline(
        target: &TargetSurface,
        tool: Tool,
        run: Vec<(DVec2, DVec3)>,
        closed: [bool; 2],
        is_loop: bool,
        ends: [bool; 2],
    ) -> Result<Self> {
        let surface: &dyn ParamSurface = target;
        let n = run.len();
        let centre_uv: Vec<DVec2> = run.iter().map(|r| r.0).collect();
        let centre: Vec<DVec3> = run.iter().map(|r| r.1).collect();
        // The target is evaluated at wrapped parameters only.
        let normals: Vec<DVec3> = centre_uv
            .iter()
            .map(|&uv| normal_at(surface, wrap_uv(uv)))
            .collect();
        let mut cum = vec![0.0];
        for w in centre.windows(2) {
            cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
        }
        let total = cum[n - 1];
        let taper_len = if is_loop {
            0.0
        } else {
            tool.taper.min(total * 0.5)
        };
        let taper = |s: f64| -> f64 {
            if taper_len <= 0.0 {
                return 1.0;
            }
            let from_end = match ends {
                [true, true] => s.min(total - s),
                [true, false] => s,
                [false, true] => total - s,
                [false, false] => return 1.0,
            };
            let x = (from_end / taper_len).clamp(0.0, 1.0);
            x * x * (3.0 - 2.0 * x)
        };
        let half_width: Vec<f64> = cum.iter().map(|&s| 0.5 * tool.width * taper(s)).collect();
        let depth: Vec<f64> = cum.iter().map(|&s| tool.depth * taper(s)).collect();
        // A rim point: the 3D point `centre[i] + offset` projected onto the target, seeded
        // by the parameter step that best realises the offset, in the unwrapped plane
        // within half a period of the centre.
        let rim_of = |i: usize, sp: &SurfacePoint, offset: DVec3| -> DVec2 {
            let seed = centre_uv[i] + uv_step(sp.du, sp.dv, offset);
            target
                .closest_point_near(centre[i] + offset, closed, centre_uv[i], seed)
                .uv_in_square
        };
        let mut rims_uv = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let t = (centre[(i + 1).min(n - 1)] - centre[i.saturating_sub(1)]).normalize_or_zero();
            let side = normals[i].cross(t).normalize_or_zero();
            let sp = surface.eval(wrap_uv(centre_uv[i]));
            for (k, sign) in [(0, 1.0), (1, -1.0)] {
                rims_uv[k].push(rim_of(i, &sp, side * (sign * half_width[i])));
            }
        }
        // Footprint pieces in the unwrapped plane: the strip's quads plus round caps.
        let mut polys: Vec<Vec<DVec2>> = Vec::with_capacity(2 * n + 2);
        let [l, r] = &rims_uv;
        for i in 0..n - 1 {
            let c = [centre_uv[i], centre_uv[i + 1]];
            polys.push(vec![l[i], l[i + 1], c[1], c[0]]);
            polys.push(vec![r[i], c[0], c[1], r[i + 1]]);
        }
        for (end, next, tapered) in [(0, 1, ends[0]), (n - 1, n - 2, ends[1])] {
            if taper_len <= 0.0 || !tapered {
                let t = (centre[end] - centre[next]).normalize_or_zero();
                let side = normals[end].cross(t).normalize_or_zero();
                let sp = surface.eval(wrap_uv(centre_uv[end]));
                let mut cap = vec![centre_uv[end]];
                for k in 0..=16 {
                    let a = std::f64::consts::PI * k as f64 / 16.0;
                    let dir = side * a.cos() + t * a.sin();
                    cap.push(rim_of(end, &sp, dir * half_width[end]));
                }
                polys.push(cap);
            }
        }
        // Into the square: each piece's copies shifted by whole periods in the closed
        // directions, those meeting the square kept; their union clipped to the square.
        let mut pieces: Vec<Vec<[f64; 2]>> = Vec::with_capacity(polys.len());
        let mut piece_bounds: Vec<Rect> = Vec::with_capacity(polys.len());
        let mut unwrapped = Rect::new(centre_uv[0], centre_uv[0]);
        for poly in &polys {
            let rect = bounds_of(poly);
            unwrapped = Rect::new(unwrapped.min.min(rect.min), unwrapped.max.max(rect.max));
            for shift in period_shifts(&rect, closed) {
                piece_bounds.push(Rect::new(
                    (rect.min + shift).max(DVec2::ZERO),
                    (rect.max + shift).min(DVec2::ONE),
                ));
                let mut piece: Vec<DVec2> = poly.iter().map(|&p| p + shift).collect();
                if shift != DVec2::ZERO {
                    piece = clip_to_box(&piece, DVec2::splat(-1.0), DVec2::splat(2.0));
                }
                let a = signed_area(&piece);
                if piece.len() < 3 || a.abs() < crate::tolerance::UV_AREA_EPS || !a.is_finite() {
                    continue;
                }
                if a < 0.0 {
                    piece.reverse();
                }
                pieces.push(piece.into_iter().map(|p| [p.x, p.y]).collect());
            }
        }
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let union = domain_overlay(&pieces, &[], OverlayRule::Subject);
        let union: Vec<Vec<[f64; 2]>> = union.into_iter().flatten().collect();
        let clipped = domain_overlay(&union, &[square.to_vec()], OverlayRule::Intersect);
        let footprint = region_from_shapes(clipped);
        if footprint.is_empty() {
            return Err(reject(StrokeRejection::EmptyFootprint));
        }
        let mut bounds = Rect::new(DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for c in footprint.contours() {
            for &p in c {
                bounds.min = bounds.min.min(p);
                bounds.max = bounds.max.max(p);
            }
        }
        let buckets = Buckets::new(&centre_uv, &rims_uv, unwrapped, closed);
        let centre_segments = wrapped_segments(&centre_uv, closed);
        Ok(Self {
            tool,
            centre_uv,
            centre,
            normals,
            rims_uv,
            half_width,
            depth,
            footprint,
            bounds,
            is_loop,
            pieces: piece_bounds,
            centre_segments,
            buckets,
        })
    }
}

/// Steps 1 to 3 of the pipeline: validates the input and tool, resamples the
/// polyline and projects every sample through the target's certified inverter, seeded
/// from the previous sample's foot. Returns the tool, the target's closed directions
/// and the runs of feet (unwrapped parameter, point), split where a sample leaves the
/// surface or the feet jump to another basin ([`basin_jump`]); runs may be empty. In a
/// closed direction the parameter is unwrapped next to the previous foot, so it
/// crosses the seam and continues past 1 (or below 0) instead of jumping.
fn project_runs(
    target: &TargetSurface,
    input: &StrokeInput,
    snap: f64,
) -> Result<(Tool, [bool; 2], Vec<Run>)> {
    let surface: &dyn ParamSurface = target;
    let tool = input.tool.clone();
    tool.validate()?;
    if input.samples.len() > MAX_INPUT_SAMPLES {
        return Err(reject(StrokeRejection::TooManySamples {
            count: input.samples.len(),
            max: MAX_INPUT_SAMPLES,
        }));
    }
    if let Some(k) = input
        .samples
        .iter()
        .position(|(t, p)| !(t.is_finite() && p.is_finite()))
    {
        return Err(reject(StrokeRejection::SampleNotFinite { index: k }));
    }
    let ext = extent_sampled(surface, 8);
    if tool.width > ext.diagonal() {
        return Err(reject(StrokeRejection::ToolWiderThanSurface {
            width_m: tool.width,
            across_m: ext.diagonal(),
        }));
    }
    let raw: Vec<DVec3> = input.samples.iter().map(|s| s.1).collect();
    let length: f64 = raw.windows(2).map(|w| w[0].distance(w[1])).sum();
    if raw.len() < 2 || length <= tool.width * crate::tolerance::MIN_STROKE_LEN_REL {
        return Err(reject(StrokeRejection::TooShort {
            length_m: length,
            min_m: tool.width * crate::tolerance::MIN_STROKE_LEN_REL,
        }));
    }
    let pts = resample(&raw, tool.width * 0.25);
    let closed = [ext.closed_u, ext.closed_v];
    let mut runs: Vec<Run> = vec![Vec::new()];
    // The previous on-surface sample and its foot (unwrapped parameter, point).
    let mut prev: Option<(DVec3, DVec2, DVec3)> = None;
    for &p in &pts {
        let pr = match prev {
            Some((_, uv, _)) => target.closest_point_near(p, closed, uv, uv),
            None => target.closest_point(p),
        };
        if pr.distance <= snap && pr.point.is_finite() && pr.uv_in_square.is_finite() {
            let foot = (pr.uv_in_square, pr.point);
            if prev
                .is_some_and(|(q, uv, point)| basin_jump(surface, p.distance(q), (uv, point), foot))
            {
                runs.push(Vec::new());
            }
            prev = Some((p, pr.uv_in_square, pr.point));
            if let Some(r) = runs.last_mut() {
                r.push(foot);
            }
        } else {
            prev = None;
            if runs.last().is_some_and(|r| !r.is_empty()) {
                runs.push(Vec::new());
            }
        }
    }
    Ok((tool, closed, runs))
}

/// True when consecutive feet `a` and `b` (unwrapped parameter, point) of samples
/// `spacing` apart lie in different basins of the distance: the true closest point
/// jumped (the stroke passed over a valley whose far side is nearer) rather than slid.
///
/// The closest-point map moves a foot by `spacing / |1 - d k|` for a query at distance
/// `d` over a principal curvature `k` (Euler's formula along the motion, do Carmo
/// section 3-2): no faster than the query over convex or flat ground, unboundedly only
/// at a focal point, where it tears. So the feet jumped when the way between them
/// along the surface, the length of the surface path over the straight parameter
/// segment (an upper bound of the geodesic, sampled at [`JUMP_PATH_SEGMENTS`] chords),
/// exceeds [`BASIN_JUMP_RATIO`] times the sample spacing. Feet no farther apart in 3D
/// than the spacing are never a jump (valleys narrower than the sample spacing, a
/// quarter of the tool width, are below the stroke's resolution).
fn basin_jump(
    surface: &dyn ParamSurface,
    spacing: f64,
    a: (DVec2, DVec3),
    b: (DVec2, DVec3),
) -> bool {
    let limit = BASIN_JUMP_RATIO * spacing;
    if a.1.distance(b.1) <= spacing {
        return false;
    }
    let mut length = 0.0;
    let mut last = a.1;
    for k in 1..=JUMP_PATH_SEGMENTS {
        let t = k as f64 / JUMP_PATH_SEGMENTS as f64;
        let point = if k == JUMP_PATH_SEGMENTS {
            b.1
        } else {
            surface.eval(wrap_uv(a.0.lerp(b.0, t))).p
        };
        length += last.distance(point);
        if length > limit {
            return true;
        }
        last = point;
    }
    false
}

/// The centreline through a pole: where a step leaves (or reaches) the side `v = 0`
/// or `v = 1` with a jump in `u`, the projection went over a pole (a whole side of the
/// square that is one point), and the centreline first runs along that side to the new
/// `u`, a step of no 3D length, so that no segment cuts across the cells round the
/// pole.
fn through_poles(run: &[(DVec2, DVec3)]) -> Vec<(DVec2, DVec3)> {
    let mut out: Vec<(DVec2, DVec3)> = Vec::with_capacity(run.len() + 2);
    for (k, &(uv, p)) in run.iter().enumerate() {
        if let Some(&(prev, q)) = out.last()
            && k > 0
            && (uv.x - prev.x).abs() > 0.25
        {
            let side = |y: f64| y == 0.0 || y == 1.0;
            if side(prev.y) {
                out.push((DVec2::new(uv.x, prev.y), q));
            } else if side(uv.y) {
                out.push((DVec2::new(prev.x, uv.y), p));
            }
        }
        out.push((uv, p));
    }
    out
}

/// Parameter step that best realises the 3D displacement `d` (least squares on `[Su Sv]`).
fn uv_step(du: DVec3, dv: DVec3, d: DVec3) -> DVec2 {
    let (aa, ab, bb) = (du.dot(du), du.dot(dv), dv.dot(dv));
    let det = aa * bb - ab * ab;
    if det.abs() <= crate::tolerance::DIVISOR_MIN || !det.is_finite() {
        return DVec2::ZERO;
    }
    let (ga, gb) = (du.dot(d), dv.dot(d));
    let s = DVec2::new((ga * bb - gb * ab) / det, (aa * gb - ab * ga) / det);
    if s.is_finite() {
        s.clamp(DVec2::splat(-1.0), DVec2::splat(1.0))
    } else {
        DVec2::ZERO
    }
}
