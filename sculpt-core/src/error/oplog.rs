//! Why an operator event log line could not be read or an event written
//! ([`Error::OpLog`](super::Error::OpLog)).

use glam::DVec3;
use thiserror::Error;

use super::text::{Excerpt, JsonError};

/// What is wrong with an operator event log line (or an event to write).
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum OpLogError {
    /// An event time is NaN, infinite or negative.
    #[error("time {t} is not a finite, non-negative number")]
    BadTime {
        /// The time.
        t: f64,
    },
    /// A time read back is negative or not finite.
    #[error("time {t} is negative")]
    NegativeTime {
        /// The time.
        t: f64,
    },
    /// An event time is before the previous one.
    #[error("time goes backwards: {t} after {previous}")]
    TimeBackwards {
        /// The time.
        t: f64,
        /// The previous event's time.
        previous: f64,
    },
    /// A pose position is not finite.
    #[error("pose position {p} is not finite")]
    PosePosition {
        /// The position.
        p: DVec3,
    },
    /// A pose quaternion is zero or not finite.
    #[error("pose quaternion {q} is zero or not finite")]
    PoseOrientation {
        /// The quaternion.
        q: glam::DQuat,
    },
    /// A target position is not finite.
    #[error("target position {p} is not finite")]
    TargetPosition {
        /// The position.
        p: DVec3,
    },
    /// A target width is not a positive number.
    #[error("target width {width} is not a positive number")]
    TargetWidth {
        /// The width.
        width: f64,
    },
    /// A line is longer than the cap.
    #[error("line is {bytes} bytes, longer than {max}")]
    LineTooLong {
        /// Its length.
        bytes: usize,
        /// The cap.
        max: usize,
    },
    /// The first line is not a header.
    #[error("not a {format} header: {error}")]
    Header {
        /// The format name expected.
        format: &'static str,
        /// The JSON error.
        error: JsonError,
    },
    /// The header names another format.
    #[error("format is {found}, expected {expected:?}")]
    Format {
        /// What the header says (cut short).
        found: Excerpt,
        /// The format name expected.
        expected: &'static str,
    },
    /// The header's version is not supported.
    #[error("version {found} is not supported (this reader knows 1 to {supported})")]
    Version {
        /// What the header says.
        found: u32,
        /// The newest version this reader knows.
        supported: u32,
    },
    /// An event line is not an event.
    #[error("bad event: {0}")]
    Event(JsonError),
    /// The log has no header line.
    #[error("empty log: no header line")]
    Empty,
    /// The bytes are not UTF-8.
    #[error("not UTF-8 text")]
    NotUtf8,
}
