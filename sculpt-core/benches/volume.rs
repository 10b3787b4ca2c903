//! Criterion benches of volume evaluation (`sculpt_core::volume`): a trivariate cubic
//! rational volume with 5 attributes (`x, y, z`, a density and a temperature) on a
//! 7 x 7 x 7 net, evaluated with all first derivatives.
//!
//! `cargo bench -p sculpt-core --bench volume` (about 20 s with `--warm-up-time 1
//! --measurement-time 3`; the scattered fit is `--bench volume_fit`)
//!
//! Every target is measured twice: in wall time (criterion's default) and in the CPU
//! time of the bench thread (`.._cpu`, [`cpu_time`]), the figure that means something
//! on a machine shared with other jobs.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

#[path = "support/cpu_time.rs"]
mod cpu_time;
#[path = "support/volume_data.rs"]
mod volume_data;

use volume_data::{bench_volume, params};

fn eval(c: &mut Criterion) {
    let vol = bench_volume();
    let pts = params(1024);
    let mut group = c.benchmark_group("volume");
    group.throughput(Throughput::Elements(pts.len() as u64));
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

criterion_group!(benches, eval);
criterion_main!(benches);
