//! The serial wand over a real pseudo-terminal pair made by socat, with injected noise.
//!
//! Needs `socat` (CI installs it; locally `apt-get install socat`). Without it this
//! test fails with a clear message rather than skipping.

use glam::{DQuat, DVec3};
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Command, Stdio};
use std::time::Duration;
use tracking::config::{SourceConfig, TrackingConfig};
use tracking::hub::TrackingStatus;
use tracking::serial::{SerialRecord, encode_serial};
use tracking::transport::start;
use tracking::{DeviceId, Pose};

/// A socat pty pair; killed (by its own pid) on drop.
struct PtyPair {
    child: Child,
    a: String,
    b: String,
}

impl Drop for PtyPair {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn pty_pair() -> PtyPair {
    let mut child = Command::new("socat")
        .args(["-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("this test needs socat on PATH (apt-get install socat): {e}"));
    let stderr = child.stderr.take().unwrap();
    let mut lines = BufReader::new(stderr).lines();
    let mut ptys = Vec::new();
    while ptys.len() < 2 {
        let line = lines
            .next()
            .expect("socat exited early")
            .expect("socat stderr");
        if let Some(i) = line.find("PTY is ") {
            ptys.push(line[i + 7..].trim().to_string());
        }
    }
    // Keep draining socat's log so it never blocks on a full pipe.
    std::thread::spawn(move || for _ in lines {});
    PtyPair {
        child,
        a: ptys[0].clone(),
        b: ptys[1].clone(),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serial_wand_over_a_pty_with_line_noise() {
    let pair = pty_pair();
    let config = TrackingConfig {
        sources: vec![SourceConfig::Serial {
            port: pair.a.clone(),
            baud: 115_200,
            wand_id: 7,
            button_count: 4,
        }],
        filter: tracking::filter::FilterConfig {
            enabled: false,
            ..Default::default()
        },
        ..TrackingConfig::default()
    };
    let running = start(&config).await.unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(7));
    let mut events = running.hub.subscribe();
    // Wait until the reader has the port open before writing.
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while !running
        .hub
        .source_stats(running.sources[0])
        .unwrap()
        .connected
    {
        assert!(
            std::time::Instant::now() < deadline,
            "serial source never opened {}",
            pair.a
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let mut port = std::fs::OpenOptions::new()
        .write(true)
        .open(&pair.b)
        .unwrap();
    let mut bytes = b"\x00\xff\x13noise$WAND,9,1".to_vec(); // noise and a half line
    for (seq, buttons) in [(1u32, 0u64), (2, 1), (3, 1), (4, 0)] {
        let pose = Pose::from_quat(
            DVec3::new(100.0 * f64::from(seq), 1500.0, -20.0),
            DQuat::from_rotation_y(0.1),
        );
        let mut line = Vec::new();
        encode_serial(
            &SerialRecord {
                seq,
                buttons,
                pose: Some(pose),
            },
            &mut line,
        );
        bytes.extend_from_slice(&line);
        bytes.extend_from_slice(b"\r\n$WAND,5,1*00000000\r\n"); // a bad checksum
        bytes.extend_from_slice(b"#\x07garbage\n");
    }
    port.write_all(&bytes).unwrap();
    port.flush().unwrap();
    let state = tokio::time::timeout(Duration::from_secs(20), wand.wait_for(|s| s.frame == 4))
        .await
        .expect("serial records never arrived")
        .unwrap()
        .clone();
    assert_eq!(state.status, TrackingStatus::Tracking);
    assert_eq!(state.buttons, 0);
    sculpt_core::assert_near!(
        state.pose.unwrap().position_m.to_array(),
        [0.4, 1.5, -0.02],
        sculpt_core::tolerance::POINT_EPS
    );
    let mut edges = Vec::new();
    while let Ok(e) = events.try_recv() {
        if let tracking::hub::TrackingEvent::Button {
            button, pressed, ..
        } = e
        {
            edges.push((button, pressed));
        }
    }
    assert_eq!(edges, vec![(0, true), (0, false)]);
    // The last bad line may still be in flight when record 4 lands: wait for it.
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    let stats = loop {
        let stats = running.hub.source_stats(running.sources[0]).unwrap();
        if stats.bad_frames >= 4 || std::time::Instant::now() > deadline {
            break stats;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    };
    assert_eq!(stats.frames, 4);
    assert_eq!(stats.bad_frames, 4, "four bad-checksum lines");
}
