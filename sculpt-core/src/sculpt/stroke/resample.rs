//! Cleaning, resampling and smoothing of the wand polyline (step 2 of the pipeline in
//! the [module docs](super)).

use super::{CORNER_ANGLE_DEG, MAX_SAMPLES};
use glam::DVec3;

/// Cleans, resamples by arc length and smooths a polyline, keeping corners (see the
/// module docs). `spacing` is the target sample distance. Returns the new samples.
pub fn resample(points: &[DVec3], spacing: f64) -> Vec<DVec3> {
    let mut pts: Vec<DVec3> = Vec::with_capacity(points.len());
    for &p in points {
        if pts
            .last()
            .is_none_or(|q: &DVec3| q.distance(p) > crate::tolerance::POINT_EPS)
        {
            pts.push(p);
        }
    }
    if pts.len() < 2 {
        return pts;
    }
    let length: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
    let spacing = spacing
        .max(length / MAX_SAMPLES as f64)
        .max(crate::tolerance::MIN_SPACING);
    // Corners: the turn between the directions one window back and ahead.
    let mut cum = vec![0.0];
    for w in pts.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let window = spacing * 4.0;
    let at = |s: f64| -> DVec3 { point_at(&pts, &cum, s) };
    let mut corners = vec![0usize];
    let cos_lim = CORNER_ANGLE_DEG.to_radians().cos();
    let mut best: Option<(usize, f64)> = None;
    for i in 1..pts.len() - 1 {
        let s = cum[i];
        let ok = s > window && s < length - window;
        let turn = if ok {
            let a = (pts[i] - at(s - window)).normalize_or_zero();
            let b = (at(s + window) - pts[i]).normalize_or_zero();
            a.dot(b)
        } else {
            1.0
        };
        if turn < cos_lim {
            if best.is_none_or(|(_, t)| turn < t) {
                best = Some((i, turn));
            }
        } else if let Some((k, _)) = best.take() {
            corners.push(k);
        }
    }
    if let Some((k, _)) = best {
        corners.push(k);
    }
    corners.push(pts.len() - 1);
    corners.dedup();
    // Resample each piece between corners, then smooth with its ends pinned.
    let mut out = vec![pts[0]];
    for w in corners.windows(2) {
        let (s0, s1) = (cum[w[0]], cum[w[1]]);
        let n = ((s1 - s0) / spacing).ceil().max(1.0) as usize;
        let mut piece: Vec<DVec3> = (0..=n)
            .map(|k| at(s0 + (s1 - s0) * k as f64 / n as f64))
            .collect();
        piece[0] = pts[w[0]];
        piece[n] = pts[w[1]];
        for _ in 0..3 {
            let prev = piece.clone();
            for k in 1..n {
                piece[k] = prev[k] * 0.5 + (prev[k - 1] + prev[k + 1]) * 0.25;
            }
        }
        out.extend_from_slice(&piece[1..]);
    }
    out
}

fn point_at(pts: &[DVec3], cum: &[f64], s: f64) -> DVec3 {
    let i = cum.partition_point(|&c| c <= s).clamp(1, pts.len() - 1);
    let (a, b) = (cum[i - 1], cum[i]);
    let t = if b > a {
        ((s - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    pts[i - 1].lerp(pts[i], t)
}
