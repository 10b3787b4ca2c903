//! Unit tests of the stroke pipeline.

use super::polygon::clip_to_box;
use super::*;
use crate::assert_near;
use crate::sculpt::jordan::Location;
use crate::sculpt::jordan::signed_area;
use crate::sculpt::surface::test_surfaces::plane;
use crate::sculpt::surface::{ParamSurface, TargetSurface, wrap_uv};
use crate::tolerance::{
    AREA_SYMMETRY_EPS, EXACT_EPS, FOOTPRINT_AREA_TOL, POINT_EPS, SEAM_DEPTH_TOL,
};

fn tool() -> Tool {
    Tool {
        profile: Profile::V,
        width: 0.1,
        depth: 0.02,
        mode: Mode::Carve,
        taper: 0.0,
    }
}

/// Builds a stroke with the test tool and a snap distance of 0.1.
fn build(s: &TargetSurface, samples: Vec<(f64, DVec3)>) -> Stroke {
    Stroke::build(
        s,
        &StrokeInput {
            samples,
            tool: tool(),
        },
        0.1,
    )
    .unwrap()
}

fn line(a: DVec3, b: DVec3, n: usize) -> Vec<(f64, DVec3)> {
    (0..n)
        .map(|i| {
            let t = i as f64 / (n - 1) as f64;
            (t, a.lerp(b, t))
        })
        .collect()
}

#[test]
fn straight_groove_on_a_plane() {
    let s = plane(1.0);
    let input = StrokeInput {
        samples: line(DVec3::new(0.2, 0.5, 0.01), DVec3::new(0.8, 0.5, 0.01), 50),
        tool: tool(),
    };
    let st = Stroke::build(&s, &input, 0.1).unwrap();
    assert_near!(
        st.depth_at(DVec2::new(0.5, 0.5), DVec3::new(0.5, 0.5, 0.0)),
        0.02,
        POINT_EPS
    );
    assert_near!(
        st.depth_at(DVec2::new(0.5, 0.525), DVec3::new(0.5, 0.525, 0.0)),
        0.01,
        POINT_EPS
    );
    assert_eq!(
        st.depth_at(DVec2::new(0.5, 0.6), DVec3::new(0.5, 0.6, 0.0)),
        0.0
    );
    assert_eq!(st.footprint.locate(DVec2::new(0.5, 0.5)), Location::Inside);
    assert_eq!(
        st.footprint.locate(DVec2::new(0.5, 0.56)),
        Location::Outside
    );
    // Area of the footprint: 0.6 x 0.1 plus two half discs of radius 0.05.
    assert_near!(
        st.footprint.area(),
        0.06 + std::f64::consts::PI * 0.0025,
        FOOTPRINT_AREA_TOL
    );
}

#[test]
fn self_crossing_path_gives_a_simple_outline() {
    let s = plane(1.0);
    let samples: Vec<(f64, DVec3)> = (0..200)
        .map(|i| {
            let a = i as f64 / 199.0 * 1.8 * std::f64::consts::TAU;
            (
                i as f64,
                DVec3::new(0.5 + 0.2 * a.cos(), 0.5 + 0.2 * a.sin(), 0.0),
            )
        })
        .collect();
    let st = build(&s, samples);
    // A loop: an outer outline and a hole; the hole's centre is outside.
    assert_eq!(st.footprint.contours().len(), 2);
    assert_eq!(st.footprint.locate(DVec2::splat(0.5)), Location::Outside);
    assert_eq!(st.footprint.locate(DVec2::new(0.7, 0.5)), Location::Inside);
}

#[test]
fn bad_strokes_are_rejected_with_reasons() {
    let s = plane(1.0);
    let mut samples = line(DVec3::new(0.2, 0.5, 0.0), DVec3::new(0.8, 0.5, 0.0), 5);
    samples[2].1.x = f64::NAN;
    let err = Stroke::build(
        &s,
        &StrokeInput {
            samples,
            tool: tool(),
        },
        0.1,
    )
    .unwrap_err();
    assert!(err.to_string().contains("not finite"), "{err}");
    let zero = vec![(0.0, DVec3::splat(0.5)); 10];
    let err = Stroke::build(
        &s,
        &StrokeInput {
            samples: zero,
            tool: tool(),
        },
        0.1,
    )
    .unwrap_err();
    assert!(err.to_string().contains("zero length"), "{err}");
    let off = line(DVec3::new(0.2, 0.5, 3.0), DVec3::new(0.8, 0.5, 3.0), 10);
    let err = Stroke::build(
        &s,
        &StrokeInput {
            samples: off,
            tool: tool(),
        },
        0.1,
    )
    .unwrap_err();
    assert!(err.to_string().contains("does not lie"), "{err}");
    let mut wide = tool();
    wide.width = 5.0;
    let ok = line(DVec3::new(0.2, 0.5, 0.0), DVec3::new(0.8, 0.5, 0.0), 10);
    let err = Stroke::build(
        &s,
        &StrokeInput {
            samples: ok,
            tool: wide,
        },
        0.1,
    )
    .unwrap_err();
    assert!(err.to_string().contains("larger than the surface"), "{err}");
}

#[test]
fn stroke_off_the_edge_is_clipped_to_the_domain() {
    let s = plane(1.0);
    let input = StrokeInput {
        samples: line(DVec3::new(0.5, 0.5, 0.0), DVec3::new(1.3, 0.5, 0.0), 50),
        tool: tool(),
    };
    let st = Stroke::build(&s, &input, 0.1).unwrap();
    assert!(st.bounds.max.x <= 1.0 && st.bounds.min.x >= 0.0);
    assert!(st.centre_uv.iter().all(|c| c.x <= 1.0));
}

/// Along the equator of the unit sphere from `from` to `to` degrees (the seam
/// u = 0 = 1 of the test sphere is at 180 degrees, u growing with the angle), one
/// sample per degree.
fn equator(from: f64, to: f64) -> Vec<(f64, DVec3)> {
    let n = (to - from).round() as usize + 1;
    (0..n)
        .map(|k| {
            let a = (from + k as f64).to_radians();
            (k as f64, DVec3::new(a.cos(), a.sin(), 0.0))
        })
        .collect()
}

#[test]
fn stroke_across_the_seam_of_a_sphere_wraps() {
    use crate::sculpt::surface::test_surfaces::sphere;
    let s = sphere(1.0);
    let st = build(&s, equator(150.0, 205.0));
    // One run, unwrapped: u continues past 1 instead of jumping back to 0.
    assert!(
        st.centre_uv
            .windows(2)
            .all(|w| (w[1] - w[0]).length() < 0.01)
    );
    let (first, last) = (st.centre_uv[0], st.centre_uv[st.centre_uv.len() - 1]);
    assert!(first.x < 1.0 && first.x > 0.9, "{first:?}");
    assert!(last.x > 1.0 && last.x < 1.1, "{last:?}");
    // On the equator, where the samples are (the ends are exact resampled points).
    let at = |deg: f64| {
        let a = f64::to_radians(deg);
        [a.cos(), a.sin(), 0.0]
    };
    assert_near!(s.eval(wrap_uv(first)).p.to_array(), at(150.0), POINT_EPS);
    assert_near!(s.eval(wrap_uv(last)).p.to_array(), at(205.0), POINT_EPS);
    // The footprint in the square covers both sides of the seam.
    for u in [0.002, 0.05, 0.95, 0.998] {
        assert_eq!(
            st.footprint.locate(DVec2::new(u, 0.5)),
            Location::Inside,
            "{u}"
        );
    }
    assert!(
        st.footprint
            .contours()
            .iter()
            .flatten()
            .all(|p| (0.0..=1.0).contains(&p.x))
    );
    // Same area as the stroke turned half-way round, away from the seam (the
    // sphere's four quarter arcs have the same parametrisation).
    let away = build(&s, equator(-30.0, 25.0));
    assert_near!(
        st.footprint.area(),
        away.footprint.area(),
        AREA_SYMMETRY_EPS
    );
    // Full depth on the centreline either side of the seam, from either copy (the
    // depth is measured from the centreline's chords: their sag, spacing^2 / 8R, is
    // under 1e-4 m).
    for u in [0.999, 0.001, 1.001, -0.001] {
        let uv = DVec2::new(u, 0.5);
        assert_near!(
            st.depth_at(uv, s.eval(wrap_uv(uv)).p),
            0.02,
            SEAM_DEPTH_TOL,
            "{u}"
        );
    }
}

#[test]
fn a_stroke_back_at_its_start_is_an_untapered_loop() {
    let s = plane(1.0);
    let circle = |turns: f64| -> Vec<(f64, DVec3)> {
        (0..=100)
            .map(|i| {
                let a = i as f64 / 100.0 * turns * std::f64::consts::TAU;
                (
                    i as f64,
                    DVec3::new(0.5 + 0.2 * a.cos(), 0.5 + 0.2 * a.sin(), 0.0),
                )
            })
            .collect()
    };
    let mut tapered = tool();
    tapered.taper = 0.1;
    let input = |samples| StrokeInput {
        samples,
        tool: tapered.clone(),
    };
    let round = Stroke::build(&s, &input(circle(1.0)), 0.1).unwrap();
    assert!(round.is_loop());
    assert!(round.depth.iter().all(|&d| d == 0.02));
    // Full depth at the join (the start, at angle 0).
    let join = DVec2::new(0.7, 0.5);
    assert_near!(round.depth_at(join, join.extend(0.0)), 0.02, POINT_EPS);
    // Three quarters of a turn is no loop: its ends taper.
    let open = Stroke::build(&s, &input(circle(0.75)), 0.1).unwrap();
    assert!(!open.is_loop());
    assert_eq!(open.depth[0], 0.0);
}

#[test]
fn wrapped_centre_segments_split_exactly_on_the_seam() {
    let line = [
        DVec2::new(0.9, 0.95),
        DVec2::new(1.1, 1.05),
        DVec2::new(1.1, 1.05),
        DVec2::new(1.3, 1.2),
    ];
    let segs = wrapped_segments(&line, [true, true]);
    // Cut at u = 1 and at v = 1 (both at t = 0.5 here: one corner point), then
    // shifted into the square; the repeated point gives no segment.
    assert_eq!(segs.len(), 3, "{segs:?}");
    assert_eq!(segs[0], [DVec2::new(0.9, 0.95), DVec2::new(1.0, 1.0)]);
    assert_eq!(segs[1][0], DVec2::new(0.0, 0.0));
    assert!(
        segs.iter()
            .flatten()
            .all(|p| (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y))
    );
    // Open directions are left alone.
    let open = wrapped_segments(&line[..2], [false, false]);
    assert_eq!(open, vec![[line[0], line[1]]]);
}

#[test]
fn clip_to_box_keeps_the_part_inside() {
    let tri = [
        DVec2::new(-2.0, 0.0),
        DVec2::new(1.0, 0.0),
        DVec2::new(1.0, 1.0),
    ];
    let c = clip_to_box(&tri, DVec2::splat(-1.0), DVec2::splat(2.0));
    assert!(c.iter().all(|p| p.x >= -1.0));
    // The triangle's area right of x = -1: the integral of (x + 2) / 3 over [-1, 1].
    assert_near!(signed_area(&c).abs(), 4.0 / 3.0, EXACT_EPS);
}

#[test]
fn resampling_keeps_corners() {
    let pts = vec![
        DVec3::ZERO,
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
    ];
    let out = resample(&pts, 0.05);
    assert!(
        out.iter()
            .any(|p| p.distance(DVec3::new(1.0, 0.0, 0.0)) < EXACT_EPS)
    );
    for w in out.windows(2) {
        assert!(w[0].distance(w[1]) <= 0.05 + POINT_EPS);
    }
}

/// A stroke lifted off the surface part-way is carved on both sides of the gap: two
/// pieces of one stroke, each tapered at its own ends; `Stroke::build`, which must
/// give one piece, refuses it.
#[test]
fn a_stroke_lifted_off_mid_way_is_carved_in_two_pieces() {
    let s = plane(1.0);
    let samples: Vec<(f64, DVec3)> = line(DVec3::new(0.1, 0.5, 0.0), DVec3::new(0.9, 0.5, 0.0), 81)
        .into_iter()
        .map(|(t, p)| {
            let lift = if (0.45..=0.55).contains(&p.x) {
                0.5
            } else {
                0.0
            };
            (t, p + DVec3::Z * lift)
        })
        .collect();
    let input = StrokeInput {
        samples,
        tool: tool(),
    };
    let built = StrokePieces::build(&s, &input, 0.1).unwrap();
    assert_eq!(built.pieces.len(), 2);
    assert_eq!(built.dropped, 0);
    for (piece, x) in built.pieces.iter().zip([0.25, 0.75]) {
        let uv = DVec2::new(x, 0.5);
        assert_near!(piece.depth_at(uv, uv.extend(0.0)), 0.02, POINT_EPS);
    }
    // Nothing under the gap.
    let gap = DVec2::new(0.5, 0.5);
    assert!(
        built
            .pieces
            .iter()
            .all(|p| p.depth_at(gap, gap.extend(0.0)) == 0.0)
    );
    let b = built.bounds();
    assert!(b.min.x < 0.15 && b.max.x > 0.85, "{b:?}");
    let err = Stroke::build(&s, &input, 0.1).unwrap_err();
    assert!(err.to_string().contains("2 pieces"), "{err}");
}

/// A lone on-surface foot between two gaps is too short to carve: dropped and
/// counted, the rest carved. The path runs flat on the plane, up and down two 45 degree
/// ridges (touching the plane once, at x = 0.5, between them) and flat again; with a
/// snap of 5 mm only the touching corner of the ridges is on the surface.
#[test]
fn a_lone_foot_between_gaps_is_dropped_and_counted() {
    let s = plane(1.0);
    let ridge = |x: f64| {
        (0.15 - (x - 0.35).abs())
            .max(0.0)
            .max(0.15 - (x - 0.65).abs())
    };
    let samples: Vec<(f64, DVec3)> =
        line(DVec3::new(0.1, 0.5, 0.0), DVec3::new(0.9, 0.5, 0.0), 161)
            .into_iter()
            .map(|(t, p)| (t, p + DVec3::Z * ridge(p.x)))
            .collect();
    let built = StrokePieces::build(
        &s,
        &StrokeInput {
            samples,
            tool: tool(),
        },
        0.005,
    )
    .unwrap();
    assert_eq!(built.pieces.len(), 2);
    assert_eq!(built.dropped, 1);
}
