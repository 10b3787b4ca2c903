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
    SerialLine(String),
    /// A pose-log line is corrupt.
    #[error("pose log line {line}: {reason}")]
    PoseLogLine {
        /// 1-based line number in the log file.
        line: usize,
        /// What was wrong.
        reason: String,
    },
    /// A pose log does not start with a supported header.
    #[error("not a Wandsculpt pose log (or unsupported version): {0}")]
    PoseLogHeader(String),
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
    #[error("I/O on {what}: {source}")]
    Io {
        /// The file, socket address or port involved.
        what: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A serial port could not be opened or configured.
    #[cfg(feature = "io")]
    #[error("serial port {port}: {source}")]
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
    #[error("JSON: {0}")]
    Json(#[from] serde_json::Error),
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
