//! The `replay` binary end to end: byte-identical outputs, `--check`, and the
//! tracking-server emulation over real loopback TCP and a real pty pair.

use std::io::{BufRead, BufReader, Read};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use tracking::poselog::{PoseLog, RecordKind};

fn session(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../tests/data/sessions/{name}.poselog"))
}

fn replay() -> Command {
    Command::new(env!("CARGO_BIN_EXE_replay"))
}

/// The DTrack2 bytes of a session, concatenated, as a tracking server sends them.
fn dtrack_stream(name: &str) -> Vec<u8> {
    let log = PoseLog::from_bytes(&std::fs::read(session(name)).unwrap()).unwrap();
    log.records
        .iter()
        .filter(|r| r.kind == RecordKind::DTrack)
        .flat_map(|r| r.bytes.clone())
        .collect()
}

fn run_to(dir: &Path, name: &str) {
    let status = replay()
        .arg(session(name))
        .arg("--out")
        .arg(dir)
        .arg("-q")
        .status()
        .unwrap();
    assert!(status.success());
}

#[test]
fn the_same_log_gives_byte_identical_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["patch-carve-reordered", "sketch-carve"] {
        let (a, b) = (
            tmp.path().join(format!("{name}-a")),
            tmp.path().join(format!("{name}-b")),
        );
        run_to(&a, name);
        run_to(&b, name);
        for file in replay::output::DETERMINISTIC_FILES {
            let x = std::fs::read(a.join(file)).unwrap();
            let y = std::fs::read(b.join(file)).unwrap();
            assert!(!x.is_empty(), "{name}/{file} is empty");
            assert!(x == y, "{name}/{file} differs between two runs");
        }
        // The exports read back with their own readers.
        let obj =
            sculpt_core::formats::obj::read(&std::fs::read(a.join("scene.obj")).unwrap()).unwrap();
        assert!(!obj.triangles.is_empty());
        let glb =
            sculpt_core::formats::glb::read(&std::fs::read(a.join("scene.glb")).unwrap()).unwrap();
        assert_eq!(glb.triangles.len(), obj.triangles.len());
        sculpt_core::formats::iges::read(&std::fs::read(a.join("scene.igs")).unwrap()).unwrap();
        let ops = sculpt_core::oplog::decode_bytes(&std::fs::read(a.join("operator.log")).unwrap())
            .unwrap();
        assert!(ops.events.len() > 100);
    }
}

#[test]
fn check_passes_on_a_match_and_prints_a_readable_diff_on_a_mismatch() {
    let tmp = tempfile::tempdir().unwrap();
    let good = tmp.path().join("good.json");
    std::fs::write(
        &good,
        r#"{"gestures": {"strokes_applied": 3}, "frames": {"out_of_order": {"min": 1}}}"#,
    )
    .unwrap();
    let bad = tmp.path().join("bad.json");
    std::fs::write(
        &bad,
        r#"{"gestures": {"strokes_applied": 4}, "targets": 1}"#,
    )
    .unwrap();
    let run = |expect: &Path| {
        replay()
            .arg(session("patch-carve-reordered"))
            .arg("--out")
            .arg(tmp.path().join("out"))
            .arg("--check")
            .arg(expect)
            .arg("-q")
            .output()
            .unwrap()
    };
    let ok = run(&good);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let fail = run(&bad);
    assert_eq!(fail.status.code(), Some(2));
    let err = String::from_utf8_lossy(&fail.stderr);
    assert!(
        err.contains("gestures.strokes_applied: expected 4, got 3"),
        "{err}"
    );
    assert!(!err.contains("targets"), "{err}");
}

#[test]
fn bad_inputs_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let junk = tmp.path().join("junk.poselog");
    std::fs::write(&junk, "not a pose log\n").unwrap();
    let out = replay()
        .arg(&junk)
        .arg("--out")
        .arg(tmp.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("replay: error"));
    let cfg = tmp.path().join("bad.toml");
    std::fs::write(&cfg, "[tool]\ndepth = 0.0\n").unwrap();
    let out = replay()
        .arg(session("patch-carve"))
        .arg("--config")
        .arg(&cfg)
        .arg("--out")
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("tool depth"));
}

/// Kills the child when the test ends, pass or fail.
struct Reap(Child);

impl Drop for Reap {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn serve_sends_the_raw_frames_over_loopback_tcp() {
    let mut child = Reap(
        replay()
            .arg(session("patch-overlaps"))
            .args(["--serve", "tcp://127.0.0.1:0", "--speed", "0", "-q"])
            .stdout(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut lines = BufReader::new(child.0.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let addr = first
        .strip_prefix("listening on tcp://")
        .unwrap_or_else(|| panic!("{first}"));
    let mut got = Vec::new();
    TcpStream::connect(addr)
        .unwrap()
        .read_to_end(&mut got)
        .unwrap();
    assert!(
        got == dtrack_stream("patch-overlaps"),
        "the stream differs from the log's frames"
    );
    assert!(child.0.wait().unwrap().success());
    let summary = lines.next().unwrap().unwrap();
    assert!(summary.contains("0 missed"), "{summary}");
}

#[test]
fn connect_and_serial_send_the_same_bytes() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let mut child = Reap(
        replay()
            .arg(session("patch-overlaps"))
            .args(["--connect", &format!("tcp://{addr}"), "--speed", "0", "-q"])
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let (mut s, _) = listener.accept().unwrap();
    let mut got = Vec::new();
    s.read_to_end(&mut got).unwrap();
    assert!(got == dtrack_stream("patch-overlaps"));
    assert!(child.0.wait().unwrap().success());

    // A real pty pair from socat (CI installs it).
    let mut socat = Reap(
        Command::new("socat")
            .args(["-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"])
            .stderr(Stdio::piped())
            .spawn()
            .expect("socat is needed for the serial test (apt-get install socat)"),
    );
    let mut err = BufReader::new(socat.0.stderr.take().unwrap());
    let mut ptys = Vec::new();
    let mut line = String::new();
    while ptys.len() < 2 && err.read_line(&mut line).unwrap() > 0 {
        if let Some(p) = line
            .trim()
            .rsplit(' ')
            .next()
            .filter(|p| p.starts_with("/dev/"))
        {
            ptys.push(p.to_string());
        }
        line.clear();
    }
    let reader_path = ptys[1].clone();
    let expected = dtrack_stream("patch-overlaps");
    let n = expected.len();
    let reader = std::thread::spawn(move || {
        let mut f = std::fs::File::open(reader_path).unwrap();
        let mut got = vec![0u8; n];
        f.read_exact(&mut got).unwrap();
        got
    });
    let status = replay()
        .arg(session("patch-overlaps"))
        .args([
            "--serve",
            &format!("serial://{}", ptys[0]),
            "--speed",
            "0",
            "-q",
        ])
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    assert!(
        reader.join().unwrap() == expected,
        "the pty carried different bytes"
    );
}

#[test]
fn render_writes_decodable_stereo_pairs_at_the_chosen_times() {
    let dir = tempfile::tempdir().unwrap();
    let out = replay()
        .arg(session("patch-carve"))
        .arg("--out")
        .arg(dir.path())
        .args(["--render", "5.0,2.5", "--render-size", "160x90", "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let load = |t: &str, eye: &str| {
        image::open(dir.path().join(format!("render-{t}-{eye}.png")))
            .unwrap_or_else(|e| panic!("render-{t}-{eye}.png: {e}"))
            .to_rgba8()
    };
    let (l1, r1) = (load("2.500", "left"), load("2.500", "right"));
    let (l2, r2) = (load("5.000", "left"), load("5.000", "right"));
    assert_eq!(l1.dimensions(), (160, 90));
    assert_eq!(r2.dimensions(), (160, 90));
    assert_ne!(
        l1.as_raw(),
        r1.as_raw(),
        "head-tracked stereo: the eyes differ"
    );
    assert_ne!(l2.as_raw(), r2.as_raw());
    // Between 2.5 s and 5 s a groove was carved: the picture changed.
    assert_ne!(l1.as_raw(), l2.as_raw());
    // The session's scratch directory is gone.
    assert!(!dir.path().join(".render-session").exists());
    // Bad times are a clear error.
    let bad = replay()
        .arg(session("patch-carve"))
        .arg("--out")
        .arg(dir.path())
        .args(["--render", "soon", "-q"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("soon"));
}

/// `replay SESSION --connect tcp://ADDR --speed 0 --wait 2 -q`: exit status and stdout.
fn connect_to(addr: std::net::SocketAddr) -> (bool, String) {
    let out = replay()
        .arg(session("patch-overlaps"))
        .args(["--connect", &format!("tcp://{addr}"), "--speed", "0"])
        .args(["--wait", "2", "-q"])
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

/// Regression (issue 15, item 5): a receiver whose slots were full accepted and closed
/// every connection, and `replay --connect` still said `sent 451 records` and exited 0.
/// It now says the receiver did not take the data, and fails.
#[test]
fn connect_to_a_receiver_that_refuses_every_connection_fails() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stop_flag = stop.clone();
    // Like a display server with no free slot: accept, then close at once.
    let refuser = std::thread::spawn(move || {
        let mut refused = 0;
        for s in listener.incoming() {
            if stop_flag.load(std::sync::atomic::Ordering::Relaxed) {
                break;
            }
            drop(s);
            refused += 1;
        }
        refused
    });
    let (ok, stdout) = connect_to(addr);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    drop(TcpStream::connect(addr)); // wakes the refuser to see the stop
    assert!(refuser.join().unwrap() >= 1);
    assert!(!ok, "exit status 0 although nothing was taken: {stdout}");
    assert!(
        stdout.contains("the receiver did not take the data"),
        "{stdout}"
    );
}

/// Regression (issue 15, item 5): a receiver that exits (a full disk) with the stream
/// half read was reported as a success. Its reset is now a failure.
#[test]
fn connect_to_a_receiver_that_exits_mid_stream_fails() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let receiver = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut first = [0u8; 100];
        s.read_exact(&mut first).unwrap();
        // Wait until more is queued, then go away with it unread.
        std::thread::sleep(std::time::Duration::from_millis(300));
        drop(s);
        drop(listener);
    });
    let (ok, stdout) = connect_to(addr);
    receiver.join().unwrap();
    assert!(!ok, "exit status 0 although the receiver left: {stdout}");
    assert!(stdout.contains("did not take"), "{stdout}");
}

/// The positive case: a receiver that reads the stream to its end and closes is
/// reported as such (and the report says DTrack2 cannot confirm more).
#[test]
fn connect_to_a_receiver_that_reads_everything_reports_it() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let receiver = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut got = Vec::new();
        s.read_to_end(&mut got).unwrap();
        got
    });
    let (ok, stdout) = connect_to(addr);
    assert_eq!(receiver.join().unwrap(), dtrack_stream("patch-overlaps"));
    assert!(ok, "{stdout}");
    assert!(
        stdout.contains("the receiver read the stream to its end"),
        "{stdout}"
    );
}

/// Regression (issue 15, item 7): `--out /etc/hostname` said only "File exists".
#[test]
fn an_out_path_that_is_a_file_says_it_is_not_a_directory() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("hostname");
    std::fs::write(&file, b"x").unwrap();
    let out = replay()
        .arg(session("patch-overlaps"))
        .arg("--out")
        .arg(&file)
        .arg("-q")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("exists and is not a directory"), "{err}");
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
}

/// Issue 19: replay's operator log is cut into one segment per interaction mode, as the
/// display server's is (it used to keep the start mode's segment after a switch, so
/// `goms` counted sketching as carving). Every mode switch starts a segment naming the
/// new mode at the switch's time, and every event lies in a segment.
#[test]
fn regression_the_plain_log_follows_mode_switches() {
    use sculpt_core::oplog::EventKind;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("sketch-carve");
    run_to(&dir, "sketch-carve");
    let log = sculpt_core::oplog::decode_bytes(&std::fs::read(dir.join("operator.log")).unwrap())
        .unwrap();
    let mut open: Option<String> = None;
    let mut methods = Vec::new();
    for e in &log.events {
        match &e.kind {
            EventKind::TrialStart { method, .. } => {
                open = method.clone();
                methods.push(method.clone().unwrap_or_default());
            }
            EventKind::TrialEnd { .. } => open = None,
            EventKind::Mode { mode } => {
                assert_eq!(open.as_deref(), Some(mode.as_str()), "at {}", e.t)
            }
            _ => assert!(open.is_some(), "an event outside a segment at {}", e.t),
        }
    }
    assert!(
        methods.iter().any(|m| m == "sketch") && methods.iter().any(|m| m == "carve"),
        "{methods:?}"
    );
}
