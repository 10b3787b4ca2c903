use super::*;
use crate::assert_near;
use crate::error::{ToolParam, ToolRangeError};
use crate::tolerance::{BOUND_MARGIN, EXACT_EPS, MIN_SPEED_DT, POINT_EPS};

fn at(x: f64) -> DVec3 {
    DVec3::new(x, 1.0, 0.2)
}

fn feed(m: &mut Interaction, t: f64, s: WandSample) -> Vec<Output> {
    let mut out = Vec::new();
    m.handle(&WandEvent::sample(t, s), &mut out).unwrap();
    out
}

fn edits(outs: &[Output]) -> Vec<&Edit> {
    outs.iter()
        .filter_map(|o| match o {
            Output::Edit(e) => Some(e),
            _ => None,
        })
        .collect()
}

fn ops(outs: &[Output]) -> Vec<&OperatorEvent> {
    outs.iter()
        .filter_map(|o| match o {
            Output::Op { event, .. } if !matches!(event, OperatorEvent::Pose { .. }) => Some(event),
            _ => None,
        })
        .collect()
}

/// Runs a scripted session: (t, x or None when lost, buttons).
fn run(m: &mut Interaction, script: &[(f64, Option<f64>, u32)]) -> Vec<Output> {
    let mut all = Vec::new();
    for &(t, x, b) in script {
        let s = match x {
            Some(x) => WandSample::tracked(at(x), DQuat::IDENTITY, b),
            None => WandSample::lost(b),
        };
        all.extend(feed(m, t, s));
    }
    all
}

#[test]
fn carve_stroke_press_move_release() {
    let mut m = Interaction::default();
    let script: Vec<_> = (0..=10)
        .map(|i| {
            (
                i as f64 * 0.01,
                Some(i as f64 * 0.01),
                if i < 10 { 1 } else { 0 },
            )
        })
        .collect();
    let out = run(&mut m, &script);
    let e = edits(&out);
    assert_eq!(e.len(), 1);
    let Edit::Stroke(s) = e[0] else {
        panic!("expected a stroke, got {e:?}")
    };
    assert_eq!(s.mode, StrokeMode::Carve);
    assert_eq!(s.samples.len(), 11);
    assert_near!(s.samples[10].position.x, 0.1, EXACT_EPS);
    let o = ops(&out);
    assert_eq!(o[0], &OperatorEvent::TrackingRegained);
    assert_eq!(o[1], &OperatorEvent::ButtonDown { button: 0 });
    assert_eq!(
        o[2],
        &OperatorEvent::GestureStart {
            mode: InteractionMode::CARVE
        }
    );
    assert_eq!(o[3], &OperatorEvent::ButtonUp { button: 0 });
    assert_eq!(
        o[4],
        &OperatorEvent::GestureEnd {
            mode: InteractionMode::CARVE,
            committed: true,
            reason: EndReason::Released,
            dropped: None
        }
    );
    // Poses are logged for every tracked sample.
    let poses = out
        .iter()
        .filter(|o| {
            matches!(
                o,
                Output::Op {
                    event: OperatorEvent::Pose { .. },
                    ..
                }
            )
        })
        .count();
    assert_eq!(poses, 11);
}

#[test]
fn live_stroke_previews_while_held() {
    let mut m = Interaction::default();
    run(&mut m, &[(0.0, Some(0.0), 1), (0.01, Some(0.01), 1)]);
    let live = m.live_stroke().unwrap();
    assert_eq!(live.samples.len(), 2);
    assert!(m.gesture_active());
}

#[test]
fn tiny_strokes_are_discarded() {
    let mut m = Interaction::default();
    let out = run(&mut m, &[(0.0, Some(0.0), 1), (0.01, Some(0.001), 0)]);
    assert!(edits(&out).is_empty());
    assert!(ops(&out).iter().any(|e| matches!(
        e,
        OperatorEvent::GestureEnd {
            mode: InteractionMode::CARVE,
            committed: false,
            reason: EndReason::Released,
            dropped: Some(StrokeRejection::TooShort { length_m, min_m })
        } if *length_m < *min_m
    )));
}

#[test]
fn mode_button_cycles_and_emboss_strokes_are_emboss() {
    let mut m = Interaction::default();
    // Button 1 press: carve -> emboss.
    let out = run(&mut m, &[(0.0, Some(0.0), 0b10), (0.01, Some(0.0), 0)]);
    assert!(ops(&out).contains(&&OperatorEvent::ModeChange {
        from: InteractionMode::CARVE,
        to: InteractionMode::EMBOSS
    }));
    let out = run(
        &mut m,
        &[
            (0.02, Some(0.0), 1),
            (0.03, Some(0.02), 1),
            (0.04, Some(0.04), 0),
        ],
    );
    let e = edits(&out);
    assert!(matches!(e[0], Edit::Stroke(s) if s.mode == StrokeMode::Emboss));
}

#[test]
fn mode_and_tool_do_not_change_mid_stroke() {
    let mut m = Interaction::default();
    run(&mut m, &[(0.0, Some(0.0), 1)]);
    let mut out = Vec::new();
    m.handle(
        &WandEvent::command(
            0.01,
            Command::SetMode {
                mode: InteractionMode::Sketch,
            },
        ),
        &mut out,
    )
    .unwrap();
    m.handle(
        &WandEvent::command(0.01, Command::SetWidth { width: 0.05 }),
        &mut out,
    )
    .unwrap();
    m.handle(&WandEvent::command(0.01, Command::Undo), &mut out)
        .unwrap();
    assert!(out.is_empty());
    assert_eq!(m.mode(), InteractionMode::CARVE);
}

#[test]
fn tool_commands_validate_and_log() {
    let mut m = Interaction::default();
    let mut out = Vec::new();
    m.handle(
        &WandEvent::command(0.0, Command::SetWidth { width: 0.03 }),
        &mut out,
    )
    .unwrap();
    m.handle(
        &WandEvent::command(
            0.0,
            Command::SetProfile {
                profile: Profile::U,
            },
        ),
        &mut out,
    )
    .unwrap();
    assert_eq!(m.tool().profile, Profile::U);
    assert_near!(m.tool().width, 0.03, EXACT_EPS);
    assert_eq!(out.len(), 2);
    for bad in [f64::NAN, -1.0, 0.0, 11.0] {
        let r = m.handle(
            &WandEvent::command(0.1, Command::SetDepth { depth: bad }),
            &mut out,
        );
        assert!(
            matches!(
                r,
                Err(Error::Interaction(InteractionError::Tool(ToolRangeError {
                    param: ToolParam::Depth,
                    ..
                })))
            ),
            "depth {bad}"
        );
    }
    assert_near!(m.tool().depth, Tool::default().depth, EXACT_EPS);
}

#[test]
fn undo_redo_select_save_from_buttons_and_commands() {
    let mut m = Interaction::default();
    m.set_targets(&[1, 5, 9]);
    let out = run(
        &mut m,
        &[
            (0.0, Some(0.0), 1 << 3),
            (0.1, Some(0.0), 1 << 4),
            (0.2, Some(0.0), 1 << 5),
            (0.3, Some(0.0), 1 << 5 | 1 << 3),
        ],
    );
    let e = edits(&out);
    // The last sample keeps select held (no new edge) and presses undo again.
    assert_eq!(
        e,
        vec![
            &Edit::Undo,
            &Edit::Redo,
            &Edit::SelectTarget { target: 5 },
            &Edit::Undo
        ]
    );
    let mut out = Vec::new();
    m.handle(&WandEvent::command(0.4, Command::Save), &mut out)
        .unwrap();
    m.handle(
        &WandEvent::command(
            0.4,
            Command::SelectTarget {
                index: TargetIndex(7),
            },
        ),
        &mut out,
    )
    .unwrap();
    assert_eq!(
        edits(&out),
        vec![&Edit::Save],
        "out-of-range selection is ignored"
    );
    assert_eq!(m.target(), 5);
    assert_eq!(m.target_position(), TargetIndex(1));
}

/// The selection is a target id: it stays on its target while that exists, and moves
/// to the target now at its position when it is gone.
#[test]
fn the_selection_follows_its_target_through_new_target_lists() {
    let mut m = Interaction::default();
    assert_eq!(m.target(), DEFAULT_TARGET);
    m.set_targets(&[1, 5, 9]);
    let mut out = Vec::new();
    m.handle(
        &WandEvent::command(
            0.0,
            Command::SelectTarget {
                index: TargetIndex(2),
            },
        ),
        &mut out,
    )
    .unwrap();
    assert_eq!(m.target(), 9);
    m.set_targets(&[1, 5, 9, 12]);
    assert_eq!(m.target(), 9, "a new target leaves the selection alone");
    m.set_targets(&[1, 5, 12]);
    assert_eq!(m.target(), 12, "the target at the removed one's position");
    m.set_targets(&[1]);
    assert_eq!(m.target(), 1, "or the last one");
    m.set_targets(&[]);
    assert_eq!(m.target(), 1, "an empty list changes nothing");
}

#[test]
fn time_going_backwards_is_rejected_without_changing_state() {
    let mut m = Interaction::default();
    run(&mut m, &[(1.0, Some(0.0), 1)]);
    let before = m.clone();
    let mut out = Vec::new();
    assert!(matches!(
        m.handle(
            &WandEvent::sample(0.5, WandSample::tracked(at(0.0), DQuat::IDENTITY, 0)),
            &mut out
        ),
        Err(Error::Interaction(InteractionError::TimeBackwards {
            t: 0.5,
            previous: 1.0
        }))
    ));
    assert!(
        m.handle(&WandEvent::sample(f64::NAN, WandSample::lost(0)), &mut out)
            .is_err()
    );
    assert_eq!(m, before);
    assert!(out.is_empty());
}

#[test]
fn short_tracking_loss_pauses_then_resumes() {
    let mut m = Interaction::default();
    let out = run(
        &mut m,
        &[
            (0.00, Some(0.00), 1),
            (0.01, Some(0.01), 1),
            (0.02, None, 1),
            (0.10, None, 1),
            (0.20, Some(0.02), 1),
            (0.21, Some(0.03), 0),
        ],
    );
    assert!(ops(&out).contains(&&OperatorEvent::TrackingLost));
    assert!(ops(&out).contains(&&OperatorEvent::TrackingRegained));
    let e = edits(&out);
    let Edit::Stroke(s) = e[0] else { panic!() };
    assert_eq!(s.samples.len(), 4, "paused samples are not recorded");
}

#[test]
fn regression_tracking_returns_far_away_ends_stroke_without_a_jump() {
    // Cause: a stroke that resumed wherever tracking came back drew a long straight
    // segment across the surface. It must end at the last good sample instead.
    let mut m = Interaction::default();
    let out = run(
        &mut m,
        &[
            (0.00, Some(0.00), 1),
            (0.01, Some(0.01), 1),
            (0.02, Some(0.02), 1),
            (0.03, None, 1),
            (0.10, Some(0.50), 1),
            (0.11, Some(0.51), 1),
            (0.12, Some(0.52), 0),
        ],
    );
    let e = edits(&out);
    assert_eq!(e.len(), 1);
    let Edit::Stroke(s) = e[0] else { panic!() };
    assert!(
        s.samples.iter().all(|p| p.position.x <= 0.02 + EXACT_EPS),
        "{s:?}"
    );
    assert!(ops(&out).contains(&&OperatorEvent::GestureEnd {
        mode: InteractionMode::CARVE,
        committed: true,
        reason: EndReason::TrackingLost,
        dropped: None
    }));
    // The held button after the early end starts nothing until it is released.
    assert!(!m.gesture_active());
}

#[test]
fn long_tracking_loss_ends_the_stroke_on_timeout() {
    let mut m = Interaction::default();
    let out = run(
        &mut m,
        &[(0.0, Some(0.0), 1), (0.01, Some(0.01), 1), (0.02, None, 1)],
    );
    assert!(edits(&out).is_empty());
    let mut out = Vec::new();
    m.tick(0.3, &mut out);
    assert!(edits(&out).is_empty(), "still inside the pause timeout");
    m.tick(0.6, &mut out);
    assert_eq!(
        edits(&out).len(),
        1,
        "ends once the timeout passes, with no new event"
    );
    assert!(!m.gesture_active());
}

#[test]
fn glitch_samples_are_treated_as_loss() {
    let mut m = Interaction::default();
    // One sample 2 m away 10 ms later (200 m/s) is a glitch, then the wand is back.
    let out = run(
        &mut m,
        &[
            (0.0, Some(0.0), 1),
            (0.01, Some(0.01), 1),
            (0.02, Some(2.0), 1),
            (0.03, Some(0.02), 1),
            (0.04, Some(0.03), 0),
        ],
    );
    let Edit::Stroke(s) = edits(&out)[0] else {
        panic!()
    };
    assert!(s.samples.iter().all(|p| p.position.x < 0.05));
    assert_eq!(s.samples.len(), 4);
}

#[test]
fn nan_pose_is_loss_not_nan_output() {
    let mut m = Interaction::default();
    let mut out = run(&mut m, &[(0.0, Some(0.0), 1), (0.01, Some(0.01), 1)]);
    out.extend(feed(
        &mut m,
        0.02,
        WandSample::tracked(DVec3::new(f64::NAN, 0.0, 0.0), DQuat::IDENTITY, 1),
    ));
    out.extend(feed(
        &mut m,
        0.03,
        WandSample::tracked(at(0.02), DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0), 1),
    ));
    out.extend(run(&mut m, &[(0.04, Some(0.02), 0)]));
    let Edit::Stroke(s) = edits(&out)[0] else {
        panic!()
    };
    assert!(s.samples.iter().all(|p| p.position.is_finite()));
    let json = serde_json::to_string(&out).unwrap();
    assert!(!json.contains("NaN") && !json.contains("null"));
}

#[test]
fn press_while_untracked_starts_nothing() {
    let mut m = Interaction::default();
    let out = run(
        &mut m,
        &[
            (0.0, None, 1),
            (0.1, Some(0.0), 1),
            (0.2, Some(0.1), 1),
            (0.3, Some(0.2), 0),
        ],
    );
    assert!(edits(&out).is_empty());
}

#[test]
fn sketch_sweep_builds_a_point_grid() {
    let mut m = Interaction::new(
        InteractionConfig::default(),
        InteractionMode::Sketch,
        Tool::default(),
    );
    let script: Vec<_> = (0..=10)
        .map(|i| (i as f64 * 0.02, Some(0.0), if i < 10 { 1 } else { 0 }))
        .collect();
    // Move along y instead of x so the sweep axis (wand x) is across the motion.
    let mut out = Vec::new();
    for &(t, _, b) in &script {
        let p = DVec3::new(0.0, 1.0 + t, 0.2);
        out.extend(feed(&mut m, t, WandSample::tracked(p, DQuat::IDENTITY, b)));
    }
    let e = edits(&out);
    let Edit::Sketch { rows } = e[0] else {
        panic!("{e:?}")
    };
    assert_eq!(rows.len(), 11);
    assert!(rows.iter().all(|r| r.len() == 8));
    assert_near!(rows[3][7].to_array(), [0.3, 1.06, 0.2], EXACT_EPS);
}

#[test]
fn sample_cap_bounds_memory() {
    let cfg = InteractionConfig {
        max_samples: 5,
        ..Default::default()
    };
    let mut m = Interaction::new(cfg, InteractionMode::CARVE, Tool::default());
    let script: Vec<_> = (0..20)
        .map(|i| (i as f64 * 0.01, Some(i as f64 * 0.01), 1))
        .collect();
    let out = run(&mut m, &script);
    let Edit::Stroke(s) = edits(&out)[0] else {
        panic!()
    };
    assert_eq!(s.samples.len(), 5);
}

#[test]
fn same_events_same_outputs() {
    let script: Vec<_> = (0..50)
        .map(|i| {
            let x = (i as f64 * 0.37).sin() * 0.1;
            let lost = i % 13 == 5;
            (
                i as f64 * 0.011,
                (!lost).then_some(x),
                (i / 7 % 2) as u32 | ((i % 17 == 3) as u32) << 1,
            )
        })
        .collect();
    let a = run(&mut Interaction::default(), &script);
    let b = run(&mut Interaction::default(), &script);
    assert_eq!(a, b);
}

/// Regression: the interaction and the sculpting layer each had a `Profile`, a
/// carve/emboss `Mode` and a `Tool` (serde kebab-case and lowercase). The one set must
/// read every former spelling and write the same bytes: the journal, pose-log commands,
/// documents and configurations depend on it.
#[test]
fn one_vocabulary_reads_and_writes_every_former_spelling() {
    use crate::sculpt::stroke::DEFAULT_TAPER;
    fn round_trip<T>(text: &str, value: &T)
    where
        T: serde::Serialize + serde::de::DeserializeOwned + PartialEq + std::fmt::Debug,
    {
        assert_eq!(&serde_json::from_str::<T>(text).unwrap(), value, "{text}");
        assert_eq!(serde_json::to_string(value).unwrap(), text);
    }
    // Kebab-case (the interaction's) and lowercase (the sculpting layer's) spell every
    // profile and mode alike.
    round_trip("\"v\"", &Profile::V);
    round_trip("\"u\"", &Profile::U);
    round_trip(
        "{\"custom\":[[0.0,1.0],[0.5,0.8]]}",
        &Profile::Custom(vec![[0.0, 1.0], [0.5, 0.8]]),
    );
    round_trip("\"carve\"", &StrokeMode::Carve);
    round_trip("\"emboss\"", &StrokeMode::Emboss);
    round_trip("\"sketch\"", &InteractionMode::Sketch);
    round_trip("\"carve\"", &InteractionMode::CARVE);
    round_trip("\"emboss\"", &InteractionMode::EMBOSS);
    round_trip("\"paint\"", &InteractionMode::Paint);
    for bad in ["\"V\"", "\"Carve\"", "\"smear\""] {
        assert!(serde_json::from_str::<Profile>(bad).is_err(), "{bad}");
        assert!(
            serde_json::from_str::<InteractionMode>(bad).is_err(),
            "{bad}"
        );
    }
    // A document's stroke tool: the mode inside; no taper means blunt ends.
    let tool = Tool {
        profile: Profile::U,
        width: 0.05,
        depth: 0.01,
        mode: StrokeMode::Emboss,
        taper: 0.02,
    };
    round_trip(
        r#"{"profile":"u","width":0.05,"depth":0.01,"mode":"emboss","taper":0.02}"#,
        &tool,
    );
    let blunt: Tool =
        serde_json::from_str(r#"{"profile":"v","width":0.05,"depth":0.01,"mode":"carve"}"#)
            .unwrap();
    assert_eq!(blunt.taper, 0.0);
    // A journalled stroke: the mode beside the tool, the target an id.
    let samples = vec![
        StrokeSample {
            t: 0.0,
            position: DVec3::new(0.0, 1.0, 0.0),
        },
        StrokeSample {
            t: 0.1,
            position: DVec3::new(0.1, 1.0, 0.0),
        },
    ];
    let stroke = Edit::Stroke(StrokeEdit::new(
        1,
        Tool {
            taper: DEFAULT_TAPER,
            ..tool.clone()
        },
        samples.clone(),
    ));
    let line = r#"{"edit":"stroke","target":1,"mode":"emboss","tool":{"profile":"u","width":0.05,"depth":0.01,"taper":0.01},"samples":[{"t":0.0,"position":[0.0,1.0,0.0]},{"t":0.1,"position":[0.1,1.0,0.0]}]}"#;
    round_trip(line, &stroke);
    let Edit::Stroke(read) = serde_json::from_str::<Edit>(line).unwrap() else {
        panic!("{line} is a stroke")
    };
    assert_eq!(
        read.tool.mode,
        StrokeMode::Emboss,
        "the mode reaches the tool"
    );
    // No taper in a journalled tool: the default taper.
    let no_taper = line.replace(",\"taper\":0.01", "");
    assert_eq!(serde_json::from_str::<Edit>(&no_taper).unwrap(), stroke);
    // The tool of a journalled stroke carries no mode of its own.
    let mode_in_tool = line.replace("\"taper\"", "\"mode\":\"carve\",\"taper\"");
    assert!(serde_json::from_str::<Edit>(&mode_in_tool).is_err());
    round_trip(
        r#"{"edit":"select-target","target":2}"#,
        &Edit::SelectTarget { target: 2 },
    );
    // A version 1 journal named the target's position as `index`.
    assert_eq!(
        serde_json::from_str::<Edit>(r#"{"edit":"select-target","index":2}"#).unwrap(),
        Edit::SelectTarget { target: 2 }
    );
    // Pose-log commands.
    round_trip(
        r#"{"command":"set-mode","mode":"sketch"}"#,
        &Command::SetMode {
            mode: InteractionMode::Sketch,
        },
    );
    round_trip(
        r#"{"command":"set-mode","mode":"emboss"}"#,
        &Command::SetMode {
            mode: InteractionMode::EMBOSS,
        },
    );
    round_trip(
        r#"{"command":"set-profile","profile":"u"}"#,
        &Command::SetProfile {
            profile: Profile::U,
        },
    );
    round_trip(
        r#"{"command":"select-target","index":1}"#,
        &Command::SelectTarget {
            index: TargetIndex(1),
        },
    );
}

/// The mode button cycles sketch, carve, emboss; the tool keeps the stroke mode while
/// sketching, and strokes carry it.
#[test]
fn interaction_modes_are_built_on_the_stroke_mode() {
    let mut m = Interaction::new(
        InteractionConfig::default(),
        InteractionMode::EMBOSS,
        Tool::default(),
    );
    assert_eq!(
        m.tool().mode,
        StrokeMode::Emboss,
        "the mode reaches the tool"
    );
    let mut out = Vec::new();
    for (t, mode) in [
        (0.0, InteractionMode::Sketch),
        (0.1, InteractionMode::CARVE),
    ] {
        m.handle(&WandEvent::command(t, Command::SetMode { mode }), &mut out)
            .unwrap();
        assert_eq!(m.mode(), mode);
    }
    assert_eq!(m.tool().mode, StrokeMode::Carve);
    assert_eq!(
        InteractionMode::Sketch.next().next().next(),
        InteractionMode::Sketch
    );
    assert_eq!(
        InteractionMode::CARVE.stroke_mode(),
        Some(StrokeMode::Carve)
    );
    assert_eq!(InteractionMode::Sketch.stroke_mode(), None);
    // A custom profile is a profile like any other; the profile button leaves it for V.
    m.handle(
        &WandEvent::command(
            0.2,
            Command::SetProfile {
                profile: Profile::Custom(vec![[0.0, 1.0], [0.5, 0.5]]),
            },
        ),
        &mut out,
    )
    .unwrap();
    assert!(matches!(m.tool().profile, Profile::Custom(_)));
    assert_eq!(m.tool().profile.toggled(), Profile::V);
    let bad = Command::SetProfile {
        profile: Profile::Custom(vec![[0.5, 1.0], [0.2, 0.5]]),
    };
    assert!(matches!(
        m.handle(&WandEvent::command(0.3, bad), &mut out),
        Err(Error::Interaction(InteractionError::Profile(
            StrokeRejection::ProfileX { .. }
        )))
    ));
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn arbitrary_inputs_never_panic_or_emit_non_finite(
            steps in proptest::collection::vec((0.0f64..0.05, any::<bool>(), -1.0f64..1.0, any::<u8>(), prop_oneof![Just(f64::NAN), -1.0f64..1.0]), 0..120)
        ) {
            let mut m = Interaction::default();
            let mut t = 0.0;
            let mut out = Vec::new();
            for (dt, tracked, x, buttons, y) in steps {
                t += dt;
                let s = WandSample { tracked, position: DVec3::new(x, y, 0.0), orientation: DQuat::IDENTITY, buttons: u32::from(buttons) };
                m.handle(&WandEvent::sample(t, s), &mut out).unwrap();
            }
            for o in &out {
                if let Output::Edit(Edit::Stroke(s)) = o {
                    prop_assert!(s.samples.len() >= 2);
                    prop_assert!(s.samples.iter().all(|p| p.position.is_finite()));
                    for w in s.samples.windows(2) {
                        // No jump larger than the resume bound or the glitch bound allows.
                        let step = (w[1].position - w[0].position).length();
                        let dt = (w[1].t - w[0].t).max(MIN_SPEED_DT);
                        prop_assert!(step <= 0.05 + POINT_EPS || step / dt <= 15.0 + BOUND_MARGIN);
                    }
                }
            }
        }
    }
}
