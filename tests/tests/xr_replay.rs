//! A headset session replays: scripted controller states (what the OpenXR actions
//! report) go through `XrWand`, the path `wandsculpt --xr` runs (tracker frames, frame
//! stage, edit loop, journal, operator log), and `replay` of the pose log it wrote,
//! with the replay config it wrote, builds the same document byte for byte, the
//! thumbstick's tool changes included. No OpenXR runtime is involved.

mod support;

use glam::{DQuat, DVec3};
use replay::config::ReplayConfig;
use replay::pipeline::{default_document, replay_log};
use sculpt_core::editor::default_surface_point;
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::xr::actions::{ControllerState, Feedback};
use vr_app::xr::wand::{POSE_LOG_FILE, REPLAY_CONFIG_FILE};

#[test]
fn a_headset_session_replays_to_the_same_document() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = Config::default();
    cfg.files.dir = dir.path().to_path_buf();
    let mut app = AppState::new(cfg).unwrap();
    let start_tool = app.session.interaction.tool().clone();
    // A grip pose in the stage for a point of the display frame.
    let (mut wand, grip_at) =
        support::scripted_headset(&app, dir.path(), DQuat::from_rotation_x(-0.3));
    let dt = 1.0 / 90.0;
    let mut t = 0.0;
    let mut pulses = Vec::new();
    // Two strokes across the sheet, at two heights, the trigger squeezed past its
    // hysteresis, with a pause between them: an undo press and release, then the
    // thumbstick held right and down for half a second (a wider, shallower tool).
    for (row, y) in [1.1, 1.25].into_iter().enumerate() {
        for i in 0..=40 {
            let x = -0.12 + 0.006 * f64::from(i);
            let state = ControllerState {
                grip: Some(grip_at(default_surface_point(x, y))),
                trigger: if (1..40).contains(&i) { 0.9 } else { 0.1 },
                ..ControllerState::default()
            };
            pulses.extend(wand.step(&mut app, t, &state, None).unwrap());
            t += dt;
        }
        if row == 0 {
            for undo in [true, false, false] {
                let state = ControllerState {
                    grip: Some(grip_at(default_surface_point(0.0, 1.2) + DVec3::Z * 0.1)),
                    undo,
                    ..ControllerState::default()
                };
                pulses.extend(wand.step(&mut app, t, &state, None).unwrap());
                t += dt;
            }
            for _ in 0..STICK_FRAMES {
                let state = ControllerState {
                    grip: Some(grip_at(default_surface_point(0.0, 1.2) + DVec3::Z * 0.1)),
                    thumbstick: [0.9, -0.6],
                    ..ControllerState::default()
                };
                pulses.extend(wand.step(&mut app, t, &state, None).unwrap());
                t += dt;
            }
        }
    }
    assert_eq!(
        pulses,
        [Feedback::Applied, Feedback::Applied],
        "one pulse per stroke"
    );
    assert_eq!(
        app.session.doc.strokes().len(),
        1,
        "two strokes, one undone"
    );
    assert_eq!(wand.frames(), 85 + STICK_FRAMES);
    // The thumbstick changed the tool, and the second stroke was cut with it.
    let tool = app.session.interaction.tool().clone();
    assert!(
        tool.width > start_tool.width && tool.depth < start_tool.depth,
        "{start_tool:?} -> {tool:?}"
    );
    let stroke = app.session.doc.strokes().last().unwrap();
    assert_eq!(stroke.input.tool.width, tool.width);
    let live = app.session.doc.to_json();

    let log = std::fs::read(dir.path().join(POSE_LOG_FILE)).unwrap();
    let config = std::fs::read_to_string(dir.path().join(REPLAY_CONFIG_FILE)).unwrap();
    let replay_cfg = ReplayConfig::from_toml_str(&config).unwrap();
    assert!(replay_cfg.thumbstick.is_some(), "{config}");
    let outcome = replay_log(&log, &replay_cfg, default_document(), "xr", false, None).unwrap();
    assert_eq!(
        String::from_utf8_lossy(&outcome.document.to_json()),
        String::from_utf8_lossy(&live),
        "replay of the headset session's pose log"
    );
    // Without the `[thumbstick]` section (a config from before it existed) the axes
    // change nothing: the second stroke keeps the starting tool, and the documents
    // differ.
    let without = ReplayConfig {
        thumbstick: None,
        ..replay_cfg
    };
    let outcome = replay_log(&log, &without, default_document(), "xr", false, None).unwrap();
    let stroke = outcome.document.strokes().last().unwrap();
    assert_eq!(stroke.input.tool.width, start_tool.width);
    assert_ne!(outcome.document.to_json(), live);
}

/// Frames with the thumbstick held (90 Hz: half a second).
const STICK_FRAMES: u64 = 45;

/// Issue 35 item 1 in the headset: the lattice action (a left-hand button,
/// [`WandAction::Lattice`](vr_app::xr::actions::WandAction::Lattice)) turns lattice
/// mode on, the trigger grabs the cage's control point at the wand tip (with the
/// group within the grab radius) and the controller drags it 3 cm up and 8 cm towards
/// the viewer. Through `XrWand` (the feeder, edit loop, journal and operator log of
/// every driver): the release is one deformation with its pulse, the sheet bends, the
/// replay of the headset's pose log builds the same document byte for byte, and the
/// undo button puts the flat sheet back.
#[test]
fn a_headset_lattice_drag_bends_the_sheet_and_replays() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = Config::default();
    cfg.files.dir = dir.path().to_path_buf();
    let mut app = AppState::new(cfg).unwrap();
    let flat = app.session.doc.targets()[0].surface.clone();
    let (mut wand, grip_at) = support::scripted_headset(&app, dir.path(), DQuat::IDENTITY);
    // The cage's top front point, a third in from the left: the point the recorded
    // desktop session grabs.
    let grab = replay::sessions::lattice_grab_point();
    let mut pulses = Vec::new();
    let mut step = at_90_hz(&mut wand);
    // Hover near the point, press and release the lattice button.
    for lattice in [false, true, false, false] {
        let state = ControllerState {
            grip: Some(grip_at(grab + DVec3::Z * 0.05)),
            lattice,
            ..ControllerState::default()
        };
        pulses.extend(step(&mut app, state));
    }
    assert_eq!(
        app.session.interaction.mode(),
        sculpt_core::interaction::InteractionMode::Lattice,
        "the lattice button turned lattice mode on"
    );
    // Onto the point, squeeze, drag, let go, move away.
    let drag = DVec3::new(0.0, 0.03, 0.08);
    let mut path: Vec<(DVec3, f64)> = vec![(grab, 0.1), (grab, 0.9)];
    path.extend((1..=30).map(|k| (grab + drag * (f64::from(k) / 30.0), 0.9)));
    path.extend([(grab + drag, 0.1), (grab + drag + DVec3::Z * 0.05, 0.1)]);
    for state in trigger_path(&path, &grip_at) {
        pulses.extend(step(&mut app, state));
    }
    assert_eq!(pulses, [Feedback::Applied], "one pulse for the deformation");
    assert_eq!(app.session.doc.deforms().len(), 1);
    let bent = app.session.doc.targets()[0].surface.clone();
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
        "towards the drag"
    );
    let live = app.session.doc.to_json();

    let outcome = replay_headset(dir.path(), default_document(), &live, "lattice drag");
    assert_eq!(outcome.document.deforms().len(), 1);

    // The undo button takes the deformation back.
    for state in undo_press(grip_at(grab + DVec3::Z * 0.1)) {
        step(&mut app, state);
    }
    assert_eq!(app.session.doc.targets()[0].surface, flat);
}

/// Issue 35 items 2 and 4 in the headset: the paint action (the left trigger,
/// [`WandAction::Paint`](vr_app::xr::actions::WandAction::Paint)) turns paint mode
/// on, and three trigger sweeps 8 mm above the default sheet paint it, through
/// `XrWand` (the feeder, edit loop, journal and operator log of every driver): three
/// paint strokes, each with its pulse, a colour field on the sheet and its geometry
/// untouched; the replay of the headset's pose log builds the same document byte for
/// byte, and the undo button takes the last sweep back. Regression: the headset had no
/// paint action, so paint (button bit 7) could not be reached from it.
#[test]
fn a_headset_paint_sweep_colours_the_sheet_and_replays() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = Config::default();
    cfg.files.dir = dir.path().to_path_buf();
    let mut app = AppState::new(cfg).unwrap();
    let sheet = app.session.doc.targets()[0].surface.clone();
    let (mut wand, grip_at) = support::scripted_headset(&app, dir.path(), DQuat::IDENTITY);
    let mut pulses = Vec::new();
    let mut step = at_90_hz(&mut wand);
    let above = |x: f64, y: f64, h: f64| default_surface_point(x, y) + DVec3::Z * h;
    // Hover, press and release the paint button.
    for paint in [false, true, false, false] {
        let state = ControllerState {
            grip: Some(grip_at(above(-0.35, 1.17, 0.05))),
            paint,
            ..ControllerState::default()
        };
        pulses.extend(step(&mut app, state));
    }
    assert_eq!(
        app.session.interaction.mode(),
        sculpt_core::interaction::InteractionMode::Paint,
        "the paint button turned paint mode on"
    );
    for y in [1.13, 1.17, 1.21] {
        let mut path: Vec<(DVec3, f64)> = vec![(above(-0.35, y, 0.05), 0.1)];
        path.extend((0..=40).map(|k| (above(-0.35 + 0.7 * f64::from(k) / 40.0, y, 0.008), 0.9)));
        path.extend([(above(0.35, y, 0.008), 0.1), (above(0.35, y, 0.05), 0.1)]);
        for state in trigger_path(&path, &grip_at) {
            pulses.extend(step(&mut app, state));
        }
    }
    assert_eq!(
        pulses,
        [Feedback::Applied; 3],
        "one pulse for each sweep: {pulses:?}"
    );
    let doc = &app.session.doc;
    assert_eq!(doc.paints().len(), 3);
    assert!(doc.paints().iter().all(|p| p.deposited > 0));
    let target = doc.targets()[0].id;
    assert!(
        doc.attribute_field(target, sculpt_core::paint::COLOUR)
            .is_some()
    );
    assert_eq!(doc.targets()[0].surface, sheet, "paint changes no geometry");
    let live = doc.to_json();

    let outcome = replay_headset(dir.path(), default_document(), &live, "paint sweeps");
    assert_eq!(outcome.document.paints().len(), 3);

    // The undo button takes the last sweep back.
    for state in undo_press(grip_at(above(0.0, 1.17, 0.1))) {
        step(&mut app, state);
    }
    assert_eq!(app.session.doc.paints().len(), 2);
}

/// Issue 35 items 3 and 4 in the headset: with the `carve-solid` session's plate as
/// the base's solid (`[files] solid`), the next-target button selects it and a trigger
/// sweep across its top face carves a groove through it, through `XrWand` (the feeder,
/// edit loop, journal and operator log of every driver): one pulse, one cut on the
/// plate, a slot through it (the Euler characteristic drops from 2 to 0), and the
/// replay of the headset's pose log on the same base builds the same document byte for
/// byte. The undo button takes the groove back.
#[test]
fn a_headset_stroke_carves_through_a_solid_and_replays() {
    let dir = tempfile::tempdir().unwrap();
    let spec = replay::sessions::carve_solid_plate();
    let model = dir.path().join("plate.json");
    std::fs::write(&model, &spec.model).unwrap();
    let mut cfg = Config::default();
    cfg.files.dir = dir.path().to_path_buf();
    cfg.files.solid = Some(model.clone());
    cfg.files.solid_cells = spec.cells;
    let mut app = AppState::new(cfg).unwrap();
    let plate = app.session.doc.solids()[0].id;
    let uncut = app.session.doc.solid_mesh(plate).unwrap();
    assert_eq!(sculpt_core::solid::euler_characteristic(&uncut), 2);
    let (mut wand, grip_at) = support::scripted_headset(&app, dir.path(), DQuat::IDENTITY);
    let top = replay::sessions::CARVE_SOLID_TOP;
    let mut pulses = Vec::new();
    let mut step = at_90_hz(&mut wand);
    // Above the plate, press and release the next-target button.
    let above = DVec3::new(-0.1, 1.17, top + 0.05);
    for next_target in [false, true, false, false] {
        let state = ControllerState {
            grip: Some(grip_at(above)),
            next_target,
            ..ControllerState::default()
        };
        pulses.extend(step(&mut app, state));
    }
    assert_eq!(
        app.session.interaction.target(),
        plate,
        "the button selected the plate"
    );
    // Down onto the top face, squeeze, sweep 20 cm across, let go, lift.
    let mut path: Vec<(DVec3, f64)> = vec![(DVec3::new(-0.1, 1.17, top), 0.1)];
    path.extend((0..=40).map(|k| (DVec3::new(-0.1 + 0.005 * f64::from(k), 1.17, top), 0.9)));
    path.extend([
        (DVec3::new(0.1, 1.17, top), 0.1),
        (DVec3::new(0.1, 1.17, top + 0.05), 0.1),
    ]);
    for state in trigger_path(&path, &grip_at) {
        pulses.extend(step(&mut app, state));
    }
    assert_eq!(pulses, [Feedback::Applied], "one pulse for the groove");
    let record = &app.session.doc.solids()[0];
    assert_eq!(record.solid.cuts().len(), 1, "the groove cut the plate");
    let carved = app.session.doc.solid_mesh(plate).unwrap();
    assert_eq!(
        sculpt_core::solid::euler_characteristic(&carved),
        0,
        "a slot through the plate"
    );
    let live = app.session.doc.to_json();

    let mut base = default_document();
    vr_app::solid_view::load_solid(&mut base, &model, spec.cells).unwrap();
    let outcome = replay_headset(dir.path(), base, &live, "groove");
    assert_eq!(outcome.document.solids()[0].solid.cuts().len(), 1);

    // The undo button takes the groove back.
    for state in undo_press(grip_at(DVec3::new(0.0, 1.17, top + 0.1))) {
        step(&mut app, state);
    }
    assert_eq!(
        app.session.doc.solid_mesh(plate).unwrap().triangles,
        uncut.triangles
    );
}

/// The controller states of a wand path: the grip at each point (display frame) with
/// the trigger at its value.
fn trigger_path(
    path: &[(DVec3, f64)],
    grip_at: &impl Fn(DVec3) -> vr_app::xr::XrPose,
) -> Vec<ControllerState> {
    path.iter()
        .map(|&(p, trigger)| ControllerState {
            grip: Some(grip_at(p)),
            trigger,
            ..ControllerState::default()
        })
        .collect()
}

/// A step of `wand` per call, 90 times a second from 0: its pulse, if any.
fn at_90_hz(
    wand: &mut vr_app::xr::wand::XrWand,
) -> impl FnMut(&mut AppState, ControllerState) -> Option<Feedback> + '_ {
    let mut t = 0.0;
    move |app, state| {
        let pulse = wand.step(app, t, &state, None).unwrap();
        t += 1.0 / 90.0;
        pulse
    }
}

/// The undo button pressed and released with the grip at `grip`.
fn undo_press(grip: vr_app::xr::XrPose) -> [ControllerState; 2] {
    [true, false].map(|undo| ControllerState {
        grip: Some(grip),
        undo,
        ..ControllerState::default()
    })
}

/// `replay` of the pose log the headset wrote into `dir`, with the replay config it
/// wrote, on `base`: its document must equal `live` (the headset session's) byte for
/// byte.
fn replay_headset(
    dir: &std::path::Path,
    base: sculpt_core::sculpt::document::Document,
    live: &[u8],
    what: &str,
) -> replay::pipeline::Outcome {
    let log = std::fs::read(dir.join(POSE_LOG_FILE)).unwrap();
    let config = std::fs::read_to_string(dir.join(REPLAY_CONFIG_FILE)).unwrap();
    let replay_cfg = ReplayConfig::from_toml_str(&config).unwrap();
    let outcome = replay_log(&log, &replay_cfg, base, "xr", false, None).unwrap();
    assert_eq!(
        String::from_utf8_lossy(&outcome.document.to_json()),
        String::from_utf8_lossy(live),
        "replay of the headset's {what}"
    );
    outcome
}
