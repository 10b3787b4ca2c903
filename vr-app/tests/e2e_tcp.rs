//! End to end over real loopback TCP: a scripted tracker (the tracking crate's
//! simulator, DTrack2 ASCII) serves frames; `wandsculpt --headless` connects, carves a
//! stroke, and writes the journal, the document and the stereo PNGs.

use std::io::Write;
use std::net::TcpListener;
use std::process::Command;
use std::time::{Duration, Instant};

use glam::DVec3;
use sculpt_core::editor::default_surface_point;
use sculpt_core::oplog::{EventKind, decode_bytes};
use sculpt_core::sculpt::document::Document;
use tracking::sim::{Script, SimConfig, Simulator};
use vr_app::journal::Journal;
use vr_app::session::{DOCUMENT_FILE, JOURNAL_FILE, OPLOG_FILE};

#[test]
fn headless_carve_over_loopback_tcp() {
    let dir = tempfile::tempdir().unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let config = dir.path().join("wandsculpt.toml");
    std::fs::write(
        &config,
        format!(
            r#"
[display]
mode = "side-by-side"
width = 320
height = 180

[tracking]
wand = "wand0"
head = "body0"

[tracking.input]
lost_after_ms = 200

[[tracking.input.source]]
kind = "tcp-connect"
addr = "{addr}"
"#
        ),
    )
    .unwrap();
    let out = dir.path().join("session");
    let child = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--headless")
        .arg("--config")
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .args(["--idle-exit", "1.0", "--duration", "60"])
        .env("WANDSCULPT_ADAPTER", "llvmpipe")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();

    // The tracker: wait for the display server to connect, then play a carve stroke
    // in real time: hover, press, sweep 30 cm across the default surface, release.
    listener.set_nonblocking(true).unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let (mut stream, _) = loop {
        match listener.accept() {
            Ok(s) => break s,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                assert!(Instant::now() < deadline, "wandsculpt never connected");
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("{e}"),
        }
    };
    stream.set_nonblocking(false).unwrap();
    let from = default_surface_point(-0.15, 1.2);
    let to = default_surface_point(0.15, 1.18);
    let script = Script::new(from)
        .head_start(DVec3::new(0.05, 1.17, 0.6))
        .hold(0.3)
        .press(0)
        .move_to(to, 1.0)
        .release(0)
        .hold(0.3);
    let start = Instant::now();
    for frame in Simulator::new(&script, SimConfig::default()).unwrap() {
        let mut bytes = Vec::new();
        tracking::dtrack::encode_frame(&frame, &mut bytes);
        if let Some(wait) = frame.receive_time.checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
        stream.write_all(&bytes).unwrap();
    }
    drop(stream);
    drop(listener);

    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "wandsculpt failed:\n{stderr}");
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();

    // The journal holds the stroke, fsync'd, readable by its own reader.
    let journal = Journal::read(out.join(JOURNAL_FILE)).unwrap();
    let strokes: Vec<_> = journal
        .iter()
        .filter_map(|e| match &e.edit {
            sculpt_core::interaction::Edit::Stroke(s) => Some(s),
            _ => None,
        })
        .collect();
    assert_eq!(strokes.len(), 1, "journal: {journal:?}\n{stderr}");
    let s = strokes[0];
    assert_eq!(s.mode, sculpt_core::interaction::StrokeMode::Carve);
    let first = s.samples.first().unwrap().position;
    let last = s.samples.last().unwrap().position;
    // It spans (most of) the 30 cm sweep, in metres in the display frame.
    assert!(last.x - first.x > 0.25, "stroke from {first} to {last}");
    sculpt_core::assert_near!(first.z, from.z, 0.005);

    // The saved document has it too.
    let doc = Document::from_json(&std::fs::read(out.join(DOCUMENT_FILE)).unwrap()).unwrap();
    assert_eq!(doc.strokes().len(), 1, "{stderr}");
    let saved: Vec<(f64, DVec3)> = s.samples.iter().map(|p| (p.t, p.position)).collect();
    assert_eq!(doc.strokes()[0].input.samples, saved);
    assert_eq!(report["strokes"], 1);

    // The operator log (the GOMS harness's format) has the gesture.
    let oplog = decode_bytes(&std::fs::read(out.join(OPLOG_FILE)).unwrap()).unwrap();
    let kinds: Vec<&EventKind> = oplog.events.iter().map(|e| &e.kind).collect();
    assert!(kinds.contains(&&EventKind::StrokeStart), "{kinds:?}");
    assert!(kinds.contains(&&EventKind::StrokeEnd));

    // Stereo PNGs: two eye images that differ, and the side-by-side frame.
    let left = image::open(out.join("left.png")).unwrap().to_rgba8();
    let right = image::open(out.join("right.png")).unwrap().to_rgba8();
    let frame = image::open(out.join("frame.png")).unwrap().to_rgba8();
    assert_eq!(left.dimensions(), (160, 180));
    assert_eq!(frame.dimensions(), (320, 180));
    assert_ne!(
        left.as_raw(),
        right.as_raw(),
        "the eyes must differ (head-tracked stereo)"
    );
}

/// `--listen 127.0.0.1:0 --addr-file`: the display server listens on a free port,
/// says which, and finishes (saving) once its tracker has sent a session and gone.
#[test]
fn listening_on_an_ephemeral_port_and_finishing_when_the_tracker_leaves() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    let addr_file = dir.path().join("addr");
    let child = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--headless")
        .args(["--listen", "127.0.0.1:0", "--addr-file"])
        .arg(&addr_file)
        .arg("--out")
        .arg(&out)
        .args(["--size", "96x54", "--idle-exit", "30", "--duration", "60"])
        .env("WANDSCULPT_ADAPTER", "llvmpipe")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let addr = loop {
        if let Ok(text) = std::fs::read_to_string(&addr_file) {
            break text.trim().to_string();
        }
        assert!(Instant::now() < deadline, "no address file");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(
        addr.starts_with("127.0.0.1:") && !addr.ends_with(":0"),
        "{addr}"
    );
    // The whole session at once: times come from the frames' `ts`, not their arrival.
    let mut stream = std::net::TcpStream::connect(&addr).unwrap();
    let mut bytes = Vec::new();
    for frame in Simulator::new(&vr_app::live::builtin_script(), SimConfig::default()).unwrap() {
        tracking::dtrack::encode_frame(&frame, &mut bytes);
    }
    stream.write_all(&bytes).unwrap();
    drop(stream);
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("sources_gone=true"), "{stderr}");
    assert!(stderr.contains(&format!("listening on {addr}")), "{stderr}");
    let doc = Document::from_json(&std::fs::read(out.join(DOCUMENT_FILE)).unwrap()).unwrap();
    assert_eq!(doc.strokes().len(), 1, "{stderr}");
}

/// Regression (issue 15, item 6): anyone on the machine could drive the display
/// server. A stray loopback peer that sent one frame and closed ended a headless run
/// before the tracker came, and a second connection pressing button 3 undid the
/// sculptor's stroke. Now a peer that never sent the configured wand cannot end the
/// session, and a second peer is refused while the tracker is connected.
#[test]
fn stray_loopback_peers_neither_end_the_session_nor_undo_strokes() {
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    let addr_file = dir.path().join("addr");
    let child = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--headless")
        .args(["--listen", "127.0.0.1:0", "--addr-file"])
        .arg(&addr_file)
        .arg("--out")
        .arg(&out)
        .args(["--size", "96x54", "--idle-exit", "30", "--duration", "90"])
        .env("WANDSCULPT_ADAPTER", "llvmpipe")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let addr = loop {
        if let Ok(text) = std::fs::read_to_string(&addr_file) {
            break text.trim().to_string();
        }
        assert!(Instant::now() < deadline, "no address file");
        std::thread::sleep(Duration::from_millis(20));
    };
    // A stray peer first: one frame without the wand, then it closes. The display
    // server reads it to the end (our read sees its close) and must not finish.
    let mut stray = std::net::TcpStream::connect(&addr).unwrap();
    stray.write_all(b"fr 1\r\nts 0.0\r\n\r\n").unwrap();
    stray.shutdown(std::net::Shutdown::Write).unwrap();
    let mut rest = Vec::new();
    let _ = stray.read_to_end(&mut rest);
    drop(stray);
    // The tracker: the built-in session's frames up to the stroke's release...
    let frames: Vec<tracking::Frame> =
        Simulator::new(&vr_app::live::builtin_script(), SimConfig::default())
            .unwrap()
            .collect();
    let encode = |fs: &[tracking::Frame]| {
        let mut bytes = Vec::new();
        for f in fs {
            tracking::dtrack::encode_frame(f, &mut bytes);
        }
        bytes
    };
    let released = frames.len() - 10;
    let mut tracker = std::net::TcpStream::connect(&addr).unwrap();
    tracker.write_all(&encode(&frames[..released])).unwrap();
    // The tracker is connected once identified (tracking::transport: its frames are
    // read concurrently with other peers'); the second peer comes while it is, as in
    // the report. (Pacing only: nothing here is timed.)
    std::thread::sleep(Duration::from_millis(1500));
    // ...a second peer pressing button 3 (undo) with a newer counter: refused...
    let mut undo = frames[released].clone();
    undo.number += 1_000_000;
    for w in &mut undo.wands {
        w.buttons = 1 << 3;
    }
    let mut second = std::net::TcpStream::connect(&addr).unwrap();
    let _ = second.write_all(&encode(&[undo]));
    let mut rest = Vec::new();
    let _ = second.read_to_end(&mut rest);
    drop(second);
    // ...and the rest of the session.
    tracker.write_all(&encode(&frames[released..])).unwrap();
    drop(tracker);
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("sources_gone=true"), "{stderr}");
    assert!(stderr.contains("refusing tracking peer"), "{stderr}");
    let doc = Document::from_json(&std::fs::read(out.join(DOCUMENT_FILE)).unwrap()).unwrap();
    assert_eq!(
        doc.strokes().len(),
        1,
        "the tracker's stroke, not undone\n{stderr}"
    );
}
