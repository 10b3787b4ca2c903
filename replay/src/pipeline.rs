//! The replay pipeline: pose-log records in; the sculpted document, the operator event
//! log and metrics out.
//!
//! Stages, in the order the live display server runs them:
//! 1. **decode** each DTrack2 record (`tracking::dtrack`); corrupt lines, bad frames,
//!    stale (out-of-order) frame numbers and a truncated last line are counted, not
//!    fatal;
//! 2. **calibrate** tracker millimetres into the display frame and the wand's tool tip
//!    ([`Calibration`]), then **filter** the pose (the tracking crate's One Euro
//!    filter, `[filter]` in the config);
//! 3. **tracking loss**: a wand with quality < 0, or no frame for longer than the
//!    tracking timeout, is lost (its buttons still count);
//! 4. **interaction**: the [`Driver`] turns samples into edits and operator events;
//! 5. **sculpting**: edits go to the [`Document`] (strokes through the multiresolution
//!    trimming, sketches fitted into new targets, undo and redo).
//!
//! Time is virtual: each record's receive time from the log, so a replay is
//! deterministic and runs as fast as the CPU allows.
//!
//! [`Calibration`]: crate::config::Calibration

use std::time::Instant;

use glam::{DQuat, DVec3};
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::oplog::{OpLogHeader, OpLogWriter};
use sculpt_core::sculpt::document::{Document, TargetId};
use sculpt_core::sculpt::stroke::{Mode as StrokeMode, Profile, StrokeInput, Tool};
use serde::Serialize;
use tracking::DeviceId;
use tracking::filter::PoseFilter;
use tracking::poselog::{PoseLogReader, Record, RecordKind};

use crate::config::{ProfileName, ReplayConfig};
use crate::driver::{Driver, Edit, Sample};
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
    /// Records of kinds this replay does not use (serial lines).
    pub other_kinds: usize,
    /// The log ended in the middle of a line.
    pub truncated_tail: bool,
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
    pub id: u64,
    /// Target id.
    pub target: u64,
    /// `carve` or `emboss`.
    pub mode: &'static str,
    /// `v` or `u`.
    pub profile: &'static str,
    /// Wand samples.
    pub samples: usize,
    /// First sample time, seconds.
    pub start_s: f64,
    /// Last sample time, seconds.
    pub end_s: f64,
    /// Path length, metres.
    pub length_m: f64,
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
    /// Why.
    pub reason: String,
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

pub use sculpt_core::editor::{default_document, default_surface};

/// Fits a sketched point grid: a B-spline surface of degree up to 3 with the (at most
/// 12 x 12, evenly picked) grid points as control points and clamped uniform knots.
pub fn fit_sketch(rows: &[Vec<DVec3>]) -> Result<NurbsSurface> {
    let pick = |n: usize, max: usize| -> Vec<usize> {
        if n <= max {
            (0..n).collect()
        } else {
            (0..max).map(|k| k * (n - 1) / (max - 1)).collect()
        }
    };
    let cols = rows.first().map_or(0, Vec::len);
    if rows.len() < 2 || cols < 2 || rows.iter().any(|r| r.len() != cols) {
        return Err(Error::Session(
            "a sketch needs at least a 2 x 2 grid".into(),
        ));
    }
    let ri = pick(rows.len(), 12);
    let ci = pick(cols, 12);
    let control: Vec<Vec<DVec3>> = ri
        .iter()
        .map(|&i| ci.iter().map(|&j| rows[i][j]).collect())
        .collect();
    let knots = |n: usize, p: usize| -> Vec<f64> {
        let inner = n - p - 1;
        let mut k = vec![0.0; p + 1];
        k.extend((1..=inner).map(|i| i as f64 / (inner + 1) as f64));
        k.extend(vec![1.0; p + 1]);
        k
    };
    let (nu, nv) = (control.len(), control[0].len());
    let (pu, pv) = ((nu - 1).min(3), (nv - 1).min(3));
    NurbsSurface::new(pu, pv, knots(nu, pu), knots(nv, pv), control, None)
        .map_err(|e| Error::Session(format!("sketch surface: {e}")))
}

/// Feeds records through the pipeline one at a time.
pub struct Replayer {
    cfg: ReplayConfig,
    doc: Document,
    driver: Driver,
    filter: PoseFilter,
    oplog: OpLogWriter,
    metrics: Metrics,
    timing: Timing,
    last_number: Option<u64>,
    first_t: Option<f64>,
    last_t: f64,
    lost_since: Option<f64>,
    last_sample_t: Option<f64>,
}

impl Replayer {
    /// A replayer starting from `doc` (the base scene), in the config's start mode.
    pub fn new(cfg: &ReplayConfig, doc: Document, session: &str) -> Result<Self> {
        cfg.validate()?;
        let driver = Driver::new(cfg, doc.targets().len());
        let oplog = OpLogWriter::new(
            &OpLogHeader::new()
                .with_source("replay")
                .with_method(cfg.tool.mode.name()),
        );
        Ok(Self {
            cfg: cfg.clone(),
            doc,
            driver,
            filter: PoseFilter::new(cfg.filter),
            oplog,
            metrics: Metrics {
                session: session.to_string(),
                ..Metrics::default()
            },
            timing: Timing::default(),
            last_number: None,
            first_t: None,
            last_t: 0.0,
            lost_since: None,
            last_sample_t: None,
        })
    }

    /// The document so far.
    pub fn document(&self) -> &Document {
        &self.doc
    }

    /// Feeds one pose-log record.
    pub fn feed(&mut self, rec: &Record) {
        self.metrics.frames.records += 1;
        if rec.kind != RecordKind::DTrack {
            self.metrics.frames.other_kinds += 1;
            return;
        }
        let t = rec.time.as_secs_f64();
        self.first_t.get_or_insert(t);
        // A silent gap longer than the timeout: the wand was lost from then on.
        if let Some(prev) = self.last_sample_t
            && t - prev > self.cfg.tracking.timeout
        {
            self.metrics.tracking.timeouts += 1;
            let edits = self.driver.lost(prev + self.cfg.tracking.timeout);
            self.apply_all(edits, prev + self.cfg.tracking.timeout);
        }
        self.last_t = t;
        let frame = match rec.frame() {
            Ok(f) => f,
            Err(_) => {
                self.metrics.frames.bad_frames += 1;
                return;
            }
        };
        if let Some(last) = self.last_number
            && frame.number <= last
            && last - frame.number < 10_000
        {
            self.metrics.frames.out_of_order += 1;
            return;
        }
        self.last_number = Some(frame.number);
        let Some(wand) = frame.wand(self.cfg.tracking.wand_id) else {
            self.metrics.frames.without_wand += 1;
            return;
        };
        self.metrics.frames.used += 1;
        let device = DeviceId::Wand(self.cfg.tracking.wand_id);
        let world = if wand.is_tracked() {
            self.cfg.calibration.pose_in_world(device, &wand.pose)
        } else {
            None
        };
        let sample = match world {
            Some(pose) => {
                let pose = self.filter.filter(t, pose);
                Sample {
                    t,
                    tracked: true,
                    position: pose.tool_m,
                    orientation: pose.orientation,
                    buttons: wand.buttons as u32,
                }
            }
            None => Sample {
                t,
                tracked: false,
                position: DVec3::ZERO,
                orientation: DQuat::IDENTITY,
                buttons: wand.buttons as u32,
            },
        };
        self.last_sample_t = Some(t);
        let edits = self.driver.sample(sample);
        self.apply_all(edits, t);
    }

    fn track_lost_time(&mut self, t: f64) {
        let lost_now = self.driver.losses > self.metrics.tracking.losses;
        if lost_now && self.lost_since.is_none() {
            self.lost_since = Some(t);
        }
        self.metrics.tracking.losses = self.driver.losses;
    }

    fn apply_all(&mut self, edits: Vec<Edit>, t: f64) {
        self.track_lost_time(t);
        for (et, kind) in self.driver.take_events() {
            if matches!(
                kind,
                sculpt_core::oplog::EventKind::Tracking {
                    state: sculpt_core::oplog::TrackingState::Tracked
                }
            ) && let Some(t0) = self.lost_since.take()
            {
                self.metrics.tracking.lost_s += et - t0;
            }
            // Times are monotone by construction; a refused event is dropped.
            let _ = self.oplog.push(et, kind);
        }
        for edit in edits {
            self.apply(edit, t);
        }
    }

    fn target_ids(&self) -> Vec<TargetId> {
        self.doc.targets().iter().map(|t| t.id).collect()
    }

    fn apply(&mut self, edit: Edit, t: f64) {
        match edit {
            Edit::Stroke {
                target,
                emboss,
                profile,
                samples,
                ended_at: _,
            } => {
                let ids = self.target_ids();
                let Some(&target_id) = ids.get(target) else {
                    self.metrics.gestures.strokes_rejected += 1;
                    self.metrics.rejected.push(Rejection {
                        at_s: t,
                        reason: format!("no target {target}"),
                    });
                    return;
                };
                let tool = Tool {
                    profile: match profile {
                        ProfileName::V => Profile::V,
                        ProfileName::U => Profile::U,
                    },
                    width: self.cfg.tool.width,
                    depth: self.cfg.tool.depth,
                    mode: if emboss {
                        StrokeMode::Emboss
                    } else {
                        StrokeMode::Carve
                    },
                    taper: self.cfg.tool.taper,
                };
                let n = samples.len();
                let (start_s, end_s) = (samples[0].0, samples[n - 1].0);
                let length_m = samples.windows(2).map(|w| (w[1].1 - w[0].1).length()).sum();
                let started = Instant::now();
                let result = self
                    .doc
                    .apply_stroke(target_id, StrokeInput { samples, tool });
                self.timing
                    .stroke_apply_us
                    .push(started.elapsed().as_secs_f64() * 1e6);
                match result {
                    Ok(id) => {
                        self.metrics.gestures.strokes_applied += 1;
                        self.metrics.operations += 1;
                        self.metrics.per_stroke.push(StrokeMetrics {
                            id,
                            target: target_id,
                            mode: if emboss { "emboss" } else { "carve" },
                            profile: match profile {
                                ProfileName::V => "v",
                                ProfileName::U => "u",
                            },
                            samples: n,
                            start_s,
                            end_s,
                            length_m,
                            apply_latency_ms: (t - end_s) * 1000.0,
                        });
                    }
                    Err(e) => {
                        self.metrics.gestures.strokes_rejected += 1;
                        self.metrics.rejected.push(Rejection {
                            at_s: t,
                            reason: e.to_string(),
                        });
                    }
                }
            }
            Edit::Sketch { rows, .. } => match fit_sketch(&rows) {
                Ok(surface) => {
                    let name = format!("sketch {}", self.metrics.gestures.sketches + 1);
                    self.metrics.gestures.sketches += 1;
                    self.metrics.operations += 1;
                    self.doc.add_target(&name, surface);
                    self.driver.set_target_count(self.doc.targets().len());
                }
                Err(e) => {
                    self.metrics.rejected.push(Rejection {
                        at_s: t,
                        reason: e.to_string(),
                    });
                }
            },
            Edit::Undo => {
                if self.doc.undo() {
                    self.metrics.gestures.undos += 1;
                    self.metrics.operations += 1;
                }
                self.driver.set_target_count(self.doc.targets().len());
            }
            Edit::Redo => {
                if self.doc.redo() {
                    self.metrics.gestures.redos += 1;
                    self.metrics.operations += 1;
                }
                self.driver.set_target_count(self.doc.targets().len());
            }
        }
    }

    /// Ends the session at the last record's time (a paused gesture is given its
    /// timeout) and returns the outcome.
    pub fn finish(mut self, corrupt_lines: usize, truncated_tail: bool) -> Outcome {
        let end = self.last_t + self.cfg.interaction.pause_timeout + 1e-9;
        let edits = self.driver.tick(end);
        self.apply_all(edits, end);
        if let Some(t0) = self.lost_since.take() {
            self.metrics.tracking.lost_s += self.last_t - t0;
        }
        let m = &mut self.metrics;
        m.frames.corrupt_lines = corrupt_lines;
        m.frames.truncated_tail = truncated_tail;
        m.duration_s = self.last_t - self.first_t.unwrap_or(self.last_t);
        m.tracking.glitches = self.driver.glitches;
        m.gestures.too_short = self.driver.too_short;
        m.gestures.ended_by_loss = self.driver.ended_by_loss;
        m.gestures.resumed = self.driver.resumed;
        m.targets = self.doc.targets().len();
        m.strokes = self.doc.strokes().len();
        let mut sorted = self.timing.stroke_apply_us.clone();
        sorted.sort_by(f64::total_cmp);
        self.timing.stroke_apply_median_us = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        self.timing.stroke_apply_max_us = sorted.last().copied().unwrap_or(0.0);
        Outcome {
            document: self.doc,
            oplog: self.oplog.take(),
            metrics: self.metrics,
            timing: self.timing,
        }
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
    mut progress: Option<&mut dyn FnMut(u64, u64)>,
) -> Result<Outcome> {
    let started = Instant::now();
    let mut reader = PoseLogReader::new(bytes).map_err(|e| Error::Tracking(e.to_string()))?;
    let mut replayer = Replayer::new(cfg, base, session)?;
    let mut corrupt = 0;
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
                replayer.feed(&rec)
            }
            Err(tracking::TrackingError::PoseLogLine { .. }) => corrupt += 1,
            Err(e) => return Err(Error::Tracking(e.to_string())),
        }
        if k % 256 == 0
            && let Some(cb) = progress.as_mut()
        {
            cb((k as u64 + 2).min(total), total);
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::EXACT_EPS;

    #[test]
    fn sketch_grids_fit_into_surfaces_through_their_corners() {
        let rows: Vec<Vec<DVec3>> = (0..30)
            .map(|i| {
                (0..8)
                    .map(|j| DVec3::new(j as f64 * 0.04, 1.0 + i as f64 * 0.01, 0.0))
                    .collect()
            })
            .collect();
        let s = fit_sketch(&rows).unwrap();
        assert_near!(
            s.point(0.0, 0.0).to_array(),
            rows[0][0].to_array(),
            EXACT_EPS
        );
        assert_near!(
            s.point(1.0, 1.0).to_array(),
            rows[29][7].to_array(),
            EXACT_EPS
        );
        assert!(fit_sketch(&rows[..1]).is_err());
    }
}
