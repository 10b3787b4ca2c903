//! The one error type of `sculpt-core`.

use thiserror::Error;

/// Everything that can go wrong in `sculpt-core`.
///
/// Each module adds its variants in its own block; callers match on the variant, and
/// each error is handled exactly once (reported, or turned into a fallback).
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    // NURBS kernel (knots, curves, surfaces, fitting, inversion).
    /// A knot vector is malformed.
    #[error("invalid knot vector: {0}")]
    InvalidKnots(String),
    /// A degree is zero or above [`crate::nurbs::MAX_DEGREE`].
    #[error("invalid degree: {0}")]
    InvalidDegree(String),
    /// The control net does not match the knot vectors (counts, ragged rows, NaN).
    #[error("invalid control net: {0}")]
    InvalidControlNet(String),
    /// A weight is missing, not finite or not positive.
    #[error("invalid weights: {0}")]
    InvalidWeights(String),
    /// A parameter (knot to insert, constructor argument) is out of range or not finite.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// A fit could not be computed (too few points, singular system, NaN data).
    #[error("fit failed: {0}")]
    FitFailed(String),
    /// A curve or surface JSON document could not be read.
    #[error("invalid NURBS JSON: {0}")]
    Json(String),

    // Sculpting (UV maps, strokes, trimming, documents, formats).
    /// A stroke was rejected; the reason says why.
    #[error("stroke rejected: {0}")]
    StrokeRejected(String),
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
    Document(String),
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
        reason: String,
    },

    // Interaction.
    /// The interaction state machine refused an input.
    #[error("interaction: {0}")]
    Interaction(String),
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
