//! `wandsculpt --xr` (feature `openxr`) on a machine without an OpenXR runtime: one
//! line on stderr naming what is missing, a non-zero exit, and no session written.
//! With the loader installed the line names the runtime manifest `XR_RUNTIME_JSON`
//! points to; without it, the loader.

use std::process::Command;

#[test]
fn xr_without_a_runtime_names_what_is_missing_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("no-such-runtime.json");
    let out = dir.path().join("session");
    let output = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .args(["--xr", "--frames", "3", "--out"])
        .arg(&out)
        .env("XR_RUNTIME_JSON", &manifest)
        .env_remove("XR_LOADER_DEBUG")
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line, got:\n{stderr}");
    let line = lines[0];
    assert!(line.starts_with("wandsculpt: OpenXR: "), "{line}");
    let names_runtime = line.contains("no runtime")
        && line.contains(&manifest.display().to_string())
        && line.contains("does not exist");
    let names_loader = line.contains("no loader") && line.contains("libopenxr-loader1");
    assert!(names_runtime || names_loader, "{line}");
    assert!(output.stdout.is_empty(), "no report");
    assert!(
        !out.exists(),
        "the probe fails before the session is opened"
    );
}
