//! Criterion benches of the NURBS kernel hot paths on a wavy bicubic 6x6 patch: the
//! polynomial B-spline [`wavy_patch`] (all weights 1) and, for the rational code paths,
//! the same net with uneven weights ([`wavy_rational_patch`]).
//!
//! `cargo bench -p sculpt-core --bench nurbs`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{DVec2, DVec3};
use sculpt_core::nurbs::NurbsSurface;

/// The wavy bicubic 6x6 patch used by every bench (and by the peer comparison).
pub fn wavy_patch() -> NurbsSurface {
    let pts: Vec<Vec<DVec3>> = (0..6)
        .map(|i| {
            (0..6)
                .map(|j| {
                    let (x, y) = (i as f64 / 5.0, j as f64 / 5.0);
                    DVec3::new(x, y, 0.25 * (5.0 * x).sin() * (4.0 * y).cos())
                })
                .collect()
        })
        .collect();
    let k = vec![0., 0., 0., 0., 1. / 3., 2. / 3., 1., 1., 1., 1.];
    NurbsSurface::new(3, 3, k.clone(), k, pts, None).expect("valid patch")
}

/// [`wavy_patch`] made truly rational: weights from 0.5 to 2 across the net, so every
/// evaluation divides by a non-constant `w(u, v)`.
pub fn wavy_rational_patch() -> NurbsSurface {
    let p = wavy_patch();
    let (nu, nv) = (p.count_u(), p.count_v());
    let weights: Vec<Vec<f64>> = (0..nu)
        .map(|i| {
            (0..nv)
                .map(|j| 1.25 + 0.75 * (1.3 * i as f64 - 0.9 * j as f64).sin())
                .collect()
        })
        .collect();
    let k = vec![0., 0., 0., 0., 1. / 3., 2. / 3., 1., 1., 1., 1.];
    NurbsSurface::new(3, 3, k.clone(), k, p.control_points(), Some(weights))
        .expect("valid rational patch")
}

/// Deterministic query points around the patch: about a third project onto an edge.
pub fn queries(n: usize) -> Vec<DVec3> {
    let mut state = 0x1234_5678_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| DVec3::new(next() * 1.4 - 0.2, next() * 1.4 - 0.2, next() * 0.8 - 0.4))
        .collect()
}

fn params(n: usize) -> Vec<DVec2> {
    (0..n)
        .map(|i| DVec2::new((i % 97) as f64 / 96.0, (i % 89) as f64 / 88.0))
        .collect()
}

fn bench(c: &mut Criterion) {
    let s = wavy_patch();
    let uvs = params(1024);
    let mut g = c.benchmark_group("nurbs");
    g.measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    g.throughput(Throughput::Elements(uvs.len() as u64));
    g.bench_function("eval_1024", |b| {
        b.iter(|| {
            let mut acc = DVec3::ZERO;
            for uv in &uvs {
                acc += s.point(uv.x, uv.y);
            }
            black_box(acc)
        })
    });
    g.bench_function("derivatives_1024", |b| {
        b.iter(|| {
            let mut acc = DVec3::ZERO;
            for uv in &uvs {
                let d = s.derivatives(uv.x, uv.y);
                acc += d.duu + d.duv + d.dvv + d.du;
            }
            black_box(acc)
        })
    });
    let inv = s.inverter();
    let qs = queries(1024);
    g.bench_function("invert_1024", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in &qs {
                acc += inv.closest_point(*q).distance;
            }
            black_box(acc)
        })
    });
    // A stroke: consecutive samples 1 mm apart, each seeded with the previous answer.
    let stroke: Vec<DVec3> = (0..1024)
        .map(|i| {
            let t = i as f64 / 1023.0;
            s.point(t, 0.5 + 0.3 * (6.0 * t).sin()) + DVec3::Z * 0.01
        })
        .collect();
    g.bench_function("invert_seeded_stroke_1024", |b| {
        b.iter(|| black_box(inv.closest_points_along(&stroke)))
    });
    let r = wavy_rational_patch();
    g.bench_function("eval_rational_1024", |b| {
        b.iter(|| {
            let mut acc = DVec3::ZERO;
            for uv in &uvs {
                acc += r.point(uv.x, uv.y);
            }
            black_box(acc)
        })
    });
    let rinv = r.inverter();
    g.bench_function("invert_rational_1024", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in &qs {
                acc += rinv.closest_point(*q).distance;
            }
            black_box(acc)
        })
    });
    g.finish();

    let big = queries(65_536);
    let mut g = c.benchmark_group("nurbs_batch");
    g.measurement_time(Duration::from_secs(3)).sample_size(10);
    g.throughput(Throughput::Elements(big.len() as u64));
    g.bench_function("invert_batch_65536", |b| {
        b.iter(|| black_box(inv.closest_points(&big)))
    });
    g.finish();
    let mut g = c.benchmark_group("nurbs_setup");
    g.measurement_time(Duration::from_secs(2));
    g.bench_function("build_inverter", |b| b.iter(|| black_box(s.inverter())));
    g.bench_function("build_inverter_rational", |b| {
        b.iter(|| black_box(r.inverter()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
