//! The recorded paint session (`tests/data/sessions/paint.poselog`, made by
//! `make-sessions`) through the `replay` binary: byte-identical outputs, the metrics
//! checked against expectations (`--check`), the painted band in the PLY (read here
//! by a minimal reader of its own), and the operator log naming paint mode.

mod common;

use std::path::PathBuf;

use sculpt_core::oplog::EventKind;

fn session() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions/paint.poselog")
}

/// `(x, y, green byte)` of every vertex of an ASCII PLY with `x y z nx ny nz red green
/// blue` vertices (the header is checked to say so).
fn ply_green(bytes: &[u8]) -> Vec<(f64, f64, u8)> {
    let text = std::str::from_utf8(bytes).unwrap();
    let (header, body) = text.split_once("end_header\n").unwrap();
    let props: Vec<&str> = header
        .lines()
        .filter_map(|l| l.strip_prefix("property "))
        .filter(|l| !l.starts_with("list"))
        .map(|l| l.rsplit(' ').next().unwrap())
        .collect();
    assert_eq!(
        props,
        ["x", "y", "z", "nx", "ny", "nz", "red", "green", "blue"]
    );
    let vertices: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .unwrap()
        .parse()
        .unwrap();
    body.lines()
        .take(vertices)
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (
                w[0].parse().unwrap(),
                w[1].parse().unwrap(),
                w[7].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn the_paint_session_replays_byte_identically_and_paints_a_band() {
    let tmp = tempfile::tempdir().unwrap();
    let a = common::replay_twice_identically(
        &session(),
        tmp.path(),
        r#"{"gestures": {"strokes_applied": 1, "strokes_rejected": 0, "paints": 3, "too_short": 0},
            "operations": 4, "targets": 1, "strokes": 1}"#,
    );
    // The band (three sweeps at y 1.13 to 1.21, x -0.35 to 0.35, brush 3 cm) is
    // terracotta, green
    // 0.3 x 255 = 77 in its middle; the sheet away from it is the unpainted grey
    // (green 0.8 x 255 = 204).
    let unpainted = (sculpt_core::paint::UNPAINTED[1] * 255.0).round() as u8;
    let (mut on, mut off) = (0, 0);
    for (x, y, g) in ply_green(&std::fs::read(a.join("scene.ply")).unwrap()) {
        if (y - 1.17).abs() < 0.03 && x.abs() < 0.3 {
            on += 1;
            assert!(g < 120, "green {g} at y {y}");
        } else if (y - 1.17).abs() > 0.12 {
            off += 1;
            assert!(g.abs_diff(unpainted) <= 3, "green {g} at y {y}");
        }
    }
    assert!(on > 10 && off > 10, "{on} on the band, {off} off it");
    // The OBJ carries the same colours (`v x y z r g b`).
    let obj = std::fs::read_to_string(a.join("scene.obj")).unwrap();
    assert!(
        obj.lines()
            .filter(|l| l.starts_with("v "))
            .all(|l| l.split_whitespace().count() == 7)
    );
    // The operator log names the mode and each paint stroke; paint mode is a segment
    // of its own, a method for `sculpt-tools goms analyze`.
    let log =
        sculpt_core::oplog::decode_bytes(&std::fs::read(a.join("operator.log")).unwrap()).unwrap();
    assert!(log.events.iter().any(|e| e.kind
        == EventKind::Mode {
            mode: "paint".into()
        }));
    let paints = log
        .events
        .iter()
        .filter(|e| matches!(&e.kind, EventKind::Marker { label } if label.starts_with("paint ")))
        .count();
    assert_eq!(paints, 3);
    assert!(log.events.iter().any(|e| matches!(
        &e.kind,
        EventKind::TrialStart { method: Some(m), .. } if m == "paint"
    )));
    // A wrong expectation fails the check.
    let wrong = tmp.path().join("wrong.json");
    std::fs::write(&wrong, r#"{"gestures": {"paints": 2}}"#).unwrap();
    let o = common::run_to(&session(), &tmp.path().join("c"), Some(&wrong));
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("gestures.paints: expected 2, got 3"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
