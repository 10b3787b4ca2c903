//! End-to-end latency: from a DTrack2 frame being written to a loopback TCP socket to
//! its filtered, calibrated pose being readable from the hub's `watch` channel, at
//! 1 kHz input.
//!
//! `cargo bench -p tracking --bench latency [-- FRAMES]` (default 5000 frames = 5 s).
//!
//! Two threads: a sender writing one frame per millisecond (timestamped just before
//! `write_all`), and a current-thread tokio runtime running the TCP listener, the hub
//! and an observer task awaiting the wand's `watch` receiver, which timestamps each new
//! frame counter it sees (so the figure includes the consumer's wake-up). Latency =
//! seen − sent, per frame; frames the observer did not see individually (overwritten
//! before it looked) are counted, not guessed.

use glam::DVec3;
use std::io::Write;
use std::net::TcpStream;
use std::time::{Duration, Instant};
use tracking::DeviceId;
use tracking::config::{SourceConfig, TrackingConfig};
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::transport::{frames_as_items, start};

fn main() {
    let frames: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5000);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let config = TrackingConfig {
        sources: vec![SourceConfig::TcpListen {
            addr: "127.0.0.1:0".parse().unwrap(),
        }],
        ..TrackingConfig::default()
    };
    let running = rt.block_on(start(&config)).unwrap();
    let addr = running.local_addrs[0].unwrap();
    let rx = running.hub.watch(DeviceId::Wand(0));

    let secs = frames as f64 / 1000.0;
    let script = Script::new(DVec3::new(0.0, 1.2, 0.3)).move_to(DVec3::new(0.4, 1.3, -0.1), secs);
    let sim = Simulator::new(
        &script,
        SimConfig {
            rate_hz: 1000.0,
            ..SimConfig::default()
        },
    )
    .unwrap();
    let items: Vec<Vec<u8>> = frames_as_items(sim.take(frames)).map(|(_, b)| b).collect();

    let observer = async move {
        let mut rx = rx;
        let mut seen = vec![None::<Instant>; frames + 2];
        let give_up = tokio::time::sleep(Duration::from_secs_f64(secs + 5.0));
        tokio::pin!(give_up);
        loop {
            tokio::select! {
                r = rx.changed() => {
                    if r.is_err() {
                        break;
                    }
                    let now = Instant::now();
                    let n = rx.borrow_and_update().frame as usize;
                    if let Some(slot) = seen.get_mut(n) {
                        *slot = Some(now);
                    }
                    if n >= frames {
                        break;
                    }
                }
                _ = &mut give_up => break,
            }
        }
        seen
    };

    let sender = std::thread::spawn(move || {
        let mut stream = TcpStream::connect(addr).unwrap();
        stream.set_nodelay(true).unwrap();
        let mut sent = vec![None::<Instant>; frames + 2];
        let start_at = Instant::now() + Duration::from_millis(50);
        for (i, bytes) in items.iter().enumerate() {
            let due = start_at + Duration::from_millis(i as u64);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
            sent[i + 1] = Some(Instant::now());
            stream.write_all(bytes).unwrap();
        }
        std::thread::sleep(Duration::from_millis(200));
        sent
    });
    let seen = rt.block_on(observer);
    let sent = sender.join().unwrap();

    let mut lat: Vec<f64> = sent
        .iter()
        .zip(&seen)
        .filter_map(|(s, r)| Some(r.as_ref()?.duration_since(*s.as_ref()?).as_secs_f64() * 1e6))
        .collect();
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| lat[((lat.len() - 1) as f64 * p).round() as usize];
    println!(
        "tcp->filtered pose latency at 1 kHz: frames sent {frames}, observed individually {} ({} overwritten before observed)",
        lat.len(),
        frames - lat.len()
    );
    println!(
        "  median {:.1} us  p90 {:.1} us  p99 {:.1} us  p99.9 {:.1} us  max {:.1} us",
        q(0.5),
        q(0.9),
        q(0.99),
        q(0.999),
        lat[lat.len() - 1]
    );
    println!(
        "  target p99 <= 1000 us: {}",
        if q(0.99) <= 1000.0 { "met" } else { "NOT met" }
    );
}
