//! Why the NURBS kernel refused an input: knot vectors, control nets, weights,
//! parameters and fits ([`Error`](enum@super::Error)'s kernel variants).

use std::fmt;

use glam::DVec3;
use thiserror::Error;

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
