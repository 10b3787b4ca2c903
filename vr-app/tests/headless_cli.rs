//! `wandsculpt --headless` on a scene with no other input: the scene rendered as it is,
//! with the UV quadtree overlay (`--quadtree`) and a turned view (`--view`), the
//! commands `scripts/pictures` uses for the pictures in `docs/images/`.

use std::path::Path;
use std::process::Command;

fn scene() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/scenes/curved-patch-carved.json")
}

/// Runs `wandsculpt --headless --scene ... --size 160x90 ARGS` and returns its report
/// and picture.
fn render(args: &[&str]) -> (serde_json::Value, image::RgbaImage) {
    let dir = tempfile::tempdir().unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--headless")
        .arg("--scene")
        .arg(scene())
        .args(["--size", "160x90", "--out"])
        .arg(dir.path())
        .args(args)
        .env("WANDSCULPT_ADAPTER", "llvmpipe")
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report = serde_json::from_slice(&output.stdout).unwrap();
    let img = image::open(dir.path().join("frame.png"))
        .unwrap()
        .to_rgba8();
    (report, img)
}

/// Pixels in the quadtree overlay's boundary colour (amber).
fn amber(img: &image::RgbaImage) -> usize {
    img.pixels()
        .filter(|p| p[0] > 220 && p[1] > 150 && p[1] < 225 && p[2] < 50)
        .count()
}

#[test]
fn a_scene_alone_is_rendered_as_it_is_with_overlay_and_turned_view() {
    let (report, plain) = render(&[]);
    assert_eq!(report["strokes"], 3);
    assert_eq!(report["inputs"], 0);
    assert_eq!(plain.dimensions(), (160, 90));
    assert_eq!(amber(&plain), 0);
    let (_, overlay) = render(&["--quadtree"]);
    assert!(amber(&overlay) > 20, "{}", amber(&overlay));
    let (_, turned) = render(&["--view", "20,-60"]);
    let changed = plain
        .pixels()
        .zip(turned.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(changed > 1000, "{changed}");
}

#[test]
fn headless_without_input_or_scene_and_bad_views_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
            .arg("--headless")
            .arg("--out")
            .arg(dir.path())
            .args(args)
            .output()
            .unwrap()
    };
    let none = run(&[]);
    assert!(!none.status.success());
    assert!(String::from_utf8_lossy(&none.stderr).contains("--scene"));
    for bad in ["1", "a,b", "inf,0"] {
        let out = run(&["--scene", scene().to_str().unwrap(), "--view", bad]);
        assert!(!out.status.success(), "--view {bad}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("--view"),
            "{bad}"
        );
    }
}

/// `wandsculpt --headless --demo --study MANIFEST --participant P`: each run records
/// the participant's next trial into the log the manifest names (the whole input is one
/// trial), in the order `sculpt-tools goms study next` gives; once every trial is
/// recorded the program refuses with exit 1.
#[test]
fn study_mode_records_each_run_as_the_next_trial_in_the_manifests_log() {
    use sculpt_core::oplog::{EventKind, decode_bytes};
    use sculpt_core::study::{MANIFEST, Manifest};
    let dir = tempfile::tempdir().unwrap();
    let ps = vec!["P1".to_owned(), "P2".to_owned()];
    let ms = vec!["wall".to_owned(), "desk".to_owned()];
    let manifest = dir.path().join(MANIFEST);
    std::fs::write(
        &manifest,
        Manifest::plan(&ps, &ms, 1, true).to_toml().unwrap(),
    )
    .unwrap();
    let run = |participant: &str| {
        Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
            .args(["--headless", "--demo", "--size", "64x36", "--out"])
            .arg(dir.path().join(format!("run-{participant}")))
            .arg("--study")
            .arg(&manifest)
            .args(["--participant", participant, "--task", "groove"])
            .env("WANDSCULPT_ADAPTER", "llvmpipe")
            .output()
            .unwrap()
    };
    // P2's balanced Latin-square order is desk, then wall.
    for (method, trial) in [("desk", 1), ("wall", 1)] {
        let out = run("P2");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(
            err.contains(&format!("recorded P2 / {method} trial {trial} of 1")),
            "{err}"
        );
        let log = decode_bytes(
            &std::fs::read(dir.path().join(format!("logs/P2-{method}.oplog"))).unwrap(),
        )
        .unwrap();
        assert_eq!(log.header.participant.as_deref(), Some("P2"));
        assert_eq!(log.header.method.as_deref(), Some(method));
        assert_eq!(log.header.source.as_deref(), Some("wandsculpt"));
        assert!(matches!(
            &log.events[0].kind,
            EventKind::TrialStart { trial: 1, task: Some(t), .. } if t == "groove"
        ));
        assert!(matches!(
            log.events.last().unwrap().kind,
            EventKind::TrialEnd { trial: 1 }
        ));
        assert!(log.events.iter().any(|e| e.kind == EventKind::StrokeStart));
    }
    let out = run("P2");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("every trial"), "{err}");
    assert!(!dir.path().join("logs/P1-wall.oplog").exists());
}
