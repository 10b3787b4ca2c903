//! Why reading a point file or reconstructing from it failed: [`ReconstructError`],
//! defined beside the core's [`Error`](enum@crate::Error) (its `Fit` variant carries
//! one, and `Error::Reconstruct` carries it).

pub use crate::error::ReconstructError;
