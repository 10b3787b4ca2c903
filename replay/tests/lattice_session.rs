//! The recorded lattice bend (`tests/data/sessions/lattice-bend.poselog`, made by
//! `make-sessions`) through the `replay` binary: byte-identical outputs, the metrics
//! checked against expectations (`--check`), the bent sheet in the document and the
//! IGES, and the operator log naming lattice mode.

mod common;

use std::path::PathBuf;

use sculpt_core::editor::default_surface;
use sculpt_core::oplog::EventKind;
use sculpt_core::sculpt::document::Document;

fn session() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions/lattice-bend.poselog")
}

#[test]
fn the_lattice_session_replays_byte_identically_and_bends_the_sheet() {
    let tmp = tempfile::tempdir().unwrap();
    let a = common::replay_twice_identically(
        &session(),
        tmp.path(),
        r#"{"gestures": {"strokes_applied": 1, "strokes_rejected": 0, "deforms": 1, "too_short": 0},
            "operations": 2, "targets": 1, "strokes": 1}"#,
    );
    // The document holds the bent sheet, the groove still carved into it.
    let doc = Document::from_json(&std::fs::read(a.join("scene.json")).unwrap()).unwrap();
    let bent = &doc.targets()[0].surface;
    let flat = default_surface();
    let grab = replay::sessions::lattice_grab_point();
    let moved = bent
        .control_points()
        .iter()
        .flatten()
        .zip(flat.control_points().iter().flatten())
        .map(|(p, q)| p.distance(*q))
        .fold(0.0, f64::max);
    assert!(moved > 0.005, "the sheet bent: {moved} m");
    assert!(
        bent.point(0.33, 1.0).z > flat.point(0.33, 1.0).z,
        "towards {grab}"
    );
    assert_eq!(doc.strokes().len(), 1);
    // The IGES holds the bent net.
    let iges =
        sculpt_core::formats::iges::read(&std::fs::read(a.join("scene.igs")).unwrap()).unwrap();
    let read = iges.surfaces[0].control_points.iter().flatten();
    for (p, q) in read.zip(bent.control_points().iter().flatten()) {
        sculpt_core::assert_near!(*p, *q, sculpt_core::tolerance::POINT_EPS);
    }
    // The operator log names the mode and the deformation.
    let log =
        sculpt_core::oplog::decode_bytes(&std::fs::read(a.join("operator.log")).unwrap()).unwrap();
    assert!(log.events.iter().any(|e| e.kind
        == EventKind::Mode {
            mode: "lattice".into()
        }));
    assert!(log.events.iter().any(|e| matches!(
        &e.kind,
        EventKind::Marker { label } if label.starts_with("deform ")
    )));
    // Lattice mode is a segment of its own, a method for `sculpt-tools goms analyze`.
    assert!(log.events.iter().any(|e| matches!(
        &e.kind,
        EventKind::TrialStart { method: Some(m), .. } if m == "lattice"
    )));
    // A wrong expectation fails the check.
    let wrong = tmp.path().join("wrong.json");
    std::fs::write(&wrong, r#"{"gestures": {"deforms": 2}}"#).unwrap();
    let o = common::run_to(&session(), &tmp.path().join("c"), Some(&wrong));
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("gestures.deforms: expected 2, got 1"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
