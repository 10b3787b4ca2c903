//! The typed errors of the volume module.

use std::fmt;

use thiserror::Error;

/// A control point's place in the net: `[i1][i2]..[in]`, as in the JSON nesting.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetIndex(pub Vec<usize>);

impl fmt::Display for NetIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for i in &self.0 {
            write!(f, "[{i}]")?;
        }
        Ok(())
    }
}

/// Everything that can be wrong with a volume, its file or a request made of it.
///
/// The reasons are part of each message, so a binary prints one clear line.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum VolumeError {
    /// The number of parameter directions is outside `1..=MAX_DIRECTIONS`.
    #[error("a volume has 1 to {max} parameter directions, not {got}")]
    Directions {
        /// Directions given.
        got: usize,
        /// The most allowed ([`super::MAX_DIRECTIONS`]).
        max: usize,
    },
    /// `degrees` and `knots` list different numbers of directions.
    #[error("{degrees} degrees but {knots} knot vectors")]
    DegreeKnotCount {
        /// Entries in `degrees`.
        degrees: usize,
        /// Entries in `knots`.
        knots: usize,
    },
    /// A knot vector (or its degree) is malformed.
    #[error("knots of direction {direction}: {reason}")]
    Knots {
        /// The direction, 0-based.
        direction: usize,
        /// What is wrong, from the knot-vector validation.
        reason: crate::Error,
    },
    /// A knot vector is not clamped (`p + 1` equal knots at both ends).
    #[error("knots of direction {direction} are not clamped: each end needs {need} equal knots")]
    NotClamped {
        /// The direction, 0-based.
        direction: usize,
        /// `degree + 1`.
        need: usize,
    },
    /// The attribute list is empty or too long.
    #[error("a volume has 1 to {max} attributes, not {got}")]
    AttributeCount {
        /// Attributes given.
        got: usize,
        /// The most allowed ([`super::MAX_COMPONENTS`]).
        max: usize,
    },
    /// An attribute name is empty or repeated.
    #[error("attribute {index} {name:?} is empty or repeated")]
    AttributeName {
        /// Its position.
        index: usize,
        /// The name.
        name: String,
    },
    /// The control net has more points than a volume may have.
    #[error("{count} control points exceed the cap of {max}")]
    TooManyControlPoints {
        /// Points the knots ask for.
        count: usize,
        /// The cap ([`super::MAX_CONTROL_POINTS`]).
        max: usize,
    },
    /// The flat control-value array has the wrong length.
    #[error("{got} control values given, the knots and attributes need {need}")]
    ControlValueCount {
        /// Values given.
        got: usize,
        /// `control points x attributes`.
        need: usize,
    },
    /// A nested list in the file has the wrong length for its level.
    #[error("{what}{at}: {got} entries, the knots of direction {direction} need {need}")]
    NestedLength {
        /// `control_points` or `weights`.
        what: &'static str,
        /// Where the list is.
        at: NetIndex,
        /// The direction that level runs along.
        direction: usize,
        /// Entries found.
        got: usize,
        /// Entries needed (`knots - degree - 1`).
        need: usize,
    },
    /// A leaf of `control_points` has the wrong number of components.
    #[error("control_points{at}: {got} components, the attributes need {need}")]
    LeafLength {
        /// The point.
        at: NetIndex,
        /// Components found.
        got: usize,
        /// The number of attributes.
        need: usize,
    },
    /// An entry of the nested arrays is not what the level needs (a list or a number).
    #[error("{what}{at}: expected {expected}")]
    NestedShape {
        /// `control_points` or `weights`.
        what: &'static str,
        /// Where.
        at: NetIndex,
        /// "a list" or "a number".
        expected: &'static str,
    },
    /// A control value is NaN, infinite or beyond [`super::MAX_JSON_VALUE`].
    #[error(
        "control point {at}, attribute {attribute}: {value} is not a finite value within +-{max:e}"
    )]
    ControlValue {
        /// The point.
        at: NetIndex,
        /// The attribute index.
        attribute: usize,
        /// The value.
        value: f64,
        /// The cap.
        max: f64,
    },
    /// A weight is not finite, not positive, or outside the reader's range.
    #[error(
        "weight {at} = {weight}: weights must be finite and positive (within [1/{max:e}, {max:e}])"
    )]
    Weight {
        /// The point.
        at: NetIndex,
        /// The weight.
        weight: f64,
        /// The reader's cap ([`super::MAX_WEIGHT`]).
        max: f64,
    },
    /// A parameter tuple has the wrong number of entries.
    #[error("{got} parameters given, the volume has {need} directions")]
    ParamCount {
        /// Parameters given.
        got: usize,
        /// Directions.
        need: usize,
    },
    /// An output buffer has the wrong length.
    #[error("the output holds {got} values, the volume writes {need}")]
    OutputLength {
        /// Values the buffer holds.
        got: usize,
        /// Values written.
        need: usize,
    },
    /// A parameter is NaN or infinite.
    #[error("parameter {direction} is not finite ({value})")]
    ParamNotFinite {
        /// The direction.
        direction: usize,
        /// The value.
        value: f64,
    },
    /// A derivative order above 2 was asked for.
    #[error("derivatives up to order {max} are available, not {got}")]
    DerivativeOrder {
        /// The order asked for.
        got: usize,
        /// The highest available.
        max: usize,
    },
    /// A direction index is not one of the volume's.
    #[error("direction {got} does not exist (the volume has {count})")]
    NoSuchDirection {
        /// The index asked for.
        got: usize,
        /// The number of directions.
        count: usize,
    },
    /// Knot insertion or refinement failed (knot outside the domain, unsorted, too many).
    #[error("knot insertion in direction {direction}: {reason}")]
    Insertion {
        /// The direction.
        direction: usize,
        /// The kernel's reason.
        reason: crate::Error,
    },
    /// Degree elevation would exceed the kernel's highest degree.
    #[error("degree {degree} + {by} in direction {direction} exceeds the highest degree {max}")]
    ElevationTooHigh {
        /// The direction.
        direction: usize,
        /// The current degree.
        degree: usize,
        /// The elevation asked for.
        by: usize,
        /// [`crate::nurbs::MAX_DEGREE`].
        max: usize,
    },
    /// The analysis needs a trivariate volume with the geometry attributes `x, y, z`.
    #[error(
        "{what} needs a volume with 3 parameter directions and attributes x, y, z (this one has {directions} directions and geometry {geometry:?})"
    )]
    NoGeometry {
        /// What was asked for.
        what: &'static str,
        /// The volume's directions.
        directions: usize,
        /// The geometry attributes found.
        geometry: Vec<String>,
    },
    /// The map is singular at a parameter: `sqrt(g) = B_u . (B_v x B_w)` vanishes.
    #[error("singular Jacobian at parameters {params:?} (sqrt(g) = {jacobian:e})")]
    SingularJacobian {
        /// Where.
        params: Vec<f64>,
        /// The Jacobian found.
        jacobian: f64,
    },
    /// A physical point lies outside the volume (the closest parameter is on the
    /// boundary and does not reach it).
    #[error("point ({}, {}, {}) is outside the volume (nearest boundary point {distance:e} away)", point[0], point[1], point[2])]
    OutsideVolume {
        /// The point.
        point: [f64; 3],
        /// Its distance from the nearest mapped point found.
        distance: f64,
    },
    /// An attribute name is not one of the volume's.
    #[error("no attribute {name:?} (the volume has {available:?})")]
    NoSuchAttribute {
        /// The name asked for.
        name: String,
        /// The attributes there are.
        available: Vec<String>,
    },
    /// The velocity vanishes on a curve or region: too many zeros to list.
    #[error(
        "more than {max} critical points: the velocity vanishes on a curve or a region, not at isolated points"
    )]
    TooManyCriticalPoints {
        /// The cap ([`super::critical::MAX_CRITICAL_POINTS`]).
        max: usize,
    },
    /// A sampling resolution is zero or too large.
    #[error("resolution {got}: use 1 to {max} cells per direction")]
    Resolution {
        /// The resolution asked for.
        got: usize,
        /// The most allowed.
        max: usize,
    },
    /// A number given to an application is NaN or infinite.
    #[error("{what} is not finite ({value})")]
    NotFinite {
        /// What the number is.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// The text is not JSON or does not follow the volume schema.
    #[error("volume JSON: {0}")]
    Json(crate::error::JsonError),
    /// The `format` or `version` field is wrong.
    #[error(
        "volume JSON: expected \"format\": \"wandsculpt-volume\" and \"version\": 1, found {format:?} version {version}"
    )]
    FormatTag {
        /// The `format` found.
        format: String,
        /// The `version` found.
        version: u64,
    },
}

/// The result type of the volume module.
pub type VolumeResult<T> = std::result::Result<T, VolumeError>;
