//! Replay configuration (`--config display.toml`).
//!
//! The file is the display server's TOML config; replay reads the tables that decide
//! what a session does and ignores the rest (screens, windows):
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
//! [tracking]
//! wand_id = 0              # Flystick id of the wand
//! timeout = 0.5            # seconds without data before the wand counts as lost
//!
//! [tool]
//! mode = "carve"           # starting mode: carve, emboss or sketch
//! profile = "v"            # v or u
//! width = 0.02             # metres
//! depth = 0.005            # metres
//! taper = 0.01             # metres
//!
//! [interaction]
//! buttons = { action = 0, mode = 1, profile = 2, undo = 3, redo = 4, select = 5 }
//! pause_timeout = 0.5      # a gesture survives this much tracking loss (seconds)
//! max_resume_jump = 0.05   # ... if it comes back within this distance (metres)
//! max_speed = 15.0         # faster apparent motion is a glitch (m/s)
//! min_stroke_length = 0.005
//! sketch_axis = [0.3, 0.0, 0.0]  # the sweep segment in wand coordinates (metres)
//! sketch_columns = 8
//! sketch_row_spacing = 0.01
//! min_sketch_rows = 4
//! pose_every = 1           # operator-log pose events every n-th tracked sample
//! ```
//!
//! ```
//! let cfg = replay::config::ReplayConfig::from_toml_str("[tool]\nwidth = 0.03\n[display]\nmode = \"mono\"\n").unwrap();
//! assert_eq!(cfg.tool.width, 0.03);
//! assert_eq!(cfg.tracking.wand_id, 0);
//! ```

use glam::DVec3;
use serde::{Deserialize, Serialize};
pub use tracking::calibration::Calibration;
pub use tracking::filter::FilterConfig;

use crate::error::{Error, Result};

/// Which tracker device is the wand, and when it counts as lost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrackingSection {
    /// Flystick id of the wand.
    pub wand_id: u32,
    /// Seconds without frames before the wand counts as lost.
    pub timeout: f64,
}

impl Default for TrackingSection {
    fn default() -> Self {
        Self {
            wand_id: 0,
            timeout: 0.5,
        }
    }
}

/// Starting mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Sweep to create a surface.
    Sketch,
    /// Strokes cut grooves.
    Carve,
    /// Strokes raise ridges.
    Emboss,
}

impl Mode {
    /// The next mode in the cycle carve -> emboss -> sketch -> carve.
    pub fn next(self) -> Self {
        match self {
            Mode::Carve => Mode::Emboss,
            Mode::Emboss => Mode::Sketch,
            Mode::Sketch => Mode::Carve,
        }
    }

    /// The lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Sketch => "sketch",
            Mode::Carve => "carve",
            Mode::Emboss => "emboss",
        }
    }
}

/// The starting tool.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ToolSection {
    /// Starting mode.
    pub mode: Mode,
    /// `v` or `u`.
    pub profile: ProfileName,
    /// Width, metres.
    pub width: f64,
    /// Depth or height, metres.
    pub depth: f64,
    /// End taper length, metres.
    pub taper: f64,
}

/// A chisel profile by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProfileName {
    /// V groove.
    V,
    /// U groove.
    U,
}

impl Default for ToolSection {
    fn default() -> Self {
        Self {
            mode: Mode::Carve,
            profile: ProfileName::V,
            width: 0.02,
            depth: 0.005,
            taper: 0.01,
        }
    }
}

/// Which button bit does what: the same assignment the live app's interaction uses.
pub use sculpt_core::interaction::ButtonMap;

/// Gesture tuning.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct InteractionSection {
    /// Button assignment.
    pub buttons: ButtonMap,
    /// Seconds a gesture may stay paused by tracking loss.
    pub pause_timeout: f64,
    /// Largest jump (metres) at which a paused gesture resumes.
    pub max_resume_jump: f64,
    /// Faster apparent motion (m/s) is a glitch and dropped.
    pub max_speed: f64,
    /// Shorter strokes (metres of path) are discarded.
    pub min_stroke_length: f64,
    /// The sketch sweep segment in wand coordinates (metres).
    pub sketch_axis: [f64; 3],
    /// Points per sketch row.
    pub sketch_columns: u32,
    /// Minimum tip travel between sketch rows (metres).
    pub sketch_row_spacing: f64,
    /// Minimum rows for a sketch.
    pub min_sketch_rows: u32,
    /// Operator-log pose events every n-th tracked sample (0: none).
    pub pose_every: u32,
}

impl Default for InteractionSection {
    fn default() -> Self {
        Self {
            buttons: ButtonMap::default(),
            pause_timeout: 0.5,
            max_resume_jump: 0.05,
            max_speed: 15.0,
            min_stroke_length: 0.005,
            sketch_axis: [0.3, 0.0, 0.0],
            sketch_columns: 8,
            sketch_row_spacing: 0.01,
            min_sketch_rows: 4,
            pose_every: 1,
        }
    }
}

/// Everything replay reads from the display config.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct ReplayConfig {
    /// Tracker-to-display transform (the tracking crate's calibration).
    pub calibration: Calibration,
    /// The One Euro filter on the wand pose (the tracking crate's filter).
    pub filter: FilterConfig,
    /// Wand id and loss timeout.
    pub tracking: TrackingSection,
    /// Starting tool.
    pub tool: ToolSection,
    /// Gesture tuning.
    pub interaction: InteractionSection,
}

impl ReplayConfig {
    /// Parses and validates TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let cfg: Self = toml::from_str(text).map_err(|e| Error::Config(e.to_string()))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks every number; the error names the bad setting.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Config(m));
        self.calibration
            .validate()
            .map_err(|e| Error::Config(format!("calibration: {e}")))?;
        self.filter
            .validate()
            .map_err(|e| Error::Config(format!("filter: {e}")))?;
        let i = &self.interaction;
        let positive = [
            ("tracking.timeout", self.tracking.timeout),
            ("tool.width", self.tool.width),
            ("tool.depth", self.tool.depth),
            ("interaction.max_speed", i.max_speed),
            ("interaction.sketch_row_spacing", i.sketch_row_spacing),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} must be a positive number, got {v}"));
            }
        }
        let non_negative = [
            ("tool.taper", self.tool.taper),
            ("interaction.pause_timeout", i.pause_timeout),
            ("interaction.max_resume_jump", i.max_resume_jump),
            ("interaction.min_stroke_length", i.min_stroke_length),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} must be >= 0, got {v}"));
            }
        }
        if !(2..=64).contains(&i.sketch_columns) || !(2..=10_000).contains(&i.min_sketch_rows) {
            return bad("sketch_columns must be in 2..=64 and min_sketch_rows in 2..=10000".into());
        }
        if !DVec3::from(i.sketch_axis).is_finite() || DVec3::from(i.sketch_axis).length() < 1e-6 {
            return bad("interaction.sketch_axis must be a non-zero vector".into());
        }
        let b = i.buttons;
        if [b.action, b.mode, b.profile, b.undo, b.redo, b.select]
            .iter()
            .any(|&x| x >= 32)
        {
            return bad("button indices must be below 32".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_settings_are_named() {
        let e = ReplayConfig::from_toml_str("[tool]\nwidth = -1.0\n").unwrap_err();
        assert!(e.to_string().contains("tool.width"), "{e}");
        let e = ReplayConfig::from_toml_str("[calibration]\nunits = 2\n").unwrap_err();
        assert!(e.to_string().contains("units"), "{e}");
        let e = ReplayConfig::from_toml_str("[tool]\nmode = \"paint\"\n").unwrap_err();
        assert!(e.to_string().contains("paint"), "{e}");
    }

    #[test]
    fn calibration_and_filter_come_from_the_tracking_tables() {
        let c = ReplayConfig::from_toml_str(
            "[calibration]\ntranslation_m = [0.0, 1.0, 0.0]\n[filter]\nenabled = false\n",
        )
        .unwrap();
        let p = c
            .calibration
            .point_in_world(DVec3::new(1000.0, 0.0, -500.0));
        assert_eq!(p, DVec3::new(1.0, 1.0, -0.5));
        assert!(!c.filter.enabled);
        let e = ReplayConfig::from_toml_str("[calibration]\naxes = [\"x\", \"x\", \"z\"]\n")
            .unwrap_err();
        assert!(e.to_string().contains("calibration"), "{e}");
    }
}
