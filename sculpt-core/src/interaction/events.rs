//! The machine's input: wand samples, commands and the modes they select.

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use super::*;

/// What the action button does: sweep a sketch, or stroke in the tool's carve or emboss
/// mode.
///
/// Written as `"sketch"`, `"carve"` or `"emboss"` (pose-log commands, the configuration's
/// `[tool] mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(from = "ModeName", into = "ModeName")]
pub enum InteractionMode {
    /// Sweep to create a surface.
    Sketch,
    /// Strokes cut grooves ([`StrokeMode::Carve`]) or raise ridges
    /// ([`StrokeMode::Emboss`]).
    Stroke(StrokeMode),
    /// Drag a lattice control point (or the group within
    /// [`InteractionConfig::lattice_radius`] of it) to deform the targets
    /// ([`Edit::Deform`]). Not in the mode button's cycle: a command selects it.
    Lattice,
    /// Sweep the wand over a target to paint it with the brush
    /// ([`Interaction::brush`], [`Edit::Paint`]). Not in the mode button's cycle: the
    /// paint button or a command selects it.
    Paint,
}

impl InteractionMode {
    /// Carving strokes.
    pub const CARVE: Self = Self::Stroke(StrokeMode::Carve);
    /// Embossing strokes.
    pub const EMBOSS: Self = Self::Stroke(StrokeMode::Emboss);

    /// The next mode in the cycle sketch -> carve -> emboss -> sketch; lattice mode
    /// (outside the cycle) goes on to carve.
    pub fn next(self) -> Self {
        match self {
            Self::Sketch | Self::Lattice | Self::Paint => Self::CARVE,
            Self::Stroke(StrokeMode::Carve) => Self::EMBOSS,
            Self::Stroke(StrokeMode::Emboss) => Self::Sketch,
        }
    }

    /// The stroke mode, or `None` when sketching or in lattice mode.
    pub fn stroke_mode(self) -> Option<StrokeMode> {
        match self {
            Self::Sketch | Self::Lattice | Self::Paint => None,
            Self::Stroke(mode) => Some(mode),
        }
    }

    /// The mode's name, as it is written: `sketch`, `carve`, `emboss`, `lattice` or
    /// `paint`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sketch => "sketch",
            Self::Stroke(StrokeMode::Carve) => "carve",
            Self::Stroke(StrokeMode::Emboss) => "emboss",
            Self::Lattice => "lattice",
            Self::Paint => "paint",
        }
    }
}

impl From<StrokeMode> for InteractionMode {
    fn from(mode: StrokeMode) -> Self {
        Self::Stroke(mode)
    }
}

/// How an [`InteractionMode`] is written: one word.
#[derive(Clone, Copy, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum ModeName {
    Sketch,
    Carve,
    Emboss,
    Lattice,
    Paint,
}

impl From<ModeName> for InteractionMode {
    fn from(name: ModeName) -> Self {
        match name {
            ModeName::Sketch => Self::Sketch,
            ModeName::Carve => Self::CARVE,
            ModeName::Emboss => Self::EMBOSS,
            ModeName::Lattice => Self::Lattice,
            ModeName::Paint => Self::Paint,
        }
    }
}

impl From<InteractionMode> for ModeName {
    fn from(mode: InteractionMode) -> Self {
        match mode {
            InteractionMode::Sketch => Self::Sketch,
            InteractionMode::Stroke(StrokeMode::Carve) => Self::Carve,
            InteractionMode::Stroke(StrokeMode::Emboss) => Self::Emboss,
            InteractionMode::Lattice => Self::Lattice,
            InteractionMode::Paint => Self::Paint,
        }
    }
}

/// One wand tracker sample, in the display frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WandSample {
    /// Whether the tracker sees the wand; the pose is ignored when false.
    pub tracked: bool,
    /// Tip position (metres, display frame).
    pub position: DVec3,
    /// `display_from_wand` rotation.
    pub orientation: DQuat,
    /// Button states, bit i = button i held.
    pub buttons: u32,
}

impl WandSample {
    /// A tracked sample.
    pub fn tracked(position: DVec3, orientation: DQuat, buttons: u32) -> Self {
        Self {
            tracked: true,
            position,
            orientation,
            buttons,
        }
    }

    /// An untracked sample (buttons still arrive from a wireless wand).
    pub fn lost(buttons: u32) -> Self {
        Self {
            tracked: false,
            position: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
            buttons,
        }
    }

    /// True when tracked with a finite pose and a usable (non-zero) rotation.
    pub(super) fn usable(&self) -> bool {
        self.tracked
            && self.position.is_finite()
            && self.orientation.is_finite()
            && self.orientation.length_squared() > crate::tolerance::ZERO_QUAT_LEN2
    }
}

/// A discrete command from a keyboard, menu or voice (desktop mode uses these).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "command", rename_all = "kebab-case")]
pub enum Command {
    /// Switch mode.
    SetMode {
        /// The new mode.
        mode: InteractionMode,
    },
    /// Change the profile.
    SetProfile {
        /// The new profile.
        profile: Profile,
    },
    /// Change the tool width (metres).
    SetWidth {
        /// The new width.
        width: f64,
    },
    /// Change the tool depth (metres).
    SetDepth {
        /// The new depth.
        depth: f64,
    },
    /// Undo the last edit.
    Undo,
    /// Redo the last undone edit.
    Redo,
    /// Select the target surface at position `index`.
    SelectTarget {
        /// Its position in the document's targets.
        index: TargetIndex,
    },
    /// Select the next target surface.
    SelectNextTarget,
    /// Change the lattice grab radius (metres): a drag in lattice mode moves the
    /// lattice control points within it ([`InteractionConfig::lattice_radius`]).
    SetLatticeRadius {
        /// The new radius.
        radius: f64,
    },
    /// Save the document.
    Save,
    /// Change the paint brush: attribute, value and radius (checked as
    /// [`crate::paint::Brush::validate`] does).
    SetBrush {
        /// The new brush.
        brush: crate::paint::Brush,
    },
}

/// What happened at time `t`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum WandInput {
    /// A tracker sample.
    Sample(WandSample),
    /// A command.
    Command(Command),
}

/// A timestamped input.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WandEvent {
    /// Seconds on the session clock (monotonic, non-decreasing).
    pub t: f64,
    /// The input.
    pub input: WandInput,
}

impl WandEvent {
    /// A sample event.
    pub fn sample(t: f64, sample: WandSample) -> Self {
        Self {
            t,
            input: WandInput::Sample(sample),
        }
    }

    /// A command event.
    pub fn command(t: f64, command: Command) -> Self {
        Self {
            t,
            input: WandInput::Command(command),
        }
    }
}
