//! The headset's controller as the session's wand: each controller state becomes a
//! tracker frame ([`WandMapper::frame`]), written to the pose log
//! ([`POSE_LOG_FILE`]) and pushed through the same [`FrameStage`](tracking::stage::FrameStage) and
//! [`Session`](crate::session::Session) (edit loop, journal, operator log) as a
//! tracked wand; the thumbstick's tool changes follow. [`REPLAY_CONFIG_FILE`] holds
//! the calibration, filter and stage settings, so
//! `replay xr.poselog --config xr-replay.toml` builds the same document. No runtime
//! is involved: `xr_runtime` feeds it from the OpenXR actions, tests from scripts.
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use vr_app::app::AppState;
//! use vr_app::config::Config;
//! use vr_app::xr::XrPose;
//! use vr_app::xr::actions::{ControllerState, PoseSource};
//! use vr_app::xr::wand::XrWand;
//! let dir = tempfile::tempdir().unwrap();
//! let mut cfg = Config::default();
//! cfg.files.dir = dir.path().to_path_buf();
//! let mut app = AppState::new(cfg)?;
//! let mut wand = XrWand::create(dir.path(), "doc", &XrPose::IDENTITY, Default::default(), PoseSource::Grip)?;
//! let state = ControllerState {
//!     grip: Some(XrPose { position: DVec3::new(0.0, 1.2, 0.3), orientation: DQuat::IDENTITY }),
//!     ..ControllerState::default()
//! };
//! assert_eq!(wand.step(&mut app, 0.0, &state, None)?, None); // no stroke, no pulse
//! assert!(dir.path().join(vr_app::xr::wand::POSE_LOG_FILE).exists());
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use sculpt_core::interaction::{ButtonMap, Edit, Tool, WandEvent};
use serde::Serialize;
use tracking::poselog::{PoseLogHeader, PoseLogWriter, RecordKind};
use tracking::stage::StageConfig;

use super::XrPose;
use super::actions::{
    self, ControllerState, Feedback, PoseSource, ThumbstickTool, WandMapper, feedback,
};
use crate::app::AppState;
use crate::error::{VrError, VrResult, XrError};
use crate::feeder::{Feeder, Sink};
use crate::input::{Input, TrackingState};

/// The pose log's file name in the session directory.
pub const POSE_LOG_FILE: &str = "xr.poselog";
/// The replay config's file name in the session directory.
pub const REPLAY_CONFIG_FILE: &str = "xr-replay.toml";

fn encode(what: &'static str) -> impl Fn(Box<dyn std::error::Error + Send + Sync>) -> VrError {
    move |cause| VrError::Xr(XrError::Encode { what, cause })
}

/// The stage config for the frames [`WandMapper`] writes: the stage's calibration,
/// no filter (the runtime already predicts and smooths its poses).
pub fn xr_stage_config(display_from_stage: &XrPose, timeout_s: f64) -> StageConfig {
    StageConfig {
        wand_id: actions::WAND_ID,
        head_id: Some(actions::HEAD_ID),
        timeout_s,
        calibration: actions::stage_calibration(display_from_stage),
        filter: tracking::filter::FilterConfig {
            enabled: false,
            ..Default::default()
        },
    }
}

/// `replay --config` for the session's pose log (its flat layout): the calibration,
/// the filter, the stage and the thumbstick's rates (so `replay` makes the same tool
/// changes).
pub fn replay_config(stage: &StageConfig, thumbstick: &ThumbstickTool) -> VrResult<String> {
    #[derive(Serialize)]
    struct Tracking {
        wand_id: u32,
        head_id: Option<u32>,
        timeout: f64,
    }
    #[derive(Serialize)]
    struct ReplayFile<'a> {
        calibration: &'a tracking::calibration::Calibration,
        filter: &'a tracking::filter::FilterConfig,
        tracking: Tracking,
        thumbstick: &'a ThumbstickTool,
    }
    toml::to_string(&ReplayFile {
        calibration: &stage.calibration,
        filter: &stage.filter,
        tracking: Tracking {
            wand_id: stage.wand_id,
            head_id: stage.head_id,
            timeout: stage.timeout_s,
        },
        thumbstick,
    })
    .map_err(|e| encode(REPLAY_CONFIG_FILE)(Box::new(e)))
}

/// The controller as the wand (see the module docs).
#[derive(Debug)]
pub struct XrWand {
    mapper: WandMapper,
    /// The frames (as logged) to wand events and tool changes, as every driver does it.
    feeder: Feeder,
    frame_number: u64,
    last_t: f64,
    log: PoseLogWriter<BufWriter<File>>,
    log_path: PathBuf,
    bytes: Vec<u8>,
}

/// The headset session as the feeder's sink: the app's session, the edits applied
/// (for the haptic feedback); the eyes come from the runtime's views, not the head
/// body.
struct XrSink<'a> {
    app: &'a mut AppState,
    applied: Vec<Edit>,
}

impl Sink for XrSink<'_> {
    type Error = VrError;

    fn wand(&mut self, ev: &WandEvent) -> VrResult<()> {
        self.applied.extend(self.app.session.handle(ev)?);
        Ok(())
    }

    fn tick(&mut self, t: f64) -> VrResult<()> {
        self.applied.extend(self.app.session.tick(t)?);
        Ok(())
    }

    fn tool(&self) -> Tool {
        self.app.session.interaction.tool().clone()
    }

    fn tracking(&mut self, state: TrackingState) {
        self.app.tracking = state;
    }

    fn key(&mut self, t: f64, key: &str) {
        self.app.session.key(t, key);
    }
}

impl XrWand {
    /// Starts the pose log and writes the replay config in `dir`; `source` names the
    /// runtime and headset in the log's header.
    pub fn create(
        dir: &Path,
        source: &str,
        display_from_stage: &XrPose,
        buttons: ButtonMap,
        pose: PoseSource,
    ) -> VrResult<Self> {
        let stage_config = xr_stage_config(display_from_stage, StageConfig::default().timeout_s);
        let tracking_err = |what: &Path| {
            let what = what.display().to_string();
            move |reason| VrError::Tracking {
                what,
                reason: Box::new(reason),
            }
        };
        let feeder = Feeder::new(
            stage_config.clone(),
            // Unused: a headset session's frames come every display frame, no silence.
            sculpt_core::interaction::InteractionConfig::default().pause_timeout,
            Some(ThumbstickTool::default()),
        )?;
        let log_path = dir.join(POSE_LOG_FILE);
        let mut header = PoseLogHeader::new(format!("openxr {source}"));
        header.calibration = serde_json::to_value(&stage_config.calibration)
            .map_err(|e| encode(POSE_LOG_FILE)(Box::new(e)))?;
        let log = PoseLogWriter::create(&log_path, &header).map_err(tracking_err(&log_path))?;
        crate::session::write_atomic(
            &dir.join(REPLAY_CONFIG_FILE),
            replay_config(&stage_config, &ThumbstickTool::default())?.as_bytes(),
        )?;
        Ok(Self {
            mapper: WandMapper::new(buttons, pose),
            feeder,
            frame_number: 0,
            last_t: 0.0,
            log,
            log_path,
            bytes: Vec::new(),
        })
    }

    /// The time of the last step (seconds since the session began).
    pub fn last_t(&self) -> f64 {
        self.last_t
    }

    /// Controller frames stepped so far.
    pub fn frames(&self) -> u64 {
        self.frame_number
    }

    /// The pose log being written.
    pub fn log_path(&self) -> &Path {
        &self.log_path
    }

    /// One controller state at time `t` (seconds since the session began; a time
    /// before the last step is ignored): the frame is logged and staged, its wand
    /// events and the thumbstick's tool changes go to the session. Returns the haptic
    /// feedback for what happened, if any.
    pub fn step(
        &mut self,
        app: &mut AppState,
        t: f64,
        c: &ControllerState,
        head_in_stage: Option<&XrPose>,
    ) -> VrResult<Option<Feedback>> {
        if !(t.is_finite() && t >= self.last_t) {
            return Ok(None);
        }
        self.frame_number += 1;
        let frame = self.mapper.frame(self.frame_number, t, c, head_in_stage);
        // The stage sees the frame as the log holds it (DTrack2 ASCII, millimetres to
        // three decimals), exactly what `replay` decodes: live == replay.
        self.bytes.clear();
        tracking::dtrack::encode_frame(&frame, &mut self.bytes);
        let log_err = |reason| VrError::Tracking {
            what: self.log_path.display().to_string(),
            reason: Box::new(reason),
        };
        self.log
            .write(RecordKind::DTrack, frame.receive_time, &self.bytes)
            .map_err(log_err)?;
        let mut logged = tracking::dtrack::parse_frame(&self.bytes).map_err(log_err)?;
        logged.receive_time = frame.receive_time;
        let rejected_before = app.session.rejected;
        let mut sink = XrSink {
            app,
            applied: Vec::new(),
        };
        self.feeder.feed(&Input::Frame(logged), &mut sink)?;
        let applied = sink.applied;
        self.last_t = t;
        Ok(feedback(
            &applied,
            app.session.rejected.saturating_sub(rejected_before),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};

    #[test]
    fn the_replay_config_carries_the_stage_calibration() {
        let d = XrPose {
            position: DVec3::new(0.0, -0.08, 0.45),
            orientation: DQuat::IDENTITY,
        };
        let stage = xr_stage_config(&d, 0.5);
        let stick = ThumbstickTool {
            width_rate: 0.03,
            ..ThumbstickTool::default()
        };
        let text = replay_config(&stage, &stick).unwrap();
        let value: toml::Value = toml::from_str(&text).unwrap();
        assert_eq!(value["calibration"]["scale"].as_float(), Some(0.001));
        assert_eq!(value["filter"]["enabled"].as_bool(), Some(false));
        assert_eq!(value["tracking"]["wand_id"].as_integer(), Some(0));
        let t = value["calibration"]["translation_m"].as_array().unwrap();
        assert_eq!(t[2].as_float(), Some(0.45));
        let back: ThumbstickTool = value["thumbstick"].clone().try_into().unwrap();
        assert_eq!(back, stick);
    }
}
