//! The one edit loop: wand events in, the [`Interaction`] driven, its edits applied to
//! the [`Document`] with [`editor::apply`], and what happened handed back as a
//! [`Step`].
//!
//! The display server (`vr-app`'s `Session`) and `replay` both feed every staged wand
//! sample (`tracking::stage` converts a stage sample into a [`WandEvent`]), every
//! command and every tick through an [`EditLoop`], so a live session and the replay of
//! its pose log take the same steps and build the same document. The loop is pure: no
//! I/O, no clock, no threads. What a caller must do *while* a step runs, it does in
//! [`EditHooks`]: the display server appends each edit to its journal (and fsyncs)
//! before the edit is applied and writes the operator log as events happen; `replay`
//! times each stroke's apply. Everything else the caller reads from the returned
//! [`Step`].
//!
//! One step, for one input at time `t`:
//! 1. the interaction handles the input (a [`WandEvent`]) or the passage of time
//!    ([`EditLoop::tick`]); an input it refuses (time not finite or going back, a bad
//!    command value) changes nothing and is [`LoopError::Refused`];
//! 2. its outputs are taken in order: an operator event goes to
//!    [`EditHooks::operator_event`]; an edit over one of the document's size caps
//!    ([`editor::check_caps`]) is rejected there and then, unjournalled; any other edit
//!    goes to [`EditHooks::before_apply`], is applied with [`editor::apply`], the
//!    interaction is told the document's targets (a sketch adds a target, an undo may
//!    remove one), and the edit and its
//!    [`Applied`] go to [`EditHooks::after_apply`];
//! 3. the [`Step`] lists all of it, with whether the live gesture's [`Preview`]
//!    changed, whether a paused gesture resumed and whether a tracked sample was
//!    dropped as a glitch.
//!
//! ```
//! use glam::DQuat;
//! use sculpt_core::edit_loop::{EditLoop, NoHooks, Preview};
//! use sculpt_core::editor::{self, Applied};
//! use sculpt_core::interaction::{Interaction, WandEvent, WandSample};
//!
//! let mut edits = EditLoop::new(Interaction::default(), editor::default_document());
//! let mut previews = Vec::new();
//! // Press, carve 20 cm across the default surface, release.
//! for i in 0..=10 {
//!     let tip = editor::default_surface_point(-0.1 + 0.02 * i as f64, 1.15);
//!     let buttons = u32::from(i < 10);
//!     let ev = WandEvent::sample(0.01 * i as f64, WandSample::tracked(tip, DQuat::IDENTITY, buttons));
//!     let step = edits.handle(&ev, &mut NoHooks)?;
//!     previews.extend(step.preview);
//!     for (edit, applied) in step.edits() {
//!         assert!(matches!(applied, Applied::Stroke { .. }), "{edit:?}: {applied:?}");
//!     }
//! }
//! assert_eq!(edits.doc.strokes().len(), 1);
//! assert_eq!(previews.first(), Some(&Preview::Stroke { samples: 1, paused: false }));
//! assert_eq!(previews.last(), Some(&Preview::Idle));
//! # Ok::<(), sculpt_core::edit_loop::LoopError<std::convert::Infallible>>(())
//! ```

use std::convert::Infallible;

use crate::editor::{self, Applied};
use crate::error::Error;
use crate::interaction::{Edit, Interaction, OperatorEvent, Output, WandEvent, WandInput};
use crate::sculpt::document::Document;

/// What a caller does while a step runs, in the order the interaction emitted it. Every
/// hook defaults to doing nothing; an error from a hook ends the step there (the rest of
/// its outputs are dropped) and is returned as [`LoopError::Hook`].
pub trait EditHooks {
    /// Why a hook failed (the display server's journal or file I/O).
    type Error: std::error::Error + 'static;

    /// An operator event at time `t` (the display server writes its operator log here).
    fn operator_event(&mut self, t: f64, event: &OperatorEvent) -> Result<(), Self::Error> {
        let _ = (t, event);
        Ok(())
    }

    /// `edit`, caused at time `t`, is about to be applied: a write-ahead journal records
    /// it here. An error leaves the edit unapplied. An edit over one of the document's
    /// size caps ([`editor::check_caps`]) is rejected without this call.
    fn before_apply(&mut self, t: f64, edit: &Edit) -> Result<(), Self::Error> {
        let _ = (t, edit);
        Ok(())
    }

    /// `edit` was applied to `doc` (the interaction already knows the new targets).
    fn after_apply(
        &mut self,
        t: f64,
        edit: &Edit,
        applied: &Applied,
        doc: &Document,
    ) -> Result<(), Self::Error> {
        let _ = (t, edit, applied, doc);
        Ok(())
    }
}

/// Hooks that do nothing, for callers that only read the [`Step`].
#[derive(Debug, Clone, Copy, Default)]
pub struct NoHooks;

impl EditHooks for NoHooks {
    type Error = Infallible;
}

/// Why a step did not complete.
#[derive(Debug, thiserror::Error)]
pub enum LoopError<E: std::error::Error + 'static> {
    /// The interaction refused the input (time not finite or going back, a bad command
    /// value); nothing changed.
    #[error("the interaction refused the input")]
    Refused(#[source] Error),
    /// A hook failed; the outputs after it in the step were dropped.
    #[error("an edit hook failed")]
    Hook(#[source] E),
}

/// The live gesture, as a renderer previews it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preview {
    /// No stroke or sketch is live.
    Idle,
    /// A carve or emboss stroke is live.
    Stroke {
        /// Samples so far.
        samples: usize,
        /// Paused by tracking loss.
        paused: bool,
    },
    /// A sketch is live.
    Sketch {
        /// Rows so far.
        rows: usize,
        /// Paused by tracking loss.
        paused: bool,
    },
}

impl Preview {
    /// The live gesture of `interaction`.
    pub fn of(interaction: &Interaction) -> Self {
        let paused = interaction.gesture_paused();
        if let Some(samples) = interaction.live_stroke_samples() {
            Preview::Stroke {
                samples: samples.len(),
                paused,
            }
        } else if let Some(rows) = interaction.live_sketch() {
            Preview::Sketch {
                rows: rows.len(),
                paused,
            }
        } else {
            Preview::Idle
        }
    }
}

/// One thing that happened in a step, in the order the interaction emitted it.
#[derive(Debug, Clone, PartialEq)]
pub enum LoopEvent {
    /// An operator event (for the operator log).
    Operator {
        /// When, seconds on the session clock.
        t: f64,
        /// The event.
        event: OperatorEvent,
    },
    /// An edit, applied to the document.
    Edit {
        /// The edit.
        edit: Edit,
        /// What applying it did (a rejection leaves the document as it was).
        applied: Applied,
    },
}

/// What one input did (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The input's time: every edit of the step was caused and applied at it.
    pub t: f64,
    /// Operator events and applied edits, in order.
    pub events: Vec<LoopEvent>,
    /// The live gesture after the step, when it differs from before (a stroke started,
    /// gained a sample, paused or resumed, or ended).
    pub preview: Option<Preview>,
    /// A gesture paused by tracking loss resumed.
    pub resumed: bool,
    /// A tracked sample was dropped as a glitch (an impossible jump) and counts as a
    /// tracking loss.
    pub glitch: bool,
}

impl Step {
    /// The operator events, with their times.
    pub fn operator_events(&self) -> impl Iterator<Item = (f64, &OperatorEvent)> {
        self.events.iter().filter_map(|e| match e {
            LoopEvent::Operator { t, event } => Some((*t, event)),
            LoopEvent::Edit { .. } => None,
        })
    }

    /// The edits, each with what applying it did (rejected ones included).
    pub fn edits(&self) -> impl Iterator<Item = (&Edit, &Applied)> {
        self.events.iter().filter_map(|e| match e {
            LoopEvent::Edit { edit, applied } => Some((edit, applied)),
            LoopEvent::Operator { .. } => None,
        })
    }

    /// The edits the document refused, with why.
    pub fn rejections(&self) -> impl Iterator<Item = (&Edit, &Error)> {
        self.edits().filter_map(|(edit, applied)| match applied {
            Applied::Rejected(e) => Some((edit, e)),
            _ => None,
        })
    }
}

/// The interaction state machine and the document it edits, kept in step (see the
/// module docs).
#[derive(Debug, Clone)]
pub struct EditLoop {
    /// The interaction state machine. Feed it through [`EditLoop::handle`] and
    /// [`EditLoop::tick`]; reading it (mode, tool, live gesture, wand) is free.
    pub interaction: Interaction,
    /// The sculpted document. Change it through the loop; a caller that replaces or
    /// edits it directly calls [`EditLoop::sync_targets`] afterwards.
    pub doc: Document,
    /// Scratch for the interaction's outputs, reused across steps.
    outputs: Vec<Output>,
}

impl EditLoop {
    /// A loop editing `doc` with `interaction`, which is told the document's targets.
    pub fn new(interaction: Interaction, doc: Document) -> Self {
        let mut edit_loop = Self {
            interaction,
            doc,
            outputs: Vec::new(),
        };
        edit_loop.sync_targets();
        edit_loop
    }

    /// Targets in the document, as the interaction counts them.
    pub fn target_count(&self) -> u32 {
        u32::try_from(self.doc.targets().len()).unwrap_or(u32::MAX)
    }

    /// Tells the interaction the document's targets (selection wraps around them).
    pub fn sync_targets(&mut self) {
        self.interaction.set_targets(&self.doc.stroke_target_ids());
    }

    /// Applies one edit that did not come from the interaction (a journalled one,
    /// recovered) and keeps the interaction's targets in step.
    pub fn apply(&mut self, edit: &Edit) -> Applied {
        let applied = editor::apply(&mut self.doc, edit);
        self.sync_targets();
        applied
    }

    /// Feeds one wand event (a sample or a command) and applies the edits it causes.
    pub fn handle<H: EditHooks>(
        &mut self,
        ev: &WandEvent,
        hooks: &mut H,
    ) -> Result<Step, LoopError<H::Error>> {
        let preview = Preview::of(&self.interaction);
        let was_paused = self.interaction.gesture_paused();
        let mut outputs = std::mem::take(&mut self.outputs);
        outputs.clear();
        let handled = self.interaction.handle(ev, &mut outputs);
        let resumed =
            was_paused && !self.interaction.gesture_paused() && self.interaction.gesture_active();
        let tracked = matches!(ev.input, WandInput::Sample(s) if s.tracked);
        let glitch = tracked
            && outputs.iter().any(|o| {
                matches!(
                    o,
                    Output::Op {
                        event: OperatorEvent::TrackingLost,
                        ..
                    }
                )
            });
        let step = match handled {
            Ok(()) => self
                .consume(ev.t, &mut outputs, preview, hooks)
                .map(|step| Step {
                    resumed,
                    glitch,
                    ..step
                })
                .map_err(LoopError::Hook),
            Err(e) => Err(LoopError::Refused(e)),
        };
        self.outputs = outputs;
        step
    }

    /// Advances time to `t` with no input: a gesture paused by tracking loss for longer
    /// than the pause timeout ends (and its edit, if long enough, is applied). Times
    /// that are not finite or before the last input change nothing.
    pub fn tick<H: EditHooks>(&mut self, t: f64, hooks: &mut H) -> Result<Step, H::Error> {
        let preview = Preview::of(&self.interaction);
        let mut outputs = std::mem::take(&mut self.outputs);
        outputs.clear();
        self.interaction.tick(t, &mut outputs);
        let step = self.consume(t, &mut outputs, preview, hooks);
        self.outputs = outputs;
        step
    }

    /// Feeds one wand event like [`EditLoop::handle`], but applies nothing: operator
    /// events go to the hooks as they happen and the edits are handed back in order.
    /// A replicated document (the cluster's operation stream) applies them later, in
    /// the stream's order, through [`EditLoop::apply`]; applied before the next input,
    /// they give exactly the steps of [`EditLoop::handle`].
    pub fn propose<H: EditHooks>(
        &mut self,
        ev: &WandEvent,
        hooks: &mut H,
    ) -> Result<Vec<Edit>, LoopError<H::Error>> {
        let mut outputs = std::mem::take(&mut self.outputs);
        outputs.clear();
        let handled = self.interaction.handle(ev, &mut outputs);
        let edits = match handled {
            Ok(()) => Self::split_outputs(&mut outputs, hooks).map_err(LoopError::Hook),
            Err(e) => Err(LoopError::Refused(e)),
        };
        self.outputs = outputs;
        edits
    }

    /// Advances time like [`EditLoop::tick`], but applies nothing (see
    /// [`EditLoop::propose`]).
    pub fn propose_tick<H: EditHooks>(
        &mut self,
        t: f64,
        hooks: &mut H,
    ) -> Result<Vec<Edit>, H::Error> {
        let mut outputs = std::mem::take(&mut self.outputs);
        outputs.clear();
        self.interaction.tick(t, &mut outputs);
        let edits = Self::split_outputs(&mut outputs, hooks);
        self.outputs = outputs;
        edits
    }

    /// Operator events to the hooks, edits handed back.
    fn split_outputs<H: EditHooks>(
        outputs: &mut Vec<Output>,
        hooks: &mut H,
    ) -> Result<Vec<Edit>, H::Error> {
        let mut edits = Vec::new();
        for output in outputs.drain(..) {
            match output {
                Output::Op { t, event } => hooks.operator_event(t, &event)?,
                Output::Edit(edit) => edits.push(edit),
            }
        }
        Ok(edits)
    }

    /// Takes the interaction's outputs in order: operator events to the hooks, edits
    /// through the hooks and [`editor::apply`].
    fn consume<H: EditHooks>(
        &mut self,
        t: f64,
        outputs: &mut Vec<Output>,
        preview_before: Preview,
        hooks: &mut H,
    ) -> Result<Step, H::Error> {
        let mut events = Vec::with_capacity(outputs.len());
        for output in outputs.drain(..) {
            match output {
                Output::Op { t: at, event } => {
                    hooks.operator_event(at, &event)?;
                    events.push(LoopEvent::Operator { t: at, event });
                }
                Output::Edit(edit) => {
                    // An edit over a document cap is refused before the journal sees it.
                    let applied = match editor::check_caps(&self.doc, &edit) {
                        Err(e) => Applied::Rejected(e),
                        Ok(()) => {
                            hooks.before_apply(t, &edit)?;
                            self.apply(&edit)
                        }
                    };
                    hooks.after_apply(t, &edit, &applied, &self.doc)?;
                    events.push(LoopEvent::Edit { edit, applied });
                }
            }
        }
        let preview = Preview::of(&self.interaction);
        Ok(Step {
            t,
            events,
            preview: (preview != preview_before).then_some(preview),
            resumed: false,
            glitch: false,
        })
    }
}

#[cfg(test)]
mod tests;
