//! Shared by the recorded-session tests: run the `replay` binary on a session, and
//! replay it twice against expectations with byte-identical outputs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `replay SESSION --out DIR -q [--check CHECK]`.
pub fn run_to(session: &Path, dir: &Path, check: Option<&Path>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_replay"));
    c.arg(session).arg("--out").arg(dir).arg("-q");
    if let Some(expect) = check {
        c.arg("--check").arg(expect);
    }
    c.output().unwrap()
}

/// Replays `session` into `tmp/a` and `tmp/b`, each checked against `expect` (written to
/// `tmp/expect.json`); both must succeed and every deterministic output must be
/// non-empty and equal. Returns the first output folder.
pub fn replay_twice_identically(session: &Path, tmp: &Path, expect: &str) -> PathBuf {
    let expect_path = tmp.join("expect.json");
    std::fs::write(&expect_path, expect).unwrap();
    let (a, b) = (tmp.join("a"), tmp.join("b"));
    for dir in [&a, &b] {
        let o = run_to(session, dir, Some(&expect_path));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    for file in replay::output::DETERMINISTIC_FILES {
        let x = std::fs::read(a.join(file)).unwrap();
        assert!(!x.is_empty(), "{file} is empty");
        assert!(x == std::fs::read(b.join(file)).unwrap(), "{file} differs");
    }
    a
}
