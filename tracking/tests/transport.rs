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
    // Two slots, so the slow sender gets in and the read timeout is what cuts it.
    config.max_connections = 2;
    config.read_timeout_ms = 500;
    config.lost_after_ms = 5_000;
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let frames = session_bytes(400);
    // A well-behaved tracker at 20 Hz, connected throughout.
    let mut good = TcpStream::connect(addr).await.unwrap();
    let good_frames = frames.clone();
    let good_task = tokio::spawn(async move {
        for f in &good_frames {
            good.write_all(f).await.unwrap();
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    });
    wait_for(&mut wand, "good frame 1", |s| s.frame >= 1).await;
    let mut loris = TcpStream::connect(addr).await.unwrap();
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
    // Cutting one connection does not disconnect the source while another is open.
    let now = wand.borrow().frame;
    assert_eq!(wand.borrow().status, TrackingStatus::Tracking);
    wait_for(&mut wand, "later good frames", |s| s.frame >= now + 3).await;
    good_task.abort();
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

/// Frames of a session whose wand holds `buttons` throughout, numbered from `first`.
fn frames_with_buttons(first: u64, n: usize, buttons: u64) -> Vec<Vec<u8>> {
    let script = Script::new(DVec3::new(0.0, 1.0, 0.0)).hold(n as f64 / 60.0);
    let sim = Simulator::new(&script, SimConfig::default()).unwrap();
    sim.take(n)
        .enumerate()
        .map(|(k, mut f)| {
            f.number = first + k as u64;
            for w in &mut f.wands {
                w.buttons = buttons;
            }
            let mut bytes = Vec::new();
            tracking::dtrack::encode_frame(&f, &mut bytes);
            bytes
        })
        .collect()
}

/// Whether the server closed `s` (reads end or fail within the patience).
async fn closed_by_server(s: &mut TcpStream) -> bool {
    let mut buf = [0u8; 64];
    matches!(
        tokio::time::timeout(PATIENCE, s.read(&mut buf)).await,
        Ok(Ok(0) | Err(_))
    )
}

/// Regression (issue 15, item 6): a second loopback connection to a listening source
/// could press button 3 (undo) while the sculptor's tracker was connected. A source now
/// keeps one active connection: the second peer is refused before a byte is read, and
/// counted.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_peer_on_a_listening_source_is_refused_and_presses_nothing() {
    let running = start(&cfg(listen_any())).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let mut events = running.hub.subscribe();
    let mut tracker = TcpStream::connect(addr).await.unwrap();
    for f in frames_with_buttons(1, 5, 0) {
        tracker.write_all(&f).await.unwrap();
    }
    wait_for(&mut wand, "tracker frame 5", |s| s.frame == 5).await;
    let mut stray = TcpStream::connect(addr).await.unwrap();
    // Button 3 held, with counters far ahead of the tracker's.
    for f in frames_with_buttons(1_000_000, 5, 1 << 3) {
        let _ = stray.write_all(&f).await;
    }
    assert!(
        closed_by_server(&mut stray).await,
        "the stray was not refused"
    );
    // The tracker goes on; the hub saw no button at all.
    for f in frames_with_buttons(6, 5, 0) {
        tracker.write_all(&f).await.unwrap();
    }
    let st = wait_for(&mut wand, "tracker frame 10", |s| s.frame == 10).await;
    assert_eq!(st.buttons, 0);
    while let Ok(e) = events.try_recv() {
        assert!(
            !matches!(e, tracking::hub::TrackingEvent::Button { .. }),
            "a refused peer pressed a button: {e:?}"
        );
    }
    let stats = running.hub.source_stats(running.sources[0]).unwrap();
    assert_eq!(stats.refused, 1);
    assert_eq!(stats.connections, 1);
    assert!(stats.connected);
}

/// Regression (issue 15, item 6): four loopback connections sending one tiny frame a
/// second held every slot of a listening source and locked out the real tracker. With
/// an allow-list, peers from other addresses are refused before they take a slot; the
/// tracker (here from 127.0.0.2) still gets in and its frames are applied.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn peers_off_the_allow_list_cannot_take_the_trackers_slot() {
    let mut config = cfg(listen_any());
    config.allow = vec!["127.0.0.2".parse().unwrap()];
    // Loopback passes an allow-list by default (issue 31, item 11); here the strays
    // are loopback peers, so the list must hold without that exception.
    config.allow_loopback = false;
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let mut strays = Vec::new();
    for k in 0..4 {
        let mut s = TcpStream::connect(addr).await.unwrap();
        let _ = s.write_all(&frames_with_buttons(k + 1, 1, 0)[0]).await;
        strays.push(s);
    }
    for s in &mut strays {
        assert!(closed_by_server(s).await, "a stray kept its connection");
    }
    let socket = tokio::net::TcpSocket::new_v4().unwrap();
    socket.bind("127.0.0.2:0".parse().unwrap()).unwrap();
    let mut tracker = socket.connect(addr).await.unwrap();
    for f in frames_with_buttons(1, 10, 0) {
        tracker.write_all(&f).await.unwrap();
    }
    wait_for(&mut wand, "tracker frame 10", |s| s.frame == 10).await;
    let stats = running.hub.source_stats(running.sources[0]).unwrap();
    assert_eq!(stats.refused, 4);
    assert_eq!(stats.connections, 1);
    assert_eq!(stats.frames, 10, "nothing a stray sent was applied");
}

/// Regression (issue 15, item 6): a UDP source took datagrams from anyone, so a second
/// local sender could interleave frames with the tracker's. It now takes one peer at a
/// time (and only allowed ones).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_udp_source_takes_datagrams_from_one_peer_only() {
    let running = start(&cfg(SourceConfig::Udp {
        addr: "127.0.0.1:0".parse().unwrap(),
    }))
    .await
    .unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let tracker = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let stray = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let frames = frames_with_buttons(1, 6, 0);
    tracker.send_to(&frames[0], addr).await.unwrap();
    wait_for(&mut wand, "frame 1", |s| s.frame == 1).await;
    for f in frames_with_buttons(1_000, 3, 1 << 3) {
        stray.send_to(&f, addr).await.unwrap();
    }
    for f in &frames[1..] {
        tracker.send_to(f, addr).await.unwrap();
    }
    let st = wait_for(&mut wand, "frame 6", |s| s.frame == 6).await;
    assert_eq!(st.buttons, 0);
    let stats = running.hub.source_stats(running.sources[0]).unwrap();
    assert_eq!(stats.refused, 3);
    assert_eq!(stats.frames, 6);
}
