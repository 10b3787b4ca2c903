//! The replay pipeline: pose-log records in; the sculpted document, the operator event
//! log and metrics out.
//!
//! Stages, in the order the live display server runs them, with the same code:
//! 1. **decode** each DTrack2 record (`tracking::dtrack`); corrupt lines, bad frames
//!    and a truncated last line are counted, not fatal;
//! 2. the [`FrameStage`](tracking::stage::FrameStage) (`tracking::stage`): out-of-order frames dropped, time from
//!    the frames' DTrack `ts`, **calibration** of tracker millimetres into the display
//!    frame with the wand's tool tip, the One Euro **filter**, **tracking loss**
//!    (quality < 0, no wand, or no frame for longer than the timeout);
//! 3. **the edit loop** ([`EditLoop`], `sculpt_core::edit_loop`), fed by the display
//!    server's own [`Feeder`] (stage samples as the stage converts them, a serial
//!    wand's buttons merged in, the thumbstick): [`Interaction`] turns wand
//!    samples into edits and operator events, and [`editor::apply`] applies each edit
//!    to the [`Document`] (strokes through the multiresolution trimming, sketches
//!    fitted into new targets, undo and redo). The replay counts what each [`Step`]
//!    did into its metrics, times each stroke's apply ([`EditHooks`]) and writes the
//!    operator log with [`editor::oplog_event`], one segment per interaction mode
//!    ([`ModeSegments::marked`], as the display server's log); with a `[thumbstick]`
//!    config (a headset session), each accepted frame's analog axes then change the
//!    tool's width and depth as they did live.
//!
//! Time is virtual: the frames' own times, so a replay is deterministic, runs as fast
//! as the CPU allows, and matches a live run of the same log.

use std::convert::Infallible;
use std::time::Instant;

use sculpt_core::edit_loop::{EditHooks, EditLoop, LoopError, LoopEvent, Step};
use sculpt_core::editor::{self, Applied};
use sculpt_core::error::StrokeRejection;
use sculpt_core::interaction::{
    Edit, EndReason, Interaction, OperatorEvent, Profile, StrokeEdit, StrokeMode, Tool, WandEvent,
};
use sculpt_core::oplog::{EventKind, ModeSegments, OpLogHeader, OpLogWriter};
use sculpt_core::sculpt::document::{Document, StrokeId, TargetId};
use serde::Serialize;
use tracking::Frame;
use tracking::poselog::{PoseLogReader, Record, RecordKind};

use vr_app::feeder::{Feeder, Sink};
use vr_app::input::Input;
use vr_app::projection::HeadPose;

use crate::config::ReplayConfig;
use crate::error::{Error, Result};

/// Counts over the input records.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FrameMetrics {
    /// Records read from the log.
    pub records: usize,
    /// Frames decoded and used.
    pub used: usize,
    /// Lines of the log that were corrupt (bad CRC, bad escape, time going back).
    pub corrupt_lines: usize,
    /// Records whose DTrack2 bytes did not parse (e.g. a half frame).
    pub bad_frames: usize,
    /// Frames dropped because their frame number was not newer than the last one.
    pub out_of_order: usize,
    /// Frames without the configured wand.
    pub without_wand: usize,
    /// Records of other kinds than DTrack: serial wand lines, used as live (their
    /// buttons merged into the wand's samples; a line with a pose is a frame).
    pub other_kinds: usize,
    /// The log ended in the middle of a line.
    pub truncated_tail: bool,
    /// Frames without a `ts` field, timed by their receive time: where this is not
    /// zero, a live run of the log may differ from this replay (written only then).
    #[serde(skip_serializing_if = "is_zero")]
    pub receive_timed: usize,
    /// Frames whose `ts` broke the stream's clock (a restarted tracker, `ts` jumps),
    /// each continued one frame period on (written only when not zero).
    #[serde(skip_serializing_if = "is_zero")]
    pub clock_breaks: usize,
}

/// Whether a count is zero (such counts are left out of `metrics.json`).
fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Tracking-loss counts.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct TrackingMetrics {
    /// Times the wand went from tracked to lost.
    pub losses: usize,
    /// Gaps in the data longer than the tracking timeout.
    pub timeouts: usize,
    /// Samples dropped as impossible jumps.
    pub glitches: usize,
    /// Seconds the wand was lost in all.
    pub lost_s: f64,
}

/// One applied stroke.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StrokeMetrics {
    /// Document stroke id.
    pub id: StrokeId,
    /// Document target id.
    pub target: TargetId,
    /// `carve` or `emboss`.
    pub mode: &'static str,
    /// `v`, `u` or `custom`.
    pub profile: &'static str,
    /// Wand samples.
    pub samples: usize,
    /// First sample time, seconds.
    pub start_s: f64,
    /// Last sample time, seconds.
    pub end_s: f64,
    /// Path length, metres.
    pub length_m: f64,
    /// Pieces carved (more than one where the stroke passed over basin jumps).
    pub pieces: usize,
    /// Pieces left uncarved, no longer than the minimum stroke length.
    pub dropped_pieces: usize,
    /// Apply latency on the session clock: from the stroke's last sample to the
    /// moment the edit was applied (milliseconds; the pause timeout when tracking loss
    /// ended it).
    pub apply_latency_ms: f64,
}

/// A stroke the sculpting layer refused.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rejection {
    /// When, seconds.
    pub at_s: f64,
    /// Why (written to `metrics.json` as its message).
    #[serde(serialize_with = "as_message")]
    pub reason: sculpt_core::Error,
}

/// Writes an error as its one-line message.
fn as_message<S: serde::Serializer>(e: &sculpt_core::Error, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(&sculpt_core::error::Chain(e))
}

/// Gesture counts.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct GestureMetrics {
    /// Strokes applied to the document.
    pub strokes_applied: usize,
    /// Strokes the sculpting layer rejected.
    pub strokes_rejected: usize,
    /// Sketches turned into targets.
    pub sketches: usize,
    /// Gestures discarded as too short.
    pub too_short: usize,
    /// Gestures ended by tracking loss.
    pub ended_by_loss: usize,
    /// Gestures that resumed after a short loss.
    pub resumed: usize,
    /// Undo commands that undid something.
    pub undos: usize,
    /// Redo commands that redid something.
    pub redos: usize,
    /// Lattice deformations applied (left out of `metrics.json` while zero, so the
    /// metrics of sessions without any are as they were).
    #[serde(skip_serializing_if = "is_zero")]
    pub deforms: usize,
    /// Paint strokes applied (left out of `metrics.json` while zero, like `deforms`).
    #[serde(skip_serializing_if = "is_zero")]
    pub paints: usize,
}

/// `metrics.json`: everything here is deterministic.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Metrics {
    /// The session's name (file stem).
    pub session: String,
    /// Session-clock seconds from the first to the last record.
    pub duration_s: f64,
    /// Input counts.
    pub frames: FrameMetrics,
    /// Tracking loss.
    pub tracking: TrackingMetrics,
    /// Gestures.
    pub gestures: GestureMetrics,
    /// Document operations applied (strokes, sketches, undos, redos).
    pub operations: usize,
    /// Targets in the final document.
    pub targets: usize,
    /// Strokes in the final document.
    pub strokes: usize,
    /// The applied strokes, in order.
    pub per_stroke: Vec<StrokeMetrics>,
    /// The rejected strokes, in order.
    pub rejected: Vec<Rejection>,
    /// Solid targets in the final document and strokes carved into them (issue 35);
    /// absent when there are none, so sessions without solids write what they did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solids: Option<SolidMetrics>,
}

/// The solid targets of `metrics.json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SolidMetrics {
    /// Solid targets.
    pub targets: usize,
    /// Strokes on them.
    pub strokes: usize,
    /// Euler characteristic of each solid's mesh (2 minus twice its handles): a
    /// stroke that cuts through lowers it by 2.
    pub euler: Vec<i64>,
}

/// `timing.json`: wall-clock measurements (these differ from run to run).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Timing {
    /// CPU time applying each stroke to the document, microseconds, in order.
    pub stroke_apply_us: Vec<f64>,
    /// Median of `stroke_apply_us`.
    pub stroke_apply_median_us: f64,
    /// Largest of `stroke_apply_us`.
    pub stroke_apply_max_us: f64,
    /// Wall time of the whole replay (reading to the final document), seconds.
    pub replay_wall_s: f64,
    /// Session seconds per wall second.
    pub speed_ratio: f64,
}

/// What a replay produced.
#[derive(Debug)]
pub struct Outcome {
    /// The final document.
    pub document: Document,
    /// The operator event log (`wandsculpt-oplog` JSON lines).
    pub oplog: Vec<u8>,
    /// Deterministic metrics.
    pub metrics: Metrics,
    /// Wall-clock measurements.
    pub timing: Timing,
}

pub use sculpt_core::editor::{default_document, default_surface, fit_sketch};

/// Times each stroke's apply on the wall clock, for `timing.json`: the one thing the
/// replay does while the edit loop runs.
#[derive(Debug, Default)]
struct ApplyTimer {
    started: Option<Instant>,
    stroke_apply_us: Vec<f64>,
}

impl EditHooks for ApplyTimer {
    type Error = Infallible;

    fn before_apply(&mut self, _t: f64, _edit: &Edit) -> std::result::Result<(), Infallible> {
        self.started = Some(Instant::now());
        Ok(())
    }

    fn after_apply(
        &mut self,
        _t: f64,
        edit: &Edit,
        _applied: &Applied,
        _doc: &Document,
    ) -> std::result::Result<(), Infallible> {
        if let (Edit::Stroke(_), Some(started)) = (edit, self.started.take()) {
            self.stroke_apply_us
                .push(started.elapsed().as_secs_f64() * 1e6);
        }
        Ok(())
    }
}

/// The replay's side of the feeder: the [`EditLoop`] ([`Interaction`] →
/// [`editor::apply`]), its metrics and the operator log.
struct Recorder {
    edit_loop: EditLoop,
    timer: ApplyTimer,
    oplog: OpLogWriter,
    /// The operator log's segments, one per interaction mode.
    segments: ModeSegments,
    metrics: Metrics,
    head: Option<HeadPose>,
}

impl Sink for Recorder {
    type Error = Infallible;

    fn wand(&mut self, ev: &WandEvent) -> std::result::Result<(), Infallible> {
        // Stage times never go back, so the interaction accepts every sample.
        match self.edit_loop.handle(ev, &mut self.timer) {
            Ok(step) => self.record(&step),
            Err(LoopError::Refused(_)) => {}
            Err(LoopError::Hook(never)) => match never {},
        }
        Ok(())
    }

    fn tick(&mut self, t: f64) -> std::result::Result<(), Infallible> {
        let Ok(step) = self.edit_loop.tick(t, &mut self.timer);
        self.record(&step);
        Ok(())
    }

    fn tool(&self) -> Tool {
        self.edit_loop.interaction.tool().clone()
    }

    fn head(&mut self, head: Option<HeadPose>) {
        self.head = head;
    }
}

/// Feeds records through the pipeline one at a time: the display server's
/// [`Feeder`] (the frame stage, a serial wand's buttons, the thumbstick), then the
/// [`EditLoop`] ([`Interaction`] → [`editor::apply`]): the same calls the display
/// server makes.
pub struct Replayer {
    feeder: Feeder,
    recorder: Recorder,
    pause_timeout: f64,
    first_t: Option<f64>,
    last_t: f64,
    wand_id: u32,
}

impl Replayer {
    /// A replayer starting from `doc` (the base scene), in the config's start mode.
    pub fn new(cfg: &ReplayConfig, doc: Document, session: &str) -> Result<Self> {
        cfg.validate()?;
        let stage = cfg.stage();
        stage.validate().map_err(|source| Error::ConfigTracking {
            section: "[tracking]",
            source,
        })?;
        let feeder = Feeder::new(stage, cfg.interaction.pause_timeout, cfg.thumbstick).map_err(
            |source| Error::ConfigDisplay {
                section: "[tracking]",
                source,
            },
        )?;
        let interaction = Interaction::new(cfg.interaction, cfg.tool.mode, cfg.tool.tool());
        let oplog = OpLogWriter::new(
            &OpLogHeader::new()
                .with_source("replay")
                .with_method(editor::mode_name(cfg.tool.mode)),
        );
        Ok(Self {
            feeder,
            recorder: Recorder {
                edit_loop: EditLoop::new(interaction, doc),
                timer: ApplyTimer::default(),
                oplog,
                segments: ModeSegments::new(editor::mode_name(cfg.tool.mode)),
                metrics: Metrics {
                    session: session.to_string(),
                    ..Metrics::default()
                },
                head: None,
            },
            pause_timeout: cfg.interaction.pause_timeout,
            first_t: None,
            last_t: 0.0,
            wand_id: cfg.tracking.wand_id,
        })
    }

    /// The document so far.
    pub fn document(&self) -> &Document {
        &self.recorder.edit_loop.doc
    }

    /// The interaction state (mode, tool, live stroke, wand).
    pub fn interaction(&self) -> &Interaction {
        &self.recorder.edit_loop.interaction
    }

    /// The latest tracked head pose (display frame).
    pub fn head(&self) -> Option<&HeadPose> {
        self.recorder.head.as_ref()
    }

    /// Session time of the last frame used (seconds on the stage clock).
    pub fn time(&self) -> f64 {
        self.last_t
    }

    /// Seconds since the first frame.
    pub fn elapsed(&self) -> f64 {
        self.first_t.map_or(0.0, |t0| self.last_t - t0)
    }

    /// Feeds one pose-log record: a DTrack frame, or a serial wand line (its
    /// buttons, or with a pose a frame, as the live hub takes it).
    pub fn feed(&mut self, rec: &Record) {
        self.recorder.metrics.frames.records += 1;
        match rec.kind {
            RecordKind::DTrack => match rec.frame() {
                Ok(frame) => self.feed_frame(&frame),
                Err(_) => self.feeder.bad_frame(),
            },
            RecordKind::Serial => {
                self.recorder.metrics.frames.other_kinds += 1;
                match tracking::serial::parse_serial(rec.bytes.trim_ascii_end()) {
                    Ok(line) => {
                        let mut frame = line.to_frame(self.wand_id, 0);
                        frame.receive_time = rec.time;
                        if line.pose.is_some() {
                            self.feed_frame(&frame);
                        } else {
                            self.feed_input(&Input::Buttons(frame));
                        }
                    }
                    Err(_) => self.feeder.bad_frame(),
                }
            }
        }
    }

    /// Feeds one decoded frame (in arrival order).
    pub fn feed_frame(&mut self, frame: &Frame) {
        self.feed_input(&Input::Frame(frame.clone()));
    }

    /// Feeds one raw input through the feeder.
    pub fn feed_input(&mut self, input: &Input) {
        let Ok(_) = self.feeder.feed(input, &mut self.recorder);
        if let Some(t) = self.feeder.stage().time() {
            self.first_t.get_or_insert(t);
            self.last_t = t;
        }
    }

    /// Ends the session at the last frame's time (a paused gesture is given its
    /// timeout) and returns the outcome.
    pub fn finish(self, corrupt_lines: usize, truncated_tail: bool) -> Outcome {
        let Self {
            feeder,
            mut recorder,
            pause_timeout,
            first_t,
            last_t,
            ..
        } = self;
        let end = last_t + pause_timeout + sculpt_core::tolerance::TIME_EPS;
        let Ok(()) = recorder.tick(end);
        let stage = feeder.stage().metrics_until(last_t);
        let m = &mut recorder.metrics;
        m.frames.used = stage.used;
        m.frames.bad_frames = stage.bad_frames;
        m.frames.out_of_order = stage.out_of_order;
        m.frames.without_wand = stage.without_wand;
        m.frames.corrupt_lines = corrupt_lines;
        m.frames.truncated_tail = truncated_tail;
        m.frames.receive_timed = stage.receive_timed;
        m.frames.clock_breaks = stage.clock_breaks;
        m.tracking.losses = stage.losses;
        m.tracking.timeouts = stage.timeouts;
        m.tracking.lost_s = stage.lost_s;
        m.duration_s = last_t - first_t.unwrap_or(last_t);
        m.targets = recorder.edit_loop.doc.targets().len();
        m.strokes = recorder.edit_loop.doc.strokes().len();
        let solids = recorder.edit_loop.doc.solids();
        m.solids = (!solids.is_empty()).then(|| SolidMetrics {
            targets: solids.len(),
            strokes: solids.iter().map(|s| s.solid.cuts().len()).sum(),
            euler: solids
                .iter()
                .map(|s| sculpt_core::solid::euler_characteristic(&s.solid.mesh()))
                .collect(),
        });
        let stroke_apply_us = std::mem::take(&mut recorder.timer.stroke_apply_us);
        let mut sorted = stroke_apply_us.clone();
        sorted.sort_by(f64::total_cmp);
        let timing = Timing {
            stroke_apply_median_us: sculpt_core::percentile::median(&sorted).unwrap_or(0.0),
            stroke_apply_max_us: sorted.last().copied().unwrap_or(0.0),
            stroke_apply_us,
            ..Timing::default()
        };
        Outcome {
            document: recorder.edit_loop.doc,
            oplog: recorder.oplog.take(),
            metrics: recorder.metrics,
            timing,
        }
    }
}

impl Recorder {
    /// Logs one operator event in its mode's segment; times are monotone by
    /// construction, and a refused event is dropped.
    fn log(&mut self, t: f64, kind: EventKind) {
        for k in self.segments.marked(t, kind) {
            let _ = self.oplog.push(t, k);
        }
    }

    /// Counts what a step of the edit loop did into the metrics and logs its operator
    /// events.
    fn record(&mut self, step: &Step) {
        if step.resumed {
            self.metrics.gestures.resumed += 1;
        }
        if step.glitch {
            self.metrics.tracking.glitches += 1;
        }
        for event in &step.events {
            match event {
                LoopEvent::Operator { t, event } => {
                    let g = &mut self.metrics.gestures;
                    if let OperatorEvent::GestureEnd {
                        reason, dropped, ..
                    } = event
                    {
                        match (reason, dropped) {
                            (EndReason::TrackingLost, _) => g.ended_by_loss += 1,
                            (
                                EndReason::Released,
                                Some(
                                    StrokeRejection::TooShort { .. }
                                    | StrokeRejection::TooFewRows { .. },
                                ),
                            ) => g.too_short += 1,
                            _ => {}
                        }
                    }
                    self.log(*t, editor::oplog_event(event));
                }
                LoopEvent::Edit { edit, applied } => self.applied(edit, applied, step.t),
            }
        }
    }

    /// Counts one applied edit, caused at time `t`.
    fn applied(&mut self, edit: &Edit, applied: &Applied, t: f64) {
        if let (
            Edit::Stroke(s),
            Applied::Stroke {
                id,
                target,
                pieces,
                dropped,
            },
        ) = (edit, applied)
        {
            self.stroke_applied(s, (*id, *target), (*pieces, *dropped), t);
        }
        if let Some(kind) = editor::oplog_applied(applied) {
            self.log(t, kind);
        }
        let g = &mut self.metrics.gestures;
        match applied {
            Applied::Stroke { .. } => g.strokes_applied += 1,
            Applied::Sketch { .. } => g.sketches += 1,
            Applied::Deform { .. } => g.deforms += 1,
            Applied::Paint { .. } => g.paints += 1,
            Applied::Undone => g.undos += 1,
            Applied::Redone => g.redos += 1,
            Applied::Unchanged => {}
            Applied::Rejected(e) => {
                if matches!(edit, Edit::Stroke(_)) {
                    g.strokes_rejected += 1;
                }
                self.metrics.rejected.push(Rejection {
                    at_s: t,
                    reason: e.clone(),
                });
            }
        }
        if applied.changed() {
            self.metrics.operations += 1;
        }
    }

    fn stroke_applied(
        &mut self,
        s: &StrokeEdit,
        (id, target): (StrokeId, TargetId),
        (pieces, dropped_pieces): (usize, usize),
        t: f64,
    ) {
        let n = s.samples.len();
        let (start_s, end_s) = (s.samples[0].t, s.samples[n - 1].t);
        self.metrics.per_stroke.push(StrokeMetrics {
            id,
            target,
            mode: match s.mode {
                StrokeMode::Carve => "carve",
                StrokeMode::Emboss => "emboss",
            },
            profile: match s.tool.profile {
                Profile::V => "v",
                Profile::U => "u",
                Profile::Custom(_) => "custom",
            },
            samples: n,
            start_s,
            end_s,
            length_m: s
                .samples
                .windows(2)
                .map(|w| (w[1].position - w[0].position).length())
                .sum(),
            pieces,
            dropped_pieces,
            apply_latency_ms: (t - end_s) * 1000.0,
        });
    }
}

/// Replays a whole pose log (its bytes) from `base`, as fast as possible or, with
/// `realtime`, paced by the records' times; `progress` is called with (lines read,
/// total lines) every few hundred records. The outcome does not depend on the pacing.
pub fn replay_log(
    bytes: &[u8],
    cfg: &ReplayConfig,
    base: Document,
    session: &str,
    realtime: bool,
    progress: Option<&mut dyn FnMut(u64, u64)>,
) -> Result<Outcome> {
    run_log(
        bytes,
        cfg,
        base,
        session,
        realtime,
        progress,
        &[],
        &mut |_, _| Ok(()),
    )
}

/// Replays like [`replay_log`] and calls `at(t, replayer)` once for each of the sorted
/// session times `times` (seconds since the first frame): at the first frame at or
/// after `t`, or at the end for times past it. `--render` uses it.
pub fn replay_log_rendering(
    bytes: &[u8],
    cfg: &ReplayConfig,
    base: Document,
    session: &str,
    times: &[f64],
    at: &mut dyn FnMut(f64, &Replayer) -> Result<()>,
) -> Result<Outcome> {
    run_log(bytes, cfg, base, session, false, None, times, at)
}

/// `base` with the solid target the pose log's header names added, as part of the
/// base (never undone), when it names one ([`tracking::poselog::SessionSolid`]).
pub fn with_session_solid(
    mut base: Document,
    header: &tracking::poselog::PoseLogHeader,
) -> Result<Document> {
    if let Some(s) = &header.solid {
        base.add_solid(&s.name, &s.model, s.cells)
            .map_err(|source| Error::SessionSolid {
                name: s.name.clone(),
                source,
            })?;
        base.seal_history();
    }
    Ok(base)
}

#[allow(clippy::too_many_arguments)]
fn run_log(
    bytes: &[u8],
    cfg: &ReplayConfig,
    base: Document,
    session: &str,
    realtime: bool,
    mut progress: Option<&mut dyn FnMut(u64, u64)>,
    times: &[f64],
    at: &mut dyn FnMut(f64, &Replayer) -> Result<()>,
) -> Result<Outcome> {
    let started = Instant::now();
    let mut reader = PoseLogReader::new(bytes)?;
    let base = with_session_solid(base, reader.header())?;
    let mut replayer = Replayer::new(cfg, base, session)?;
    let mut corrupt = 0;
    let mut due = times.iter().copied().peekable();
    let total = bytes.iter().filter(|&&b| b == b'\n').count() as u64;
    for (k, item) in reader.by_ref().enumerate() {
        match item {
            Ok(rec) => {
                if realtime {
                    // Pace by the log's clock; the results do not depend on it.
                    let due = started + rec.time;
                    let now = Instant::now();
                    if due > now {
                        std::thread::sleep(due - now);
                    }
                }
                replayer.feed(&rec);
                while let Some(t) = due.next_if(|&t| t <= replayer.elapsed()) {
                    at(t, &replayer)?;
                }
            }
            Err(tracking::TrackingError::PoseLogLine { .. }) => corrupt += 1,
            Err(e) => return Err(Error::Tracking(e)),
        }
        if k % 256 == 0
            && let Some(cb) = progress.as_mut()
        {
            cb((k as u64 + 2).min(total), total);
        }
    }
    for t in due {
        at(t, &replayer)?;
    }
    let truncated = reader.truncated_tail();
    let mut outcome = replayer.finish(corrupt, truncated);
    let wall = started.elapsed().as_secs_f64();
    outcome.timing.replay_wall_s = wall;
    outcome.timing.speed_ratio = if wall > 0.0 {
        outcome.metrics.duration_s / wall
    } else {
        0.0
    };
    if let Some(cb) = progress.as_mut() {
        cb(total, total);
    }
    Ok(outcome)
}
