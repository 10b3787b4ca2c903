//! Criterion bench of a stroke on a solid target (`sculpt_core::solid`, issue 35 item
//! 3): apply and re-mesh, on a hollow sphere (radius 0.25 m, 2 cm wall) meshed at 256
//! cells along its box (a 256^3-equivalent solid: 17 x 17 x 17 blocks of 16^3 cells).
//! The stroke is a V groove (3 cm wide, 3 cm deep: through the wall) of 41 samples,
//! 20 cm over the top; each run carves it (timed: sample projection, the tool solid,
//! re-evaluating and re-meshing the blocks it reaches) and takes it back (not timed).
//! After criterion the stroke is timed once per run over [`TIMED_RUNS`] runs and its
//! median and p99 printed. A stroke where one was made before finds the blocks' corner
//! values kept and combines only its own tool; the first stroke on a region evaluates
//! the blocks from the model: it is timed first, [`FIRST_RUNS`] times on fresh clones.
//!
//! `cargo bench -p sculpt-core --bench solid`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use sculpt_core::percentile;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
use sculpt_core::solid::SolidTarget;

/// Runs timed one by one for the median and p99.
const TIMED_RUNS: usize = 200;
/// Runs of the first stroke on a fresh solid (each on a clone).
const FIRST_RUNS: usize = 30;

/// A hollow sphere: radius 0.25, inner radius 0.23.
const SHELL: &str = r#"{"version": 1, "solid": {"and": {"system": "min_max", "solids": [
  {"sphere": {"center": [0, 0, 0], "radius": 0.25}},
  {"not": {"solid": {"sphere": {"center": [0, 0, 0], "radius": 0.23}}}}]}}}"#;

fn stroke() -> StrokeInput {
    let samples = (0..=40)
        .map(|i| {
            let a = -0.4 + 0.8 * i as f64 / 40.0;
            (
                i as f64 * 0.01,
                DVec3::new(0.25 * a.sin(), 0.0, 0.25 * a.cos()),
            )
        })
        .collect();
    let tool = Tool {
        profile: Profile::V,
        width: 0.03,
        depth: 0.03,
        mode: Mode::Carve,
        taper: 0.01,
    };
    StrokeInput { samples, tool }
}

fn carve(c: &mut Criterion) {
    let fresh = SolidTarget::new(SHELL, 256).expect("the shell");
    let input = stroke();
    // The first stroke on a region: no corner values kept yet, every block the tool's
    // box reaches is evaluated from the model.
    let mut first: Vec<f64> = (0..FIRST_RUNS)
        .map(|_| {
            let mut solid = fresh.clone();
            let t0 = Instant::now();
            black_box(solid.cut(1, &input).expect("carved"));
            t0.elapsed().as_secs_f64()
        })
        .collect();
    first.sort_by(f64::total_cmp);
    let mut solid = fresh.clone();
    let r = solid.cut(1, &input).expect("carved");
    println!(
        "solid/stroke_256: {} blocks reached, {} re-meshed, {} decided by intervals, of {}",
        r.reached,
        r.blocks,
        r.pruned,
        solid.block_meshes().1.len()
    );
    println!(
        "solid/stroke_256 first stroke on the region over {FIRST_RUNS} runs: median {:.3} ms, p99 {:.3} ms",
        percentile::median(&first).unwrap_or(f64::NAN) * 1e3,
        percentile::p99(&first).unwrap_or(f64::NAN) * 1e3,
    );
    // Taken back: the blocks are evaluated again without it and their values kept,
    // as after any stroke there; the timed strokes below are the next stroke there.
    solid.uncut();
    let mut group = c.benchmark_group("solid");
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("stroke_256", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t0 = Instant::now();
                black_box(solid.cut(1, black_box(&input)).expect("carved"));
                total += t0.elapsed();
                solid.uncut();
            }
            total
        });
    });
    group.finish();
    let mut times: Vec<f64> = (0..TIMED_RUNS)
        .map(|_| {
            let t0 = Instant::now();
            black_box(solid.cut(1, &input).expect("carved"));
            let t = t0.elapsed().as_secs_f64();
            solid.uncut();
            t
        })
        .collect();
    times.sort_by(f64::total_cmp);
    // The project's one percentile rule (`sculpt_core::percentile`).
    let ms = |v: Option<f64>| v.unwrap_or(f64::NAN) * 1e3;
    println!(
        "solid/stroke_256 over {TIMED_RUNS} runs: median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        ms(percentile::median(&times)),
        ms(percentile::p99(&times)),
        ms(times.last().copied())
    );
}

criterion_group!(benches, carve);
criterion_main!(benches);
