//! Bounded Newton with an active set (step 4 of the module docs; P&T eqs. 6.5 to 6.7)
//! and the final polish on the whole domain (step 5).

use glam::{DVec2, DVec3};

use super::{Candidate, SurfaceInverter};
use crate::tolerance::{COSINE_EPS, POINT_EPS};
/// Newton iterations per run before giving up.
pub(super) const MAX_ITERS: u32 = 40;
/// Step halvings in the line search.
pub(super) const MAX_HALVINGS: u32 = 30;

impl SurfaceInverter {
    /// A last Newton run on the whole domain from a leaf answer (wrapping in closed
    /// directions); the better of the two.
    pub(super) fn polish(&self, p: DVec3, best: Candidate) -> Candidate {
        if best.converged && !best.on_leaf_edge && !self.closed[0] && !self.closed[1] {
            // Already a converged answer of the whole-domain problem.
            return best;
        }
        let polished = self.newton(p, best.uv, self.domain_lo, self.domain_hi, self.closed);
        // Rounding: the polish evaluates with the power form, which can differ from the
        // point routine (corners) in the last digit. `|S - P|^2` carries an absolute
        // error of a few ulps of `|S|` and `|P|` times `|S - P|`: for a query within
        // 1e-7 of a corner a relative tolerance alone rejects the converged polish.
        let noise = 8.0
            * f64::EPSILON
            * best.dist2.sqrt()
            * (p.abs().max_element() + best.point.abs().max_element());
        let mut out = if polished.dist2 <= best.dist2 * (1.0 + crate::tolerance::REL_EPS) + noise {
            polished
        } else {
            best
        };
        out.iters = best.iters + polished.iters;
        out
    }

    /// Bounded Newton with an active set (see the module docs).
    #[inline]
    pub(super) fn newton(
        &self,
        p: DVec3,
        start: DVec2,
        lo: DVec2,
        hi: DVec2,
        wrap: [bool; 2],
    ) -> Candidate {
        // Leaf runs never wrap: their copy has no wrap-around code at all.
        if wrap == [false; 2] {
            self.bounded_newton::<false>(p, start, lo, hi, wrap)
        } else {
            self.bounded_newton::<true>(p, start, lo, hi, wrap)
        }
    }

    /// [`Self::newton`], with `WRAP` false when no direction wraps.
    fn bounded_newton<const WRAP: bool>(
        &self,
        p: DVec3,
        start: DVec2,
        lo: DVec2,
        hi: DVec2,
        wrap: [bool; 2],
    ) -> Candidate {
        let wrap = if WRAP { wrap } else { [false; 2] };
        let mut uv = start.clamp(lo, hi);
        let mut d = self.derivs(uv);
        let mut r = d.point - p;
        let mut f = r.length_squared();
        let mut iters = 0;
        let mut converged = false;
        // Squared forms of the tests, so the loop takes no square roots.
        const POINT_EPS2: f64 = POINT_EPS * POINT_EPS;
        const RESIDUAL_EPS2: f64 = crate::tolerance::RESIDUAL_EPS * crate::tolerance::RESIDUAL_EPS;
        // Rounding scale of f (see `noise` below).
        let p_scale = p.abs().max_element();
        loop {
            if f <= POINT_EPS2 {
                converged = true;
                break;
            }
            let g = DVec2::new(d.du.dot(r), d.dv.dot(r));
            let mut free = [true; 2];
            for k in 0..2 {
                if !wrap[k] && ((uv[k] <= lo[k] && g[k] > 0.0) || (uv[k] >= hi[k] && g[k] < 0.0)) {
                    free[k] = false;
                }
            }
            let lens2 = [d.du.length_squared(), d.dv.length_squared()];
            // Zero cosine, |g_k| <= tol |S_k| |S - P|, or a tangential residual
            // |g_k| / |S_k| below POINT_EPS / 1000 (when |S - P| is small the cosine
            // cannot be resolved further, but the point is exact).
            let cos_small = move |k: usize, tol: f64| {
                let g2 = g[k] * g[k];
                g2 <= tol * tol * lens2[k] * f || g2 <= RESIDUAL_EPS2 * lens2[k]
            };
            if (0..2).all(|k| !free[k] || cos_small(k, COSINE_EPS)) {
                converged = true;
                break;
            }
            if iters >= MAX_ITERS {
                break;
            }
            iters += 1;
            let h00 = lens2[0] + d.duu.dot(r);
            let h01 = d.du.dot(d.dv) + d.duv.dot(r);
            let h11 = lens2[1] + d.dvv.dot(r);
            let newton = match free {
                [true, true] => newton_step_2(h00, h01, h11, g),
                [true, false] => DVec2::new(newton_step_1(h00, lens2[0], g.x), 0.0),
                [false, true] => DVec2::new(0.0, newton_step_1(h11, lens2[1], g.y)),
                [false, false] => DVec2::ZERO,
            };
            let project = |c: DVec2| {
                let mut c = c;
                for k in 0..2 {
                    c[k] = if wrap[k] {
                        lo[k] + (c[k] - lo[k]).rem_euclid(hi[k] - lo[k])
                    } else {
                        c[k].clamp(lo[k], hi[k])
                    };
                }
                c
            };
            // Rounding noise of f: r = S - P loses the digits of |S| and |P|.
            let noise = 8.0 * f64::EPSILON * f.sqrt() * (p_scale + d.point.abs().max_element());
            let mut accepted = false;
            for attempt in 0..2 {
                let step = if attempt == 0 {
                    // Skip a projected Newton step that does not descend (it can turn
                    // uphill where a bound cuts it).
                    if !wrap[0] && !wrap[1] && g.dot(project(uv + newton) - uv) >= 0.0 {
                        continue;
                    }
                    newton
                } else {
                    // The fallback: the gradient scaled by the Hessian diagonal.
                    let scaled = |k: usize, h: f64, jtj: f64| {
                        let den = h.max(jtj);
                        if free[k] && den > 0.0 {
                            -g[k] / den
                        } else {
                            0.0
                        }
                    };
                    DVec2::new(scaled(0, h00, lens2[0]), scaled(1, h11, lens2[1]))
                };
                let mut t = 1.0;
                for _ in 0..MAX_HALVINGS {
                    let cand = project(uv + step * t);
                    if cand == uv {
                        break;
                    }
                    let dc = self.derivs(cand);
                    let rc = dc.point - p;
                    let fc = rc.length_squared();
                    // Accept descent, and changes within rounding noise of f (near the
                    // minimum f stops resolving the last digits while g still improves).
                    if fc <= f + noise {
                        let moved2 = (dc.point - d.point).length_squared();
                        uv = cand;
                        d = dc;
                        r = rc;
                        f = fc;
                        accepted = true;
                        if moved2 <= POINT_EPS2 && t == 1.0 && attempt == 0 {
                            converged = true;
                        }
                        break;
                    }
                    t *= 0.5;
                }
                if accepted {
                    break;
                }
            }
            if converged {
                break;
            }
            if !accepted {
                // No descent left: a numerical minimum. Accept it if the cosines are
                // small to a looser tolerance.
                converged =
                    (0..2).all(|k| !free[k] || cos_small(k, crate::tolerance::LOOSE_COSINE_EPS));
                break;
            }
        }
        let on_leaf_edge = (0..2).any(|k| {
            !wrap[k]
                && ((uv[k] <= lo[k] && lo[k] > self.domain_lo[k])
                    || (uv[k] >= hi[k] && hi[k] < self.domain_hi[k]))
        });
        Candidate {
            uv,
            point: d.point,
            dist2: f,
            iters,
            converged,
            on_leaf_edge,
        }
    }
}

/// The 2x2 Newton step `-H^{-1} g`, with `H` shifted to positive definite if needed.
#[inline]
fn newton_step_2(h00: f64, h01: f64, h11: f64, g: DVec2) -> DVec2 {
    let tr = h00 + h11;
    let det = h00 * h11 - h01 * h01;
    // Clearly positive definite (`lmin / lmax > 1e-12`, as `det = lmin lmax` and
    // `tr = lmin + lmax`): no eigenvalues needed.
    if h00 > 0.0 && det > crate::tolerance::POS_DEF_REL * tr * tr && det.is_finite() {
        return DVec2::new(
            -(h11 * g.x - h01 * g.y) / det,
            -(h00 * g.y - h01 * g.x) / det,
        );
    }
    let disc = ((h00 - h11) * (h00 - h11) + 4.0 * h01 * h01).sqrt();
    let lmin = 0.5 * (tr - disc);
    let lmax = 0.5 * (tr + disc);
    let mut shift = 0.0;
    if lmin.is_nan() || lmin <= crate::tolerance::SINGULAR_REL * lmax.abs() {
        shift = -lmin
            + crate::tolerance::HESSIAN_SHIFT_REL * lmax.abs().max(crate::tolerance::DIVISOR_MIN);
    }
    let (a, b, c) = (h00 + shift, h01, h11 + shift);
    let det = a * c - b * b;
    if det.is_nan() || det <= 0.0 || !det.is_finite() {
        return DVec2::ZERO;
    }
    DVec2::new(-(c * g.x - b * g.y) / det, -(a * g.y - b * g.x) / det)
}

/// The 1D Newton step `-g / h`, falling back to Gauss-Newton when `h <= 0`.
#[inline]
fn newton_step_1(h: f64, jtj: f64, g: f64) -> f64 {
    let den = if h > crate::tolerance::SINGULAR_REL * jtj {
        h
    } else {
        jtj.max(h.abs())
    };
    if den > 0.0 && den.is_finite() {
        -g / den
    } else {
        0.0
    }
}
