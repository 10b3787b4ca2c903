//! Criterion bench of streamline tracing (`sculpt_core::volume::streamline`, Park 2005
//! sec. 5.2): 1,000 streamlines of 1,000 Dormand-Prince steps each, in a trivariate
//! cubic rational volume (7 x 7 x 7 net, curved, 6 attributes: `x, y, z` and the
//! velocity of a rigid rotation, so no line leaves the volume and every line takes
//! exactly its 1,000 steps).
//!
//! Three measurements of the same work: wall time on one thread, the CPU time of that
//! thread (`.._cpu`, the figure that means something on a shared machine), and wall
//! time with the seeds split over two threads (`.._2threads`, as `sculpt-tools volume
//! streamlines` splits them over the cores; the library itself runs no threads).
//!
//! `cargo bench -p sculpt-core --bench volume_flow`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sculpt_core::volume::{FlowField, StreamlineEnd, StreamlineOptions, Volume};

#[path = "support/cpu_time.rs"]
mod cpu_time;

/// Lines per iteration.
const LINES: usize = 1000;
/// Steps per line.
const STEPS: usize = 1000;

/// The bench volume: a wavy, rational cubic box over `[-1, 1]^3` whose velocity is
/// `e_z x x`, a rotation at unit rate.
fn flow_volume() -> Volume {
    let c: usize = 7;
    let knots = [0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.];
    let (mut values, mut weights) = (Vec::new(), Vec::new());
    // The net point by point, the last index fastest (the file's nesting).
    for flat in 0..c.pow(3) {
        let idx = [flat / (c * c), flat / c % c, flat % c];
        let s = idx.map(|a| 2.0 * a as f64 / 6.0 - 1.0);
        let interior = idx.iter().all(|&a| a > 0 && a < c - 1);
        let wobble = if interior {
            0.05 * (5.0 * s[0]).sin() * (4.0 * s[1]).cos()
        } else {
            0.0
        };
        let (x, y, z) = (s[0] + wobble, s[1] - wobble, s[2] + 0.5 * wobble);
        values.extend([x, y, z, -y, x, 0.0]);
        let bump = 0.3 * (1.3 * s[0] - 0.9 * s[1] + 0.7 * s[2]).sin();
        weights.push(if interior { 1.0 + bump } else { 1.0 });
    }
    let k = knots.to_vec();
    Volume::new(
        vec![3, 3, 3],
        vec![k.clone(), k.clone(), k],
        ["x", "y", "z", "vx", "vy", "vz"].map(String::from).to_vec(),
        values,
        Some(weights),
    )
    .expect("valid bench volume")
}

fn streamlines(c: &mut Criterion) {
    let vol = flow_volume();
    let field = FlowField::new(&vol, [3, 4, 5]).expect("a flow");
    // Seeds on rings of radius 0.1 to 0.8 in parameter space around the axis.
    let seeds: Vec<[f64; 3]> = (0..LINES)
        .map(|i| {
            let a = i as f64 * 2.399_963;
            let r = 0.05 + 0.35 * (i as f64 / LINES as f64);
            [0.5 + r * a.cos(), 0.5 + r * a.sin(), (i % 17) as f64 / 16.0]
        })
        .collect();
    let opts = StreamlineOptions {
        time: 1e9,
        max_steps: STEPS,
        ..StreamlineOptions::new(0.0)
    };
    // Every line takes its full number of steps.
    for s in &seeds {
        let line = field.trace(*s, &opts).expect("a valid seed");
        assert_eq!(line.end, StreamlineEnd::MaxSteps);
        assert_eq!(line.points.len(), STEPS + 1);
    }
    let mut group = c.benchmark_group("volume_flow");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    group.throughput(Throughput::Elements((LINES * STEPS) as u64));
    let trace_all = |seeds: &[[f64; 3]]| {
        let mut acc = 0.0;
        for s in seeds {
            let line = field.trace(black_box(*s), &opts).expect("a valid seed");
            acc += line.points[STEPS].x;
        }
        acc
    };
    group.bench_function("streamlines_1000x1000", |b| b.iter(|| trace_all(&seeds)));
    group.bench_function("streamlines_1000x1000_cpu", |b| {
        b.iter_custom(|iters| cpu_time::thread_cpu_of(iters, || trace_all(&seeds)))
    });
    group.bench_function("streamlines_1000x1000_2threads", |b| {
        b.iter(|| {
            let (a, c) = seeds.split_at(LINES / 2);
            std::thread::scope(|scope| {
                let other = scope.spawn(|| trace_all(c));
                trace_all(a) + other.join().expect("no panic")
            })
        })
    });
    group.finish();
}

criterion_group!(benches, streamlines);
criterion_main!(benches);
