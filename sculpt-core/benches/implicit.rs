//! Implicit-solid evaluation: the benchmark of Shin, Kim and Sheen 2007, Table 4 (the
//! R_0 conjunction of circle (0.5, 0.5) r 0.4 with NOT circle (0.7, 0.5) r 0.1, Fig.
//! 12) at 2,097,152 points, a 2048 x 1024 grid on [0,1]^2; and meshing a torus.
//!
//! `cargo bench -p sculpt-core --bench implicit`

use criterion::{Criterion, criterion_group, criterion_main};
use sculpt_core::implicit::Model;
use sculpt_core::implicit::contour::contour;
use sculpt_core::implicit::tape::Grid;
use std::hint::black_box;

const TABLE4: &str = r#"{"solid": {"and": {"system": {"r0": {"m": 0}}, "solids": [
    {"circle": {"center": [0.5, 0.5], "radius": 0.4}},
    {"not": {"solid": {"circle": {"center": [0.7, 0.5], "radius": 0.1}}}}]}}}"#;

fn table4(c: &mut Criterion) {
    let tape = Model::from_solid_json(TABLE4)
        .unwrap()
        .tape_positive_inside();
    let grid = Grid::new([2048, 1024, 1], [0.0, 0.0, -0.5], [1.0, 1.0, 0.5]).unwrap();
    let mut group = c.benchmark_group("implicit");
    group.sample_size(30);
    group.bench_function("table4_2048x1024", |b| {
        b.iter(|| black_box(tape.eval_grid(black_box(&grid))))
    });
    let torus = Model::from_solid_json(
        r#"{"solid": {"torus": {"center": [0, 0, 0], "axis": [0, 0, 1], "major": 0.6, "minor": 0.25}}}"#,
    )
    .unwrap()
    .tape_negative_inside();
    group.sample_size(10);
    group.bench_function("mesh_torus_128", |b| {
        b.iter(|| black_box(contour(&torus, [128; 3], [-1.0; 3], [1.0; 3]).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, table4);
criterion_main!(benches);
