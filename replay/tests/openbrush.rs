//! The two real Open Brush recordings decode with the counts documented in
//! `../shared/data/README.md`.

use std::path::PathBuf;

use replay::tilt;

fn data(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/openbrush")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Decodes `name` and checks the README's stroke and point counts and the time span.
fn check_counts(
    name: &str,
    strokes: usize,
    points: usize,
    span_s: std::ops::Range<f64>,
) -> tilt::Tilt {
    let t = tilt::read_tilt(&data(name)).unwrap();
    assert_eq!(t.sketch.strokes.len(), strokes, "{name}");
    assert_eq!(t.sketch.point_count(), points, "{name}");
    let (lo, hi) = t.sketch.time_span_ms().unwrap();
    let span = (hi - lo) as f64 / 1000.0;
    assert!(span_s.contains(&span), "{name}: span {span} s");
    t
}

#[test]
fn sketch_tilt_has_161_strokes_and_7268_points() {
    let t = check_counts("sketch.tilt", 161, 7268, 500.0..530.0);
    // README: sketch.tilt sets stroke-extension bit 0 only.
    assert!(
        t.sketch
            .strokes
            .iter()
            .all(|s| s.flags.is_some() && s.seed.is_none())
    );
    assert!(t.metadata.unwrap().contains("SceneTransformInRoomSpace"));
}

#[test]
fn untitled_2_tilt_has_77_strokes_and_6495_points() {
    let t = check_counts("untitled_2.tilt", 77, 6495, 310.0..335.0);
    // README: untitled_2.tilt sets stroke-extension bits 0 and 3.
    assert!(
        t.sketch
            .strokes
            .iter()
            .all(|s| s.flags.is_some() && s.seed.is_some())
    );
}

#[test]
fn real_files_re_encode_to_the_same_sketch() {
    for name in ["sketch.tilt", "untitled_2.tilt"] {
        let t = tilt::read_tilt(&data(name)).unwrap();
        let again =
            tilt::read_tilt(&tilt::write_tilt(&t.sketch, t.metadata.as_deref()).unwrap()).unwrap();
        assert_eq!(again.sketch, t.sketch, "{name}");
    }
}

#[test]
fn every_truncation_of_a_real_file_is_rejected_cleanly() {
    let bytes = data("untitled_2.tilt");
    for keep in (0..bytes.len()).step_by(997) {
        assert!(
            tilt::read_tilt(&bytes[..keep]).is_err(),
            "prefix {keep} accepted"
        );
    }
}
