//! Long commands report progress and memory when stderr is not a terminal (issue 31,
//! item 9: a 10-minute reconstruction printed nothing into a log). Here stderr is a
//! pipe, as in CI or `2> log`.

use std::process::{Command, Output};

fn run(interval: Option<&str>, args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sculpt-tools"));
    cmd.args(args);
    match interval {
        Some(s) => cmd.env("SCULPT_TOOLS_PROGRESS_S", s),
        None => cmd.env_remove("SCULPT_TOOLS_PROGRESS_S"),
    };
    let out = cmd.output().expect("sculpt-tools runs");
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn stderr_lines(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .map(str::to_owned)
        .collect()
}

/// The closing line: `LABEL: done in T s, peak memory M MiB` with M a positive number.
fn assert_done_line(lines: &[String], label: &str) {
    let last = lines.last().expect("a closing line");
    let prefix = format!("{label}: done in ");
    assert!(last.starts_with(&prefix), "{lines:?}");
    let mib: f64 = last
        .rsplit_once("peak memory ")
        .and_then(|(_, m)| m.strip_suffix(" MiB"))
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("no peak memory in {last:?}"));
    assert!(mib > 0.0, "{last}");
}

#[test]
fn mesh_prints_a_line_per_step_and_its_peak_memory() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("m.stl");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/scenes/sphere-overlaps.json"
    );
    let args = [
        "mesh",
        "--scene",
        scene,
        "--out",
        out_path.to_str().unwrap(),
    ];
    // Interval 0: a line at every step, each with the count and resident memory.
    let lines = stderr_lines(&run(Some("0"), &args));
    let patches: Vec<&String> = lines
        .iter()
        .filter(|l| l.starts_with("mesh: tessellating patches ("))
        .collect();
    assert!(patches.len() > 1, "{lines:?}");
    assert!(
        patches.iter().all(|l| l.ends_with("MiB resident")),
        "{patches:?}"
    );
    assert_done_line(&lines, "mesh");
    // The default interval (5 s): a run this short prints only the closing line.
    let lines = stderr_lines(&run(None, &args));
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert_done_line(&lines, "mesh");
}

#[test]
fn reconstruct_names_its_stages() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("scan.json");
    let lines = stderr_lines(&run(
        Some("0"),
        &[
            "reconstruct",
            "torus:1500:3",
            "--patches",
            "12",
            "--out",
            doc.to_str().unwrap(),
        ],
    ));
    let stages = lines
        .iter()
        .filter(|l| l.starts_with("reconstruct: ") && l.contains("/"))
        .count();
    assert!(stages >= 3, "{lines:?}");
    assert_done_line(&lines, "reconstruct");
}
