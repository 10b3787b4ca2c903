//! The operator event log: what a sculpting session did, event by event.
//!
//! The interaction state machine and `replay` write one of these per session; the
//! GOMS/KLM harness (`sculpt-tools goms`) reads them back to find the operators
//! (pointing, button presses, mental pauses) and their timing.
//!
//! # Format (version 1)
//!
//! JSON Lines, UTF-8, one object per line, `\n` line ends:
//!
//! 1. a **header** line: `{"format":"wandsculpt-oplog","version":1, ...}` with optional
//!    `participant`, `method`, `trial`, `source` and a free `meta` string map;
//! 2. one **event** per line: `{"t":1.25,"ev":"<kind>", ...fields}` where `t` is seconds,
//!    monotonic (never decreasing) from the session start.
//!
//! | `ev` | fields | meaning |
//! |---|---|---|
//! | `pose` | `p: [x,y,z]` metres (display frame), `q: [x,y,z,w]` | a wand pose sample |
//! | `button` | `id: u8`, `down: bool` | a button edge |
//! | `key` | `key: string` (`Ctrl+Z`, `2`, `Tab`, `MouseRight`, `Wheel`, ...) | a desktop key press, or a press of a mouse button other than the wand's or a wheel notch (a keystroke; no release is logged) |
//! | `mode` | `mode: string` (`sketch`, `carve`, `emboss`, ...) | interaction mode change |
//! | `tool` | `tool: string` (`v-chisel`, `u-chisel`, ...) | tool change |
//! | `stroke_start`, `stroke_end` | | a stroke begins / ends |
//! | `undo`, `redo`, `save` | | document commands |
//! | `tracking` | `state: "tracked" \| "coasting" \| "lost"` | tracking state change |
//! | `target` | `id: string`, `p: [x,y,z]`, `width: f64` metres | the selectable target under the wand (for Fitts' law) |
//! | `marker` | `label: string` | a free-form marker |
//! | `trial_start` | `trial: u32`, optional `task: string`, optional `method: string` | a trial (or segment) begins; `method` overrides the header's for it |
//! | `trial_end` | `trial: u32` | a trial ends |
//!
//! Writing is one [`OpLogWriter::push`] (or [`encode_line`]) per event into a byte
//! buffer; nothing is flushed until the caller [`OpLogWriter::take`]s the bytes.
//! Reading ([`decode`]) reports the first bad line with its 1-based number through
//! [`Error::OpLog`]; a last line without its `\n` that does not parse is taken as a
//! write cut short by a crash and dropped (see [`OpLog::truncated_tail`]). Unknown
//! fields are ignored; an unknown `ev`, a time going backwards, a zero quaternion or a
//! header of a newer version is an error. Quaternions are normalised on reading.
//!
//! ```
//! use sculpt_core::oplog::{self, EventKind, OpLogHeader, OpLogWriter};
//! use glam::{DQuat, DVec3};
//!
//! let mut w = OpLogWriter::new(&OpLogHeader::new().with_participant("P1"));
//! w.push(0.0, EventKind::Pose { p: DVec3::new(0.0, 1.2, -0.5), q: DQuat::IDENTITY }).unwrap();
//! w.push(0.4, EventKind::Button { id: 0, down: true }).unwrap();
//! w.push(0.5, EventKind::Button { id: 0, down: false }).unwrap();
//! let bytes = w.take();
//!
//! let log = oplog::decode_bytes(&bytes).unwrap();
//! assert_eq!(log.header.participant.as_deref(), Some("P1"));
//! assert_eq!(log.events.len(), 3);
//! assert!(oplog::decode("{\"format\":\"wandsculpt-oplog\",\"version\":1}\n{\"t\":1}\n").is_err());
//! ```

use std::collections::BTreeMap;

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use crate::error::OpLogError;
use crate::{Error, Result};

/// The `format` value of every header line.
pub const FORMAT: &str = "wandsculpt-oplog";
/// The format version this code writes and the newest it reads.
pub const VERSION: u32 = 1;
/// Longest accepted line in bytes (a pose line is about 150).
pub const MAX_LINE_BYTES: usize = 64 * 1024;

/// The first line of a log: what it is and whose session it records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OpLogHeader {
    /// Always [`FORMAT`].
    pub format: String,
    /// Format version, at most [`VERSION`].
    pub version: u32,
    /// Study participant id, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub participant: Option<String>,
    /// Interaction method (study condition) id, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Trial number, when the whole log is one trial.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trial: Option<u32>,
    /// What wrote the log (`wandsculpt`, `replay`, `synthetic`, ...).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Free key/value metadata.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub meta: BTreeMap<String, String>,
}

impl Default for OpLogHeader {
    fn default() -> Self {
        Self::new()
    }
}

impl OpLogHeader {
    /// A header of the current version with no metadata.
    pub fn new() -> Self {
        Self {
            format: FORMAT.to_owned(),
            version: VERSION,
            participant: None,
            method: None,
            trial: None,
            source: None,
            meta: BTreeMap::new(),
        }
    }

    /// Sets the participant id.
    pub fn with_participant(mut self, participant: impl Into<String>) -> Self {
        self.participant = Some(participant.into());
        self
    }

    /// Sets the method id.
    pub fn with_method(mut self, method: impl Into<String>) -> Self {
        self.method = Some(method.into());
        self
    }

    /// Sets the trial number.
    pub fn with_trial(mut self, trial: u32) -> Self {
        self.trial = Some(trial);
        self
    }

    /// Sets the writer's name.
    pub fn with_source(mut self, source: impl Into<String>) -> Self {
        self.source = Some(source.into());
        self
    }
}

/// Tracking quality as the tracking layer reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrackingState {
    /// Poses are measured.
    Tracked,
    /// Poses are predicted for a short gap.
    Coasting,
    /// No pose.
    Lost,
}

/// What happened at one instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "ev", rename_all = "snake_case")]
pub enum EventKind {
    /// A wand pose sample: position `p` in metres in the display frame,
    /// orientation `q` (display from wand), serialised as `[x, y, z, w]`.
    Pose {
        /// Wand position, metres, display frame.
        p: DVec3,
        /// Wand orientation, display from wand.
        q: DQuat,
    },
    /// A button edge.
    Button {
        /// Button id (0 is the trigger).
        id: u8,
        /// True on press, false on release.
        down: bool,
    },
    /// A desktop key press, or a mouse button other than the wand's or a wheel notch
    /// (a keystroke: the press; no release is logged).
    Key {
        /// The key as the key help shows it (`Ctrl+Z`, `2`, `Tab`, ...).
        key: String,
    },
    /// The interaction mode changed (`sketch`, `carve`, `emboss`, ...).
    Mode {
        /// New mode name.
        mode: String,
    },
    /// The active tool changed (`v-chisel`, `u-chisel`, ...).
    Tool {
        /// New tool name.
        tool: String,
    },
    /// A stroke begins.
    StrokeStart,
    /// A stroke ends.
    StrokeEnd,
    /// Undo.
    Undo,
    /// Redo.
    Redo,
    /// The document was saved.
    Save,
    /// Tracking state changed.
    Tracking {
        /// New state.
        state: TrackingState,
    },
    /// The selectable target under the wand, for Fitts' law analysis.
    Target {
        /// Target id (menu item, handle, surface ...).
        id: String,
        /// Target centre, metres, display frame.
        p: DVec3,
        /// Target width, metres.
        width: f64,
    },
    /// A free-form marker.
    Marker {
        /// Marker text.
        label: String,
    },
    /// A trial begins.
    TrialStart {
        /// Trial number.
        trial: u32,
        /// Task name, when the study has several.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        task: Option<String>,
        /// The method of this trial, when it is not the header's (a session segment
        /// after a mode switch).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        method: Option<String>,
    },
    /// A trial ends.
    TrialEnd {
        /// Trial number.
        trial: u32,
    },
}

/// One timestamped event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OpEvent {
    /// Seconds since the session start, monotonic.
    pub t: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: EventKind,
}

/// A whole decoded log.
#[derive(Debug, Clone, PartialEq)]
pub struct OpLog {
    /// The header line.
    pub header: OpLogHeader,
    /// Events in file order (times never decrease).
    pub events: Vec<OpEvent>,
    /// True when an unterminated, unreadable last line was dropped.
    pub truncated_tail: bool,
}

fn err(line: usize, reason: OpLogError) -> Error {
    Error::OpLog { line, reason }
}

/// Encodes the header as one line, `\n` included.
pub fn encode_header(header: &OpLogHeader) -> String {
    let mut s = serde_json::to_string(header).unwrap_or_default();
    s.push('\n');
    s
}

/// Appends one event as a line (with its `\n`) to `out`. Does not validate; see
/// [`OpLogWriter::push`] for a checked writer.
pub fn encode_line(event: &OpEvent, out: &mut Vec<u8>) {
    // Serialising these plain structs into a Vec cannot fail except on non-finite
    // floats, which serde_json writes as `null` (and the reader rejects).
    if serde_json::to_writer(&mut *out, event).is_ok() {
        out.push(b'\n');
    }
}

/// Encodes a whole log.
pub fn encode(log: &OpLog) -> Vec<u8> {
    let mut out = encode_header(&log.header).into_bytes();
    for e in &log.events {
        encode_line(e, &mut out);
    }
    out
}

/// A checked, buffered writer: validates each event and appends its line.
#[derive(Debug, Clone)]
pub struct OpLogWriter {
    buf: Vec<u8>,
    last_t: f64,
    lines: usize,
}

impl OpLogWriter {
    /// Starts a log with its header line.
    pub fn new(header: &OpLogHeader) -> Self {
        Self {
            buf: encode_header(header).into_bytes(),
            last_t: 0.0,
            lines: 1,
        }
    }

    /// Appends one event at time `t` (seconds from session start).
    ///
    /// Fails, writing nothing, when `t` is not finite, negative or earlier than the
    /// previous event, or when the event holds a non-finite number.
    pub fn push(&mut self, t: f64, kind: EventKind) -> Result<()> {
        let line = self.lines + 1;
        if !t.is_finite() || t < 0.0 {
            return Err(err(line, OpLogError::BadTime { t }));
        }
        if t < self.last_t {
            return Err(err(
                line,
                OpLogError::TimeBackwards {
                    t,
                    previous: self.last_t,
                },
            ));
        }
        let event = OpEvent { t, kind };
        validate(&event).map_err(|r| err(line, r))?;
        encode_line(&event, &mut self.buf);
        self.last_t = t;
        self.lines = line;
        Ok(())
    }

    /// Takes the bytes written so far (header included the first time), leaving the
    /// buffer empty; call it to stream the log to a file.
    pub fn take(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.buf)
    }

    /// The bytes not yet taken.
    pub fn pending(&self) -> &[u8] {
        &self.buf
    }

    /// Number of lines written, header included.
    pub fn lines(&self) -> usize {
        self.lines
    }
}

/// Cuts a plain session's log into segments, one per interaction mode, so that the
/// GOMS harness counts each operator under the mode it was made in: the log opens with
/// `trial_start {trial: 1, method: <start mode>}` at its first event, and each mode
/// switch ends the segment and starts the next (`trial_end`, then `trial_start` with
/// the new mode as its `method`, numbered per mode), both at the switch's time. A
/// segment starts at its first event, not at time zero (a live session's clock is the
/// tracker's), and a switch before any event leaves no empty segment. The display
/// server and `replay` both write their plain logs through it; in a study the study's
/// trials are the segments instead.
#[derive(Debug, Clone)]
pub struct ModeSegments {
    /// The open segment: its method and number.
    open: (String, u32),
    /// Segments started per method.
    started: BTreeMap<String, u32>,
    /// Whether the open segment's `trial_start` has been handed out.
    begun: bool,
    /// The latest event time seen.
    last_t: f64,
}

impl ModeSegments {
    /// Segments for a session that starts in mode `method`.
    pub fn new(method: &str) -> Self {
        Self {
            open: (method.to_owned(), 1),
            started: BTreeMap::from([(method.to_owned(), 1)]),
            begun: false,
            last_t: 0.0,
        }
    }

    /// The segment events to log at `t` just before `kind` (also at `t`): the open
    /// segment's `trial_start` before its first event, and at a `mode` event that
    /// switches mode, the `trial_end` of the segment and the next one's start. Nothing
    /// for an event the writer will refuse (time not finite or going back).
    pub fn before(&mut self, t: f64, kind: &EventKind) -> Vec<EventKind> {
        if !t.is_finite() || t < self.last_t {
            return Vec::new();
        }
        self.last_t = t;
        let mut out = Vec::new();
        if let EventKind::Mode { mode } = kind
            && *mode != self.open.0
        {
            if self.begun {
                out.push(EventKind::TrialEnd { trial: self.open.1 });
            } else if let Some(n) = self.started.get_mut(&self.open.0) {
                // Nothing in the segment yet: it is not counted.
                *n -= 1;
            }
            let n = self.started.entry(mode.clone()).or_insert(0);
            *n += 1;
            self.open = (mode.clone(), *n);
            self.begun = false;
        }
        if !self.begun {
            self.begun = true;
            out.push(EventKind::TrialStart {
                trial: self.open.1,
                task: None,
                method: Some(self.open.0.clone()),
            });
        }
        out
    }

    /// Every line to log at `t` for `kind`, in order: the segment events
    /// ([`ModeSegments::before`]), then `kind` itself. The display server's operator
    /// log and `replay`'s both write through this.
    pub fn marked(&mut self, t: f64, kind: EventKind) -> Vec<EventKind> {
        let mut out = self.before(t, &kind);
        out.push(kind);
        out
    }
}

/// Checks one event's values; the reason when it is bad.
fn validate(e: &OpEvent) -> std::result::Result<(), OpLogError> {
    match &e.kind {
        EventKind::Pose { p, q } => {
            if !p.is_finite() {
                return Err(OpLogError::PosePosition { p: *p });
            }
            if !q.is_finite() || q.length() < crate::tolerance::ZERO_QUAT_LEN {
                return Err(OpLogError::PoseOrientation { q: *q });
            }
        }
        EventKind::Target { p, width, .. } => {
            if !p.is_finite() {
                return Err(OpLogError::TargetPosition { p: *p });
            }
            if !width.is_finite() || *width <= 0.0 {
                return Err(OpLogError::TargetWidth { width: *width });
            }
        }
        _ => {}
    }
    Ok(())
}

/// Decodes logs line by line (for streaming readers); [`decode`] uses it.
#[derive(Debug, Clone, Default)]
pub struct LineDecoder {
    line: usize,
    last_t: f64,
    header: Option<OpLogHeader>,
}

impl LineDecoder {
    /// A decoder expecting the header line next.
    pub fn new() -> Self {
        Self::default()
    }

    /// The header, once its line was read.
    pub fn header(&self) -> Option<&OpLogHeader> {
        self.header.as_ref()
    }

    /// Number of the last line fed (1-based).
    pub fn line(&self) -> usize {
        self.line
    }

    /// Feeds one line (without its `\n`). Returns the event it holds, or `None` for the
    /// header and blank lines.
    pub fn feed(&mut self, text: &str) -> Result<Option<OpEvent>> {
        self.line += 1;
        let line = self.line;
        if text.len() > MAX_LINE_BYTES {
            return Err(err(
                line,
                OpLogError::LineTooLong {
                    bytes: text.len(),
                    max: MAX_LINE_BYTES,
                },
            ));
        }
        let text = text.trim_end_matches('\r');
        if text.trim().is_empty() {
            return Ok(None);
        }
        if self.header.is_none() {
            let header: OpLogHeader = serde_json::from_str(text).map_err(|e| {
                err(
                    line,
                    OpLogError::Header {
                        format: FORMAT,
                        error: e.into(),
                    },
                )
            })?;
            if header.format != FORMAT {
                return Err(err(
                    line,
                    OpLogError::Format {
                        found: crate::error::Excerpt::new(&header.format),
                        expected: FORMAT,
                    },
                ));
            }
            if header.version == 0 || header.version > VERSION {
                return Err(err(
                    line,
                    OpLogError::Version {
                        found: header.version,
                        supported: VERSION,
                    },
                ));
            }
            self.header = Some(header);
            return Ok(None);
        }
        let mut event: OpEvent =
            serde_json::from_str(text).map_err(|e| err(line, OpLogError::Event(e.into())))?;
        if !event.t.is_finite() || event.t < 0.0 {
            return Err(err(line, OpLogError::NegativeTime { t: event.t }));
        }
        if event.t < self.last_t {
            return Err(err(
                line,
                OpLogError::TimeBackwards {
                    t: event.t,
                    previous: self.last_t,
                },
            ));
        }
        validate(&event).map_err(|r| err(line, r))?;
        // Normalise only quaternions that need it: one already of unit length (to
        // rounding) is kept bit for bit, so reading and re-writing a log is a fixed
        // point (found by the `operator_log` fuzz target).
        if let EventKind::Pose { q, .. } = &mut event.kind
            && (q.length_squared() - 1.0).abs() > crate::tolerance::EXACT_EPS
        {
            *q = q.normalize();
        }
        self.last_t = event.t;
        Ok(Some(event))
    }
}

/// Decodes a whole log from text.
pub fn decode(text: &str) -> Result<OpLog> {
    let mut dec = LineDecoder::new();
    let mut events = Vec::new();
    let mut truncated_tail = false;
    let ends_with_newline = text.ends_with('\n');
    let mut lines = text.split('\n').peekable();
    while let Some(line) = lines.next() {
        let is_last = lines.peek().is_none();
        if is_last && ends_with_newline {
            // The empty piece after the final '\n'.
            break;
        }
        match dec.feed(line) {
            Ok(Some(e)) => events.push(e),
            Ok(None) => {}
            Err(_) if is_last && dec.header.is_some() && !line.is_empty() => {
                // An unterminated last line that does not parse: a cut-short write.
                truncated_tail = true;
            }
            Err(e) => return Err(e),
        }
    }
    let header = dec
        .header
        .ok_or_else(|| err(dec.line.max(1), OpLogError::Empty))?;
    Ok(OpLog {
        header,
        events,
        truncated_tail,
    })
}

/// Decodes a whole log from bytes; invalid UTF-8 is reported with its line.
pub fn decode_bytes(bytes: &[u8]) -> Result<OpLog> {
    match std::str::from_utf8(bytes) {
        Ok(text) => decode(text),
        Err(e) => {
            let good = &bytes[..e.valid_up_to()];
            let line = good.iter().filter(|&&b| b == b'\n').count() + 1;
            let rest_has_newline = bytes[e.valid_up_to()..].contains(&b'\n');
            if !rest_has_newline && line > 1 {
                // The bad bytes are in the unterminated last line: a cut-short write
                // (possibly mid-character). Drop it like any truncated tail.
                let cut = good.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
                let text = std::str::from_utf8(&bytes[..cut]).unwrap_or_default();
                let mut log = decode(text)?;
                log.truncated_tail = true;
                return Ok(log);
            }
            Err(err(line, OpLogError::NotUtf8))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Regression (found by the `operator_log` fuzz target): the reader normalised every
    /// quaternion, so reading and re-writing a recorded log changed its last digits, again
    /// on every pass.
    #[test]
    fn regression_reading_and_rewriting_a_log_is_a_fixed_point() {
        let recorded = concat!(
            "{\"format\":\"wandsculpt-oplog\",\"version\":1,\"method\":\"carve\"}\n",
            "{\"t\":0.05,\"ev\":\"pose\",\"p\":[0.0,1.17,0.02],\"q\":[0.000021019118340507596,",
            "-0.00010847112180698752,-0.00006817938258199037,0.9999999915718922]}\n",
        );
        let once = encode(&decode(recorded).unwrap());
        let twice = encode(&decode_bytes(&once).unwrap());
        assert_eq!(
            String::from_utf8_lossy(&once),
            String::from_utf8_lossy(&twice)
        );
        assert_eq!(once, recorded.as_bytes());
    }

    fn sample() -> OpLog {
        let events = vec![
            OpEvent {
                t: 0.0,
                kind: EventKind::TrialStart {
                    trial: 1,
                    task: Some("carve".into()),
                    method: Some("wall".into()),
                },
            },
            OpEvent {
                t: 0.01,
                kind: EventKind::Pose {
                    p: DVec3::new(0.1, 1.2, -0.3),
                    q: DQuat::from_rotation_y(0.3),
                },
            },
            OpEvent {
                t: 0.5,
                kind: EventKind::Button { id: 0, down: true },
            },
            OpEvent {
                t: 0.6,
                kind: EventKind::Button { id: 0, down: false },
            },
            OpEvent {
                t: 0.7,
                kind: EventKind::Key { key: "2".into() },
            },
            OpEvent {
                t: 0.7,
                kind: EventKind::Mode {
                    mode: "carve".into(),
                },
            },
            OpEvent {
                t: 0.7,
                kind: EventKind::Tool {
                    tool: "v-chisel".into(),
                },
            },
            OpEvent {
                t: 0.8,
                kind: EventKind::StrokeStart,
            },
            OpEvent {
                t: 0.9,
                kind: EventKind::StrokeEnd,
            },
            OpEvent {
                t: 1.0,
                kind: EventKind::Undo,
            },
            OpEvent {
                t: 1.1,
                kind: EventKind::Redo,
            },
            OpEvent {
                t: 1.2,
                kind: EventKind::Save,
            },
            OpEvent {
                t: 1.3,
                kind: EventKind::Tracking {
                    state: TrackingState::Lost,
                },
            },
            OpEvent {
                t: 1.4,
                kind: EventKind::Target {
                    id: "menu.carve".into(),
                    p: DVec3::new(0.0, 1.5, -0.6),
                    width: 0.05,
                },
            },
            OpEvent {
                t: 1.5,
                kind: EventKind::Marker {
                    label: "hello \"world\"\n".into(),
                },
            },
            OpEvent {
                t: 2.0,
                kind: EventKind::TrialEnd { trial: 1 },
            },
        ];
        OpLog {
            header: OpLogHeader::new()
                .with_participant("P1")
                .with_method("sculpt")
                .with_trial(1)
                .with_source("test"),
            events,
            truncated_tail: false,
        }
    }

    /// Issue 19: a plain log is one segment per mode, for the display server and
    /// `replay` alike (replay's log kept the start mode's segment after a switch). A
    /// switch before any event leaves no empty segment; segments are numbered per mode;
    /// an event going back in time gets no marks.
    #[test]
    fn mode_segments_open_at_the_first_event_and_cut_at_each_switch() {
        let mode = |m: &str| EventKind::Mode { mode: m.to_owned() };
        let start = |trial, m: &str| EventKind::TrialStart {
            trial,
            task: None,
            method: Some(m.to_owned()),
        };
        let press = EventKind::Button { id: 0, down: true };
        let mut seg = ModeSegments::new("carve");
        // Switched away before anything happened in carve: no carve segment.
        assert_eq!(seg.before(5.0, &mode("emboss")), vec![start(1, "emboss")]);
        assert_eq!(seg.before(5.5, &press), vec![]);
        assert_eq!(seg.before(6.0, &mode("emboss")), vec![], "not a switch");
        assert_eq!(
            seg.before(7.0, &mode("carve")),
            vec![EventKind::TrialEnd { trial: 1 }, start(1, "carve")]
        );
        assert_eq!(seg.before(6.5, &mode("emboss")), vec![], "time going back");
        assert_eq!(
            seg.before(8.0, &mode("emboss")),
            vec![EventKind::TrialEnd { trial: 1 }, start(2, "emboss")]
        );
        // Through a writer, the marks come out at the events' times.
        let mut seg = ModeSegments::new("sketch");
        let mut w = OpLogWriter::new(&OpLogHeader::new().with_method("sketch"));
        for (t, k) in [(2.0, press.clone()), (3.0, mode("carve")), (4.0, press)] {
            for m in seg.before(t, &k) {
                w.push(t, m).unwrap();
            }
            w.push(t, k).unwrap();
        }
        let log = decode_bytes(w.pending()).unwrap();
        let kinds: Vec<(f64, &str)> = log
            .events
            .iter()
            .map(|e| {
                let k = match &e.kind {
                    EventKind::TrialStart { .. } => "start",
                    EventKind::TrialEnd { .. } => "end",
                    EventKind::Mode { .. } => "mode",
                    _ => "press",
                };
                (e.t, k)
            })
            .collect();
        assert_eq!(
            kinds,
            [
                (2.0, "start"),
                (2.0, "press"),
                (3.0, "end"),
                (3.0, "start"),
                (3.0, "mode"),
                (4.0, "press")
            ]
        );
    }

    #[test]
    fn round_trip_every_event_kind() {
        let log = sample();
        let bytes = encode(&log);
        let back = decode_bytes(&bytes).unwrap();
        assert_eq!(back.header, log.header);
        assert_eq!(back.events.len(), log.events.len());
        for (a, b) in back.events.iter().zip(&log.events) {
            match (&a.kind, &b.kind) {
                (EventKind::Pose { p: pa, q: qa }, EventKind::Pose { p: pb, q: qb }) => {
                    crate::assert_near!(pa.to_array(), pb.to_array(), crate::tolerance::EXACT_EPS);
                    crate::assert_near!(qa.to_array(), qb.to_array(), crate::tolerance::EXACT_EPS);
                }
                _ => assert_eq!(a, b),
            }
        }
        assert!(!back.truncated_tail);
    }

    #[test]
    fn wire_format_is_documented_shape() {
        let mut out = Vec::new();
        encode_line(
            &OpEvent {
                t: 1.5,
                kind: EventKind::Button { id: 2, down: true },
            },
            &mut out,
        );
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "{\"t\":1.5,\"ev\":\"button\",\"id\":2,\"down\":true}\n"
        );
        let h = encode_header(&OpLogHeader::new());
        assert_eq!(h, "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n");
        let mut out = Vec::new();
        for kind in [
            EventKind::Key {
                key: "Ctrl+Z".into(),
            },
            EventKind::TrialStart {
                trial: 2,
                task: None,
                method: Some("emboss".into()),
            },
        ] {
            encode_line(&OpEvent { t: 0.5, kind }, &mut out);
        }
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "{\"t\":0.5,\"ev\":\"key\",\"key\":\"Ctrl+Z\"}\n\
             {\"t\":0.5,\"ev\":\"trial_start\",\"trial\":2,\"method\":\"emboss\"}\n"
        );
    }

    #[test]
    fn truncated_last_line_is_tolerated() {
        let mut bytes = encode(&sample());
        bytes.truncate(bytes.len() - 10);
        let log = decode_bytes(&bytes).unwrap();
        assert!(log.truncated_tail);
        assert_eq!(log.events.len(), sample().events.len() - 1);
    }

    #[test]
    fn bad_line_in_the_middle_names_its_line() {
        let text = "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n{\"t\":0.1,\"ev\":\"undo\"}\n{\"t\":0.2,\"ev\":\"warp\"}\n{\"t\":0.3,\"ev\":\"redo\"}\n";
        match decode(text) {
            Err(Error::OpLog { line, reason }) => {
                assert_eq!(line, 3);
                assert!(matches!(reason, OpLogError::Event(_)), "{reason:?}");
                assert!(reason.to_string().contains("warp"), "{reason}");
            }
            other => panic!("expected an oplog error, got {other:?}"),
        }
    }

    #[test]
    fn time_going_backwards_is_an_error() {
        let text = "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n{\"t\":0.5,\"ev\":\"undo\"}\n{\"t\":0.2,\"ev\":\"redo\"}\n";
        let e = decode(text).unwrap_err();
        assert_eq!(
            e,
            Error::OpLog {
                line: 3,
                reason: OpLogError::TimeBackwards {
                    t: 0.2,
                    previous: 0.5
                }
            }
        );
        assert_eq!(
            e.to_string(),
            "operator log line 3: time goes backwards: 0.2 after 0.5"
        );
    }

    #[test]
    fn header_problems() {
        assert!(matches!(decode(""), Err(Error::OpLog { line: 1, .. })));
        assert!(matches!(
            decode("{\"format\":\"other\",\"version\":1}\n"),
            Err(Error::OpLog { line: 1, .. })
        ));
        let e = decode("{\"format\":\"wandsculpt-oplog\",\"version\":9}\n").unwrap_err();
        assert!(e.to_string().contains("version 9"), "{e}");
        // A header alone is an empty, valid log.
        let log = decode("{\"format\":\"wandsculpt-oplog\",\"version\":1}\n").unwrap();
        assert!(log.events.is_empty());
    }

    #[test]
    fn zero_quaternion_and_bad_width_are_errors() {
        let h = "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n";
        let q0 = format!("{h}{{\"t\":0,\"ev\":\"pose\",\"p\":[0,0,0],\"q\":[0,0,0,0]}}\n");
        assert!(matches!(decode(&q0), Err(Error::OpLog { line: 2, .. })));
        let w0 =
            format!("{h}{{\"t\":0,\"ev\":\"target\",\"id\":\"a\",\"p\":[0,0,0],\"width\":-1}}\n");
        assert!(matches!(decode(&w0), Err(Error::OpLog { line: 2, .. })));
        let q2 = format!("{h}{{\"t\":0,\"ev\":\"pose\",\"p\":[0,0,0],\"q\":[0,0,0,2]}}\n");
        let log = decode(&q2).unwrap();
        let EventKind::Pose { q, .. } = log.events[0].kind else {
            panic!("not a pose")
        };
        crate::assert_near!(q.w, 1.0, crate::tolerance::EXACT_EPS);
    }

    #[test]
    fn writer_rejects_bad_events_without_writing() {
        let mut w = OpLogWriter::new(&OpLogHeader::new());
        w.push(1.0, EventKind::Save).unwrap();
        let before = w.pending().len();
        assert!(w.push(0.5, EventKind::Save).is_err());
        assert!(w.push(f64::NAN, EventKind::Save).is_err());
        assert!(
            w.push(
                2.0,
                EventKind::Pose {
                    p: DVec3::new(f64::INFINITY, 0.0, 0.0),
                    q: DQuat::IDENTITY
                }
            )
            .is_err()
        );
        assert_eq!(w.pending().len(), before);
        assert_eq!(w.lines(), 2);
        let first = w.take();
        w.push(2.0, EventKind::Undo).unwrap();
        let mut all = first;
        all.extend(w.take());
        assert_eq!(decode_bytes(&all).unwrap().events.len(), 2);
    }

    #[test]
    fn overlong_line_and_bad_utf8() {
        let h = "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n";
        let long = format!(
            "{h}{{\"t\":0,\"ev\":\"marker\",\"label\":\"{}\"}}\n",
            "x".repeat(MAX_LINE_BYTES)
        );
        assert!(matches!(decode(&long), Err(Error::OpLog { line: 2, .. })));
        let mut bytes = h.as_bytes().to_vec();
        bytes.extend_from_slice(b"{\"t\":0,\"ev\":\"undo\"}\n\xff\xfe\n");
        assert!(matches!(
            decode_bytes(&bytes),
            Err(Error::OpLog { line: 3, .. })
        ));
    }

    fn arb_kind() -> impl Strategy<Value = EventKind> {
        let f = -10.0f64..10.0;
        prop_oneof![
            (
                [f.clone(), f.clone(), f.clone()],
                [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0.1f64..1.0]
            )
                .prop_map(|(p, q)| EventKind::Pose {
                    p: DVec3::from_array(p),
                    q: DQuat::from_array(q).normalize(),
                }),
            (any::<u8>(), any::<bool>()).prop_map(|(id, down)| EventKind::Button { id, down }),
            "\\PC{0,12}".prop_map(|mode| EventKind::Mode { mode }),
            "\\PC{0,12}".prop_map(|tool| EventKind::Tool { tool }),
            Just(EventKind::StrokeStart),
            Just(EventKind::StrokeEnd),
            Just(EventKind::Undo),
            Just(EventKind::Redo),
            Just(EventKind::Save),
            prop_oneof![
                Just(TrackingState::Tracked),
                Just(TrackingState::Coasting),
                Just(TrackingState::Lost)
            ]
            .prop_map(|state| EventKind::Tracking { state }),
            // not a tolerance: the range of generated tool widths
            ("\\PC{0,8}", [f.clone(), f.clone(), f], 1e-4f64..1.0).prop_map(|(id, p, width)| {
                EventKind::Target {
                    id,
                    p: DVec3::from_array(p),
                    width,
                }
            }),
            "\\PC{0,20}".prop_map(|label| EventKind::Marker { label }),
            (
                any::<u32>(),
                proptest::option::of("\\PC{0,8}"),
                proptest::option::of("\\PC{0,8}")
            )
                .prop_map(|(trial, task, method)| EventKind::TrialStart {
                    trial,
                    task,
                    method
                }),
            "\\PC{0,8}".prop_map(|key| EventKind::Key { key }),
            any::<u32>().prop_map(|trial| EventKind::TrialEnd { trial }),
        ]
    }

    proptest! {
        #[test]
        fn encode_decode_round_trips(kinds in proptest::collection::vec((0.0f64..2.0, arb_kind()), 0..40)) {
            let mut w = OpLogWriter::new(&OpLogHeader::new().with_method("m"));
            let mut t = 0.0;
            for (dt, k) in &kinds {
                t += dt;
                w.push(t, k.clone()).unwrap();
            }
            let log = decode_bytes(&w.take()).unwrap();
            prop_assert_eq!(log.events.len(), kinds.len());
            for (e, (_, k)) in log.events.iter().zip(&kinds) {
                prop_assert_eq!(std::mem::discriminant(&e.kind), std::mem::discriminant(k));
            }
        }

        #[test]
        fn any_text_decodes_or_errors_without_panic(s in "\\PC{0,300}") {
            let _ = decode(&s);
            let with_header = format!("{{\"format\":\"wandsculpt-oplog\",\"version\":1}}\n{s}");
            match decode(&with_header) {
                Ok(log) => prop_assert!(log.events.iter().all(|e| e.t.is_finite() && e.t >= 0.0)),
                Err(Error::OpLog { line, .. }) => prop_assert!(line >= 2),
                Err(other) => prop_assert!(false, "unexpected error {other:?}"),
            }
        }

        #[test]
        fn any_cut_of_a_valid_log_is_tolerated(cut in 0usize..2000) {
            let bytes = encode(&sample());
            let header_len = encode_header(&sample().header).len();
            let cut = header_len + cut % (bytes.len() - header_len + 1);
            let log = decode_bytes(&bytes[..cut]).unwrap();
            prop_assert!(log.events.len() <= sample().events.len());
        }

        #[test]
        fn any_bytes_never_panic(b in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = decode_bytes(&b);
        }
    }
}
