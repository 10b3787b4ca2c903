//! Helpers shared by the `sculpt-tools` CLI tests: running the real binary.

use std::process::{Command, Output};

/// `sculpt-tools`' own tolerances (`src/tolerance.rs`; a binary crate's modules are
/// not importable, so the file is included here).
#[allow(dead_code)] // not every test binary compares with each of them
#[path = "../../src/tolerance.rs"]
pub mod tolerance;

/// Runs `sculpt-tools ARGS`.
pub fn tools(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sculpt-tools"))
        .args(args)
        .output()
        .expect("sculpt-tools runs")
}

/// Runs `sculpt-tools ARGS`, which must succeed, and returns its standard output.
pub fn ok(args: &[&str]) -> String {
    let out = tools(args);
    assert!(
        out.status.success(),
        "sculpt-tools {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// A scratch directory for the files a test writes.
#[allow(dead_code)] // not every test binary writes files
pub struct Files(pub tempfile::TempDir);

#[allow(dead_code)]
impl Files {
    /// A new empty directory.
    pub fn new() -> Self {
        Self(tempfile::tempdir().unwrap())
    }
    /// Writes `text` to `name` and returns the path as the command line takes it.
    pub fn put(&self, name: &str, text: &str) -> String {
        let p = self.0.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    }
    /// A path in the directory that nothing has written yet.
    pub fn path(&self, name: &str) -> std::path::PathBuf {
        self.0.path().join(name)
    }
}

/// A failed run: non-zero exit, exactly one line on stderr, no panic, containing
/// `needle`.
#[allow(dead_code)]
pub fn assert_one_line_error(args: &[&str], needle: &str) {
    let out = tools(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(needle), "expected '{needle}' in: {err}");
}
