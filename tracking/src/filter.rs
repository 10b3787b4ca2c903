//! The One Euro filter on position and orientation, per device.
//!
//! Casiez, Roussel & Vogel (CHI 2012), "1€ Filter": an exponential low-pass whose
//! cutoff rises with speed, so a still wand is steady and a fast one does not lag:
//!
//! ```text
//! α(fc, Δt) = 1 / (1 + τ/Δt),  τ = 1 / (2π fc)
//! ẋ̂_i = ẋ̂_{i−1} + α(d_cutoff, Δt) · ((x_i − x̂_{i−1})/Δt − ẋ̂_{i−1})
//! fc  = min_cutoff + β · |ẋ̂_i|
//! x̂_i = x̂_{i−1} + α(fc, Δt) · (x_i − x̂_{i−1})
//! ```
//!
//! Positions use the speed of the 3-vector; orientations use the angular speed and a
//! slerp by `α` (shortest arc). A non-increasing timestamp returns the previous output;
//! a gap longer than [`OneEuroParams::reset_after_s`] restarts the filter.
//!
//! ```
//! use tracking::filter::{FilterConfig, PoseFilter};
//! use tracking::calibration::DisplayPose;
//! use glam::{DQuat, DVec3};
//! let mut f = PoseFilter::new(FilterConfig::default());
//! let p = |x: f64| DisplayPose { position_m: DVec3::new(x, 0.0, 0.0), orientation: DQuat::IDENTITY, tool_m: DVec3::new(x, 0.0, 0.0) };
//! f.filter(0.0, p(0.0));
//! let out = f.filter(0.01, p(0.001)); // a 1 mm jitter is mostly smoothed away
//! assert!(out.position_m.x < 0.0005);
//! ```

use crate::calibration::DisplayPose;
use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

/// One Euro parameters for one quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OneEuroParams {
    /// Cutoff at rest, Hz (lower: steadier, more lag when slow).
    pub min_cutoff_hz: f64,
    /// Speed coefficient: cutoff grows by β per unit of speed (1/m or 1/rad).
    pub beta: f64,
    /// Cutoff for the speed estimate, Hz.
    pub d_cutoff_hz: f64,
    /// A gap longer than this (seconds) restarts the filter.
    pub reset_after_s: f64,
}

impl OneEuroParams {
    /// Defaults for positions in metres.
    pub const POSITION: Self = Self {
        min_cutoff_hz: 1.0,
        beta: 5.0,
        d_cutoff_hz: 1.0,
        reset_after_s: 0.5,
    };
    /// Defaults for orientations in radians.
    pub const ORIENTATION: Self = Self {
        min_cutoff_hz: 1.0,
        beta: 0.5,
        d_cutoff_hz: 1.0,
        reset_after_s: 0.5,
    };

    fn valid(&self) -> bool {
        [self.min_cutoff_hz, self.d_cutoff_hz, self.reset_after_s]
            .iter()
            .all(|v| v.is_finite() && *v > 0.0)
            && self.beta.is_finite()
            && self.beta >= 0.0
    }
}

impl Default for OneEuroParams {
    fn default() -> Self {
        Self::POSITION
    }
}

/// Filter settings for a device.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilterConfig {
    /// Whether to filter at all (off: poses pass through unchanged).
    pub enabled: bool,
    /// Position parameters (metres).
    pub position: OneEuroParams,
    /// Orientation parameters (radians).
    pub orientation: OneEuroParams,
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            position: OneEuroParams::POSITION,
            orientation: OneEuroParams::ORIENTATION,
        }
    }
}

impl FilterConfig {
    /// Checks that cutoffs are positive and β is non-negative.
    pub fn validate(&self) -> crate::Result<()> {
        if self.position.valid() && self.orientation.valid() {
            Ok(())
        } else {
            Err(crate::TrackingError::Config(crate::ConfigError::Filter))
        }
    }
}

fn alpha(cutoff_hz: f64, dt: f64) -> f64 {
    let tau = 1.0 / (std::f64::consts::TAU * cutoff_hz);
    1.0 / (1.0 + tau / dt)
}

#[derive(Debug, Clone, Copy)]
struct State {
    t: f64,
    pos: DVec3,
    vel: DVec3,
    rot: DQuat,
    ang_vel: DVec3,
}

/// A One Euro filter for one device's pose.
#[derive(Debug, Clone)]
pub struct PoseFilter {
    config: FilterConfig,
    state: Option<State>,
    last: Option<DisplayPose>,
}

impl PoseFilter {
    /// A fresh filter.
    pub fn new(config: FilterConfig) -> Self {
        Self {
            config,
            state: None,
            last: None,
        }
    }

    /// Forgets the history (after a loss: no smoothing across the gap).
    pub fn reset(&mut self) {
        self.state = None;
        self.last = None;
    }

    /// Filters the pose measured at `t` seconds. The tool point moves rigidly with the
    /// filtered pose (its offset from the marker is kept).
    pub fn filter(&mut self, t: f64, pose: DisplayPose) -> DisplayPose {
        if !self.config.enabled {
            return pose;
        }
        let (pp, po) = (self.config.position, self.config.orientation);
        let tip_in_body = pose.orientation.inverse() * (pose.tool_m - pose.position_m);
        let next = match self.state {
            Some(s) if t > s.t && t - s.t <= pp.reset_after_s.min(po.reset_after_s) => {
                let dt = t - s.t;
                // Position.
                let vel = s
                    .vel
                    .lerp((pose.position_m - s.pos) / dt, alpha(pp.d_cutoff_hz, dt));
                let fc = pp.min_cutoff_hz + pp.beta * vel.length();
                let pos = s.pos.lerp(pose.position_m, alpha(fc, dt));
                // Orientation: the rotation from the last estimate, as a rate.
                let mut q = pose.orientation;
                if q.dot(s.rot) < 0.0 {
                    q = -q;
                }
                let delta = (q * s.rot.inverse()).normalize().to_scaled_axis();
                let ang_vel = s.ang_vel.lerp(delta / dt, alpha(po.d_cutoff_hz, dt));
                let fc = po.min_cutoff_hz + po.beta * ang_vel.length();
                let rot = s.rot.slerp(q, alpha(fc, dt)).normalize();
                State {
                    t,
                    pos,
                    vel,
                    rot,
                    ang_vel,
                }
            }
            Some(s) if t <= s.t => {
                if let Some(last) = self.last {
                    return last;
                }
                s
            }
            _ => State {
                t,
                pos: pose.position_m,
                vel: DVec3::ZERO,
                rot: pose.orientation,
                ang_vel: DVec3::ZERO,
            },
        };
        let all_finite = next.pos.is_finite()
            && next.rot.is_finite()
            && next.vel.is_finite()
            && next.ang_vel.is_finite();
        let next = if all_finite {
            next
        } else {
            // Never output NaN: restart from the measurement.
            State {
                t,
                pos: pose.position_m,
                vel: DVec3::ZERO,
                rot: pose.orientation,
                ang_vel: DVec3::ZERO,
            }
        };
        self.state = Some(next);
        let out = DisplayPose {
            position_m: next.pos,
            orientation: next.rot,
            tool_m: next.pos + next.rot * tip_in_body,
        };
        self.last = Some(out);
        out
    }
}
