//! Helpers shared by the `sculpt-tools` CLI tests: running the real binary.

use std::process::{Command, Output};

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
