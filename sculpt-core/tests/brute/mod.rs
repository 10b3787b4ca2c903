//! Brute-force closest points, shared by the integration tests that check projections
//! against the truth without using the inverter.

use glam::{DVec2, DVec3};
use sculpt_core::nurbs::NurbsSurface;

/// The closest point of `s` to `p` by brute force: a dense `(nu + 1) x (nv + 1)` grid
/// over the knot domain, then four rounds of zooming in around the best few samples.
/// Every candidate is a true surface point, so the result is an upper bound of the
/// true distance. Returns the distance and the parameter (knot domain).
pub fn closest_point(s: &NurbsSurface, p: DVec3, (nu, nv): (usize, usize)) -> (f64, DVec2) {
    let (u0, u1) = s.domain_u();
    let (v0, v1) = s.domain_v();
    let mut cands: Vec<(f64, DVec2)> = Vec::with_capacity((nu + 1) * (nv + 1));
    for i in 0..=nu {
        for j in 0..=nv {
            let uv = DVec2::new(
                u0 + (u1 - u0) * i as f64 / nu as f64,
                v0 + (v1 - v0) * j as f64 / nv as f64,
            );
            cands.push((s.point_uv(uv).distance(p), uv));
        }
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best = cands[0];
    let mut h = DVec2::new((u1 - u0) / nu as f64, (v1 - v0) / nv as f64);
    let mut seeds: Vec<DVec2> = cands.iter().take(6).map(|c| c.1).collect();
    for _ in 0..4 {
        let mut next: Vec<(f64, DVec2)> = Vec::new();
        for c in &seeds {
            let m = 16;
            for i in 0..=m {
                for j in 0..=m {
                    let uv = DVec2::new(
                        (c.x - h.x + 2.0 * h.x * i as f64 / m as f64).clamp(u0, u1),
                        (c.y - h.y + 2.0 * h.y * j as f64 / m as f64).clamp(v0, v1),
                    );
                    next.push((s.point_uv(uv).distance(p), uv));
                }
            }
        }
        next.sort_by(|a, b| a.0.total_cmp(&b.0));
        if next[0].0 < best.0 {
            best = next[0];
        }
        seeds = next.iter().take(3).map(|c| c.1).collect();
        h /= 8.0;
    }
    best
}
