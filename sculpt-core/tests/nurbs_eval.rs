//! Public-API tests of NURBS evaluation: book examples, analytic shapes, derivatives
//! against finite differences, JSON schema.

use glam::{DVec2, DVec3};
use sculpt_core::Error;
use sculpt_core::assert_near;
use sculpt_core::error::{ControlNetError, KnotError, NetIndex, WeightError};
use sculpt_core::nurbs::refine::Direction;
use sculpt_core::nurbs::{KnotVector, NurbsCurve, NurbsSurface};
use sculpt_core::tolerance::{EXACT_EPS, FD_EPS, FD_STEP};

fn wavy_bicubic() -> NurbsSurface {
    let pts: Vec<Vec<DVec3>> = (0..6)
        .map(|i| {
            (0..6)
                .map(|j| {
                    let (x, y) = (i as f64 / 5.0, j as f64 / 5.0);
                    DVec3::new(x, y, 0.3 * (3.0 * x).sin() * (2.0 * y).cos())
                })
                .collect()
        })
        .collect();
    let k = vec![0., 0., 0., 0., 0.3, 0.6, 1., 1., 1., 1.];
    let w = (0..6)
        .map(|i| {
            (0..6)
                .map(|j| 1.0 + 0.1 * ((i + 2 * j) % 3) as f64)
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, k.clone(), k, pts, Some(w)).unwrap()
}

#[test]
fn book_example_4_2_rational_circle_point() {
    // P&T Ex4.2-style: the quarter circle of radius 1 as a rational quadratic.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let c = NurbsCurve::new(
        2,
        vec![0., 0., 0., 1., 1., 1.],
        vec![DVec3::X, DVec3::new(1., 1., 0.), DVec3::Y],
        Some(vec![1., h, 1.]),
    )
    .unwrap();
    // At u = 1/2 the point is (1/sqrt2, 1/sqrt2).
    assert_near!(c.point(0.5).to_array(), [h, h, 0.0], EXACT_EPS);
}

#[test]
fn surface_derivatives_match_finite_differences() {
    let s = wavy_bicubic();
    let h = FD_STEP;
    for &(u, v) in &[
        (0.1, 0.2),
        (0.45, 0.7),
        (0.3, 0.3),
        (0.95, 0.05),
        (0.61, 0.59),
    ] {
        let d = s.derivatives(u, v);
        let scale = 1.0 + d.du.length().max(d.dv.length());
        let fu = (s.point(u + h, v) - s.point(u - h, v)) / (2.0 * h);
        let fv = (s.point(u, v + h) - s.point(u, v - h)) / (2.0 * h);
        assert_near!(d.du.to_array(), fu.to_array(), FD_EPS * scale);
        assert_near!(d.dv.to_array(), fv.to_array(), FD_EPS * scale);
        let fuu = (s.derivatives(u + h, v).du - s.derivatives(u - h, v).du) / (2.0 * h);
        let fuv = (s.derivatives(u, v + h).du - s.derivatives(u, v - h).du) / (2.0 * h);
        let fvv = (s.derivatives(u, v + h).dv - s.derivatives(u, v - h).dv) / (2.0 * h);
        let scale2 = 1.0 + d.duu.length().max(d.dvv.length());
        assert_near!(d.duu.to_array(), fuu.to_array(), FD_EPS * scale2);
        assert_near!(d.duv.to_array(), fuv.to_array(), FD_EPS * scale2);
        assert_near!(d.dvv.to_array(), fvv.to_array(), FD_EPS * scale2);
        assert_near!(d.point.to_array(), s.point(u, v).to_array(), EXACT_EPS);
        let n = s.normal(u, v);
        assert_near!(n.length(), 1.0, EXACT_EPS);
        assert_near!(n.dot(d.du), 0.0, EXACT_EPS * scale);
    }
}

#[test]
fn bilinear_patch_is_exact() {
    let s = NurbsSurface::new(
        1,
        1,
        vec![0., 0., 2., 2.],
        vec![-1., -1., 1., 1.],
        vec![
            vec![DVec3::ZERO, DVec3::Y],
            vec![DVec3::X, DVec3::new(1., 1., 1.)],
        ],
        None,
    )
    .unwrap();
    assert_eq!(s.domain_u(), (0.0, 2.0));
    assert_eq!(s.domain_v(), (-1.0, 1.0));
    let p = s.point(1.0, 0.0);
    assert_near!(p.to_array(), [0.5, 0.5, 0.25], EXACT_EPS);
    let ff = s.fundamental_forms(1.0, 0.0);
    // z = xy has K = -1/(1+x^2+y^2)^2 at (x, y) = (1/2, 1/2).
    assert_near!(ff.gaussian_curvature(), -1.0 / 1.5f64.powi(2), EXACT_EPS);
}

#[test]
fn json_schema_round_trip_and_field_names() {
    let s = wavy_bicubic();
    let text = s.to_json();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "degree_u",
        "degree_v",
        "knots_u",
        "knots_v",
        "control_points",
        "weights",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["control_points"].as_array().unwrap().len(), 6);
    assert_eq!(v["control_points"][0][0].as_array().unwrap().len(), 3);
    let back = NurbsSurface::from_json(&text).unwrap();
    // Cartesian in, homogeneous inside: the round trip is exact to rounding.
    assert_eq!(back.knots_u(), s.knots_u());
    assert_eq!(back.weights(), s.weights());
    for (a, b) in back.homogeneous().iter().zip(s.homogeneous()) {
        assert_near!(a.to_array(), b.to_array(), EXACT_EPS);
    }
    // Weights are optional and default to 1.
    let plain = r#"{"degree_u":1,"degree_v":1,"knots_u":[0,0,1,1],"knots_v":[0,0,1,1],
        "control_points":[[[0,0,0],[0,1,0]],[[1,0,0],[1,1,0]]]}"#;
    let s = NurbsSurface::from_json(plain).unwrap();
    assert!(!s.is_rational());
    assert_near!(s.point(0.5, 0.5).to_array(), [0.5, 0.5, 0.0], EXACT_EPS);
    assert!(!s.to_json().contains("weights"));
}

/// Text that is not JSON or not the schema is `Error::Json` with a position; a
/// surface the schema allows but that is invalid is the typed error naming the entry.
#[test]
fn bad_json_gives_typed_errors() {
    let syntax_or_schema = [
        r#"{"degree_u":1,"degree_v":1,"knots_u":[0,0,1,1],"knots_v":[0,0,1,1],"control_points":[[[0,0,0],[0,1,0]],[[1,0,0],[1,1,0]]],"weight":[[1,1],[1,1]]}"#,
        r#"{"degree_u":1"#,
        "",
    ];
    for c in syntax_or_schema {
        assert!(
            matches!(NurbsSurface::from_json(c), Err(Error::Json(ref j)) if j.line() >= 1),
            "{c}"
        );
    }
    let ragged = r#"{"degree_u":1,"degree_v":1,"knots_u":[0,0,1,1],"knots_v":[0,0,1,1],"control_points":[[[0,0,0]],[[1,0,0],[1,1,0]]]}"#;
    assert!(matches!(
        NurbsSurface::from_json(ragged),
        Err(Error::InvalidControlNet(ControlNetError::RowLength {
            row: 0,
            got: 1,
            need: 2,
            ..
        }))
    ));
    let knots = r#"{"degree_u":1,"degree_v":1,"knots_u":[0,1,0,1],"knots_v":[0,0,1,1],"control_points":[[[0,0,0],[0,1,0]],[[1,0,0],[1,1,0]]]}"#;
    assert!(matches!(
        NurbsSurface::from_json(knots),
        Err(Error::InvalidKnots {
            direction: Some(Direction::U),
            reason: KnotError::Decreasing { index: 2, .. }
        })
    ));
    let weight = r#"{"degree_u":1,"degree_v":1,"knots_u":[0,0,1,1],"knots_v":[0,0,1,1],"control_points":[[[0,0,0],[0,1,0]],[[1,0,0],[1,1,0]]],"weights":[[1,1],[1,-1]]}"#;
    let e = NurbsSurface::from_json(weight).unwrap_err();
    assert!(
        matches!(
            e,
            Error::InvalidWeights(WeightError::NotPositive {
                at: NetIndex::Surface(1, 1),
                weight: -1.0
            })
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "invalid weights: control point [1][1]: weight -1 is not finite and positive"
    );
    let degree = r#"{"degree_u":0,"degree_v":1,"knots_u":[0,1],"knots_v":[0,0,1,1],"control_points":[[[0,0,0],[0,1,0]]]}"#;
    assert!(matches!(
        NurbsSurface::from_json(degree),
        Err(Error::InvalidDegree {
            direction: Some(Direction::U),
            degree: 0
        })
    ));
}

#[test]
fn parameters_outside_the_domain_are_clamped() {
    let s = wavy_bicubic();
    assert_eq!(s.point(-3.0, 0.5), s.point(0.0, 0.5));
    assert_eq!(s.point(0.5, 7.0), s.point(0.5, 1.0));
    assert_eq!(s.point_uv(DVec2::new(2.0, 2.0)), s.point(1.0, 1.0));
}

#[test]
fn unclamped_knots_evaluate_on_their_domain() {
    let kv = KnotVector::new(3, (0..10).map(f64::from).collect()).unwrap();
    assert_eq!(kv.domain(), (3.0, 6.0));
    let pts: Vec<DVec3> = (0..6)
        .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
        .collect();
    let c = NurbsCurve::new(3, (0..10).map(f64::from).collect(), pts, None).unwrap();
    // A uniform cubic B-spline reproduces x linearly: x(u) = u - 2 on [3, 6].
    for i in 0..=30 {
        let u = 3.0 + 3.0 * i as f64 / 30.0;
        assert_near!(c.point(u).x, u - 2.0, EXACT_EPS);
    }
}
