//! Criterion bench of the paint sample update (`sculpt_core::paint`): one paint stroke
//! as the document applies it (deposit the brush samples on the default sheet, refit
//! the colour field's VNURBS volume, Park 2005 sec. 3.1), on a sheet already painted
//! with two strokes (so the refit carries earlier samples). After criterion, the
//! update is timed once per run over [`TIMED_RUNS`] runs and its median and p99
//! printed (criterion reports means and medians, not tails).
//!
//! `cargo bench -p sculpt-core --bench paint`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use sculpt_core::editor::{self, Applied, default_document, default_surface_point};
use sculpt_core::interaction::{DEFAULT_TARGET, Edit};
use sculpt_core::paint::Brush;
use sculpt_core::sculpt::document::Document;

/// Runs of the update timed one by one for the median and p99.
const TIMED_RUNS: usize = 40;

/// A sweep of the default brush 5 mm over the sheet along x at height `y`.
fn sweep(y: f64) -> Edit {
    let samples = (0..=40)
        .map(|i| default_surface_point(-0.35 + 0.0175 * i as f64, y) + DVec3::Z * 0.005)
        .collect();
    Edit::Paint(Brush::default().stroke(DEFAULT_TARGET, samples))
}

fn painted() -> Document {
    let mut doc = default_document();
    for y in [1.1, 1.24] {
        assert!(matches!(
            editor::apply(&mut doc, &sweep(y)),
            Applied::Paint { .. }
        ));
    }
    doc
}

fn paint(c: &mut Criterion) {
    let doc = painted();
    let edit = sweep(1.17);
    let mut group = c.benchmark_group("paint");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("stroke_update_sheet", |b| {
        b.iter_batched(
            || doc.clone(),
            |mut d| {
                let applied = editor::apply(&mut d, black_box(&edit));
                assert!(matches!(applied, Applied::Paint { .. }));
                d
            },
            BatchSize::SmallInput,
        );
    });
    group.finish();

    let mut times: Vec<f64> = (0..TIMED_RUNS)
        .map(|_| {
            let mut d = doc.clone();
            let t0 = Instant::now();
            black_box(editor::apply(&mut d, &edit));
            t0.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let at = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize] * 1e3;
    println!(
        "paint/stroke_update_sheet over {TIMED_RUNS} runs: median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        at(0.5),
        at(0.99),
        at(1.0)
    );
}

criterion_group!(benches, paint);
criterion_main!(benches);
