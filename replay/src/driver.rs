//! The gesture driver: timed wand samples in, document edits and operator events out.
//!
//! A small, pure, deterministic state machine (time comes only from the samples):
//!
//! - **Carve / emboss**: the action button's press starts a stroke, each tracked sample
//!   adds a point, the release ends it and emits [`Edit::Stroke`].
//! - **Sketch**: while the action button is held, every [`sketch_row_spacing`] of tip
//!   travel adds a row of points along the wand's sweep axis; the release emits
//!   [`Edit::Sketch`] with the point grid.
//! - The mode button cycles carve -> emboss -> sketch, the profile button toggles
//!   V / U, undo and redo buttons emit [`Edit::Undo`] / [`Edit::Redo`], the select
//!   button selects the next target. Buttons other than the action button act on their
//!   press, and only between gestures.
//! - **Tracking loss** mid-gesture pauses it: samples stop being added. If tracking
//!   comes back within `pause_timeout` and within `max_resume_jump` of the last good
//!   sample, the gesture resumes; otherwise it ends at the last good sample and the
//!   driver waits for the action button to come up. Apparent motion faster than
//!   `max_speed` is a glitch and the sample is dropped. Nothing is ever invented.
//!
//! This is the smallest machine the replay needs while the display server's own
//! interaction layer is not in the workspace; its settings use the same names as the
//! display config's `[interaction]` table.
//!
//! [`sketch_row_spacing`]: crate::config::InteractionSection::sketch_row_spacing
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use replay::config::ReplayConfig;
//! use replay::driver::{Driver, Edit, Sample};
//! let mut d = Driver::new(&ReplayConfig::default(), 1);
//! let mut edits = Vec::new();
//! for i in 0..5 {
//!     let p = DVec3::new(0.01 * i as f64, 1.0, 0.0);
//!     let buttons = if i < 4 { 1 } else { 0 };
//!     edits.extend(d.sample(Sample { t: 0.01 * i as f64, tracked: true, position: p, orientation: DQuat::IDENTITY, buttons }));
//! }
//! // The release sample, still tracked, is the stroke's last point.
//! assert!(matches!(&edits[0], Edit::Stroke { samples, .. } if samples.len() == 5));
//! ```

use glam::{DQuat, DVec3};
use sculpt_core::oplog::{EventKind, TrackingState};

use crate::config::{Mode, ProfileName, ReplayConfig};

/// One wand sample in the display frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Seconds on the session clock.
    pub t: f64,
    /// Whether the pose is measured (the pose is ignored otherwise).
    pub tracked: bool,
    /// Tip position, metres.
    pub position: DVec3,
    /// `display_from_wand`.
    pub orientation: DQuat,
    /// Button bits held.
    pub buttons: u32,
}

/// A document edit.
#[derive(Debug, Clone, PartialEq)]
pub enum Edit {
    /// A carve or emboss stroke on target `target` (index).
    Stroke {
        /// Target index.
        target: usize,
        /// Carve (false) or emboss (true).
        emboss: bool,
        /// The chisel profile.
        profile: ProfileName,
        /// `(t, position)` samples.
        samples: Vec<(f64, DVec3)>,
        /// When the gesture ended (seconds).
        ended_at: f64,
    },
    /// A sketched surface: rows of points, all the same length.
    Sketch {
        /// The grid, display metres.
        rows: Vec<Vec<DVec3>>,
        /// When the gesture ended.
        ended_at: f64,
    },
    /// Undo the last edit.
    Undo,
    /// Redo.
    Redo,
}

#[derive(Debug, Clone, PartialEq)]
enum Gesture {
    Idle,
    Stroke {
        samples: Vec<(f64, DVec3)>,
        paused_since: Option<f64>,
    },
    Sketch {
        rows: Vec<Vec<DVec3>>,
        last_tip: DVec3,
        paused_since: Option<f64>,
    },
    /// Ended early; wait for the action button to come up.
    Spent,
}

/// The gesture state machine.
#[derive(Debug, Clone)]
pub struct Driver {
    cfg: ReplayConfig,
    mode: Mode,
    profile: ProfileName,
    target: usize,
    target_count: usize,
    buttons: u32,
    tracked: Option<bool>,
    last_good: Option<(f64, DVec3)>,
    last_t: f64,
    gesture: Gesture,
    pose_counter: u32,
    events: Vec<(f64, EventKind)>,
    /// Gestures ended by tracking loss.
    pub ended_by_loss: usize,
    /// Gestures that resumed after a loss.
    pub resumed: usize,
    /// Samples dropped as speed glitches.
    pub glitches: usize,
    /// Strokes discarded as too short.
    pub too_short: usize,
    /// Times the wand went from tracked to lost.
    pub losses: usize,
}

/// Most samples one gesture may hold (memory bound).
pub const MAX_GESTURE_SAMPLES: usize = 200_000;

impl Driver {
    /// A driver in the config's starting mode, on target 0 of `target_count`.
    pub fn new(cfg: &ReplayConfig, target_count: usize) -> Self {
        Self {
            cfg: cfg.clone(),
            mode: cfg.tool.mode,
            profile: cfg.tool.profile,
            target: 0,
            target_count: target_count.max(1),
            buttons: 0,
            tracked: None,
            last_good: None,
            last_t: f64::NEG_INFINITY,
            gesture: Gesture::Idle,
            pose_counter: 0,
            events: Vec::new(),
            ended_by_loss: 0,
            resumed: 0,
            glitches: 0,
            too_short: 0,
            losses: 0,
        }
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The selected target index.
    pub fn target(&self) -> usize {
        self.target
    }

    /// Tells the driver how many targets the document has (after a sketch or undo).
    pub fn set_target_count(&mut self, n: usize) {
        self.target_count = n.max(1);
        if self.target >= self.target_count {
            self.target = self.target_count - 1;
        }
    }

    /// Operator events produced since the last call, oldest first.
    pub fn take_events(&mut self) -> Vec<(f64, EventKind)> {
        std::mem::take(&mut self.events)
    }

    fn ev(&mut self, t: f64, kind: EventKind) {
        self.events.push((t, kind));
    }

    fn bit(&self, b: u8) -> u32 {
        1u32 << b
    }

    /// Feeds one sample; returns the edits it completes. Samples with time going
    /// backwards or NaN are dropped.
    pub fn sample(&mut self, s: Sample) -> Vec<Edit> {
        let mut edits = Vec::new();
        if !s.t.is_finite() || s.t < self.last_t {
            return edits;
        }
        self.tick_into(s.t, &mut edits);
        self.last_t = s.t;
        let usable = s.tracked
            && s.position.is_finite()
            && s.orientation.is_finite()
            && s.orientation.length_squared() > 1e-6;
        // A physically impossible jump is a glitch: treat the sample as untracked.
        let glitch = usable
            && self.last_good.is_some_and(|(t0, p0)| {
                let dt = s.t - t0;
                dt > 0.0 && (s.position - p0).length() / dt > self.cfg.interaction.max_speed
            });
        if glitch {
            self.glitches += 1;
        }
        let tracked = usable && !glitch;
        if self.tracked != Some(tracked) && !glitch {
            if self.tracked == Some(true) && !tracked {
                self.losses += 1;
            }
            if self.tracked.is_some() || !tracked {
                let state = if tracked {
                    TrackingState::Tracked
                } else {
                    TrackingState::Lost
                };
                self.ev(s.t, EventKind::Tracking { state });
            }
            self.tracked = Some(tracked);
        }
        if tracked {
            let every = self.cfg.interaction.pose_every;
            if every > 0 {
                if self.pose_counter.is_multiple_of(every) {
                    self.ev(
                        s.t,
                        EventKind::Pose {
                            p: s.position,
                            q: s.orientation.normalize(),
                        },
                    );
                }
                self.pose_counter = self.pose_counter.wrapping_add(1);
            }
        }
        // Button edges, in bit order.
        let changed = self.buttons ^ s.buttons;
        for b in 0..32u8 {
            if changed & (1 << b) != 0 {
                self.ev(
                    s.t,
                    EventKind::Button {
                        id: b,
                        down: s.buttons & (1 << b) != 0,
                    },
                );
            }
        }
        let pressed = changed & s.buttons;
        let map = self.cfg.interaction.buttons;
        let action = s.buttons & self.bit(map.action) != 0;
        let idle = matches!(self.gesture, Gesture::Idle);
        if idle && !action {
            if pressed & self.bit(map.mode) != 0 {
                self.mode = self.mode.next();
                self.ev(
                    s.t,
                    EventKind::Mode {
                        mode: self.mode.name().into(),
                    },
                );
            }
            if pressed & self.bit(map.profile) != 0 {
                self.profile = match self.profile {
                    ProfileName::V => ProfileName::U,
                    ProfileName::U => ProfileName::V,
                };
                let name = match self.profile {
                    ProfileName::V => "v-chisel",
                    ProfileName::U => "u-chisel",
                };
                self.ev(s.t, EventKind::Tool { tool: name.into() });
            }
            if pressed & self.bit(map.undo) != 0 {
                self.ev(s.t, EventKind::Undo);
                edits.push(Edit::Undo);
            }
            if pressed & self.bit(map.redo) != 0 {
                self.ev(s.t, EventKind::Redo);
                edits.push(Edit::Redo);
            }
            if pressed & self.bit(map.select) != 0 {
                self.target = (self.target + 1) % self.target_count;
                self.ev(
                    s.t,
                    EventKind::Marker {
                        label: format!("select-target {}", self.target),
                    },
                );
            }
        }
        // The action button.
        let active = matches!(
            self.gesture,
            Gesture::Stroke { .. } | Gesture::Sketch { .. }
        );
        let spent = matches!(self.gesture, Gesture::Spent);
        if idle && action && pressed & self.bit(map.action) != 0 && tracked {
            self.ev(s.t, EventKind::StrokeStart);
            self.gesture = match self.mode {
                Mode::Sketch => Gesture::Sketch {
                    rows: vec![self.sketch_row(s.position, s.orientation)],
                    last_tip: s.position,
                    paused_since: None,
                },
                _ => Gesture::Stroke {
                    samples: vec![(s.t, s.position)],
                    paused_since: None,
                },
            };
        } else if active && action {
            self.continue_gesture(s, tracked, &mut edits);
        } else if active {
            if tracked {
                self.continue_gesture(s, true, &mut edits);
            }
            if !matches!(self.gesture, Gesture::Spent) {
                self.end_gesture(s.t, &mut edits);
            }
            self.gesture = Gesture::Idle;
        } else if spent && !action {
            self.gesture = Gesture::Idle;
        }
        if tracked {
            self.last_good = Some((s.t, s.position));
        }
        self.buttons = s.buttons;
        edits
    }

    fn sketch_row(&self, tip: DVec3, q: DQuat) -> Vec<DVec3> {
        let axis = q.normalize() * DVec3::from(self.cfg.interaction.sketch_axis);
        let n = self.cfg.interaction.sketch_columns;
        (0..n)
            .map(|j| tip + axis * (j as f64 / (n - 1) as f64))
            .collect()
    }

    fn continue_gesture(&mut self, s: Sample, tracked: bool, edits: &mut Vec<Edit>) {
        let i = self.cfg.interaction;
        let last_good = self.last_good;
        let row = tracked.then(|| self.sketch_row(s.position, s.orientation));
        let (paused_since, resume_ok) = match &mut self.gesture {
            Gesture::Stroke { paused_since, .. } | Gesture::Sketch { paused_since, .. } => {
                let ok = paused_since.is_none_or(|p0| {
                    s.t - p0 <= i.pause_timeout
                        && last_good
                            .is_some_and(|(_, p)| (s.position - p).length() <= i.max_resume_jump)
                });
                (paused_since, ok)
            }
            _ => return,
        };
        if !tracked {
            if paused_since.is_none() {
                *paused_since = Some(s.t);
            }
            return;
        }
        let was_paused = paused_since.is_some();
        if !resume_ok {
            self.ended_by_loss += 1;
            self.end_gesture(s.t, edits);
            self.gesture = Gesture::Spent;
            return;
        }
        if was_paused {
            self.resumed += 1;
        }
        match &mut self.gesture {
            Gesture::Stroke {
                samples,
                paused_since,
            } => {
                *paused_since = None;
                if samples.len() < MAX_GESTURE_SAMPLES {
                    samples.push((s.t, s.position));
                }
            }
            Gesture::Sketch {
                rows,
                last_tip,
                paused_since,
            } => {
                *paused_since = None;
                if (s.position - *last_tip).length() >= i.sketch_row_spacing
                    && rows.len() < MAX_GESTURE_SAMPLES
                    && let Some(row) = row
                {
                    rows.push(row);
                    *last_tip = s.position;
                }
            }
            _ => {}
        }
    }

    fn end_gesture(&mut self, t: f64, edits: &mut Vec<Edit>) {
        let gesture = std::mem::replace(&mut self.gesture, Gesture::Idle);
        let i = self.cfg.interaction;
        match gesture {
            Gesture::Stroke { samples, .. } => {
                self.ev(t, EventKind::StrokeEnd);
                let length: f64 = samples.windows(2).map(|w| (w[1].1 - w[0].1).length()).sum();
                if samples.len() >= 2 && length >= i.min_stroke_length {
                    edits.push(Edit::Stroke {
                        target: self.target,
                        emboss: self.mode == Mode::Emboss,
                        profile: self.profile,
                        samples,
                        ended_at: t,
                    });
                } else {
                    self.too_short += 1;
                }
            }
            Gesture::Sketch { rows, .. } => {
                self.ev(t, EventKind::StrokeEnd);
                if rows.len() >= i.min_sketch_rows as usize {
                    edits.push(Edit::Sketch { rows, ended_at: t });
                } else {
                    self.too_short += 1;
                }
            }
            Gesture::Idle | Gesture::Spent => {}
        }
    }

    fn tick_into(&mut self, t: f64, edits: &mut Vec<Edit>) {
        let timeout = self.cfg.interaction.pause_timeout;
        let expired = match &self.gesture {
            Gesture::Stroke {
                paused_since: Some(p0),
                ..
            }
            | Gesture::Sketch {
                paused_since: Some(p0),
                ..
            } => t - p0 > timeout,
            _ => false,
        };
        if expired {
            self.ended_by_loss += 1;
            self.end_gesture(t, edits);
            self.gesture = Gesture::Spent;
        }
    }

    /// Advances time with no input: ends a gesture paused longer than the timeout.
    pub fn tick(&mut self, t: f64) -> Vec<Edit> {
        let mut edits = Vec::new();
        if t.is_finite() && t >= self.last_t {
            self.tick_into(t, &mut edits);
            self.last_t = t;
        }
        edits
    }

    /// Marks the wand lost at time `t` (no data for longer than the tracking
    /// timeout): same as an untracked sample with the buttons unchanged.
    pub fn lost(&mut self, t: f64) -> Vec<Edit> {
        let buttons = self.buttons;
        self.sample(Sample {
            t,
            tracked: false,
            position: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
            buttons,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t: f64, x: f64, buttons: u32) -> Sample {
        Sample {
            t,
            tracked: true,
            position: DVec3::new(x, 1.0, 0.0),
            orientation: DQuat::IDENTITY,
            buttons,
        }
    }

    fn lost(t: f64, buttons: u32) -> Sample {
        Sample {
            t,
            tracked: false,
            position: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
            buttons,
        }
    }

    #[test]
    fn a_short_loss_resumes_and_a_long_one_ends_the_stroke() {
        let mut d = Driver::new(&ReplayConfig::default(), 1);
        let mut edits = Vec::new();
        for k in 0..10 {
            edits.extend(d.sample(at(k as f64 * 0.01, k as f64 * 0.002, 1)));
        }
        edits.extend(d.sample(lost(0.10, 1)));
        edits.extend(d.sample(lost(0.20, 1)));
        edits.extend(d.sample(at(0.21, 0.02, 1))); // back after 0.11 s, 2 mm away
        assert_eq!(d.resumed, 1);
        edits.extend(d.sample(lost(0.3, 1)));
        edits.extend(d.sample(lost(0.9, 1))); // 0.6 s > pause_timeout: ends
        assert_eq!(d.ended_by_loss, 1);
        assert_eq!(edits.len(), 1);
        let Edit::Stroke { samples, .. } = &edits[0] else {
            panic!("{edits:?}")
        };
        assert_eq!(samples.len(), 11);
        // Still held when tracking returns: nothing new until the button comes up.
        assert!(d.sample(at(1.0, 0.1, 1)).is_empty());
        assert!(d.sample(at(1.1, 0.1, 0)).is_empty());
        assert_eq!(d.losses, 2);
    }

    #[test]
    fn mode_button_cycles_and_sketch_makes_a_grid() {
        let mut d = Driver::new(&ReplayConfig::default(), 1);
        d.sample(at(0.0, 0.0, 0));
        d.sample(at(0.1, 0.0, 2));
        d.sample(at(0.2, 0.0, 0));
        assert_eq!(d.mode(), Mode::Emboss);
        d.sample(at(0.3, 0.0, 2));
        d.sample(at(0.4, 0.0, 0));
        assert_eq!(d.mode(), Mode::Sketch);
        let mut edits = Vec::new();
        for k in 0..20 {
            let mut s = at(0.5 + k as f64 * 0.01, 0.0, 1);
            s.position.y += k as f64 * 0.02;
            edits.extend(d.sample(s));
        }
        let mut up = at(0.8, 0.0, 0);
        up.position.y += 19.0 * 0.02; // released where the sweep ended
        edits.extend(d.sample(up));
        let Edit::Sketch { rows, .. } = &edits[0] else {
            panic!("{edits:?}")
        };
        assert_eq!(rows.len(), 20);
        assert!(rows.iter().all(|r| r.len() == 8));
        let ev = d.take_events();
        assert!(
            ev.iter()
                .any(|(_, e)| matches!(e, EventKind::Mode { mode } if mode == "sketch"))
        );
    }

    #[test]
    fn glitches_nan_and_time_going_back_are_dropped() {
        let mut d = Driver::new(&ReplayConfig::default(), 1);
        d.sample(at(0.0, 0.0, 1));
        d.sample(at(0.01, 5.0, 1)); // 500 m/s
        assert_eq!(d.glitches, 1);
        d.sample(at(0.005, 0.0, 1)); // back in time
        let mut nan = at(0.02, f64::NAN, 1);
        nan.orientation = DQuat::from_xyzw(f64::NAN, 0.0, 0.0, 1.0);
        d.sample(nan);
        let edits = d.sample(at(0.05, 0.01, 0));
        let Edit::Stroke { samples, .. } = &edits[0] else {
            panic!()
        };
        assert!(samples.iter().all(|(_, p)| p.is_finite()));
        assert_eq!(samples.len(), 2);
    }
}
