//! The subcommands, one module each, and the input/output helpers they share.

pub mod eval;
pub mod export;
pub mod goms;
pub mod implicit;
pub mod io;
pub mod mesh;
pub mod project;
pub mod reconstruct;
pub mod rfm;
pub mod tilt2poselog;
pub mod volume;
pub mod volume_apps;
