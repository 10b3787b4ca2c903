//! Scan reconstruction, stages 1 and 2 on the paper's torus (16,200 points, K = 80):
//! neighbours, PCA normals with orientation, K-means and adjacency.
//!
//! `cargo bench -p sculpt-core --bench reconstruct`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use sculpt_core::reconstruct::read::PointCloud;
use sculpt_core::reconstruct::sample::torus;
use sculpt_core::reconstruct::segment::{SegmentSettings, segment};

fn bench(c: &mut Criterion) {
    let cloud = PointCloud {
        points: torus(16_200, 0.2, 0.08, 1),
        normals: None,
    };
    let mut g = c.benchmark_group("reconstruct_torus_16200");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("segment_k80", |b| {
        b.iter(|| segment(black_box(&cloud), &SegmentSettings::new(80), |_| {}).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
