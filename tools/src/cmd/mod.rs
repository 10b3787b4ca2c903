//! One module per `sculpt-tools` subcommand.

pub mod eval;
pub mod export;
pub mod goms;
pub mod mesh;
pub mod project;
