//! A lattice bend goes through the session as strokes do: journalled (fsync'd before
//! it is applied), recovered after the process dies without cleaning up, a torn final
//! deform line cut off, and a bad deform record refused with its line number.

use std::io::Write;

use glam::{DQuat, DVec3};
use sculpt_core::interaction::{Command, Edit, InteractionMode, WandEvent, WandSample};
use vr_app::config::Config;
use vr_app::journal::Journal;
use vr_app::session::{JOURNAL_FILE, Session};

fn config(dir: &std::path::Path) -> Config {
    let mut c = Config::default();
    c.files.dir = dir.to_path_buf();
    c
}

/// Lattice mode, then a drag from the cage's top front middle control point group
/// 8 cm towards the viewer; returns the edits the session applied.
fn bend(s: &mut Session) -> Vec<Edit> {
    let mut edits = s
        .handle(&WandEvent::command(
            0.0,
            Command::SetMode {
                mode: InteractionMode::Lattice,
            },
        ))
        .unwrap();
    let (doc, _, interaction) = s.draw_parts();
    let cage = vr_app::lattice_view::rest_cage(doc, interaction).unwrap();
    // The highest, frontmost control point.
    let grab = cage
        .control_points()
        .into_iter()
        .max_by(|a, b| (a.y + a.z).total_cmp(&(b.y + b.z)))
        .unwrap();
    let q = DQuat::IDENTITY;
    for k in 0..=10 {
        let p = grab + DVec3::new(0.0, 0.0, 0.008 * k as f64);
        let buttons = u32::from(k > 0 && k < 10);
        let ev = WandEvent::sample(0.1 + 0.02 * k as f64, WandSample::tracked(p, q, buttons));
        edits.extend(s.handle(&ev).unwrap());
    }
    edits
}

#[test]
fn a_bend_is_journalled_and_recovered_after_the_process_dies() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = Session::open(&config(dir.path())).unwrap();
    let before = s.doc.to_json();
    let edits = bend(&mut s);
    assert!(
        edits.iter().any(|e| matches!(e, Edit::Deform(_))),
        "{edits:?}"
    );
    assert_eq!(s.rejected, 0);
    let bent = s.doc.to_json();
    assert_ne!(bent, before, "the bend changed the document");
    // On disk before the session goes: the deform record.
    let path = dir.path().join(JOURNAL_FILE);
    let entries = Journal::read(&path).unwrap();
    assert!(entries.iter().any(|e| matches!(e.edit, Edit::Deform(_))));
    // The process dies: no destructor runs, nothing is flushed or saved.
    std::mem::forget(s);
    // ... in the middle of writing the next line.
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&path)
        .unwrap();
    f.write_all(br#"{"seq":99,"t":2.0,"edit":{"edit":"deform","targets":[1],"gr"#)
        .unwrap();
    drop(f);
    let recovered = Session::open(&config(dir.path())).unwrap();
    assert_eq!(recovered.recovered, entries.len());
    assert_eq!(recovered.rejected, 0);
    assert!(
        recovered.doc.to_json() == bent,
        "the recovered document is the bent one"
    );
    // Undo after recovery takes the bend back.
    drop(recovered);
    let mut again = Session::open(&config(dir.path())).unwrap();
    again
        .handle(&WandEvent::command(3.0, Command::Undo))
        .unwrap();
    assert!(again.doc.to_json() == before);
}

#[test]
fn a_bad_deform_record_is_refused_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = Session::open(&config(dir.path())).unwrap();
    bend(&mut s);
    drop(s);
    let path = dir.path().join(JOURNAL_FILE);
    let text = std::fs::read_to_string(&path).unwrap();
    let line = text.lines().position(|l| l.contains("\"deform\"")).unwrap();
    let bad = text.replace("\"radius\":0.05", "\"radius\":-0.05");
    assert_ne!(bad, text);
    std::fs::write(&path, &bad).unwrap();
    let err = Session::open(&config(dir.path())).unwrap_err().to_string();
    assert!(err.contains(&format!("line {}", line + 1)), "{err}");
    assert!(err.contains("radius"), "{err}");
    // Refused without touching the file.
    assert_eq!(std::fs::read_to_string(&path).unwrap(), bad);
}
