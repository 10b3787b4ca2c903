//! Real loopback sockets: TCP both ways with mid-frame disconnects, a 100 MB garbage
//! flood, a slow-loris sender, UDP with out-of-order datagrams, and recording.

use glam::DVec3;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tokio::sync::watch;
use tracking::DeviceId;
use tracking::config::{SourceConfig, TrackingConfig};
use tracking::hub::{DeviceState, TrackingStatus};
use tracking::poselog::PoseLog;
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::transport::{frames_as_items, send_paced, start};

const PATIENCE: Duration = Duration::from_secs(20);

fn session_bytes(frames: usize) -> Vec<Vec<u8>> {
    let script = Script::new(DVec3::new(0.0, 1.0, 0.0))
        .move_to(DVec3::new(0.3, 1.1, 0.0), frames as f64 / 120.0);
    let sim = Simulator::new(&script, SimConfig::default()).unwrap();
    frames_as_items(sim.take(frames)).map(|(_, b)| b).collect()
}

async fn wait_for(
    rx: &mut watch::Receiver<DeviceState>,
    what: &str,
    pred: impl Fn(&DeviceState) -> bool,
) -> DeviceState {
    let r = tokio::time::timeout(PATIENCE, rx.wait_for(|s| pred(s)))
        .await
        .map(|r| r.map(|s| s.clone()));
    match r {
        Ok(Ok(s)) => s,
        _ => panic!("timed out waiting for {what}; last state {:?}", rx.borrow()),
    }
}

fn cfg(source: SourceConfig) -> TrackingConfig {
    TrackingConfig {
        sources: vec![source],
        ..TrackingConfig::default()
    }
}

fn listen_any() -> SourceConfig {
    SourceConfig::TcpListen {
        addr: "127.0.0.1:0".parse().unwrap(),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcp_listen_survives_a_disconnect_mid_frame() {
    let running = start(&cfg(listen_any())).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let frames = session_bytes(40);
    let mut s = TcpStream::connect(addr).await.unwrap();
    for f in &frames[..20] {
        s.write_all(f).await.unwrap();
    }
    // Half of frame 21, then the connection drops.
    s.write_all(&frames[20][..frames[20].len() / 2])
        .await
        .unwrap();
    wait_for(&mut wand, "frame 20", |s| s.frame == 20).await;
    drop(s);
    let st = wait_for(&mut wand, "disconnect", |s| {
        s.status == TrackingStatus::Disconnected
    })
    .await;
    assert_eq!(st.frame, 20, "the cut frame is never applied");
    // Reconnect and carry on from frame 21.
    let mut s = TcpStream::connect(addr).await.unwrap();
    for f in &frames[20..] {
        s.write_all(f).await.unwrap();
    }
    let st = wait_for(&mut wand, "frame 40", |s| s.frame == 40).await;
    assert_eq!(st.status, TrackingStatus::Tracking);
    let stats = running.hub.source_stats(running.sources[0]).unwrap();
    assert_eq!(stats.connections, 2);
    assert_eq!(stats.frames, 40);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcp_connect_reconnects_with_backoff() {
    let server = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = server.local_addr().unwrap();
    let mut config = cfg(SourceConfig::TcpConnect { addr });
    config.reconnect_min_ms = 10;
    config.reconnect_max_ms = 50;
    let running = start(&config).await.unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let frames = session_bytes(30);
    // First connection: 10 frames and half a frame, then the server drops it.
    let (mut c, _) = tokio::time::timeout(PATIENCE, server.accept())
        .await
        .unwrap()
        .unwrap();
    for f in &frames[..10] {
        c.write_all(f).await.unwrap();
    }
    c.write_all(&frames[10][..7]).await.unwrap();
    wait_for(&mut wand, "frame 10", |s| s.frame == 10).await;
    drop(c);
    // The display server connects again by itself.
    let (mut c, _) = tokio::time::timeout(PATIENCE, server.accept())
        .await
        .unwrap()
        .unwrap();
    for f in &frames[10..] {
        c.write_all(f).await.unwrap();
    }
    wait_for(&mut wand, "frame 30", |s| s.frame == 30).await;
    assert_eq!(
        running
            .hub
            .source_stats(running.sources[0])
            .unwrap()
            .connections,
        2
    );
}

/// Resident memory of this process, bytes (Linux).
fn rss() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").expect("Linux /proc");
    let pages: u64 = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4096
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_flood_of_100_mb_keeps_memory_bounded() {
    let mut config = cfg(listen_any());
    config.read_timeout_ms = 60_000;
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let before = rss();
    let mut s = TcpStream::connect(addr).await.unwrap();
    let frames = session_bytes(2);
    s.write_all(&frames[0]).await.unwrap();
    // 100 MB of xorshift garbage, in 1 MB chunks; every other chunk has no newline at
    // all (one endless line), the rest random bytes with random line breaks.
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    let mut chunk = vec![0u8; 1 << 20];
    for i in 0..100 {
        for b in chunk.chunks_mut(8) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            b.copy_from_slice(&x.to_le_bytes()[..b.len()]);
        }
        if i % 2 == 0 {
            for b in &mut chunk {
                if *b == b'\n' {
                    *b = b'x';
                }
            }
        }
        s.write_all(&chunk).await.unwrap();
    }
    s.write_all(b"\r\n\r\n").await.unwrap();
    s.write_all(&frames[1]).await.unwrap();
    let st = wait_for(&mut wand, "frame after the flood", |s| s.frame == 2).await;
    assert_eq!(st.status, TrackingStatus::Tracking);
    let grown = rss().saturating_sub(before);
    assert!(
        grown < 32 << 20,
        "resident memory grew by {} MB",
        grown >> 20
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_loris_is_cut_off_while_a_good_sender_goes_on() {
    let mut config = cfg(listen_any());
    config.read_timeout_ms = 300;
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut loris = TcpStream::connect(addr).await.unwrap();
    let frames = session_bytes(1);
    let drip = async {
        // One byte every 20 ms, never finishing a frame.
        for &b in frames[0][..frames[0].len() - 4].iter().cycle() {
            if loris.write_all(&[b]).await.is_err() {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        false
    };
    let cut = tokio::time::timeout(PATIENCE, drip)
        .await
        .expect("the slow sender was never cut off");
    assert!(cut);
    let mut buf = [0u8; 1];
    assert_eq!(
        loris.read(&mut buf).await.unwrap_or(0),
        0,
        "server closed the connection"
    );
    // A well-behaved tracker is still served.
    let mut good = TcpStream::connect(addr).await.unwrap();
    good.write_all(&frames[0]).await.unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    wait_for(&mut wand, "good frame", |s| s.frame == 1).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn udp_drops_out_of_order_datagrams() {
    let running = start(&cfg(SourceConfig::Udp {
        addr: "127.0.0.1:0".parse().unwrap(),
    }))
    .await
    .unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let frames = session_bytes(8);
    let sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    for i in [0usize, 1, 2, 4, 3, 5] {
        sock.send_to(&frames[i], addr).await.unwrap();
    }
    sock.send_to(b"\xff\xfe not dtrack at all", addr)
        .await
        .unwrap();
    // A datagram whose last line has no CR/LF still counts.
    let last = &frames[6];
    sock.send_to(&last[..last.len() - 4], addr).await.unwrap();
    wait_for(&mut wand, "frame 7", |s| s.frame == 7).await;
    let stats = running.hub.source_stats(running.sources[0]).unwrap();
    assert_eq!(stats.out_of_order, 1, "frame 4 arrived after 5");
    assert_eq!(stats.frames, 6);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn recording_keeps_every_frame_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.wslog");
    let mut config = cfg(listen_any());
    config.record = Some(path.clone());
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let script = Script::new(DVec3::ZERO)
        .move_to(DVec3::X, 0.2)
        .click(1, 0.05);
    let sim = Simulator::new(&script, SimConfig::default()).unwrap();
    let items: Vec<_> = frames_as_items(sim).collect();
    let sent: Vec<u8> = items.iter().flat_map(|(_, b)| b.clone()).collect();
    let mut s = TcpStream::connect(addr).await.unwrap();
    // Paced at 4x real time: 0.25 s of frames arrive over about 60 ms.
    send_paced(&mut s, items.clone(), 4.0).await.unwrap();
    wait_for(&mut wand, "last frame", |s| s.frame == items.len() as u64).await;
    let log = PoseLog::read(&path).unwrap();
    assert!(log.corrupt.is_empty());
    let logged: Vec<u8> = log.records.iter().flat_map(|r| r.bytes.clone()).collect();
    assert_eq!(logged, sent);
    assert!(log.header.config.get("source").is_some());
    assert!(log.records.windows(2).all(|w| w[0].time <= w[1].time));
}
