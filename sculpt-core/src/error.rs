//! The one error type of `sculpt-core`, and the typed reasons its variants carry.
//!
//! This file holds [`Error`](enum@Error) and the reasons that carry an `Error` in turn
//! ([`DocumentError`], [`ReconstructError`]); the other reasons live in submodules by
//! subsystem (kernel, strokes, file formats, operator log, interaction, quoted text)
//! and are re-exported here. No reason module uses this file, so the error types form
//! no import circle.

use thiserror::Error;

use crate::nurbs::Direction;

mod format;
mod interaction;
mod nurbs;
mod oplog;
mod paint;
mod solid;
mod stroke;
mod text;

pub use format::{FileFormat, FormatError, GltfPart, WrittenValue};
pub use interaction::{InteractionConfigError, InteractionError};
pub use nurbs::{ControlNetError, FitError, KnotError, NetIndex, ParameterError, WeightError};
pub use oplog::OpLogError;
pub use paint::PaintError;
pub use solid::{ModelError, SolidError};
pub use stroke::{StrokeRejection, ToolParam, ToolRangeError};
pub use text::{Chain, Excerpt, JsonError, MAX_JSON_MESSAGE_CHARS, MAX_QUOTED_CHARS};

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
        crate::nurbs::limits::MAX_DEGREE
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
    Reconstruct(#[from] ReconstructError),

    // Lattice deformation.
    /// A lattice or a deformation was refused; the reason says why.
    #[error("lattice: {0}")]
    Lattice(#[from] crate::lattice::LatticeError),

    // Solid targets.
    /// A solid target or a stroke on it was refused; the reason says why.
    #[error("solid: {0}")]
    Solid(#[from] SolidError),
    // Painted attributes.
    /// A paint stroke or attribute field was refused; the reason says why.
    #[error("paint: {0}")]
    Paint(#[from] PaintError),
}

fn knots_prefix(direction: Option<Direction>) -> &'static str {
    match direction {
        None => "",
        Some(Direction::U) => "knots_u: ",
        Some(Direction::V) => "knots_v: ",
    }
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
    /// The document already holds
    /// [`MAX_SOLIDS`](crate::sculpt::document::MAX_SOLIDS) solid targets.
    #[error("more than {max} solid targets")]
    TooManySolids {
        /// The cap.
        max: usize,
    },
    /// The document's history already holds
    /// [`MAX_PAINTS`](crate::sculpt::document::MAX_PAINTS) paint strokes.
    #[error("more than {max} paint strokes")]
    TooManyPaints {
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
    /// A paint stroke of the file could not be applied again.
    #[error("paint stroke {index} (from 0): {error}")]
    Paint {
        /// Its position in the file's `paints`.
        index: usize,
        /// Why.
        error: Box<Error>,
    },
}

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
        cause: Box<Error>,
    },
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
