//! The `[tracking.playback]` sources in headless mode: a pose-log file and the tracker
//! simulator, played in real time into the hub, through the frame subscription and the
//! frame stage, into the session.

use std::path::{Path, PathBuf};
use std::process::Command;

use sculpt_core::oplog::{EventKind, decode_bytes};
use sculpt_core::sculpt::document::Document;
use tracking::poselog::PoseLog;
use vr_app::config::Config;
use vr_app::feeder::Feeder;
use vr_app::headless::Input;
use vr_app::journal::Journal;
use vr_app::session::{DOCUMENT_FILE, JOURNAL_FILE, OPLOG_FILE, Session};

fn session_log(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/sessions")
        .join(format!("{name}.poselog"))
}

fn run_headless(dir: &Path, tracking: &str) -> (PathBuf, String) {
    let config = dir.join("wandsculpt.toml");
    std::fs::write(
        &config,
        format!(
            "[display]\nmode = \"mono\"\nwidth = 96\nheight = 54\n\n[tracking]\nwand = \"wand0\"\nhead = \"body0\"\n{tracking}"
        ),
    )
    .unwrap();
    let out = dir.join("session");
    let output = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--headless")
        .arg("--config")
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .args(["--idle-exit", "5", "--duration", "120"])
        .env("WANDSCULPT_ADAPTER", "llvmpipe")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    assert!(output.status.success(), "wandsculpt failed:\n{stderr}");
    (out, stderr)
}

/// The same log fed offline, frame by frame, through the same stage and session.
fn offline_document(log: &Path, dir: &Path) -> Vec<u8> {
    let mut cfg = Config::from_toml_str(
        "[tracking]\nwand = \"wand0\"\nhead = \"body0\"\n[tracking.playback]\nkind = \"sim\"\n",
    )
    .unwrap();
    cfg.files.dir = dir.to_path_buf();
    let mut feeder = Feeder::for_config(&cfg).unwrap();
    let mut session = Session::open(&cfg).unwrap();
    let (frames, _) = PoseLog::read(log).unwrap().frames();
    let mut last_t = 0.0;
    for f in frames {
        feeder.feed(&Input::Frame(f), &mut session).unwrap();
        last_t = feeder.stage().time().unwrap_or(last_t);
    }
    session.tick(last_t + 10.0).unwrap();
    session.doc.to_json()
}

#[test]
fn a_pose_log_played_live_builds_the_offline_document() {
    let dir = tempfile::tempdir().unwrap();
    let log = session_log("patch-carve");
    let (out, stderr) = run_headless(
        dir.path(),
        &format!(
            "[tracking.playback]\nkind = \"poselog\"\npath = \"{}\"\nspeed = 3.0\n",
            log.display()
        ),
    );
    let live = std::fs::read(out.join(DOCUMENT_FILE)).unwrap();
    let doc = Document::from_json(&live).unwrap();
    assert_eq!(doc.strokes().len(), 3, "{stderr}");
    let expected = offline_document(&log, &dir.path().join("offline"));
    assert!(
        live == expected,
        "live and offline documents differ\n{stderr}"
    );
}

#[test]
fn the_simulator_plays_its_built_in_stroke() {
    let dir = tempfile::tempdir().unwrap();
    let (out, stderr) = run_headless(
        dir.path(),
        "[tracking.playback]\nkind = \"sim\"\nspeed = 2.0\nconfig = { rate_hz = 90.0 }\n",
    );
    let doc = Document::from_json(&std::fs::read(out.join(DOCUMENT_FILE)).unwrap()).unwrap();
    assert_eq!(doc.strokes().len(), 1, "{stderr}");
    let journal = Journal::read(out.join(JOURNAL_FILE)).unwrap();
    assert_eq!(journal.len(), 1);
    let oplog = decode_bytes(&std::fs::read(out.join(OPLOG_FILE)).unwrap()).unwrap();
    assert_eq!(oplog.header.source.as_deref(), Some("wandsculpt"));
    let kinds: Vec<&EventKind> = oplog.events.iter().map(|e| &e.kind).collect();
    assert!(kinds.contains(&&EventKind::StrokeStart) && kinds.contains(&&EventKind::StrokeEnd));
    assert!(
        kinds
            .iter()
            .filter(|k| matches!(k, EventKind::Pose { .. }))
            .count()
            > 50,
        "every frame reaches the interaction"
    );
}
