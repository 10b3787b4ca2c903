//! Seams, poles, curves and knot insertion through the public API: closest points on
//! exact spheres and tori (answers on and across the seam, at the poles), curve
//! inversion against brute force, and refinement that leaves shapes unchanged.

use std::f64::consts::TAU;

use glam::{DVec2, DVec3};
use sculpt_core::assert_near;
use sculpt_core::nurbs::{Direction, NurbsCurve, NurbsSurface};
use sculpt_core::tolerance::{EXACT_EPS, POINT_EPS, STATIONARY_FOOT_EPS};

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn sphere_closest_points_are_radial_everywhere_including_seam_and_poles() {
    let c = DVec3::new(0.1, -0.2, 0.3);
    let r = 0.8;
    let s = NurbsSurface::sphere(c, r).unwrap();
    let inv = s.inverter();
    let mut seed = 11;
    let mut dirs: Vec<DVec3> = (0..300)
        .map(|_| {
            DVec3::new(
                lcg(&mut seed) - 0.5,
                lcg(&mut seed) - 0.5,
                lcg(&mut seed) - 0.5,
            )
            .normalize()
        })
        .collect();
    // On the seam plane (u = 0 is the -x half-plane of the profile) and at the poles.
    dirs.extend([
        DVec3::Z,
        -DVec3::Z,
        -DVec3::X,
        DVec3::new(-1.0, 1e-9, 0.3).normalize(), // not a tolerance: directions just off a pole
        DVec3::new(-1.0, -1e-9, -0.3).normalize(), // not a tolerance: as above
        DVec3::new(1e-7, 0.0, 1.0).normalize(),  // not a tolerance: as above
    ]);
    for d in dirs {
        for dist in [0.05, 0.5, 3.0, 500.0] {
            let p = c + d * (r + dist);
            let got = inv.closest_point(p);
            assert!(got.converged, "{p:?}: {got:?}");
            assert_near!(got.distance, dist, POINT_EPS, "p = {p:?}, got {got:?}");
            // The distance is stationary at the foot, so the point is determined only to
            // about the square root of the distance tolerance.
            assert_near!(
                got.point.to_array(),
                (c + d * r).to_array(),
                STATIONARY_FOOT_EPS
            );
        }
        // Inside the sphere too (not at the centre).
        let p = c + d * (r * 0.5);
        assert_near!(inv.closest_point(p).distance, r * 0.5, POINT_EPS);
    }
}

#[test]
fn torus_closest_points_wrap_both_seams() {
    let (big, small) = (1.5, 0.4);
    let t = NurbsSurface::torus(DVec3::ZERO, big, small).unwrap();
    let inv = t.inverter();
    let mut seed = 5;
    for k in 0..400 {
        let phi = if k < 20 { 0.0 } else { lcg(&mut seed) * TAU }; // seam phi = 0
        let psi = if k % 10 == 0 {
            0.0
        } else {
            lcg(&mut seed) * TAU
        };
        let off = 0.05 + 0.3 * lcg(&mut seed);
        let ring = DVec3::new(phi.cos(), phi.sin(), 0.0);
        let normal = ring * psi.cos() + DVec3::Z * psi.sin();
        let foot = ring * big + normal * small;
        let p = foot + normal * off;
        let got = inv.closest_point(p);
        assert!(got.converged, "{p:?}: {got:?}");
        assert_near!(got.distance, off, POINT_EPS, "p = {p:?} got {got:?}");
        // Seeded from the other side of the seam still finds it.
        let seeded = inv.closest_point_from(p, DVec2::new(0.999, 0.001));
        assert_near!(seeded.distance, off, POINT_EPS);
        let newton = inv.newton_from(p, got.uv_in_knots + DVec2::new(0.01, -0.01));
        assert_near!(newton.distance, off, POINT_EPS);
    }
}

#[test]
fn seeded_newton_wraps_across_the_seam() {
    let s = NurbsSurface::sphere(DVec3::ZERO, 1.0).unwrap();
    let inv = s.inverter();
    // A point just past the seam (u slightly above 0), seeded just before it (u ~ 1).
    let target = s.point(0.002, 0.5);
    let got = inv.newton_from(target * 1.1, DVec2::new(0.998, 0.5));
    assert!(got.converged);
    assert_near!(got.distance, 0.1, POINT_EPS);
    assert!(got.uv_in_knots.x < 0.01 || got.uv_in_knots.x > 0.99);
    assert!(!got.on_boundary, "the seam is not a boundary");
}

#[test]
fn curve_inversion_matches_brute_force() {
    let c = NurbsCurve::new(
        3,
        vec![0., 0., 0., 0., 0.2, 0.5, 0.8, 1., 1., 1., 1.],
        vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(1., 2., 0.),
            DVec3::new(2., -1., 0.5),
            DVec3::new(3., 2., 0.),
            DVec3::new(4., -2., -0.5),
            DVec3::new(5., 1., 0.),
            DVec3::new(6., 0., 0.),
        ],
        Some(vec![1., 2., 0.5, 1., 1.5, 1., 1.]),
    )
    .unwrap();
    let mut seed = 3;
    let mut ends = 0;
    for _ in 0..300 {
        let p = DVec3::new(
            lcg(&mut seed) * 9.0 - 1.5,
            lcg(&mut seed) * 6.0 - 3.0,
            lcg(&mut seed) - 0.5,
        );
        let got = c.closest_point(p);
        let mut brute = f64::INFINITY;
        let mut bu = 0.0;
        for i in 0..=20_000 {
            let u = i as f64 / 20_000.0;
            let d = c.point(u).distance(p);
            if d < brute {
                (brute, bu) = (d, u);
            }
        }
        assert!(
            got.distance <= brute + POINT_EPS,
            "{p:?}: {} vs brute {brute} at {bu}",
            got.distance
        );
        assert!(got.converged);
        assert_near!(got.point.to_array(), c.point(got.u).to_array(), EXACT_EPS);
        if bu == 0.0 || bu == 1.0 {
            ends += 1;
        }
    }
    assert!(ends > 20, "too few end-point cases: {ends}");
    assert_eq!(c.closest_point(DVec3::NAN).distance, f64::INFINITY);
}

#[test]
fn knot_insertion_and_refinement_leave_shapes_unchanged() {
    let s = NurbsSurface::torus(DVec3::new(0.3, 0.0, -0.2), 1.0, 0.25).unwrap();
    let once = s.insert_knot(Direction::U, 0.3, 2).unwrap();
    let refined = once
        .refine_knots(Direction::V, &[0.1, 0.1, 0.4, 0.6, 0.9])
        .unwrap();
    let bezier = s.to_bezier_form().unwrap();
    assert_eq!(once.count_u(), s.count_u() + 2);
    assert_eq!(refined.count_v(), s.count_v() + 5);
    for i in 0..=25 {
        for j in 0..=25 {
            let (u, v) = (i as f64 / 25.0, j as f64 / 25.0);
            let p = s.point(u, v);
            for other in [&once, &refined, &bezier] {
                assert_near!(other.point(u, v).to_array(), p.to_array(), EXACT_EPS);
            }
        }
    }
    let c = NurbsCurve::circle(DVec3::ZERO, DVec3::X, DVec3::Y, 2.0).unwrap();
    let c2 = c
        .insert_knot(0.3, 1)
        .unwrap()
        .refine_knots(&[0.3, 0.6, 0.61])
        .unwrap();
    for i in 0..=100 {
        let u = i as f64 / 100.0;
        assert_near!(c2.point(u).to_array(), c.point(u).to_array(), EXACT_EPS);
        assert_near!(
            c.point_by_corner_cut(u).unwrap().to_array(),
            c.point(u).to_array(),
            EXACT_EPS
        );
    }
    // Multiplicity above the degree, and knots outside the domain, are typed errors.
    assert!(c.insert_knot(0.25, 2).is_err());
    assert!(c.insert_knot(1.5, 1).is_err());
    assert!(c.refine_knots(&[f64::NAN]).is_err());
}
