//! Replay configuration (`--config display.toml`).
//!
//! The file is the display server's TOML config (`vr-app/config/wall.toml`, the file
//! `wandsculpt --config` reads): replay takes its `[tracking]` wand, head, timeout,
//! calibration and filter, its `[tool]` and its `[interaction]`, and ignores the
//! screens and windows ([`ReplayConfig::from_display`]). It also reads a flat layout of
//! its own, for sessions recorded without a display config:
//!
//! ```toml
//! [calibration]            # tracker -> display frame (tracking::calibration)
//! scale = 0.001                     # tracker units to metres (DTrack2: millimetres)
//! axes = ["x", "y", "z"]            # axis remap, e.g. ["x", "z", "-y"]
//! rotation = [0.0, 0.0, 0.0, 1.0]   # display_from_tracker quaternion x, y, z, w
//! translation_m = [0.0, 0.0, 0.0]
//! tips = { "wand0" = [0.0, 0.0, -0.1] }   # tool-tip offsets in the body frame (metres)
//!
//! [filter]                 # One Euro filter on the wand (tracking::filter)
//! enabled = true
//! position = { min_cutoff_hz = 1.0, beta = 5.0, d_cutoff_hz = 1.0, reset_after_s = 0.5 }
//!
//! [tracking]              # the frame stage (tracking::stage)
//! wand_id = 0              # Flystick id of the wand
//! head_id = 0              # body id of the head target (omit: no head tracking)
//! timeout = 0.5            # seconds without data before the wand counts as lost
//!
//! [tool]                   # the interaction's starting mode and tool
//! mode = "carve"           # carve, emboss or sketch (the mode button cycles
//!                          # sketch -> carve -> emboss -> sketch)
//! profile = "v"            # v or u
//! width = 0.02             # metres
//! depth = 0.005            # metres
//! taper = 0.01             # metres
//!
//! [interaction]            # sculpt_core::interaction::InteractionConfig
//! buttons = { action = 0, mode = 1, profile = 2, undo = 3, redo = 4, select = 5 }
//! pause_timeout = 0.5      # a gesture survives this much tracking loss (seconds)
//! max_resume_jump = 0.05   # ... if it comes back within this distance (metres)
//! max_speed = 15.0         # faster apparent motion is a glitch (m/s)
//! min_stroke_length = 0.005
//! sketch_axis = [0.3, 0.0, 0.0]  # the sweep segment in wand coordinates (metres)
//! sketch_columns = 8
//! sketch_row_spacing = 0.01
//! min_sketch_rows = 4
//! max_samples = 200000     # gesture sample cap (memory bound)
//! pose_every = 1           # operator-log pose events every n-th tracked sample
//!
//! [thumbstick]             # a headset session's (`wandsculpt --xr`) tool changes from
//!                          # the wand's analog axes (vr_app::xr::actions::ThumbstickTool);
//!                          # omit: the axes change nothing
//! dead_zone = 0.2
//! width_rate = 0.02        # m/s at full deflection (x axis)
//! depth_rate = 0.005       # m/s at full deflection (y axis)
//! width_range = [0.002, 0.1]
//! depth_range = [0.0005, 0.03]
//! step = 0.0005            # commands in steps of this (metres)
//! ```
//!
//! Replay runs the live app's code on these: [`tracking::stage::FrameStage`], then
//! [`sculpt_core::interaction::Interaction`], then [`sculpt_core::editor::apply`].
//!
//! ```
//! let cfg = replay::config::ReplayConfig::from_toml_str("[tool]\nwidth = 0.03\n[display]\nmode = \"mono\"\n").unwrap();
//! assert_eq!(cfg.tool.width, 0.03);
//! assert_eq!(cfg.tracking.wand_id, 0);
//! ```

pub use sculpt_core::interaction::{
    ButtonMap, InteractionConfig, InteractionMode, Profile, StrokeMode, Tool,
};
use serde::{Deserialize, Serialize};
pub use tracking::calibration::Calibration;
pub use tracking::filter::FilterConfig;
use tracking::stage::StageConfig;
pub use vr_app::xr::actions::ThumbstickTool;

use crate::error::{Error, Result};

/// Which tracker devices are the wand and the head, and when the wand counts as lost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingSection {
    /// Flystick id of the wand.
    pub wand_id: u32,
    /// Standard body id of the head target (the glasses).
    pub head_id: Option<u32>,
    /// Seconds without frames before the wand counts as lost.
    pub timeout: f64,
}

impl Default for TrackingSection {
    fn default() -> Self {
        let stage = StageConfig::default();
        Self {
            wand_id: stage.wand_id,
            head_id: stage.head_id,
            timeout: stage.timeout_s,
        }
    }
}

/// The starting tool: the display server's own `[tool]` table (mode, profile, width,
/// depth, taper).
pub use vr_app::config::ToolConfig as ToolSection;

/// Everything replay reads from the display config.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReplayConfig {
    /// Tracker-to-display transform (the tracking crate's calibration).
    pub calibration: Calibration,
    /// The One Euro filter on the wand pose (the tracking crate's filter).
    pub filter: FilterConfig,
    /// Wand id and loss timeout.
    pub tracking: TrackingSection,
    /// Starting tool.
    pub tool: ToolSection,
    /// Gesture tuning: the interaction state machine's own config.
    pub interaction: InteractionConfig,
    /// The wand's analog axes change the tool's width and depth (a headset session's
    /// thumbstick); `None`: they change nothing.
    pub thumbstick: Option<ThumbstickTool>,
}

impl ReplayConfig {
    /// Parses and validates TOML text: the display server's own config (the file
    /// `wandsculpt --config` takes, read as [`vr_app::config::Config`]), or the flat
    /// layout above. A file that is neither gets both reasons.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let cfg = match vr_app::config::Config::from_toml_str(text) {
            Ok(display) => Self::from_display(&display)?,
            Err(display) => {
                toml::from_str::<Self>(text).map_err(|flat| Error::ConfigUnrecognised {
                    display: Box::new(display),
                    flat: Box::new(flat),
                })?
            }
        };
        cfg.validate()?;
        Ok(cfg)
    }

    /// What replay takes from a display server config: the frame stage of its
    /// `[tracking]` (wand, head, timeout, and the calibration and filter of
    /// `[tracking.input]`; the stage's defaults without `[tracking]`), its `[tool]` and
    /// its `[interaction]`: exactly what the live app runs with.
    pub fn from_display(display: &vr_app::config::Config) -> Result<Self> {
        let stage = match &display.tracking {
            Some(t) => t.stage_config().map_err(|source| Error::ConfigDisplay {
                section: "[tracking]",
                source,
            })?,
            None => StageConfig::default(),
        };
        Ok(Self {
            tracking: TrackingSection {
                wand_id: stage.wand_id,
                head_id: stage.head_id,
                timeout: stage.timeout_s,
            },
            calibration: stage.calibration,
            filter: stage.filter,
            tool: display.tool.clone(),
            interaction: display.interaction,
            thumbstick: None,
        })
    }

    /// The frame stage's config (wand and head ids, timeout, calibration, filter).
    pub fn stage(&self) -> StageConfig {
        StageConfig {
            wand_id: self.tracking.wand_id,
            head_id: self.tracking.head_id,
            timeout_s: self.tracking.timeout,
            calibration: self.calibration.clone(),
            filter: self.filter,
        }
    }

    /// Checks every number with the same checks the display server runs: the frame
    /// stage's (timeout, calibration, filter), the tool's ([`Tool::validate`]) and the
    /// interaction's. Each setting has one rule, kept by the layer that owns it.
    ///
    /// [`Tool::validate`]: sculpt_core::sculpt::stroke::Tool::validate
    pub fn validate(&self) -> Result<()> {
        self.stage()
            .validate()
            .map_err(|source| Error::ConfigTracking {
                section: "tracking",
                source,
            })?;
        self.tool.tool().validate().map_err(Error::ConfigTool)?;
        self.interaction
            .validate()
            .map_err(Error::ConfigInteraction)?;
        if let Some(stick) = &self.thumbstick {
            stick.validate().map_err(Error::ConfigThumbstick)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ConfigError;
    use glam::DVec3;

    #[test]
    fn the_display_servers_own_config_is_read_as_the_live_app_reads_it() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../vr-app/config/wall.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let cfg = ReplayConfig::from_toml_str(&text).unwrap();
        let display = vr_app::config::Config::from_toml_str(&text).unwrap();
        let live = display.tracking.as_ref().unwrap().stage_config().unwrap();
        assert_eq!(cfg.stage(), live, "the same frame stage as wandsculpt");
        assert_eq!(cfg.tracking.wand_id, 1, "wall.toml's wand is wand1");
        assert_eq!(cfg.tool.tool(), display.tool.tool());
        assert_eq!(cfg.interaction, display.interaction);
        // A display config with a wand the stage cannot read is refused, not ignored.
        let e = ReplayConfig::from_toml_str(&text.replace("\"wand1\"", "\"body3\"")).unwrap_err();
        assert!(matches!(e, Error::ConfigUnrecognised { .. }), "{e:?}");
        assert!(chain(&e).contains("Flystick"), "{e}");
        // Neither kind of config: both reasons.
        let e = ReplayConfig::from_toml_str("[screen]\nbogus = 1\n[tool]\nwidth = \"x\"\n")
            .unwrap_err();
        assert!(matches!(e, Error::ConfigUnrecognised { .. }), "{e:?}");
        assert!(
            e.to_string().contains("neither a display server config"),
            "{e}"
        );
    }

    #[test]
    fn bad_settings_are_named() {
        let e = ReplayConfig::from_toml_str("[tool]\nwidth = -1.0\n").unwrap_err();
        assert!(chain(&e).contains("tool width"), "{e}");
        let e = ReplayConfig::from_toml_str("[calibration]\nunits = 2\n").unwrap_err();
        assert!(chain(&e).contains("units"), "{e}");
        // Regression: "paint" was the unknown mode here until paint mode existed.
        let e = ReplayConfig::from_toml_str("[tool]\nmode = \"chisel\"\n").unwrap_err();
        assert!(chain(&e).contains("chisel"), "{e}");
    }

    #[test]
    fn calibration_and_filter_come_from_the_tracking_tables() {
        let c = ReplayConfig::from_toml_str(
            "[calibration]\ntranslation_m = [0.0, 1.0, 0.0]\n[filter]\nenabled = false\n",
        )
        .unwrap();
        let p = c
            .calibration
            .point_in_display(DVec3::new(1000.0, 0.0, -500.0));
        assert_eq!(p, DVec3::new(1.0, 1.0, -0.5));
        assert!(!c.filter.enabled);
        let e = ReplayConfig::from_toml_str("[calibration]\naxes = [\"x\", \"x\", \"z\"]\n")
            .unwrap_err();
        assert!(chain(&e).contains("calibration"), "{e}");
    }

    #[test]
    fn a_thumbstick_section_is_read_and_checked() {
        let c = ReplayConfig::from_toml_str("[thumbstick]\nwidth_rate = 0.04\n").unwrap();
        let stick = c.thumbstick.unwrap();
        assert_eq!(stick.width_rate, 0.04);
        assert_eq!(stick.depth_rate, ThumbstickTool::default().depth_rate);
        assert_eq!(ReplayConfig::from_toml_str("").unwrap().thumbstick, None);
        let e = ReplayConfig::from_toml_str("[thumbstick]\ndead_zone = 1.0\n").unwrap_err();
        assert!(
            matches!(
                e,
                Error::ConfigThumbstick(vr_app::xr::actions::ThumbstickError::DeadZone(d)) if d == 1.0
            ),
            "{e:?}"
        );
        let e =
            ReplayConfig::from_toml_str("[thumbstick]\nwidth_range = [0.1, 0.01]\n").unwrap_err();
        assert!(chain(&e).contains("width_range"), "{e}");
    }

    /// The message as a binary prints it: the error and its causes.
    fn chain(e: &Error) -> String {
        sculpt_core::error::Chain(e).to_string()
    }

    #[test]
    fn typed_config_errors_name_the_setting() {
        let e = crate::render::parse_times("1,x").unwrap_err();
        assert!(
            matches!(e, Error::Config(ConfigError::RenderTimeNotANumber { ref text }) if text == "x"),
            "{e:?}"
        );
        let e = crate::render::every(0.0, 1.0).unwrap_err();
        assert!(
            matches!(e, Error::Config(ConfigError::RenderStep { step: 0.0 })),
            "{e:?}"
        );
        let mut cfg = ReplayConfig::default();
        cfg.interaction.max_samples = 1;
        assert!(matches!(
            cfg.validate(),
            Err(Error::ConfigInteraction(sculpt_core::Error::Interaction(
                sculpt_core::error::InteractionError::Config(
                    sculpt_core::error::InteractionConfigError::MaxSamples
                )
            )))
        ));
    }

    /// Regression (issue 15, item 7): `wandsculpt` accepted `[interaction]
    /// pause_timeout = -1` and `max_resume_jump = nan` that `replay` rejected; both now
    /// run sculpt-core's one `InteractionConfig::validate`, so they agree on every key.
    #[test]
    fn wandsculpt_and_replay_reject_the_same_interaction_values() {
        let bad = [
            "pause_timeout = -1.0",
            "max_resume_jump = nan",
            "max_speed = 0.0",
            "min_stroke_length = inf",
            "sketch_row_spacing = -0.01",
            "max_samples = 1",
            "sketch_columns = 65",
        ];
        for line in bad {
            let text = format!("[interaction]\n{line}\n");
            let r = ReplayConfig::from_toml_str(&text);
            let w = vr_app::config::Config::from_toml_str(&text);
            assert!(r.is_err(), "replay accepted {line}");
            assert!(w.is_err(), "wandsculpt accepted {line}");
            let key = line.split(' ').next().unwrap();
            assert!(w.unwrap_err().to_string().contains(key), "{line}");
        }
        let good = "[interaction]\npause_timeout = 0.0\nmax_resume_jump = 0.1\n";
        assert!(ReplayConfig::from_toml_str(good).is_ok());
        assert!(vr_app::config::Config::from_toml_str(good).is_ok());
    }
}
