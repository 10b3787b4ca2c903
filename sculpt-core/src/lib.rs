//! # sculpt-core
//!
//! The pure geometry core of Wandsculpt: no I/O, threads of its own, GPU or async.
//!
//! It will hold the NURBS kernel (evaluation, derivatives, knots, point inversion,
//! fitting), the multiresolution UV vector map with strokes, Jordan classification and
//! trimming, tessellation into mesh sinks, the document with undo, file formats as bytes
//! in and out, and the interaction state machine that turns wand events into edits.
#![warn(missing_docs)]

pub mod edit_loop;
pub mod editor;
pub mod error;
pub mod formats;
pub mod implicit;
pub mod interaction;
pub mod lattice;
pub mod mesh;
pub mod nurbs;
pub mod oplog;
pub mod paint;
pub mod percentile;
pub mod reconstruct;
pub mod sculpt;
pub mod solid;
pub mod study;
pub mod tolerance;
pub mod volume;

pub use error::{Error, Result};
