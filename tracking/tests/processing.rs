//! Calibration (Umeyama fit, tip offsets), the One Euro filter and the merge hub.

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use sculpt_core::assert_near;
use sculpt_core::tolerance::{EXACT_EPS, POINT_EPS};
use std::time::Duration;
use tracking::calibration::{Calibration, DisplayPose, FitOptions, fit};
use tracking::config::TrackingConfig;
use tracking::filter::{FilterConfig, PoseFilter};
use tracking::hub::{Hub, TrackingEvent, TrackingStatus};
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::tolerance::NOISY_RMS_CEIL;
use tracking::tolerance::{
    NOISY_RMS_FLOOR, NORMALISED_EPS, QUAT_GEN_MIN_LEN, ROTATION_EPS, WIRE_M_EPS,
};
use tracking::{DeviceId, Frame, Pose, Wand};

fn truth() -> Calibration {
    Calibration {
        axes: ["x".into(), "z".into(), "-y".into()],
        rotation: DQuat::from_euler(glam::EulerRot::YXZ, 0.4, -0.2, 0.1).to_array(),
        translation_m: [0.5, -0.1, 2.0],
        ..Calibration::default()
    }
}

#[test]
fn fit_recovers_the_transform_and_reports_noise() {
    let t = truth();
    let pts: Vec<DVec3> = (0..8)
        .map(|i| DVec3::new((i % 2) as f64, ((i / 2) % 2) as f64, (i / 4) as f64) * 1500.0 - 700.0)
        .collect();
    // ±0.5 mm of deterministic "measurement noise" on the display side.
    let pairs: Vec<_> = pts
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let n = DVec3::new(
                (i as f64 * 1.7).sin(),
                (i as f64 * 2.3).cos(),
                (i as f64 * 0.9).sin(),
            ) * 0.0005;
            (p, t.point_in_display(p) + n)
        })
        .collect();
    let opts = FitOptions {
        base: Calibration {
            axes: t.axes.clone(),
            ..Calibration::default()
        },
        fit_scale: false,
    };
    let f = fit(&pairs, &opts).unwrap();
    assert!(
        f.rms_residual_m > NOISY_RMS_FLOOR && f.rms_residual_m < NOISY_RMS_CEIL,
        "rms {}",
        f.rms_residual_m
    );
    assert!(f.max_residual_m >= f.rms_residual_m);
    assert_eq!(f.residuals_m.len(), 8);
    let probe = DVec3::new(100.0, 2000.0, -300.0);
    assert_near!(
        f.calibration.point_in_display(probe).to_array(),
        t.point_in_display(probe).to_array(),
        0.002
    );
}

#[test]
fn fit_scale_recovers_centimetres() {
    let t = Calibration {
        scale: 0.01,
        ..truth()
    };
    let pts = [
        DVec3::ZERO,
        DVec3::X * 100.0,
        DVec3::Y * 50.0,
        DVec3::new(10.0, 20.0, 90.0),
    ];
    let pairs: Vec<_> = pts.iter().map(|&p| (p, t.point_in_display(p))).collect();
    let opts = FitOptions {
        base: Calibration {
            axes: t.axes.clone(),
            ..Calibration::default()
        },
        fit_scale: true,
    };
    let f = fit(&pairs, &opts).unwrap();
    assert_near!(f.calibration.scale, 0.01, EXACT_EPS);
    assert!(f.rms_residual_m < POINT_EPS);
}

#[test]
fn degenerate_fits_are_errors() {
    let line: Vec<_> = (0..5)
        .map(|i| (DVec3::X * i as f64, DVec3::X * i as f64 * 0.001))
        .collect();
    assert!(fit(&line, &FitOptions::default()).is_err());
    assert!(fit(&line[..2], &FitOptions::default()).is_err());
    let nan = vec![(DVec3::NAN, DVec3::ZERO); 4];
    assert!(fit(&nan, &FitOptions::default()).is_err());
}

#[test]
fn tip_offset_moves_the_tool_point() {
    let mut c = Calibration::default();
    c.tips.insert("wand0".into(), [0.0, 0.0, -0.15]);
    c.validate().unwrap();
    // Wand turned 90 degrees about y: its -z axis points along -x in the room.
    let pose = Pose::from_quat(
        DVec3::new(0.0, 1000.0, 0.0),
        DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2),
    );
    let w = c.pose_in_display(DeviceId::Wand(0), &pose).unwrap();
    assert_near!(w.tool_m.to_array(), [-0.15, 1.0, 0.0], EXACT_EPS);
    // Other devices have no tip.
    let b = c.pose_in_display(DeviceId::Body(0), &pose).unwrap();
    assert_near!(b.tool_m.to_array(), b.position_m.to_array(), 0.0);
}

proptest! {
    #[test]
    fn exact_pairs_fit_exactly(q in prop::array::uniform4(-1.0..1.0f64), t in prop::array::uniform3(-3.0..3.0f64)) {
        prop_assume!(DQuat::from_array(q).length() > 0.1);
        let c = Calibration { rotation: q, translation_m: t, ..Calibration::default() };
        let pts = [DVec3::ZERO, DVec3::X * 900.0, DVec3::Y * 1100.0, DVec3::new(-300.0, 250.0, 1200.0), DVec3::new(500.0, -400.0, 80.0)];
        let pairs: Vec<_> = pts.iter().map(|&p| (p, c.point_in_display(p))).collect();
        let f = fit(&pairs, &FitOptions::default()).unwrap();
        prop_assert!(f.rms_residual_m < POINT_EPS);
    }

    #[test]
    fn filter_never_outputs_nan(steps in prop::collection::vec((0.0..0.05f64, prop::array::uniform3(-1e3..1e3f64), prop::array::uniform4(-1.0..1.0f64)), 1..50)) {
        let mut f = PoseFilter::new(FilterConfig::default());
        let mut t = 0.0;
        for (dt, p, q) in steps {
            t += dt;
            let q = DQuat::from_array(q);
            let q = if q.length() < QUAT_GEN_MIN_LEN { DQuat::IDENTITY } else { q.normalize() };
            let p = DVec3::from_array(p);
            let out = f.filter(t, DisplayPose { position_m: p, orientation: q, tool_m: p });
            prop_assert!(out.position_m.is_finite() && out.orientation.is_finite() && out.tool_m.is_finite());
            assert_near!(out.orientation.length(), 1.0, NORMALISED_EPS);
        }
    }
}

fn wp(p: DVec3, q: DQuat) -> DisplayPose {
    DisplayPose {
        position_m: p,
        orientation: q,
        tool_m: p,
    }
}

#[test]
fn filter_steadies_a_still_wand_and_follows_a_moving_one() {
    let mut f = PoseFilter::new(FilterConfig::default());
    let mut in_dev = 0.0f64;
    let mut out_dev = 0.0f64;
    for i in 0..600 {
        let t = i as f64 / 120.0;
        let jitter = DVec3::new(
            (i as f64 * 2.1).sin(),
            (i as f64 * 3.7).cos(),
            (i as f64 * 5.3).sin(),
        ) * 0.0005;
        let out = f.filter(t, wp(DVec3::ONE + jitter, DQuat::IDENTITY));
        if i > 120 {
            in_dev = in_dev.max(jitter.length());
            out_dev = out_dev.max((out.position_m - DVec3::ONE).length());
        }
    }
    assert!(out_dev < in_dev / 3.0, "jitter {in_dev} -> {out_dev}");
    // A 1 m/s sweep: the lag stays small once moving.
    let mut f = PoseFilter::new(FilterConfig::default());
    let mut lag = 0.0;
    for i in 0..240 {
        let t = i as f64 / 120.0;
        let out = f.filter(t, wp(DVec3::X * t, DQuat::IDENTITY));
        lag = t - out.position_m.x;
    }
    assert!(lag > 0.0 && lag < 0.05, "lag {lag} m at 1 m/s");
    // Off: identity.
    let mut off = PoseFilter::new(FilterConfig {
        enabled: false,
        ..FilterConfig::default()
    });
    off.filter(0.0, wp(DVec3::ZERO, DQuat::IDENTITY));
    let out = off.filter(0.01, wp(DVec3::ONE, DQuat::IDENTITY));
    assert_near!(out.position_m.to_array(), [1.0, 1.0, 1.0], 0.0);
}

#[test]
fn filter_ignores_quaternion_sign_flips() {
    let mut f = PoseFilter::new(FilterConfig::default());
    let q = DQuat::from_rotation_z(1.0);
    for i in 0..50 {
        let qi = if i % 2 == 0 { q } else { -q };
        let out = f.filter(i as f64 / 100.0, wp(DVec3::ZERO, qi));
        assert!(out.orientation.angle_between(q) < ROTATION_EPS);
    }
}

fn config() -> TrackingConfig {
    TrackingConfig {
        filter: FilterConfig {
            enabled: false,
            ..FilterConfig::default()
        },
        ..TrackingConfig::default()
    }
}

#[test]
fn hub_follows_a_simulated_session() {
    let script = Script::new(DVec3::new(0.0, 1.0, 0.0))
        .move_to(DVec3::new(0.2, 1.0, 0.0), 0.3)
        .press(0)
        .occlude_wand(0.2)
        .move_to(DVec3::new(0.4, 1.0, 0.0), 0.3)
        .release(0)
        .hold(0.1);
    let hub = Hub::new(&config());
    let src = hub.add_source("sim");
    let wand = hub.watch(DeviceId::Wand(0));
    let mut events = hub.subscribe();
    let truth = script.timeline();
    let mut frozen: Option<DisplayPose> = None;
    for f in Simulator::new(&script, SimConfig::exact()).unwrap() {
        let t = f.receive_time.as_secs_f64();
        assert!(hub.apply_frame(src, &f));
        let s = wand.borrow().clone();
        if truth.occluded(DeviceId::Wand(0), t) {
            assert_eq!(s.status, TrackingStatus::Lost);
            // Frozen: the pose does not move while lost.
            let pose = s.pose.unwrap();
            if let Some(fz) = frozen {
                assert_eq!(pose, fz);
            }
            frozen = Some(pose);
        } else {
            assert_eq!(s.status, TrackingStatus::Tracking);
            assert_near!(
                s.pose.unwrap().position_m.to_array(),
                truth.wand_at(t).position_m.to_array(),
                WIRE_M_EPS
            );
        }
        assert_eq!(s.buttons, truth.buttons_at(t));
    }
    let mut got = Vec::new();
    while let Ok(e) = events.try_recv() {
        got.push(e);
    }
    let buttons: Vec<(u8, bool)> = got
        .iter()
        .filter_map(|e| match e {
            TrackingEvent::Button {
                button, pressed, ..
            } => Some((*button, *pressed)),
            _ => None,
        })
        .collect();
    assert_eq!(buttons, vec![(0, true), (0, false)]);
    let statuses: Vec<TrackingStatus> = got
        .iter()
        .filter_map(|e| match e {
            TrackingEvent::Status {
                device: DeviceId::Wand(0),
                status,
                ..
            } => Some(*status),
            _ => None,
        })
        .collect();
    assert_eq!(
        statuses,
        vec![
            TrackingStatus::Tracking,
            TrackingStatus::Lost,
            TrackingStatus::Tracking
        ]
    );
}

fn wand_frame(n: u64, x_mm: f64, ms: u64) -> Frame {
    let mut f = Frame::new(n);
    f.receive_time = Duration::from_millis(ms);
    f.wands.push(Wand::tracked(
        0,
        Pose::from_position_mm(DVec3::new(x_mm, 0.0, 0.0)),
    ));
    f
}

#[test]
fn out_of_order_frames_are_dropped_and_stale_devices_lost() {
    let hub = Hub::new(&config());
    let src = hub.add_source("t");
    let wand = hub.watch(DeviceId::Wand(0));
    assert!(hub.apply_frame(src, &wand_frame(10, 10.0, 0)));
    assert!(!hub.apply_frame(src, &wand_frame(9, 9.0, 1)));
    assert!(!hub.apply_frame(src, &wand_frame(10, 9.0, 1)));
    assert!(hub.apply_frame(src, &wand_frame(12, 12.0, 2)));
    assert_near!(wand.borrow().pose.unwrap().position_m.x, 0.012, EXACT_EPS);
    assert_eq!(hub.source_stats(src).unwrap().out_of_order, 2);
    // A restarted tracker (after a quiet second) counts from 1 again.
    assert!(hub.apply_frame(src, &wand_frame(1, 1.0, 2000)));
    // Stale after lost_after (100 ms).
    hub.check_stale(Duration::from_millis(2050));
    assert_eq!(wand.borrow().status, TrackingStatus::Tracking);
    hub.check_stale(Duration::from_millis(2101));
    assert_eq!(wand.borrow().status, TrackingStatus::Lost);
    assert_near!(wand.borrow().pose.unwrap().position_m.x, 0.001, EXACT_EPS);
    hub.set_connected(src, false, Duration::from_millis(2200));
    assert_eq!(wand.borrow().status, TrackingStatus::Disconnected);
}

#[test]
fn missing_bodies_and_buttons_only_sources() {
    let hub = Hub::new(&config());
    let dtrack = hub.add_source("dtrack");
    let serial = hub.add_source("serial");
    let head = hub.watch(DeviceId::Body(3));
    let mut f = Frame::new(1);
    f.bodies.push(tracking::Body {
        id: 3,
        quality: 1.0,
        pose: Pose::IDENTITY,
    });
    hub.apply_frame(dtrack, &f);
    assert_eq!(head.borrow().status, TrackingStatus::Tracking);
    hub.apply_frame(dtrack, &Frame::new(2));
    assert_eq!(
        head.borrow().status,
        TrackingStatus::Lost,
        "a body missing from 6d is untracked"
    );
    // Wand pose from DTrack, buttons from a serial wand.
    hub.apply_frame(dtrack, &wand_frame(3, 5.0, 0));
    let rec = tracking::serial::SerialRecord {
        seq: 1,
        buttons: 0b10,
        pose: None,
    };
    hub.apply(serial, &rec.to_frame(0, 6), false);
    let w = hub.watch(DeviceId::Wand(0)).borrow().clone();
    assert_eq!(w.status, TrackingStatus::Tracking);
    assert_eq!(w.buttons, 0b10);
}

#[test]
fn readme_config_example_parses() {
    // Keeps the README's documented config honest.
    let readme = include_str!("../../README.md");
    let section = readme
        .split("### Config file (TOML)")
        .nth(1)
        .expect("README config section");
    let block = section
        .split("```toml")
        .nth(1)
        .unwrap()
        .split("```")
        .next()
        .unwrap();
    let cfg = TrackingConfig::from_toml_str(block).unwrap();
    assert_eq!(cfg.sources.len(), 2);
    assert_eq!(cfg.calibration.tips.len(), 1);
    // Z-up tracker, 1 m up -> display y = 1 m (then 2 m back).
    assert_near!(
        cfg.calibration
            .point_in_display(DVec3::new(0.0, 0.0, 1000.0))
            .to_array(),
        [0.0, 1.0, -2.0],
        EXACT_EPS
    );
}

#[test]
fn readme_serial_examples_decode() {
    let readme = include_str!("../../README.md");
    let mut n = 0;
    for line in readme.lines().filter(|l| l.starts_with("$WAND,1")) {
        let rec = line.split("\\r\\n").next().unwrap();
        tracking::serial::parse_serial(rec.as_bytes()).unwrap();
        n += 1;
    }
    assert_eq!(n, 2);
}

#[test]
fn pivot_calibration_finds_the_tip() {
    use tracking::calibration::fit_tip;
    let tip = DVec3::new(0.01, -0.02, -0.15);
    let pivot = DVec3::new(0.3, 1.1, -0.4);
    let poses: Vec<(DVec3, DQuat)> = (0..12)
        .map(|i| {
            let a = i as f64 * 0.5;
            let q = DQuat::from_euler(
                glam::EulerRot::YXZ,
                a.sin() * 0.8,
                a.cos() * 0.5,
                0.2 * a.sin(),
            );
            (pivot - q * tip, q)
        })
        .collect();
    let f = fit_tip(&poses).unwrap();
    assert_near!(f.tip_in_body_m.to_array(), tip.to_array(), POINT_EPS);
    assert_near!(f.pivot_in_display_m.to_array(), pivot.to_array(), POINT_EPS);
    assert!(f.rms_residual_m < POINT_EPS);
    // One rotation axis only cannot pin the tip down along that axis.
    let flat: Vec<(DVec3, DQuat)> = (0..8)
        .map(|i| {
            let q = DQuat::from_rotation_y(i as f64 * 0.3);
            (pivot - q * tip, q)
        })
        .collect();
    assert!(fit_tip(&flat).is_err());
    assert!(fit_tip(&poses[..2]).is_err());
}

#[test]
fn a_body_with_negative_quality_is_lost_not_moved() {
    let hub = Hub::new(&config());
    let src = hub.add_source("t");
    let head = hub.watch(DeviceId::Body(0));
    let mut f = Frame::new(1);
    f.bodies.push(tracking::Body {
        id: 0,
        quality: 1.0,
        pose: Pose::from_position_mm(DVec3::X * 10.0),
    });
    hub.apply_frame(src, &f);
    let mut g = Frame::new(2);
    g.bodies.push(tracking::Body {
        id: 0,
        quality: -1.0,
        pose: Pose::from_position_mm(DVec3::X * 99.0),
    });
    hub.apply_frame(src, &g);
    let s = head.borrow().clone();
    assert_eq!(s.status, TrackingStatus::Lost);
    assert_near!(s.pose.unwrap().position_m.x, 0.01, EXACT_EPS);
}
