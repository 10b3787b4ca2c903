//! Parsing throughput: DTrack2 `6df2` lines, whole frames through the stream decoder,
//! serial wand lines, and pose-log records.
//!
//! `cargo bench -p tracking --bench parse`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use std::hint::black_box;
use std::time::Duration;
use tracking::dtrack::{DTrackDecoder, Decoded, encode_frame, parse_line};
use tracking::frame::Frame;
use tracking::poselog::{PoseLog, PoseLogHeader};
use tracking::serial::{SerialDecoder, SerialRecord, encode_serial};
use tracking::sim::{Script, SimConfig, Simulator};

fn session(frames: usize) -> Vec<Frame> {
    let script = Script::new(DVec3::new(0.0, 1.2, 0.3))
        .move_to(DVec3::new(0.3, 1.4, -0.2), 2.0)
        .click(0, 0.2)
        .move_to(DVec3::new(-0.3, 1.1, 0.1), 2.0);
    Simulator::new(
        &script,
        SimConfig {
            rate_hz: 300.0,
            ..SimConfig::default()
        },
    )
    .unwrap()
    .take(frames)
    .collect()
}

/// The `6df2` lines of a simulated session (one Flystick, 6 buttons, 2 axes).
fn wand_lines(frames: &[Frame]) -> Vec<Vec<u8>> {
    frames
        .iter()
        .map(|f| {
            let mut bytes = Vec::new();
            encode_frame(f, &mut bytes);
            let text = String::from_utf8(bytes).unwrap();
            text.lines()
                .find(|l| l.starts_with("6df2"))
                .unwrap()
                .as_bytes()
                .to_vec()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let frames = session(1000);
    let lines = wand_lines(&frames);
    let mut g = c.benchmark_group("dtrack");
    g.throughput(Throughput::Elements(lines.len() as u64));
    g.bench_function(BenchmarkId::new("6df2_lines", lines.len()), |b| {
        let mut f = Frame::default();
        b.iter(|| {
            for l in &lines {
                f.wands.clear();
                black_box(parse_line(black_box(l), &mut f).unwrap());
            }
        })
    });
    let mut stream = Vec::new();
    for f in &frames {
        encode_frame(f, &mut stream);
    }
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.bench_function(BenchmarkId::new("decoder_frames", frames.len()), |b| {
        b.iter(|| {
            let mut d = DTrackDecoder::default();
            let mut n = 0;
            for chunk in stream.chunks(1500) {
                d.push(chunk, &mut |x| {
                    if let Decoded::Frame(..) = x {
                        n += 1
                    }
                });
            }
            assert_eq!(n, frames.len());
        })
    });
    g.finish();

    let mut serial = Vec::new();
    for f in &frames {
        let w = &f.wands[0];
        encode_serial(
            &SerialRecord {
                seq: f.number as u32,
                buttons: w.buttons,
                pose: Some(w.pose),
            },
            &mut serial,
        );
    }
    let mut g = c.benchmark_group("serial");
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.bench_function(BenchmarkId::new("pose_lines", frames.len()), |b| {
        b.iter(|| {
            let mut n = 0;
            SerialDecoder::default().push(&serial, &mut |r, _| n += usize::from(r.is_ok()));
            assert_eq!(n, frames.len());
        })
    });
    g.finish();

    let sim = Simulator::new(
        &Script::new(DVec3::ZERO).hold(1000.0 / 120.0),
        SimConfig::default(),
    )
    .unwrap();
    let log = sim
        .write_pose_log(Vec::new(), &PoseLogHeader::new("bench"))
        .unwrap();
    let mut g = c.benchmark_group("poselog");
    g.throughput(Throughput::Bytes(log.len() as u64));
    g.bench_function("read_and_parse_frames", |b| {
        b.iter(|| {
            let l = PoseLog::from_bytes(&log).unwrap();
            black_box(l.frames())
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    targets = bench
}
criterion_main!(benches);
