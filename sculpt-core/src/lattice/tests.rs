use super::*;
use crate::assert_near;
use crate::editor::default_surface;
use crate::nurbs::refine::Direction;
use crate::tolerance::{EXACT_EPS, LATTICE_BEND_MAX_REL, POINT_EPS};
use proptest::prelude::*;

fn sheet_lattice(spec: LatticeSpec) -> (NurbsSurface, Lattice) {
    let sheet = default_surface();
    let lattice = Lattice::around(spec, &[&sheet]).unwrap();
    (sheet, lattice)
}

/// The test bend of `docs/lattice.md`: the default sheet in a 4 x 4 x 4 tricubic
/// lattice, the control points within 0.3 m of the middle of the cage's top front
/// edge pulled 0.1 m towards the viewer.
pub(super) fn test_bend(lattice: &mut Lattice) -> DVec3 {
    let (lo, hi) = lattice.bounds();
    let grab = DVec3::new(0.5 * (lo.x + hi.x), hi.y, hi.z);
    let group = lattice.group(grab, 0.3).unwrap();
    let d = DVec3::new(0.0, 0.0, 0.1);
    lattice.displace(&group, d).unwrap();
    d
}

#[test]
fn greville_points_of_a_bezier_lattice_are_the_thirds_of_the_box() {
    let l = Lattice::fit(
        LatticeSpec::default(),
        DVec3::ZERO,
        DVec3::new(3.0, 6.0, 9.0),
    )
    .unwrap();
    assert_near!(
        l.rest_point(l.flat([1, 2, 3])),
        DVec3::new(1.0, 4.0, 9.0),
        EXACT_EPS
    );
    assert_eq!(l.control_points().len(), 64);
    // 3 directions x 4 x 4 lines of 3 segments.
    assert_eq!(l.cage_edges().len(), 3 * 16 * 3);
}

#[test]
fn a_lattice_at_rest_maps_every_point_to_itself_exactly() {
    for spec in [
        LatticeSpec::default(),
        LatticeSpec {
            degree: [2, 1, 3],
            counts: [5, 2, 7],
        },
    ] {
        let (sheet, l) = sheet_lattice(spec);
        assert!(l.at_rest());
        for a in 0..=10 {
            for b in 0..=10 {
                let p = sheet.point(a as f64 / 10.0, b as f64 / 10.0);
                assert_near!(l.map_point(p), p, 0.0);
            }
        }
        assert_eq!(l.deform_surface(&sheet).unwrap(), sheet);
    }
}

#[test]
fn moving_a_group_and_back_restores_the_identity() {
    let (sheet, mut l) = sheet_lattice(LatticeSpec::default());
    let group = l.group(l.rest_point(0), 0.01).unwrap();
    assert_eq!(group, vec![0]);
    l.displace(&group, DVec3::X).unwrap();
    assert!(!l.at_rest());
    assert_near!(l.control_points()[0], l.rest_point(0) + DVec3::X, EXACT_EPS);
    l.displace(&group, -DVec3::X).unwrap();
    assert!(l.at_rest());
    assert_eq!(l.deform_surface(&sheet).unwrap(), sheet);
}

/// With every control point moved by the same vector, the map is a translation
/// (partition of unity, P&T property P2.4): an exact check of the displacement volume.
#[test]
fn moving_every_point_translates_the_surface() {
    let (sheet, mut l) = sheet_lattice(LatticeSpec::default());
    let all: Vec<usize> = (0..64).collect();
    let d = DVec3::new(0.1, -0.2, 0.3);
    l.displace(&all, d).unwrap();
    let moved = l.deform_surface(&sheet).unwrap();
    for (a, b) in [(0.0, 0.0), (0.3, 0.8), (1.0, 1.0)] {
        assert_near!(moved.point(a, b), sheet.point(a, b) + d, POINT_EPS);
    }
}

/// The map is the volume of the moved control points (linear precision): evaluated
/// independently here as a 64-point Bézier volume of the moved positions.
#[test]
fn the_map_is_the_volume_of_the_moved_control_points() {
    let (_, mut l) = sheet_lattice(LatticeSpec::default());
    test_bend(&mut l);
    let points = l.control_points();
    let values: Vec<f64> = points.iter().flat_map(|p| p.to_array()).collect();
    let k = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let vol = Volume::new(
        vec![3, 3, 3],
        vec![k.clone(), k.clone(), k],
        ["x", "y", "z"].map(String::from).to_vec(),
        values,
        None,
    )
    .unwrap();
    let (lo, hi) = l.bounds();
    for s in [[0.1, 0.2, 0.3], [0.5, 0.5, 0.5], [0.9, 0.7, 0.05]] {
        let p = lo + DVec3::from_array(s) * (hi - lo);
        let expect = DVec3::from_slice(&vol.point(&s).unwrap());
        assert_near!(l.map_point(p), expect, POINT_EPS);
    }
}

#[test]
fn a_bend_moves_the_surface_and_stays_close_to_the_exact_composition() {
    let (sheet, mut l) = sheet_lattice(LatticeSpec::default());
    let d = test_bend(&mut l);
    let bent = l.deform_surface(&sheet).unwrap();
    // The top edge comes forward; the bottom edge (still inside every basis
    // function's support in a Bézier lattice, but with little weight) much less.
    let top = bent.point(0.5, 1.0).z - sheet.point(0.5, 1.0).z;
    let bottom = bent.point(0.5, 0.0).z - sheet.point(0.5, 0.0).z;
    assert!(
        top > 0.15 * d.z && bottom < 0.1 * top,
        "top {top}, bottom {bottom}"
    );
    let err = composition_error(&l, &sheet, &bent, 41);
    assert!(err.max_m > 0.0, "mapping control points is not exact");
    assert!(
        err.max_m < LATTICE_BEND_MAX_REL * d.length(),
        "max {} m for a {} m pull",
        err.max_m,
        d.length()
    );
}

/// Knot refinement (P&T A5.4) leaves the surface as it is but gives the lattice more
/// control points to map: the composition error shrinks. The figures of
/// `docs/lattice.md` (run with `--nocapture` to print them).
#[test]
fn refining_the_target_shrinks_the_composition_error() {
    let (sheet, mut l) = sheet_lattice(LatticeSpec::default());
    test_bend(&mut l);
    let mut last = f64::INFINITY;
    for spans in [1usize, 2, 4, 8, 16] {
        let x: Vec<f64> = (1..spans).map(|i| i as f64 / spans as f64).collect();
        let refined = sheet
            .refine_knots(Direction::U, &x)
            .and_then(|s| s.refine_knots(Direction::V, &x))
            .unwrap();
        let err = composition_error(&l, &refined, &l.deform_surface(&refined).unwrap(), 101);
        println!(
            "lattice composition error, {spans}x{spans} spans ({}x{} control points): max {:.3} mm, mean {:.3} mm",
            refined.count_u(),
            refined.count_v(),
            err.max_m * 1000.0,
            err.mean_m * 1000.0
        );
        assert!(err.max_m < last, "{spans} spans: {} >= {last}", err.max_m);
        last = err.max_m;
    }
}

#[test]
fn rational_targets_keep_their_weights() {
    let sphere = NurbsSurface::sphere(DVec3::new(0.0, 1.0, 0.0), 0.2).unwrap();
    let mut l = Lattice::around(LatticeSpec::default(), &[&sphere]).unwrap();
    let (_, hi) = l.bounds();
    let group = l.group(hi, 0.2).unwrap();
    l.displace(&group, DVec3::splat(0.05)).unwrap();
    let out = l.deform_surface(&sphere).unwrap();
    assert_eq!(out.weights(), sphere.weights());
    assert_ne!(out.control_points(), sphere.control_points());
}

#[test]
fn bad_lattices_and_grabs_are_refused_with_their_reason() {
    let bad = |degree, counts| LatticeSpec { degree, counts }.validate().unwrap_err();
    assert!(matches!(
        bad([3, 3, 3], [4, 1, 4]),
        LatticeError::Count { direction: 1, .. }
    ));
    assert!(matches!(
        bad([3, 3, 4], [4, 4, 4]),
        LatticeError::Degree { direction: 2, .. }
    ));
    assert!(matches!(
        bad([0, 3, 3], [4, 4, 4]),
        LatticeError::Degree { direction: 0, .. }
    ));
    assert!(matches!(
        bad([3, 3, 3], [17, 4, 4]),
        LatticeError::Count { .. }
    ));
    let (_, mut l) = sheet_lattice(LatticeSpec::default());
    let far = l.group(DVec3::new(0.0, 50.0, 0.0), 0.01).unwrap_err();
    assert!(matches!(far, LatticeError::NothingGrabbed { nearest_m, .. } if nearest_m > 40.0));
    assert!(l.group(DVec3::NAN, 0.1).is_err());
    assert!(l.group(DVec3::ZERO, -1.0).is_err());
    assert!(l.displace(&[64], DVec3::X).is_err());
    assert!(l.displace(&[0], DVec3::splat(f64::INFINITY)).is_err());
    assert!(l.displace(&[0], DVec3::splat(1000.0)).is_err());
    assert!(Lattice::around(LatticeSpec::default(), &[]).is_err());
    assert!(
        Lattice::fit(
            LatticeSpec::default(),
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 1.0)
        )
        .is_err()
    );
}

fn edit() -> DeformEdit {
    DeformEdit {
        targets: vec![1],
        lattice: LatticeSpec::default(),
        grab: DVec3::new(0.0, 1.4, 0.0),
        radius: 0.05,
        displacement: DVec3::new(0.0, 0.0, 0.08),
    }
}

#[test]
fn deform_records_round_trip_and_bad_ones_say_why() {
    let e = edit();
    let text = serde_json::to_string(&e).unwrap();
    assert_eq!(serde_json::from_str::<DeformEdit>(&text).unwrap(), e);
    // The lattice may be left out: the default.
    let short = r#"{"targets":[1],"grab":[0,1.4,0],"radius":0.05,"displacement":[0,0,0.08]}"#;
    assert_eq!(serde_json::from_str::<DeformEdit>(short).unwrap(), e);
    for (bad, why) in [
        (
            r#"{"targets":[],"grab":[0,0,0],"radius":0.05,"displacement":[0,0,0]}"#,
            "at least one target",
        ),
        (
            r#"{"targets":[1,1],"grab":[0,0,0],"radius":0.05,"displacement":[0,0,0]}"#,
            "named twice",
        ),
        (
            r#"{"targets":[1],"grab":[0,0,0],"radius":-1,"displacement":[0,0,0]}"#,
            "radius",
        ),
        (
            r#"{"targets":[1],"grab":[0,0,0],"radius":1,"displacement":[0,0,1000]}"#,
            "displacement",
        ),
        (
            r#"{"targets":[1],"lattice":{"degree":[3,3,3],"counts":[4,4,40]},"grab":[0,0,0],"radius":1,"displacement":[0,0,0]}"#,
            "control points",
        ),
        (
            r#"{"targets":[1],"grab":[0,0,0],"radius":1,"displacement":[0,0,0],"extra":1}"#,
            "unknown field",
        ),
    ] {
        let err = serde_json::from_str::<DeformEdit>(bad)
            .unwrap_err()
            .to_string();
        assert!(err.contains(why), "{bad}: {err}");
    }
}

proptest! {
    /// The record parser never panics on arbitrary text, and whatever it accepts is
    /// valid and writes back to the same edit.
    #[test]
    fn the_deform_parser_never_panics_and_accepts_only_valid_edits(text in ".{0,200}") {
        if let Ok(e) = serde_json::from_str::<DeformEdit>(&text) {
            prop_assert!(e.validate().is_ok());
        }
    }

    /// Valid edits round-trip exactly; out-of-range fields are refused, never clamped.
    #[test]
    fn deform_records_round_trip(
        targets in proptest::collection::btree_set(1u64..1000, 1..5),
        c in proptest::array::uniform3(2usize..=MAX_COUNT),
        p in proptest::array::uniform3(1usize..=MAX_DEGREE),
        grab in proptest::array::uniform3(-5.0f64..5.0),
        radius in -1.0f64..200.0,
        d in proptest::array::uniform3(-80.0f64..80.0),
    ) {
        let e = DeformEdit {
            targets: targets.into_iter().collect(),
            lattice: LatticeSpec { degree: p, counts: c },
            grab: DVec3::from_array(grab),
            radius,
            displacement: DVec3::from_array(d),
        };
        let text = serde_json::to_string(&e).unwrap();
        match serde_json::from_str::<DeformEdit>(&text) {
            Ok(back) => {
                prop_assert!(e.validate().is_ok());
                prop_assert_eq!(back, e);
            }
            Err(_) => prop_assert!(e.validate().is_err()),
        }
    }
}
