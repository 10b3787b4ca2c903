//! Operator event log: writing one event (the per-frame cost in the interaction loop)
//! and decoding a session, against serde_json's untyped `Value` as the peer.
//!
//! `cargo bench -p sculpt-core --bench oplog`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{DQuat, DVec3};
use sculpt_core::oplog::{self, EventKind, OpLogHeader, OpLogWriter};

/// A 90 Hz pose stream with a button edge every second: `n` events.
fn session(n: usize) -> Vec<u8> {
    let mut w = OpLogWriter::new(&OpLogHeader::new().with_participant("P1"));
    for i in 0..n {
        let t = i as f64 / 90.0;
        let kind = if i % 90 == 45 {
            EventKind::Button {
                id: 0,
                down: (i / 90) % 2 == 0,
            }
        } else {
            EventKind::Pose {
                p: DVec3::new(0.1 * t.sin(), 1.2 + 0.05 * t.cos(), -0.4 + 0.01 * t),
                q: DQuat::from_rotation_y(0.3 * t.sin()),
            }
        };
        w.push(t, kind).unwrap();
    }
    w.take()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("oplog_write_pose");
    g.throughput(Throughput::Elements(1));
    let pose = EventKind::Pose {
        p: DVec3::new(0.123_456_789, 1.234_567_89, -0.456_789_123),
        q: DQuat::from_rotation_y(0.3),
    };
    g.bench_function("OpLogWriter::push", |b| {
        let mut w = OpLogWriter::new(&OpLogHeader::new());
        let mut t = 0.0;
        b.iter(|| {
            t += 0.011;
            w.push(t, black_box(pose.clone())).unwrap();
            if w.pending().len() > 1 << 20 {
                black_box(w.take());
            }
        });
    });
    g.bench_function("serde_json::Value peer", |b| {
        let mut buf = Vec::new();
        let mut t = 0.0;
        b.iter(|| {
            t += 0.011;
            let v = serde_json::json!({
                "t": t, "ev": "pose",
                "p": [0.123_456_789, 1.234_567_89, -0.456_789_123],
                "q": [0.0, 0.149_438_132_473_599_2, 0.0, 0.988_771_077_936_042_5],
            });
            serde_json::to_writer(&mut buf, black_box(&v)).unwrap();
            buf.push(b'\n');
            if buf.len() > 1 << 20 {
                buf.clear();
            }
        });
    });
    g.finish();

    let bytes = session(90 * 60);
    let text = std::str::from_utf8(&bytes).unwrap();
    let mut g = c.benchmark_group("oplog_decode_1min_90hz");
    g.throughput(Throughput::Bytes(bytes.len() as u64));
    g.bench_function("oplog::decode", |b| {
        b.iter(|| black_box(oplog::decode(black_box(text)).unwrap().events.len()));
    });
    g.bench_function("serde_json::Value peer", |b| {
        b.iter(|| {
            let n: usize = text
                .lines()
                .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
                .filter(|v| v.get("ev").is_some())
                .count();
            black_box(n)
        });
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(30);
    targets = bench
}
criterion_main!(benches);
