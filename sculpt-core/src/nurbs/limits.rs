//! The kernel's fixed sizes: basis functions live in stack arrays of these lengths.
//! Plain numbers, so the errors that quote them
//! ([`Error::InvalidDegree`](crate::Error::InvalidDegree)) need nothing else of the
//! kernel.

/// The highest degree the kernel supports (basis functions live in stack arrays).
pub const MAX_DEGREE: usize = 9;
/// `MAX_DEGREE + 1`: the length of the stack arrays for basis values.
pub const MAX_ORDER: usize = MAX_DEGREE + 1;
/// The highest derivative order the evaluation routines compute.
pub const MAX_DERIV: usize = 2;
