//! Issue 31, item 11: who may feed a listening tracking port, with real loopback
//! sockets. A squatter that keeps reconnecting cannot lock the tracker out; a wrong
//! shared secret is refused; a peer sending nothing plausible is dropped; the
//! allow-list works on loopback.

use glam::DVec3;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::watch;
use tracking::DeviceId;
use tracking::config::{SourceConfig, TrackingConfig};
use tracking::hub::DeviceState;
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::transport::{Running, hello_line, start};

const PATIENCE: Duration = Duration::from_secs(20);

/// `n` frames of the simulator (wand0 and the head body0 at 60 Hz, with `ts`),
/// numbered from `first`, as DTrack2 bytes.
fn tracker_frames(first: u64, n: usize) -> Vec<Vec<u8>> {
    let script = Script::new(DVec3::new(0.0, 1.0, 0.0)).hold(n as f64 / 60.0 + 1.0);
    let sim = Simulator::new(
        &script,
        SimConfig {
            rate_hz: 60.0,
            ..SimConfig::default()
        },
    )
    .unwrap();
    sim.take(n)
        .enumerate()
        .map(|(k, mut f)| {
            f.number = first + k as u64;
            let mut bytes = Vec::new();
            tracking::dtrack::encode_frame(&f, &mut bytes);
            bytes
        })
        .collect()
}

fn listen_config() -> TrackingConfig {
    TrackingConfig {
        sources: vec![SourceConfig::TcpListen {
            addr: "127.0.0.1:0".parse().unwrap(),
        }],
        ..TrackingConfig::default()
    }
}

async fn wait_for(
    rx: &mut watch::Receiver<DeviceState>,
    what: &str,
    pred: impl Fn(&DeviceState) -> bool,
) -> DeviceState {
    let got = tokio::time::timeout(PATIENCE, rx.wait_for(|s| pred(s)))
        .await
        .map(|r| r.map(|s| s.clone()));
    match got {
        Ok(Ok(s)) => s,
        _ => panic!("timed out waiting for {what}; last state {:?}", rx.borrow()),
    }
}

/// Whether the server closed `s` (reads end or fail within the patience).
async fn closed_by_server(s: &mut TcpStream) -> bool {
    let mut buf = [0u8; 64];
    loop {
        match tokio::time::timeout(PATIENCE, s.read(&mut buf)).await {
            Ok(Ok(0) | Err(_)) => return true,
            Ok(Ok(_)) => {}
            Err(_) => return false,
        }
    }
}

/// Sends `frames` to `addr` (after `hello`, if any) and returns the stream.
async fn send(addr: std::net::SocketAddr, hello: Option<&[u8]>, frames: &[Vec<u8>]) -> TcpStream {
    let mut s = TcpStream::connect(addr).await.unwrap();
    if let Some(h) = hello {
        s.write_all(h).await.unwrap();
    }
    for f in frames {
        // A refused peer may see its writes fail; that is the point.
        if s.write_all(f).await.is_err() {
            break;
        }
    }
    s
}

fn stats(running: &Running) -> tracking::hub::SourceStats {
    running.hub.source_stats(running.sources[0]).unwrap()
}

/// Regression (issue 31, items 3 and 11): four idle connections opened before the
/// tracker held the one slot of a listening source until the read timeout (2 s), and a
/// squatter reconnecting in a loop kept the tracker out for good (0 strokes); the
/// frames the tracker sent meanwhile were lost. Peers are now identified concurrently
/// and the first plausible one gets the slot: the tracker's every frame is applied.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_squatter_that_keeps_reconnecting_cannot_lock_the_tracker_out() {
    let running = start(&listen_config()).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let mut idle = Vec::new();
    for _ in 0..4 {
        idle.push(TcpStream::connect(addr).await.unwrap());
    }
    let squatter = tokio::spawn(async move {
        loop {
            if let Ok(mut s) = TcpStream::connect(addr).await {
                let _ = s.write_all(b"hello?\r\n").await;
                tokio::time::sleep(Duration::from_millis(30)).await;
            }
        }
    });
    tokio::time::sleep(Duration::from_millis(100)).await;
    let frames = tracker_frames(1, 60);
    let mut tracker = send(addr, None, &frames[..30]).await;
    wait_for(&mut wand, "tracker frame 30", |s| s.frame == 30).await;
    for f in &frames[30..] {
        tracker.write_all(f).await.unwrap();
    }
    wait_for(&mut wand, "tracker frame 60", |s| s.frame == 60).await;
    squatter.abort();
    let st = stats(&running);
    assert_eq!(st.frames, 60, "every tracker frame is applied: {st:?}");
    assert_eq!(st.connections, 1, "only the tracker fed the source: {st:?}");
    for s in &mut idle {
        assert!(
            closed_by_server(s).await,
            "an idle peer kept its connection"
        );
    }
    assert!(stats(&running).refused >= 4);
}

/// A source with a shared secret: a peer with a wrong secret (or none) is closed,
/// counted and never applied; the tracker with the right one gets in.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wrong_secret_is_refused_and_the_right_one_admitted() {
    let mut config = listen_config();
    config.secret = Some("lab-wall-7".into());
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let frames = tracker_frames(1, 10);
    let mut wrong = send(addr, Some(&hello_line("lab-wall-8")), &frames).await;
    assert!(closed_by_server(&mut wrong).await, "a wrong secret got in");
    let mut none = send(addr, None, &frames).await;
    assert!(closed_by_server(&mut none).await, "no hello got in");
    assert_eq!(
        stats(&running).frames,
        0,
        "a refused peer's frame was applied"
    );
    assert_eq!(stats(&running).refused, 2);
    let _tracker = send(addr, Some(&hello_line("lab-wall-7")), &frames).await;
    wait_for(&mut wand, "tracker frame 10", |s| s.frame == 10).await;
    let st = stats(&running);
    assert_eq!((st.frames, st.connections), (10, 1), "{st:?}");
}

/// A source that expects the wand and the head at 60 Hz drops a peer that sends
/// frames without them, and one whose `ts` runs at 1 Hz, within its identification
/// time (the outcome is checked, not the speed); the real tracker gets in after them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_implausible_peer_is_dropped_and_the_tracker_admitted() {
    let mut config = listen_config();
    config.expect.devices = vec!["wand0".into(), "body0".into()];
    config.expect.rate_hz = 60.0;
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    // Valid DTrack2, but only a body 5, never the wand.
    let stranger: Vec<Vec<u8>> = (1..=30)
        .map(|n| {
            format!(
                "fr {n}\r\nts {:.3}\r\n6d 1 [5 1.000][0 0 0][1 0 0 0 1 0 0 0 1]\r\n\r\n",
                n as f64 / 60.0
            )
            .into_bytes()
        })
        .collect();
    let mut a = send(addr, None, &stranger).await;
    // The right devices, at one frame a second by their `ts`.
    let slow: Vec<Vec<u8>> = tracker_frames(1, 30)
        .into_iter()
        .enumerate()
        .map(|(k, f)| {
            let text = String::from_utf8(f).unwrap();
            let ts_line = text
                .lines()
                .find(|l| l.starts_with("ts "))
                .unwrap()
                .to_string();
            text.replace(&ts_line, &format!("ts {}.000000", k))
                .into_bytes()
        })
        .collect();
    let mut b = send(addr, None, &slow).await;
    assert!(
        closed_by_server(&mut a).await,
        "the stranger was not dropped"
    );
    assert!(
        closed_by_server(&mut b).await,
        "the 1 Hz peer was not dropped"
    );
    let st = stats(&running);
    assert_eq!((st.frames, st.refused), (0, 2), "{st:?}");
    let frames = tracker_frames(1, 20);
    let _tracker = send(addr, None, &frames).await;
    wait_for(&mut wand, "tracker frame 20", |s| s.frame == 20).await;
    assert_eq!(stats(&running).frames, 20);
}

/// Regression (issue 31, item 11, UDP): a UDP source took the first sender as its peer
/// for as long as it kept sending, so a squatter sending garbage every 20 ms held the
/// port and the tracker's frames were all refused (0 applied). UDP peers are now
/// identified like TCP ones: garbage, and frames without the expected devices, never
/// identify, and the tracker's every frame is applied.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_udp_squatter_cannot_hold_the_port() {
    let mut config = TrackingConfig {
        sources: vec![SourceConfig::Udp {
            addr: "127.0.0.1:0".parse().unwrap(),
        }],
        ..TrackingConfig::default()
    };
    config.expect.devices = vec!["wand0".into(), "body0".into()];
    config.expect.rate_hz = 60.0;
    let running = start(&config).await.unwrap();
    let addr = running.local_addrs[0].unwrap();
    let mut wand = running.hub.watch(DeviceId::Wand(0));
    let squatter = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let stranger = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let noise = tokio::spawn(async move {
        for n in 1u64.. {
            let _ = squatter.send_to(b"hello?\r\n", addr).await;
            // Valid DTrack2, but only a body 5, never the wand.
            let frame = format!("fr {n}\r\n6d 1 [5 1.000][0 0 0][1 0 0 0 1 0 0 0 1]\r\n\r\n");
            let _ = stranger.send_to(frame.as_bytes(), addr).await;
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });
    tokio::time::sleep(Duration::from_millis(100)).await;
    let tracker = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    for f in tracker_frames(1, 40) {
        tracker.send_to(&f, addr).await.unwrap();
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    wait_for(&mut wand, "tracker frame 40", |s| s.frame == 40).await;
    noise.abort();
    let st = stats(&running);
    assert_eq!(st.frames, 40, "every tracker frame is applied: {st:?}");
    assert_eq!(st.connections, 1, "only the tracker fed the source: {st:?}");
    assert!(st.refused >= 2, "the squatters were refused: {st:?}");
}

/// Regression (issue 31, item 11): `allow = ["10.9.9.9"]` refused every loopback
/// peer, so an allow-list could not be used with a local tracker emulator. Loopback
/// now passes unless `allow_loopback = false`, and entries may be CIDR blocks.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_allow_list_works_on_loopback() {
    let frames = tracker_frames(1, 5);
    let cases: [(&str, bool, bool); 4] = [
        (r#"allow = ["10.9.9.9"]"#, true, true),
        (
            r#"allow = ["10.9.9.9"]
allow_loopback = false"#,
            false,
            false,
        ),
        (
            r#"allow = ["10.9.0.0/16", "127.0.0.0/8"]
allow_loopback = false"#,
            false,
            true,
        ),
        (
            r#"allow = ["127.0.0.2/32"]
allow_loopback = false"#,
            false,
            false,
        ),
    ];
    for (toml, loopback, admitted) in cases {
        let text = format!("{toml}\n[[source]]\nkind = \"tcp-listen\"\naddr = \"127.0.0.1:0\"\n");
        let config = TrackingConfig::from_toml_str(&text).unwrap();
        assert_eq!(config.allow_loopback, loopback, "{toml}");
        let running = start(&config).await.unwrap();
        let addr = running.local_addrs[0].unwrap();
        let mut wand = running.hub.watch(DeviceId::Wand(0));
        let mut s = send(addr, None, &frames).await;
        if admitted {
            wait_for(&mut wand, "frame 5", |s| s.frame == 5).await;
        } else {
            assert!(
                closed_by_server(&mut s).await,
                "{toml}: a loopback peer got in"
            );
            let st = stats(&running);
            assert_eq!((st.frames, st.refused), (0, 1), "{toml}: {st:?}");
        }
    }
}

mod parsers {
    use proptest::prelude::*;
    use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};
    use tracking::config::{AllowEntry, check_hello, hello_from_secret_text, hello_line};

    proptest! {
        /// Any text parses to an entry or a clear error, never a panic.
        #[test]
        fn allow_entries_never_panic(text in ".{0,60}") {
            let _ = text.parse::<AllowEntry>();
        }

        /// An entry prints and parses back to itself, and holds its own address; an
        /// address differing in the first bit is outside every prefix longer than 0.
        #[test]
        fn allow_entries_round_trip(bits in any::<u32>(), prefix in 0u8..=32, v6 in any::<u128>(), p6 in 0u8..=128) {
            for (addr, prefix) in [
                (IpAddr::V4(Ipv4Addr::from(bits)), prefix),
                (IpAddr::V6(Ipv6Addr::from(v6)), p6),
            ] {
                let e: AllowEntry = format!("{addr}/{prefix}").parse().unwrap();
                prop_assert_eq!(e.to_string().parse::<AllowEntry>().unwrap(), e);
                prop_assert!(e.contains(addr));
                let flipped = match addr {
                    IpAddr::V4(a) => IpAddr::V4(Ipv4Addr::from(u32::from(a) ^ (1 << 31))),
                    IpAddr::V6(a) => IpAddr::V6(Ipv6Addr::from(u128::from(a) ^ (1 << 127))),
                };
                prop_assert_eq!(e.contains(flipped), prefix == 0);
            }
        }

        /// Any line is checked without a panic; the right hello passes and any other
        /// secret fails.
        #[test]
        fn hello_lines(line in prop::collection::vec(any::<u8>(), 0..300), secret in "[!-~]{1,40}", other in "[!-~]{1,40}") {
            let _ = check_hello(&line, secret.as_bytes());
            prop_assert!(check_hello(&hello_line(&secret), secret.as_bytes()).is_ok());
            prop_assert_eq!(
                check_hello(&hello_line(&other), secret.as_bytes()).is_ok(),
                other == secret
            );
        }

        /// A secret file's text never panics; a valid first line (surrounding blanks
        /// trimmed) gives the hello its secret passes, anything else is refused.
        #[test]
        fn secret_files(text in "\\PC{0,80}", secret in "[!-~]{1,40}", pad in "[ \t]{0,3}") {
            match hello_from_secret_text(&text) {
                Ok(line) => prop_assert!(check_hello(&line, text.lines().next().unwrap().trim().as_bytes()).is_ok()),
                Err(_) => prop_assert!(!tracking::config::valid_secret(text.lines().next().unwrap_or("").trim())),
            }
            let file = format!("{pad}{secret}{pad}\nsecond line\n");
            let line = hello_from_secret_text(&file).unwrap();
            prop_assert!(check_hello(&line, secret.as_bytes()).is_ok());
        }
    }

    #[test]
    fn malformed_entries_say_why() {
        assert!(
            "10.0.0.0/33"
                .parse::<AllowEntry>()
                .unwrap_err()
                .to_string()
                .contains("/33")
        );
        assert!(
            "lab-wall"
                .parse::<AllowEntry>()
                .unwrap_err()
                .to_string()
                .contains("lab-wall")
        );
        let e: AllowEntry = "::ffff:10.1.2.3".parse().unwrap();
        assert!(
            e.contains("10.1.2.3".parse().unwrap()),
            "IPv4-mapped peers match"
        );
    }
}
