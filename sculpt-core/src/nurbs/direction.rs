//! Which parametric direction of a surface: a plain value the kernel and the errors
//! that name a direction ([`Error::InvalidKnots`](crate::Error::InvalidKnots)) share.

/// Which parametric direction of a surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Along `u` (across rows `i`).
    U,
    /// Along `v` (across columns `j`).
    V,
}
