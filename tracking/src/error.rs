//! The one error type of the `tracking` crate.

use std::path::PathBuf;

/// Everything that can go wrong in `tracking`.
#[derive(Debug, thiserror::Error)]
pub enum TrackingError {
    /// A DTrack2 ASCII line could not be parsed.
    #[error("DTrack2 line `{kind}`: {reason}")]
    DTrackLine {
        /// The line type (`fr`, `6d`, `6df2`, ...), or `?` when unknown.
        kind: String,
        /// What was wrong.
        reason: String,
    },
    /// A line exceeded the configured length cap and was discarded.
    #[error("line longer than {cap} bytes discarded")]
    LineTooLong {
        /// The cap in bytes.
        cap: usize,
    },
    /// A frame exceeded the configured size cap and was discarded.
    #[error("frame larger than {cap} bytes (or too many devices) discarded")]
    FrameTooLarge {
        /// The cap in bytes.
        cap: usize,
    },
    /// A serial wand line was malformed or failed its checksum.
    #[error("serial wand line: {0}")]
    SerialLine(SerialLineError),
    /// A pose-log line is corrupt.
    #[error("pose log line {line}: {reason}")]
    PoseLogLine {
        /// 1-based line number in the log file.
        line: usize,
        /// What was wrong.
        reason: PoseLogLineError,
    },
    /// A pose log does not start with a supported header.
    #[error("not a Wandsculpt pose log (or unsupported version): {0}")]
    PoseLogHeader(PoseLogHeaderError),
    /// Invalid configuration (TOML or programmatic).
    #[error("config: {0}")]
    Config(String),
    /// A calibration could not be computed (too few or degenerate point pairs).
    #[error("calibration: {0}")]
    Calibration(String),
    /// An invalid simulator script or setting.
    #[error("simulator: {0}")]
    Sim(String),
    /// An I/O error, with the path or endpoint involved when known.
    #[error("I/O on {what}")]
    Io {
        /// The file, socket address or port involved.
        what: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A serial port could not be opened or configured.
    #[cfg(feature = "io")]
    #[error("serial port {port}")]
    Serial {
        /// The port path.
        port: String,
        /// The underlying error.
        #[source]
        source: tokio_serial::Error,
    },
    /// The `.tilt` container (16-byte header and zip archive) is malformed.
    #[error("not a readable .tilt file: {0}")]
    TiltContainer(String),
    /// The `data.sketch` stream inside a `.tilt` file is malformed.
    #[error("malformed data.sketch at byte {offset}: {reason}")]
    TiltSketch {
        /// Byte offset in `data.sketch` where the problem was found.
        offset: usize,
        /// What was wrong.
        reason: String,
    },
    /// Import options or the sketch cannot make a wand track.
    #[error("import: {0}")]
    Import(String),
    /// JSON in a pose-log header could not be (de)serialised.
    #[error("JSON")]
    Json(#[from] serde_json::Error),
}

/// What is wrong with a pose-log line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PoseLogLineError {
    /// A serial record was asked for as a DTrack frame.
    #[error("not a DTrack record")]
    NotDTrack,
    /// The DTrack payload does not parse.
    #[error("{0}")]
    DTrack(Box<TrackingError>),
    /// The record kind is neither `d` nor `s`.
    #[error("unknown record kind (want `d` or `s`)")]
    UnknownKind,
    /// No payload after the time.
    #[error("missing payload")]
    MissingPayload,
    /// The time field does not parse.
    #[error("bad time (want seconds with 9 decimals)")]
    BadTime,
    /// The time goes back.
    #[error("time {time} goes back before {previous}")]
    TimeBackwards {
        /// The record's time, as written.
        time: String,
        /// The previous record's time, as written.
        previous: String,
    },
    /// The checksum field is not 8 hex digits.
    #[error("bad checksum field (want 8 hex digits)")]
    ChecksumField,
    /// The payload does not match its checksum.
    #[error("checksum mismatch (payload damaged or cut)")]
    ChecksumMismatch,
    /// A raw byte outside printable ASCII.
    #[error("raw byte 0x{byte:02X} at column {column}")]
    RawByte {
        /// The byte.
        byte: u8,
        /// 1-based column in the payload.
        column: usize,
    },
    /// A malformed `\` escape.
    #[error("bad {}escape at column {column}", if *.hex { "\\x " } else { "" })]
    BadEscape {
        /// Whether it was a `\x` escape.
        hex: bool,
        /// 1-based column in the payload.
        column: usize,
    },
    /// The line is longer than the cap.
    #[error("longer than {max} bytes")]
    TooLong {
        /// The cap.
        max: usize,
    },
}

/// Why a pose log's first lines are not a supported header.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum PoseLogHeaderError {
    /// No complete first line.
    #[error("missing first line")]
    MissingFirstLine,
    /// The first line is not the magic and a version.
    #[error("first line `{0}`")]
    FirstLine(String),
    /// The version is not the one this reader knows.
    #[error("version {found}, this reader knows {supported}")]
    Version {
        /// The version in the file.
        found: u32,
        /// The version this reader knows.
        supported: u32,
    },
    /// No complete header line.
    #[error("missing header line")]
    MissingHeaderLine,
    /// The second line does not start with `header `.
    #[error("second line is not `header {{json}}`")]
    NotHeader,
    /// The header JSON does not parse.
    #[error("header JSON: {0}")]
    Json(sculpt_core::error::JsonError),
}

/// Why a serial wand line was refused.
#[derive(Debug, thiserror::Error, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SerialLineError {
    /// The line does not start with `$`.
    #[error("missing `$`")]
    NoDollar,
    /// The line has no `*checksum`.
    #[error("missing `*checksum`")]
    NoChecksum,
    /// The checksum is not 8 hex digits.
    #[error("checksum must be 8 hex digits")]
    ChecksumFormat,
    /// The checksum does not match the payload.
    #[error("checksum mismatch")]
    ChecksumMismatch {
        /// The checksum the line carries.
        expected: u32,
        /// The checksum of its payload.
        actual: u32,
    },
    /// The payload is not ASCII.
    #[error("not ASCII")]
    NotAscii,
    /// The sentence is not `WAND`.
    #[error("unknown sentence (want WAND)")]
    UnknownSentence,
    /// Neither 3 nor 10 fields.
    #[error("want 3 fields, or 10 with a pose")]
    FieldCount {
        /// Fields found.
        got: usize,
    },
    /// The sequence number does not parse.
    #[error("bad sequence number")]
    Sequence,
    /// The button mask is not 1 to 16 hex digits.
    #[error("bad button mask")]
    Buttons,
    /// A pose number does not parse or is not finite.
    #[error("bad pose number")]
    PoseNumber {
        /// Its index among the 7 pose fields.
        index: usize,
    },
    /// The pose quaternion is far from unit length.
    #[error("quaternion is not unit length")]
    NotUnitQuaternion,
    /// A line exceeded the length cap and was discarded.
    #[error("line longer than {max} bytes")]
    TooLong {
        /// The cap.
        max: usize,
    },
}

impl TrackingError {
    /// An I/O error on a file path.
    pub fn io_path(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            what: path.into().display().to_string(),
            source,
        }
    }

    /// An I/O error on a named endpoint (socket address, port).
    pub fn io(what: impl Into<String>, source: std::io::Error) -> Self {
        Self::Io {
            what: what.into(),
            source,
        }
    }
}

/// `Result` with [`TrackingError`].
pub type Result<T, E = TrackingError> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: `Io` printed its source in its message and as its `source()`, so
    /// `{:#}` in the binaries said the cause twice.
    #[test]
    fn io_cause_is_printed_once_in_the_chain() {
        let e = TrackingError::io("pose log", std::io::Error::other("disk on fire"));
        assert_eq!(
            sculpt_core::error::Chain(&e).to_string(),
            "I/O on pose log: disk on fire"
        );
    }
}
