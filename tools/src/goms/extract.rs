//! Operator extraction: from an operator event log to timed P, K (or B), and M
//! operators, trial by trial.
//!
//! 1. **Trials**: `trial_start`/`trial_end` events cut the log; without them the whole
//!    log is one trial (numbered by the header's `trial`, else 1).
//! 2. **Speed**: the wand speed at each pose sample is the central difference
//!    `|p[i+1] - p[i-1]| / (t[i+1] - t[i-1])`, smoothed by a Gaussian kernel of
//!    `smooth_sigma_s` seconds (weights `exp(-Δt²/2σ²)` over ±3σ). Samples more than
//!    `gap_s` apart, or across a `tracking: lost` event, start a new run; nothing is
//!    smoothed or differenced across runs.
//! 3. **Sub-movements** (dual threshold, hysteresis): a movement starts when the smoothed
//!    speed rises above `v_on`; its onset is moved back to the last sample below `v_off`;
//!    it ends when the speed falls below `v_off`. A button edge inside a movement splits it.
//! 4. **P**: consecutive sub-movements belong to one pointing operator (corrective
//!    sub-movements) until a button edge (the selection) or a still gap of `m_pause_s`
//!    or more. A P whose wand never moves `min_amplitude` from its start point is dropped.
//!    Movement with a button held (a stroke) is a P of its own: a drag is press, P,
//!    release (KLM's B-down P B-up).
//! 5. **K** is the press itself, not the hold: each press owns the window
//!    `[press, press + k_window_s]` (default 0.2 s, KLM's K for a skilled typist), cut
//!    short by its release or the next press (`k_mode = k`). With `k_mode = bb` each
//!    press and each release owns a B window of `k_window_s / 2` (KLM's B, 0.1 s).
//!    A P that starts inside a button window starts at its end.
//! 6. **M and R**: time between operators while a button is still held is R (holding
//!    still); the rest of the gap is an M when it lasts at least `m_pause_s` and ends at
//!    the next operator, otherwise R too (system response or waiting: short pauses, the
//!    end of the trial).
//! 7. **Fitts**: per P, the amplitude A (start to the target centre when the log has a
//!    `target` event during the P, else start to the selection point), the width W
//!    (the target's, else `default_width`), the Shannon index of difficulty
//!    `ID = log2(A/W + 1)`, and the angular version: the angle α between the wand ray
//!    (wand -Z) at the start and the ray to the target (or at the end), the angular
//!    width `ω = 2 atan(W / 2D)` with D the distance to the target, `ID_a = log2(α/ω + 1)`.
//!
//! Every instant of a trial belongs to exactly one operator, so the operator times of a
//! trial sum to its length `t1 - t0` ([`Trial::duration`]).

use glam::{DQuat, DVec3};
use sculpt_core::oplog::{EventKind, OpLog, TrackingState};

/// An operator kind found in data or tallies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum OpKind {
    /// Pointing.
    P,
    /// Key or button press (the press itself, see the module docs).
    K,
    /// Button press or release alone.
    B,
    /// Mental preparation.
    M,
    /// Homing.
    H,
    /// System response time or waiting: trial time no other operator accounts for
    /// (a button held still, short pauses, the end of a trial).
    R,
}

impl OpKind {
    /// All kinds in display order.
    pub const ALL: [OpKind; 6] = [
        OpKind::P,
        OpKind::K,
        OpKind::B,
        OpKind::M,
        OpKind::H,
        OpKind::R,
    ];

    /// The letter.
    pub fn letter(self) -> &'static str {
        match self {
            OpKind::P => "P",
            OpKind::K => "K",
            OpKind::B => "B",
            OpKind::M => "M",
            OpKind::H => "H",
            OpKind::R => "R",
        }
    }

    /// Whether an operator of this kind counts in the operation counts (Table 1). R is
    /// time the other operators leave (waiting, holding still): it has seconds, no count.
    pub fn counts_as_operation(self) -> bool {
        self != OpKind::R
    }

    /// Parses a letter.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|k| k.letter().eq_ignore_ascii_case(s.trim()))
    }
}

/// How a button press/release pair counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum KMode {
    /// Each press is one K (a click or a drag's press; the release is part of it).
    K,
    /// Each press and each release is one B (KLM's mouse-button operator).
    Bb,
}

/// Extraction thresholds; [`Default`] gives the documented defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractConfig {
    /// Gaussian smoothing of the speed, seconds (0 = none). Default 0.025.
    pub smooth_sigma_s: f64,
    /// Movement onset speed, m/s. Default 0.10.
    pub v_on: f64,
    /// Movement offset speed, m/s (at most `v_on`). Default 0.04.
    pub v_off: f64,
    /// Smallest excursion from its start for a P, metres. Default 0.02.
    pub min_amplitude: f64,
    /// Shortest pause that is an M, seconds; also the longest still gap inside one P.
    /// Default 1.0.
    pub m_pause_s: f64,
    /// Pose samples further apart than this start a new run, seconds. Default 0.1.
    pub gap_s: f64,
    /// K or B+B. Default K.
    pub k_mode: KMode,
    /// Length of the keystroke window a press owns (K), seconds; each B owns half of
    /// it. Default 0.2 (KLM: K 0.08 to 1.2 s, 0.2 s for a skilled typist; B 0.1 s).
    pub k_window_s: f64,
    /// Target width when the log names no target, metres. Default none.
    pub default_width: Option<f64>,
}

impl Default for ExtractConfig {
    fn default() -> Self {
        Self {
            smooth_sigma_s: 0.025,
            v_on: 0.10,
            v_off: 0.04,
            min_amplitude: 0.02,
            m_pause_s: 1.0,
            gap_s: 0.1,
            k_mode: KMode::K,
            k_window_s: 0.2,
            default_width: None,
        }
    }
}

impl ExtractConfig {
    /// Checks the thresholds; the reason when they make no sense.
    pub fn validate(&self) -> Result<(), String> {
        let finite_nonneg = |v: f64, name: &str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a finite number >= 0, got {v}"))
            }
        };
        finite_nonneg(self.smooth_sigma_s, "smooth-sigma")?;
        finite_nonneg(self.v_on, "v-on")?;
        finite_nonneg(self.v_off, "v-off")?;
        finite_nonneg(self.min_amplitude, "min-amplitude")?;
        finite_nonneg(self.m_pause_s, "m-pause")?;
        finite_nonneg(self.gap_s, "gap")?;
        finite_nonneg(self.k_window_s, "k-window")?;
        if self.v_off > self.v_on {
            return Err(format!(
                "v-off ({}) must not exceed v-on ({})",
                self.v_off, self.v_on
            ));
        }
        if self.gap_s <= 0.0 {
            return Err("gap must be > 0".into());
        }
        if let Some(w) = self.default_width
            && !(w.is_finite() && w > 0.0)
        {
            return Err(format!("default-width must be > 0, got {w}"));
        }
        Ok(())
    }
}

/// Fitts' law measures of one P.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitts {
    /// Amplitude, metres.
    pub amplitude: f64,
    /// Target width, metres, when known.
    pub width: Option<f64>,
    /// Shannon index of difficulty, bits, when the width is known.
    pub id: Option<f64>,
    /// Angular amplitude, radians.
    pub amplitude_rad: f64,
    /// Angular target width, radians, when known.
    pub width_rad: Option<f64>,
    /// Angular index of difficulty, bits.
    pub id_angular: Option<f64>,
}

/// One timed operator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Operator {
    /// Kind.
    pub op: OpKind,
    /// Start, seconds from the session start.
    pub t_start: f64,
    /// End, seconds.
    pub t_end: f64,
    /// Fitts measures (P only).
    pub fitts: Option<Fitts>,
}

impl Operator {
    /// `t_end - t_start`.
    pub fn duration(&self) -> f64 {
        self.t_end - self.t_start
    }
}

/// The operators of one trial, with the speed trace they were found in.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// Participant id.
    pub participant: String,
    /// Method id.
    pub method: String,
    /// Trial number.
    pub trial: u32,
    /// Task name, when the trial names one.
    pub task: Option<String>,
    /// Trial start, seconds.
    pub t0: f64,
    /// Trial end, seconds.
    pub t1: f64,
    /// Operators ordered by start.
    pub ops: Vec<Operator>,
    /// Smoothed speed `(t, m/s)` per pose sample.
    pub speed: Vec<(f64, f64)>,
    /// Sub-movements `(onset, offset)` before grouping into P.
    pub movements: Vec<(f64, f64)>,
}

impl Trial {
    /// The trial's length, `t1 - t0` seconds: the sum of its operator times.
    pub fn duration(&self) -> f64 {
        self.t1 - self.t0
    }

    /// Checks that the operators tile `[t0, t1]`: ordered, each starting where the one
    /// before ends, none empty (except a K or B cut to nothing by the trial end), the first at `t0` and the last ending at `t1`. The reason
    /// when they do not.
    pub fn check_tiling(&self) -> Result<(), String> {
        let mut cursor = self.t0;
        for o in &self.ops {
            if o.t_start != cursor {
                return Err(format!(
                    "{} at {:.6} s does not start where the time before it ends ({:.6} s)",
                    o.op.letter(),
                    o.t_start,
                    cursor
                ));
            }
            let button = matches!(o.op, OpKind::K | OpKind::B);
            if o.t_end < o.t_start || (o.t_end == o.t_start && !button) {
                return Err(format!("empty {} at {:.6} s", o.op.letter(), o.t_start));
            }
            cursor = o.t_end;
        }
        if cursor != self.t1 {
            return Err(format!(
                "operators end at {cursor:.6} s, the trial at {:.6} s",
                self.t1
            ));
        }
        Ok(())
    }

    /// Seconds in operators of a kind.
    #[cfg(test)]
    pub fn time(&self, op: OpKind) -> f64 {
        self.ops
            .iter()
            .filter(|o| o.op == op)
            .map(Operator::duration)
            .sum()
    }

    /// Number of operators of a kind.
    pub fn count(&self, op: OpKind) -> usize {
        self.ops.iter().filter(|o| o.op == op).count()
    }
}

struct Sample {
    t: f64,
    p: DVec3,
    q: DQuat,
    run: usize,
}

/// Extracts the operators of every trial of a log. `participant` and `method` name the
/// session when the header does not.
pub fn extract(log: &OpLog, cfg: &ExtractConfig, participant: &str, method: &str) -> Vec<Trial> {
    let participant = log.header.participant.as_deref().unwrap_or(participant);
    let method = log.header.method.as_deref().unwrap_or(method);
    let ev = &log.events;
    // Trial ranges over event indices.
    // (trial, task, method of the trial when it names one, first and end index)
    type Range = (u32, Option<String>, Option<String>, usize);
    let mut ranges: Vec<(Range, usize)> = Vec::new();
    let mut open: Option<Range> = None;
    for (i, e) in ev.iter().enumerate() {
        match &e.kind {
            EventKind::TrialStart {
                trial,
                task,
                method,
            } => {
                if let Some(r) = open.take() {
                    ranges.push((r, i));
                }
                open = Some((*trial, task.clone(), method.clone(), i));
            }
            EventKind::TrialEnd { .. } => {
                if let Some(r) = open.take() {
                    ranges.push((r, i + 1));
                }
            }
            _ => {}
        }
    }
    if let Some(r) = open {
        ranges.push((r, ev.len()));
    }
    if ranges.is_empty() && !ev.is_empty() {
        ranges.push(((log.header.trial.unwrap_or(1), None, None, 0), ev.len()));
    }
    ranges
        .into_iter()
        .map(|((n, task, trial_method, s), e)| {
            let mut trial = extract_range(&ev[s..e], cfg);
            trial.participant = participant.to_owned();
            // A trial that names its method (a segment after a mode switch) is that
            // method's; the others are the header's.
            trial.method = trial_method.unwrap_or_else(|| method.to_owned());
            trial.trial = n;
            trial.task = task;
            trial
        })
        .collect()
}

fn extract_range(ev: &[sculpt_core::oplog::OpEvent], cfg: &ExtractConfig) -> Trial {
    let t0 = ev.first().map_or(0.0, |e| e.t);
    let t1 = ev.last().map_or(0.0, |e| e.t);
    // Pose samples in runs.
    let mut samples: Vec<Sample> = Vec::new();
    let mut run = 0;
    let mut lost = false;
    let mut edges: Vec<(f64, u8, bool)> = Vec::new();
    let mut keys: Vec<f64> = Vec::new();
    let mut targets: Vec<(f64, DVec3, f64)> = Vec::new();
    for e in ev {
        match &e.kind {
            EventKind::Pose { p, q } => {
                if let Some(last) = samples.last()
                    && (lost || e.t - last.t > cfg.gap_s)
                {
                    run += 1;
                }
                lost = false;
                samples.push(Sample {
                    t: e.t,
                    p: *p,
                    q: *q,
                    run,
                });
            }
            EventKind::Tracking {
                state: TrackingState::Lost,
            } => lost = true,
            EventKind::Button { id, down } => edges.push((e.t, *id, *down)),
            EventKind::Key { .. } => keys.push(e.t),
            EventKind::Target { p, width, .. } => targets.push((e.t, *p, *width)),
            _ => {}
        }
    }
    let speed = smoothed_speed(&samples, cfg.smooth_sigma_s);
    // Key presses split movements and end pointing as button edges do.
    let mut edge_times: Vec<f64> = edges
        .iter()
        .map(|e| e.0)
        .chain(keys.iter().copied())
        .collect();
    edge_times.sort_by(f64::total_cmp);
    let movements = split_at(&segment(&samples, &speed, cfg), &edge_times);

    // Button operators: each press (K mode) or each edge (B+B mode) owns a short fixed
    // window from its edge, the KLM keystroke itself; the rest of a hold is not K.
    let mut presses: Vec<(f64, f64)> = Vec::new();
    let mut held: Vec<(u8, f64)> = Vec::new();
    for &(t, id, down) in &edges {
        let pos = held.iter().position(|h| h.0 == id);
        match (down, pos) {
            (true, Some(i)) => {
                // A second press without a release: the first ends at this press.
                presses.push((held[i].1, t));
                held[i].1 = t;
            }
            (true, None) => held.push((id, t)),
            (false, Some(i)) => presses.push((held.swap_remove(i).1, t)),
            (false, None) => {}
        }
    }
    presses.extend(held.iter().map(|h| (h.1, t1)));
    // A desktop key is a keystroke (K in either mode): its press owns the window.
    let key_presses: Vec<(f64, f64)> = keys.iter().map(|&t| (t, t + cfg.k_window_s)).collect();
    presses.extend(&key_presses);
    presses.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut buttons: Vec<Operator> = match cfg.k_mode {
        KMode::K => presses
            .iter()
            .map(|&(s, e)| Operator {
                op: OpKind::K,
                t_start: s,
                t_end: e.min(s + cfg.k_window_s),
                fitts: None,
            })
            .collect(),
        KMode::Bb => edges
            .iter()
            .map(|&(t, _, _)| Operator {
                op: OpKind::B,
                t_start: t,
                t_end: t + 0.5 * cfg.k_window_s,
                fitts: None,
            })
            .chain(key_presses.iter().map(|&(s, e)| Operator {
                op: OpKind::K,
                t_start: s,
                t_end: e,
                fitts: None,
            }))
            .collect(),
    };
    buttons.sort_by(|a, b| a.t_start.total_cmp(&b.t_start));
    // A window ends at the next button operator and at the trial end.
    for i in 0..buttons.len() {
        let next = buttons.get(i + 1).map_or(t1, |b| b.t_start);
        buttons[i].t_end = buttons[i].t_end.min(next).min(t1);
    }

    // Group sub-movements into P operators.
    let mut groups: Vec<(f64, f64)> = Vec::new();
    for &(s, e) in &movements {
        if let Some(g) = groups.last_mut() {
            let selection_between = edge_times.iter().any(|&t| t >= g.1 && t <= s);
            if !selection_between && s - g.1 < cfg.m_pause_s {
                g.1 = e;
                continue;
            }
        }
        groups.push((s, e));
    }
    let mut ops: Vec<Operator> = Vec::new();
    for (s, e) in groups {
        let i0 = sample_at(&samples, s);
        let Some(start) = i0.map(|i| &samples[i]) else {
            continue;
        };
        let extent = samples
            .iter()
            .filter(|x| x.t >= s && x.t <= e)
            .map(|x| x.p.distance(start.p))
            .fold(0.0, f64::max);
        if extent < cfg.min_amplitude {
            continue;
        }
        let selection = edges
            .iter()
            .find(|x| x.2 && x.0 >= e && x.0 - e < cfg.m_pause_s)
            .map_or(e, |x| x.0);
        let end = sample_at(&samples, selection).map_or(start, |i| &samples[i]);
        let target = targets
            .iter()
            .rev()
            .find(|t| t.0 >= s && t.0 <= selection)
            .copied();
        // The button windows take precedence: a P starting inside one starts at its end,
        // a P running into one ends at its start. Movements never contain a button edge
        // (they are split there), so a window cannot cut a P in two.
        let (mut ps, mut pe) = (s.max(t0), e.min(t1));
        for b in &buttons {
            if b.t_start <= ps && b.t_end > ps {
                ps = b.t_end;
            }
            if b.t_start > ps && b.t_start < pe {
                pe = b.t_start;
            }
        }
        if pe > ps {
            ops.push(Operator {
                op: OpKind::P,
                t_start: ps,
                t_end: pe,
                fitts: Some(fitts(start, end, target, cfg.default_width)),
            });
        }
    }
    ops.extend(buttons);
    ops.sort_by(|a, b| a.t_start.total_cmp(&b.t_start));
    // Consecutive P groups are disjoint; fix any overlap left by the onset moved back
    // into the previous P's tail (the earlier operator keeps its time).
    for i in 1..ops.len() {
        let prev_end = ops[i - 1].t_end;
        if ops[i].t_start < prev_end {
            ops[i].t_start = prev_end.min(ops[i].t_end);
        }
    }
    // A button operator cut to nothing (a release at the trial end, two presses at one
    // instant) still counts; an empty P does not.
    ops.retain(|o| o.t_end > o.t_start || matches!(o.op, OpKind::K | OpKind::B));
    // The time between operators: while a button is still held it is R (holding); the
    // rest is an M when it is a pause of at least `m_pause_s` that ends at an operator,
    // else R (waiting, short pauses, the end of the trial). Together the operators tile
    // [t0, t1] exactly.
    let mut fill = Vec::new();
    let mut cursor = t0;
    for o in ops.iter().map(Some).chain([None]) {
        let end = o.map_or(t1, |o| o.t_start);
        if end > cursor {
            // Presses start operators, so a hold overlapping this gap began before it.
            let free = presses
                .iter()
                .filter(|&&(s, e)| s < end && e > cursor)
                .map(|&(_, e)| e)
                .fold(cursor, f64::max)
                .min(end);
            let mental = o.is_some() && end - free >= cfg.m_pause_s;
            let split = if mental { free } else { end };
            if split > cursor {
                fill.push(Operator {
                    op: OpKind::R,
                    t_start: cursor,
                    t_end: split,
                    fitts: None,
                });
            }
            if mental {
                fill.push(Operator {
                    op: OpKind::M,
                    t_start: free,
                    t_end: end,
                    fitts: None,
                });
            }
        }
        if let Some(o) = o {
            cursor = o.t_end;
        }
    }
    ops.extend(fill);
    ops.sort_by(|a, b| a.t_start.total_cmp(&b.t_start).then(a.op.cmp(&b.op)));
    Trial {
        participant: String::new(),
        method: String::new(),
        trial: 0,
        task: None,
        t0,
        t1,
        ops,
        speed: samples.iter().zip(&speed).map(|(s, v)| (s.t, *v)).collect(),
        movements,
    }
}

/// Index of the last sample at or before `t` (the first sample if none is).
fn sample_at(samples: &[Sample], t: f64) -> Option<usize> {
    if samples.is_empty() {
        return None;
    }
    let i = samples.partition_point(|s| s.t <= t);
    Some(i.saturating_sub(1))
}

fn smoothed_speed(samples: &[Sample], sigma: f64) -> Vec<f64> {
    let n = samples.len();
    let same = |i: usize, j: usize| samples[i].run == samples[j].run;
    let raw: Vec<f64> = (0..n)
        .map(|i| {
            let a = if i > 0 && same(i - 1, i) { i - 1 } else { i };
            let b = if i + 1 < n && same(i, i + 1) {
                i + 1
            } else {
                i
            };
            let dt = samples[b].t - samples[a].t;
            if dt > 0.0 {
                samples[b].p.distance(samples[a].p) / dt
            } else {
                0.0
            }
        })
        .collect();
    if sigma <= 0.0 {
        return raw;
    }
    let reach = 3.0 * sigma;
    let mut lo = 0;
    (0..n)
        .map(|i| {
            while samples[lo].t < samples[i].t - reach || !same(lo, i) {
                lo += 1;
            }
            let (mut sw, mut sv) = (0.0, 0.0);
            let mut j = lo;
            while j < n && same(i, j) && samples[j].t <= samples[i].t + reach {
                let d = samples[j].t - samples[i].t;
                let w = (-d * d / (2.0 * sigma * sigma)).exp();
                sw += w;
                sv += w * raw[j];
                j += 1;
            }
            if sw > 0.0 { sv / sw } else { raw[i] }
        })
        .collect()
}

/// Dual-threshold segmentation of the smoothed speed into `(onset, offset)` times.
fn segment(samples: &[Sample], speed: &[f64], cfg: &ExtractConfig) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut moving: Option<usize> = None;
    let mut last_below = 0;
    for i in 0..samples.len() {
        if i > 0 && samples[i].run != samples[i - 1].run {
            if let Some(on) = moving.take() {
                out.push((samples[on].t, samples[i - 1].t));
            }
            last_below = i;
        }
        match moving {
            None => {
                if speed[i] < cfg.v_off {
                    last_below = i;
                }
                if speed[i] > cfg.v_on {
                    moving = Some(last_below);
                }
            }
            Some(on) => {
                if speed[i] < cfg.v_off {
                    out.push((samples[on].t, samples[i].t));
                    moving = None;
                    last_below = i;
                }
            }
        }
    }
    if let (Some(on), Some(last)) = (moving, samples.last()) {
        out.push((samples[on].t, last.t));
    }
    out
}

/// Splits segments at the button edges strictly inside them.
fn split_at(segs: &[(f64, f64)], edges: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(segs.len());
    for &(s, e) in segs {
        let mut start = s;
        for &t in edges.iter().filter(|&&t| t > s && t < e) {
            if t > start {
                out.push((start, t));
                start = t;
            }
        }
        out.push((start, e));
    }
    out
}

fn ray(q: DQuat) -> DVec3 {
    q * DVec3::NEG_Z
}

fn angle(a: DVec3, b: DVec3) -> f64 {
    let (a, b) = (a.normalize_or_zero(), b.normalize_or_zero());
    if a == DVec3::ZERO || b == DVec3::ZERO {
        return 0.0;
    }
    a.cross(b).length().atan2(a.dot(b))
}

fn fitts(
    start: &Sample,
    end: &Sample,
    target: Option<(f64, DVec3, f64)>,
    default_width: Option<f64>,
) -> Fitts {
    let id = |a: f64, w: Option<f64>| {
        w.filter(|w| *w > 0.0)
            .map(|w| (a / w + 1.0).log2())
            .filter(|v| v.is_finite())
    };
    match target {
        Some((_, centre, w)) => {
            let amplitude = centre.distance(start.p);
            let alpha = angle(ray(start.q), centre - start.p);
            let width_rad = (amplitude > crate::tolerance::AMPLITUDE_EPS)
                .then(|| 2.0 * (w / (2.0 * amplitude)).atan());
            Fitts {
                amplitude,
                width: Some(w),
                id: id(amplitude, Some(w)),
                amplitude_rad: alpha,
                width_rad,
                id_angular: id(alpha, width_rad),
            }
        }
        None => {
            let amplitude = end.p.distance(start.p);
            Fitts {
                amplitude,
                width: default_width,
                id: id(amplitude, default_width),
                amplitude_rad: angle(ray(start.q), ray(end.q)),
                width_rad: None,
                id_angular: None,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::oplog::{OpEvent, OpLogHeader};
    use sculpt_core::tolerance::{EXACT_EPS, POINT_EPS};

    fn log(events: Vec<(f64, EventKind)>) -> OpLog {
        OpLog {
            header: OpLogHeader::new(),
            events: events
                .into_iter()
                .map(|(t, kind)| OpEvent { t, kind })
                .collect(),
            truncated_tail: false,
        }
    }

    fn pose(x: f64) -> EventKind {
        EventKind::Pose {
            p: DVec3::new(x, 1.0, 0.0),
            q: DQuat::IDENTITY,
        }
    }

    #[test]
    fn presses_only() {
        let l = log(vec![
            (0.0, EventKind::Button { id: 0, down: true }),
            (0.1, EventKind::Button { id: 0, down: false }),
            (2.0, EventKind::Button { id: 1, down: true }),
            (2.2, EventKind::Button { id: 1, down: false }),
        ]);
        let t = &extract(&l, &ExtractConfig::default(), "p", "m")[0];
        assert_eq!(t.count(OpKind::K), 2);
        // The 1.9 s gap between the two presses is an M.
        assert_eq!(t.count(OpKind::M), 1);
        assert_eq!(t.trial, 1);
        let bb = ExtractConfig {
            k_mode: KMode::Bb,
            ..Default::default()
        };
        let t = &extract(&l, &bb, "p", "m")[0];
        assert_eq!((t.count(OpKind::B), t.count(OpKind::K)), (4, 0));
        // Each edge owns half the keystroke window; the last release is cut to nothing
        // by the end of the log.
        assert_near!(t.ops[0].duration(), 0.1, EXACT_EPS);
        assert_eq!(t.ops.last().map(Operator::duration), Some(0.0));
        t.check_tiling().unwrap();
    }

    /// Still 0 to 1.6 s, press at 1.5, sweep 0.5 m from 1.6 to 2.6 s with the button
    /// held, release at 3.0, end at 3.5 s.
    fn drag_log() -> OpLog {
        let mut ev: Vec<(f64, EventKind)> =
            (0..=160).map(|i| (i as f64 * 0.01, pose(0.0))).collect();
        ev.extend((1..=100).map(|i| (1.6 + i as f64 * 0.01, pose(0.005 * i as f64))));
        ev.extend((1..=90).map(|i| (2.6 + i as f64 * 0.01, pose(0.5))));
        ev.push((1.5, EventKind::Button { id: 0, down: true }));
        ev.push((3.0, EventKind::Button { id: 0, down: false }));
        ev.sort_by(|a, b| a.0.total_cmp(&b.0));
        log(ev)
    }

    fn letters(t: &Trial) -> Vec<&'static str> {
        t.ops.iter().map(|o| o.op.letter()).collect()
    }

    /// Regression (issue 19): a press was timed over the whole hold, the same seconds as
    /// the stroke's P, so operator times summed to more than the trial.
    #[test]
    fn regression_a_drag_is_press_window_then_p_and_times_sum_to_the_trial() {
        let smear = 2.4 * ExtractConfig::default().smooth_sigma_s;
        let t = &extract(&drag_log(), &ExtractConfig::default(), "p", "m")[0];
        t.check_tiling().unwrap();
        assert_eq!(letters(t), ["M", "K", "P", "R"], "{:?}", t.ops);
        // K is the press window, not the 1.5 s hold; the P starts after it.
        assert_near!(t.time(OpKind::K), 0.2, EXACT_EPS);
        assert_near!(t.ops[2].t_start, 1.7, EXACT_EPS);
        assert_near!(t.ops[2].t_end, 2.6, smear);
        let sum: f64 = t.ops.iter().map(Operator::duration).sum();
        assert_near!(sum, t.duration(), sculpt_core::tolerance::TIME_EPS);
        assert_near!(t.duration(), 3.5, EXACT_EPS);
        // B + B: the drag is B-down P B-up, each B 0.1 s.
        let bb = ExtractConfig {
            k_mode: KMode::Bb,
            ..Default::default()
        };
        let t = &extract(&drag_log(), &bb, "p", "m")[0];
        t.check_tiling().unwrap();
        assert_eq!(letters(t), ["M", "B", "P", "R", "B", "R"], "{:?}", t.ops);
        assert_near!(t.time(OpKind::B), 0.2, EXACT_EPS);
        assert_near!(t.ops[2].t_start, 1.6, smear);
    }

    #[test]
    fn tiling_check_finds_gaps_overlaps_and_a_short_end() {
        let mut t = extract(&drag_log(), &ExtractConfig::default(), "p", "m").remove(0);
        t.check_tiling().unwrap();
        let mut gap = t.clone();
        gap.ops[1].t_end -= 0.01;
        assert!(gap.check_tiling().unwrap_err().contains("does not start"));
        let mut overlap = t.clone();
        overlap.ops[1].t_end += 0.01;
        assert!(overlap.check_tiling().is_err());
        t.t1 += 1.0;
        assert!(t.check_tiling().unwrap_err().contains("operators end"));
    }

    #[test]
    fn straight_constant_speed_move_with_target() {
        // Still for 1.5 s, 0.5 m at 0.5 m/s sampled at 100 Hz, then a click on a 5 cm
        // target: M (the 1.5 s pause before the P), P, K.
        let mut ev: Vec<(f64, EventKind)> =
            (0..=150).map(|i| (i as f64 * 0.01, pose(0.0))).collect();
        ev.extend((1..=100).map(|i| (1.5 + i as f64 * 0.01, pose(0.005 * i as f64))));
        ev.extend((1..=50).map(|i| (2.5 + i as f64 * 0.01, pose(0.5))));
        ev.push((
            2.6,
            EventKind::Target {
                id: "t".into(),
                p: DVec3::new(0.5, 1.0, 0.0),
                width: 0.05,
            },
        ));
        ev.sort_by(|a, b| a.0.total_cmp(&b.0));
        ev.push((3.0, EventKind::Button { id: 0, down: true }));
        ev.push((3.1, EventKind::Button { id: 0, down: false }));
        let t = &extract(&log(ev), &ExtractConfig::default(), "p", "m")[0];
        assert_eq!(
            (t.count(OpKind::P), t.count(OpKind::K), t.count(OpKind::M)),
            (1, 1, 1)
        );
        let p = t.ops.iter().find(|o| o.op == OpKind::P).unwrap();
        let f = p.fitts.unwrap();
        assert_near!(f.amplitude, 0.5, POINT_EPS);
        assert_near!(f.id.unwrap(), (0.5f64 / 0.05 + 1.0).log2(), EXACT_EPS);
        // Onset and offset within a smoothing width (2.4 σ = 0.06 s) of the true 1.5 s
        // and 2.5 s.
        let smear = 2.4 * ExtractConfig::default().smooth_sigma_s;
        assert_near!(p.t_start, 1.5, smear);
        assert_near!(p.t_end, 2.5, smear);
    }

    #[test]
    fn tracking_loss_splits_runs() {
        // A jump across a 0.5 s gap is no movement.
        let mut ev: Vec<(f64, EventKind)> = (0..50).map(|i| (i as f64 * 0.01, pose(0.0))).collect();
        ev.extend((0..50).map(|i| (1.0 + i as f64 * 0.01, pose(0.4))));
        let t = &extract(&log(ev), &ExtractConfig::default(), "p", "m")[0];
        assert_eq!(t.count(OpKind::P), 0);
    }

    #[test]
    fn angular_index_of_difficulty_by_hand() {
        // Wand at the origin pointing down -Z; a 10 cm target 1 m along -Z and 1 m to
        // the side: α = 45°, D = √2 m, ω = 2 atan(0.05 / √2).
        let at = |t: f64, p: DVec3| Sample {
            t,
            p,
            q: DQuat::IDENTITY,
            run: 0,
        };
        let start = at(0.0, DVec3::ZERO);
        let end = at(1.0, DVec3::new(0.9, 0.0, -0.9));
        let f = fitts(
            &start,
            &end,
            Some((0.5, DVec3::new(1.0, 0.0, -1.0), 0.1)),
            None,
        );
        let alpha = std::f64::consts::FRAC_PI_4;
        let omega = 2.0 * (0.05 / 2f64.sqrt()).atan();
        assert_near!(f.amplitude, 2f64.sqrt(), EXACT_EPS);
        assert_near!(f.amplitude_rad, alpha, EXACT_EPS);
        assert_near!(f.width_rad.unwrap(), omega, EXACT_EPS);
        assert_near!(
            f.id_angular.unwrap(),
            (alpha / omega + 1.0).log2(),
            EXACT_EPS
        );
        assert_near!(f.id.unwrap(), (2f64.sqrt() / 0.1 + 1.0).log2(), EXACT_EPS);
        // No target and no default width: amplitude only, no ID.
        let f = fitts(&start, &end, None, None);
        assert_near!(f.amplitude, 0.9 * 2f64.sqrt(), EXACT_EPS);
        assert_eq!((f.id, f.id_angular), (None, None));
    }

    /// Regression (issue 19): desktop keys were no operators, and a session that
    /// switched mode kept its first method. A `key` is a K in either mode, and a trial
    /// that names its method is that method's.
    #[test]
    fn regression_keys_are_k_and_a_segment_names_its_method() {
        let key = |k: &str| EventKind::Key { key: k.into() };
        let start = |trial, method: Option<&str>| EventKind::TrialStart {
            trial,
            task: None,
            method: method.map(str::to_owned),
        };
        let mut l = log(vec![
            (0.0, start(1, None)),
            (0.5, key("Ctrl+Z")),
            (0.6, EventKind::Button { id: 0, down: true }),
            (0.7, EventKind::Button { id: 0, down: false }),
            (1.0, EventKind::TrialEnd { trial: 1 }),
            (1.0, start(1, Some("emboss"))),
            (1.0, key("3")),
            (1.05, key("Tab")),
            (1.5, EventKind::TrialEnd { trial: 1 }),
        ]);
        l.header = OpLogHeader::new().with_method("carve");
        for mode in [KMode::K, KMode::Bb] {
            let cfg = ExtractConfig {
                k_mode: mode,
                ..Default::default()
            };
            let trials = extract(&l, &cfg, "p", "m");
            let methods: Vec<&str> = trials.iter().map(|t| t.method.as_str()).collect();
            assert_eq!(methods, ["carve", "emboss"]);
            let (carve, emboss) = (&trials[0], &trials[1]);
            carve.check_tiling().unwrap();
            emboss.check_tiling().unwrap();
            match mode {
                KMode::K => assert_eq!(carve.count(OpKind::K), 2),
                KMode::Bb => {
                    assert_eq!((carve.count(OpKind::K), carve.count(OpKind::B)), (1, 2))
                }
            }
            // The first key's window is cut short by the second press.
            assert_eq!(emboss.count(OpKind::K), 2);
            assert_near!(emboss.time(OpKind::K), 0.05 + 0.2, EXACT_EPS);
        }
    }

    #[test]
    fn config_validation() {
        assert!(ExtractConfig::default().validate().is_ok());
        let bad = ExtractConfig {
            v_off: 0.5,
            ..Default::default()
        };
        assert!(bad.validate().unwrap_err().contains("v-off"));
        let nan = ExtractConfig {
            m_pause_s: f64::NAN,
            ..Default::default()
        };
        assert!(nan.validate().is_err());
    }
}
