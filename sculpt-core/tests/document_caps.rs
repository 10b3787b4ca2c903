//! The document's size caps (issue 15: "no size caps on documents and surfaces"):
//! targets, strokes, samples per stroke, samples per document and control points per
//! target, each checked by the document reader and by the edit path (a rejection with
//! a typed reason, the document unchanged, nothing journalled).

use glam::{DQuat, DVec3};
use sculpt_core::edit_loop::{EditHooks, EditLoop};
use sculpt_core::editor::{self, Applied};
use sculpt_core::error::{ControlNetError, DocumentError, Error, StrokeRejection};
use sculpt_core::interaction::{Edit, Interaction, InteractionMode, WandEvent, WandSample};
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::{
    Document, MAX_DOCUMENT_SAMPLES, MAX_STROKE_SAMPLES, MAX_STROKES, MAX_TARGET_CONTROL_POINTS,
    MAX_TARGETS,
};
use sculpt_core::sculpt::stroke::{StrokeInput, Tool};
use serde_json::json;

/// Counts what a journal would write.
#[derive(Default)]
struct Journal {
    appended: usize,
}

impl EditHooks for Journal {
    type Error = std::convert::Infallible;
    fn before_apply(&mut self, _t: f64, _edit: &Edit) -> Result<(), Self::Error> {
        self.appended += 1;
        Ok(())
    }
}

/// A flat 1 m square, as document JSON.
fn plane_json() -> serde_json::Value {
    json!({"degree_u": 1, "degree_v": 1, "knots_u": [0.0, 0.0, 1.0, 1.0],
        "knots_v": [0.0, 0.0, 1.0, 1.0],
        "control_points": [[[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]]})
}

fn document_json(targets: usize, strokes: Vec<serde_json::Value>) -> Vec<u8> {
    let targets: Vec<_> = (1..=targets)
        .map(|id| json!({"id": id, "name": "p", "surface": plane_json()}))
        .collect();
    serde_json::to_vec(&json!({"format": "wandsculpt-document", "version": 1,
        "targets": targets, "strokes": strokes}))
    .unwrap()
}

/// A stroke of `n` samples across the plane: 11 distinct points, the rest repeats of
/// the last (cheap to build however many there are).
fn samples(n: usize) -> Vec<(f64, DVec3)> {
    (0..n)
        .map(|i| {
            let k = i.min(10) as f64;
            (i as f64 / 1000.0, DVec3::new(0.2 + 0.05 * k, 0.5, 0.0))
        })
        .collect()
}

fn stroke_json(id: u64, n: usize) -> serde_json::Value {
    let samples: Vec<[f64; 4]> = samples(n)
        .into_iter()
        .map(|(t, p)| [t, p.x, p.y, p.z])
        .collect();
    json!({"id": id, "target": 1,
        "tool": {"profile": "v", "width": 0.02, "depth": 0.005, "mode": "carve"},
        "samples": samples})
}

fn tool() -> Tool {
    serde_json::from_value(json!({"profile": "v", "width": 0.02, "depth": 0.005, "mode": "carve"}))
        .unwrap()
}

fn stroke_error(bytes: &[u8]) -> Error {
    match Document::from_json(bytes) {
        Err(Error::Document(DocumentError::Stroke { error, .. })) => *error,
        other => panic!("expected a stroke error, got {other:?}"),
    }
}

#[test]
fn reader_takes_max_targets_and_refuses_one_more() {
    let doc = Document::from_json(&document_json(MAX_TARGETS, vec![])).unwrap();
    assert_eq!(doc.targets().len(), MAX_TARGETS);
    assert_eq!(
        Document::from_json(&document_json(MAX_TARGETS + 1, vec![])).unwrap_err(),
        Error::Document(DocumentError::TooManyTargets { max: MAX_TARGETS })
    );
}

#[test]
fn reader_refuses_more_than_max_strokes_before_building_any() {
    let strokes = (0..=MAX_STROKES as u64)
        .map(|k| stroke_json(k + 2, 2))
        .collect();
    assert_eq!(
        Document::from_json(&document_json(1, strokes)).unwrap_err(),
        Error::Document(DocumentError::TooManyStrokes { max: MAX_STROKES })
    );
}

#[test]
fn reader_refuses_a_stroke_over_max_stroke_samples() {
    let at_cap = document_json(1, vec![stroke_json(2, MAX_STROKE_SAMPLES)]);
    assert_eq!(Document::from_json(&at_cap).unwrap().strokes().len(), 1);
    let over = document_json(1, vec![stroke_json(2, MAX_STROKE_SAMPLES + 1)]);
    assert_eq!(
        stroke_error(&over),
        Error::StrokeRejected(StrokeRejection::TooManySamples {
            count: MAX_STROKE_SAMPLES + 1,
            max: MAX_STROKE_SAMPLES
        })
    );
}

#[test]
fn reader_refuses_samples_over_max_document_samples() {
    let full = MAX_DOCUMENT_SAMPLES / 2;
    let strokes = vec![
        stroke_json(2, full),
        stroke_json(3, full),
        stroke_json(4, 2),
    ];
    assert_eq!(
        stroke_error(&document_json(1, strokes)),
        Error::Document(DocumentError::TooManySamples {
            total: MAX_DOCUMENT_SAMPLES + 2,
            max: MAX_DOCUMENT_SAMPLES
        })
    );
}

/// A degree-1 surface with `n x n` control points over the unit square.
fn grid_surface(n: usize) -> NurbsSurface {
    let mut knots = vec![0.0];
    knots.extend((0..n).map(|i| i as f64 / (n - 1) as f64));
    knots.push(1.0);
    let net = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| DVec3::new(i as f64, j as f64, 0.0) / (n - 1) as f64)
                .collect()
        })
        .collect();
    NurbsSurface::new(1, 1, knots.clone(), knots, net, None).unwrap()
}

#[test]
fn a_target_over_max_target_control_points_is_refused_by_the_edit_path() {
    let n = (MAX_TARGET_CONTROL_POINTS as f64).sqrt() as usize + 1;
    let mut doc = Document::new();
    assert_eq!(
        doc.try_add_target("big", grid_surface(n)).unwrap_err(),
        Error::InvalidControlNet(ControlNetError::TooMany {
            count: n * n,
            max: MAX_TARGET_CONTROL_POINTS
        })
    );
    assert!(doc.targets().is_empty());
    // The reader refuses the same surface (it reads surfaces with the same cap).
    let mut big = document_json(1, vec![]);
    let surface = serde_json::from_str::<serde_json::Value>(&grid_surface(n).to_json()).unwrap();
    let mut value: serde_json::Value = serde_json::from_slice(&big).unwrap();
    value["targets"][0]["surface"] = surface;
    big = serde_json::to_vec(&value).unwrap();
    assert!(
        Document::from_json(&big)
            .unwrap_err()
            .to_string()
            .contains(&format!("more than the {MAX_TARGET_CONTROL_POINTS}")),
    );
    assert!(doc.try_add_target("small", grid_surface(n - 1)).is_ok());
}

/// Sweeps a sketch (or a stroke, by mode) through the edit loop and returns what the
/// last step applied.
fn gesture(edits: &mut EditLoop, journal: &mut Journal, t0: f64, tips: &[DVec3]) -> Applied {
    let mut last = None;
    for (i, &tip) in tips.iter().enumerate() {
        let buttons = u32::from(i + 1 < tips.len());
        let ev = WandEvent::sample(
            t0 + 0.02 * i as f64,
            WandSample::tracked(tip, DQuat::IDENTITY, buttons),
        );
        let step = edits.handle(&ev, journal).unwrap();
        if let Some((_, applied)) = step.edits().next() {
            last = Some(applied.clone());
        }
    }
    last.expect("the gesture made an edit")
}

#[test]
fn edit_loop_rejects_a_sketch_beyond_max_targets_and_journals_nothing() {
    let mut doc = editor::default_document();
    while doc.targets().len() < MAX_TARGETS {
        doc.add_target("more", editor::default_surface());
    }
    let interaction = Interaction::new(
        Default::default(),
        InteractionMode::Sketch,
        sculpt_core::interaction::Tool::default(),
    );
    let mut edits = EditLoop::new(interaction, doc);
    let mut journal = Journal::default();
    let tips: Vec<DVec3> = (0..=20)
        .map(|i| DVec3::new(-0.2, 1.0 + 0.01 * i as f64, 0.3))
        .collect();
    assert_eq!(
        gesture(&mut edits, &mut journal, 10.0, &tips),
        Applied::Rejected(Error::Document(DocumentError::TooManyTargets {
            max: MAX_TARGETS
        }))
    );
    assert_eq!(journal.appended, 0, "an over-cap edit is not journalled");
    assert_eq!(edits.doc.targets().len(), MAX_TARGETS);
    // One fewer target: the same sketch is journalled and applied.
    edits.doc.undo();
    edits.sync_targets();
    assert!(matches!(
        gesture(&mut edits, &mut journal, 20.0, &tips),
        Applied::Sketch { .. }
    ));
    assert_eq!(journal.appended, 1);
}

#[test]
fn edit_loop_rejects_a_stroke_beyond_max_document_samples_and_journals_nothing() {
    let mut doc = editor::default_document();
    let target = doc.targets()[0].id;
    let on_sheet = |k: usize, n: usize| -> Vec<(f64, DVec3)> {
        (0..n)
            .map(|i| {
                let x = -0.2 + 0.04 * i.min(10) as f64;
                (
                    i as f64 / 1000.0,
                    editor::default_surface_point(x, 1.1 + 0.05 * k as f64),
                )
            })
            .collect()
    };
    for k in 0..2 {
        let input = StrokeInput {
            samples: on_sheet(k, MAX_DOCUMENT_SAMPLES / 2),
            tool: tool(),
        };
        doc.apply_stroke(target, input).unwrap();
    }
    doc.seal_history();
    let mut edits = EditLoop::new(Interaction::default(), doc);
    let mut journal = Journal::default();
    let tips: Vec<DVec3> = (0..=10)
        .map(|i| editor::default_surface_point(-0.1 + 0.02 * i as f64, 1.3))
        .collect();
    let applied = gesture(&mut edits, &mut journal, 10.0, &tips);
    assert!(
        matches!(
            applied,
            Applied::Rejected(Error::Document(DocumentError::TooManySamples { max, .. }))
                if max == MAX_DOCUMENT_SAMPLES
        ),
        "{applied:?}"
    );
    assert_eq!(journal.appended, 0, "an over-cap edit is not journalled");
    assert_eq!(edits.doc.strokes().len(), 2);
}

#[test]
fn edit_loop_rejects_a_stroke_beyond_max_strokes_and_journals_nothing() {
    let mut doc = editor::default_document();
    let target = doc.targets()[0].id;
    // MAX_STROKES short strokes, cycling over a few rows of the sheet.
    for k in 0..MAX_STROKES {
        let y = 1.0 + 0.02 * (k % 16) as f64;
        let samples = (0..3)
            .map(|i| {
                let x = -0.3 + 0.05 * i as f64 + 0.01 * (k % 7) as f64;
                (i as f64 / 100.0, editor::default_surface_point(x, y))
            })
            .collect();
        doc.apply_stroke(
            target,
            StrokeInput {
                samples,
                tool: tool(),
            },
        )
        .unwrap();
    }
    let mut edits = EditLoop::new(Interaction::default(), doc);
    let mut journal = Journal::default();
    let tips: Vec<DVec3> = (0..=10)
        .map(|i| editor::default_surface_point(-0.1 + 0.02 * i as f64, 1.3))
        .collect();
    assert_eq!(
        gesture(&mut edits, &mut journal, 10.0, &tips),
        Applied::Rejected(Error::Document(DocumentError::TooManyStrokes {
            max: MAX_STROKES
        }))
    );
    assert_eq!(journal.appended, 0, "an over-cap edit is not journalled");
    assert_eq!(edits.doc.strokes().len(), MAX_STROKES);
    // Undo one: there is room again, and the same stroke is journalled and applied.
    assert!(edits.doc.undo());
    assert!(matches!(
        gesture(&mut edits, &mut journal, 20.0, &tips),
        Applied::Stroke { .. }
    ));
    assert_eq!(journal.appended, 1);
}
