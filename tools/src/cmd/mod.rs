//! One module per `sculpt-tools` subcommand.

pub mod goms;
pub mod tilt2poselog;
