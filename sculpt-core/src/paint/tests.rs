use super::*;
use crate::editor::{DEFAULT_SURFACE_CENTER, default_surface, default_surface_point};
use crate::tolerance::{PAINT_VALUE_TOL, POINT_EPS};
use proptest::prelude::*;

fn sheet() -> (crate::nurbs::NurbsSurface, TargetSurface) {
    let s = default_surface();
    let t = TargetSurface::new(&s);
    (s, t)
}

/// A wand path hovering 5 mm over the sheet along x at height `y`, from `x0` to `x1`.
fn path_over(y: f64, x0: f64, x1: f64) -> Vec<DVec3> {
    (0..=40)
        .map(|i| {
            let x = x0 + (x1 - x0) * i as f64 / 40.0;
            default_surface_point(x, y) + DVec3::Z * 0.005
        })
        .collect()
}

#[test]
fn deposits_lie_on_the_target_within_the_brush() {
    let (_, t) = sheet();
    let c = DEFAULT_SURFACE_CENTER;
    let path = path_over(c.y, c.x - 0.2, c.x + 0.2);
    let radius = 0.03;
    let d = deposit(&t, &path, radius);
    assert!(d.len() > 2 * RING_POINTS, "{} deposits", d.len());
    for p in &d {
        // On the sheet: z is the sheet's at (x, y).
        let on = default_surface_point(p.x, p.y);
        crate::assert_near!(p.z, on.z, POINT_EPS);
        // Within the brush of the path (plus the surface's curvature).
        let gap = path
            .iter()
            .map(|q| q.distance(*p))
            .fold(f64::INFINITY, f64::min);
        assert!(gap <= radius + 0.01, "deposit {p} is {gap} m from the path");
    }
}

#[test]
fn a_wand_beyond_the_brush_radius_deposits_nothing() {
    let (_, t) = sheet();
    let c = DEFAULT_SURFACE_CENTER;
    let far: Vec<DVec3> = path_over(c.y, c.x - 0.1, c.x + 0.1)
        .into_iter()
        .map(|p| p + DVec3::Z * 0.2)
        .collect();
    assert!(deposit(&t, &far, 0.03).is_empty());
}

#[test]
fn a_painted_stripe_is_its_colour_and_the_rest_is_unpainted() {
    let (s, t) = sheet();
    let c = DEFAULT_SURFACE_CENTER;
    let field = AttributeField::around(COLOUR, 3, &s, &t).unwrap();
    let d = deposit(&t, &path_over(c.y, c.x - 0.3, c.x + 0.3), 0.04);
    let red = field.painted(&d, &[0.9, 0.1, 0.2], 0.04).unwrap();
    let on_stripe = default_surface_point(c.x, c.y);
    let (v, a) = red.eval(on_stripe);
    assert!(a > 1.0 - PAINT_VALUE_TOL, "coverage {a}");
    crate::assert_near!(v, vec![0.9, 0.1, 0.2], PAINT_VALUE_TOL);
    let away = default_surface_point(c.x + 0.4, c.y + 0.25);
    assert!(red.eval(away).1 < PAINT_VALUE_TOL, "{:?}", red.eval(away));
    // Blended over grey: the stripe is red, the corner grey.
    let grey = [0.5f32; 3];
    let over = red.colour_over(on_stripe, grey);
    assert!(over[0] > 0.8 && over[1] < 0.2, "{over:?}");
    let corner = red.colour_over(away, grey);
    crate::assert_near!(f64::from(corner[0]), 0.5, PAINT_VALUE_TOL);
}

#[test]
fn painting_over_a_spot_replaces_its_colour() {
    let (s, t) = sheet();
    let c = DEFAULT_SURFACE_CENTER;
    let d = deposit(&t, &path_over(c.y, c.x - 0.2, c.x + 0.2), 0.04);
    let field = AttributeField::around(COLOUR, 3, &s, &t).unwrap();
    let red = field.painted(&d, &[1.0, 0.0, 0.0], 0.04).unwrap();
    let blue = red.painted(&d, &[0.0, 0.0, 1.0], 0.04).unwrap();
    // Every red sample was replaced by a blue one.
    assert_eq!(blue.sample_count(), d.len());
    let (v, _) = blue.eval(default_surface_point(c.x, c.y));
    crate::assert_near!(v, vec![0.0, 0.0, 1.0], PAINT_VALUE_TOL);
}

#[test]
fn a_scalar_attribute_carries_its_value() {
    let (s, t) = sheet();
    let c = DEFAULT_SURFACE_CENTER;
    let d = deposit(&t, &path_over(c.y - 0.1, c.x - 0.2, c.x + 0.2), 0.05);
    let density = AttributeField::around("density", 1, &s, &t)
        .unwrap()
        .painted(&d, &[250.0], 0.05)
        .unwrap();
    let (v, a) = density.eval(default_surface_point(c.x, c.y - 0.1));
    assert!(a > 1.0 - PAINT_VALUE_TOL);
    crate::assert_near!(v[0], 250.0, 250.0 * PAINT_VALUE_TOL);
    assert_eq!(density.volume().unwrap().components(), 2);
}

#[test]
fn heat_runs_blue_to_red() {
    assert_eq!(heat(0.0), [0.0, 0.0, 1.0]);
    assert_eq!(heat(0.5), [0.0, 1.0, 0.0]);
    assert_eq!(heat(1.0), [1.0, 0.0, 0.0]);
    assert_eq!(heat(f64::NAN), [0.0, 0.0, 1.0]);
}

fn edit() -> PaintEdit {
    PaintEdit {
        target: 1,
        attribute: COLOUR.into(),
        value: vec![1.0, 0.5, 0.0],
        radius: 0.03,
        samples: vec![DVec3::ZERO, DVec3::X],
    }
}

#[test]
fn bad_edits_are_refused_with_their_reason() {
    assert_eq!(edit().validate(), Ok(()));
    let mut e = edit();
    e.attribute = "Density!".into();
    assert!(matches!(e.validate(), Err(PaintError::Name { .. })));
    let mut e = edit();
    e.value = vec![1.0];
    assert!(matches!(
        e.validate(),
        Err(PaintError::ValueCount { need: 3, .. })
    ));
    let mut e = edit();
    e.value = vec![1.0, 2.0, 0.0];
    assert!(matches!(e.validate(), Err(PaintError::ValueRange { .. })));
    let mut e = edit();
    e.radius = 0.0;
    assert!(matches!(e.validate(), Err(PaintError::Radius { .. })));
    let mut e = edit();
    e.samples.clear();
    assert_eq!(e.validate(), Err(PaintError::NoSamples));
    let mut e = edit();
    e.samples.push(DVec3::NAN);
    assert!(matches!(e.validate(), Err(PaintError::NotFinite { .. })));
    let mut e = edit();
    e.attribute = "density".into();
    e.value = vec![-3.0];
    assert_eq!(e.validate(), Ok(()));
}

#[test]
fn a_paint_edit_round_trips_through_json() {
    let e = edit();
    let text = serde_json::to_string(&e).unwrap();
    let back: PaintEdit = serde_json::from_str(&text).unwrap();
    assert_eq!(back, e);
}

proptest! {
    /// The journal reader: any JSON text gives an edit or an error, never a panic,
    /// and a parsed edit either validates or says why.
    #[test]
    fn parsing_any_text_never_panics(text in ".{0,200}") {
        if let Ok(e) = serde_json::from_str::<PaintEdit>(&text) {
            let _ = e.validate();
        }
    }

    #[test]
    fn random_edits_validate_or_are_refused(
        radius in -1.0f64..2.0,
        v in proptest::collection::vec(-2.0f64..2.0, 0..5),
        n in 0usize..4,
        name in "[a-zA-Z_!]{0,40}",
    ) {
        let e = PaintEdit {
            target: 1,
            attribute: name.clone(),
            value: v.clone(),
            radius,
            samples: vec![DVec3::ONE; n],
        };
        let ok = e.validate().is_ok();
        let expect = check_name(&name).is_ok()
            && v.len() == components_of(&name)
            && (name != COLOUR || v.iter().all(|x| (0.0..=1.0).contains(x)))
            && radius > 0.0 && radius <= MAX_BRUSH_RADIUS_M
            && n > 0;
        prop_assert_eq!(ok, expect);
    }
}

/// Two strokes across the sheet (the paint bench's), each refitted locally, and a
/// third along x from `x0` to `x1` at y 1.17, refitted locally and whole (the
/// reference). Returns the field before the third, after it (local), after it
/// (whole), its deposits and the brush radius.
fn third_stroke_local_and_whole(
    x0: f64,
    x1: f64,
) -> (
    AttributeField,
    AttributeField,
    AttributeField,
    Vec<DVec3>,
    f64,
) {
    let (s, t) = sheet();
    let radius = Brush::default().radius;
    let sweep = |y: f64, x0: f64, x1: f64| deposit(&t, &path_over(y, x0, x1), radius);
    let mut field = AttributeField::around(COLOUR, 3, &s, &t).unwrap();
    for (y, colour) in [(1.1, [0.8, 0.3, 0.15]), (1.24, [0.2, 0.4, 0.9])] {
        field = field
            .painted(&sweep(y, -0.35, 0.35), &colour, radius)
            .unwrap();
    }
    let third = sweep(1.17, x0, x1);
    let value = [0.1, 0.8, 0.2];
    let local = field.painted(&third, &value, radius).unwrap();
    let whole = field.painted_whole(&third, &value, radius).unwrap();
    (field, local, whole, third, radius)
}

/// The largest difference of value or coverage between two fields at `points`.
fn worst_difference(a: &AttributeField, b: &AttributeField, points: &[DVec3]) -> f64 {
    let mut worst: f64 = 0.0;
    for p in points {
        let (va, aa) = a.eval(*p);
        let (vb, ab) = b.eval(*p);
        worst = worst.max((aa - ab).abs());
        for (x, y) in va.iter().zip(&vb) {
            worst = worst.max((x - y).abs());
        }
    }
    worst
}

#[test]
fn a_local_refit_agrees_with_the_whole_refit_at_the_samples() {
    let (s, t) = sheet();
    let radius = Brush::default().radius;
    let mut field = AttributeField::around(COLOUR, 3, &s, &t).unwrap();
    // The paint bench's three strokes, each refitted locally and compared, at its
    // samples, with the whole refit of the same samples (value and coverage).
    for (y, colour) in [
        (1.1, [0.8, 0.3, 0.15]),
        (1.24, [0.2, 0.4, 0.9]),
        (1.17, [0.1, 0.8, 0.2]),
    ] {
        let d = deposit(&t, &path_over(y, -0.35, 0.35), radius);
        field = field.painted(&d, &colour, radius).unwrap();
        let whole = field.refit_whole(radius).unwrap();
        let worst = worst_difference(&field, &whole, &d);
        assert!(
            worst <= crate::tolerance::PAINT_LOCAL_REFIT_AGREE,
            "stroke at y {y}: local vs whole refit at its samples: {worst}"
        );
        // And the painted colour is there.
        let (v, a) = field.eval(d[d.len() / 2]);
        assert!(a > 1.0 - PAINT_VALUE_TOL, "coverage {a}");
        crate::assert_near!(v, colour.to_vec(), PAINT_VALUE_TOL);
    }
}

#[test]
fn a_local_refit_keeps_the_field_far_from_the_stroke() {
    // A dab at the sheet's left edge.
    let (before, local, whole, third, radius) = third_stroke_local_and_whole(-0.45, -0.4);
    let worst = worst_difference(&local, &whole, &third);
    assert!(
        worst <= crate::tolerance::PAINT_LOCAL_REFIT_AGREE,
        "local vs whole refit at the dab's samples: {worst}"
    );
    // Beyond the brush, the free region's rings and a control point's support
    // (degree + 1 knot spans) from every sample the dab added or replaced, the field
    // is unchanged bit for bit; near it, it changed.
    let (lo, hi) = before.bounds();
    let spans = (hi - lo) / DVec3::from_array(before.counts.map(|c| (c - FIELD_DEGREE) as f64));
    let reach = DVec3::splat(radius) + (LOCAL_REFIT_RINGS + FIELD_DEGREE + 1) as f64 * spans;
    let changed: Vec<DVec3> = third
        .iter()
        .copied()
        .chain(
            before
                .samples
                .iter()
                .map(|(p, _)| *p)
                .filter(|p| third.iter().any(|q| q.distance(*p) < before.spacing())),
        )
        .collect();
    let (mut far, mut moved) = (0, 0);
    for i in 0..40 {
        for j in 0..40 {
            let x = -0.5 + i as f64 / 39.0;
            let y = 0.87 + 0.6 * j as f64 / 39.0;
            let p = default_surface_point(x, y);
            let beyond = changed
                .iter()
                .all(|q| ((p - *q).abs() - reach).max_element() > 0.0);
            let (b, l) = (before.eval(p), local.eval(p));
            if beyond {
                far += 1;
                assert_eq!(b, l, "changed far from the dab at {p}");
            } else if b != l {
                moved += 1;
            }
        }
    }
    assert!(far > 400 && moved > 50, "{far} far points, {moved} moved");
}

#[test]
fn the_local_refit_is_deterministic() {
    let (_, a, _, _, _) = third_stroke_local_and_whole(-0.35, 0.35);
    let (_, b, _, _, _) = third_stroke_local_and_whole(-0.35, 0.35);
    let bits = |f: &AttributeField| -> Vec<u64> {
        f.volume()
            .unwrap()
            .homogeneous()
            .iter()
            .map(|v| v.to_bits())
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
}
