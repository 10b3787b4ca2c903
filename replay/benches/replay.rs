//! Replay speed: the shipped 60-second soak session (60 Hz, 12 strokes) through the
//! whole pipeline (decode, frame stage, interaction, sculpting) without rendering or writing.
//! Target: >= 50x real time on one core, i.e. a median below 1.2 s.
//!
//! `cargo bench -p replay --bench replay`

use criterion::{Criterion, criterion_group, criterion_main};
use replay::config::ReplayConfig;
use replay::pipeline::{default_document, replay_log};

fn soak(c: &mut Criterion) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/sessions/soak-60s.poselog"
    );
    let bytes = std::fs::read(path).expect("the shipped soak session");
    let cfg = ReplayConfig::default();
    let mut group = c.benchmark_group("replay");
    group.sample_size(10);
    group.measurement_time(std::time::Duration::from_secs(8));
    group.bench_function("soak-60s", |b| {
        b.iter(|| {
            let out = replay_log(&bytes, &cfg, default_document(), "soak", false, None).unwrap();
            assert_eq!(out.metrics.gestures.strokes_applied, 12);
            out
        })
    });
    group.finish();
}

criterion_group!(benches, soak);
criterion_main!(benches);
