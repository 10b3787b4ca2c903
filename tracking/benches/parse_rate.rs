//! DTrack2 `6df2` parse rate on one core, reported per second of wall time *and* per
//! second of this thread's CPU time (from `/proc/thread-self/schedstat`), so the figure
//! stays meaningful on a machine shared with other work.
//!
//! `cargo bench -p tracking --bench parse_rate [-- SECONDS]` (default 3 s).

use glam::DVec3;
use std::hint::black_box;
use std::time::Instant;
use tracking::dtrack::{encode_frame, parse_line};
use tracking::frame::Frame;
use tracking::sim::{Script, SimConfig, Simulator};

/// Nanoseconds this thread has spent on a CPU (Linux schedstat), if available.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

fn main() {
    let secs: f64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(3.0);
    let script = Script::new(DVec3::new(0.0, 1.2, 0.3)).move_to(DVec3::new(0.3, 1.4, -0.2), 4.0);
    let frames: Vec<Frame> = Simulator::new(
        &script,
        SimConfig {
            rate_hz: 250.0,
            ..SimConfig::default()
        },
    )
    .unwrap()
    .take(1000)
    .collect();
    let lines: Vec<Vec<u8>> = frames
        .iter()
        .map(|f| {
            let mut b = Vec::new();
            encode_frame(f, &mut b);
            let t = String::from_utf8(b).unwrap();
            t.lines()
                .find(|l| l.starts_with("6df2"))
                .unwrap()
                .as_bytes()
                .to_vec()
        })
        .collect();
    println!("sample line: {}", String::from_utf8_lossy(&lines[500]));
    let mut f = Frame::default();
    let mut n = 0u64;
    let cpu0 = thread_cpu_ns();
    let t0 = Instant::now();
    while t0.elapsed().as_secs_f64() < secs {
        for l in &lines {
            f.wands.clear();
            black_box(parse_line(black_box(l), &mut f).unwrap());
        }
        n += lines.len() as u64;
    }
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu0
        .zip(thread_cpu_ns())
        .map(|(a, b)| (b - a) as f64 * 1e-9); // not a tolerance: nanoseconds to seconds
    println!("6df2 lines parsed: {n} in {wall:.3} s wall");
    println!("  per wall second: {:.0} lines/s", n as f64 / wall);
    match cpu {
        Some(c) => println!(
            "  per CPU second:  {:.0} lines/s ({c:.3} s on CPU, {:.0}% of wall)",
            n as f64 / c,
            100.0 * c / wall
        ),
        None => println!("  (thread CPU time unavailable)"),
    }
}
