//! The thumbstick as the tool's width and depth: a wand's first two analog axes,
//! held over time, become `SetWidth` / `SetDepth` commands in steps. Pure; the
//! [`crate::feeder::Feeder`] runs it for every driver after each accepted frame.

use sculpt_core::interaction::{Command, Tool, WandEvent};
use tracking::Frame;

/// Rate and range of the thumbstick's tool changes. A headset session writes them to
/// its replay config (`[thumbstick]`), so `replay` makes the same changes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ThumbstickTool {
    /// Axis values within this of zero do nothing.
    pub dead_zone: f64,
    /// Width change at full deflection (metres per second).
    pub width_rate: f64,
    /// Depth change at full deflection (metres per second).
    pub depth_rate: f64,
    /// Allowed widths (metres).
    pub width_range: (f64, f64),
    /// Allowed depths (metres).
    pub depth_range: (f64, f64),
    /// Changes are sent in steps of this (metres), so the operator log and the
    /// journal see a few commands, not one per frame.
    pub step: f64,
}

impl Default for ThumbstickTool {
    fn default() -> Self {
        Self {
            dead_zone: 0.2,
            width_rate: 0.02,
            depth_rate: 0.005,
            width_range: (0.002, 0.1),
            depth_range: (0.0005, 0.03),
            step: 0.0005,
        }
    }
}

/// A [`ThumbstickTool`] setting that cannot work.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThumbstickError {
    /// The dead zone is not in [0, 1).
    #[error("thumbstick dead_zone {0} is not in [0, 1)")]
    DeadZone(f64),
    /// A rate is negative or not finite.
    #[error("thumbstick {name} {value} is not a finite rate >= 0 (m/s)")]
    Rate {
        /// `width_rate` or `depth_rate`.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A range is not `0 < low <= high`, finite.
    #[error("thumbstick {name} [{low}, {high}] is not a range 0 < low <= high (m)")]
    Range {
        /// `width_range` or `depth_range`.
        name: &'static str,
        /// Its low end.
        low: f64,
        /// Its high end.
        high: f64,
    },
    /// The step is not positive and finite.
    #[error("thumbstick step {0} is not a finite length > 0 (m)")]
    Step(f64),
}

impl ThumbstickTool {
    /// Checks every setting (a replay config is user input).
    pub fn validate(&self) -> Result<(), ThumbstickError> {
        if !(self.dead_zone >= 0.0 && self.dead_zone < 1.0) {
            return Err(ThumbstickError::DeadZone(self.dead_zone));
        }
        for (name, value) in [
            ("width_rate", self.width_rate),
            ("depth_rate", self.depth_rate),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ThumbstickError::Rate { name, value });
            }
        }
        for (name, (low, high)) in [
            ("width_range", self.width_range),
            ("depth_range", self.depth_range),
        ] {
            if !(low > 0.0 && high >= low && high.is_finite()) {
                return Err(ThumbstickError::Range { name, low, high });
            }
        }
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(ThumbstickError::Step(self.step));
        }
        Ok(())
    }

    /// The commands for holding `stick` (x: width, y: depth) for `dt` seconds, at time
    /// `t`, with the tool as it is. `pending` accumulates sub-step changes between
    /// calls (width, depth).
    pub fn commands(
        &self,
        t: f64,
        dt: f64,
        stick: [f64; 2],
        tool: &Tool,
        pending: &mut [f64; 2],
    ) -> Vec<WandEvent> {
        let mut out = Vec::new();
        if !(dt.is_finite() && dt > 0.0) {
            return out;
        }
        let axes = [
            (stick[0], self.width_rate, tool.width, self.width_range),
            (stick[1], self.depth_rate, tool.depth, self.depth_range),
        ];
        for (i, (v, rate, now, (lo, hi))) in axes.into_iter().enumerate() {
            let v = if v.is_finite() {
                v.clamp(-1.0, 1.0)
            } else {
                0.0
            };
            if v.abs() <= self.dead_zone {
                pending[i] = 0.0;
                continue;
            }
            // Rescaled so the rate starts at zero at the dead zone's edge.
            let s = v.signum() * (v.abs() - self.dead_zone) / (1.0 - self.dead_zone);
            pending[i] += s * rate * dt;
            if pending[i].abs() < self.step {
                continue;
            }
            let steps = (pending[i] / self.step).trunc();
            pending[i] -= steps * self.step;
            let next = (now + steps * self.step).clamp(lo, hi);
            if next != now {
                let command = if i == 0 {
                    Command::SetWidth { width: next }
                } else {
                    Command::SetDepth { depth: next }
                };
                out.push(WandEvent::command(t, command));
            }
        }
        out
    }
}

/// The thumbstick's tool changes driven by tracker frames: the wand's first two analog
/// axes (x: width, y: depth) of each frame the stage accepted, at the stage's time.
/// Every driver runs it through [`crate::feeder::Feeder`] (a headset's
/// [`XrWand`](crate::xr::wand::XrWand), live tracking with `[tracking.thumbstick]`, `replay`) on the
/// frames as the pose log holds them (axes to two decimals, `ts` to six), so both make
/// the same commands at the same times.
#[derive(Debug, Clone, PartialEq)]
pub struct ThumbstickDriver {
    /// Rates and ranges.
    pub tool: ThumbstickTool,
    pending: [f64; 2],
    last_t: Option<f64>,
}

impl ThumbstickDriver {
    /// A driver with no frame seen yet.
    pub fn new(tool: ThumbstickTool) -> Self {
        Self {
            tool,
            pending: [0.0; 2],
            last_t: None,
        }
    }

    /// The commands after the stage accepted `frame` at stage time `t`, for the wand
    /// `wand_id` (its axes held since the previous accepted frame), with the tool as
    /// it is. The first frame only starts the clock.
    pub fn commands(&mut self, t: f64, frame: &Frame, wand_id: u32, tool: &Tool) -> Vec<WandEvent> {
        let axes = frame
            .wands
            .iter()
            .find(|w| w.id == wand_id)
            .map_or([0.0; 2], |w| {
                [0, 1].map(|i| w.analog.get(i).copied().unwrap_or(0.0))
            });
        let dt = self.last_t.map_or(0.0, |last| t - last);
        if t.is_finite() {
            self.last_t = Some(t);
        }
        self.tool.commands(t, dt, axes, tool, &mut self.pending)
    }
}
