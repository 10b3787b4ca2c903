//! Stroke samples land on their true closest points, checked against brute force.
//!
//! **Regression** (issue 14): strokes were projected by local Newton iteration seeded
//! from the previous sample (the removed `sculpt::surface::project_seeded`). Over a
//! finely waved sheet, a stroke hovering a few centimetres above it passes over valleys
//! whose far side is nearer: the true closest point jumps from one slope to the other,
//! but the seeded Newton run kept following the slope it started on (a local minimum
//! of the distance), silently, so the groove lay under samples it was not closest to.
//! Now every sample goes through the target's certified inverter, and the stroke is
//! split into runs at such basin jumps, each carved as a piece (see
//! `sculpt_core::sculpt::stroke`; `stroke_pieces.rs` checks that no part is lost). The
//! true closest points here come from a dense parameter grid refined locally, never
//! from the inverter.

use glam::DVec3;
use sculpt_core::assert_near;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, StrokePieces, Tool, resample};
use sculpt_core::sculpt::surface::TargetSurface;
use sculpt_core::tolerance::{
    BASIN_JUMP_RATIO, INVERSION_EPS, LOST_TRACK_EPS, STATIONARY_FOOT_EPS,
};

mod brute;

/// Waves across the sheet.
const WAVES: f64 = 14.0;
/// Wave amplitude, metres.
const AMPLITUDE: f64 = 0.01;

/// A 1 m square sheet, `z = AMPLITUDE sin(2 pi WAVES x)`: the bicubic interpolant of
/// 16 samples per wave along `x` (P&T A9.4).
fn waved_sheet() -> NurbsSurface {
    let (nx, ny) = (16 * WAVES as usize, 4);
    let grid: Vec<Vec<DVec3>> = (0..=nx)
        .map(|i| {
            (0..=ny)
                .map(|j| {
                    let (x, y) = (i as f64 / nx as f64, j as f64 / ny as f64);
                    let z = AMPLITUDE * (std::f64::consts::TAU * WAVES * x).sin();
                    DVec3::new(x, y, z)
                })
                .collect()
        })
        .collect();
    NurbsSurface::interpolate_grid(&grid, 3, 3)
        .expect("valid grid")
        .0
}

/// The true closest point of `s` to `p` by brute force ([`brute::closest_point`]) on a
/// 1401 x 9 grid (100 samples per wave), refined locally.
fn brute_force(s: &NurbsSurface, p: DVec3) -> (f64, DVec3) {
    let (d, uv) = brute::closest_point(s, p, (1400, 8));
    (d, s.point_uv(uv))
}

/// A stroke along `x` over the waves, hovering 2.5 to 4.5 cm above the sheet's mean
/// plane: every centreline point of every piece is the true closest point of its
/// sample, the feet never jump inside a piece, and the samples' true feet do jump (the
/// case the test is about).
#[test]
fn strokes_over_a_waved_sheet_follow_the_true_closest_points_and_split_at_basin_jumps() {
    let sheet = waved_sheet();
    let target = TargetSurface::new(&sheet);
    let tool = Tool {
        profile: Profile::V,
        width: 0.02,
        depth: 0.005,
        mode: Mode::Carve,
        taper: 0.0,
    };
    let raw: Vec<(f64, DVec3)> = (0..=200)
        .map(|k| {
            let t = k as f64 / 200.0;
            let height = 0.035 + 0.01 * (std::f64::consts::TAU * 1.5 * t).sin();
            (t, DVec3::new(0.1 + 0.8 * t, 0.5, height))
        })
        .collect();
    let input = StrokeInput {
        samples: raw.clone(),
        tool: tool.clone(),
    };
    let stroke = StrokePieces::build(&target, &input, 0.1).expect("a stroke");
    // The samples the stroke projected (the same resampling).
    let points: Vec<DVec3> = raw.iter().map(|s| s.1).collect();
    let samples = resample(&points, tool.width * 0.25);
    let truth: Vec<(f64, DVec3)> = samples.iter().map(|&p| brute_force(&sheet, p)).collect();
    let spacing = samples
        .windows(2)
        .map(|w| w[0].distance(w[1]))
        .fold(0.0, f64::max);
    // The true feet jump over valleys: feet of neighbouring samples far apart.
    let jumps = truth
        .windows(2)
        .filter(|w| w[0].1.distance(w[1].1) > BASIN_JUMP_RATIO * spacing)
        .count();
    assert!(jumps >= 5, "{jumps} basin jumps");
    let kept: usize = stroke.pieces.iter().map(|p| p.centre.len()).sum();
    println!(
        "{} samples, {jumps} basin jumps, {} pieces ({} dropped), {kept} samples kept",
        samples.len(),
        stroke.pieces.len(),
        stroke.dropped,
    );
    // The old projection, local Newton seeded from the previous foot (here the
    // inverter's local run), follows a slope past the jump: farther than the truth.
    let inverter = target.inverter();
    let mut seed = inverter.closest_point(samples[0]).uv_in_knots;
    let mut lost = 0;
    for (p, (d, _)) in samples.iter().zip(&truth) {
        let local = inverter.newton_from(*p, seed);
        seed = local.uv_in_knots;
        if local.distance > d + LOST_TRACK_EPS {
            lost += 1;
        }
    }
    assert!(lost > 0, "local Newton never left the true closest point");
    // Each piece is consecutive samples, the pieces in drawing order: find where each
    // starts.
    assert!(stroke.pieces.len() >= 2, "{} pieces", stroke.pieces.len());
    let mut from = 0;
    for piece in &stroke.pieces {
        let centre = &piece.centre;
        let start = (from..samples.len())
            .find(|&k| truth[k].1.distance(centre[0]) <= STATIONARY_FOOT_EPS)
            .expect("the first centre point is the true foot of a sample");
        assert!(start + centre.len() <= samples.len());
        for (i, c) in centre.iter().enumerate() {
            let (p, (d, _)) = (samples[start + i], truth[start + i]);
            // A closest point: no farther from its sample than the brute-force foot.
            assert_near!(p.distance(*c), d, INVERSION_EPS, "sample {}", start + i);
        }
        // No jump inside a piece.
        for w in centre.windows(2) {
            assert!(w[0].distance(w[1]) <= BASIN_JUMP_RATIO * spacing);
        }
        from = start + centre.len();
    }
}
