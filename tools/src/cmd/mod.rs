//! The subcommands, one module each, and the input/output helpers they share.

pub mod eval;
pub mod io;
pub mod project;
