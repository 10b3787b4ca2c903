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
use sculpt_core::volume::{FlowField, StreamlineEnd};

#[path = "support/cpu_time.rs"]
mod cpu_time;
#[path = "support/volume_data.rs"]
mod volume_data;

use volume_data::{FLOW_STEPS as STEPS, flow_options, flow_seeds, flow_volume};

/// Lines per iteration.
const LINES: usize = 1000;

fn streamlines(c: &mut Criterion) {
    let vol = flow_volume();
    let field = FlowField::new(&vol, [3, 4, 5]).expect("a flow");
    let seeds = flow_seeds(LINES);
    let opts = flow_options();
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
