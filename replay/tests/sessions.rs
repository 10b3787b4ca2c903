//! The shipped session library is exactly what the generator writes, and every
//! session reads back as a pose log.

use std::path::PathBuf;

use tracking::poselog::PoseLog;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions")
}

#[test]
fn shipped_sessions_are_up_to_date() {
    let mut stale = Vec::new();
    for (name, bytes) in replay::sessions::render_all().unwrap() {
        if std::fs::read(dir().join(&name)).ok() != Some(bytes) {
            stale.push(name);
        }
    }
    let index = std::fs::read_to_string(dir().join("README.md")).unwrap_or_default();
    if index != replay::sessions::index_markdown() {
        stale.push("README.md".into());
    }
    assert!(
        stale.is_empty(),
        "regenerate with `cargo run -p replay --bin make-sessions -- tests/data/sessions`: {stale:?}"
    );
}

#[test]
fn every_session_reads_back_with_its_trouble() {
    for spec in replay::sessions::catalogue() {
        let bytes = std::fs::read(dir().join(format!("{}.poselog", spec.name))).unwrap();
        let log = PoseLog::from_bytes(&bytes).unwrap();
        let (frames, bad) = log.frames();
        let secs = spec.script.duration();
        let expected = (secs * spec.sim.rate_hz) as usize;
        assert!(
            frames.len() > expected / 2,
            "{}: {} frames",
            spec.name,
            frames.len()
        );
        let trouble = spec.trouble;
        use replay::sessions::Trouble;
        assert_eq!(
            log.truncated_tail,
            trouble == Trouble::TruncatedLastLine,
            "{}",
            spec.name
        );
        assert_eq!(
            bad.len(),
            usize::from(trouble == Trouble::TcpReconnect),
            "{}",
            spec.name
        );
        // Button-0 presses: one per stroke and lattice drag, plus one for the sketch
        // when there is one.
        let presses = frames
            .windows(2)
            .filter(|w| !w[0].wands[0].button(0) && w[1].wands[0].button(0))
            .count();
        let sketches = usize::from(spec.name.starts_with("sketch"));
        assert_eq!(
            presses,
            spec.strokes + spec.deforms + spec.paints + sketches,
            "{}",
            spec.name
        );
    }
}
