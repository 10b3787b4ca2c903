//! What `replay` links: the session logic and the headless renderer, never a window
//! system, the cluster's NATS client or the OpenXR loader (issue 32). `vr-app` keeps
//! those behind its `window`, `nats` and `openxr` features, which replay does not ask
//! for; this test fails when a dependency edge brings one of them back.

use std::process::Command;

/// Crates replay must not link (normal dependencies, host target).
const FORBIDDEN: [&str; 3] = ["winit", "async-nats", "openxr"];

/// The package names of `cargo tree -p replay -e normal` (one per line, deduplicated
/// by cargo's `(*)` marks, which the name parsing ignores).
fn replay_dependencies() -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["tree", "-p", "replay", "-e", "normal", "--locked"])
        .args(["--prefix", "none", "--format", "{p}"])
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .expect("cargo tree prints UTF-8")
        .lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(str::to_owned)
        .collect()
}

#[test]
fn replay_links_no_window_nats_or_openxr() {
    let deps = replay_dependencies();
    // The listing is real: it names replay itself and the display server's library.
    assert!(deps.iter().any(|d| d == "replay"), "{deps:?}");
    assert!(deps.iter().any(|d| d == "vr-app"), "{deps:?}");
    let linked: Vec<&String> = deps
        .iter()
        .filter(|d| FORBIDDEN.contains(&d.as_str()))
        .collect();
    assert!(linked.is_empty(), "replay links {linked:?}");
}
