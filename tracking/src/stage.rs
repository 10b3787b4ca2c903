//! The frame stage: decoded DTrack [`Frame`]s in, calibrated and filtered wand samples
//! and head poses out. Pure (no I/O, no clock, no tokio), so the display server's live
//! path and `replay` run exactly the same code on the same frames.
//!
//! Rules, in the order a frame meets them:
//! 1. **time**: a frame's time is its DTrack `ts` field when present (else its receive
//!    time), re-based so the stage clock never runs backwards. Where a frame has a
//!    `ts` field, its time depends on the stream alone (counters and `ts`), never on
//!    when it arrived: while `ts` runs on, the stage clock follows it; at a
//!    discontinuity (a restarted tracker whose `ts` starts again, `ts` going back, a
//!    step forward of more than [`MAX_CLOCK_STEP_S`], or a `ts` that cannot be
//!    believed: non-finite or beyond [`MAX_TRACKER_TIME_S`], e.g. `1e300`) it
//!    continues one frame period after the last frame, the period being the stream's
//!    last plausible `ts` step ([`DEFAULT_FRAME_PERIOD_S`] before there is one), and an
//!    unbelievable `ts` moves no anchor, so the next good one continues where the
//!    stream left off. A live run, where receive times differ, and an offline replay
//!    of its log therefore give the same sample times. Only frames without a `ts`
//!    field are timed by their arrival (counted in [`StageMetrics::receive_timed`]):
//!    there a live run can differ from its replay;
//! 2. **order**: a frame whose counter is not newer than the last accepted one is
//!    dropped as out of order, unless it is more than [`REORDER_WINDOW`] behind or its
//!    tracker time `ts` went back by [`COUNTER_RESET_AFTER`] or more from the last
//!    believed one (a restarted tracker counts, and clocks, from the start again). The
//!    rule reads the frames' contents only, never their arrival times, so a live run
//!    served at any speed keeps the frames an offline replay of the same log keeps.
//!    Only frames without a `ts` field (whose time is their arrival anyway) fall back
//!    to a receive-time gap of [`COUNTER_RESET_AFTER`] since the last accepted frame;
//! 3. **timeout**: when more than [`StageConfig::timeout_s`] passed since the last wand
//!    report, the wand was lost at that report's time plus the timeout. The caller's
//!    [`FrameStage::idle`] detects the same gap while no frame arrives at all;
//! 4. **calibration** ([`Calibration`]) of the wand and the head body into metres in the
//!    display frame, with the wand's tool tip, then the One Euro [`PoseFilter`] (reset
//!    when tracking resumes, so nothing is smoothed across a gap);
//! 5. **loss**: a wand with quality < 0, an invalid pose (NaN, not a rotation), a pose
//!    that calibrates to a non-finite point, or a frame without the wand gives an
//!    untracked sample. Its buttons are the reported ones (or the last known, when the
//!    wand is absent): a loss never invents a button release.
//!
//! Everything is counted in [`StageMetrics`].
//!
//! ```
//! use glam::DVec3;
//! use std::time::Duration;
//! use tracking::stage::{FrameStage, StageConfig, StageEvent};
//! use tracking::{Frame, Pose, Wand};
//! let mut stage = FrameStage::new(StageConfig::default()).unwrap();
//! let mut out = Vec::new();
//! for n in 1..=3u64 {
//!     let mut f = Frame::new(n);
//!     f.tracker_time = Some(n as f64 * 0.01);
//!     f.receive_time = Duration::from_millis(500 + 10 * n); // ignored: `ts` wins
//!     f.wands.push(Wand::tracked(0, Pose::from_position_mm(DVec3::new(0.0, 1000.0, 0.0))));
//!     stage.push(&f, &mut out);
//! }
//! let StageEvent::Wand(last) = out.last().unwrap() else { panic!() };
//! assert!(last.tracked);
//! sculpt_core::assert_near!(last.t, 0.03, sculpt_core::tolerance::EXACT_EPS);
//! sculpt_core::assert_near!(last.tip_m.y, 1.0, sculpt_core::tolerance::EXACT_EPS);
//! // No frame for a second: the wand is lost at the last time plus the timeout.
//! out.clear();
//! stage.idle(Duration::from_millis(1530), &mut out);
//! let StageEvent::Wand(lost) = &out[0] else { panic!() };
//! assert!(!lost.tracked);
//! sculpt_core::assert_near!(lost.t, 0.53, sculpt_core::tolerance::TIME_EPS);
//! assert_eq!(stage.metrics().losses, 1);
//! ```

use crate::calibration::{Calibration, DisplayPose};
use crate::error::{Result, TrackingError};
use crate::filter::{FilterConfig, PoseFilter};
pub use crate::frame::{COUNTER_RESET_AFTER, REORDER_WINDOW};
use crate::frame::{DeviceId, Frame, Pose};
use glam::{DQuat, DVec3};
use sculpt_core::interaction::{WandEvent, WandSample as InteractionSample};
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// What the stage needs to know.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StageConfig {
    /// Flystick id of the wand.
    pub wand_id: u32,
    /// Standard body id of the head target, if a head tracker is used.
    pub head_id: Option<u32>,
    /// Seconds without a wand report before the wand counts as lost.
    pub timeout_s: f64,
    /// Tracker to display frame, with tip offsets.
    pub calibration: Calibration,
    /// The One Euro filter, for the wand and the head alike.
    pub filter: FilterConfig,
}

impl Default for StageConfig {
    fn default() -> Self {
        Self {
            wand_id: 0,
            head_id: Some(0),
            timeout_s: 0.5,
            calibration: Calibration::default(),
            filter: FilterConfig::default(),
        }
    }
}

impl StageConfig {
    /// Checks the timeout, the calibration and the filter.
    pub fn validate(&self) -> Result<()> {
        if !(self.timeout_s.is_finite() && self.timeout_s > 0.0) {
            return Err(TrackingError::Config(crate::ConfigError::StageTimeout(
                self.timeout_s,
            )));
        }
        self.calibration.validate()?;
        self.filter.validate()
    }
}

/// One wand report in the display frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WandSample {
    /// Stage time, seconds (see the module docs).
    pub t: f64,
    /// Whether the pose may be used; the pose fields are zero/identity when not.
    pub tracked: bool,
    /// The tool tip, metres in the display frame (filtered).
    pub tip_m: DVec3,
    /// The marker target's origin, metres in the display frame (filtered).
    pub position_m: DVec3,
    /// `display_from_wand` (filtered).
    pub orientation: DQuat,
    /// Button mask, bit `i` = DTrack button `i`.
    pub buttons: u64,
    /// The frame counter it came from (the last accepted one for a timeout).
    pub frame: u64,
}

impl WandSample {
    /// This sample as the interaction's input (`sculpt_core::interaction`): a wand
    /// event at the stage time, tracked at the tool tip with `display_from_wand` when the
    /// stage tracked the wand, lost otherwise. `extra_buttons` (those of a buttons-only
    /// source, such as a serial wand) are merged in; the interaction knows buttons 0
    /// to 31. The display server and `replay` both convert with this.
    pub fn wand_event(&self, extra_buttons: u64) -> WandEvent {
        let buttons = ((self.buttons | extra_buttons) & u64::from(u32::MAX)) as u32;
        let sample = if self.tracked {
            InteractionSample::tracked(self.tip_m, self.orientation, buttons)
        } else {
            InteractionSample::lost(buttons)
        };
        WandEvent::sample(self.t, sample)
    }
}

/// One tracked head pose in the display frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeadSample {
    /// Stage time, seconds.
    pub t: f64,
    /// The filtered pose.
    pub pose: DisplayPose,
}

/// The largest tracker time (`ts`, seconds) the stage believes: about 3,000 years, so
/// a DTrack2 `ts` from midnight or from the tracker's start passes, and so does a Unix
/// epoch time (1.7e9 s), where f64 still resolves 15 us. One beyond this is garbage
/// and the frame's receive time is used instead.
pub const MAX_TRACKER_TIME_S: f64 = 1e11;
/// The largest step forward of one clock between two accepted frames (seconds) that
/// the stage takes as time passing; a larger one is a restarted clock, and the stage
/// continues by the receive-time gap.
pub const MAX_CLOCK_STEP_S: f64 = 3600.0;

/// The frame period the stage assumes at a clock discontinuity before the stream has
/// shown one (seconds): DTrack2's common 60 Hz.
pub const DEFAULT_FRAME_PERIOD_S: f64 = 1.0 / 60.0;
/// The longest `ts` step (seconds) the stage takes as the stream's frame period; a
/// longer one is a gap in the data, not the rate.
pub const MAX_FRAME_PERIOD_S: f64 = 0.25;

/// What the stage emits, in time order.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum StageEvent {
    /// A wand sample (tracked or lost).
    Wand(WandSample),
    /// A tracked head pose.
    Head(HeadSample),
}

impl StageEvent {
    /// The wand sample, if this is one.
    pub fn wand(&self) -> Option<&WandSample> {
        match self {
            StageEvent::Wand(w) => Some(w),
            StageEvent::Head(_) => None,
        }
    }
}

/// Counts over everything the stage saw.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StageMetrics {
    /// Frames pushed.
    pub frames: usize,
    /// Frames accepted and used.
    pub used: usize,
    /// Frames the caller could not decode ([`FrameStage::bad_frame`]).
    pub bad_frames: usize,
    /// Frames dropped because their counter was not newer than the last one.
    pub out_of_order: usize,
    /// Accepted frames without the wand.
    pub without_wand: usize,
    /// Wand reports with quality ≥ 0 whose pose was unusable (NaN, not a rotation).
    pub invalid_poses: usize,
    /// Tracked head poses emitted.
    pub head_poses: usize,
    /// Times the wand went from tracked to lost.
    pub losses: usize,
    /// Gaps with no wand report longer than the timeout.
    pub timeouts: usize,
    /// Seconds the wand was lost in all (up to the last report; see
    /// [`FrameStage::metrics_until`]).
    pub lost_s: f64,
    /// Accepted frames without a `ts` field, timed by their arrival: where this is not
    /// zero, a live run may differ from the offline replay of its log.
    #[serde(default)]
    pub receive_timed: usize,
    /// Accepted frames whose `ts` broke the stream's clock (a restarted tracker, `ts`
    /// going back or jumping ahead, or a `ts` that cannot be believed): each continued
    /// one frame period after the frame before.
    #[serde(default)]
    pub clock_breaks: usize,
}

/// The frame stage (see the module docs).
#[derive(Debug, Clone)]
pub struct FrameStage {
    config: StageConfig,
    wand_filter: PoseFilter,
    head_filter: PoseFilter,
    metrics: StageMetrics,
    /// Counter and receive time of the last accepted frame.
    last_frame: Option<(u64, Duration)>,
    /// Stage time of the last accepted frame.
    last_t: Option<f64>,
    /// The clock's anchor: the stage time of the last frame whose raw time could be
    /// used, that raw time, and whether it was `ts` (else a receive time).
    anchor: Option<(f64, f64, bool)>,
    /// The last believed `ts` accepted (the order rule's reference).
    last_ts: Option<f64>,
    /// The stream's frame period: its last plausible `ts` step, seconds.
    period: f64,
    /// Receive time (seconds) of the last accepted frame, to map `idle` times.
    last_receive_s: f64,
    /// Stage time of the last wand report, and whether its gap was already handled.
    last_wand: Option<f64>,
    timed_out: bool,
    wand_tracked: bool,
    head_tracked: bool,
    buttons: u64,
    lost_since: Option<f64>,
    /// The latest time emitted (sample times never go back).
    emitted: f64,
}

impl FrameStage {
    /// A stage with a validated config.
    pub fn new(config: StageConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            wand_filter: PoseFilter::new(config.filter),
            head_filter: PoseFilter::new(config.filter),
            config,
            metrics: StageMetrics::default(),
            last_frame: None,
            last_t: None,
            anchor: None,
            last_ts: None,
            period: DEFAULT_FRAME_PERIOD_S,
            last_receive_s: 0.0,
            last_wand: None,
            timed_out: false,
            wand_tracked: false,
            head_tracked: false,
            buttons: 0,
            lost_since: None,
            emitted: f64::NEG_INFINITY,
        })
    }

    /// The config.
    pub fn config(&self) -> &StageConfig {
        &self.config
    }

    /// The counts so far.
    pub fn metrics(&self) -> &StageMetrics {
        &self.metrics
    }

    /// The counts with an ongoing loss counted up to stage time `t` (for the end of a
    /// session).
    pub fn metrics_until(&self, t: f64) -> StageMetrics {
        let mut m = self.metrics.clone();
        if let Some(t0) = self.lost_since {
            m.lost_s += (t - t0).max(0.0);
        }
        m
    }

    /// Whether the wand is tracked now.
    pub fn wand_tracked(&self) -> bool {
        self.wand_tracked
    }

    /// The stage time of the last accepted frame.
    pub fn time(&self) -> Option<f64> {
        self.last_t
    }

    /// Counts a frame the caller could not decode.
    pub fn bad_frame(&mut self) {
        self.metrics.bad_frames += 1;
    }

    /// Feeds one decoded frame (in arrival order); returns false when it was dropped as
    /// out of order. Events go to `out`.
    pub fn push(&mut self, frame: &Frame, out: &mut Vec<StageEvent>) -> bool {
        self.metrics.frames += 1;
        let receive = frame.receive_time;
        if let Some((last, last_receive)) = self.last_frame
            && frame.number <= last
            && last - frame.number < REORDER_WINDOW
            && !self.restarted(frame, last_receive)
        {
            self.metrics.out_of_order += 1;
            return false;
        }
        self.last_frame = Some((frame.number, receive));
        self.metrics.used += 1;
        let t = self.stage_time(frame);
        self.last_receive_s = receive.as_secs_f64();

        // A silent gap: the wand was lost at the last report plus the timeout.
        if let Some(prev) = self.last_wand
            && !self.timed_out
            && t - prev > self.config.timeout_s
        {
            self.time_out(prev, out);
        }

        if let Some(head_id) = self.config.head_id {
            self.push_head(head_id, t, frame, out);
        }

        let device = DeviceId::Wand(self.config.wand_id);
        let in_display = match frame.wand(self.config.wand_id) {
            None => {
                self.metrics.without_wand += 1;
                None
            }
            Some(w) => {
                self.buttons = w.buttons;
                if w.quality >= 0.0 {
                    let in_display = self.calibrate(device, &w.pose);
                    if in_display.is_none() {
                        self.metrics.invalid_poses += 1;
                    }
                    in_display
                } else {
                    None
                }
            }
        };
        self.last_wand = Some(t);
        self.timed_out = false;
        let sample = match in_display {
            Some(in_display) => {
                if !self.wand_tracked {
                    self.wand_filter.reset();
                }
                let pose = self.wand_filter.filter(t, in_display);
                if let Some(t0) = self.lost_since.take() {
                    self.metrics.lost_s += t - t0;
                }
                self.wand_tracked = true;
                WandSample {
                    t,
                    tracked: true,
                    tip_m: pose.tool_m,
                    position_m: pose.position_m,
                    orientation: pose.orientation,
                    buttons: self.buttons,
                    frame: frame.number,
                }
            }
            None => {
                self.lose(t);
                self.lost_sample(t, frame.number)
            }
        };
        out.push(StageEvent::Wand(sample));
        true
    }

    /// Whether a frame whose counter is not newer than the last accepted one comes from
    /// a restarted tracker: its `ts` went back by [`COUNTER_RESET_AFTER`] or more from
    /// the last accepted `ts` (content only, so arrival timing never matters). Without
    /// a `ts` on both, a receive-time gap of that much since the last accepted frame.
    fn restarted(&self, frame: &Frame, last_receive: Duration) -> bool {
        let reset_s = COUNTER_RESET_AFTER.as_secs_f64();
        match (frame.tracker_time, tracker_time(frame), self.last_ts) {
            (_, Some(ts), Some(last_ts)) => last_ts - ts >= reset_s,
            // A `ts` field that cannot be believed, or none before it to compare with:
            // the counter alone decides (never the arrival).
            (Some(_), _, _) => false,
            (None, _, _) => frame.receive_time.saturating_sub(last_receive) >= COUNTER_RESET_AFTER,
        }
    }

    /// Tells the stage that no frame came until receive time `now` (the caller's clock,
    /// the one frames' `receive_time` uses). When the gap since the last wand report
    /// exceeds the timeout, a lost sample is emitted at that report's time plus the
    /// timeout (once per gap). Returns whether it emitted one.
    pub fn idle(&mut self, now: Duration, out: &mut Vec<StageEvent>) -> bool {
        let (Some(prev), Some(stage_t)) = (self.last_wand, self.last_t) else {
            return false;
        };
        if self.timed_out {
            return false;
        }
        let stage_now = stage_t + (now.as_secs_f64() - self.last_receive_s);
        if stage_now - prev > self.config.timeout_s {
            self.time_out(prev, out)
        } else {
            false
        }
    }

    fn time_out(&mut self, prev: f64, out: &mut Vec<StageEvent>) -> bool {
        self.timed_out = true;
        self.metrics.timeouts += 1;
        if !self.wand_tracked {
            return false;
        }
        let t = prev + self.config.timeout_s;
        self.emitted = self.emitted.max(t);
        self.lose(t);
        let frame = self.last_frame.map_or(0, |f| f.0);
        out.push(StageEvent::Wand(self.lost_sample(t, frame)));
        true
    }

    fn lose(&mut self, t: f64) {
        if self.wand_tracked {
            self.metrics.losses += 1;
            self.lost_since = Some(t);
        }
        self.wand_tracked = false;
    }

    fn lost_sample(&self, t: f64, frame: u64) -> WandSample {
        WandSample {
            t,
            tracked: false,
            tip_m: DVec3::ZERO,
            position_m: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
            buttons: self.buttons,
            frame,
        }
    }

    fn push_head(&mut self, head_id: u32, t: f64, frame: &Frame, out: &mut Vec<StageEvent>) {
        let in_display = frame
            .body(head_id)
            .filter(|b| b.quality >= 0.0)
            .and_then(|b| self.calibrate(DeviceId::Body(head_id), &b.pose));
        match in_display {
            Some(in_display) => {
                if !self.head_tracked {
                    self.head_filter.reset();
                }
                self.head_tracked = true;
                let pose = self.head_filter.filter(t, in_display);
                self.metrics.head_poses += 1;
                out.push(StageEvent::Head(HeadSample { t, pose }));
            }
            None => self.head_tracked = false,
        }
    }

    /// A calibrated pose, or `None` when it is not a usable rigid pose or lands on a
    /// non-finite point.
    fn calibrate(&self, device: DeviceId, pose: &Pose) -> Option<DisplayPose> {
        let w = self.config.calibration.pose_in_display(device, pose)?;
        (w.position_m.is_finite() && w.tool_m.is_finite() && w.orientation.is_finite()).then_some(w)
    }

    /// The frame's stage time (see rule 1 of the module docs): `ts` when present and
    /// believable, continuing from the anchor while it runs on; one frame period after
    /// the last time at a discontinuity; the receive time only for frames without a
    /// `ts` field.
    ///
    /// An implausible `ts` never reaches the clock: one beyond
    /// [`MAX_TRACKER_TIME_S`] counts as a break, and a step forward of more than
    /// [`MAX_CLOCK_STEP_S`] counts as a restarted clock. One frame with `ts 1e300` once
    /// froze the clock at 1e300, where 1/60 s steps vanish in the rounding, so every
    /// later stroke was "too short".
    fn stage_time(&mut self, frame: &Frame) -> f64 {
        let believed = tracker_time(frame);
        let raw = match (frame.tracker_time, believed) {
            (_, Some(ts)) => Some((ts, true)),
            (Some(_), None) => None,
            (None, _) => {
                self.metrics.receive_timed += 1;
                Some((frame.receive_time.as_secs_f64(), false))
            }
        };
        let continued = match (self.anchor, raw) {
            (Some((a_t, a_raw, a_is_ts)), Some((raw, is_ts)))
                if is_ts == a_is_ts && raw >= a_raw && raw - a_raw <= MAX_CLOCK_STEP_S =>
            {
                if is_ts && raw > a_raw && raw - a_raw <= MAX_FRAME_PERIOD_S {
                    self.period = raw - a_raw;
                }
                Some(a_t + (raw - a_raw))
            }
            _ => None,
        };
        let t = match (continued, self.last_t, raw) {
            (Some(t), _, _) => t,
            // The first frame: its own time, or zero when its `ts` cannot be believed.
            (None, None, raw) => raw.map_or(0.0, |r| r.0),
            // No `ts` field: continue by the receive-time gap (arrival, documented).
            (None, Some(last_t), Some((_, false))) => {
                let gap = frame.receive_time.as_secs_f64() - self.last_receive_s;
                last_t + if gap.is_finite() { gap.max(0.0) } else { 0.0 }
            }
            // A break in the stream's clock: one frame period on, from the stream alone.
            (None, Some(last_t), _) => {
                self.metrics.clock_breaks += 1;
                last_t + self.period
            }
        };
        // Never before a time already emitted (a timeout sample from `idle` while the
        // network stalled and `ts` then shows a shorter gap), nor before the last frame
        // (a `ts` that continues the anchor after unbelievable ones moved the clock on).
        let t = t.max(self.emitted).max(self.last_t.unwrap_or(t));
        if let Some((raw, is_ts)) = raw {
            self.anchor = Some((t, raw, is_ts));
        }
        if believed.is_some() {
            self.last_ts = believed;
        }
        self.last_t = Some(t);
        t
    }
}

/// The frame's `ts` when the stage believes it (finite, within
/// [`MAX_TRACKER_TIME_S`]).
fn tracker_time(frame: &Frame) -> Option<f64> {
    frame
        .tracker_time
        .filter(|ts| ts.is_finite() && ts.abs() <= MAX_TRACKER_TIME_S)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Wand;
    use sculpt_core::interaction::WandInput;

    fn frame(n: u64, quality: f64, buttons: u64) -> Frame {
        let mut f = Frame::new(n);
        f.tracker_time = Some(n as f64 * 0.01);
        let mut w = Wand::tracked(0, Pose::from_position_mm(DVec3::new(0.0, 1000.0, 0.0)));
        w.quality = quality;
        w.buttons = buttons;
        f.wands.push(w);
        f
    }

    fn sample(event: &WandEvent) -> InteractionSample {
        match &event.input {
            WandInput::Sample(s) => *s,
            WandInput::Command(c) => panic!("a stage sample became a command: {c:?}"),
        }
    }

    #[test]
    fn stage_samples_become_wand_events_with_the_extra_buttons_merged() {
        let mut stage = FrameStage::new(StageConfig::default()).unwrap();
        let mut out = Vec::new();
        stage.push(&frame(1, 1.0, 0b01), &mut out);
        stage.push(&frame(2, -1.0, 0b01 | 1 << 40), &mut out);
        let wands: Vec<&WandSample> = out.iter().filter_map(StageEvent::wand).collect();
        let tracked = wands[0].wand_event(0b100);
        assert_eq!(tracked.t, wands[0].t);
        let s = sample(&tracked);
        assert!(s.tracked);
        assert_eq!(s.position, wands[0].tip_m);
        assert_eq!(s.orientation, wands[0].orientation);
        assert_eq!(s.buttons, 0b101, "the extra buttons are merged in");
        let lost = wands[1].wand_event(0);
        assert_eq!(lost.t, wands[1].t);
        assert_eq!(
            sample(&lost),
            InteractionSample::lost(0b01),
            "buttons past 31 are dropped and a lost sample carries no pose"
        );
    }
}
