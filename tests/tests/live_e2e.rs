//! End to end with real processes: `replay --serve` plays a shipped session as the
//! tracking server over loopback TCP into `wandsculpt --headless`, whose saved document
//! must equal the offline replay's `scene.json` byte for byte (both run
//! `tracking::stage::FrameStage` → `sculpt_core::interaction::Interaction` →
//! `sculpt_core::editor::apply`, with the frames' own DTrack times).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use tests::{ChildGuard, sessions_dir, workspace_bin};

/// Plenty for a few seconds of session, on a loaded 2-core CI machine.
const TIMEOUT: Duration = Duration::from_secs(120);

fn session(name: &str) -> PathBuf {
    sessions_dir().join(format!("{name}.poselog"))
}

/// `replay SESSION --out DIR`: the offline outputs.
fn offline(name: &str, dir: &Path) -> Vec<u8> {
    let status = Command::new(workspace_bin("replay", "replay"))
        .arg(session(name))
        .arg("--out")
        .arg(dir)
        .arg("-q")
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    std::fs::read(dir.join("scene.json")).unwrap()
}

/// `replay SESSION --serve tcp://127.0.0.1:0`, and the address it listens on.
fn serve_tcp(name: &str, speed: f64) -> (ChildGuard, String) {
    let mut child = ChildGuard::spawn(
        Command::new(workspace_bin("replay", "replay"))
            .arg(session(name))
            .args(["--serve", "tcp://127.0.0.1:0", "--wait", "60", "-q"])
            .args(["--speed", &speed.to_string()])
            .stdout(Stdio::piped()),
    );
    let mut stdout = BufReader::new(child.0.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    // Keep draining, so its closing summary never meets a closed pipe.
    std::thread::spawn(move || std::io::copy(&mut stdout, &mut std::io::sink()));
    let addr = line
        .trim()
        .strip_prefix("listening on tcp://")
        .unwrap_or_else(|| panic!("replay said {line:?}"))
        .to_string();
    (child, addr)
}

/// A headless display server config reading DTrack2 from `addr` (connecting out).
fn display_config(dir: &Path, addr: &str) -> PathBuf {
    let path = dir.join("wandsculpt.toml");
    std::fs::write(
        &path,
        format!(
            r#"
[display]
mode = "mono"
width = 160
height = 90

[tracking]
wand = "wand0"
head = "body0"

[[tracking.input.source]]
kind = "tcp-connect"
addr = "{addr}"
"#
        ),
    )
    .unwrap();
    path
}

fn wandsculpt(config: &Path, out: &Path) -> ChildGuard {
    ChildGuard::spawn(
        Command::new(workspace_bin("vr-app", "wandsculpt"))
            .arg("--headless")
            .arg("--config")
            .arg(config)
            .arg("--out")
            .arg(out)
            .args(["--idle-exit", "1.0", "--duration", "100"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    )
}

fn stderr_of(child: &mut ChildGuard) -> String {
    let mut s = String::new();
    if let Some(mut e) = child.0.stderr.take() {
        let _ = std::io::Read::read_to_string(&mut e, &mut s);
    }
    s
}

/// The first differing line of two JSON texts, with its number.
fn first_difference(live: &[u8], offline: &[u8]) -> String {
    let (a, b) = (
        String::from_utf8_lossy(live),
        String::from_utf8_lossy(offline),
    );
    let (la, lb): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    match la.iter().zip(&lb).position(|(x, y)| x != y) {
        Some(i) => format!(
            "line {}: live {:?}, offline {:?} ({} vs {} lines)",
            i + 1,
            la[i],
            lb[i],
            la.len(),
            lb.len()
        ),
        None => format!("{} vs {} lines", la.len(), lb.len()),
    }
}

#[test]
fn a_session_served_over_tcp_builds_the_offline_document() {
    let name = "patch-overlaps";
    let dir = tempfile::tempdir().unwrap();
    let expected = offline(name, &dir.path().join("offline"));
    // Three times real time: two seconds for this six-second session. The result does
    // not depend on the pacing (times come from the frames' `ts`).
    let (mut server, addr) = serve_tcp(name, 3.0);
    let live = dir.path().join("live");
    let mut app = wandsculpt(&display_config(dir.path(), &addr), &live);
    assert!(server.wait_for("replay --serve", TIMEOUT).success());
    let status = app.wait_for("wandsculpt", TIMEOUT);
    let log = stderr_of(&mut app);
    assert!(status.success(), "wandsculpt failed:\n{log}");
    let saved = std::fs::read(live.join(vr_app::session::DOCUMENT_FILE)).unwrap();
    assert!(
        saved == expected,
        "the live document differs from the offline scene.json: {}\n{log}",
        first_difference(&saved, &expected)
    );
}
