//! One recorded input log through every driver that runs headless gives
//! byte-identical documents and operator logs: the drivers share one feeder
//! (`vr_app::feeder::Feeder`: the frame stage, a serial wand's buttons, the
//! thumbstick) and one edit loop.
//!
//! The log is recorded by the headset path: scripted controller states (what the
//! OpenXR actions report: grip pose, trigger, undo, thumbstick) go through `XrWand`,
//! which writes `xr.poselog` and `xr-replay.toml`. Then the same log goes through
//! `replay`'s pipeline, `run_headless` (what `wandsculpt --headless` runs, on
//! lavapipe) and `LiveTracking` fed over a loopback TCP connection. A second log adds
//! serial wand lines (buttons only) to it: a stroke drawn with the serial wand's button
//! while the controller's trigger is up, which the headset path cannot see, so it goes
//! through the other three drivers only.
//!
//! Not here: the cluster node's driver (`cluster::node`), which commits each edit
//! through NATS JetStream and so needs a `nats-server`; `tests/cluster.rs` runs it.
//! Operator logs are compared below their header line, which names the program that
//! wrote it (`replay` or `wandsculpt`).

mod support;

use std::io::Write;
use std::net::TcpStream;
use std::time::{Duration, Instant};

use glam::{DQuat, DVec3};
use replay::config::ReplayConfig;
use replay::pipeline::{default_document, replay_log};
use sculpt_core::editor::default_surface_point;
use tracking::config::{SourceConfig, TrackingConfig};
use tracking::poselog::{PoseLogReader, PoseLogWriter, Record, RecordKind};
use tracking::serial::{SerialRecord, encode_serial};
use vr_app::app::AppState;
use vr_app::config::{Config, TrackingSection};
use vr_app::headless::{HeadlessOptions, run_headless};
use vr_app::input::Input;
use vr_app::live::LiveTracking;
use vr_app::output::OutputMode;
use vr_app::render::Gpu;
use vr_app::session::{DOCUMENT_FILE, OPLOG_FILE};
use vr_app::xr::actions::ControllerState;
use vr_app::xr::wand::{POSE_LOG_FILE, REPLAY_CONFIG_FILE, XrWand};

/// A document and an operator log (below its header line).
#[derive(Debug, PartialEq)]
struct Outputs {
    document: String,
    oplog: String,
}

impl Outputs {
    fn new(document: &[u8], oplog: &[u8]) -> Self {
        let oplog = String::from_utf8_lossy(oplog);
        let body = oplog.split_once('\n').map_or("", |(_, rest)| rest);
        Self {
            document: String::from_utf8_lossy(document).into_owned(),
            oplog: body.to_owned(),
        }
    }

    fn from_dir(dir: &std::path::Path) -> Self {
        Self::new(
            &std::fs::read(dir.join(DOCUMENT_FILE)).unwrap(),
            &std::fs::read(dir.join(OPLOG_FILE)).unwrap(),
        )
    }
}

/// The recorded headset session: its outputs, its pose log and replay config, and
/// the frame indices where the serial wand's stroke starts and ends.
struct Recorded {
    outputs: Outputs,
    log: Vec<u8>,
    replay_config: String,
    serial_pass: (usize, usize),
}

/// Scripted controller states through `XrWand`: a stroke with the trigger, an undo
/// press, the thumbstick held (a wider, shallower tool), a second stroke, then a pass
/// across the sheet with the trigger up (the serial wand's stroke in the second log),
/// and a hover at the end, so no gesture is open when the drivers end the session.
fn record_headset_session(dir: &std::path::Path) -> Recorded {
    let mut cfg = Config::default();
    cfg.files.dir = dir.to_path_buf();
    let mut app = AppState::new(cfg).unwrap();
    let (mut wand, grip_at) = support::scripted_headset(&app, dir, DQuat::from_rotation_x(-0.3));
    let hover = grip_at(default_surface_point(0.0, 1.2) + DVec3::Z * 0.1);
    let dt = 1.0 / 90.0;
    let mut t = 0.0;
    let mut step = |wand: &mut XrWand, app: &mut AppState, state: ControllerState| {
        wand.step(app, t, &state, None).unwrap();
        t += dt;
    };
    let pass = |wand: &mut XrWand,
                app: &mut AppState,
                step: &mut dyn FnMut(&mut XrWand, &mut AppState, ControllerState),
                y: f64,
                trigger: bool| {
        for i in 0..=40 {
            let x = -0.12 + 0.006 * f64::from(i);
            step(
                wand,
                app,
                ControllerState {
                    grip: Some(grip_at(default_surface_point(x, y))),
                    trigger: if trigger && (1..40).contains(&i) {
                        0.9
                    } else {
                        0.1
                    },
                    ..ControllerState::default()
                },
            );
        }
    };
    pass(&mut wand, &mut app, &mut step, 1.1, true);
    for undo in [true, false, false] {
        let state = ControllerState {
            grip: Some(hover),
            undo,
            ..ControllerState::default()
        };
        step(&mut wand, &mut app, state);
    }
    for _ in 0..45 {
        let state = ControllerState {
            grip: Some(hover),
            thumbstick: [0.9, -0.6],
            ..ControllerState::default()
        };
        step(&mut wand, &mut app, state);
    }
    pass(&mut wand, &mut app, &mut step, 1.25, true);
    // Over to the third pass's start with no button held, then hold still there.
    let (from, to) = (
        default_surface_point(0.12, 1.25),
        default_surface_point(-0.12, 1.35),
    );
    for i in 1..=30 {
        let state = ControllerState {
            grip: Some(grip_at(
                from.lerp(to, (f64::from(i) / 20.0).min(1.0)) + DVec3::Z * 0.02,
            )),
            ..ControllerState::default()
        };
        step(&mut wand, &mut app, state);
    }
    let first = usize::try_from(wand.frames()).unwrap();
    pass(&mut wand, &mut app, &mut step, 1.35, false);
    let last = usize::try_from(wand.frames()).unwrap();
    for _ in 0..30 {
        let state = ControllerState {
            grip: Some(hover),
            ..ControllerState::default()
        };
        step(&mut wand, &mut app, state);
    }
    // The undone stroke, and the second one, cut with the thumbstick's tool.
    assert_eq!(app.session.doc.strokes().len(), 1);
    let start = app.config.tool.tool();
    let tool = app.session.interaction.tool().clone();
    assert!(
        tool.width > start.width && tool.depth < start.depth,
        "{tool:?}"
    );
    let outputs = Outputs::new(
        &app.session.doc.to_json(),
        &std::fs::read(dir.join(OPLOG_FILE)).unwrap(),
    );
    drop(wand);
    Recorded {
        outputs,
        log: std::fs::read(dir.join(POSE_LOG_FILE)).unwrap(),
        replay_config: std::fs::read_to_string(dir.join(REPLAY_CONFIG_FILE)).unwrap(),
        serial_pass: (first, last),
    }
}

/// The log's records.
fn records(log: &[u8]) -> Vec<Record> {
    PoseLogReader::new(log)
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// The log with a serial wand's lines (buttons only) added: button 0 down before
/// frame `from` and up before frame `to` (frame indices, 0-based).
fn with_serial_button(log: &[u8], (from, to): (usize, usize)) -> Vec<u8> {
    let reader = PoseLogReader::new(log).unwrap();
    let mut out = PoseLogWriter::new(Vec::new(), reader.header()).unwrap();
    let mut seq = 0;
    for (i, rec) in records(log).into_iter().enumerate() {
        if i == from || i == to {
            seq += 1;
            let mut line = Vec::new();
            let buttons = u64::from(i == from);
            encode_serial(
                &SerialRecord {
                    seq,
                    buttons,
                    pose: None,
                },
                &mut line,
            );
            out.write(RecordKind::Serial, rec.time, &line).unwrap();
        }
        out.write(rec.kind, rec.time, &rec.bytes).unwrap();
    }
    out.into_inner()
}

/// The display server's config for the log: the replay config's stage (calibration,
/// filter, wand and head, timeout) and thumbstick as its `[tracking]` section, with
/// `sources`, writing into `dir`, rendering small.
fn display_config(
    replay: &ReplayConfig,
    sources: Vec<SourceConfig>,
    dir: &std::path::Path,
) -> Config {
    let stage = replay.stage();
    let mut cfg = Config::default();
    cfg.files.dir = dir.to_path_buf();
    cfg.display.width = 64;
    cfg.display.height = 48;
    cfg.tracking = Some(TrackingSection {
        wand: format!("wand{}", stage.wand_id),
        head: stage.head_id.map(|h| format!("body{h}")),
        timeout: stage.timeout_s,
        input: TrackingConfig {
            sources,
            calibration: stage.calibration.clone(),
            filter: stage.filter,
            ..TrackingConfig::default()
        },
        playback: None,
        thumbstick: replay.thumbstick,
    });
    cfg
}

/// The log's records as the raw inputs a playback source gives the feeder.
fn inputs_of(log: &[u8], wand_id: u32) -> Vec<Input> {
    records(log)
        .iter()
        .map(|rec| match rec.kind {
            RecordKind::DTrack => Input::Frame(rec.frame().unwrap()),
            RecordKind::Serial => {
                let line = tracking::serial::parse_serial(rec.bytes.trim_ascii_end()).unwrap();
                let mut f = line.to_frame(wand_id, 0);
                f.receive_time = rec.time;
                Input::Buttons(f)
            }
        })
        .collect()
}

fn headless(cfg: Config, inputs: Vec<Input>) -> Outputs {
    let dir = cfg.files.dir.clone();
    let opts = HeadlessOptions {
        width: cfg.display.width,
        height: cfg.display.height,
        mode: OutputMode::Mono,
        render_every: 0,
        realtime: false,
    };
    let mut app = AppState::new(cfg).unwrap();
    let gpu = Gpu::headless().expect("a Vulkan adapter (lavapipe) for the headless driver");
    let report = run_headless(&mut app, &gpu, inputs, &opts).unwrap();
    assert!(report.failed.is_empty(), "{report:?}");
    Outputs::from_dir(&dir)
}

/// Live tracking: the DTrack records sent over a loopback TCP connection to a
/// `tcp-listen` source, the serial lines applied to a fed source of the same hub (as
/// a serial port's reader does), each record polled before the next is sent so the
/// arrival order is the log's. Silence (an arrival-time matter, live only) is left
/// out, so the hub's scheduling cannot change the result.
fn live_inputs(log: &[u8], section: &TrackingSection) -> Vec<Input> {
    let mut live = LiveTracking::start(section).unwrap();
    let (hub, serial_src) = live.add_feed("serial wand");
    let addr = live.local_addrs()[0].unwrap();
    let mut stream = TcpStream::connect(addr).unwrap();
    let wand_id = section.stage_config().unwrap().wand_id;
    let mut inputs = Vec::new();
    for rec in records(log) {
        match rec.kind {
            RecordKind::DTrack => stream.write_all(&rec.bytes).unwrap(),
            RecordKind::Serial => {
                let line = tracking::serial::parse_serial(rec.bytes.trim_ascii_end()).unwrap();
                let mut f = line.to_frame(wand_id, 0);
                f.receive_time = hub.now();
                hub.apply(serial_src, &f, false);
            }
        }
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let got: Vec<Input> = live
                .poll()
                .into_iter()
                .filter(|i| !matches!(i, Input::Silence(_)))
                .collect();
            let done = !got.is_empty();
            inputs.extend(got);
            if done {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "record {} never arrived",
                rec.line
            );
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    inputs
}

/// Every driver but the headset's on `log`; all must give `expected`.
fn every_driver_gives(log: &[u8], replay_cfg: &ReplayConfig, expected: &Outputs, what: &str) {
    let dir = tempfile::tempdir().unwrap();
    let outcome = replay_log(log, replay_cfg, default_document(), "drivers", false, None).unwrap();
    assert_eq!(
        Outputs::new(&outcome.document.to_json(), &outcome.oplog),
        *expected,
        "{what}: replay"
    );
    let wand_id = replay_cfg.stage().wand_id;
    let played = display_config(replay_cfg, Vec::new(), &dir.path().join("headless"));
    assert_eq!(
        headless(played, inputs_of(log, wand_id)),
        *expected,
        "{what}: headless"
    );
    let listen = SourceConfig::TcpListen {
        addr: "127.0.0.1:0".parse().unwrap(),
    };
    let cfg = display_config(replay_cfg, vec![listen], &dir.path().join("live"));
    let inputs = live_inputs(log, cfg.tracking.as_ref().unwrap());
    assert!(inputs.iter().any(|i| matches!(i, Input::Frame(_))));
    assert_eq!(headless(cfg, inputs), *expected, "{what}: live tracking");
}

#[test]
fn one_input_log_gives_the_same_document_and_operator_log_through_every_driver() {
    let dir = tempfile::tempdir().unwrap();
    let recorded = record_headset_session(dir.path());
    let replay_cfg = ReplayConfig::from_toml_str(&recorded.replay_config).unwrap();
    assert!(replay_cfg.thumbstick.is_some());
    // The headset's own outputs are the reference for its log.
    every_driver_gives(&recorded.log, &replay_cfg, &recorded.outputs, "headset log");

    // With the serial wand's button: one more stroke, the same through each driver.
    let log = with_serial_button(&recorded.log, recorded.serial_pass);
    let outcome = replay_log(&log, &replay_cfg, default_document(), "serial", false, None).unwrap();
    assert_eq!(
        outcome.document.strokes().len(),
        2,
        "the serial wand's button carves the third pass: {:?}",
        outcome.metrics
    );
    assert_eq!(outcome.metrics.frames.other_kinds, 2);
    let expected = Outputs::new(&outcome.document.to_json(), &outcome.oplog);
    assert_ne!(expected, recorded.outputs);
    every_driver_gives(&log, &replay_cfg, &expected, "with a serial wand");
}
