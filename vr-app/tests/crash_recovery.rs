//! Kill -9 in the middle of a session, restart, and check that every operation the
//! process reported as committed was recovered from the journal.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use sculpt_core::editor::{self, Applied};
use sculpt_core::interaction::Edit;
use vr_app::config::Config;
use vr_app::journal::Journal;
use vr_app::session::{JOURNAL_FILE, Session};

fn wandsculpt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_wandsculpt"));
    c.env("RUST_LOG", "vr_app=info")
        .env("WANDSCULPT_ADAPTER", "llvmpipe");
    c
}

#[test]
fn kill_9_mid_session_loses_no_committed_operation() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    let mut child = wandsculpt()
        .args([
            "--headless",
            "--demo",
            "--realtime",
            "--size",
            "64x36",
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read the log until two operations are reported committed.
    let stderr = child.stderr.take().unwrap();
    let mut committed = 0;
    let deadline = Instant::now() + Duration::from_secs(120);
    for line in BufReader::new(stderr).lines() {
        let line = line.unwrap();
        if line.contains("operation committed") {
            committed += 1;
            if committed == 2 {
                break;
            }
        }
        assert!(Instant::now() < deadline, "no commits reported in time");
    }
    assert_eq!(
        committed, 2,
        "the process ended before committing two operations"
    );
    // SIGKILL: no destructors, no flushing.
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success());
    let journalled = Journal::read(out.join(JOURNAL_FILE)).unwrap();
    assert!(
        journalled.len() >= 2,
        "committed operations missing: {journalled:?}"
    );
    // Regression: `recovered` counted journal lines read, whether or not they applied.
    // The recovered document must be the default document with every journalled edit
    // applied, and each of those edits must apply (none refused on recovery).
    let mut expected = editor::default_document();
    let mut changed = 0;
    for entry in &journalled {
        if matches!(entry.edit, Edit::SelectTarget { .. }) {
            continue;
        }
        match editor::apply(&mut expected, &entry.edit) {
            Applied::Rejected(e) => panic!("journalled edit {} refused: {e}", entry.seq),
            applied => changed += usize::from(applied.changed()),
        }
    }
    assert!(
        changed >= 2 && !expected.strokes().is_empty(),
        "the journalled demo operations must change the document: {journalled:?}"
    );
    let mut cfg = Config::default();
    cfg.files.dir = out.clone();
    let recovered = Session::open(&cfg).unwrap();
    assert_eq!(recovered.recovered, journalled.len());
    assert_eq!(recovered.rejected, 0);
    assert!(
        recovered.doc.to_json() == expected.to_json(),
        "the recovered document differs from the journalled edits applied in order"
    );
    drop(recovered);
    // Restart on the same directory: recovery replays the journal, then the demo runs
    // again on top of it.
    let o = wandsculpt()
        .args(["--headless", "--demo", "--size", "64x36", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        report["recovered"].as_u64().unwrap(),
        journalled.len() as u64
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(&format!("recovered {} operations", journalled.len())),
        "{stderr}"
    );
    // All 7 demo operations were added on top of the recovered ones.
    assert_eq!(
        report["operations"].as_u64().unwrap(),
        journalled.len() as u64 + 7
    );
}
