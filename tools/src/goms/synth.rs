//! Synthetic sessions with known operators, for testing the extraction.
//!
//! A small scripted wand: minimum-jerk reaches `x(τ) = x0 + (x1 - x0)(10τ³ - 15τ⁴ + 6τ⁵)`
//! (Flash and Hogan 1985), optionally split into a primary movement to 92 % of the
//! distance, a 0.12 s dwell and a corrective sub-movement; still holds with physiological
//! tremor (9 Hz, 0.3 mm) and tracker noise (Gaussian, σ 0.2 mm); button presses and
//! drags; a tracking dropout. Sampled at 90 Hz, written with
//! [`sculpt_core::oplog::OpLogWriter`] and decoded back, so the codec is in the loop.
//!
//! **How the test knows the truth**: the script counts and times as it writes. Each
//! scripted press or drag is one K of `min(hold, K_WINDOW)` seconds; each scripted reach
//! (with its corrective sub-movement) or drag is one P, timed from its first to its last
//! moving sample (a drag's P starts after its press window); each still interval of at least [`LONG_PAUSE`] s that is followed by a
//! press, reach or drag is one M. Scripted still intervals are either at least
//! [`LONG_PAUSE`] (1.4 s) or at most [`SHORT_PAUSE`] (0.6 s), clear of the default
//! 1.0 s M threshold, so the truth does not hinge on the smoothing's edges.
//!
//! `sculpt-tools goms study simulate` uses it to fill a planned study with synthetic
//! sessions, to try the whole pipeline without hardware.

use glam::{DQuat, DVec3};
use sculpt_core::oplog::{EventKind, OpLogHeader, OpLogWriter, TrackingState};

/// Shortest scripted pause that is an M.
pub const LONG_PAUSE: f64 = 1.4;
/// Longest scripted pause that is not.
pub const SHORT_PAUSE: f64 = 0.6;
const RATE: f64 = 90.0;

/// The keystroke window of a press (the extraction's default `k_window_s`).
pub const K_WINDOW: f64 = 0.2;

/// Operator counts and times the script knows.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Truth {
    /// K.
    pub k: usize,
    /// P.
    pub p: usize,
    /// M.
    pub m: usize,
    /// Seconds of K: each press's window, `min(hold, K_WINDOW)`.
    pub k_time: f64,
    /// Seconds of P: each reach from its first to its last moving sample (the corrective
    /// dwell included); each drag's sweep after its press window.
    pub p_time: f64,
}

/// The scripted wand.
pub struct Script {
    w: OpLogWriter,
    rng: fastrand::Rng,
    t: f64,
    pos: DVec3,
    phase: [f64; 3],
    still: f64,
    /// The truth so far.
    pub truth: Truth,
}

impl Script {
    /// A script starting at rest at `start`, writing a log with `header`.
    pub fn new(seed: u64, start: DVec3, header: &OpLogHeader) -> Self {
        let mut rng = fastrand::Rng::with_seed(seed);
        let phase = [rng.f64() * 6.3, rng.f64() * 6.3, rng.f64() * 6.3];
        Self {
            w: OpLogWriter::new(header),
            rng,
            t: 0.0,
            pos: start,
            phase,
            still: 0.0,
            truth: Truth::default(),
        }
    }

    fn gauss(&mut self) -> f64 {
        // Box-Muller.
        let u1 = self.rng.f64().max(crate::tolerance::LOG_ARG_MIN);
        let u2 = self.rng.f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    fn sample(&mut self, ideal: DVec3) {
        let tremor = DVec3::new(
            (std::f64::consts::TAU * 9.0 * self.t + self.phase[0]).sin(),
            (std::f64::consts::TAU * 9.0 * self.t + self.phase[1]).sin(),
            (std::f64::consts::TAU * 9.0 * self.t + self.phase[2]).sin(),
        ) * 0.0003;
        let noise = DVec3::new(self.gauss(), self.gauss(), self.gauss()) * 0.0002;
        let p = ideal + tremor + noise;
        let q = DQuat::from_rotation_y(0.8 * ideal.x) * DQuat::from_rotation_x(0.5 * ideal.y);
        self.w
            .push(self.t, EventKind::Pose { p, q })
            .expect("scripted poses are valid");
        self.t += 1.0 / RATE;
    }

    fn begin_operator(&mut self) {
        if self.still >= LONG_PAUSE {
            self.truth.m += 1;
        }
        self.still = 0.0;
    }

    /// Holds still for `d` seconds.
    pub fn pause(&mut self, d: f64) {
        let end = self.t + d;
        while self.t < end {
            self.sample(self.pos);
        }
        self.still += d;
    }

    /// Holds still with a tracking dropout of `d` seconds in the middle.
    pub fn pause_with_dropout(&mut self, before: f64, d: f64, after: f64) {
        self.pause(before);
        self.w
            .push(
                self.t,
                EventKind::Tracking {
                    state: TrackingState::Lost,
                },
            )
            .expect("valid");
        self.t += d;
        self.w
            .push(
                self.t,
                EventKind::Tracking {
                    state: TrackingState::Tracked,
                },
            )
            .expect("valid");
        // The wand drifted during the dropout: a jump that must not read as a movement.
        self.pos += DVec3::new(0.05, 0.0, 0.0);
        self.still += d;
        self.pause(after);
    }

    fn min_jerk(&mut self, to: DVec3, dur: f64) {
        let from = self.pos;
        let n = (dur * RATE).ceil() as usize;
        for i in 0..n {
            let tau = i as f64 / n as f64;
            let s = tau.powi(3) * (10.0 - 15.0 * tau + 6.0 * tau * tau);
            self.sample(from + (to - from) * s);
        }
        self.pos = to;
    }

    /// Reaches `to` in `dur` seconds; with `corrective`, as a primary movement and a
    /// corrective sub-movement. One P.
    pub fn reach(&mut self, to: DVec3, dur: f64, corrective: bool) {
        self.begin_operator();
        self.truth.p += 1;
        let start = self.t;
        if corrective {
            let primary = self.pos + (to - self.pos) * 0.92;
            self.min_jerk(primary, dur);
            let end = self.t + 0.12;
            while self.t < end {
                self.sample(self.pos);
            }
            self.min_jerk(to, 0.3);
        } else {
            self.min_jerk(to, dur);
        }
        self.truth.p_time += self.t - start;
    }

    /// Presses button 0 for `hold` seconds. One K.
    pub fn press(&mut self, hold: f64) {
        self.begin_operator();
        self.truth.k += 1;
        self.w
            .push(self.t, EventKind::Button { id: 0, down: true })
            .expect("valid");
        let (pressed, end) = (self.t, self.t + hold);
        while self.t < end {
            self.sample(self.pos);
        }
        self.truth.k_time += (self.t - pressed).min(K_WINDOW);
        self.w
            .push(self.t, EventKind::Button { id: 0, down: false })
            .expect("valid");
    }

    /// Presses, sweeps a stroke to `to`, releases. One K (the press window) and one P
    /// (the sweep after it): the stroke's press, P, release.
    pub fn drag(&mut self, to: DVec3, dur: f64) {
        self.begin_operator();
        self.truth.k += 1;
        self.truth.p += 1;
        self.w
            .push(self.t, EventKind::Button { id: 0, down: true })
            .expect("valid");
        let pressed = self.t;
        self.pause(0.1);
        self.min_jerk(to, dur);
        self.truth.k_time += K_WINDOW;
        self.truth.p_time += self.t - (pressed + K_WINDOW);
        self.pause(0.1);
        self.w
            .push(self.t, EventKind::Button { id: 0, down: false })
            .expect("valid");
        self.still = 0.0;
    }

    /// Writes a trial boundary.
    pub fn trial(&mut self, trial: u32, start: bool) {
        let kind = if start {
            EventKind::TrialStart {
                trial,
                task: None,
                method: None,
            }
        } else {
            EventKind::TrialEnd { trial }
        };
        self.w.push(self.t, kind).expect("valid");
        self.still = 0.0;
    }

    /// The log text.
    pub fn finish(mut self) -> (Vec<u8>, Truth) {
        (self.w.take(), self.truth)
    }
}

/// Appends `steps` random actions (reaches, clicks, drags, pauses, dropouts) chosen
/// from `seed`, starting and ending with a long pause.
pub fn random_steps(s: &mut Script, seed: u64, steps: usize) {
    let mut rng = fastrand::Rng::with_seed(seed ^ 0xabcdef);
    let mut target = || {
        DVec3::new(
            -0.3 + 0.6 * rng.f64(),
            0.9 + 0.6 * rng.f64(),
            -0.6 + 0.4 * rng.f64(),
        )
    };
    let mut choose = fastrand::Rng::with_seed(seed.wrapping_mul(31) + 7);
    s.pause(LONG_PAUSE + 0.3 * choose.f64());
    for _ in 0..steps {
        let mut to = target();
        // Keep reaches long enough to be pointing movements.
        while to.distance(s.pos) < 0.12 {
            to = target();
        }
        match choose.usize(0..4) {
            0 => {
                s.reach(to, 0.45 + 0.4 * choose.f64(), choose.bool());
                s.pause(0.1 + 0.4 * choose.f64());
                s.press(0.08 + 0.1 * choose.f64());
            }
            1 => s.drag(to, 0.6 + 0.4 * choose.f64()),
            2 => s.press(0.1),
            _ => {
                s.reach(to, 0.5 + 0.3 * choose.f64(), true);
                s.pause(0.15);
                s.press(0.1);
            }
        }
        match choose.usize(0..3) {
            0 => s.pause(LONG_PAUSE + choose.f64()),
            1 => s.pause(0.15 + (SHORT_PAUSE - 0.15) * choose.f64()),
            _ => s.pause_with_dropout(0.6, 0.3, 0.9),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::goms::extract::{ExtractConfig, KMode, OpKind, extract};
    use sculpt_core::oplog;

    fn header(seed: u64) -> OpLogHeader {
        OpLogHeader::new()
            .with_participant(format!("S{seed}"))
            .with_method("synthetic")
            .with_source("synthetic")
    }

    /// A random one-trial session of `steps` actions.
    pub fn random_session(seed: u64, steps: usize) -> (Vec<u8>, Truth) {
        let mut s = Script::new(seed, DVec3::new(0.0, 1.2, -0.4), &header(seed));
        random_steps(&mut s, seed, steps);
        s.finish()
    }

    #[test]
    fn synthetic_sessions_give_back_their_operators() {
        let cfg = ExtractConfig::default();
        for seed in 1..=12u64 {
            let (bytes, truth) = random_session(seed, 14);
            let log = oplog::decode_bytes(&bytes).unwrap();
            let trials = extract(&log, &cfg, "", "");
            assert_eq!(trials.len(), 1);
            let t = &trials[0];
            let (k, p, m) = (t.count(OpKind::K), t.count(OpKind::P), t.count(OpKind::M));
            eprintln!(
                "seed {seed}: K {k}/{} P {p}/{} M {m}/{} (found/truth)",
                truth.k, truth.p, truth.m
            );
            assert_eq!(k, truth.k, "seed {seed}: K exact");
            // Every second of the trial is in exactly one operator.
            t.check_tiling().unwrap();
            let sum: f64 = t.ops.iter().map(|o| o.duration()).sum();
            sculpt_core::assert_near!(sum, t.duration(), sculpt_core::tolerance::TIME_EPS);
            sculpt_core::assert_near!(
                t.time(OpKind::K),
                truth.k_time,
                sculpt_core::tolerance::TIME_EPS
            );
            // Onset and offset detection of a minimum-jerk reach, per P.
            assert_eq!(K_WINDOW, ExtractConfig::default().k_window_s);
            let per_p_s = 0.1;
            let p_time = t.time(OpKind::P);
            eprintln!("seed {seed}: P time {p_time:.3} / {:.3} s", truth.p_time);
            assert!(
                (p_time - truth.p_time).abs() <= per_p_s * truth.p as f64,
                "seed {seed}: P time {p_time} vs truth {}",
                truth.p_time
            );
            assert!(
                p.abs_diff(truth.p) <= 1,
                "seed {seed}: P {p} vs truth {}",
                truth.p
            );
            assert!(
                m.abs_diff(truth.m) <= 1,
                "seed {seed}: M {m} vs truth {}",
                truth.m
            );
        }
    }

    #[test]
    fn corrective_submovements_stay_in_one_p() {
        let mut s = Script::new(3, DVec3::new(0.0, 1.2, -0.4), &header(3));
        s.pause(0.5);
        s.reach(DVec3::new(0.3, 1.3, -0.5), 0.6, true);
        s.pause(0.2);
        s.press(0.1);
        s.pause(0.5);
        let (bytes, truth) = s.finish();
        let t = &extract(
            &oplog::decode_bytes(&bytes).unwrap(),
            &ExtractConfig::default(),
            "",
            "",
        )[0];
        // Two sub-movements, one P.
        assert_eq!(t.movements.len(), 2, "{:?}", t.movements);
        assert_eq!((t.count(OpKind::P), truth.p), (1, 1));
        assert_eq!(t.count(OpKind::M), 0);
    }

    #[test]
    fn b_plus_b_doubles_the_button_operators() {
        let (bytes, truth) = random_session(5, 8);
        let log = oplog::decode_bytes(&bytes).unwrap();
        let cfg = ExtractConfig {
            k_mode: KMode::Bb,
            ..Default::default()
        };
        let t = &extract(&log, &cfg, "", "")[0];
        assert_eq!(t.count(OpKind::B), 2 * truth.k);
        assert_eq!(t.count(OpKind::K), 0);
    }
}
