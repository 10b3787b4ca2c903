//! The frame stage: ordering, timing, calibration with tips, loss and timeouts, and
//! the invariants (never a panic, never NaN) over random frames.

use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;
use sculpt_core::assert_near;
use sculpt_core::tolerance::{EXACT_EPS, TIME_EPS};
use std::collections::BTreeMap;
use std::time::Duration;
use tracking::calibration::Calibration;
use tracking::filter::FilterConfig;
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::stage::{FrameStage, StageConfig, StageEvent, WandSample};
use tracking::tolerance::{FILTERED_UNIT_EPS, SIM_END_TOL};
use tracking::{Body, Frame, Pose, Wand};

fn unfiltered() -> StageConfig {
    StageConfig {
        filter: FilterConfig {
            enabled: false,
            ..FilterConfig::default()
        },
        ..StageConfig::default()
    }
}

fn wand_frame(n: u64, t: f64, p_mm: DVec3, buttons: u64) -> Frame {
    let mut f = Frame::new(n);
    f.tracker_time = Some(t);
    f.receive_time = Duration::from_secs_f64(t);
    let mut w = Wand::tracked(0, Pose::from_position_mm(p_mm));
    w.buttons = buttons;
    f.wands.push(w);
    f
}

fn wands(out: &[StageEvent]) -> Vec<WandSample> {
    out.iter().filter_map(StageEvent::wand).copied().collect()
}

fn rframe(n: u64, ts: Option<f64>, x_mm: f64) -> Frame {
    let mut f = wand_frame(n, ts.unwrap_or(0.0), DVec3::new(x_mm, 1000.0, 0.0), 0);
    f.tracker_time = ts;
    f.receive_time = Duration::from_secs_f64(ts.unwrap_or(n as f64 * 0.01) + 0.25);
    f
}

/// Regression (issue 31, item 4): after a tracker restart (counter and `ts` both from
/// the start) the stage clock continued by the receive-time gap, so a live run and
/// the offline replay of its log (and two live runs) gave stroke 2 different sample
/// times (3.2666666 offline, 3.2666444 and 3.2666327 live). The restart now continues
/// one frame period (the stream's last `ts` step) after the last frame, whatever the
/// arrival: here once after a quiet 9.76 s and once with no gap at all.
#[test]
fn the_stage_clock_continues_across_a_tracker_restart() {
    let run = |restart_receive: f64| {
        let mut s = FrameStage::new(StageConfig::default()).unwrap();
        let mut out = Vec::new();
        s.push(&rframe(1, Some(10.0), 0.0), &mut out);
        s.push(&rframe(2, Some(10.01), 0.0), &mut out);
        // The tracker restarts: counter and ts from the start.
        let mut f = rframe(1, Some(0.0), 0.0);
        f.receive_time = Duration::from_secs_f64(restart_receive);
        assert!(s.push(&f, &mut out));
        let mut f = rframe(2, Some(0.01), 0.0);
        f.receive_time = Duration::from_secs_f64(restart_receive + 0.01);
        s.push(&f, &mut out);
        assert_eq!(s.metrics().clock_breaks, 1);
        assert_eq!(s.metrics().receive_timed, 0);
        wands(&out).iter().map(|w| w.t).collect::<Vec<f64>>()
    };
    let quiet = run(20.0);
    assert_eq!(quiet, run(10.27), "arrival timing changed the sample times");
    assert_eq!(quiet.len(), 4, "{quiet:?}");
    assert_near!(quiet[2], 10.02, TIME_EPS, "one period on: {quiet:?}");
    assert_near!(quiet[3] - quiet[2], 0.01, TIME_EPS, "{quiet:?}");
}

/// Issue 31, item 4: jumps of `ts` (+1e15, back to negative, 1e300, NaN) are timed
/// from the stream alone: the same frames received with different arrival jitter give
/// the same sample times, and frames without `ts` are counted as timed by arrival.
#[test]
fn ts_jumps_are_timed_from_the_stream_alone() {
    let dt = 1.0 / 60.0;
    for jump in [1e15, -5.0, 1e300, f64::NAN, 10.0 + 7200.0] {
        let run = |jitter: f64| {
            let mut s = FrameStage::new(unfiltered()).unwrap();
            let mut out = Vec::new();
            for n in 1..=12_u64 {
                let ts = match n {
                    5 | 6 => jump + (n - 5) as f64 * dt,
                    _ => 10.0 + n as f64 * dt,
                };
                let mut f = wand_frame(n, 0.0, DVec3::new(n as f64, 1000.0, 0.0), 0);
                f.tracker_time = Some(ts);
                f.receive_time =
                    Duration::from_secs_f64(n as f64 * dt + jitter * ((n * 7) % 5) as f64);
                s.push(&f, &mut out);
            }
            assert_eq!(s.metrics().receive_timed, 0);
            wands(&out).iter().map(|w| w.t).collect::<Vec<f64>>()
        };
        let a = run(0.0);
        assert_eq!(a, run(0.003), "ts jump {jump}: arrival changed the times");
        // Twelve samples, and a timeout sample where the stream's own clock shows a
        // gap (back to -5 s, then forward 15 s: a gap by the stream's word).
        assert!((12..=13).contains(&a.len()), "ts jump {jump}: {a:?}");
        assert!(a.windows(2).all(|w| w[1] > w[0]), "ts jump {jump}: {a:?}");
    }
    // Without `ts`, arrival is all there is: counted, so the report can say so.
    let mut s = FrameStage::new(unfiltered()).unwrap();
    let mut out = Vec::new();
    for n in 1..=3_u64 {
        s.push(&rframe(n, None, 0.0), &mut out);
    }
    assert_eq!(s.metrics().receive_timed, 3);
}

/// Regression (issue 15, item 1): one frame with `ts 1e300` (or any `ts` of 1e15 or
/// more, or a jump of hours) set the stage clock so far out that 1/60 s steps no
/// longer changed it, and every later stroke was "too short". Such a `ts` is now
/// refused, and the clock keeps its 60 Hz steps after it.
#[test]
fn an_absurd_tracker_time_does_not_stop_the_clock() {
    for absurd in [1e300, 1e15, 10.0 + 7200.0, f64::MAX] {
        let mut s = FrameStage::new(unfiltered()).unwrap();
        let mut out = Vec::new();
        let dt = 1.0 / 60.0;
        for n in 1..=10_u64 {
            let ts = 10.0 + n as f64 * dt;
            let mut f = rframe(n, Some(ts), 0.0);
            f.receive_time = Duration::from_secs_f64(ts);
            if n == 5 {
                f.tracker_time = Some(absurd);
            }
            assert!(s.push(&f, &mut out));
        }
        let t: Vec<f64> = wands(&out).iter().map(|w| w.t).collect();
        assert_eq!(t.len(), 10, "{absurd}");
        for w in t.windows(2) {
            let step = w[1] - w[0];
            assert!(
                step >= 0.0 && step <= 2.0 * dt + EXACT_EPS,
                "ts {absurd}: stage times {t:?}"
            );
        }
        assert!(t[9] - t[0] >= 8.0 * dt - EXACT_EPS, "ts {absurd}: {t:?}");
    }
}

#[test]
fn calibration_and_tips_put_the_tool_point_in_the_display_frame() {
    let calibration = Calibration {
        axes: ["x".into(), "z".into(), "-y".into()],
        translation_m: [0.0, 0.0, 1.0],
        tips: BTreeMap::from([("wand0".to_string(), [0.0, 0.0, -0.1])]),
        ..Calibration::default()
    };
    let mut stage = FrameStage::new(StageConfig {
        calibration,
        ..unfiltered()
    })
    .unwrap();
    let mut out = Vec::new();
    // Tracker z-up: 1 m up is tracker z = 1000 mm; display y = tracker z.
    stage.push(
        &wand_frame(1, 0.0, DVec3::new(100.0, 0.0, 1000.0), 0b1),
        &mut out,
    );
    let w = wands(&out)[0];
    assert!(w.tracked);
    assert_near!(w.position_m.to_array(), [0.1, 1.0, 1.0], EXACT_EPS);
    // The tip is 0.1 m along the body's -z; body z maps to display y (z-up tracker).
    assert_near!(w.tip_m.to_array(), [0.1, 0.9, 1.0], EXACT_EPS);
    assert_eq!(w.buttons, 1);
}

#[test]
fn stale_frames_are_dropped_and_times_come_from_ts() {
    let mut stage = FrameStage::new(unfiltered()).unwrap();
    let mut out = Vec::new();
    let mut live = Vec::new();
    let mut f = wand_frame(5, 1.0, DVec3::ZERO, 0);
    assert!(stage.push(&f, &mut out));
    f.number = 4;
    assert!(!stage.push(&f, &mut out), "older counter");
    f.number = 5;
    assert!(!stage.push(&f, &mut out), "same counter");
    assert_eq!(stage.metrics().out_of_order, 2);
    // The same frames with other receive times give the same samples.
    let mut other = FrameStage::new(unfiltered()).unwrap();
    for (n, ts) in [(5, 1.0), (6, 1.01), (7, 1.02)] {
        let mut g = wand_frame(n, ts, DVec3::new(ts * 100.0, 0.0, 0.0), 1);
        g.receive_time = Duration::from_secs_f64(40.0 + ts * 3.0);
        other.push(&g, &mut live);
        if n > 5 {
            stage.push(
                &wand_frame(n, ts, DVec3::new(ts * 100.0, 0.0, 0.0), 1),
                &mut out,
            );
        }
    }
    let (a, b) = (wands(&out), wands(&live));
    assert_eq!(a.len(), 3);
    assert_eq!(a[1..], b[1..]);
}

#[test]
fn quality_below_zero_and_a_missing_wand_are_losses_that_keep_the_buttons() {
    let mut stage = FrameStage::new(unfiltered()).unwrap();
    let mut out = Vec::new();
    stage.push(&wand_frame(1, 0.00, DVec3::ZERO, 1), &mut out);
    let mut f = wand_frame(2, 0.01, DVec3::ZERO, 1);
    f.wands[0].quality = -1.0;
    stage.push(&f, &mut out);
    let mut f = Frame::new(3);
    f.tracker_time = Some(0.02);
    stage.push(&f, &mut out);
    stage.push(&wand_frame(4, 0.03, DVec3::ZERO, 0), &mut out);
    let w = wands(&out);
    assert_eq!(
        w.iter().map(|s| s.tracked).collect::<Vec<_>>(),
        [true, false, false, true]
    );
    assert_eq!(
        w[2].buttons, 1,
        "an absent wand does not release its button"
    );
    let m = stage.metrics();
    assert_eq!((m.losses, m.without_wand, m.timeouts), (1, 1, 0));
    assert_near!(m.lost_s, 0.02, EXACT_EPS);
}

#[test]
fn a_silent_gap_times_out_once_whether_idle_or_the_next_frame_finds_it() {
    for use_idle in [false, true] {
        let mut stage = FrameStage::new(unfiltered()).unwrap();
        let mut out = Vec::new();
        stage.push(&wand_frame(1, 1.0, DVec3::ZERO, 1), &mut out);
        if use_idle {
            assert!(!stage.idle(Duration::from_secs_f64(1.4), &mut out));
            assert!(stage.idle(Duration::from_secs_f64(1.6), &mut out));
            assert!(!stage.idle(Duration::from_secs_f64(1.9), &mut out), "once");
        }
        stage.push(&wand_frame(2, 2.0, DVec3::ZERO, 1), &mut out);
        let w = wands(&out);
        assert_eq!(w.len(), 3, "idle: {use_idle}");
        assert!(!w[1].tracked);
        assert_near!(w[1].t, 1.5, EXACT_EPS);
        assert_eq!(w[1].buttons, 1);
        let m = stage.metrics();
        assert_eq!((m.timeouts, m.losses), (1, 1));
        assert_near!(m.lost_s, 0.5, EXACT_EPS);
    }
}

#[test]
fn head_poses_are_calibrated_and_filtered() {
    let mut stage = FrameStage::new(StageConfig::default()).unwrap();
    let mut out = Vec::new();
    let mut f = wand_frame(1, 0.0, DVec3::ZERO, 0);
    f.bodies.push(Body {
        id: 0,
        quality: 1.0,
        pose: Pose::from_position_mm(DVec3::new(0.0, 1700.0, 600.0)),
    });
    stage.push(&f, &mut out);
    let StageEvent::Head(h) = out[0] else {
        panic!("head first: {out:?}")
    };
    assert_near!(h.pose.position_m.to_array(), [0.0, 1.7, 0.6], EXACT_EPS);
    assert_eq!(stage.metrics().head_poses, 1);
}

#[test]
fn a_simulated_session_passes_through_with_every_frame_used() {
    let script = Script::new(DVec3::new(0.0, 1.0, 0.2))
        .press(0)
        .move_to(DVec3::new(0.2, 1.0, 0.2), 0.5)
        .release(0);
    let frames: Vec<Frame> = Simulator::new(&script, SimConfig::default())
        .unwrap()
        .collect();
    let mut stage = FrameStage::new(StageConfig::default()).unwrap();
    let mut out = Vec::new();
    for f in &frames {
        stage.push(f, &mut out);
    }
    let w = wands(&out);
    assert_eq!(w.len(), frames.len());
    assert!(w.iter().all(|s| s.tracked));
    assert!(w.iter().any(|s| s.buttons & 1 == 1));
    assert_near!(w.last().unwrap().tip_m.x, 0.2, SIM_END_TOL);
}

fn pose_strategy() -> impl Strategy<Value = Pose> {
    let num = prop_oneof![
        4 => -5000.0..5000.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(1e300),
    ];
    (
        prop::array::uniform3(num.clone()),
        prop::array::uniform4(-1.0..1.0f64),
        prop::array::uniform9(num),
        any::<bool>(),
    )
        .prop_map(|(p, q, m, use_matrix)| Pose {
            position_mm: DVec3::from_array(p),
            tracker_from_body: if use_matrix {
                DMat3::from_cols_array(&m)
            } else {
                DMat3::from_quat(DQuat::from_array(q).normalize())
            },
        })
}

fn frame_strategy() -> impl Strategy<Value = Frame> {
    (
        0..40u64,
        prop::option::of(prop_oneof![0.0..10.0f64, Just(f64::NAN), Just(-1.0)]),
        0..20_000u64,
        prop::option::of((pose_strategy(), -1.5..1.0f64, any::<u64>())),
        prop::option::of((pose_strategy(), -1.0..1.0f64)),
    )
        .prop_map(|(n, ts, rx_ms, wand, head)| {
            let mut f = Frame::new(n);
            f.tracker_time = ts;
            f.receive_time = Duration::from_millis(rx_ms);
            if let Some((pose, quality, buttons)) = wand {
                let mut w = Wand::tracked(0, pose);
                w.quality = quality;
                w.buttons = buttons;
                f.wands.push(w);
            }
            if let Some((pose, quality)) = head {
                f.bodies.push(Body {
                    id: 0,
                    quality,
                    pose,
                });
            }
            f
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_frames_never_panic_or_emit_nan(
        frames in prop::collection::vec(frame_strategy(), 0..60),
        idles in prop::collection::vec(0..20_000u64, 0..60),
    ) {
        let mut stage = FrameStage::new(StageConfig::default()).unwrap();
        let mut out = Vec::new();
        for (k, f) in frames.iter().enumerate() {
            stage.push(f, &mut out);
            if let Some(&ms) = idles.get(k) {
                stage.idle(Duration::from_millis(ms), &mut out);
            }
        }
        let mut last_t = f64::NEG_INFINITY;
        for e in &out {
            match e {
                StageEvent::Wand(w) => {
                    prop_assert!(w.t.is_finite() && w.t >= last_t, "time {} after {}", w.t, last_t);
                    last_t = w.t;
                    prop_assert!(w.tip_m.is_finite() && w.position_m.is_finite());
                    prop_assert!(w.orientation.is_finite());
                    prop_assert!(!w.tracked || (w.orientation.length() - 1.0).abs() < FILTERED_UNIT_EPS);
                }
                StageEvent::Head(h) => {
                    prop_assert!(h.t.is_finite());
                    prop_assert!(h.pose.position_m.is_finite() && h.pose.orientation.is_finite());
                }
            }
        }
        let m = stage.metrics_until(last_t.max(0.0));
        prop_assert_eq!(m.frames, frames.len());
        prop_assert_eq!(m.used + m.out_of_order, m.frames);
        prop_assert!(m.lost_s.is_finite() && m.lost_s >= 0.0);
    }
}

/// Regression (issue 15, item 4): frames 151 to 250 renumbered 9850 down to 9751 were
/// kept or dropped by how fast they arrived: a source "quiet" for a second of arrival
/// time since the last accepted frame could restart its counter, so at speed 1 frame
/// 212 (a second after 151) was kept, and at speed 3 it was not. The order rule now
/// reads only the frames' contents: every arrival spacing keeps the same frames.
#[test]
fn a_counter_running_backwards_is_ordered_alike_at_any_arrival_speed() {
    let run = |speed: f64| {
        let mut stage = FrameStage::new(unfiltered()).unwrap();
        let mut out = Vec::new();
        let mut kept = Vec::new();
        for k in 1..=300u64 {
            let n = if (151..=250).contains(&k) {
                10_001 - k
            } else {
                k
            };
            let ts = k as f64 / 60.0;
            let mut f = wand_frame(n, ts, DVec3::new(ts * 10.0, 1000.0, 0.0), 1);
            f.receive_time = Duration::from_secs_f64(ts / speed);
            if stage.push(&f, &mut out) {
                kept.push(n);
            }
        }
        (kept, wands(&out), stage.metrics().clone())
    };
    let (kept, samples, metrics) = run(1.0);
    let mut want: Vec<u64> = (1..=151).collect();
    want[150] = 9850;
    want.extend(251..=300);
    assert_eq!(kept, want, "the backward run is dropped, 251 is a reset");
    assert_eq!(metrics.out_of_order, 99);
    for speed in [0.25, 3.0, 10.0, 1e6] {
        let (k, s, m) = run(speed);
        assert_eq!(k, kept, "speed {speed}");
        assert_eq!(s, samples, "speed {speed}");
        assert_eq!(m, metrics, "speed {speed}");
    }
}

/// A restarted tracker (counter and `ts` from the start again) is accepted at once,
/// however close its first frame arrives to the last one: the `ts` going back a second
/// or more is the signal, not the arrival gap.
#[test]
fn a_restart_is_recognised_by_its_clock_not_by_arrival() {
    let mut s = FrameStage::new(StageConfig::default()).unwrap();
    let mut out = Vec::new();
    s.push(&rframe(50, Some(30.0), 0.0), &mut out);
    let mut f = rframe(1, Some(0.0), 0.0);
    f.receive_time = Duration::from_secs_f64(30.26);
    assert!(s.push(&f, &mut out), "ts went back 30 s: a restart");
    assert!(s.push(&rframe(3, Some(0.05), 0.0), &mut out));
    // A late frame whose clock went back less than a second is out of order, however
    // long after the last one it arrives.
    let mut late = rframe(2, Some(0.04), 0.0);
    late.receive_time = Duration::from_secs_f64(40.0);
    assert!(!s.push(&late, &mut out));
    assert_eq!(s.metrics().out_of_order, 1);
}
