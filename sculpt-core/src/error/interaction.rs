//! Why the interaction refused an input, and which `[interaction]` setting is out of
//! range.

use thiserror::Error;

use super::stroke::{StrokeRejection, ToolRangeError};

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
