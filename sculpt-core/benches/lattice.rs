//! Criterion benches of lattice deformation (`sculpt_core::lattice`): the whole
//! document operation (fit the lattice, map the target, carry and rebuild its strokes)
//! on the default sheet with three carved grooves, and the lattice map of one surface.
//! After criterion, the document operation is timed once per run over
//! [`TIMED_RUNS`] runs and its median and p99 printed (criterion reports means and
//! medians, not tails).
//!
//! `cargo bench -p sculpt-core --bench lattice`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use sculpt_core::editor::{self, Applied, default_document, default_surface_point};
use sculpt_core::interaction::{DEFAULT_TARGET, Edit, StrokeEdit, StrokeSample, Tool};
use sculpt_core::lattice::{DeformEdit, Lattice, LatticeSpec};
use sculpt_core::nurbs::refine::Direction;
use sculpt_core::sculpt::document::Document;

/// Runs of the document operation timed one by one for the median and p99.
const TIMED_RUNS: usize = 300;

/// The default document with three carved grooves across it.
fn carved() -> Document {
    let mut doc = default_document();
    for y in [1.05, 1.17, 1.29] {
        let samples = (0..=40)
            .map(|i| StrokeSample {
                t: i as f64 * 0.01,
                position: default_surface_point(-0.4 + 0.02 * i as f64, y),
            })
            .collect();
        let edit = Edit::Stroke(StrokeEdit::new(DEFAULT_TARGET, Tool::default(), samples));
        assert!(matches!(
            editor::apply(&mut doc, &edit),
            Applied::Stroke { .. }
        ));
    }
    doc
}

/// The test bend of `docs/lattice.md`: the cage's top front middle group pulled
/// towards the viewer.
fn bend(doc: &Document) -> Edit {
    let surfaces: Vec<_> = doc.targets().iter().map(|t| &t.surface).collect();
    let (lo, hi) = Lattice::around(LatticeSpec::default(), &surfaces)
        .expect("a lattice")
        .bounds();
    Edit::Deform(DeformEdit {
        targets: doc.target_ids(),
        lattice: LatticeSpec::default(),
        grab: DVec3::new(0.5 * (lo.x + hi.x), hi.y, hi.z),
        radius: 0.3,
        displacement: DVec3::new(0.0, 0.0, 0.1),
    })
}

fn deform(c: &mut Criterion) {
    let doc = carved();
    let edit = bend(&doc);
    let mut group = c.benchmark_group("lattice");
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("apply_sheet_3_strokes", |b| {
        b.iter_batched(
            || doc.clone(),
            |mut d| {
                let applied = editor::apply(&mut d, black_box(&edit));
                assert!(matches!(applied, Applied::Deform { .. }));
                d
            },
            BatchSize::SmallInput,
        );
    });
    let sheet = &doc.targets()[0].surface;
    let x: Vec<f64> = (1..16).map(|i| i as f64 / 16.0).collect();
    let fine = sheet
        .refine_knots(Direction::U, &x)
        .and_then(|s| s.refine_knots(Direction::V, &x))
        .expect("refined sheet");
    let mut lattice = Lattice::around(LatticeSpec::default(), &[&fine]).expect("lattice");
    let (lo, hi) = lattice.bounds();
    let g = lattice
        .group(DVec3::new(0.5 * (lo.x + hi.x), hi.y, hi.z), 0.3)
        .expect("group");
    lattice
        .displace(&g, DVec3::new(0.0, 0.0, 0.1))
        .expect("displace");
    group.bench_function("map_surface_18x18", |b| {
        b.iter(|| lattice.deform_surface(black_box(&fine)).expect("mapped"));
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
        "lattice/apply_sheet_3_strokes over {TIMED_RUNS} runs: median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        at(0.5),
        at(0.99),
        at(1.0)
    );
}

criterion_group!(benches, deform);
criterion_main!(benches);
