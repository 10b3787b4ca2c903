//! The one error type of `sculpt-core`, and the typed reasons its variants carry.

use std::fmt;
use std::sync::Arc;

use glam::DVec3;
use thiserror::Error;

use crate::nurbs::refine::Direction;

/// Everything that can go wrong in `sculpt-core`.
///
/// Each module adds its variants in its own block; callers match on the variant and
/// its reason, and each error is handled exactly once (reported, or turned into a
/// fallback). Reasons are part of the message (not [`std::error::Error::source`]),
/// so `{:#}` in a binary prints each cause once.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    // NURBS kernel (knots, curves, surfaces, fitting, inversion).
    /// A knot vector is malformed.
    #[error("invalid knot vector: {}{reason}", knots_prefix(*.direction))]
    InvalidKnots {
        /// The surface direction whose knots are wrong (`None` for a curve or a bare
        /// knot vector).
        direction: Option<Direction>,
        /// What is wrong.
        reason: KnotError,
    },
    /// A degree is zero or above [`crate::nurbs::MAX_DEGREE`].
    #[error(
        "invalid degree: {}degree {degree} is outside 1..={}",
        knots_prefix(*.direction),
        crate::nurbs::MAX_DEGREE
    )]
    InvalidDegree {
        /// The surface direction (`None` for a curve or a bare knot vector).
        direction: Option<Direction>,
        /// The degree asked for.
        degree: usize,
    },
    /// The control net does not match the knot vectors (counts, ragged rows, NaN).
    #[error("invalid control net: {0}")]
    InvalidControlNet(ControlNetError),
    /// A weight is missing, not finite or not positive.
    #[error("invalid weights: {0}")]
    InvalidWeights(WeightError),
    /// A parameter (knot to insert, constructor argument) is out of range or not finite.
    #[error("invalid parameter: {0}")]
    InvalidParameter(ParameterError),
    /// A fit could not be computed (too few points, singular system, NaN data).
    #[error("fit failed: {0}")]
    FitFailed(FitError),
    /// A curve or surface JSON document is not valid JSON or does not follow the
    /// schema; the cause has the line and column.
    #[error("invalid NURBS JSON")]
    Json(#[source] JsonError),

    // Sculpting (UV maps, strokes, trimming, documents, formats).
    /// A stroke was rejected; the reason says why.
    #[error("stroke rejected: {0}")]
    StrokeRejected(StrokeRejection),
    /// A mesh or CAD file could not be read or written; the reason says where and why.
    #[error("{format}: {reason}")]
    Format {
        /// The file format (OBJ, STL, glTF, IGES).
        format: &'static str,
        /// What was wrong.
        reason: String,
    },
    /// A document or scene file was rejected; the reason says where and why.
    #[error("document: {0}")]
    Document(DocumentError),
    /// A document operation named a target or stroke that does not exist.
    #[error("no such {kind} {id}")]
    NotFound {
        /// "target" or "stroke".
        kind: &'static str,
        /// The id asked for.
        id: u64,
    },

    // Operator event log.
    /// An operator event log line could not be read.
    #[error("operator log line {line}: {reason}")]
    OpLog {
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        reason: OpLogError,
    },

    // Interaction.
    /// The interaction state machine refused an input.
    #[error("interaction: {0}")]
    Interaction(InteractionError),
}

fn knots_prefix(direction: Option<Direction>) -> &'static str {
    match direction {
        None => "",
        Some(Direction::U) => "knots_u: ",
        Some(Direction::V) => "knots_v: ",
    }
}

/// Why a knot vector is malformed.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum KnotError {
    /// Fewer knots than `2 (degree + 1)`.
    #[error("{count} knots are too few for degree {degree} (need at least {need})")]
    TooFew {
        /// Knots given.
        count: usize,
        /// The degree.
        degree: usize,
        /// Knots needed.
        need: usize,
    },
    /// A knot is NaN or infinite.
    #[error("knot {index} is not finite")]
    NotFinite {
        /// Its index.
        index: usize,
    },
    /// The knots decrease at `index` (`knots[index - 1] > knots[index]`).
    #[error("knots decrease at index {index}: {previous} > {knot}")]
    Decreasing {
        /// The index of the smaller knot.
        index: usize,
        /// The knot before it.
        previous: f64,
        /// The knot at `index`.
        knot: f64,
    },
    /// A knot repeats more often than the degree allows.
    #[error(
        "knot {knot} has multiplicity {multiplicity}, more than {max} allowed for degree {degree}"
    )]
    Multiplicity {
        /// The knot value.
        knot: f64,
        /// How often it repeats.
        multiplicity: usize,
        /// The most allowed there.
        max: usize,
        /// The degree.
        degree: usize,
    },
    /// The domain `[knots[p], knots[n + 1]]` is empty.
    #[error("empty domain [{start}, {end}] for degree {degree}")]
    EmptyDomain {
        /// Domain start.
        start: f64,
        /// Domain end.
        end: f64,
        /// The degree.
        degree: usize,
    },
    /// Too few control points for a clamped knot vector of this degree.
    #[error("{count} control points are too few for degree {degree}")]
    TooFewControlPoints {
        /// Control points asked for.
        count: usize,
        /// The degree.
        degree: usize,
    },
}

/// Where a control point sits: index `i` of a curve, or `[i][j]` of a surface net.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NetIndex {
    /// Control point `i` of a curve.
    Curve(usize),
    /// Control point `[i][j]` of a surface (`i` along `u`).
    Surface(usize, usize),
}

impl fmt::Display for NetIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NetIndex::Curve(i) => write!(f, "{i}"),
            NetIndex::Surface(i, j) => write!(f, "[{i}][{j}]"),
        }
    }
}

/// Why a control net does not fit its knot vectors.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ControlNetError {
    /// A curve's point count does not match its knots.
    #[error("{got} control points, but {knots} knots of degree {degree} need {need}")]
    CurveCount {
        /// Points given.
        got: usize,
        /// Knots given.
        knots: usize,
        /// The degree.
        degree: usize,
        /// Points needed.
        need: usize,
    },
    /// A surface's row count does not match `knots_u`.
    #[error("{got} rows of control points along u, but knots_u of degree {degree} need {need}")]
    RowCount {
        /// Rows given.
        got: usize,
        /// The degree in `u`.
        degree: usize,
        /// Rows needed.
        need: usize,
    },
    /// A surface row's length does not match `knots_v`.
    #[error(
        "row {row} has {got} control points along v, but knots_v of degree {degree} need {need}"
    )]
    RowLength {
        /// The row.
        row: usize,
        /// Points in it.
        got: usize,
        /// The degree in `v`.
        degree: usize,
        /// Points needed.
        need: usize,
    },
    /// The homogeneous point count does not match the knots.
    #[error("{got} homogeneous points for {need} expected")]
    HomogeneousCount {
        /// Points given.
        got: usize,
        /// Points needed.
        need: usize,
    },
    /// A control point is NaN or infinite.
    #[error("control point {at} is not finite: {point}")]
    NotFinite {
        /// Which point.
        at: NetIndex,
        /// Its value.
        point: DVec3,
    },
    /// A surface read from JSON has more control points than a surface may have.
    #[error("{count} control points, more than the {max} a surface may have")]
    TooMany {
        /// Points given.
        count: usize,
        /// The cap.
        max: usize,
    },
    /// A control point read from JSON lies farther from the origin than any sculpted
    /// object does.
    #[error("control point {at} = {point} is beyond {max_m} m")]
    TooFar {
        /// Which point.
        at: NetIndex,
        /// Its value.
        point: DVec3,
        /// The cap (absolute coordinate, metres).
        max_m: f64,
    },
}

/// Why the weights are unusable.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum WeightError {
    /// A curve's weight count does not match its points.
    #[error("{got} weights for {need} control points")]
    Count {
        /// Weights given.
        got: usize,
        /// Weights needed.
        need: usize,
    },
    /// A surface's weight rows do not match its control point rows.
    #[error("{got} rows of weights for {need} rows of control points")]
    RowCount {
        /// Rows given.
        got: usize,
        /// Rows needed.
        need: usize,
    },
    /// A surface weight row has the wrong length.
    #[error("weight row {row} has {got} entries, expected {need}")]
    RowLength {
        /// The row.
        row: usize,
        /// Entries in it.
        got: usize,
        /// Entries needed.
        need: usize,
    },
    /// A weight is NaN, infinite, zero or negative.
    #[error("control point {at}: weight {weight} is not finite and positive")]
    NotPositive {
        /// Which control point.
        at: NetIndex,
        /// The weight.
        weight: f64,
    },
    /// A weight read from JSON lies outside `[1 / max, max]`.
    #[error("control point {at}: weight {weight:e} is outside [{:e}, {max:e}]", 1.0 / max)]
    OutOfRange {
        /// Which control point.
        at: NetIndex,
        /// The weight.
        weight: f64,
        /// The cap.
        max: f64,
    },
}

/// Why a constructor or refinement argument is unusable.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ParameterError {
    /// An argument is NaN or infinite.
    #[error("{what} must be finite")]
    NotFinite {
        /// Which argument.
        what: &'static str,
    },
    /// A vector argument is zero.
    #[error("{what} is zero")]
    ZeroVector {
        /// Which argument.
        what: &'static str,
    },
    /// Two axes are parallel (or one is zero).
    #[error("{what} are parallel")]
    Parallel {
        /// Which arguments.
        what: &'static str,
    },
    /// A length or angle is not positive.
    #[error("{what} {value} must be positive")]
    NotPositive {
        /// Which argument.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Plane edges are parallel or zero.
    #[error("plane edges are parallel or zero")]
    DegeneratePlane,
    /// A cylinder's radius is not positive or its axis is zero.
    #[error("cylinder needs a positive radius and a non-zero axis")]
    DegenerateCylinder,
    /// An arc ends at or before its start.
    #[error("arc end must be after its start")]
    ArcEndBeforeStart,
    /// Torus radii out of order.
    #[error("torus radii must satisfy 0 < minor ({minor}) < major ({major})")]
    TorusRadii {
        /// Minor radius.
        minor: f64,
        /// Major radius.
        major: f64,
    },
    /// A knot to insert lies outside the domain.
    #[error("knot {knot} is outside the domain [{start}, {end}]")]
    KnotOutsideDomain {
        /// The knot.
        knot: f64,
        /// Domain start.
        start: f64,
        /// Domain end.
        end: f64,
    },
    /// Inserting a knot would raise its multiplicity above the degree.
    #[error(
        "inserting knot {knot} {times} times would raise its multiplicity {multiplicity} above the degree {degree}"
    )]
    MultiplicityAboveDegree {
        /// The knot.
        knot: f64,
        /// Insertions asked for.
        times: usize,
        /// Its multiplicity now.
        multiplicity: usize,
        /// The degree.
        degree: usize,
    },
    /// Knots to insert are not sorted.
    #[error("knots to insert must be sorted")]
    UnsortedKnots,
}

/// Why a fit could not be computed.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum FitError {
    /// The point grid is empty.
    #[error("the grid is empty")]
    EmptyGrid,
    /// A grid row has the wrong length.
    #[error("grid row {row} has {got} points, expected {need}")]
    RaggedGrid {
        /// The row.
        row: usize,
        /// Points in it.
        got: usize,
        /// Points expected.
        need: usize,
    },
    /// A grid point, data point or parameter is NaN or infinite.
    #[error("{what} must be finite")]
    NotFinite {
        /// What.
        what: &'static str,
    },
    /// The grid has too few points for the degrees.
    #[error("a {n_u} x {n_v} grid is too small for degrees ({degree_u}, {degree_v})")]
    GridTooSmall {
        /// Rows.
        n_u: usize,
        /// Columns.
        n_v: usize,
        /// Degree in `u`.
        degree_u: usize,
        /// Degree in `v`.
        degree_v: usize,
    },
    /// The control net size does not fit the grid and degrees.
    #[error(
        "need degree < control count <= grid size: grid {n_u} x {n_v}, net {count_u} x {count_v}, degrees ({degree_u}, {degree_v})"
    )]
    NetSize {
        /// Grid rows.
        n_u: usize,
        /// Grid columns.
        n_v: usize,
        /// Control rows asked for.
        count_u: usize,
        /// Control columns asked for.
        count_v: usize,
        /// Degree in `u`.
        degree_u: usize,
        /// Degree in `v`.
        degree_v: usize,
    },
    /// Points and parameters differ in number.
    #[error("{points} points with {params} parameters")]
    ParamCount {
        /// Points given.
        points: usize,
        /// Parameters given.
        params: usize,
    },
    /// The least-squares system is singular.
    #[error("singular system: {0}")]
    Singular(&'static str),
    /// The solution is not finite.
    #[error("the solution is not finite")]
    NonFiniteSolution,
    /// Sketch rows are too short or differ in length.
    #[error("a sketch needs rows of at least 2 points, all the same length")]
    SketchRows,
    /// The sketch sweep did not move.
    #[error("the sketch sweep did not move (at least 2 distinct rows are needed)")]
    SketchDidNotMove,
    /// A stroke surface needs at least two samples.
    #[error("the stroke has fewer than two samples")]
    StrokeTooFewSamples,
    /// A stroke surface needs a width.
    #[error("the stroke has no width")]
    StrokeNoWidth,
    /// A stroke's depth list does not match its samples.
    #[error("the stroke's depth list does not match its samples")]
    StrokeDepthCount,
    /// A stroke sample is NaN or infinite.
    #[error("stroke sample {at} is not finite")]
    StrokeSampleNotFinite {
        /// The (fractional) sample coordinate.
        at: f64,
    },
}

/// A tool parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToolParam {
    /// Full width at the rims.
    Width,
    /// Depth or height at the centreline.
    Depth,
    /// Taper length at each end.
    Taper,
}

impl fmt::Display for ToolParam {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ToolParam::Width => "width",
            ToolParam::Depth => "depth",
            ToolParam::Taper => "taper",
        })
    }
}

/// A tool parameter outside its range: `(0, max]` m for width and depth, `[0, max]` m
/// for the taper.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[error("tool {param} must be in {}, {max}] m, got {value}", if matches!(.param, ToolParam::Taper) { "[0" } else { "(0" })]
pub struct ToolRangeError {
    /// Which parameter.
    pub param: ToolParam,
    /// The value given.
    pub value: f64,
    /// The largest allowed, metres.
    pub max: f64,
}

/// Why a stroke was rejected.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum StrokeRejection {
    /// A tool parameter is out of range.
    #[error(transparent)]
    Tool(ToolRangeError),
    /// A custom profile has no points or too many.
    #[error("a custom profile needs 1 to {max} points")]
    ProfilePointCount {
        /// Points given.
        count: usize,
        /// The most allowed.
        max: usize,
    },
    /// A custom profile's x values do not increase within `[0, 1]`.
    #[error("custom profile x values must increase within [0, 1] and be finite")]
    ProfileX {
        /// The first bad point.
        index: usize,
    },
    /// A custom profile depth fraction is outside `[0, 1]`.
    #[error("custom profile depth fractions must lie in [0, 1]")]
    ProfileDepth {
        /// The first bad point.
        index: usize,
    },
    /// More samples than a stroke may have.
    #[error("too many samples")]
    TooManySamples {
        /// Samples given.
        count: usize,
        /// The most allowed.
        max: usize,
    },
    /// A sample time or position is NaN or infinite.
    #[error("sample {index} is not finite")]
    SampleNotFinite {
        /// The sample.
        index: usize,
    },
    /// The tool is wider than the whole surface.
    #[error("tool width {width_m} m is larger than the surface ({across_m} m across)")]
    ToolWiderThanSurface {
        /// Tool width, metres.
        width_m: f64,
        /// The surface's diagonal, metres.
        across_m: f64,
    },
    /// The stroke is (nearly) a point.
    #[error("the stroke has zero length")]
    TooShort {
        /// Its length, metres.
        length_m: f64,
        /// The length it must exceed, metres.
        min_m: f64,
    },
    /// A sketch gesture has too few rows to become a surface.
    #[error("the sketch has {rows} rows, at least {min_rows} are needed")]
    TooFewRows {
        /// Rows drawn.
        rows: usize,
        /// Rows needed.
        min_rows: usize,
    },
    /// No sample lies on the surface.
    #[error("the stroke does not lie on the surface")]
    OffSurface,
    /// The footprint is empty after clipping.
    #[error("the stroke's footprint is empty")]
    EmptyFootprint,
}

/// Why a document or scene file was rejected.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DocumentError {
    /// The file is larger than the limit.
    #[error("{bytes} bytes is larger than the {max}-byte limit")]
    TooLarge {
        /// File size.
        bytes: usize,
        /// The limit.
        max: usize,
    },
    /// Not a JSON object.
    #[error("not a JSON object: {0}")]
    NotAnObject(JsonError),
    /// JSON that does not follow the document schema.
    #[error("{0}")]
    Schema(JsonError),
    /// The `"format"` field is missing or wrong.
    #[error("\"format\" must be \"{expected}\", found {found:?}")]
    Format {
        /// The format this build reads.
        expected: &'static str,
        /// What the file says.
        found: Option<String>,
    },
    /// The version is missing or unsupported.
    #[error("unsupported version {found:?} (this build reads version {supported})")]
    Version {
        /// What the file says.
        found: Option<u64>,
        /// The version this build reads.
        supported: u32,
    },
    /// A target id is zero or repeated.
    #[error("target id {id} is zero or repeated")]
    TargetId {
        /// The id.
        id: u64,
    },
    /// A stroke id is zero or repeated.
    #[error("stroke id {id} is zero or repeated")]
    StrokeId {
        /// The id.
        id: u64,
    },
    /// A stroke of the file could not be replayed.
    #[error("stroke {id}: {error}")]
    Stroke {
        /// The stroke's id.
        id: u64,
        /// Why.
        error: Box<Error>,
    },
}

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
    #[error("format is {found:?}, expected {expected:?}")]
    Format {
        /// What the header says.
        found: String,
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

/// Why the interaction refused an input.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum InteractionError {
    /// An event time is NaN or infinite.
    #[error("event time {t} is not finite")]
    TimeNotFinite {
        /// The time.
        t: f64,
    },
    /// An event time is before the previous one.
    #[error("event time {t} is before the previous {previous}")]
    TimeBackwards {
        /// The time.
        t: f64,
        /// The previous event's time.
        previous: f64,
    },
    /// A tool parameter is out of range.
    #[error(transparent)]
    Tool(ToolRangeError),
    /// An `[interaction]` setting is out of range.
    #[error("interaction.{0}")]
    Config(InteractionConfigError),
    /// A custom tool profile is malformed (too few points, x not increasing, depth
    /// outside `[0, 1]`).
    #[error("tool profile: {0}")]
    Profile(StrokeRejection),
}

/// Which [`InteractionConfig`](crate::interaction::InteractionConfig) setting is out
/// of range, and its value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InteractionConfigError {
    /// A setting must be a positive number.
    #[error("{setting} must be a positive number, got {value}")]
    NotPositive {
        /// The setting's name in `[interaction]`.
        setting: &'static str,
        /// Its value.
        value: f64,
    },
    /// A setting must be a number >= 0.
    #[error("{setting} must be >= 0, got {value}")]
    Negative {
        /// The setting's name in `[interaction]`.
        setting: &'static str,
        /// Its value.
        value: f64,
    },
    /// `max_samples` is below 2.
    #[error("max_samples must be at least 2")]
    MaxSamples,
    /// Sketch columns or rows out of range.
    #[error("sketch_columns must be in 2..=64 and min_sketch_rows in 2..=10000")]
    SketchSize,
    /// `sketch_axis` is zero or not finite.
    #[error("sketch_axis must be a non-zero vector")]
    SketchAxis,
    /// A button index is 32 or more.
    #[error("button indices must be below 32")]
    ButtonIndex,
}

/// A JSON syntax or schema error with its position, shared so that [`Error`] stays
/// `Clone`; two are equal when they say the same thing at the same place.
#[derive(Debug, Clone)]
pub struct JsonError(Arc<serde_json::Error>);

impl JsonError {
    /// 1-based line of the error (0 when serde could not tell).
    pub fn line(&self) -> usize {
        self.0.line()
    }
    /// 1-based column of the error (0 when serde could not tell).
    pub fn column(&self) -> usize {
        self.0.column()
    }
    /// Syntax, data, end of file or I/O.
    pub fn classify(&self) -> serde_json::error::Category {
        self.0.classify()
    }
    /// The underlying serde error.
    pub fn inner(&self) -> &serde_json::Error {
        &self.0
    }
}

impl From<serde_json::Error> for JsonError {
    fn from(e: serde_json::Error) -> Self {
        Self(Arc::new(e))
    }
}

impl PartialEq for JsonError {
    fn eq(&self, other: &Self) -> bool {
        self.0.to_string() == other.0.to_string()
    }
}

impl fmt::Display for JsonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for JsonError {}

/// Displays an error and every [`source`](std::error::Error::source) below it on one
/// line, separated by `": "` (as `anyhow` does with `{:#}`), for libraries that log.
pub struct Chain<'a>(pub &'a (dyn std::error::Error + 'static));

impl fmt::Display for Chain<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)?;
        let mut next = self.0.source();
        while let Some(e) = next {
            write!(f, ": {e}")?;
            next = e.source();
        }
        Ok(())
    }
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_cause_is_printed_once_in_the_chain() {
        let e = Error::Json(serde_json::from_str::<u8>("x").unwrap_err().into());
        let chain = Chain(&e).to_string();
        assert!(
            chain.starts_with("invalid NURBS JSON: expected value"),
            "{chain}"
        );
        assert_eq!(chain.matches("expected value").count(), 1, "{chain}");
    }
}
