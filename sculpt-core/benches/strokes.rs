//! Scaling with the number of strokes (issue 31, item 6): `Document::mesh` at final
//! detail of a flat 8 m x 8 m sheet carrying N scattered small strokes (4 cm V grooves,
//! 1 cm wide, at the points of a Halton sequence, some overlapping their neighbours).
//!
//! - `mesh_final_scattered/N` (criterion) for N = 1,000 and 10,000;
//! - at start-up, one run per N = 250, 1,000, 2,000, 10,000 prints the time and the peak
//!   resident memory of the process (Linux `VmHWM`, reset before each step) while
//!   building the document and while meshing it: the table in `docs/benchmarks.md`.
//!
//! Run: `cargo bench -p sculpt-core --bench strokes`.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
use sculpt_core::sculpt::tessellate::Detail;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// The process's peak resident memory so far (`VmHWM`), MiB; `None` off Linux.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Starts a new peak: the kernel resets `VmHWM` to the current resident size when
/// "5" is written to `/proc/self/clear_refs`.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Sheet side, metres.
const SIDE: f64 = 8.0;

fn sheet() -> NurbsSurface {
    let knots = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let cps = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| {
                    let at = |k: i32| SIDE * (f64::from(k) / 3.0 - 0.5);
                    DVec3::new(at(i), at(j), 0.0)
                })
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, knots.clone(), knots, cps, None).expect("valid sheet")
}

/// The k-th point of the Halton sequence in base `b`.
fn halton(mut k: u64, b: u64) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while k > 0 {
        f /= b as f64;
        r += f * (k % b) as f64;
        k /= b;
    }
    r
}

fn stroke(k: u64) -> StrokeInput {
    let margin = 0.2;
    let at = |h: f64| -SIDE / 2.0 + margin + (SIDE - 2.0 * margin) * h;
    let (x0, y0) = (at(halton(k + 1, 2)), at(halton(k + 1, 3)));
    let angle = std::f64::consts::PI * halton(k + 1, 5);
    let (s, c) = angle.sin_cos();
    let samples = (0..10)
        .map(|i| {
            let t = f64::from(i) / 9.0 * 0.04;
            (f64::from(i) * 0.01, DVec3::new(x0 + c * t, y0 + s * t, 0.0))
        })
        .collect();
    StrokeInput {
        samples,
        tool: Tool {
            profile: Profile::V,
            width: 0.01,
            depth: 0.002,
            mode: Mode::Carve,
            taper: 0.005,
        },
    }
}

fn document(n: u64) -> Document {
    let mut doc = Document::new();
    let target = doc.add_target("sheet", sheet());
    for k in 0..n {
        doc.apply_stroke(target, stroke(k))
            .expect("a scattered stroke applies");
    }
    doc
}

fn report() {
    println!("strokes | build s | peak RSS MiB | mesh final s | peak RSS MiB | triangles");
    let mib = |m: Option<f64>| m.map_or("-".to_owned(), |m| format!("{m:.0}"));
    for n in [250, 1_000, 2_000, 10_000] {
        reset_peak_rss();
        let t = Instant::now();
        let doc = document(n);
        let build = t.elapsed().as_secs_f64();
        let build_peak = peak_rss_mib();
        reset_peak_rss();
        let t = Instant::now();
        let mesh = doc.mesh(Detail::Final);
        let secs = t.elapsed().as_secs_f64();
        let mesh_peak = peak_rss_mib();
        println!(
            "{n} | {build:.2} | {} | {secs:.2} | {} | {}",
            mib(build_peak),
            mib(mesh_peak),
            mesh.triangle_count()
        );
    }
}

fn benches(c: &mut Criterion) {
    report();
    let mut group = c.benchmark_group("mesh_final_scattered");
    group.sample_size(10);
    for n in [1_000, 10_000] {
        let doc = document(n);
        group.bench_function(n.to_string(), |b| {
            b.iter_batched(
                || doc.clone(),
                |d| black_box(d.mesh(Detail::Final).triangle_count()),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group! {
    name = strokes;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(10));
    targets = benches
}
criterion_main!(strokes);
