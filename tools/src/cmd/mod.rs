//! One module per `sculpt-tools` subcommand.

pub mod goms;
