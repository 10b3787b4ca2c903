//! The simulator: scripted ground truth, tremor and noise statistics, occlusions, buttons.

use glam::DVec3;
use sculpt_core::assert_near;
use sculpt_core::tolerance::{BOUND_MARGIN, EXACT_EPS};
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::tolerance::{MM_ROUNDING_EPS, VELOCITY_EPS, VELOCITY_FD_STEP};

fn reach() -> Script {
    Script::new(DVec3::new(0.0, 1.0, 0.0))
        .mark("start")
        .move_to(DVec3::new(0.3, 1.1, -0.2), 0.8)
        .hold(0.5)
        .press(0)
        .move_to(DVec3::new(0.3, 1.3, -0.2), 0.4)
        .release(0)
        .occlude_wand(0.1)
        .hold(0.2)
        .head_move_to(DVec3::new(0.2, 1.7, 0.6), 1.0)
}

#[test]
fn exact_config_follows_the_script() {
    let script = reach();
    let truth = script.timeline();
    assert_near!(truth.duration, 2.9, EXACT_EPS);
    let frames: Vec<_> = Simulator::new(&script, SimConfig::exact())
        .unwrap()
        .collect();
    assert_eq!(frames.len(), 349);
    for f in &frames {
        let t = f.receive_time.as_secs_f64();
        let w = &f.wands[0];
        if truth.occluded(tracking::DeviceId::Wand(0), t) {
            assert!(!w.is_tracked());
        } else {
            let p = truth.wand_at(t).position_m * 1000.0;
            assert_near!(w.pose.position_mm.to_array(), p.to_array(), MM_ROUNDING_EPS);
        }
        assert_eq!(w.buttons, truth.buttons_at(t));
    }
    // The button is down during the second move only.
    assert_eq!(truth.buttons_at(1.2), 0);
    assert_eq!(truth.buttons_at(1.4), 1);
    assert_eq!(truth.buttons_at(1.8), 0);
    assert_eq!(truth.marks, vec![(0.0, "start".to_string())]);
}

#[test]
fn minimum_jerk_is_smooth_and_symmetric() {
    let tl = Script::new(DVec3::ZERO).move_to(DVec3::X, 1.0).timeline();
    assert_near!(tl.wand_at(0.5).position_m.x, 0.5, EXACT_EPS);
    // s(0.25) = 10/64 - 15/256 + 6/1024
    assert_near!(
        tl.wand_at(0.25).position_m.x,
        10.0 / 64.0 - 15.0 / 256.0 + 6.0 / 1024.0,
        EXACT_EPS
    );
    // Zero velocity at both ends.
    let v0 = (tl.wand_at(VELOCITY_FD_STEP).position_m.x - tl.wand_at(0.0).position_m.x)
        / VELOCITY_FD_STEP;
    assert_near!(v0, 0.0, VELOCITY_EPS);
}

#[test]
fn tremor_and_noise_have_the_configured_size() {
    let script = Script::new(DVec3::new(0.0, 1.0, 0.0)).hold(4.0);
    let cfg = SimConfig {
        tremor_mm: 0.3,
        noise_mm: 0.0,
        rate_hz: 300.0,
        ..SimConfig::default()
    };
    let xs: Vec<f64> = Simulator::new(&script, cfg)
        .unwrap()
        .map(|f| f.wands[0].pose.position_mm.x)
        .collect();
    let max = xs.iter().map(|x| x.abs()).fold(0.0, f64::max);
    assert!(
        max > 0.1 && max <= 0.3 + BOUND_MARGIN,
        "peak tremor {max} mm"
    );
    // Zero crossings of an 8-12 Hz oscillation over 4 s: about 64-96 of them.
    let crossings = xs
        .windows(2)
        .filter(|w| w[0].signum() != w[1].signum())
        .count();
    assert!((40..=110).contains(&crossings), "{crossings} crossings");
}

#[test]
fn same_seed_same_session_and_dropouts_happen() {
    let script = Script::new(DVec3::ZERO).hold(5.0);
    let cfg = SimConfig {
        dropouts_per_s: 2.0,
        dropout_secs: 0.1,
        ..SimConfig::default()
    };
    let a = Simulator::new(&script, cfg.clone())
        .unwrap()
        .to_dtrack_bytes();
    let b = Simulator::new(&script, cfg.clone())
        .unwrap()
        .to_dtrack_bytes();
    assert_eq!(a, b);
    let lost = Simulator::new(&script, cfg)
        .unwrap()
        .filter(|f| !f.wands[0].is_tracked())
        .count();
    assert!(lost > 0 && lost < 300, "{lost} frames lost");
}

#[test]
fn invalid_scripts_and_configs_are_refused() {
    assert!(Simulator::new(&Script::new(DVec3::ZERO).hold(-1.0), SimConfig::default()).is_err());
    assert!(
        Simulator::new(
            &Script::new(DVec3::ZERO).move_to(DVec3::NAN, 1.0),
            SimConfig::default()
        )
        .is_err()
    );
    assert!(Simulator::new(&Script::new(DVec3::ZERO).press(64), SimConfig::default()).is_err());
    let bad_rate = SimConfig {
        rate_hz: 0.0,
        ..SimConfig::default()
    };
    assert!(Simulator::new(&Script::new(DVec3::ZERO), bad_rate).is_err());
}

#[test]
fn scripts_load_from_toml() {
    let text = r#"
wand_start = [0.0, 1.0, 0.0]
[[step]]
op = "move"
to = [0.1, 1.0, 0.0]
secs = 0.5
[[step]]
op = "click"
button = 1
secs = 0.1
[[step]]
op = "mark"
label = "done"
"#;
    let script: Script = toml::from_str(text).unwrap();
    assert_near!(script.duration(), 0.6, EXACT_EPS);
    assert_eq!(script.timeline().buttons_at(0.55), 2);
    let back: Script = toml::from_str(&toml::to_string(&script).unwrap()).unwrap();
    assert_eq!(back, script);
}

#[test]
fn timeline_of_an_unvalidated_script_does_not_panic() {
    // Regression: `1 << 64` overflowed in `timeline()` for a bad button index.
    let script = Script::new(DVec3::ZERO).press(200).click(64, 0.1);
    assert_eq!(script.timeline().buttons_at(1.0), 0);
}
