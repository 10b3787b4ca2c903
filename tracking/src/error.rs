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
        /// What was wrong: which field of the line, from a fixed set of descriptions
        /// (`"bad timestamp"`, `"expected ] after quality"`, ...), never input text.
        reason: &'static str,
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
    Config(ConfigError),
    /// A calibration is invalid or could not be computed (too few or degenerate point
    /// pairs).
    #[error("calibration: {0}")]
    Calibration(CalibrationError),
    /// An invalid simulator script or setting.
    #[error("simulator: {0}")]
    Sim(SimError),
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
    TiltContainer(TiltContainerError),
    /// The `data.sketch` stream inside a `.tilt` file is malformed.
    #[error("malformed data.sketch at byte {offset}{}{}: {reason}",
        .stroke.map(|s| format!(", stroke {s}")).unwrap_or_default(),
        .point.map(|p| format!(", point {p}")).unwrap_or_default())]
    TiltSketch {
        /// Byte offset in `data.sketch` where the problem was found.
        offset: usize,
        /// The stroke being read, if any.
        stroke: Option<usize>,
        /// The control point being read, if any.
        point: Option<usize>,
        /// What was wrong (boxed: it is rare, and keeps every `Result` small).
        reason: Box<SketchError>,
    },
    /// Import options or the sketch cannot make a wand track.
    #[error("import: {0}")]
    Import(ImportError),
    /// JSON in a pose-log header could not be (de)serialised.
    #[error("JSON")]
    Json(#[from] serde_json::Error),
}

/// What is wrong with a tracking configuration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The TOML does not parse or does not follow the schema.
    #[error("{0}")]
    Toml(Box<toml::de::Error>),
    /// The config could not be written as TOML.
    #[error("writing TOML: {0}")]
    TomlWrite(Box<toml::ser::Error>),
    /// A timeout is zero.
    #[error("lost_after_ms and read_timeout_ms must be > 0")]
    Timeouts,
    /// The reconnect back-off range is empty.
    #[error("need 0 < reconnect_min_ms <= reconnect_max_ms")]
    Reconnect,
    /// No connection would be admitted.
    #[error("max_connections must be > 0")]
    MaxConnections,
    /// The line, frame or device caps are too small.
    #[error("limits: need max_line >= 64, max_frame >= max_line, max_devices > 0")]
    Limits,
    /// A filter cutoff, `beta` or `reset_after_s` is out of range.
    #[error("filter: cutoffs and reset_after_s must be > 0, beta >= 0")]
    Filter,
    /// The stage's loss timeout is not positive.
    #[error("stage timeout_s must be > 0, got {0}")]
    StageTimeout(f64),
    /// The shared secret is empty, too long, or has spaces or control bytes.
    #[error("secret: want 1 to 256 printable ASCII characters without spaces")]
    Secret,
    /// An `[expect]` value is out of range.
    #[error("expect: need rate_hz >= 0, identify_ms > 0, frames <= 10000")]
    Expect,
    /// A device id is neither `bodyN` nor `wandN` (the text as given).
    #[error("device id `{0}`: want bodyN or wandN")]
    DeviceId(String),
}

/// What is wrong in a `.tilt` file's `data.sketch` stream (see
/// [`TrackingError::TiltSketch`] for where). `what` names the field being read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SketchError {
    /// The stream ends inside a field.
    #[error("truncated: {what} needs {needed} bytes, {left} left")]
    Truncated {
        /// The field.
        what: &'static str,
        /// Bytes it needs.
        needed: usize,
        /// Bytes left.
        left: usize,
    },
    /// A float that must be finite is not.
    #[error("{what} is not finite ({value})")]
    NotFinite {
        /// The field.
        what: &'static str,
        /// Its value.
        value: f32,
    },
    /// A count is negative or more than the bytes left could hold.
    #[error("{what} {count} is impossible: {left} bytes left, {per_item} needed per item")]
    ImpossibleCount {
        /// The field.
        what: &'static str,
        /// The count read.
        count: i32,
        /// Bytes left.
        left: usize,
        /// The fewest bytes one item takes.
        per_item: usize,
    },
    /// The stream does not start with the sketch sentinel.
    #[error("bad sentinel {found:#010x} (expected {expected:#010x})")]
    Sentinel {
        /// What the stream starts with.
        found: u32,
        /// The sentinel.
        expected: u32,
    },
    /// Bytes follow the last stroke.
    #[error("{0} unexpected bytes after the last stroke")]
    Trailing(usize),
}

/// Why a calibration is invalid or cannot be fitted.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrationError {
    /// The tracker-unit scale is not positive.
    #[error("scale {0} must be > 0")]
    Scale(f64),
    /// An axis name is not `x`, `y`, `z` or a negation.
    #[error("axes {0:?}: each must be x, y, z or -x, -y, -z")]
    AxisName([String; 3]),
    /// The axes remap is a mirror or repeats an axis.
    #[error("axes {0:?} are not a rotation (mirror or repeat)")]
    NotARotation([String; 3]),
    /// The rotation quaternion is zero or not finite.
    #[error("rotation must be a non-zero quaternion")]
    Rotation,
    /// The translation is not finite.
    #[error("translation must be finite")]
    Translation,
    /// A wand tip names an unknown device.
    #[error("tip: {0}")]
    TipDevice(ConfigError),
    /// A wand tip offset is not finite.
    #[error("tip of {0} must be finite")]
    Tip(String),
    /// Fewer point pairs (or poses) than the fit needs.
    #[error("need at least {needed} {what}")]
    TooFew {
        /// How many are needed.
        needed: usize,
        /// `point pairs` or `poses`.
        what: &'static str,
    },
    /// A point pair or pose is not finite (or a quaternion is zero).
    #[error("{0} must be finite with non-zero quaternions")]
    NotFinite(&'static str),
    /// The points or poses do not determine the fit.
    #[error("{0}")]
    Degenerate(Degeneracy),
    /// The linear solve failed.
    #[error("solving the least-squares system: {0}")]
    Solve(&'static str),
    /// The fitted scale came out non-positive.
    #[error("fitted scale is not positive")]
    FittedScale,
}

/// Why calibration input does not determine a fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Degeneracy {
    /// Point pairs are coincident or collinear.
    #[error("points are degenerate (coincident or collinear)")]
    Points,
    /// Pivot poses turn about fewer than two axes.
    #[error("poses are degenerate: turn the wand about two or more axes")]
    Poses,
}

/// What is wrong with a simulator script or its settings.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A start pose is not finite.
    #[error("start poses must be finite")]
    StartPose,
    /// A step's duration is out of range (`step` is 1-based).
    #[error("step {step}: duration must be 0..=86400 s")]
    Duration {
        /// 1-based step number.
        step: usize,
    },
    /// A step's button index is out of range.
    #[error("step {step}: button index must be < 64")]
    Button {
        /// 1-based step number.
        step: usize,
    },
    /// A step has a non-finite number.
    #[error("step {step}: numbers must be finite")]
    NotFinite {
        /// 1-based step number.
        step: usize,
    },
    /// The frame rate is out of range.
    #[error("rate_hz must be in 1..=2000")]
    Rate,
    /// A tremor, noise or dropout setting is negative or not finite.
    #[error("tremor, noise and dropout settings must be finite and >= 0")]
    Noise,
    /// The tremor band is empty or not positive.
    #[error("tremor_band_hz must be 0 < lo <= hi")]
    TremorBand,
    /// More buttons or analog axes than a wand has.
    #[error("too many buttons or analog axes")]
    Channels,
}

/// What is wrong with a `.tilt` container.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TiltContainerError {
    /// Shorter than the fixed header.
    #[error("{0} bytes is shorter than the 16-byte header")]
    Short(usize),
    /// The magic is not `tilT`.
    #[error("bad magic {0:02x?} (expected \"tilT\")")]
    Magic([u8; 4]),
    /// The header size field does not fit the file.
    #[error("header size {header} out of range for a {len}-byte file")]
    HeaderSize {
        /// The header size field.
        header: usize,
        /// The file's length.
        len: usize,
    },
    /// The zip archive (or one entry) cannot be read or written.
    #[error("{what}: {source}")]
    Zip {
        /// `zip archive`, `writing zip` or the entry name.
        what: String,
        /// The zip error.
        source: zip::result::ZipError,
    },
    /// An entry could not be read or written.
    #[error("{what}: {source}")]
    Io {
        /// `writing zip` or the entry name.
        what: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The archive has no `data.sketch`.
    #[error("the archive has no data.sketch")]
    NoSketch,
    /// An entry is larger than its cap.
    #[error("{name} claims {size} bytes, more than the {cap}-byte limit")]
    TooLarge {
        /// The entry name.
        name: String,
        /// The size it claims (or at least `cap + 1` when it lied).
        size: u64,
        /// The cap.
        cap: u64,
    },
}

/// Why import options or a sketch cannot make a wand track.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// The sample rate is out of range.
    #[error("rate must be in 1..=2000 Hz")]
    Rate,
    /// The speed factor is out of range.
    #[error("speed must be in (0, 1000]")]
    Speed,
    /// A placement or timing value is not finite.
    #[error("placement and timing values must be finite")]
    NotFinite,
    /// A gap, lead or point interval is negative (or zero).
    #[error("gap and lead times must be >= 0 and the point interval > 0")]
    Timing,
    /// A gap or lead is longer than an hour.
    #[error("gap and lead times must be at most an hour")]
    TooLong,
    /// The fit box is not positive.
    #[error("the fit box must be positive")]
    FitBox,
    /// The scale is not finite and positive.
    #[error("scale must be finite and > 0")]
    Scale,
    /// The placement axes are zero or parallel.
    #[error("right and up must be non-zero and not parallel")]
    Axes,
    /// The button index is out of range.
    #[error("button must be in 0..32")]
    Button,
    /// The stroke range is empty or past the end.
    #[error("stroke range {first}..{end} is empty or beyond the sketch's {count} strokes")]
    StrokeRange {
        /// First stroke asked for.
        first: usize,
        /// One past the last stroke asked for.
        end: usize,
        /// Strokes in the sketch.
        count: usize,
    },
    /// Every stroke in the range is empty.
    #[error("no stroke in the range has control points")]
    NoPoints,
    /// The track would be too long.
    #[error("the track would have {frames} frames (more than {max}); lower the rate or the gaps")]
    TooManyFrames {
        /// Frames the track would have.
        frames: usize,
        /// The cap.
        max: usize,
    },
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
    /// The first line is not the magic and a version (the line as found, cut to 80
    /// characters).
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
