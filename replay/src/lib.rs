//! # replay
//!
//! Deterministic replay of recorded tracking sessions through the live Wandsculpt
//! pipeline, tracking-server emulation, and import of real Open Brush recordings.
//!
//! - [`tilt`]: a total reader (and writer) for Open Brush / Tilt Brush `.tilt` sketches.
//! - [`import`]: Open Brush strokes as wand motion placed on a target surface.
//! - [`check`]: `--check EXPECTED.json` comparisons with a readable diff.
//! - [`serve`]: tracking-server emulation (a log's raw bytes over TCP or serial, timed).
//! - [`sessions`]: the generator of the shipped sessions in `tests/data/sessions/`.
//!
//! ```
//! // Reading a .tilt file: bytes in, strokes out, or a clear error.
//! let err = replay::tilt::read_tilt(b"not a tilt file").unwrap_err();
//! assert!(err.to_string().contains("16-byte header"));
//! ```
#![warn(missing_docs)]

pub mod check;
pub mod config;
pub mod driver;
pub mod error;
pub mod import;
pub mod output;
pub mod pipeline;
pub mod serve;
pub mod sessions;
pub mod tilt;

pub use error::{Error, Result};
