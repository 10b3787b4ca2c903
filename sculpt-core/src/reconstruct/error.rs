//! Why reading a point file or reconstructing from it failed.

use thiserror::Error;

use crate::error::Excerpt;

/// What went wrong reading points or clustering them. Every variant says where (line,
/// element, byte offset) and carries its cause.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ReconstructError {
    /// The file extension names no point format this reader knows.
    #[error("unknown point format {0} (expected xyz, pwn, ply, obj or off)")]
    UnknownFormat(Excerpt),
    /// A text line is not valid UTF-8.
    #[error("line {line}: not UTF-8 text")]
    NotText {
        /// 1-based line number.
        line: usize,
    },
    /// A number could not be parsed.
    #[error("line {line}: {text} is not a number")]
    Number {
        /// 1-based line number.
        line: usize,
        /// The field as written (a short prefix of it).
        text: Excerpt,
        /// The parser's error.
        #[source]
        cause: std::num::ParseFloatError,
    },
    /// A line has the wrong number of fields.
    #[error("line {line}: {got} fields, expected {expected}")]
    FieldCount {
        /// 1-based line number.
        line: usize,
        /// Fields found.
        got: usize,
        /// Fields expected (a description such as "3 or 6").
        expected: &'static str,
    },
    /// A coordinate or normal component is NaN or infinite.
    #[error("line {line}: coordinate is not finite")]
    NotFinite {
        /// 1-based line number (for binary PLY: the vertex index + 1).
        line: usize,
    },
    /// A header (PLY, OFF) is malformed.
    #[error("header line {line}: {reason}")]
    Header {
        /// 1-based line number.
        line: usize,
        /// What is wrong, from a fixed set of descriptions (never input text).
        reason: &'static str,
    },
    /// The file ends before all declared elements were read.
    #[error("truncated: {what} {index} of {count} is missing")]
    Truncated {
        /// The element kind ("vertex", "face", ...).
        what: String,
        /// The 0-based index of the first missing element.
        index: usize,
        /// How many were declared.
        count: usize,
    },
    /// The file holds no points.
    #[error("no points")]
    NoPoints,
    /// More patches asked for than there are distinct points.
    #[error("{patches} patches asked for but only {points} distinct points")]
    TooManyPatches {
        /// Patches asked for.
        patches: usize,
        /// Distinct points available.
        points: usize,
    },
    /// Zero patches asked for.
    #[error("at least one patch is needed")]
    NoPatches,
    /// Points and normals differ in count.
    #[error("{points} points but {normals} normals")]
    NormalCount {
        /// Point count.
        points: usize,
        /// Normal count.
        normals: usize,
    },
    /// The degree is not 2 or 3.
    #[error("degree {degree} (expected 2 or 3)")]
    Degree {
        /// The degree asked for.
        degree: usize,
    },
    /// The control count does not fit the degree and the grid.
    #[error(
        "{control} control points per direction for degree {degree} (expected {degree} < N <= {max})"
    )]
    ControlCount {
        /// Control points asked for.
        control: usize,
        /// The degree.
        degree: usize,
        /// The most the local grids allow.
        max: usize,
    },
    /// A refit weight is negative or not finite (the grid weight must be positive).
    #[error("the refit weight {name} is {value} (expected a finite number, above 0 for the grid)")]
    Weight {
        /// The setting's name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The polygonal model has no quads to fit.
    #[error(
        "the patches never meet three at a time, so there are no quads to fit (try more patches)"
    )]
    NoQuads,
    /// The kernel's least-squares fit of a quad failed.
    #[error("fitting quad {quad}")]
    Fit {
        /// The quad.
        quad: usize,
        /// The kernel's error.
        #[source]
        cause: Box<crate::Error>,
    },
}
