//! The view of a target surface that sculpting needs: position and first derivatives
//! over the normalised parameter square, a robust normal, and Newton point inversion.
//!
//! Everything in [`crate::sculpt`] works on `&dyn ParamSurface`, so the NURBS kernel's
//! surfaces and analytic test surfaces are sculpted by the same code.

use glam::{DVec2, DVec3};

/// Position and first partial derivatives of a surface at one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// S(u, v), metres in the display frame.
    pub p: DVec3,
    /// dS/du with respect to the *normalised* parameter.
    pub du: DVec3,
    /// dS/dv with respect to the *normalised* parameter.
    pub dv: DVec3,
}

/// A parametric surface over the normalised square `[0, 1] x [0, 1]`.
pub trait ParamSurface {
    /// Position and first derivatives at `uv` (normalised, clamped by the caller).
    fn eval(&self, uv: DVec2) -> SurfacePoint;
}

impl<F: Fn(DVec2) -> SurfacePoint> ParamSurface for F {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        self(uv)
    }
}

impl ParamSurface for crate::nurbs::NurbsSurface {
    /// Maps the normalised square onto the knot domain; derivatives scale by the
    /// domain's extent (chain rule).
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let ((u0, u1), (v0, v1)) = (self.domain_u(), self.domain_v());
        let d = self.derivatives(u0 + uv.x * (u1 - u0), v0 + uv.y * (v1 - v0));
        SurfacePoint {
            p: d.point,
            du: d.du * (u1 - u0),
            dv: d.dv * (v1 - v0),
        }
    }
}

/// Clamps a parameter into the unit square (NaN becomes 0.5).
pub fn clamp_uv(uv: DVec2) -> DVec2 {
    let c = |x: f64| {
        if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.5
        }
    };
    DVec2::new(c(uv.x), c(uv.y))
}

/// Brings a parameter that left the unit square across the seam of a closed surface
/// back into it (each coordinate outside `[0, 1]` is taken modulo 1); coordinates inside
/// are unchanged, so for open surfaces, whose parameters never leave the square, this is
/// the identity. NaN becomes 0.5, as in [`clamp_uv`].
pub fn wrap_uv(uv: DVec2) -> DVec2 {
    let w = |x: f64| {
        if !x.is_finite() {
            0.5
        } else if (0.0..=1.0).contains(&x) {
            x
        } else {
            x.rem_euclid(1.0)
        }
    };
    DVec2::new(w(uv.x), w(uv.y))
}

/// The unit normal `Su x Sv / |Su x Sv|` at `uv`.
///
/// At a degenerate point (a pole, where one derivative vanishes, or a fold) the normal
/// is taken a small step inward in parameter space, where it is defined, so that poles
/// of spheres get the limit normal. Falls back to `+Z` only for a wholly degenerate
/// patch. Never NaN.
pub fn normal_at(surface: &dyn ParamSurface, uv: DVec2) -> DVec3 {
    let uv = clamp_uv(uv);
    normal_from(surface, uv, &surface.eval(uv))
}

/// [`normal_at`] when `sp = surface.eval(uv)` is already known (saves an evaluation
/// except at degenerate points).
pub fn normal_from(surface: &dyn ParamSurface, uv: DVec2, sp: &SurfacePoint) -> DVec3 {
    let n = sp.du.cross(sp.dv);
    let scale = (sp.du.length() * sp.dv.length()).max(f64::MIN_POSITIVE);
    if n.is_finite() && n.length() > 1e-9 * scale && n.length() > 0.0 {
        return n.normalize();
    }
    let centre = DVec2::splat(0.5);
    for step in [1e-6, 1e-4, 1e-2] {
        let q = uv + (centre - uv).normalize_or_zero() * step;
        let sp = surface.eval(clamp_uv(q));
        let n = sp.du.cross(sp.dv);
        if n.is_finite() && n.length() > 0.0 {
            return n.normalize();
        }
    }
    DVec3::Z
}

/// Result of projecting a point onto a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Foot point parameter, normalised and inside the square.
    pub uv: DVec2,
    /// Foot point S(uv).
    pub p: DVec3,
    /// Distance from the query point to the foot point.
    pub distance: f64,
}

/// Point inversion by Newton iteration, seeded (P&T section 6.1, eq. 6.6-6.8, with the
/// first-order Jacobian, clamped to the domain as for open surfaces).
///
/// Minimises `|S(u,v) - q|`; the step solves the 2x2 normal equations `J^T J d = -J^T r`
/// with `J = [Su Sv]`, halving the step when it does not improve the distance. Stops when
/// the point coincides (P&T epsilon 1), the residual is orthogonal to both tangents
/// (epsilon 2), or the parameter stops moving.
pub fn project_seeded(surface: &dyn ParamSurface, q: DVec3, seed: DVec2) -> Projection {
    use crate::tolerance::{COSINE_EPS, PARAM_EPS, POINT_EPS};
    let mut uv = clamp_uv(seed);
    let mut sp = surface.eval(uv);
    let mut dist = (sp.p - q).length();
    for _ in 0..40 {
        let r = sp.p - q;
        if r.length() <= POINT_EPS {
            break;
        }
        let (a, b) = (sp.du, sp.dv);
        let cos_u = a.dot(r).abs() / (a.length() * r.length()).max(f64::MIN_POSITIVE);
        let cos_v = b.dot(r).abs() / (b.length() * r.length()).max(f64::MIN_POSITIVE);
        if cos_u <= COSINE_EPS && cos_v <= COSINE_EPS {
            break;
        }
        let (aa, ab, bb) = (a.dot(a), a.dot(b), b.dot(b));
        let (ga, gb) = (-a.dot(r), -b.dot(r));
        let det = aa * bb - ab * ab;
        let step = if det.abs() > 1e-14 * (aa * bb).max(f64::MIN_POSITIVE) {
            DVec2::new((ga * bb - gb * ab) / det, (aa * gb - ab * ga) / det)
        } else {
            // Degenerate Jacobian (pole): gradient step along the usable tangent.
            DVec2::new(ga / aa.max(1e-300), gb / bb.max(1e-300)) * 0.5
        };
        if !step.is_finite() {
            break;
        }
        let mut t = 1.0;
        let mut improved = false;
        for _ in 0..8 {
            let cand = clamp_uv(uv + step * t);
            let csp = surface.eval(cand);
            let cd = (csp.p - q).length();
            if cd < dist {
                let moved = (cand - uv).length();
                uv = cand;
                sp = csp;
                dist = cd;
                improved = moved > PARAM_EPS;
                break;
            }
            t *= 0.5;
        }
        if !improved {
            break;
        }
    }
    Projection {
        uv,
        p: sp.p,
        distance: dist,
    }
}

/// Point inversion without a seed: the best of a coarse `n x n` grid search, refined by
/// [`project_seeded`].
pub fn project(surface: &dyn ParamSurface, q: DVec3) -> Projection {
    let n = 12;
    let mut best = (f64::INFINITY, DVec2::splat(0.5));
    for i in 0..=n {
        for j in 0..=n {
            let uv = DVec2::new(i as f64 / n as f64, j as f64 / n as f64);
            let d = surface.eval(uv).p.distance_squared(q);
            if d < best.0 {
                best = (d, uv);
            }
        }
    }
    project_seeded(surface, q, best.1)
}

/// Facts about a surface's extent that sculpting needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceExtent {
    /// Axis-aligned bounding box minimum of a sample grid.
    pub min: DVec3,
    /// Axis-aligned bounding box maximum of a sample grid.
    pub max: DVec3,
    /// Closed in u: the edges u = 0 and u = 1 coincide.
    pub closed_u: bool,
    /// Closed in v: the edges v = 0 and v = 1 coincide.
    pub closed_v: bool,
    /// Largest second difference of the sample grid, per unit parameter squared
    /// (an estimate of max |S_uu|, |S_vv|), used to choose the base grid.
    pub curvature: f64,
}

impl SurfaceExtent {
    /// Length of the bounding box diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }
}

/// Samples a surface on a 33 x 33 grid to find its extent, closedness and curvature
/// bound.
pub fn extent(surface: &dyn ParamSurface) -> SurfaceExtent {
    extent_sampled(surface, 32)
}

/// [`extent`] from an `(n + 1) x (n + 1)` sample grid (`n >= 2`).
pub fn extent_sampled(surface: &dyn ParamSurface, n: usize) -> SurfaceExtent {
    let n = n.max(2);
    #[allow(non_snake_case)]
    let N = n;
    let h = 1.0 / N as f64;
    let mut grid = vec![DVec3::ZERO; (N + 1) * (N + 1)];
    let (mut min, mut max) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for j in 0..=N {
        for i in 0..=N {
            let p = surface.eval(DVec2::new(i as f64 * h, j as f64 * h)).p;
            let p = if p.is_finite() { p } else { DVec3::ZERO };
            grid[j * (N + 1) + i] = p;
            min = min.min(p);
            max = max.max(p);
        }
    }
    let at = |i: usize, j: usize| grid[j * (N + 1) + i];
    let diag = (max - min).length().max(f64::MIN_POSITIVE);
    let tol = 1e-7 * diag;
    let closed_u = (0..=N).all(|j| at(0, j).distance(at(N, j)) <= tol);
    let closed_v = (0..=N).all(|i| at(i, 0).distance(at(i, N)) <= tol);
    let mut curvature: f64 = 0.0;
    for j in 0..=N {
        for i in 1..N {
            let d2 = at(i - 1, j) - 2.0 * at(i, j) + at(i + 1, j);
            curvature = curvature.max(d2.length() / (h * h));
        }
    }
    for j in 1..N {
        for i in 0..=N {
            let d2 = at(i, j - 1) - 2.0 * at(i, j) + at(i, j + 1);
            curvature = curvature.max(d2.length() / (h * h));
        }
    }
    SurfaceExtent {
        min,
        max,
        closed_u,
        closed_v,
        curvature,
    }
}

#[cfg(test)]
pub(crate) mod test_surfaces {
    //! Analytic surfaces for unit tests.
    use super::*;

    /// The plane z = 0 over [0, 1] x [0, 1] metres... scaled by `size`.
    pub fn plane(size: f64) -> impl Fn(DVec2) -> SurfacePoint {
        move |uv: DVec2| SurfacePoint {
            p: DVec3::new(uv.x * size, uv.y * size, 0.0),
            du: DVec3::X * size,
            dv: DVec3::Y * size,
        }
    }

    /// A wavy unit square: z = a sin(4 pi u) cos(4 pi v).
    pub fn wavy(a: f64) -> impl Fn(DVec2) -> SurfacePoint {
        use std::f64::consts::PI;
        move |uv: DVec2| {
            let (su, cu) = (4.0 * PI * uv.x).sin_cos();
            let (sv, cv) = (4.0 * PI * uv.y).sin_cos();
            SurfacePoint {
                p: DVec3::new(uv.x, uv.y, a * su * cv),
                du: DVec3::new(1.0, 0.0, a * 4.0 * PI * cu * cv),
                dv: DVec3::new(0.0, 1.0, -a * 4.0 * PI * su * sv),
            }
        }
    }

    /// A unit sphere, u around the axis, v pole to pole (poles at v = 0 and 1).
    pub fn sphere(r: f64) -> impl Fn(DVec2) -> SurfacePoint {
        use std::f64::consts::{PI, TAU};
        move |uv: DVec2| {
            let (th, ph) = (uv.x * TAU, uv.y * PI);
            let (st, ct) = th.sin_cos();
            let (sp, cp) = ph.sin_cos();
            SurfacePoint {
                p: r * DVec3::new(sp * ct, sp * st, -cp),
                du: r * TAU * DVec3::new(-sp * st, sp * ct, 0.0),
                dv: r * PI * DVec3::new(cp * ct, cp * st, sp),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_surfaces::*;
    use super::*;
    use crate::assert_near;

    #[test]
    fn projects_onto_plane_and_sphere() {
        let s = plane(2.0);
        let pr = project(&s, DVec3::new(0.5, 1.5, 0.3));
        assert_near!(pr.uv.to_array(), [0.25, 0.75], 1e-9);
        assert_near!(pr.distance, 0.3, 1e-9);
        let sph = sphere(1.0);
        let q = DVec3::new(1.0, 1.0, 0.2) * 2.0;
        let pr = project(&sph, q);
        assert_near!(pr.distance, q.length() - 1.0, 1e-7);
    }

    #[test]
    fn pole_normal_is_finite() {
        let sph = sphere(1.0);
        let n = normal_at(&sph, DVec2::new(0.3, 0.0));
        assert_near!(n.to_array(), [0.0, 0.0, -1.0], 1e-3);
        let e = extent(&sph);
        assert!(e.closed_u && !e.closed_v);
    }

    #[test]
    fn wrap_uv_brings_seam_crossings_back_and_leaves_the_square_alone() {
        assert_near!(
            wrap_uv(DVec2::new(1.25, 0.5)).to_array(),
            [0.25, 0.5],
            1e-15
        );
        assert_near!(
            wrap_uv(DVec2::new(-0.25, 1.0)).to_array(),
            [0.75, 1.0],
            1e-15
        );
        assert_near!(wrap_uv(DVec2::new(0.0, 1.0)).to_array(), [0.0, 1.0], 0.0);
        assert_near!(
            wrap_uv(DVec2::new(f64::NAN, 0.2)).to_array(),
            [0.5, 0.2],
            0.0
        );
    }
}
