//! Why a stroke was rejected, and the tool parameters it names.

use std::fmt;

use thiserror::Error;

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
