//! The journal rule (issue 31, item 1), through the real `wandsculpt` binary and the
//! library: a journal is never rewritten by a run that cannot use it, it names its
//! document and a mismatch is refused with one line leaving the file as it was, no file
//! is touched before the arguments are checked, and a journal of NUL bytes is not reset.
//! And item 3: an operator log that cannot be written fails the run.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use sculpt_core::editor;
use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample, Tool};
use vr_app::VrError;
use vr_app::config::Config;
use vr_app::error::JournalError;
use vr_app::journal::{HEADER_V1, Journal, JournalEntry};
use vr_app::session::{JOURNAL_FILE, OPLOG_FILE, Session};

fn wandsculpt(args: &[&str], out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .args(args)
        .arg("--out")
        .arg(out)
        .env("WANDSCULPT_ADAPTER", "llvmpipe")
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A headless demo session in `dir` (7 operations, 4 strokes of the default surface).
fn demo_session(dir: &Path) {
    let out = wandsculpt(&["--headless", "--demo", "--size", "64x36"], dir);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// Every file of `dir`, with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let bytes = std::fs::read(&p).unwrap_or_default();
            (p, bytes)
        })
        .collect();
    v.sort();
    v
}

/// A two-target scene file (the default surface and a second one).
fn two_target_scene(dir: &Path) -> PathBuf {
    let mut base = editor::default_document();
    base.add_target("second", editor::default_surface());
    let p = dir.join("two-targets.json");
    std::fs::write(&p, base.to_json()).unwrap();
    p
}

/// Regression (issue 31, item 1): the demo's journal opened with another `--scene`
/// printed "recovered 7 operations", applied none of its strokes and exited 0. The
/// journal names its document now: the run is refused with one line, and no file of
/// the session directory changes (no journal rewrite, no `operator.1.log`).
#[test]
fn another_documents_journal_is_refused_and_nothing_is_touched() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    demo_session(&session);
    let scene = two_target_scene(dir.path());
    let before = snapshot(&session);
    let out = wandsculpt(
        &[
            "--headless",
            "--scene",
            scene.to_str().unwrap(),
            "--size",
            "64x36",
        ],
        &session,
    );
    assert!(!out.status.success(), "{}", stderr(&out));
    let msg = stderr(&out);
    let lines: Vec<&str> = msg
        .lines()
        .filter(|l| l.starts_with("wandsculpt:"))
        .collect();
    assert_eq!(lines.len(), 1, "{msg}");
    assert!(lines[0].contains("another document"), "{msg}");
    assert!(lines[0].contains(JOURNAL_FILE), "{msg}");
    assert_eq!(snapshot(&session), before, "a file of the session changed");
    // The run with its own document still recovers every operation.
    let again = wandsculpt(&["--headless", "--demo", "--size", "64x36"], &session);
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(
        stderr(&again).contains("recovered 7 operations"),
        "{}",
        stderr(&again)
    );
}

/// Regression (issue 31, item 1): `--headless` with no input cut the journal's torn
/// tail and rotated `operator.log` before it refused to run. A usage error touches no
/// file now.
#[test]
fn a_usage_error_touches_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    demo_session(&session);
    // A torn final line, as a crash leaves it: a run that can use the journal cuts it.
    let journal = session.join(JOURNAL_FILE);
    let mut bytes = std::fs::read(&journal).unwrap();
    bytes.extend_from_slice(b"{\"seq\":7,\"t\":9.0,\"ed");
    std::fs::write(&journal, &bytes).unwrap();
    let before = snapshot(&session);
    let out = wandsculpt(&["--headless"], &session);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("needs an input"), "{}", stderr(&out));
    assert_eq!(snapshot(&session), before, "a file of the session changed");
}

/// Regression (issue 31, item 1): 5,000 NUL bytes as a journal were silently reset to
/// an empty journal. The run is refused and the file is left as it was.
#[test]
fn a_journal_of_nul_bytes_is_refused_not_reset() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    std::fs::create_dir_all(&session).unwrap();
    std::fs::write(session.join(JOURNAL_FILE), vec![0u8; 5000]).unwrap();
    let out = wandsculpt(&["--headless", "--demo", "--size", "64x36"], &session);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("left as it is"), "{}", stderr(&out));
    assert_eq!(
        std::fs::read(session.join(JOURNAL_FILE)).unwrap(),
        vec![0u8; 5000]
    );
    assert!(
        !session.join(OPLOG_FILE).exists(),
        "operator.log was started"
    );
}

/// Regression (issue 31, item 1): a version 1 journal (targets by position) opened
/// once without its `--scene` was rewritten with `"target": 18446744073709551615`, so
/// the right scene later recovered no stroke. It is refused unchanged now, and the
/// right scene still recovers it.
#[test]
fn a_version_1_journal_without_its_scene_is_refused_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let scene = two_target_scene(dir.path());
    let run = dir.path().join("run");
    std::fs::create_dir_all(&run).unwrap();
    // A stroke on position 1 (the second target), as version 1 wrote it.
    let samples = (0..=20)
        .map(|i| StrokeSample {
            t: f64::from(i) * 0.01,
            position: editor::default_surface_point(-0.2 + 0.02 * f64::from(i), 1.1),
        })
        .collect();
    let entry = JournalEntry {
        seq: 0,
        t: 0.2,
        edit: Edit::Stroke(StrokeEdit::new(1, Tool::default(), samples)),
    };
    let stroke = serde_json::to_string(&entry).unwrap();
    let journal = run.join(JOURNAL_FILE);
    std::fs::write(&journal, format!("{HEADER_V1}\n{stroke}\n")).unwrap();
    let before = std::fs::read(&journal).unwrap();
    let mut cfg = Config::default();
    cfg.files.dir = run.clone();
    let e = Session::open(&cfg).unwrap_err();
    assert!(
        matches!(
            e,
            VrError::Journal {
                reason: JournalError::UnknownTarget {
                    line: 2,
                    target: 1,
                    targets: 1
                },
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(
        std::fs::read(&journal).unwrap(),
        before,
        "the journal was rewritten"
    );
    assert!(!run.join(OPLOG_FILE).exists());
    cfg.files.scene = Some(scene);
    let s = Session::open(&cfg).unwrap();
    assert_eq!(s.recovered, 1);
    assert_eq!(s.doc.strokes().len(), 1, "the stroke was recovered");
    assert_eq!(Journal::read(&journal).unwrap().len(), 1);
}

/// Regression (issue 31, item 3): an operator log that could not be written
/// (`/dev/full`) left the run exiting 0 with `operator.log` listed as written. The
/// report lists it as failed now, and the run exits non-zero.
#[test]
fn an_operator_log_that_cannot_be_written_fails_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    std::fs::create_dir_all(&session).unwrap();
    std::os::unix::fs::symlink("/dev/full", session.join(OPLOG_FILE)).unwrap();
    let out = wandsculpt(&["--headless", "--demo", "--size", "64x36"], &session);
    assert!(
        !out.status.success(),
        "exit 0 after losing the operator log"
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let files = report["files"].as_array().unwrap();
    assert!(
        files
            .iter()
            .all(|f| !f.as_str().unwrap().ends_with(OPLOG_FILE)),
        "{report}"
    );
    assert!(
        report["failed"][0].as_str().unwrap().contains(OPLOG_FILE),
        "{report}"
    );
    assert!(stderr(&out).contains("lost data"), "{}", stderr(&out));
    // The journal, the record of truth, is whole.
    assert_eq!(Journal::read(session.join(JOURNAL_FILE)).unwrap().len(), 7);
}

/// Regression (issue 31, item 8): `--size 8192x8192 --mode dual` peaked at 12.7 GB.
/// A headless image is capped at 3840x2160 pixels; a larger size is refused with one
/// line before any file or the GPU is opened.
#[test]
fn a_headless_size_over_the_pixel_cap_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    let out = wandsculpt(
        &[
            "--headless",
            "--demo",
            "--mode",
            "dual",
            "--size",
            "8192x8192",
        ],
        &session,
    );
    assert!(!out.status.success());
    let msg = stderr(&out);
    assert!(
        msg.contains("8192x8192") && msg.contains("8294400"),
        "{msg}"
    );
    assert!(!session.exists(), "the session directory was created");
    // At the cap's shape (here smaller) a run goes ahead.
    assert!(vr_app::render::check_offscreen_size(3840, 2160).is_ok());
    assert!(vr_app::render::check_offscreen_size(3841, 2160).is_err());
}
