//! Why a paint stroke or an attribute field is refused ([`crate::paint`]).

use thiserror::Error;

use crate::volume::fit::FitError;

/// Why a paint stroke or an attribute field is refused.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum PaintError {
    /// The stroke has no wand samples.
    #[error("a paint stroke needs at least one wand sample")]
    NoSamples,
    /// The stroke has more than [`MAX_STROKE_SAMPLES`](crate::paint::MAX_STROKE_SAMPLES) wand samples.
    #[error("{count} wand samples exceed the limit of {max}")]
    TooManySamples {
        /// Samples given.
        count: usize,
        /// [`MAX_STROKE_SAMPLES`](crate::paint::MAX_STROKE_SAMPLES).
        max: usize,
    },
    /// The brush radius is not in `(0, MAX_BRUSH_RADIUS_M]`.
    #[error("brush radius {radius} m is outside (0, {max}] m")]
    Radius {
        /// The radius given.
        radius: f64,
        /// [`MAX_BRUSH_RADIUS_M`](crate::paint::MAX_BRUSH_RADIUS_M).
        max: f64,
    },
    /// A point or value is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which one.
        what: &'static str,
    },
    /// The attribute's name is empty, too long, or not a lower-case word.
    #[error("attribute name {name:?} must be 1..={max} characters of a-z, 0-9, '-' or '_'")]
    Name {
        /// The name given.
        name: String,
        /// [`MAX_NAME_CHARS`](crate::paint::MAX_NAME_CHARS).
        max: usize,
    },
    /// The value has the wrong number of components for its attribute.
    #[error("attribute {attribute:?} takes {need} values, got {got}")]
    ValueCount {
        /// The attribute.
        attribute: String,
        /// Values given.
        got: usize,
        /// Values it takes (3 for colour, 1 otherwise).
        need: usize,
    },
    /// A colour component is outside `[0, 1]`, or a scalar beyond [`MAX_SCALAR`](crate::paint::MAX_SCALAR).
    #[error("value {value} is out of range for attribute {attribute:?}")]
    ValueRange {
        /// The attribute.
        attribute: String,
        /// The bad value.
        value: f64,
    },
    /// No wand sample came within the brush radius of the target: nothing to paint.
    #[error("no wand sample came within the brush radius ({radius} m) of the target")]
    NothingUnderBrush {
        /// The brush radius.
        radius: f64,
    },
    /// The field would hold more than [`MAX_FIELD_SAMPLES`](crate::paint::MAX_FIELD_SAMPLES) samples.
    #[error("the field would hold {count} samples, more than {max}")]
    FieldFull {
        /// Samples it would hold.
        count: usize,
        /// [`MAX_FIELD_SAMPLES`](crate::paint::MAX_FIELD_SAMPLES).
        max: usize,
    },
    /// The field's box is empty or not finite.
    #[error("the attribute box is empty or not finite")]
    Box,
    /// The scattered-data fit failed.
    #[error("fitting the attribute volume: {0}")]
    Fit(#[source] Box<FitError>),
}
