//! Why a solid target or a stroke on it was refused ([`crate::solid`]).

use std::sync::Arc;

use crate::implicit::ImplicitError;

/// A model that does not read, shared so that [`SolidError`] can be cloned and compared
/// like the crate's other errors (equal when the messages are).
#[derive(Debug, Clone, thiserror::Error)]
#[error(transparent)]
pub struct ModelError(pub Arc<ImplicitError>);

impl PartialEq for ModelError {
    fn eq(&self, other: &Self) -> bool {
        self.0.to_string() == other.0.to_string()
    }
}

impl From<ImplicitError> for SolidError {
    fn from(e: ImplicitError) -> Self {
        SolidError::Model(ModelError(Arc::new(e)))
    }
}

/// Why a solid target or a stroke on it was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolidError {
    /// The model does not read.
    #[error("model")]
    Model(#[source] ModelError),
    /// The grid resolution is out of range.
    #[error("{cells} cells along the longest side: must be in {min}..={max}")]
    Cells {
        /// As given.
        cells: usize,
        /// Fewest.
        min: usize,
        /// Most.
        max: usize,
    },
    /// No point of the search box may be inside the solid.
    #[error("the solid is empty within {half_size} m of the origin")]
    Empty {
        /// Half the search box's side.
        half_size: f64,
    },
    /// The stroke's tool is out of range.
    #[error("tool")]
    Tool(#[source] Box<crate::Error>),
    /// A sample has no surface normal (the gradient vanishes or is not finite).
    #[error("sample {index}: the solid has no surface normal there")]
    NoNormal {
        /// The sample.
        index: usize,
    },
    /// A sample is too far from the surface.
    #[error("sample {index} is {distance} m from the surface (at most {max} m)")]
    OffSurface {
        /// The sample.
        index: usize,
        /// Its distance.
        distance: f64,
        /// The limit.
        max: f64,
    },
    /// Fewer than two distinct samples.
    #[error("a stroke needs two distinct samples on the surface, found {count}")]
    TooFewSamples {
        /// Distinct samples.
        count: usize,
    },
    /// The solid holds [`MAX_SOLID_CUTS`](crate::solid::MAX_SOLID_CUTS) strokes already.
    #[error("the solid holds {max} strokes already")]
    TooManyCuts {
        /// The limit.
        max: usize,
    },
}
