//! Button map and interaction settings, with their validation.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::*;

/// Which button bit does what.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ButtonMap {
    /// Draw (start/end strokes and sketches).
    pub action: u8,
    /// Cycle the mode.
    pub mode: u8,
    /// Toggle the profile.
    pub profile: u8,
    /// Undo.
    pub undo: u8,
    /// Redo.
    pub redo: u8,
    /// Select the next target.
    pub select: u8,
    /// Lattice mode on and off ([`InteractionMode::Lattice`]; off goes back to the
    /// stroke mode).
    pub lattice: u8,
    /// Paint mode on and off ([`InteractionMode::Paint`]; off goes back to the stroke
    /// mode).
    pub paint: u8,
}

impl Default for ButtonMap {
    fn default() -> Self {
        Self {
            action: 0,
            mode: 1,
            profile: 2,
            undo: 3,
            redo: 4,
            select: 5,
            lattice: 6,
            paint: 7,
        }
    }
}

/// Tuning of the state machine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InteractionConfig {
    /// Button assignment.
    pub buttons: ButtonMap,
    /// How long a gesture may stay paused by tracking loss (seconds).
    pub pause_timeout: f64,
    /// Largest distance from the last good sample at which a paused gesture resumes
    /// (metres).
    pub max_resume_jump: f64,
    /// Faster apparent wand motion than this (m/s) is a tracking glitch, not motion.
    pub max_speed: f64,
    /// Strokes shorter than this (metres of path) are discarded.
    pub min_stroke_length: f64,
    /// Sketch sweep segment, in wand coordinates, from the tip (metres).
    pub sketch_axis: DVec3,
    /// Points per sketch row.
    pub sketch_columns: u32,
    /// Minimum tip travel between sketch rows (metres).
    pub sketch_row_spacing: f64,
    /// Minimum rows for a sketch to count.
    pub min_sketch_rows: u32,
    /// Gesture sample cap (memory bound).
    pub max_samples: usize,
    /// Emit a pose operator event every n-th tracked sample (1 = all).
    pub pose_every: u32,
    /// Lattice mode: a drag moves the lattice control points within this distance of
    /// where it starts (metres).
    pub lattice_radius: f64,
    /// Lattice mode: the lattice's degree and control point counts.
    pub lattice: LatticeSpec,
}

impl Default for InteractionConfig {
    fn default() -> Self {
        Self {
            buttons: ButtonMap::default(),
            pause_timeout: 0.5,
            max_resume_jump: 0.05,
            max_speed: 15.0,
            min_stroke_length: 0.005,
            sketch_axis: DVec3::new(0.3, 0.0, 0.0),
            sketch_columns: 8,
            sketch_row_spacing: 0.01,
            min_sketch_rows: 4,
            max_samples: 200_000,
            pose_every: 1,
            lattice_radius: DEFAULT_LATTICE_RADIUS,
            lattice: LatticeSpec::default(),
        }
    }
}

impl InteractionConfig {
    /// Checks every value the types cannot: the one validation `wandsculpt` and
    /// `replay` both run on `[interaction]`, so neither accepts what the other
    /// rejects. The error names the key (`interaction: pause_timeout must be >= 0`).
    pub fn validate(&self) -> Result<()> {
        let bad = |e: InteractionConfigError| Err(Error::Interaction(InteractionError::Config(e)));
        let positive = [
            ("max_speed", self.max_speed),
            ("sketch_row_spacing", self.sketch_row_spacing),
        ];
        for (setting, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return bad(InteractionConfigError::NotPositive { setting, value });
            }
        }
        let non_negative = [
            ("pause_timeout", self.pause_timeout),
            ("max_resume_jump", self.max_resume_jump),
            ("min_stroke_length", self.min_stroke_length),
        ];
        for (setting, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return bad(InteractionConfigError::Negative { setting, value });
            }
        }
        if self.max_samples < 2 {
            return bad(InteractionConfigError::MaxSamples);
        }
        if !(self.lattice_radius.is_finite()
            && self.lattice_radius > 0.0
            && self.lattice_radius <= crate::lattice::MAX_REACH_M)
        {
            return bad(InteractionConfigError::NotPositive {
                setting: "lattice_radius",
                value: self.lattice_radius,
            });
        }
        if let Err(e) = self.lattice.validate() {
            return bad(InteractionConfigError::Lattice(e));
        }
        if !(2..=64).contains(&self.sketch_columns) || !(2..=10_000).contains(&self.min_sketch_rows)
        {
            return bad(InteractionConfigError::SketchSize);
        }
        if !self.sketch_axis.is_finite()
            || self.sketch_axis.length() < crate::tolerance::ZERO_QUAT_LEN
        {
            return bad(InteractionConfigError::SketchAxis);
        }
        let b = self.buttons;
        if [
            b.action, b.mode, b.profile, b.undo, b.redo, b.select, b.lattice, b.paint,
        ]
        .iter()
        .any(|&x| x >= 32)
        {
            return bad(InteractionConfigError::ButtonIndex);
        }
        Ok(())
    }
}
