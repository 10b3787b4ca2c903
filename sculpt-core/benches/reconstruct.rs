//! Scan reconstruction on the paper's torus (16,200 points): stages 1 and 2 alone
//! (neighbours, PCA normals with orientation, K-means and adjacency, K = 80), and the
//! whole method (K = 30, bicubic 8x8 patches on 17x17 grids, G1, the error figures),
//! with its three rounds of refitting to the data and without them (`refit0`).
//!
//! `cargo bench -p sculpt-core --bench reconstruct`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use sculpt_core::reconstruct::network::NetworkSettings;
use sculpt_core::reconstruct::pipeline::reconstruct;
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
    for (name, refit_rounds) in [("network_k30_n8", 3), ("network_k30_n8_refit0", 0)] {
        let settings = NetworkSettings {
            refit_rounds,
            ..NetworkSettings::new()
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                reconstruct(
                    black_box(&cloud),
                    &SegmentSettings::new(30),
                    &settings,
                    |_| {},
                )
                .unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
