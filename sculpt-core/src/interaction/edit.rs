//! The machine's output: edits for the document and operator events for the log.

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use super::*;

/// One point of a stroke.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StrokeSample {
    /// Time (seconds).
    pub t: f64,
    /// Wand tip (metres, display frame).
    pub position: DVec3,
}

/// A finished stroke, ready for the sculpting layer: the interaction's request to
/// stroke a target (what [`crate::editor::apply`] turns into a document stroke). The
/// document keeps a stroke as a
/// [`StrokeInput`](crate::sculpt::stroke::StrokeInput), on a target named by its id,
/// made from this by [`crate::editor::stroke_input`].
///
/// Journalled as `{"target": 1, "mode": "carve", "tool": {"profile": "v", "width":
/// 0.02, "depth": 0.005, "taper": 0.01}, "samples": [{"t": 0.0, "position": [x, y,
/// z]}, ...]}`: the mode beside the tool, not in it; a tool without `taper` gets
/// [`DEFAULT_TAPER`](crate::sculpt::stroke::DEFAULT_TAPER).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "StrokeEditJson", into = "StrokeEditJson")]
pub struct StrokeEdit {
    /// The target's id.
    pub target: TargetId,
    /// Carve or emboss. [`StrokeEdit::new`] takes it from `tool.mode`, and it is the
    /// one applied ([`crate::editor::stroke_input`]) and journalled.
    pub mode: StrokeMode,
    /// Tool at the time of the stroke.
    pub tool: Tool,
    /// The wand path (at least two samples).
    pub samples: Vec<StrokeSample>,
}

impl StrokeEdit {
    /// A stroke on the target at `target` with `tool` (carving or embossing as
    /// `tool.mode` says).
    pub fn new(target: TargetId, tool: Tool, samples: Vec<StrokeSample>) -> Self {
        Self {
            target,
            mode: tool.mode,
            tool,
            samples,
        }
    }
}

/// How a [`StrokeEdit`] is journalled (see there).
#[derive(Clone, Serialize, Deserialize)]
struct StrokeEditJson {
    target: TargetId,
    mode: StrokeMode,
    tool: ToolJson,
    samples: Vec<StrokeSample>,
}

/// A journalled stroke's tool: the [`Tool`] without its mode.
#[derive(Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToolJson {
    profile: Profile,
    width: f64,
    depth: f64,
    #[serde(default = "default_taper")]
    taper: f64,
}

fn default_taper() -> f64 {
    crate::sculpt::stroke::DEFAULT_TAPER
}

impl From<StrokeEditJson> for StrokeEdit {
    fn from(j: StrokeEditJson) -> Self {
        let t = j.tool;
        Self {
            target: j.target,
            mode: j.mode,
            tool: Tool {
                profile: t.profile,
                width: t.width,
                depth: t.depth,
                mode: j.mode,
                taper: t.taper,
            },
            samples: j.samples,
        }
    }
}

impl From<StrokeEdit> for StrokeEditJson {
    fn from(e: StrokeEdit) -> Self {
        let t = e.tool;
        Self {
            target: e.target,
            mode: e.mode,
            tool: ToolJson {
                profile: t.profile,
                width: t.width,
                depth: t.depth,
                taper: t.taper,
            },
            samples: e.samples,
        }
    }
}

/// A document edit the interaction asks for (and the journal records); what applying
/// it did is an [`Applied`](crate::editor::Applied).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "edit", rename_all = "kebab-case")]
pub enum Edit {
    /// A sketched surface: rows of points (one row per sweep sample, all rows the same
    /// length), to be fitted.
    Sketch {
        /// The point grid, display frame metres.
        rows: Vec<Vec<DVec3>>,
    },
    /// A carve or emboss stroke.
    Stroke(StrokeEdit),
    /// A lattice deformation of one or more targets.
    Deform(DeformEdit),
    /// A paint stroke: colour or a named scalar deposited on a target
    /// ([`crate::paint`]).
    Paint(crate::paint::PaintEdit),
    /// Undo the last edit.
    Undo,
    /// Redo.
    Redo,
    /// Make a target the target of later strokes.
    SelectTarget {
        /// Its id. (Version 1 journals wrote the target's position here, as `index`;
        /// see [`Edit::with_positions_resolved`].)
        #[serde(alias = "index")]
        target: TargetId,
    },
    /// Save the document.
    Save,
}

impl Edit {
    /// This edit with its target read as a position in `doc`'s targets rather than an
    /// id, as version 1 journals and operation logs wrote it; the position becomes the
    /// id of the target there now. A position past the last target becomes
    /// [`TargetId::MAX`], which names no target, so the edit is refused as it was then.
    pub fn with_positions_resolved(mut self, doc: &Document) -> Self {
        let resolve = |position: TargetId| {
            u32::try_from(position)
                .ok()
                .and_then(|p| doc.target_at(TargetIndex(p)))
                .map_or(TargetId::MAX, |t| t.id)
        };
        match &mut self {
            Edit::Stroke(s) => s.target = resolve(s.target),
            Edit::Paint(p) => p.target = resolve(p.target),
            Edit::SelectTarget { target } => *target = resolve(*target),
            Edit::Sketch { .. } | Edit::Deform(_) | Edit::Undo | Edit::Redo | Edit::Save => {}
        }
        self
    }
}

/// Why a gesture ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EndReason {
    /// The button was released.
    Released,
    /// Tracking was lost for too long, or came back too far away.
    TrackingLost,
    /// The gesture hit the sample cap.
    TooLong,
}

/// An operator event for the log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "kebab-case")]
pub enum OperatorEvent {
    /// A button went down.
    ButtonDown {
        /// Button index.
        button: u8,
    },
    /// A button came up.
    ButtonUp {
        /// Button index.
        button: u8,
    },
    /// The mode changed.
    ModeChange {
        /// Old mode.
        from: InteractionMode,
        /// New mode.
        to: InteractionMode,
    },
    /// The tool changed.
    ToolChange {
        /// The new tool.
        tool: Tool,
    },
    /// A stroke or sketch began.
    GestureStart {
        /// The mode it began in.
        mode: InteractionMode,
    },
    /// A stroke or sketch ended.
    GestureEnd {
        /// The mode.
        mode: InteractionMode,
        /// Whether it produced an edit.
        committed: bool,
        /// Why it ended.
        reason: EndReason,
        /// Why it produced no edit: too short a stroke or too few sketch rows (`None`
        /// when committed). Not serialised: the event's serde form is unchanged.
        #[serde(skip)]
        dropped: Option<StrokeRejection>,
    },
    /// The wand stopped being tracked.
    TrackingLost,
    /// The wand is tracked again.
    TrackingRegained,
    /// An undo, redo, select or save command.
    Command {
        /// The command's edit.
        edit: Edit,
    },
    /// A wand pose sample.
    Pose {
        /// Tip position.
        position: DVec3,
        /// Orientation.
        orientation: DQuat,
    },
}

/// What the machine produces.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Output {
    /// An edit to apply to the document.
    Edit(Edit),
    /// An operator event at time `t`.
    Op {
        /// Seconds.
        t: f64,
        /// The event.
        event: OperatorEvent,
    },
}
