//! The tracker simulator: scripted, human-like wand and head motion as DTrack2 frames.
//!
//! A [`Script`] is a list of [`Step`]s on the wand's timeline (move to a point in D
//! seconds with a minimum-jerk profile, hold still, press, release, click a button,
//! occlude) plus head moves that run alongside. [`Simulator`] samples it at 60–300 Hz
//! (any rate in 1–2000 Hz is accepted), adds physiological tremor (8–12 Hz, a few
//! tenths of a millimetre), measurement noise and random dropouts, and yields
//! [`Frame`]s: the wand as a `6df2` Flystick (quality −1 while occluded, buttons still
//! reported) and the head as a `6d` body (missing while occluded). Everything is
//! deterministic for a given seed.
//!
//! Script positions are metres in the tracker frame (the simulator writes millimetres
//! on the wire), so with the default calibration they are metres in the display frame.
//!
//! ```
//! use tracking::sim::{Script, SimConfig, Simulator};
//! use glam::DVec3;
//! let script = Script::new(DVec3::new(0.0, 1.2, 0.3))
//!     .move_to(DVec3::new(0.2, 1.3, 0.1), 0.5)
//!     .hold(0.2)
//!     .click(0, 0.1)
//!     .mark("pointed and clicked");
//! let frames: Vec<_> = Simulator::new(&script, SimConfig::default()).unwrap().collect();
//! assert_eq!(frames.len(), (script.duration() * 120.0).round() as usize + 1);
//! let truth = script.timeline();
//! assert!(truth.wand_at(0.6).position_m.distance(DVec3::new(0.2, 1.3, 0.1)) < sculpt_core::tolerance::POINT_EPS);
//! ```

use crate::error::{Result, TrackingError};
use crate::frame::{Body, DeviceId, Frame, Pose, Wand};
use crate::poselog::{PoseLogHeader, PoseLogWriter};
use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::time::Duration;

/// A pose in metres (tracker axes) with a unit quaternion: the simulator's ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SimPose {
    /// Position in metres.
    pub position_m: DVec3,
    /// Orientation, `tracker_from_body`.
    pub orientation: DQuat,
}

impl SimPose {
    /// A pose at `position_m`, unrotated.
    pub fn at(position_m: DVec3) -> Self {
        Self {
            position_m,
            orientation: DQuat::IDENTITY,
        }
    }
}

/// One step of a script.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Step {
    /// Move the wand to `to` (metres) in `secs` with a minimum-jerk profile; the
    /// orientation (x, y, z, w) slerps along when given.
    Move {
        /// Target position, metres.
        to: [f64; 3],
        /// Target orientation quaternion `[x, y, z, w]`, if it changes.
        #[serde(default)]
        orientation: Option<[f64; 4]>,
        /// Duration in seconds.
        secs: f64,
    },
    /// Hold the wand still (tremor only) for `secs`: a pause.
    Hold {
        /// Duration in seconds.
        secs: f64,
    },
    /// Press button `button` now.
    Press {
        /// Button index (0 = trigger).
        button: u8,
    },
    /// Release button `button` now.
    Release {
        /// Button index.
        button: u8,
    },
    /// Press `button`, hold still `secs`, release.
    Click {
        /// Button index.
        button: u8,
        /// How long it stays down, seconds.
        secs: f64,
    },
    /// The wand is occluded (quality −1) from now for `secs`; time does not advance.
    OccludeWand {
        /// Duration in seconds.
        secs: f64,
    },
    /// The head target is occluded (missing) from now for `secs`; time does not advance.
    OccludeHead {
        /// Duration in seconds.
        secs: f64,
    },
    /// Move the head to `to` (metres) in `secs`, starting now, alongside the wand.
    HeadMove {
        /// Target position, metres.
        to: [f64; 3],
        /// Duration in seconds.
        secs: f64,
    },
    /// A labelled instant (e.g. a GOMS operator boundary); time does not advance.
    Mark {
        /// The label.
        label: String,
    },
}

/// A scripted session: start poses and steps. Serialisable (TOML/JSON) for the
/// `tracksim` binary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Script {
    /// Wand start position, metres.
    pub wand_start: [f64; 3],
    /// Wand start orientation `[x, y, z, w]`.
    #[serde(default = "identity_xyzw")]
    pub wand_orientation: [f64; 4],
    /// Head start position, metres.
    #[serde(default = "default_head")]
    pub head_start: [f64; 3],
    /// The steps, in order.
    #[serde(default, rename = "step")]
    pub steps: Vec<Step>,
}

fn identity_xyzw() -> [f64; 4] {
    [0.0, 0.0, 0.0, 1.0]
}

fn default_head() -> [f64; 3] {
    [0.0, 1.7, 0.6]
}

impl Script {
    /// A script starting with the wand at `wand_start` (metres, unrotated) and the head
    /// at (0, 1.7, 0.6).
    pub fn new(wand_start: DVec3) -> Self {
        Self {
            wand_start: wand_start.to_array(),
            wand_orientation: identity_xyzw(),
            head_start: default_head(),
            steps: Vec::new(),
        }
    }

    /// Sets the head's start position.
    pub fn head_start(mut self, p: DVec3) -> Self {
        self.head_start = p.to_array();
        self
    }

    /// Sets the wand's start orientation.
    pub fn wand_orientation(mut self, q: DQuat) -> Self {
        self.wand_orientation = q.normalize().to_array();
        self
    }

    /// Appends a step.
    pub fn step(mut self, step: Step) -> Self {
        self.steps.push(step);
        self
    }

    /// Moves the wand to `to` in `secs` (minimum jerk).
    pub fn move_to(self, to: DVec3, secs: f64) -> Self {
        self.step(Step::Move {
            to: to.to_array(),
            orientation: None,
            secs,
        })
    }

    /// Moves and turns the wand to a pose in `secs` (minimum jerk, slerp).
    pub fn move_to_pose(self, to: DVec3, orientation: DQuat, secs: f64) -> Self {
        self.step(Step::Move {
            to: to.to_array(),
            orientation: Some(orientation.normalize().to_array()),
            secs,
        })
    }

    /// Holds still for `secs`.
    pub fn hold(self, secs: f64) -> Self {
        self.step(Step::Hold { secs })
    }

    /// Presses a button.
    pub fn press(self, button: u8) -> Self {
        self.step(Step::Press { button })
    }

    /// Releases a button.
    pub fn release(self, button: u8) -> Self {
        self.step(Step::Release { button })
    }

    /// Presses, holds still `secs`, releases.
    pub fn click(self, button: u8, secs: f64) -> Self {
        self.step(Step::Click { button, secs })
    }

    /// Occludes the wand for `secs` from now.
    pub fn occlude_wand(self, secs: f64) -> Self {
        self.step(Step::OccludeWand { secs })
    }

    /// Occludes the head for `secs` from now.
    pub fn occlude_head(self, secs: f64) -> Self {
        self.step(Step::OccludeHead { secs })
    }

    /// Moves the head to `to` in `secs`, starting now.
    pub fn head_move_to(self, to: DVec3, secs: f64) -> Self {
        self.step(Step::HeadMove {
            to: to.to_array(),
            secs,
        })
    }

    /// Labels this instant.
    pub fn mark(self, label: impl Into<String>) -> Self {
        self.step(Step::Mark {
            label: label.into(),
        })
    }

    /// Checks durations, buttons and numbers.
    pub fn validate(&self) -> Result<()> {
        let bad = |s: String| Err(TrackingError::Sim(s));
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !finite(&self.wand_start) || !finite(&self.head_start) || !finite(&self.wand_orientation)
        {
            return bad("start poses must be finite".into());
        }
        for (i, s) in self.steps.iter().enumerate() {
            let (secs, button, nums): (Option<f64>, Option<u8>, Vec<f64>) = match s {
                Step::Move {
                    to,
                    orientation,
                    secs,
                } => {
                    let mut n = to.to_vec();
                    n.extend(orientation.iter().flatten());
                    (Some(*secs), None, n)
                }
                Step::Hold { secs } | Step::OccludeWand { secs } | Step::OccludeHead { secs } => {
                    (Some(*secs), None, vec![])
                }
                Step::Press { button } | Step::Release { button } => (None, Some(*button), vec![]),
                Step::Click { button, secs } => (Some(*secs), Some(*button), vec![]),
                Step::HeadMove { to, secs } => (Some(*secs), None, to.to_vec()),
                Step::Mark { .. } => (None, None, vec![]),
            };
            if secs.is_some_and(|d| !(d.is_finite() && (0.0..=86_400.0).contains(&d))) {
                return bad(format!("step {}: duration must be 0..=86400 s", i + 1));
            }
            if button.is_some_and(|b| b >= Wand::MAX_BUTTONS) {
                return bad(format!("step {}: button index must be < 64", i + 1));
            }
            if !finite(&nums) {
                return bad(format!("step {}: numbers must be finite", i + 1));
            }
        }
        Ok(())
    }

    /// Total duration of the wand timeline (and any head move or occlusion beyond it).
    pub fn duration(&self) -> f64 {
        self.timeline().duration
    }

    /// Compiles the steps into a ground-truth timeline.
    pub fn timeline(&self) -> Timeline {
        let q0 = DQuat::from_array(self.wand_orientation).normalize();
        let mut tl = Timeline {
            wand: vec![Segment::still(
                0.0,
                SimPose {
                    position_m: DVec3::from_array(self.wand_start),
                    orientation: q0,
                },
            )],
            head: vec![Segment::still(
                0.0,
                SimPose::at(DVec3::from_array(self.head_start)),
            )],
            buttons: Vec::new(),
            occlusions: Vec::new(),
            marks: Vec::new(),
            duration: 0.0,
        };
        let mut t = 0.0;
        let mut head_t = 0.0f64;
        let mut down = 0u64;
        for s in &self.steps {
            match s {
                Step::Move {
                    to,
                    orientation,
                    secs,
                } => {
                    let from = tl.wand_end();
                    let to = SimPose {
                        position_m: DVec3::from_array(*to),
                        orientation: orientation
                            .map_or(from.orientation, |q| DQuat::from_array(q).normalize()),
                    };
                    tl.wand.push(Segment {
                        t0: t,
                        t1: t + secs,
                        from,
                        to,
                    });
                    t += secs;
                }
                Step::Hold { secs } => t += secs,
                Step::Press { button } => {
                    down |= bit(*button);
                    tl.buttons.push(ButtonEdge {
                        time: t,
                        button: *button,
                        pressed: true,
                    });
                }
                Step::Release { button } => {
                    down &= !bit(*button);
                    tl.buttons.push(ButtonEdge {
                        time: t,
                        button: *button,
                        pressed: false,
                    });
                }
                Step::Click { button, secs } => {
                    tl.buttons.push(ButtonEdge {
                        time: t,
                        button: *button,
                        pressed: true,
                    });
                    t += secs;
                    if down & bit(*button) == 0 {
                        tl.buttons.push(ButtonEdge {
                            time: t,
                            button: *button,
                            pressed: false,
                        });
                    }
                }
                Step::OccludeWand { secs } => tl.occlusions.push(Occlusion {
                    device: DeviceId::Wand(0),
                    start: t,
                    end: t + secs,
                }),
                Step::OccludeHead { secs } => tl.occlusions.push(Occlusion {
                    device: DeviceId::Body(0),
                    start: t,
                    end: t + secs,
                }),
                Step::HeadMove { to, secs } => {
                    let start = t.max(head_t);
                    let from = tl.head.last().map_or(SimPose::at(DVec3::ZERO), |s| s.to);
                    tl.head.push(Segment {
                        t0: start,
                        t1: start + secs,
                        from,
                        to: SimPose::at(DVec3::from_array(*to)),
                    });
                    head_t = start + secs;
                }
                Step::Mark { label } => tl.marks.push((t, label.clone())),
            }
        }
        let occ_end = tl.occlusions.iter().map(|o| o.end).fold(0.0, f64::max);
        tl.duration = t.max(head_t).max(occ_end);
        tl
    }
}

/// A minimum-jerk move between two poses over `[t0, t1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Start time, seconds.
    pub t0: f64,
    /// End time, seconds.
    pub t1: f64,
    /// Pose at `t0`.
    pub from: SimPose,
    /// Pose at `t1` and after.
    pub to: SimPose,
}

impl Segment {
    fn still(t: f64, p: SimPose) -> Self {
        Self {
            t0: t,
            t1: t,
            from: p,
            to: p,
        }
    }

    /// The pose at time `t`: `from + (to − from)·s(τ)` with the minimum-jerk profile
    /// `s(τ) = 10τ³ − 15τ⁴ + 6τ⁵`, `τ = (t − t0)/(t1 − t0)` (Flash & Hogan 1985), and
    /// the orientation slerped by the same `s`.
    pub fn at(&self, t: f64) -> SimPose {
        let span = self.t1 - self.t0;
        let tau = if span > 0.0 {
            ((t - self.t0) / span).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let s = tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau));
        SimPose {
            position_m: self.from.position_m.lerp(self.to.position_m, s),
            orientation: self
                .from
                .orientation
                .slerp(self.to.orientation, s)
                .normalize(),
        }
    }
}

/// A button edge in a script.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ButtonEdge {
    /// Time, seconds.
    pub time: f64,
    /// Button index.
    pub button: u8,
    /// Pressed (true) or released.
    pub pressed: bool,
}

/// An interval during which a device is occluded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Occlusion {
    /// Which device (the configured ids are substituted when simulating).
    pub device: DeviceId,
    /// Start, seconds.
    pub start: f64,
    /// End, seconds.
    pub end: f64,
}

/// The ground truth of a script: noise-free poses, button edges, occlusions, marks.
#[derive(Debug, Clone, PartialEq)]
pub struct Timeline {
    /// Wand moves, in time order.
    pub wand: Vec<Segment>,
    /// Head moves, in time order.
    pub head: Vec<Segment>,
    /// Button edges, in time order.
    pub buttons: Vec<ButtonEdge>,
    /// Scripted occlusions (`Wand(0)` = the wand, `Body(0)` = the head).
    pub occlusions: Vec<Occlusion>,
    /// Labelled instants.
    pub marks: Vec<(f64, String)>,
    /// Total duration, seconds.
    pub duration: f64,
}

fn track_at(track: &[Segment], t: f64) -> SimPose {
    let i = track.partition_point(|s| s.t0 <= t);
    track[i.saturating_sub(1)].at(t)
}

impl Timeline {
    fn wand_end(&self) -> SimPose {
        self.wand.last().map_or(SimPose::at(DVec3::ZERO), |s| s.to)
    }

    /// The noise-free wand pose at `t` seconds.
    pub fn wand_at(&self, t: f64) -> SimPose {
        track_at(&self.wand, t)
    }

    /// The noise-free head pose at `t` seconds.
    pub fn head_at(&self, t: f64) -> SimPose {
        track_at(&self.head, t)
    }

    /// The button mask at `t` (edges at exactly `t` have happened).
    pub fn buttons_at(&self, t: f64) -> u64 {
        let mut mask = 0u64;
        for e in self.buttons.iter().take_while(|e| e.time <= t) {
            if e.pressed {
                mask |= bit(e.button);
            } else {
                mask &= !bit(e.button);
            }
        }
        mask
    }

    /// Whether the scripted occlusions hide `device` (`Wand(0)` or `Body(0)`) at `t`.
    pub fn occluded(&self, device: DeviceId, t: f64) -> bool {
        self.occlusions
            .iter()
            .any(|o| o.device == device && o.start <= t && t < o.end)
    }
}

/// Simulator settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SimConfig {
    /// Frame rate, Hz (real systems: 60–300).
    pub rate_hz: f64,
    /// Random seed: same seed, same session.
    pub seed: u64,
    /// Tremor amplitude per axis, millimetres (physiological: 0.1–0.5).
    pub tremor_mm: f64,
    /// Tremor frequency band, Hz.
    pub tremor_band_hz: [f64; 2],
    /// Measurement noise (standard deviation per axis), millimetres.
    pub noise_mm: f64,
    /// Orientation noise (standard deviation per axis), degrees.
    pub noise_deg: f64,
    /// Random dropouts of the wand: expected starts per second.
    pub dropouts_per_s: f64,
    /// Length of a random dropout, seconds.
    pub dropout_secs: f64,
    /// DTrack id of the wand (Flystick).
    pub wand_id: u32,
    /// DTrack id of the head body.
    pub head_id: u32,
    /// Whether to report the head at all.
    pub head: bool,
    /// Buttons the wand reports.
    pub button_count: u8,
    /// Analog axes the wand reports (held at 0).
    pub analog_count: usize,
    /// Counter of the first frame.
    pub first_frame: u64,
    /// Tracker timestamp of the first frame, seconds.
    pub ts_start: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            rate_hz: 120.0,
            seed: 1,
            tremor_mm: 0.2,
            tremor_band_hz: [8.0, 12.0],
            noise_mm: 0.05,
            noise_deg: 0.02,
            dropouts_per_s: 0.0,
            dropout_secs: 0.1,
            wand_id: 0,
            head_id: 0,
            head: true,
            button_count: 6,
            analog_count: 2,
            first_frame: 1,
            ts_start: 0.0,
        }
    }
}

impl SimConfig {
    /// A noise-free config (no tremor, noise or dropouts): frames match the script
    /// exactly, up to the wire's rounding.
    pub fn exact() -> Self {
        Self {
            tremor_mm: 0.0,
            noise_mm: 0.0,
            noise_deg: 0.0,
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<()> {
        let bad = |s: &str| Err(TrackingError::Sim(s.to_string()));
        if !(self.rate_hz.is_finite() && (1.0..=2000.0).contains(&self.rate_hz)) {
            return bad("rate_hz must be in 1..=2000");
        }
        let nonneg = [
            self.tremor_mm,
            self.noise_mm,
            self.noise_deg,
            self.dropouts_per_s,
            self.dropout_secs,
        ];
        if nonneg.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return bad("tremor, noise and dropout settings must be finite and >= 0");
        }
        let [lo, hi] = self.tremor_band_hz;
        if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo <= hi) {
            return bad("tremor_band_hz must be 0 < lo <= hi");
        }
        if self.button_count > Wand::MAX_BUTTONS || self.analog_count > Wand::MAX_ANALOG {
            return bad("too many buttons or analog axes");
        }
        Ok(())
    }
}

/// Tremor on one axis: two sinusoids in the tremor band with random phases.
#[derive(Debug, Clone, Copy)]
struct Tremor {
    f: [f64; 2],
    phase: [f64; 2],
}

impl Tremor {
    fn new(rng: &mut ChaCha8Rng, band: [f64; 2]) -> Self {
        let mut f = || {
            if band[1] > band[0] {
                rng.random_range(band[0]..band[1])
            } else {
                band[0]
            }
        };
        let f = [f(), f()];
        let phase = [
            rng.random_range(0.0..std::f64::consts::TAU),
            rng.random_range(0.0..std::f64::consts::TAU),
        ];
        Self { f, phase }
    }

    fn at(&self, t: f64, amp: f64) -> f64 {
        let tau = std::f64::consts::TAU;
        0.5 * amp
            * ((tau * self.f[0] * t + self.phase[0]).sin()
                + (tau * self.f[1] * t + self.phase[1]).sin())
    }
}

/// Samples a script into frames (an iterator).
#[derive(Debug, Clone)]
pub struct Simulator {
    timeline: Timeline,
    config: SimConfig,
    rng: ChaCha8Rng,
    tremor: [Tremor; 3],
    n: u64,
    count: u64,
    dropout_until: f64,
}

/// A standard normal sample (Box–Muller).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl Simulator {
    /// A simulator for `script`; errors on an invalid script or config.
    pub fn new(script: &Script, config: SimConfig) -> Result<Self> {
        script.validate()?;
        config.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        let tremor = [
            Tremor::new(&mut rng, config.tremor_band_hz),
            Tremor::new(&mut rng, config.tremor_band_hz),
            Tremor::new(&mut rng, config.tremor_band_hz),
        ];
        let timeline = script.timeline();
        let count = (timeline.duration * config.rate_hz).round() as u64 + 1;
        Ok(Self {
            timeline,
            config,
            rng,
            tremor,
            n: 0,
            count,
            dropout_until: -1.0,
        })
    }

    /// The ground truth being sampled.
    pub fn timeline(&self) -> &Timeline {
        &self.timeline
    }

    fn frame_at(&mut self, n: u64) -> Frame {
        let c = &self.config;
        let t = n as f64 / c.rate_hz;
        let mut frame = Frame::new(c.first_frame + n);
        frame.tracker_time = Some(c.ts_start + t);
        frame.receive_time = Duration::from_secs_f64(t);
        let c = self.config.clone();
        // Random dropouts: a Poisson process of starts.
        if c.dropouts_per_s > 0.0
            && t >= self.dropout_until
            && self.rng.random::<f64>() < c.dropouts_per_s / c.rate_hz
        {
            self.dropout_until = t + c.dropout_secs;
        }
        if c.head {
            let truth = self.timeline.head_at(t);
            let noisy = self.noisy(truth, t, 0.3);
            if !self.timeline.occluded(DeviceId::Body(0), t) {
                frame.calibrated_bodies = Some(1);
                frame.bodies.push(Body {
                    id: c.head_id,
                    quality: 1.0,
                    pose: noisy,
                });
            } else {
                frame.calibrated_bodies = Some(1);
            }
        }
        let truth = self.timeline.wand_at(t);
        let noisy = self.noisy(truth, t, 1.0);
        let occluded = self.timeline.occluded(DeviceId::Wand(0), t) || t < self.dropout_until;
        frame.calibrated_wands = Some(1);
        frame.wands.push(Wand {
            id: c.wand_id,
            quality: if occluded { -1.0 } else { 1.0 },
            pose: if occluded { Pose::ZERO } else { noisy },
            button_count: c.button_count,
            buttons: self.timeline.buttons_at(t) & mask(c.button_count),
            analog: vec![0.0; c.analog_count],
        });
        frame
    }

    /// Truth plus tremor (scaled by `tremor_scale`) and noise, in tracker mm.
    fn noisy(&mut self, truth: SimPose, t: f64, tremor_scale: f64) -> Pose {
        let c = &self.config;
        let amp = c.tremor_mm * tremor_scale;
        let tremor = DVec3::new(
            self.tremor[0].at(t, amp),
            self.tremor[1].at(t, amp),
            self.tremor[2].at(t, amp),
        );
        let (noise_mm, noise_rad) = (c.noise_mm, c.noise_deg.to_radians());
        let noise = DVec3::new(
            gauss(&mut self.rng),
            gauss(&mut self.rng),
            gauss(&mut self.rng),
        ) * noise_mm;
        let wobble = DVec3::new(
            gauss(&mut self.rng),
            gauss(&mut self.rng),
            gauss(&mut self.rng),
        ) * noise_rad;
        let q = (DQuat::from_scaled_axis(wobble) * truth.orientation).normalize();
        Pose::from_quat(truth.position_m * 1000.0 + tremor + noise, q)
    }

    /// Encodes the whole session as one DTrack2 ASCII byte stream.
    pub fn to_dtrack_bytes(self) -> Vec<u8> {
        let mut out = Vec::new();
        for f in self {
            crate::dtrack::encode_frame(&f, &mut out);
        }
        out
    }

    /// Writes the whole session as a pose log (receive time = simulated time).
    pub fn write_pose_log<W: Write>(self, w: W, header: &PoseLogHeader) -> Result<W> {
        let mut log = PoseLogWriter::new(w, header)?;
        for f in self {
            log.write_frame(&f)?;
        }
        Ok(log.into_inner())
    }
}

/// The mask bit of button `b` (none for an out-of-range index).
fn bit(b: u8) -> u64 {
    1u64.checked_shl(u32::from(b)).unwrap_or(0)
}

fn mask(n: u8) -> u64 {
    if n >= 64 { u64::MAX } else { (1u64 << n) - 1 }
}

impl Iterator for Simulator {
    type Item = Frame;

    fn next(&mut self) -> Option<Frame> {
        if self.n >= self.count {
            return None;
        }
        let f = self.frame_at(self.n);
        self.n += 1;
        Some(f)
    }
}
