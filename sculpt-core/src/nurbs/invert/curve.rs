//! Point inversion and closest points on curves (P&T eq. 6.3).

use glam::DVec3;

use super::box_dist2;
use super::hierarchy::split_uniform;
use super::newton::{MAX_HALVINGS, MAX_ITERS};
use crate::nurbs::curve::NurbsCurve;
use crate::nurbs::surface::NurbsSurface;
use crate::tolerance::{COSINE_EPS, POINT_EPS};

/// The answer to a closest-point query on a curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveProjection {
    /// The parameter `u` of the closest point.
    pub u: f64,
    /// `C(u)`.
    pub point: DVec3,
    /// `|C(u) - P|`.
    pub distance: f64,
    /// Newton iterations spent.
    pub iterations: u32,
    /// True when the final run stopped by P&T's criteria.
    pub converged: bool,
}

impl NurbsCurve {
    /// The closest point of the curve to `p` (point inversion, P&T eq. 6.3):
    /// Newton on `f(u) = C'(u) . (C(u) - P) = 0` with the update
    /// `u <- u - f / (C'' . (C - P) + |C'|^2)`, bounded and line-searched, run in every
    /// sub-segment whose control-polygon box could hold a closer point than the best so
    /// far (Bezier segments by refinement, each split in four); both ends are
    /// candidates too. Non-finite `p` gives `distance = f64::INFINITY`.
    pub fn closest_point(&self, p: DVec3) -> CurveProjection {
        let (a, b) = self.domain();
        let mut best = CurveProjection {
            u: a,
            point: self.point(a),
            distance: f64::INFINITY,
            iterations: 0,
            converged: false,
        };
        if !p.is_finite() {
            return best;
        }
        for u in [a, b] {
            let q = self.point(u);
            if q.distance(p) < best.distance {
                best = CurveProjection {
                    u,
                    point: q,
                    distance: q.distance(p),
                    iterations: 0,
                    converged: true,
                };
            }
        }
        let pieces: Vec<(f64, f64, DVec3, DVec3)> = match self.bezier_pieces(4) {
            Some(v) => v,
            None => {
                let (lo, hi) = self.homogeneous().iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), q| (lo.min(q.truncate() / q.w), hi.max(q.truncate() / q.w)),
                );
                vec![(a, b, lo, hi)]
            }
        };
        let mut order: Vec<(f64, usize)> = pieces
            .iter()
            .enumerate()
            .map(|(k, pc)| (box_dist2(p, pc.2, pc.3), k))
            .collect();
        order.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut iters = 0;
        for (lb, k) in order {
            if lb >= best.distance * best.distance {
                break;
            }
            let (lo, hi, _, _) = pieces[k];
            let c = self.newton_1d(p, 0.5 * (lo + hi), lo, hi);
            iters += c.iterations;
            if c.distance < best.distance {
                best = c;
            }
        }
        // Polish on the whole domain.
        let c = self.newton_1d(p, best.u, a, b);
        if c.distance <= best.distance * (1.0 + crate::tolerance::REL_EPS) {
            best = c;
        }
        best.iterations += iters;
        best
    }

    /// Sub-segments `(u0, u1, box_lo, box_hi)`: each Bezier segment split in `split`.
    fn bezier_pieces(&self, split: usize) -> Option<Vec<(f64, f64, DVec3, DVec3)>> {
        let kv = self.knots();
        let x = NurbsSurface::bezier_insertions(kv);
        let (k, pw) = crate::nurbs::refine::refine_pw(kv, self.homogeneous(), &x).ok()?;
        let p = self.degree();
        let mut out = Vec::new();
        for s in p..pw.len() {
            if k[s] >= k[s + 1] {
                continue;
            }
            let seg = &pw[s - p..=s];
            for (t, piece) in split_uniform(seg, split).iter().enumerate() {
                let (lo, hi) = piece.iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), q| (lo.min(q.truncate() / q.w), hi.max(q.truncate() / q.w)),
                );
                let at = |i: usize| k[s] + (k[s + 1] - k[s]) * i as f64 / split as f64;
                let u1 = if t + 1 == split { k[s + 1] } else { at(t + 1) };
                out.push((at(t), u1, lo, hi));
            }
        }
        Some(out)
    }

    /// Bounded 1D Newton for eq. 6.3 with a halving line search on `|C - P|^2`.
    fn newton_1d(&self, p: DVec3, start: f64, lo: f64, hi: f64) -> CurveProjection {
        let mut u = start.clamp(lo, hi);
        let mut d = self.derivatives(u);
        let mut r = d.point - p;
        let mut f = r.length_squared();
        let mut iters = 0;
        let mut converged = false;
        while iters < MAX_ITERS {
            let g = d.d1.dot(r);
            let rl = f.sqrt();
            let l1 = d.d1.length();
            let active = (u <= lo && g > 0.0) || (u >= hi && g < 0.0);
            if rl <= POINT_EPS
                || active
                || g.abs() <= COSINE_EPS * l1 * rl
                || g.abs() <= crate::tolerance::RESIDUAL_EPS * l1
            {
                converged = true;
                break;
            }
            iters += 1;
            let h = d.d2.dot(r) + l1 * l1;
            let step = if h > crate::tolerance::SINGULAR_REL * l1 * l1 {
                -g / h
            } else {
                -g / (l1 * l1).max(crate::tolerance::DIVISOR_MIN)
            };
            let noise =
                8.0 * f64::EPSILON * rl * (p.abs().max_element() + d.point.abs().max_element());
            let mut t = 1.0;
            let mut accepted = false;
            for _ in 0..MAX_HALVINGS {
                let c = (u + step * t).clamp(lo, hi);
                if c == u {
                    break;
                }
                let dc = self.derivatives(c);
                let rc = dc.point - p;
                if rc.length_squared() <= f + noise {
                    let moved = dc.point.distance(d.point);
                    (u, d, r, f) = (c, dc, rc, rc.length_squared());
                    accepted = true;
                    converged = moved <= POINT_EPS && t == 1.0;
                    break;
                }
                t *= 0.5;
            }
            if converged || !accepted {
                break;
            }
        }
        CurveProjection {
            u,
            point: d.point,
            distance: f.sqrt(),
            iterations: iters,
            converged,
        }
    }
}
