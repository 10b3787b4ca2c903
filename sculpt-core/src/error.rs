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
        /// The file format.
        format: FileFormat,
        /// What was wrong, and where.
        reason: FormatError,
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

    // Scan reconstruction.
    /// Reading points or reconstructing patches from them failed.
    #[error("reconstruct: {0}")]
    Reconstruct(#[from] crate::reconstruct::ReconstructError),

    // Lattice deformation.
    /// A lattice or a deformation was refused; the reason says why.
    #[error("lattice: {0}")]
    Lattice(#[from] crate::lattice::LatticeError),
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
    /// The stroke's projection falls into several pieces (it passes over basin jumps or
    /// leaves the surface between them) where one continuous piece was asked for
    /// ([`Stroke::build`](crate::sculpt::stroke::Stroke::build));
    /// [`StrokePieces::build`](crate::sculpt::stroke::StrokePieces::build) carves them
    /// all.
    #[error("the stroke falls into {pieces} pieces, where one was asked for")]
    Pieces {
        /// The pieces it falls into.
        pieces: usize,
    },
}

/// The most characters of bad input an error quotes: longer input is cut to this many
/// characters and marked with `...`, so a 200 MB line gives a short message.
pub const MAX_QUOTED_CHARS: usize = 64;

/// A short quoted prefix of bad input (at most [`MAX_QUOTED_CHARS`] characters), kept
/// in an error as data. Displays as a Rust string literal, with `...` after the
/// closing quote when the input was cut.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Excerpt {
    /// The first characters of the input.
    pub prefix: String,
    /// Characters of the input left out (0 when it was quoted whole).
    pub cut_chars: usize,
}

impl Excerpt {
    /// The excerpt of `input`.
    pub fn new(input: &str) -> Self {
        let end = input
            .char_indices()
            .nth(MAX_QUOTED_CHARS)
            .map_or(input.len(), |(i, _)| i);
        Self {
            prefix: input[..end].to_string(),
            cut_chars: input[end..].chars().count(),
        }
    }

    /// True when the input was longer than the excerpt.
    pub fn is_cut(&self) -> bool {
        self.cut_chars > 0
    }
}

impl fmt::Display for Excerpt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.prefix)?;
        if self.is_cut() {
            write!(f, "... ({} more characters)", self.cut_chars)?;
        }
        Ok(())
    }
}

/// A file format of [`crate::formats`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    /// Wavefront OBJ.
    Obj,
    /// Binary STL.
    Stl,
    /// glTF 2.0 binary.
    Gltf,
    /// IGES 5.3.
    Iges,
}

impl fmt::Display for FileFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileFormat::Obj => "OBJ",
            FileFormat::Stl => "STL",
            FileFormat::Gltf => "glTF",
            FileFormat::Iges => "IGES",
        })
    }
}

/// Which number a writer refused to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrittenValue {
    /// A mesh vertex position.
    Position,
    /// A mesh vertex normal.
    Normal,
    /// A mesh vertex texture coordinate.
    TexCoord,
    /// A surface knot (u or v).
    Knot,
    /// A surface weight.
    Weight,
    /// A surface control point.
    ControlPoint,
    /// A trimming loop's point in the surface's parameter range.
    TrimPoint,
}

impl fmt::Display for WrittenValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WrittenValue::Position => "vertex position",
            WrittenValue::Normal => "vertex normal",
            WrittenValue::TexCoord => "vertex texture coordinate",
            WrittenValue::Knot => "knot",
            WrittenValue::Weight => "weight",
            WrittenValue::ControlPoint => "control point",
            WrittenValue::TrimPoint => "trimming loop point",
        })
    }
}

/// A part of a glTF file the reader needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GltfPart {
    /// The JSON chunk.
    JsonChunk,
    /// An attribute's accessor index.
    Accessor,
    /// An accessor's `count`.
    AccessorCount,
    /// An accessor's `bufferView`.
    AccessorView,
    /// The primitive's `indices`.
    Indices,
}

impl fmt::Display for GltfPart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GltfPart::JsonChunk => "JSON chunk",
            GltfPart::Accessor => "accessor index",
            GltfPart::AccessorCount => "accessor count",
            GltfPart::AccessorView => "accessor bufferView",
            GltfPart::Indices => "indices",
        })
    }
}

/// Why a mesh or CAD file could not be read or written ([`Error::Format`]).
///
/// Line numbers are 1-based; quoted input is an [`Excerpt`]. The underlying parse
/// error, where there is one, is kept typed and printed as part of the message (the
/// convention of [`Error`](enum@Error)).
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FormatError {
    // Any text format.
    /// The bytes are not UTF-8 (OBJ) or ASCII (IGES) text.
    #[error("not text: {error}")]
    NotText {
        /// Where decoding stopped.
        error: std::str::Utf8Error,
    },

    // Writers.
    /// A number to write is NaN or infinite; nothing was written.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// Which kind of number.
        what: WrittenValue,
        /// The vertex or control point (in writing order) it belongs to.
        index: usize,
    },

    /// A number of a surface to write is NaN or infinite; nothing was written.
    #[error("surface {surface}: {what} {index} is not finite")]
    SurfaceNonFinite {
        /// The surface, in the order given to the writer.
        surface: usize,
        /// Which kind of number.
        what: WrittenValue,
        /// Its index: in `knots_u` followed by `knots_v`, in the net (`i * rows + j`
        /// for weights and control points), or in the face's loops.
        index: usize,
    },

    // OBJ.
    /// A token is not a number.
    #[error("line {line}: {token} is not a number: {error}")]
    Number {
        /// The line.
        line: usize,
        /// The token.
        token: Excerpt,
        /// The parse error.
        error: std::num::ParseFloatError,
    },
    /// A statement has too few numbers, or one that is not finite.
    #[error("line {line}: expected {expected} finite numbers, found {finite} of {found}")]
    NumberCount {
        /// The line.
        line: usize,
        /// Numbers needed.
        expected: usize,
        /// Numbers given (up to `expected`).
        found: usize,
        /// Of those, finite ones.
        finite: usize,
    },
    /// A face's vertex reference is not an integer.
    #[error("line {line}: bad index {token}: {error}")]
    Index {
        /// The line.
        line: usize,
        /// The reference.
        token: Excerpt,
        /// The parse error.
        error: std::num::ParseIntError,
    },
    /// A face's vertex reference points at no element.
    #[error("line {line}: index {index} out of range ({count} defined)")]
    IndexOutOfRange {
        /// The line.
        line: usize,
        /// The index as written.
        index: i64,
        /// Elements defined before the line.
        count: usize,
    },
    /// A face's vertex has no position reference.
    #[error("line {line}: face without a position")]
    FaceWithoutPosition {
        /// The line.
        line: usize,
    },
    /// A face has fewer than three vertices.
    #[error("line {line}: a face needs 3 vertices, found {found}")]
    FaceTooSmall {
        /// The line.
        line: usize,
        /// Vertices given.
        found: usize,
    },

    // STL.
    /// The file is shorter than the header.
    #[error("{bytes} bytes is shorter than the {header}-byte header")]
    Truncated {
        /// File size.
        bytes: usize,
        /// Header size.
        header: usize,
    },
    /// The file size does not match the triangle count in the header.
    #[error("header says {triangles} triangles but the file has {bytes} bytes")]
    TriangleCount {
        /// Triangles in the header.
        triangles: usize,
        /// File size.
        bytes: usize,
    },
    /// A triangle corner is NaN or infinite.
    #[error("triangle {triangle} has a non-finite corner")]
    NonFiniteCorner {
        /// The triangle.
        triangle: usize,
    },

    // glTF binary.
    /// The first word is not `glTF`.
    #[error("not a GLB file (bad magic)")]
    BadMagic,
    /// The container version is not 2.
    #[error("container version {found:?} is not supported (only glTF 2.0)")]
    GltfVersion {
        /// The version (`None`: the file ends first).
        found: Option<u32>,
    },
    /// The header's length is not the file's.
    #[error("header length {header:?} does not match the file size {bytes}")]
    Length {
        /// The header's length.
        header: Option<u32>,
        /// File size.
        bytes: usize,
    },
    /// A chunk header or body runs past the end of the file.
    #[error("chunk at byte {at} runs past the end of the file")]
    Chunk {
        /// Offset of the chunk header.
        at: usize,
    },
    /// A part the reader needs is missing.
    #[error("no {0}")]
    Missing(GltfPart),
    /// The JSON chunk is not JSON.
    #[error("bad JSON chunk: {0}")]
    GltfJson(JsonError),
    /// An accessor's component type is not one the reader knows.
    #[error("accessor {accessor}: unsupported component type {component_type}")]
    ComponentType {
        /// The accessor.
        accessor: usize,
        /// Its `componentType`.
        component_type: u64,
    },
    /// An accessor reaches beyond the binary chunk.
    #[error("accessor {accessor} runs past the binary chunk ({bytes} bytes)")]
    AccessorRange {
        /// The accessor.
        accessor: usize,
        /// Size of the binary chunk.
        bytes: usize,
    },
    /// Attribute arrays have different vertex counts.
    #[error("attribute counts differ: {positions} positions, {normals} normals, {uvs} uvs")]
    AttributeCounts {
        /// Positions.
        positions: usize,
        /// Normals.
        normals: usize,
        /// Texture coordinates.
        uvs: usize,
    },
    /// The index count is not a multiple of 3 or exceeds the buffer.
    #[error("bad index count {count}")]
    IndexCount {
        /// Indices given.
        count: usize,
    },
    /// A triangle index points past the vertices.
    #[error("index {index} out of range ({vertices} vertices)")]
    VertexIndex {
        /// The index.
        index: u32,
        /// Vertices.
        vertices: usize,
    },

    // IGES.
    /// A non-blank line is shorter than the 73 columns of a section line.
    #[error("line {line}: {columns} columns, shorter than 73")]
    ShortLine {
        /// The line.
        line: usize,
        /// Its length, bytes.
        columns: usize,
    },
    /// A parameter data line's directory pointer (columns 65 to 72) is not a number.
    #[error("line {line}: bad directory pointer {token}")]
    DirectoryPointer {
        /// The line.
        line: usize,
        /// Columns 65 to 72.
        token: Excerpt,
    },
    /// Column 73 names no section.
    #[error("line {line}: unknown section {section}")]
    Section {
        /// The line.
        line: usize,
        /// Column 73.
        section: Excerpt,
    },
    /// The directory entry section has an odd number of lines.
    #[error("odd number of directory entry lines ({lines})")]
    OddDirectory {
        /// Lines.
        lines: usize,
    },
    /// A directory entry's entity type is not a number.
    #[error("directory entry {de}: bad entity type {token}")]
    EntityType {
        /// The entry's sequence number.
        de: usize,
        /// Columns 1 to 8.
        token: Excerpt,
    },
    /// A directory entry has no parameter data.
    #[error("directory entry {de}: no parameter data")]
    NoParameters {
        /// The entry's sequence number.
        de: usize,
    },
    /// A directory entry's parameter data starts with another entity type.
    #[error("directory entry {de}: parameter data is for another entity ({found}, not {kind})")]
    OtherEntity {
        /// The entry's sequence number.
        de: usize,
        /// The entry's type.
        kind: u32,
        /// The parameter data's first token.
        found: Excerpt,
    },
    /// A parameter is missing or not a finite number.
    #[error("entity {kind} at {de}: parameter {index} missing or not a number")]
    Parameter {
        /// The entity type.
        kind: u32,
        /// Its directory entry.
        de: usize,
        /// The parameter's position.
        index: usize,
    },
    /// A parameter that must be a count is not a whole number in range.
    #[error("entity {kind} at {de}: parameter {index} = {value} is not a count")]
    NotACount {
        /// The entity type.
        kind: u32,
        /// Its directory entry.
        de: usize,
        /// The parameter's position.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// An entity has fewer parameters than its counts need.
    #[error("entity {kind} at {de}: {found} parameters, {need} needed")]
    ParameterCount {
        /// The entity type.
        kind: u32,
        /// Its directory entry.
        de: usize,
        /// Parameters given.
        found: usize,
        /// Parameters needed.
        need: usize,
    },
    /// A trimmed surface's base surface is not an entity 128.
    #[error("entity 144 at {de}: base surface {pointer} is not an entity 128")]
    BaseSurface {
        /// The 144's directory entry.
        de: usize,
        /// Its base surface pointer.
        pointer: usize,
    },
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
    #[error("\"format\" must be \"{expected}\", found {}", found.as_ref().map_or_else(|| "none".to_string(), Excerpt::to_string))]
    Format {
        /// The format this build reads.
        expected: &'static str,
        /// What the file says (cut short).
        found: Option<Excerpt>,
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
    /// The document already holds [`MAX_TARGETS`](crate::sculpt::document::MAX_TARGETS)
    /// targets.
    #[error("more than {max} targets")]
    TooManyTargets {
        /// The cap.
        max: usize,
    },
    /// The document's history already holds
    /// [`MAX_DEFORMS`](crate::sculpt::document::MAX_DEFORMS) deformations.
    #[error("more than {max} lattice deformations")]
    TooManyDeforms {
        /// The cap.
        max: usize,
    },
    /// The document already holds [`MAX_STROKES`](crate::sculpt::document::MAX_STROKES)
    /// strokes.
    #[error("more than {max} strokes")]
    TooManyStrokes {
        /// The cap.
        max: usize,
    },
    /// A stroke would take the document's wand samples, all strokes together, past
    /// [`MAX_DOCUMENT_SAMPLES`](crate::sculpt::document::MAX_DOCUMENT_SAMPLES).
    #[error("{total} wand samples in all strokes, more than {max}")]
    TooManySamples {
        /// Samples the document would hold.
        total: usize,
        /// The cap.
        max: usize,
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
    /// A lattice grab radius is not in `(0, MAX_REACH_M]`.
    #[error(
        "lattice radius {radius} m must be positive and at most {} m",
        crate::lattice::MAX_REACH_M
    )]
    LatticeRadius {
        /// The radius asked for.
        radius: f64,
    },
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
    /// The lattice's degree or counts are out of range.
    #[error("lattice: {0}")]
    Lattice(crate::lattice::LatticeError),
}

/// A JSON syntax or schema error with its position, shared so that [`Error`](enum@Error) stays
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

/// The most characters of a JSON error's message that [`JsonError`] prints (before
/// its position): serde quotes bad values whole, and a value may be megabytes long.
pub const MAX_JSON_MESSAGE_CHARS: usize = 2 * MAX_QUOTED_CHARS + 32;

impl fmt::Display for JsonError {
    /// serde's message cut to [`MAX_JSON_MESSAGE_CHARS`] (with `...`), then its
    /// position (`at line L column C`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = self.0.to_string();
        let position = format!(" at line {} column {}", self.0.line(), self.0.column());
        let (message, position) = match text.strip_suffix(&position) {
            Some(message) if self.0.line() > 0 => (message, position.as_str()),
            _ => (text.as_str(), ""),
        };
        match message.char_indices().nth(MAX_JSON_MESSAGE_CHARS) {
            Some((end, _)) => write!(f, "{}...{position}", &message[..end]),
            None => write!(f, "{message}{position}"),
        }
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

/// `Result` with [`Error`](enum@Error).
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

    /// Regression (issue 15): serde quotes a bad value whole ("invalid type: string
    /// ..."), so a document with a megabyte-long string where a number belongs gave a
    /// megabyte-long message. The message is cut; the position is kept.
    #[test]
    fn json_error_quoting_a_huge_value_is_cut_but_keeps_its_position() {
        let text = format!("[\n\"{}\"]", "y".repeat(1 << 20));
        let e: JsonError = serde_json::from_str::<Vec<u8>>(&text).unwrap_err().into();
        let shown = e.to_string();
        assert!(shown.len() < 250, "{} bytes", shown.len());
        assert!(
            shown.contains("...") && shown.ends_with("at line 2 column 1048578"),
            "{shown}"
        );
        let short: JsonError = serde_json::from_str::<u8>("[").unwrap_err().into();
        assert_eq!(short.to_string(), short.inner().to_string());
    }

    #[test]
    fn excerpt_keeps_a_short_prefix_and_counts_the_rest() {
        let e = Excerpt::new(&"\u{e9}".repeat(MAX_QUOTED_CHARS + 5));
        assert_eq!(e.prefix.chars().count(), MAX_QUOTED_CHARS);
        assert_eq!(e.cut_chars, 5);
        assert!(e.to_string().ends_with("... (5 more characters)"), "{e}");
        let whole = Excerpt::new("abc");
        assert!(!whole.is_cut());
        assert_eq!(whole.to_string(), "\"abc\"");
    }
}
