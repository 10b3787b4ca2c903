//! Criterion benches of volume evaluation (`sculpt_core::volume`): a trivariate cubic
//! rational volume with 5 attributes (`x, y, z`, a density and a temperature) on a
//! 7 x 7 x 7 net, evaluated with all first derivatives.
//!
//! `cargo bench -p sculpt-core --bench volume`
//!
//! Every target is measured twice: in wall time (criterion's default) and in the CPU
//! time of the bench thread (`.._cpu`, [`cpu_time`]), the figure that means something
//! on a machine shared with other jobs.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sculpt_core::volume::Volume;

#[path = "support/cpu_time.rs"]
mod cpu_time;

/// The bench volume: a wavy cubic 7^3 net on knots with three interior spans per
/// direction, weights from 0.5 to 2 (so every point divides by a non-constant weight).
pub fn bench_volume() -> Volume {
    let c = 7;
    let k = vec![0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.];
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for i in 0..c {
        for j in 0..c {
            for l in 0..c {
                let (x, y, z) = (i as f64 / 6.0, j as f64 / 6.0, l as f64 / 6.0);
                let wobble = 0.05 * (5.0 * x).sin() * (4.0 * y).cos() * (3.0 * z).sin();
                values.extend([x + wobble, y - wobble, z + 0.5 * wobble, 1.0 + z, x * y]);
                weights
                    .push(1.25 + 0.75 * (1.3 * i as f64 - 0.9 * j as f64 + 0.7 * l as f64).sin());
            }
        }
    }
    Volume::new(
        vec![3, 3, 3],
        vec![k.clone(), k.clone(), k],
        ["x", "y", "z", "rho", "t"].map(String::from).to_vec(),
        values,
        Some(weights),
    )
    .expect("valid bench volume")
}

/// Deterministic parameters in the unit cube.
pub fn params(n: usize) -> Vec<[f64; 3]> {
    let mut state = 0x9E37_79B9_7F4A_7C15_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

fn eval(c: &mut Criterion) {
    let vol = bench_volume();
    let pts = params(1024);
    let mut group = c.benchmark_group("volume");
    group.throughput(Throughput::Elements(pts.len() as u64));
    group.measurement_time(Duration::from_secs(4));
    let mut row = [0.0; 5 * 4];
    let mut eval_d1 = || {
        let mut acc = 0.0;
        for u in &pts {
            vol.eval_d1_into(black_box(u), &mut row)
                .expect("valid parameters");
            acc += row[0] + row[19];
        }
        acc
    };
    group.bench_function("eval_d1_1024", |b| b.iter(&mut eval_d1));
    group.bench_function("eval_d1_1024_cpu", |b| {
        b.iter_custom(|iters| cpu_time::thread_cpu_of(iters, &mut eval_d1))
    });
    let mut value = [0.0; 5];
    group.bench_function("eval_1024", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for u in &pts {
                vol.eval_into(black_box(u), &mut value)
                    .expect("valid parameters");
                acc += value[0];
            }
            acc
        })
    });
    group.bench_function("derivatives2_1024", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for u in &pts {
                acc += vol
                    .derivatives(black_box(u), 2)
                    .expect("valid parameters")
                    .value()[0];
            }
            acc
        })
    });
    group.finish();
}

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
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
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

criterion_group!(benches, eval, fit);
criterion_main!(benches);
