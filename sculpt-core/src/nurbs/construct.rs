//! Constructors for the shapes users need: planes, bilinear patches, exact rational
//! circles, spheres, tori and cylinders, surfaces of revolution and extrusions (P&T
//! chapters 7 and 8).
//!
//! Orientation: `u` runs around the axis of revolved shapes and along the curve of
//! extrusions; `v` runs along the profile (revolution) or the extrusion direction.

use std::f64::consts::{PI, TAU};

use glam::{DVec3, DVec4};

use super::curve::NurbsCurve;
use super::knots::KnotVector;
use super::surface::NurbsSurface;
use crate::error::{Error, ParameterError, Result};

fn check_finite(what: &'static str, values: &[f64]) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::InvalidParameter(ParameterError::NotFinite { what }))
    }
}

/// The arc layout of P&T A7.1: number of arcs, the knot vector and the weight of the
/// middle control points, for a sweep of `theta` radians.
fn arc_layout(theta: f64) -> (usize, Vec<f64>, f64) {
    let narcs = if theta <= PI / 2.0 + crate::tolerance::ANGLE_EPS {
        1
    } else if theta <= PI + crate::tolerance::ANGLE_EPS {
        2
    } else if theta <= 1.5 * PI + crate::tolerance::ANGLE_EPS {
        3
    } else {
        4
    };
    let mut knots = vec![0.0; 3];
    for i in 1..narcs {
        let t = i as f64 / narcs as f64;
        knots.extend([t, t]);
    }
    knots.extend([1.0; 3]);
    (narcs, knots, (theta / narcs as f64 / 2.0).cos())
}

/// The `2 narcs + 1` homogeneous control points of a circular arc (P&T A7.1): centre
/// `o`, orthonormal `x`, `y`, radius `r`, from angle `start` sweeping `theta`.
fn arc_points(o: DVec3, x: DVec3, y: DVec3, r: f64, start: f64, theta: f64) -> Vec<DVec4> {
    let (narcs, _, w1) = arc_layout(theta);
    let dtheta = theta / narcs as f64;
    let at = |a: f64, scale: f64| o + (x * a.cos() + y * a.sin()) * (r * scale);
    let mut pts = vec![at(start, 1.0).extend(1.0)];
    for i in 1..=narcs {
        let a = start + dtheta * i as f64;
        // The tangent lines at both ends meet at radius r / cos(dtheta / 2).
        let mid = at(a - dtheta / 2.0, 1.0 / w1);
        pts.push((mid * w1).extend(w1));
        pts.push(at(a, 1.0).extend(1.0));
    }
    pts
}

impl NurbsCurve {
    /// A straight segment from `a` to `b` (degree 1).
    pub fn line(a: DVec3, b: DVec3) -> Result<Self> {
        NurbsCurve::new(1, vec![0.0, 0.0, 1.0, 1.0], vec![a, b], None)
    }

    /// An exact circular arc (P&T A7.1): centre, in-plane axes `x_axis` and `y_axis`
    /// (made orthonormal), radius, and angles in radians from `x_axis` towards
    /// `y_axis`. A sweep of `2 pi` or more gives the full circle. Domain `[0, 1]`.
    pub fn arc(
        center: DVec3,
        x_axis: DVec3,
        y_axis: DVec3,
        radius: f64,
        start: f64,
        end: f64,
    ) -> Result<Self> {
        check_finite("arc parameters", &[radius, start, end])?;
        check_finite(
            "arc axes",
            &[
                center.x, center.y, center.z, x_axis.x, x_axis.y, x_axis.z, y_axis.x, y_axis.y,
                y_axis.z,
            ],
        )?;
        let x =
            x_axis
                .try_normalize()
                .ok_or(Error::InvalidParameter(ParameterError::ZeroVector {
                    what: "arc x axis",
                }))?;
        let y = (y_axis - x * x.dot(y_axis))
            .try_normalize()
            .ok_or(Error::InvalidParameter(ParameterError::Parallel {
                what: "arc axes",
            }))?;
        if radius <= 0.0 {
            return Err(Error::InvalidParameter(ParameterError::NotPositive {
                what: "arc radius",
                value: radius,
            }));
        }
        let theta = (end - start).min(TAU);
        if theta <= 0.0 {
            return Err(Error::InvalidParameter(ParameterError::ArcEndBeforeStart));
        }
        let (_, knots, _) = arc_layout(theta);
        let pw = arc_points(center, x, y, radius, start, theta);
        NurbsCurve::from_homogeneous(KnotVector::new(2, knots)?, pw)
    }

    /// The full circle of `radius` about `center` in the plane spanned by `x_axis`,
    /// `y_axis` (nine control points, four quarter arcs).
    pub fn circle(center: DVec3, x_axis: DVec3, y_axis: DVec3, radius: f64) -> Result<Self> {
        Self::arc(center, x_axis, y_axis, radius, 0.0, TAU)
    }
}

impl NurbsSurface {
    /// The bilinear patch through four corners: `S(0,0) = p00`, `S(1,0) = p10`,
    /// `S(0,1) = p01`, `S(1,1) = p11`.
    pub fn bilinear(p00: DVec3, p10: DVec3, p01: DVec3, p11: DVec3) -> Result<Self> {
        let k = vec![0.0, 0.0, 1.0, 1.0];
        NurbsSurface::new(
            1,
            1,
            k.clone(),
            k,
            vec![vec![p00, p01], vec![p10, p11]],
            None,
        )
    }

    /// The planar parallelogram `origin + u * u_edge + v * v_edge`, `u, v` in `[0, 1]`.
    pub fn plane(origin: DVec3, u_edge: DVec3, v_edge: DVec3) -> Result<Self> {
        if u_edge.cross(v_edge).length_squared() == 0.0 {
            return Err(Error::InvalidParameter(ParameterError::DegeneratePlane));
        }
        Self::bilinear(
            origin,
            origin + u_edge,
            origin + v_edge,
            origin + u_edge + v_edge,
        )
    }

    /// The surface swept by rotating `profile` by `angle` radians about the axis through
    /// `axis_point` with direction `axis_dir` (P&T A8.1). Degree 2 around the axis (`u`),
    /// the profile's degree along it (`v`). Profile points on the axis become poles.
    pub fn revolution(
        profile: &NurbsCurve,
        axis_point: DVec3,
        axis_dir: DVec3,
        angle: f64,
    ) -> Result<Self> {
        check_finite("revolution angle", &[angle])?;
        let t = axis_dir.try_normalize().ok_or(Error::InvalidParameter(
            ParameterError::ZeroVector {
                what: "revolution axis",
            },
        ))?;
        let theta = angle.min(TAU);
        if theta <= 0.0 {
            return Err(Error::InvalidParameter(ParameterError::NotPositive {
                what: "revolution angle",
                value: theta,
            }));
        }
        let (narcs, knots_u, _) = arc_layout(theta);
        let rows = 2 * narcs + 1;
        let profile_pw = profile.homogeneous();
        let n_v = profile_pw.len();
        let mut pw = vec![DVec4::ZERO; rows * n_v];
        // A reference direction for points on the axis (their circles have radius 0).
        let any_x = t.any_orthonormal_vector();
        for (j, q) in profile_pw.iter().enumerate() {
            let p = q.truncate() / q.w;
            let o = axis_point + t * (p - axis_point).dot(t);
            let radial = p - o;
            let r = radial.length();
            let x = if r > 0.0 { radial / r } else { any_x };
            let y = t.cross(x);
            let arc = if r > 0.0 {
                arc_points(o, x, y, r, 0.0, theta)
            } else {
                let (_, _, w1) = arc_layout(theta);
                (0..rows)
                    .map(|i| {
                        if i % 2 == 1 {
                            (o * w1).extend(w1)
                        } else {
                            o.extend(1.0)
                        }
                    })
                    .collect()
            };
            for (i, a) in arc.iter().enumerate() {
                // Weights multiply: w_ij = w_arc_i * w_j.
                let w = a.w * q.w;
                pw[i * n_v + j] = (a.truncate() / a.w * w).extend(w);
            }
        }
        NurbsSurface::from_homogeneous(KnotVector::new(2, knots_u)?, profile.knots().clone(), pw)
    }

    /// The exact rational sphere (revolved half circle): seam at `u = 0` / `u = 1`,
    /// poles at `v = 0` (south, `-z`) and `v = 1` (north, `+z`).
    pub fn sphere(center: DVec3, radius: f64) -> Result<Self> {
        check_finite("sphere", &[center.x, center.y, center.z, radius])?;
        if radius <= 0.0 {
            return Err(Error::InvalidParameter(ParameterError::NotPositive {
                what: "sphere radius",
                value: radius,
            }));
        }
        let profile = NurbsCurve::arc(center, DVec3::Z, DVec3::X, radius, PI, TAU)?;
        Self::revolution(&profile, center, DVec3::Z, TAU)
    }

    /// The exact rational torus about the `z` axis through `center`: tube centre circle
    /// radius `major`, tube radius `minor` (`minor < major`). Closed in both `u` and `v`.
    pub fn torus(center: DVec3, major: f64, minor: f64) -> Result<Self> {
        check_finite("torus", &[center.x, center.y, center.z, major, minor])?;
        if !(minor > 0.0 && major > minor) {
            return Err(Error::InvalidParameter(ParameterError::TorusRadii {
                minor,
                major,
            }));
        }
        let profile = NurbsCurve::circle(center + DVec3::X * major, DVec3::X, DVec3::Z, minor)?;
        Self::revolution(&profile, center, DVec3::Z, TAU)
    }

    /// The exact circular cylinder: base circle about `base_center` with axis `axis`
    /// (its length is the height), radius `radius`. `u` around, `v` along the axis.
    pub fn cylinder(base_center: DVec3, axis: DVec3, radius: f64) -> Result<Self> {
        check_finite("cylinder", &[radius, axis.x, axis.y, axis.z])?;
        if radius <= 0.0 || axis.length_squared() == 0.0 {
            return Err(Error::InvalidParameter(ParameterError::DegenerateCylinder));
        }
        let x = axis.any_orthonormal_vector();
        let a = base_center + x * radius;
        Self::revolution(&NurbsCurve::line(a, a + axis)?, base_center, axis, TAU)
    }

    /// The extrusion of `curve` along `direction` (a general cylinder, P&T section 8.3):
    /// `S(u, v) = C(u) + v * direction`, degree 1 in `v`.
    pub fn extrusion(curve: &NurbsCurve, direction: DVec3) -> Result<Self> {
        check_finite(
            "extrusion direction",
            &[direction.x, direction.y, direction.z],
        )?;
        let mut pw = Vec::with_capacity(curve.homogeneous().len() * 2);
        for q in curve.homogeneous() {
            pw.push(*q);
            pw.push((q.truncate() + direction * q.w).extend(q.w));
        }
        NurbsSurface::from_homogeneous(
            curve.knots().clone(),
            KnotVector::new(1, vec![0.0, 0.0, 1.0, 1.0])?,
            pw,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{COSINE_EPS, EXACT_EPS, ULP_EPS};
    use std::f64::consts::FRAC_1_SQRT_2;

    #[test]
    fn circle_is_exact_and_closed() {
        let c = NurbsCurve::circle(DVec3::new(1.0, 2.0, 3.0), DVec3::X, DVec3::Y, 2.0).unwrap();
        for i in 0..=100 {
            let p = c.point(i as f64 / 100.0);
            assert_near!(p.distance(DVec3::new(1.0, 2.0, 3.0)), 2.0, EXACT_EPS);
        }
        assert_near!(c.point(0.0).to_array(), c.point(1.0).to_array(), EXACT_EPS);
        assert_eq!(c.homogeneous().len(), 9);
        assert_near!(c.weights()[1], FRAC_1_SQRT_2, ULP_EPS);
    }

    #[test]
    fn sphere_radius_is_exact() {
        let s = NurbsSurface::sphere(DVec3::new(0.5, -1.0, 2.0), 1.5).unwrap();
        assert!(s.is_closed_u() && !s.is_closed_v());
        assert_eq!(s.poles(), [false, false, true, true]);
        for i in 0..=40 {
            for j in 0..=40 {
                let (u, v) = (i as f64 / 40.0, j as f64 / 40.0);
                assert_near!(
                    s.point(u, v).distance(DVec3::new(0.5, -1.0, 2.0)),
                    1.5,
                    EXACT_EPS
                );
                let n = s.normal(u, v);
                let radial = (s.point(u, v) - DVec3::new(0.5, -1.0, 2.0)) / 1.5;
                assert_near!(n.dot(radial).abs(), 1.0, COSINE_EPS);
            }
        }
    }

    #[test]
    fn torus_and_cylinder_are_exact() {
        let t = NurbsSurface::torus(DVec3::ZERO, 2.0, 0.5).unwrap();
        assert!(t.is_closed_u() && t.is_closed_v());
        let c = NurbsSurface::cylinder(DVec3::ZERO, DVec3::new(0.0, 0.0, 3.0), 0.7).unwrap();
        assert!(c.is_closed_u() && !c.is_closed_v());
        for i in 0..=30 {
            for j in 0..=30 {
                let (u, v) = (i as f64 / 30.0, j as f64 / 30.0);
                let p = t.point(u, v);
                let ring = (DVec3::new(p.x, p.y, 0.0).length() - 2.0).hypot(p.z);
                assert_near!(ring, 0.5, EXACT_EPS);
                let q = c.point(u, v);
                assert_near!(q.truncate().length(), 0.7, EXACT_EPS);
                assert_near!(q.z, 3.0 * v, EXACT_EPS);
            }
        }
    }

    #[test]
    fn extrusion_and_plane() {
        let arc = NurbsCurve::arc(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 2.0).unwrap();
        let e = NurbsSurface::extrusion(&arc, DVec3::new(0.0, 0.0, 2.0)).unwrap();
        for i in 0..=10 {
            let u = i as f64 / 10.0;
            let top = e.point(u, 1.0);
            assert_near!(
                (top - DVec3::Z * 2.0).to_array(),
                arc.point(u).to_array(),
                EXACT_EPS
            );
        }
        let p = NurbsSurface::plane(DVec3::ONE, DVec3::X * 2.0, DVec3::Y * 3.0).unwrap();
        assert_near!(p.point(0.5, 0.5).to_array(), [2.0, 2.5, 1.0], EXACT_EPS);
        assert!(NurbsSurface::plane(DVec3::ZERO, DVec3::X, DVec3::X).is_err());
        assert!(NurbsSurface::sphere(DVec3::ZERO, -1.0).is_err());
        assert!(NurbsSurface::torus(DVec3::ZERO, 1.0, 2.0).is_err());
        assert!(NurbsCurve::arc(DVec3::ZERO, DVec3::X, DVec3::X, 1.0, 0.0, 1.0).is_err());
    }
}
