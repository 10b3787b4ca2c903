use glam::{DQuat, DVec3};

use super::*;
use crate::editor::default_surface_point;
use crate::interaction::{Command, EndReason, InteractionMode, TargetIndex, Tool, WandSample};

/// Every hook call, in order.
#[derive(Debug, Default)]
struct Recorder {
    calls: Vec<String>,
    /// Fail `before_apply` from this edit on (counting from 0).
    fail_from: Option<usize>,
    edits: usize,
}

#[derive(Debug, thiserror::Error)]
#[error("the journal is full")]
struct JournalFull;

impl EditHooks for Recorder {
    type Error = JournalFull;

    fn operator_event(&mut self, _t: f64, event: &OperatorEvent) -> Result<(), JournalFull> {
        if !matches!(event, OperatorEvent::Pose { .. }) {
            let name = format!("{event:?}");
            let variant = name.split(' ').next().unwrap_or_default();
            self.calls.push(format!("op {variant}"));
        }
        Ok(())
    }

    fn before_apply(&mut self, _t: f64, _edit: &Edit) -> Result<(), JournalFull> {
        if self.fail_from.is_some_and(|n| self.edits >= n) {
            return Err(JournalFull);
        }
        self.edits += 1;
        self.calls.push("before".into());
        Ok(())
    }

    fn after_apply(
        &mut self,
        _t: f64,
        _edit: &Edit,
        applied: &Applied,
        doc: &Document,
    ) -> Result<(), JournalFull> {
        self.calls.push(format!(
            "after changed={} strokes={}",
            applied.changed(),
            doc.strokes().len()
        ));
        Ok(())
    }
}

fn carve_loop() -> EditLoop {
    EditLoop::new(Interaction::default(), editor::default_document())
}

fn tracked(t: f64, tip: DVec3, buttons: u32) -> WandEvent {
    WandEvent::sample(t, WandSample::tracked(tip, DQuat::IDENTITY, buttons))
}

/// Press, carve `n` samples 2 cm apart across the default surface at height `y`
/// (from `t0`), release; the steps.
fn carve<H: EditHooks>(
    edits: &mut EditLoop,
    hooks: &mut H,
    t0: f64,
    y: f64,
) -> Result<Vec<Step>, LoopError<H::Error>> {
    (0..=10)
        .map(|i| {
            let tip = default_surface_point(-0.1 + 0.02 * i as f64, y);
            edits.handle(
                &tracked(t0 + 0.01 * i as f64, tip, u32::from(i < 10)),
                hooks,
            )
        })
        .collect()
}

#[test]
fn a_stroke_is_journalled_before_it_is_applied_and_reported_after() {
    let mut edits = carve_loop();
    let mut hooks = Recorder::default();
    let steps = carve(&mut edits, &mut hooks, 0.0, 1.15).unwrap();
    assert_eq!(edits.doc.strokes().len(), 1);
    let tail: Vec<&str> = hooks
        .calls
        .iter()
        .rev()
        .take(4)
        .rev()
        .map(String::as_str)
        .collect();
    assert_eq!(
        tail,
        [
            "op ButtonUp",
            "op GestureEnd",
            "before",
            "after changed=true strokes=1"
        ]
    );
    let last = steps.last().unwrap();
    assert_eq!(last.t, 0.1);
    let applied: Vec<_> = last.edits().collect();
    assert_eq!(applied.len(), 1);
    assert!(
        matches!(applied[0], (Edit::Stroke(s), Applied::Stroke { .. }) if s.samples.len() == 11)
    );
    assert_eq!(last.rejections().count(), 0);
    assert!(last.operator_events().any(|(t, e)| t == 0.1
        && matches!(
            e,
            OperatorEvent::GestureEnd {
                committed: true,
                ..
            }
        )));
}

#[test]
fn the_preview_follows_the_live_stroke() {
    let mut edits = carve_loop();
    let steps = carve(&mut edits, &mut NoHooks, 0.0, 1.15).unwrap();
    let previews: Vec<Preview> = steps.iter().filter_map(|s| s.preview).collect();
    let expected: Vec<Preview> = (1..=10)
        .map(|samples| Preview::Stroke {
            samples,
            paused: false,
        })
        .chain([Preview::Idle])
        .collect();
    assert_eq!(
        previews, expected,
        "the press starts it, each held sample grows it, the release ends it"
    );
    assert_eq!(Preview::of(&edits.interaction), Preview::Idle);
}

#[test]
fn a_sketch_adds_a_target_the_selection_wraps_over_and_undo_removes() {
    let mut edits = EditLoop::new(
        Interaction::new(Default::default(), InteractionMode::Sketch, Tool::default()),
        editor::default_document(),
    );
    for i in 0..=20 {
        let tip = DVec3::new(-0.2, 1.0 + 0.01 * i as f64, 0.3);
        let step = edits
            .handle(
                &tracked(0.02 * i as f64, tip, u32::from(i < 20)),
                &mut NoHooks,
            )
            .unwrap();
        if i == 20 {
            assert!(matches!(
                step.edits().next(),
                Some((Edit::Sketch { .. }, Applied::Sketch { .. }))
            ));
        }
    }
    assert_eq!(edits.target_count(), 2);
    let ids = edits.doc.target_ids();
    assert_eq!(
        edits.interaction.target_count(),
        2,
        "the sketched surface becomes a selectable target"
    );
    let select = |edits: &mut EditLoop, t: f64| {
        edits
            .handle(
                &WandEvent::command(t, Command::SelectNextTarget),
                &mut NoHooks,
            )
            .unwrap();
        edits.interaction.target()
    };
    assert_eq!(edits.interaction.target(), ids[0]);
    assert_eq!(
        select(&mut edits, 1.0),
        ids[1],
        "the sketched target can be selected"
    );
    assert_eq!(edits.interaction.target_position(), TargetIndex(1));
    assert_eq!(select(&mut edits, 1.1), ids[0], "and the selection wraps");
    select(&mut edits, 1.2);
    let undo = edits
        .handle(&WandEvent::command(1.3, Command::Undo), &mut NoHooks)
        .unwrap();
    assert_eq!(undo.edits().next().map(|(_, a)| a), Some(&Applied::Undone));
    assert_eq!(edits.target_count(), 1);
    assert_eq!(
        edits.interaction.target(),
        ids[0],
        "the selection follows the removal"
    );
}

#[test]
fn a_refused_input_changes_nothing() {
    let mut edits = carve_loop();
    carve(&mut edits, &mut NoHooks, 1.0, 1.15).unwrap();
    let before = edits.doc.to_json();
    let err = edits
        .handle(&WandEvent::command(0.5, Command::Undo), &mut NoHooks)
        .unwrap_err();
    assert!(
        matches!(err, LoopError::Refused(Error::Interaction(_))),
        "{err}"
    );
    assert!(std::error::Error::source(&err).is_some());
    assert_eq!(edits.doc.to_json(), before);
}

#[test]
fn a_failing_journal_leaves_the_edit_unapplied() {
    let mut edits = carve_loop();
    let mut hooks = Recorder {
        fail_from: Some(0),
        ..Recorder::default()
    };
    let err = carve(&mut edits, &mut hooks, 0.0, 1.15).unwrap_err();
    assert!(matches!(err, LoopError::Hook(JournalFull)));
    assert!(edits.doc.strokes().is_empty());
    assert!(!hooks.calls.iter().any(|c| c.starts_with("after")));
}

#[test]
fn a_stroke_off_the_surface_is_a_rejection() {
    let mut edits = carve_loop();
    let steps: Vec<Step> = (0..=10)
        .map(|i| {
            let tip = default_surface_point(-0.1 + 0.02 * i as f64, 1.15) + DVec3::Z * 3.0;
            edits
                .handle(
                    &tracked(0.01 * i as f64, tip, u32::from(i < 10)),
                    &mut NoHooks,
                )
                .unwrap()
        })
        .collect();
    let rejected: Vec<_> = steps.iter().flat_map(Step::rejections).collect();
    assert_eq!(rejected.len(), 1);
    assert!(matches!(rejected[0].0, Edit::Stroke(_)));
    assert!(edits.doc.strokes().is_empty());
}

#[test]
fn a_paused_stroke_resumes_and_a_tick_ends_one_paused_too_long() {
    let mut edits = carve_loop();
    let at = |i: usize| default_surface_point(-0.1 + 0.01 * i as f64, 1.15);
    for i in 0..5 {
        edits
            .handle(&tracked(0.01 * i as f64, at(i), 1), &mut NoHooks)
            .unwrap();
    }
    let lost = edits
        .handle(&WandEvent::sample(0.05, WandSample::lost(1)), &mut NoHooks)
        .unwrap();
    assert_eq!(
        lost.preview,
        Some(Preview::Stroke {
            samples: 5,
            paused: true
        })
    );
    assert!(!lost.glitch, "an untracked sample is a loss, not a glitch");
    let back = edits.handle(&tracked(0.1, at(5), 1), &mut NoHooks).unwrap();
    assert!(back.resumed);
    assert_eq!(
        back.preview,
        Some(Preview::Stroke {
            samples: 6,
            paused: false
        })
    );
    edits
        .handle(&WandEvent::sample(0.11, WandSample::lost(1)), &mut NoHooks)
        .unwrap();
    let early = edits.tick(0.3, &mut NoHooks).unwrap();
    assert!(early.events.is_empty() && early.preview.is_none());
    let ended = edits.tick(0.7, &mut NoHooks).unwrap();
    assert_eq!(ended.t, 0.7);
    assert!(ended.operator_events().any(|(_, e)| matches!(
        e,
        OperatorEvent::GestureEnd {
            reason: EndReason::TrackingLost,
            committed: true,
            ..
        }
    )));
    assert!(matches!(
        ended.edits().next(),
        Some((_, Applied::Stroke { .. }))
    ));
    assert_eq!(ended.preview, Some(Preview::Idle));
    assert_eq!(edits.doc.strokes().len(), 1);
}

#[test]
fn an_impossible_jump_is_a_glitch() {
    let mut edits = carve_loop();
    let p = default_surface_point(0.0, 1.15);
    assert!(
        !edits
            .handle(&tracked(0.0, p, 0), &mut NoHooks)
            .unwrap()
            .glitch
    );
    let jump = edits
        .handle(&tracked(0.01, p + DVec3::X, 0), &mut NoHooks)
        .unwrap();
    assert!(jump.glitch);
}

#[test]
fn recovered_edits_keep_the_target_count() {
    let mut edits = carve_loop();
    // The base surface is sealed: an undo at the start changes nothing.
    assert_eq!(edits.apply(&Edit::Undo), Applied::Unchanged);
    assert_eq!(edits.target_count(), 1);
    let rows = (0..=20)
        .map(|i| {
            (0..8)
                .map(|j| DVec3::new(-0.2 + 0.05 * j as f64, 1.0 + 0.01 * i as f64, 0.3))
                .collect()
        })
        .collect();
    assert!(matches!(
        edits.apply(&Edit::Sketch { rows }),
        Applied::Sketch { .. }
    ));
    assert_eq!(edits.target_count(), 2);
    assert_eq!(edits.apply(&Edit::Undo), Applied::Undone);
    assert_eq!(edits.target_count(), 1);
    assert_eq!(edits.apply(&Edit::Redo), Applied::Redone);
    assert_eq!(edits.target_count(), 2);
}

/// Proposing and applying each edit before the next input builds the document that
/// handling builds, and proposing alone changes nothing.
#[test]
fn proposed_edits_applied_in_order_build_the_handled_document() {
    let mut handled = carve_loop();
    carve(&mut handled, &mut NoHooks, 0.0, 1.15).unwrap();
    carve(&mut handled, &mut NoHooks, 1.0, 1.2).unwrap();
    let mut proposed = carve_loop();
    let mut recorder = Recorder::default();
    let mut all = Vec::new();
    for (t0, y) in [(0.0, 1.15), (1.0, 1.2)] {
        for i in 0..=10 {
            let tip = default_surface_point(-0.1 + 0.02 * f64::from(i), y);
            let ev = tracked(t0 + 0.01 * f64::from(i), tip, u32::from(i < 10));
            let edits = proposed.propose(&ev, &mut recorder).unwrap();
            assert_eq!(
                proposed.doc.strokes().len(),
                all.len(),
                "proposing applies nothing"
            );
            for edit in edits {
                proposed.apply(&edit);
                all.push(edit);
            }
        }
    }
    assert!(
        proposed
            .propose_tick(5.0, &mut recorder)
            .unwrap()
            .is_empty()
    );
    assert_eq!(all.len(), 2, "{all:?}");
    assert!(
        recorder.calls.iter().any(|c| c == "op GestureStart"),
        "{:?}",
        recorder.calls
    );
    assert_eq!(proposed.doc.to_json(), handled.doc.to_json());
}
