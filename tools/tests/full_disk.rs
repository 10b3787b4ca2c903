//! Issue 31, item 2: every `sculpt-tools` writer on a full disk (a 64 KiB tmpfs,
//! `fsio::testing::SmallDisk`) fails with a non-zero exit and leaves no file, and
//! `reconstruct` refuses bad input before it writes any of its outputs.

mod common;

use std::path::{Path, PathBuf};

use fsio::testing::SmallDisk;

/// The disk's size: every output below is larger.
const DISK_KIB: u32 = 64;

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/scenes/curved-patch-carved.json")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs `sculpt-tools` with `args` (where `{out}` stands for an output folder) once
/// into a normal folder, checking that it succeeds and writes more than the disk
/// holds, then into the full disk, where it must fail and leave nothing.
fn fails_cleanly_on_a_full_disk(disk: &SmallDisk, args: &[&str]) {
    let roomy = tempfile::tempdir().unwrap();
    let with =
        |dir: &Path| -> Vec<String> { args.iter().map(|a| a.replace("{out}", s(dir))).collect() };
    let ok_args = with(roomy.path());
    let ok: Vec<&str> = ok_args.iter().map(String::as_str).collect();
    common::ok(&ok);
    let written: u64 = std::fs::read_dir(roomy.path())
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    assert!(
        written > u64::from(DISK_KIB) << 10,
        "{args:?} writes only {written} bytes: the test needs more than the disk"
    );
    let full_args = with(disk.path());
    let full: Vec<&str> = full_args.iter().map(String::as_str).collect();
    let out = common::tools(&full);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} exited 0 on a full disk");
    assert!(err.contains("No space left"), "{args:?}: {err}");
    assert_eq!(disk.entries(), Vec::<String>::new(), "{args:?} left files");
}

/// Regression (issue 31, item 2): every `sculpt-tools` writer left a partial file on a
/// full disk.
#[test]
fn every_writer_leaves_no_file_on_a_full_disk() {
    let Some(disk) = SmallDisk::mount_or_skip(DISK_KIB, "every_writer_leaves_no_file") else {
        return;
    };
    let scene = scene();
    fails_cleanly_on_a_full_disk(
        &disk,
        &["mesh", "--scene", s(&scene), "--out", "{out}/m.obj"],
    );
    fails_cleanly_on_a_full_disk(
        &disk,
        &["mesh", "--scene", s(&scene), "--out", "{out}/m.stl"],
    );
    fails_cleanly_on_a_full_disk(
        &disk,
        &["export", "--scene", s(&scene), "--out", "{out}/e.igs"],
    );
    // A stream of rows (eval, project): the output appears whole or not at all.
    let inputs = tempfile::tempdir().unwrap();
    let surface = inputs.path().join("surface.json");
    std::fs::write(&surface, sculpt_core::editor::default_surface().to_json()).unwrap();
    let uv = inputs.path().join("uv.csv");
    let rows: String = (0..5000)
        .map(|i| format!("{},{}\n", f64::from(i) / 5000.0, 0.5))
        .collect();
    std::fs::write(&uv, rows).unwrap();
    fails_cleanly_on_a_full_disk(
        &disk,
        &[
            "eval",
            "--surface",
            s(&surface),
            "--uv",
            s(&uv),
            "--out",
            "{out}/p.csv",
        ],
    );
    // reconstruct writes its outputs as one set: none of them on a full disk.
    fails_cleanly_on_a_full_disk(
        &disk,
        &[
            "reconstruct",
            "torus:1500:3",
            "--patches",
            "12",
            "--out",
            "{out}/r.json",
            "--igs",
            "{out}/r.igs",
            "--layout",
            "{out}/l.ply",
            "--report",
            "{out}/report.json",
        ],
    );
}

/// The torus of `torus:N`, moved by `offset` and scaled by `scale`, as `.xyz` text.
fn torus_xyz(offset: f64, scale: f64) -> String {
    sculpt_core::reconstruct::sample::torus(1500, 0.2, 0.08, 3)
        .iter()
        .map(|p| {
            let q = *p * scale + glam::DVec3::splat(offset);
            format!("{} {} {}\n", q.x, q.y, q.z)
        })
        .collect()
}

/// Runs `reconstruct` on `points` with every output asked for in `dir`; returns the
/// one-line error.
fn reconstruct_refused(dir: &Path, points: &str) -> String {
    let file = dir.join("scan.xyz");
    std::fs::write(&file, points).unwrap();
    let out = common::tools(&[
        "reconstruct",
        s(&file),
        "--patches",
        "12",
        "--out",
        s(&dir.join("r.json")),
        "--igs",
        s(&dir.join("r.igs")),
        "--obj",
        s(&dir.join("r.obj")),
        "--layout",
        s(&dir.join("l.ply")),
        "--report",
        s(&dir.join("report.json")),
    ]);
    assert!(!out.status.success());
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["scan.xyz"],
        "reconstruct wrote files before it failed"
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Regression (issue 31, item 2): `reconstruct` on 1e150-scale input failed only
/// after `r.json`, `r.igs` and `l.ply` were written. It fails before writing now.
#[test]
fn reconstruct_fails_before_writing_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let err = reconstruct_refused(dir.path(), &torus_xyz(0.0, 1e150));
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// Regression (issue 31, item 5): a UTM-scale scan (coordinates near 5e6 m) was
/// reconstructed with exit 0 into a document that `mesh` and `wandsculpt --scene`
/// refuse. It is refused up front now, with what to do.
#[test]
fn a_utm_scale_scan_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let err = reconstruct_refused(dir.path(), &torus_xyz(5e6, 1.0));
    assert!(err.contains("move the scan near the origin"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // The same scan near the origin gives a document `mesh` reads.
    let near = dir.path().join("near.xyz");
    std::fs::write(&near, torus_xyz(0.0, 1.0)).unwrap();
    let doc = dir.path().join("near.json");
    common::ok(&["reconstruct", s(&near), "--patches", "12", "--out", s(&doc)]);
    common::ok(&[
        "mesh",
        "--scene",
        s(&doc),
        "--out",
        s(&dir.path().join("near.obj")),
    ]);
}
