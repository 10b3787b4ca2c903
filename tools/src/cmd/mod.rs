//! One module per `sculpt-tools` subcommand.

pub mod export;
pub mod goms;
pub mod mesh;
