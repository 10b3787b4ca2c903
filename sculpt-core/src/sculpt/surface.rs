//! The view of a target surface that sculpting needs: position and first derivatives
//! over the normalised parameter square, a robust normal, and closest points.
//!
//! Evaluation works on `&dyn ParamSurface`, so the NURBS kernel's surfaces and
//! analytic test surfaces are tessellated by the same code. Projection has one path:
//! [`TargetSurface`], the target's NURBS surface with its cached, certified
//! [`SurfaceInverter`] (P&T section 6.1 point inversion inside a branch-and-bound
//! search proven global by a Bernstein-net certificate, see [`crate::nurbs::invert`]).

use std::sync::Arc;

use crate::nurbs::{Certificate, NurbsSurface, Projection, SurfaceInverter};
use crate::tolerance::POINT_EPS;
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
    if n.is_finite()
        && n.length() > crate::tolerance::NORMAL_DEGENERATE_REL * scale
        && n.length() > 0.0
    {
        return n.normalize();
    }
    let centre = DVec2::splat(0.5);
    for step in crate::tolerance::DEGENERATE_NORMAL_STEPS {
        let q = uv + (centre - uv).normalize_or_zero() * step;
        let sp = surface.eval(clamp_uv(q));
        let n = sp.du.cross(sp.dv);
        if n.is_finite() && n.length() > 0.0 {
            return n.normalize();
        }
    }
    DVec3::Z
}

/// The closest point of a target ([`TargetSurface`]) to a query point, with its
/// parameter in the normalised square.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetProjection {
    /// The parameter of the closest point in the **normalised square** `[0, 1]^2`:
    /// `uv_in_square = (uv_in_knots - lo) / (hi - lo)` per direction, the inverse of the
    /// map [`ParamSurface::eval`] applies to the kernel's
    /// [`Projection::uv_in_knots`]. Inside the square except from
    /// [`TargetSurface::closest_point_near`], which moves it by whole periods across a
    /// closed target's seam (the unwrapped plane).
    pub uv_in_square: DVec2,
    /// `S(uv)`, metres in the display frame.
    pub point: DVec3,
    /// `|S(uv) - P|`, metres.
    pub distance: f64,
    /// How the kernel obtained the answer: proven global, or which exit left it
    /// unproven.
    pub certificate: Certificate,
}

/// A target as sculpting sees it: its NURBS surface over the normalised square, and
/// the one cached [`SurfaceInverter`] every projection of sculpting goes through
/// (stroke samples, rims, footprints, the feet of stroke-surface points).
///
/// The inverter is built once and shared (`Arc`): cloning a target, a document or a
/// stroke's view of it copies a pointer. It owns its copy of the surface, so the two
/// cannot disagree; a changed surface is a new `TargetSurface`.
///
/// Projections are [`TargetProjection`]s: the kernel's [`Projection`] (whose parameter
/// is in the knot domain) with its parameter mapped into the **normalised square**
/// `[0, 1]^2` here, at the producer: the closest point proven global by the
/// Bernstein-net certificate, or, where an exit left it unproven, marked so by its
/// [`TargetProjection::certificate`].
#[derive(Debug, Clone)]
pub struct TargetSurface {
    inverter: Arc<SurfaceInverter>,
    /// The knot domain's lower corner and extent.
    knots_lo: DVec2,
    knots_size: DVec2,
}

impl PartialEq for TargetSurface {
    /// The same surface (the inverter is derived from it).
    fn eq(&self, other: &Self) -> bool {
        self.surface() == other.surface()
    }
}

impl TargetSurface {
    /// Builds the inverter of `surface` (see [`SurfaceInverter::new`] for its cost).
    pub fn new(surface: &NurbsSurface) -> Self {
        Self::from_inverter(Arc::new(surface.inverter()))
    }

    /// Shares an inverter already built.
    pub fn from_inverter(inverter: Arc<SurfaceInverter>) -> Self {
        let s = inverter.surface();
        let ((u0, u1), (v0, v1)) = (s.domain_u(), s.domain_v());
        Self {
            knots_lo: DVec2::new(u0, v0),
            knots_size: DVec2::new(u1 - u0, v1 - v0),
            inverter,
        }
    }

    /// The NURBS surface.
    pub fn surface(&self) -> &NurbsSurface {
        self.inverter.surface()
    }

    /// The shared inverter.
    pub fn inverter(&self) -> &Arc<SurfaceInverter> {
        &self.inverter
    }

    /// `uv_in_square` mapped onto the knot domain.
    fn to_knots(&self, uv_in_square: DVec2) -> DVec2 {
        self.knots_lo + uv_in_square * self.knots_size
    }

    /// A kernel answer with its parameter mapped from the knot domain into the
    /// normalised square.
    fn in_square(&self, pr: Projection) -> TargetProjection {
        let uv = (pr.uv_in_knots - self.knots_lo) / self.knots_size;
        TargetProjection {
            uv_in_square: clamp_uv(uv),
            point: pr.point,
            distance: pr.distance,
            certificate: pr.certificate,
        }
    }

    /// The closest point of the target to `p`, global (no seed).
    pub fn closest_point(&self, p: DVec3) -> TargetProjection {
        self.in_square(self.inverter.closest_point(p))
    }

    /// The closest point of the target to `p`, seeded at `seed_in_square` (brought into
    /// the square by [`wrap_uv`] first): the seed's Newton answer bounds the search, so
    /// a good seed (the previous sample of a stroke) makes the query cheap; the answer
    /// is still the global one.
    pub fn closest_point_from(&self, p: DVec3, seed_in_square: DVec2) -> TargetProjection {
        let seed = self.to_knots(clamp_uv(wrap_uv(seed_in_square)));
        self.in_square(self.inverter.closest_point_from(p, seed))
    }

    /// [`Self::closest_point_from`] in the **unwrapped plane** of a closed target: the
    /// seed may lie outside the square across a seam, and the answer's `uv` is moved by
    /// whole periods in the `closed` directions to lie within half a period of `about`
    /// (see [`unwrap_near`]). On an open target only the pole rule applies.
    ///
    /// **Poles.** On a side of the square that is one point (a sphere's pole), the
    /// parameter along the side is arbitrary: the answer takes the one of `about`, so a
    /// stroke's centreline reaches the pole straight and leaves it where the next foot
    /// says (`stroke`'s `through_poles`).
    pub fn closest_point_near(
        &self,
        p: DVec3,
        closed: [bool; 2],
        about: DVec2,
        seed: DVec2,
    ) -> TargetProjection {
        let pr = self.closest_point_from(p, seed);
        let uv = unwrap_near(pr.uv_in_square, about, closed);
        TargetProjection {
            uv_in_square: self.settle_on_pole(uv, about, pr.point),
            ..pr
        }
    }

    /// `uv` with its parameter along a side of the square replaced by `about`'s when
    /// the side is a pole: `uv` lies on it and the point there is the same
    /// (`point = S(uv)`, within [`POINT_EPS`]).
    fn settle_on_pole(&self, uv: DVec2, about: DVec2, point: DVec3) -> DVec2 {
        for along in 0..2 {
            let across = 1 - along;
            if (uv[across] == 0.0 || uv[across] == 1.0) && uv[along] != about[along] {
                let mut on_pole = uv;
                on_pole[along] = about[along];
                if self.eval(wrap_uv(on_pole)).p.distance(point) <= POINT_EPS {
                    return on_pole;
                }
            }
        }
        uv
    }
}

impl ParamSurface for TargetSurface {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        self.surface().eval(uv)
    }
}

/// `uv` moved by whole periods in the `closed` directions to lie nearest `near` (within
/// half a period of it); open directions are left alone.
pub fn unwrap_near(uv: DVec2, near: DVec2, closed: [bool; 2]) -> DVec2 {
    let f = |x: f64, n: f64, c: bool| {
        let k = (n - x).round();
        if c && k.is_finite() { x + k } else { x }
    };
    DVec2::new(f(uv.x, near.x, closed[0]), f(uv.y, near.y, closed[1]))
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
    let tol = crate::tolerance::SEAM_REL * diag;
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
    //! NURBS targets for unit tests (exact where the shape allows).
    use super::*;

    /// The plane z = 0 over [0, size] x [0, size] metres (exact, bilinear).
    pub fn plane(size: f64) -> TargetSurface {
        let s = NurbsSurface::plane(DVec3::ZERO, DVec3::X * size, DVec3::Y * size)
            .expect("valid plane");
        TargetSurface::new(&s)
    }

    /// A wavy unit square, z = a sin(4 pi x) cos(4 pi y): the bicubic interpolant of a
    /// 33 x 33 grid of it (P&T A9.4).
    pub fn wavy(a: f64) -> TargetSurface {
        use std::f64::consts::PI;
        let n = 32;
        let grid: Vec<Vec<DVec3>> = (0..=n)
            .map(|i| {
                (0..=n)
                    .map(|j| {
                        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                        DVec3::new(x, y, a * (4.0 * PI * x).sin() * (4.0 * PI * y).cos())
                    })
                    .collect()
            })
            .collect();
        let (s, _, _) = NurbsSurface::interpolate_grid(&grid, 3, 3).expect("valid grid");
        TargetSurface::new(&s)
    }

    /// The exact rational sphere of radius `r` about the origin: u around the z axis
    /// (seam at -x, u growing towards -y), v pole to pole (south at v = 0).
    pub fn sphere(r: f64) -> TargetSurface {
        TargetSurface::new(&NurbsSurface::sphere(DVec3::ZERO, r).expect("valid sphere"))
    }
}

#[cfg(test)]
mod tests {
    use super::test_surfaces::*;
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{COSINE_EPS, ULP_EPS};

    /// Projections come back in the normalised square, through the target's inverter,
    /// certified; on a sphere, the seeded query across the seam is unwrapped next to
    /// the seed.
    #[test]
    fn projects_onto_plane_and_sphere_in_the_square() {
        use crate::nurbs::Certificate;
        // A plane whose knot domain is [0, 1]^2, 2 m across.
        let t = plane(2.0);
        let pr = t.closest_point(DVec3::new(0.5, 1.5, 0.3));
        assert_near!(pr.uv_in_square.to_array(), [0.25, 0.75], POINT_EPS);
        assert_near!(pr.distance, 0.3, POINT_EPS);
        assert_eq!(pr.certificate, Certificate::Certified);
        let sph = sphere(1.0);
        let q = DVec3::new(1.0, 1.0, 0.2) * 2.0;
        let pr = sph.closest_point(q);
        assert_near!(pr.distance, q.length() - 1.0, POINT_EPS);
        // Just past the seam (u = 0 = 1 at -x, u growing towards -y), seeded just
        // before it.
        let a = 0.01f64;
        let before = sph.closest_point(DVec3::new(-a.cos(), a.sin(), 0.0));
        let after = sph.closest_point_near(
            DVec3::new(-a.cos(), -a.sin(), 0.0),
            [true, false],
            before.uv_in_square,
            before.uv_in_square,
        );
        assert!(
            after.uv_in_square.x > 1.0 && after.uv_in_square.x - before.uv_in_square.x < 0.01,
            "{after:?}"
        );
        assert_near!(after.distance, 0.0, POINT_EPS);
    }

    #[test]
    fn pole_normal_is_finite() {
        let sph = sphere(1.0);
        // At the south pole `Su` vanishes: the normal is taken beside it, along the
        // axis.
        let n = normal_at(&sph, DVec2::new(0.3, 0.0));
        assert_near!(n.z.abs(), 1.0, COSINE_EPS);
        let e = extent(&sph);
        assert!(e.closed_u && !e.closed_v);
    }

    #[test]
    fn wrap_uv_brings_seam_crossings_back_and_leaves_the_square_alone() {
        assert_near!(
            wrap_uv(DVec2::new(1.25, 0.5)).to_array(),
            [0.25, 0.5],
            ULP_EPS
        );
        assert_near!(
            wrap_uv(DVec2::new(-0.25, 1.0)).to_array(),
            [0.75, 1.0],
            ULP_EPS
        );
        assert_near!(wrap_uv(DVec2::new(0.0, 1.0)).to_array(), [0.0, 1.0], 0.0);
        assert_near!(
            wrap_uv(DVec2::new(f64::NAN, 0.2)).to_array(),
            [0.5, 0.2],
            0.0
        );
    }
}
