//! Why a screen definition or a projection is unusable.

use thiserror::Error;

/// Why a screen definition is unusable.
#[derive(Debug, Error, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ScreenError {
    /// A corner is NaN or infinite.
    #[error("a corner is not finite")]
    CornerNotFinite,
    /// An edge is shorter than 0.1 mm.
    #[error("an edge is shorter than 0.1 mm")]
    EdgeTooShort,
    /// The lower and left edges are not perpendicular.
    #[error("the lower and left edges are not perpendicular")]
    NotRectangular,
}

/// Why a projection cannot be built.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ProjectionError {
    /// The eye position is NaN or infinite.
    #[error("eye position is not finite")]
    EyeNotFinite,
    /// The clip planes are not `0 < near < far`.
    #[error("need 0 < near < far, got {near} and {far}")]
    ClipPlanes {
        /// Near plane, metres.
        near: f64,
        /// Far plane, metres.
        far: f64,
    },
    /// The eye is too close to (or behind) the screen plane.
    #[error(
        "eye is {distance_m:.4} m in front of the screen plane; it must be at least {min_m} m in front"
    )]
    EyeTooClose {
        /// Distance in front of the plane, metres.
        distance_m: f64,
        /// The least allowed, metres.
        min_m: f64,
    },
}
