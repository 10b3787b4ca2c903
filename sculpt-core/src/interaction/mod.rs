//! The interaction state machine: timestamped wand events in, document edits and
//! operator events out.
//!
//! Pure and deterministic: time comes only from the events, so the display server and
//! `replay` drive the same machine with live or recorded tracking and get the same
//! edits. The machine does not know the document; it emits [`Edit`]s for the caller to
//! apply, and [`OperatorEvent`]s (button edges, mode and tool changes, stroke start and
//! end, tracking loss, wand poses) for the operator log read by the GOMS harness.
//!
//! - **Sketch** mode: hold the action button and sweep; every sample adds a row of
//!   points along the wand's sweep axis, and release emits [`Edit::Sketch`] with the
//!   point grid, to be fitted by the kernel's approximation.
//! - **Carve** and **emboss** modes: press to start a stroke, move, release to emit
//!   [`Edit::Stroke`]. [`Interaction::live_stroke`] shows the stroke so far, for the
//!   interactive-depth preview.
//! - **Tracking loss** mid-gesture pauses it: samples stop being added. If tracking
//!   comes back within [`InteractionConfig::pause_timeout`] and within
//!   [`InteractionConfig::max_resume_jump`] of the last good sample, the gesture
//!   resumes; otherwise it ends at the last good sample, so there is never a jump.
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use sculpt_core::interaction::{Edit, Interaction, Output, WandEvent, WandSample};
//! let mut m = Interaction::default(); // starts in carve mode
//! let mut out = Vec::new();
//! for (i, buttons) in [1u32, 1, 1, 0].into_iter().enumerate() {
//!     let p = DVec3::new(0.01 * i as f64, 1.0, 0.2);
//!     m.handle(&WandEvent::sample(i as f64 * 0.01, WandSample::tracked(p, DQuat::IDENTITY, buttons)), &mut out)?;
//! }
//! assert!(out.iter().any(|o| matches!(o, Output::Edit(Edit::Stroke(s)) if s.samples.len() == 4)));
//! # Ok::<(), sculpt_core::Error>(())
//! ```

use glam::{DQuat, DVec3};

use crate::error::{Error, InteractionConfigError, InteractionError, Result, StrokeRejection};

use crate::lattice::{DeformEdit, LatticeSpec};
use crate::sculpt::document::Document;

/// The default lattice grab radius (metres): about a fingertip's reach around the wand
/// tip, so a drag takes the one control point it starts on.
pub const DEFAULT_LATTICE_RADIUS: f64 = 0.05;
pub use crate::sculpt::document::{TargetId, TargetIndex};
/// Carve or emboss: the sculpting layer's [`Mode`](crate::sculpt::stroke::Mode), named
/// for what it is beside [`InteractionMode`].
pub use crate::sculpt::stroke::Mode as StrokeMode;
pub use crate::sculpt::stroke::{Profile, Tool};

mod config;
mod edit;
mod events;

pub use config::{ButtonMap, InteractionConfig};
pub use edit::*;
pub use events::*;

#[derive(Debug, Clone, PartialEq)]
enum Gesture {
    Idle,
    Stroke {
        samples: Vec<StrokeSample>,
        paused_since: Option<f64>,
    },
    Sketch {
        rows: Vec<Vec<DVec3>>,
        last_tip: DVec3,
        paused_since: Option<f64>,
    },
    /// A lattice drag: where it grabbed and where the tip is now.
    Lattice {
        grab: DVec3,
        tip: DVec3,
        paused_since: Option<f64>,
    },
    /// A gesture ended early; wait for the action button to come up.
    Spent,
}

/// The target a new machine selects: the first target of a new document.
pub const DEFAULT_TARGET: TargetId = crate::sculpt::document::FIRST_ID;

/// The interaction state machine.
#[derive(Debug, Clone, PartialEq)]
pub struct Interaction {
    config: InteractionConfig,
    /// Sketching; otherwise stroking in `tool.mode` (unless `lattice`).
    sketching: bool,
    /// Lattice mode (before `sketching`).
    lattice: bool,
    /// Paint mode (before `lattice`): strokes paint with `brush`.
    painting: bool,
    /// What paint strokes paint.
    brush: crate::paint::Brush,
    tool: Tool,
    /// The document's target ids, in document order (never empty).
    targets: Vec<TargetId>,
    /// The selected one (one of `targets`).
    target: TargetId,
    last_t: Option<f64>,
    buttons: u32,
    tracked: bool,
    last_good: Option<(f64, DVec3, DQuat)>,
    gesture: Gesture,
    pose_counter: u32,
}

impl Default for Interaction {
    fn default() -> Self {
        Self::new(
            InteractionConfig::default(),
            InteractionMode::CARVE,
            Tool::default(),
        )
    }
}

impl Interaction {
    /// A machine in `mode` with `tool`, targeting [`DEFAULT_TARGET`], the only target
    /// it knows until [`Interaction::set_targets`] tells it more. A stroke mode
    /// replaces `tool.mode`; in sketch mode `tool.mode` is the stroke mode the mode
    /// button cycles back to.
    pub fn new(config: InteractionConfig, mode: InteractionMode, mut tool: Tool) -> Self {
        if let InteractionMode::Stroke(stroke_mode) = mode {
            tool.mode = stroke_mode;
        }
        Self {
            config,
            sketching: mode == InteractionMode::Sketch,
            lattice: mode == InteractionMode::Lattice,
            painting: mode == InteractionMode::Paint,
            brush: crate::paint::Brush::default(),
            tool,
            targets: vec![DEFAULT_TARGET],
            target: DEFAULT_TARGET,
            last_t: None,
            buttons: 0,
            tracked: false,
            last_good: None,
            gesture: Gesture::Idle,
            pose_counter: 0,
        }
    }

    /// Current mode.
    pub fn mode(&self) -> InteractionMode {
        if self.painting {
            InteractionMode::Paint
        } else if self.lattice {
            InteractionMode::Lattice
        } else if self.sketching {
            InteractionMode::Sketch
        } else {
            InteractionMode::Stroke(self.tool.mode)
        }
    }

    /// Current tool (its mode is the stroke mode, also while sketching).
    pub fn tool(&self) -> &Tool {
        &self.tool
    }

    /// The selected target's id.
    pub fn target(&self) -> TargetId {
        self.target
    }

    /// The selected target's position among the document's targets (what the HUD
    /// shows and [`Command::SelectTarget`] names).
    pub fn target_position(&self) -> TargetIndex {
        let position = self.targets.iter().position(|&id| id == self.target);
        TargetIndex(position.map_or(0, |p| u32::try_from(p).unwrap_or(u32::MAX)))
    }

    /// How many targets the machine selects among.
    pub fn target_count(&self) -> u32 {
        u32::try_from(self.targets.len()).unwrap_or(u32::MAX)
    }

    /// Whether the wand is tracked.
    pub fn is_tracked(&self) -> bool {
        self.tracked
    }

    /// The last good wand pose `(t, tip, orientation)`.
    pub fn wand(&self) -> Option<(f64, DVec3, DQuat)> {
        self.last_good
    }

    /// True while a stroke or sketch is live.
    pub fn gesture_active(&self) -> bool {
        matches!(
            self.gesture,
            Gesture::Stroke { .. } | Gesture::Sketch { .. } | Gesture::Lattice { .. }
        )
    }

    /// True while a live gesture is paused by tracking loss.
    pub fn gesture_paused(&self) -> bool {
        matches!(
            self.gesture,
            Gesture::Stroke {
                paused_since: Some(_),
                ..
            } | Gesture::Sketch {
                paused_since: Some(_),
                ..
            } | Gesture::Lattice {
                paused_since: Some(_),
                ..
            }
        )
    }

    /// The live lattice drag: where it grabbed and how far the tip has moved since
    /// (for drawing the cage as it will be).
    pub fn live_lattice(&self) -> Option<(DVec3, DVec3)> {
        match &self.gesture {
            Gesture::Lattice { grab, tip, .. } => Some((*grab, *tip - *grab)),
            _ => None,
        }
    }

    /// The deformation the live lattice drag would apply if released now (for the
    /// live preview of the bent targets); `None` when no drag is live or the tip has
    /// not moved. A release emits it only once the drag is as long as a stroke must be.
    pub fn live_deform(&self) -> Option<DeformEdit> {
        match &self.gesture {
            Gesture::Lattice { grab, tip, .. } if tip != grab => {
                Some(self.deform_edit(*grab, *tip))
            }
            _ => None,
        }
    }

    /// The deformation of a lattice drag from `grab` to `tip`.
    fn deform_edit(&self, grab: DVec3, tip: DVec3) -> DeformEdit {
        DeformEdit {
            targets: self.targets.clone(),
            lattice: self.config.lattice,
            grab,
            radius: self.config.lattice_radius,
            displacement: tip - grab,
        }
    }

    /// The lattice grab radius (metres).
    pub fn lattice_radius(&self) -> f64 {
        self.config.lattice_radius
    }

    /// The lattice's shape.
    pub fn lattice_spec(&self) -> LatticeSpec {
        self.config.lattice
    }

    /// The paint brush (what paint strokes paint, [`Command::SetBrush`]).
    pub fn brush(&self) -> &crate::paint::Brush {
        &self.brush
    }

    /// The live stroke so far (for the preview), if a stroke is in progress (not
    /// while painting: a paint stroke carves nothing).
    pub fn live_stroke(&self) -> Option<StrokeEdit> {
        if self.painting {
            return None;
        }
        match &self.gesture {
            Gesture::Stroke { samples, .. } => Some(StrokeEdit::new(
                self.target,
                self.tool.clone(),
                samples.clone(),
            )),
            _ => None,
        }
    }

    /// The live stroke's samples so far, without copying them (see
    /// [`Interaction::live_stroke`]).
    pub fn live_stroke_samples(&self) -> Option<&[StrokeSample]> {
        if self.painting {
            return None;
        }
        match &self.gesture {
            Gesture::Stroke { samples, .. } => Some(samples),
            _ => None,
        }
    }

    /// The live sketch grid so far.
    pub fn live_sketch(&self) -> Option<&[Vec<DVec3>]> {
        match &self.gesture {
            Gesture::Sketch { rows, .. } => Some(rows),
            _ => None,
        }
    }

    /// Tells the machine the document's target ids, in document order (selection
    /// wraps around them). The selected target stays selected while it exists; when
    /// it is gone (an undone sketch), the target now at its position, or the last
    /// one, is selected. An empty list leaves the machine as it was.
    pub fn set_targets(&mut self, ids: &[TargetId]) {
        if ids.is_empty() || ids == self.targets.as_slice() {
            return;
        }
        if !ids.contains(&self.target) {
            let position = self.target_position().0 as usize;
            self.target = ids[position.min(ids.len() - 1)];
        }
        self.targets = ids.to_vec();
    }

    fn bit(&self, b: u8) -> u32 {
        1u32.checked_shl(u32::from(b)).unwrap_or(0)
    }

    /// Feeds one event; appends what it causes to `out`.
    ///
    /// Fails (changing nothing) when the time is not finite or goes backwards, or a
    /// command carries an invalid value.
    pub fn handle(&mut self, ev: &WandEvent, out: &mut Vec<Output>) -> Result<()> {
        if !ev.t.is_finite() {
            return Err(Error::Interaction(InteractionError::TimeNotFinite {
                t: ev.t,
            }));
        }
        if let Some(last) = self.last_t
            && ev.t < last
        {
            return Err(Error::Interaction(InteractionError::TimeBackwards {
                t: ev.t,
                previous: last,
            }));
        }
        if let WandInput::Command(c) = &ev.input {
            self.check_command(c)?;
        }
        self.last_t = Some(ev.t);
        self.tick_inner(ev.t, out);
        match &ev.input {
            WandInput::Sample(s) => self.on_sample(ev.t, s, out),
            WandInput::Command(c) => self.on_command(ev.t, c.clone(), out),
        }
        Ok(())
    }

    /// Advances time with no input (call once a frame): a gesture paused for longer
    /// than the timeout ends at its last good sample. Times before the last event are
    /// ignored.
    pub fn tick(&mut self, t: f64, out: &mut Vec<Output>) {
        if t.is_finite() && self.last_t.is_none_or(|l| t >= l) {
            self.last_t = Some(t);
            self.tick_inner(t, out);
        }
    }

    fn tick_inner(&mut self, t: f64, out: &mut Vec<Output>) {
        let paused = match &self.gesture {
            Gesture::Stroke { paused_since, .. }
            | Gesture::Sketch { paused_since, .. }
            | Gesture::Lattice { paused_since, .. } => *paused_since,
            _ => None,
        };
        if let Some(since) = paused
            && t - since > self.config.pause_timeout
        {
            self.finish(t, EndReason::TrackingLost, out);
        }
    }

    fn check_command(&self, c: &Command) -> Result<()> {
        let tool = match c {
            Command::SetBrush { brush } => return Ok(brush.validate()?),
            Command::SetLatticeRadius { radius } => {
                let ok =
                    radius.is_finite() && *radius > 0.0 && *radius <= crate::lattice::MAX_REACH_M;
                return if ok {
                    Ok(())
                } else {
                    Err(Error::Interaction(InteractionError::LatticeRadius {
                        radius: *radius,
                    }))
                };
            }
            Command::SetWidth { width } => Tool {
                width: *width,
                ..self.tool.clone()
            },
            Command::SetDepth { depth } => Tool {
                depth: *depth,
                ..self.tool.clone()
            },
            Command::SetProfile { profile } => Tool {
                profile: profile.clone(),
                ..self.tool.clone()
            },
            _ => return Ok(()),
        };
        // The one set of caps, `Tool::validate`'s; breaking them refuses the input.
        tool.validate().map_err(|e| match e {
            Error::StrokeRejected(StrokeRejection::Tool(range)) => {
                Error::Interaction(InteractionError::Tool(range))
            }
            Error::StrokeRejected(why) => Error::Interaction(InteractionError::Profile(why)),
            other => other,
        })
    }

    fn on_command(&mut self, t: f64, c: Command, out: &mut Vec<Output>) {
        match c {
            Command::SetMode { mode } => self.set_mode(t, mode, out),
            Command::SetProfile { profile } => self.set_tool(
                t,
                Tool {
                    profile,
                    ..self.tool.clone()
                },
                out,
            ),
            Command::SetWidth { width } => self.set_tool(
                t,
                Tool {
                    width,
                    ..self.tool.clone()
                },
                out,
            ),
            Command::SetDepth { depth } => self.set_tool(
                t,
                Tool {
                    depth,
                    ..self.tool.clone()
                },
                out,
            ),
            Command::Undo => self.command_edit(t, Edit::Undo, out),
            Command::Redo => self.command_edit(t, Edit::Redo, out),
            Command::SelectTarget { index } => {
                if let Some(&target) = self.targets.get(index.0 as usize) {
                    self.target = target;
                    self.command_edit(t, Edit::SelectTarget { target }, out);
                }
            }
            Command::SelectNextTarget => self.select_next(t, out),
            Command::Save => self.command_edit(t, Edit::Save, out),
            Command::SetLatticeRadius { radius } => {
                if !self.gesture_active() {
                    self.config.lattice_radius = radius;
                }
            }
            Command::SetBrush { brush } => {
                if !self.gesture_active() {
                    self.brush = brush;
                }
            }
        }
    }

    fn select_next(&mut self, t: f64, out: &mut Vec<Output>) {
        if self.gesture_active() {
            return;
        }
        let next = (self.target_position().0 as usize + 1) % self.targets.len();
        let target = self.targets[next];
        self.target = target;
        self.command_edit(t, Edit::SelectTarget { target }, out);
    }

    /// Undo, redo, select and save act only between gestures.
    fn command_edit(&mut self, t: f64, edit: Edit, out: &mut Vec<Output>) {
        if self.gesture_active() {
            return;
        }
        out.push(Output::Op {
            t,
            event: OperatorEvent::Command { edit: edit.clone() },
        });
        out.push(Output::Edit(edit));
    }

    fn set_mode(&mut self, t: f64, mode: InteractionMode, out: &mut Vec<Output>) {
        if self.gesture_active() || mode == self.mode() {
            return;
        }
        out.push(Output::Op {
            t,
            event: OperatorEvent::ModeChange {
                from: self.mode(),
                to: mode,
            },
        });
        self.lattice = mode == InteractionMode::Lattice;
        self.painting = mode == InteractionMode::Paint;
        match mode {
            InteractionMode::Sketch => self.sketching = true,
            InteractionMode::Stroke(stroke_mode) => {
                self.sketching = false;
                self.tool.mode = stroke_mode;
            }
            InteractionMode::Lattice | InteractionMode::Paint => self.sketching = false,
        }
    }

    fn set_tool(&mut self, t: f64, tool: Tool, out: &mut Vec<Output>) {
        if self.gesture_active() || tool == self.tool {
            return;
        }
        self.tool = tool.clone();
        out.push(Output::Op {
            t,
            event: OperatorEvent::ToolChange { tool },
        });
    }

    fn on_sample(&mut self, t: f64, s: &WandSample, out: &mut Vec<Output>) {
        let usable = s.usable() && !self.is_glitch(t, s);
        if usable != self.tracked {
            self.tracked = usable;
            out.push(Output::Op {
                t,
                event: if usable {
                    OperatorEvent::TrackingRegained
                } else {
                    OperatorEvent::TrackingLost
                },
            });
        }
        if usable {
            let q = s.orientation.normalize();
            self.pose_counter = self.pose_counter.wrapping_add(1);
            if self
                .pose_counter
                .is_multiple_of(self.config.pose_every.max(1))
            {
                out.push(Output::Op {
                    t,
                    event: OperatorEvent::Pose {
                        position: s.position,
                        orientation: q,
                    },
                });
            }
            self.extend_gesture(t, s.position, q, out);
            self.last_good = Some((t, s.position, q));
        } else {
            self.pause_gesture(t);
        }
        self.on_buttons(t, s.buttons, out);
    }

    /// A tracked sample implying a speed above `max_speed` is a glitch.
    fn is_glitch(&self, t: f64, s: &WandSample) -> bool {
        match self.last_good {
            Some((t0, p0, _)) if self.tracked => {
                let dt = (t - t0).max(crate::tolerance::MIN_SPEED_DT);
                (s.position - p0).length() / dt > self.config.max_speed
            }
            _ => false,
        }
    }

    fn pause_gesture(&mut self, t: f64) {
        if let Gesture::Stroke { paused_since, .. }
        | Gesture::Sketch { paused_since, .. }
        | Gesture::Lattice { paused_since, .. } = &mut self.gesture
            && paused_since.is_none()
        {
            *paused_since = Some(t);
        }
    }

    fn extend_gesture(&mut self, t: f64, p: DVec3, q: DQuat, out: &mut Vec<Output>) {
        let last_p = self.last_good.map(|(_, p, _)| p);
        let resume_ok = last_p.is_some_and(|lp| (p - lp).length() <= self.config.max_resume_jump);
        let paused = match &mut self.gesture {
            Gesture::Stroke { paused_since, .. }
            | Gesture::Sketch { paused_since, .. }
            | Gesture::Lattice { paused_since, .. } => paused_since,
            _ => return,
        };
        if paused.is_some() {
            if resume_ok {
                *paused = None;
            } else {
                // Came back somewhere else: end at the last good sample, no jump.
                self.finish(t, EndReason::TrackingLost, out);
                return;
            }
        }
        let cap = self.config.max_samples;
        let mut too_long = false;
        match &mut self.gesture {
            Gesture::Stroke { samples, .. } => {
                samples.push(StrokeSample { t, position: p });
                too_long = samples.len() >= cap;
            }
            Gesture::Sketch { rows, last_tip, .. } => {
                if rows.is_empty() || (p - *last_tip).length() >= self.config.sketch_row_spacing {
                    rows.push(sketch_row(
                        p,
                        q,
                        self.config.sketch_axis,
                        self.config.sketch_columns,
                    ));
                    *last_tip = p;
                }
                too_long = rows.len() >= cap;
            }
            Gesture::Lattice { tip, .. } => *tip = p,
            _ => {}
        }
        if too_long {
            self.finish(t, EndReason::TooLong, out);
        }
    }

    fn on_buttons(&mut self, t: f64, buttons: u32, out: &mut Vec<Output>) {
        let down = buttons & !self.buttons;
        let up = self.buttons & !buttons;
        self.buttons = buttons;
        for b in 0..32u8 {
            let bit = 1u32 << b;
            if up & bit != 0 {
                out.push(Output::Op {
                    t,
                    event: OperatorEvent::ButtonUp { button: b },
                });
            }
            if down & bit != 0 {
                out.push(Output::Op {
                    t,
                    event: OperatorEvent::ButtonDown { button: b },
                });
            }
        }
        let map = self.config.buttons;
        if up & self.bit(map.action) != 0 {
            self.finish(t, EndReason::Released, out);
            self.gesture = Gesture::Idle;
        }
        if down & self.bit(map.action) != 0 {
            self.start_gesture(t, out);
        }
        if down & self.bit(map.mode) != 0 {
            self.set_mode(t, self.mode().next(), out);
        }
        if down & self.bit(map.profile) != 0 {
            let tool = Tool {
                profile: self.tool.profile.toggled(),
                ..self.tool.clone()
            };
            self.set_tool(t, tool, out);
        }
        if down & self.bit(map.undo) != 0 {
            self.command_edit(t, Edit::Undo, out);
        }
        if down & self.bit(map.redo) != 0 {
            self.command_edit(t, Edit::Redo, out);
        }
        if down & self.bit(map.select) != 0 {
            self.select_next(t, out);
        }
        for (button, mode) in [
            (map.lattice, InteractionMode::Lattice),
            (map.paint, InteractionMode::Paint),
        ] {
            if down & self.bit(button) != 0 {
                // On, or off again to the stroke mode.
                let to = if self.mode() == mode {
                    InteractionMode::Stroke(self.tool.mode)
                } else {
                    mode
                };
                self.set_mode(t, to, out);
            }
        }
    }

    fn start_gesture(&mut self, t: f64, out: &mut Vec<Output>) {
        if !matches!(self.gesture, Gesture::Idle) {
            return;
        }
        // A press while untracked starts nothing: there is no pose to start from.
        let Some((_, p, q)) = self.last_good.filter(|_| self.tracked) else {
            self.gesture = Gesture::Spent;
            return;
        };
        self.gesture = match self.mode() {
            InteractionMode::Sketch => Gesture::Sketch {
                rows: vec![sketch_row(
                    p,
                    q,
                    self.config.sketch_axis,
                    self.config.sketch_columns,
                )],
                last_tip: p,
                paused_since: None,
            },
            InteractionMode::Stroke(_) | InteractionMode::Paint => Gesture::Stroke {
                samples: vec![StrokeSample { t, position: p }],
                paused_since: None,
            },
            InteractionMode::Lattice => Gesture::Lattice {
                grab: p,
                tip: p,
                paused_since: None,
            },
        };
        out.push(Output::Op {
            t,
            event: OperatorEvent::GestureStart { mode: self.mode() },
        });
    }

    /// Ends the live gesture (if any), emitting its edit when it is long enough.
    fn finish(&mut self, t: f64, reason: EndReason, out: &mut Vec<Output>) {
        let gesture = std::mem::replace(&mut self.gesture, Gesture::Spent);
        let mut dropped = None;
        let edit = match gesture {
            // A paint stroke: any tracked sample paints (a dab is a stroke).
            Gesture::Stroke { samples, .. } if self.painting => Some(Edit::Paint(
                self.brush
                    .stroke(self.target, samples.iter().map(|s| s.position).collect()),
            )),
            Gesture::Stroke { samples, .. } => {
                let length: f64 = samples
                    .windows(2)
                    .map(|w| (w[1].position - w[0].position).length())
                    .sum();
                if samples.len() < 2 || length < self.config.min_stroke_length {
                    dropped = Some(StrokeRejection::TooShort {
                        length_m: length,
                        min_m: self.config.min_stroke_length,
                    });
                }
                (samples.len() >= 2 && length >= self.config.min_stroke_length)
                    .then(|| Edit::Stroke(StrokeEdit::new(self.target, self.tool.clone(), samples)))
            }
            Gesture::Sketch { rows, .. } => {
                if rows.len() < self.config.min_sketch_rows as usize {
                    dropped = Some(StrokeRejection::TooFewRows {
                        rows: rows.len(),
                        min_rows: self.config.min_sketch_rows as usize,
                    });
                }
                (rows.len() >= self.config.min_sketch_rows as usize)
                    .then_some(Edit::Sketch { rows })
            }
            Gesture::Lattice { grab, tip, .. } => {
                // A drag shorter than a stroke would be is a click: nothing moves.
                let length = tip.distance(grab);
                let min = self.config.min_stroke_length;
                if length < min {
                    dropped = Some(StrokeRejection::TooShort {
                        length_m: length,
                        min_m: min,
                    });
                }
                (length >= min).then(|| Edit::Deform(self.deform_edit(grab, tip)))
            }
            idle @ (Gesture::Idle | Gesture::Spent) => {
                self.gesture = idle;
                return;
            }
        };
        out.push(Output::Op {
            t,
            event: OperatorEvent::GestureEnd {
                mode: self.mode(),
                committed: edit.is_some(),
                reason,
                dropped,
            },
        });
        if let Some(edit) = edit {
            // A sketch's new surface joins the targets when the document tells the
            // machine its targets again ([`Interaction::set_targets`]).
            out.push(Output::Edit(edit));
        }
    }
}

/// One sketch row: `columns` points from the tip along the wand's sweep axis.
fn sketch_row(
    tip: DVec3,
    display_from_wand: DQuat,
    axis_in_wand: DVec3,
    columns: u32,
) -> Vec<DVec3> {
    let axis = display_from_wand * axis_in_wand;
    let n = columns.max(2);
    (0..n)
        .map(|j| tip + axis * (f64::from(j) / f64::from(n - 1)))
        .collect()
}

#[cfg(test)]
mod tests;
