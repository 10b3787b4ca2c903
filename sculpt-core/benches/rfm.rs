//! Mesh-free heat analysis (Shin, Kim and Sheen 2007, sec. 3): the paper's ring
//! (tests/data/rfm/ring.toml: radii 0.5 and 1, lambda 7, alpha 100, 1073 / 1573 K) with
//! the 10 x 10 bicubic basis: quadrature, assembly and Cholesky solve, with the basis
//! box given (`assemble_solve`) and found by sampling (`full`). Goal: <= 50 ms.
//!
//! `cargo bench -p sculpt-core --bench rfm`

use criterion::{Criterion, criterion_group, criterion_main};
use sculpt_core::implicit::Model;
use sculpt_core::implicit::rfm::heat::{HeatSettings, Piece, solve};
use std::hint::black_box;

fn ring(c: &mut Criterion) {
    let outer = include_str!("../../tests/data/rfm/ring-outer.json");
    let inner = include_str!("../../tests/data/rfm/ring-inner.vm");
    let pieces = [
        Piece {
            model: Model::from_text(outer).unwrap(),
            ambient: 1573.0,
            film: 100.0,
        },
        Piece {
            model: Model::from_text(inner).unwrap(),
            ambient: 1073.0,
            film: 100.0,
        },
    ];
    let settings = HeatSettings {
        conductivity: 7.0,
        count: [10, 10],
        ..Default::default()
    };
    let given = HeatSettings {
        bounds: Some([-1.0, -1.0, 1.0, 1.0]),
        ..settings
    };
    let mut group = c.benchmark_group("rfm");
    group.sample_size(20);
    group.bench_function("ring_10x10_assemble_solve", |b| {
        b.iter(|| black_box(solve(black_box(&given), &pieces).unwrap()))
    });
    group.bench_function("ring_10x10_full", |b| {
        b.iter(|| black_box(solve(black_box(&settings), &pieces).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, ring);
criterion_main!(benches);
