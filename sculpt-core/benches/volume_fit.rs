//! Criterion bench of the scattered fit (`sculpt_core::volume::fit`, Park 2005 sec.
//! 3.1): 100,000 samples into a 16 x 16 x 16 cubic net, in wall time and in the CPU
//! time of the bench thread (`.._cpu`, [`cpu_time`]). Its own binary, so that the
//! evaluation benches (`--bench volume`) run in seconds.
//!
//! `cargo bench -p sculpt-core --bench volume_fit`

use std::hint::black_box;

use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};
use sculpt_core::volume::Volume;

#[path = "support/cpu_time.rs"]
mod cpu_time;
#[path = "support/volume_data.rs"]
mod volume_data;

use volume_data::params;

/// Scattered fit: 100,000 samples of a smooth 2-attribute field into a 16 x 16 x 16
/// cubic net (least squares: sparse normal equations assembled cell by cell, PCG with the
/// scaled tensor-product preconditioner); one thread.
fn fit(c: &mut Criterion) {
    let pts = params(100_000);
    let p: Vec<f64> = pts.iter().flatten().copied().collect();
    let values: Vec<f64> = pts
        .iter()
        .flat_map(|u| [(3.0 * u[0]).sin() * u[1] + u[2], (u[0] - u[2]).cos() * u[1]])
        .collect();
    let names = vec!["a".to_string(), "b".to_string()];
    let mut group = c.benchmark_group("volume_fit");
    // Flat sampling: ten samples of as many fits as the measurement time holds (one
    // each at the default 5 s), not criterion's 55 for linear sampling.
    group.sample_size(10);
    group.sampling_mode(SamplingMode::Flat);
    let fit = || {
        Volume::fit_scattered(
            black_box(&p),
            &values,
            names.clone(),
            &[3, 3, 3],
            &[16, 16, 16],
        )
        .expect("fit")
    };
    group.bench_function("fit_100k_16cubed_cubic", |b| b.iter(fit));
    group.bench_function("fit_100k_16cubed_cubic_cpu", |b| {
        b.iter_custom(|iters| cpu_time::thread_cpu_of(iters, fit))
    });
    group.finish();
}

criterion_group!(benches, fit);
criterion_main!(benches);
