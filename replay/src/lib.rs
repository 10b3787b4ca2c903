//! # replay
//!
//! Deterministic replay of recorded tracking sessions through the live Wandsculpt
//! pipeline, tracking-server emulation, and import of real Open Brush recordings.
//!
//! - [`pipeline`]: pose-log records through decode, frame stage (`tracking::stage`), the
//!   [`Interaction`](sculpt_core::interaction::Interaction) and the sculpting document, on a virtual clock; [`output`] writes the
//!   results (document, exports, operator log, metrics).
//! - [`config`]: the display config tables replay reads.
//! - [`check`]: `--check EXPECTED.json` comparisons with a readable diff.
//! - [`serve`]: tracking-server emulation (a log's raw bytes over TCP or serial, timed).
//! - [`tilt`], [`import`]: re-exported from [`tracking`], where they live so that pure
//!   tools (`sculpt-tools tilt2poselog`) read `.tilt` files without this crate's GPU
//!   dependencies: a total reader (and writer) for Open Brush / Tilt Brush `.tilt`
//!   sketches, and Open Brush strokes as wand motion placed on a target surface.
//! - [`sessions`]: the generator of the shipped sessions in `tests/data/sessions/`.
//!
//! ```
//! use replay::{config::ReplayConfig, pipeline};
//! // Replay a shipped session from the default surface, as the `replay` binary does.
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/sessions/patch-overlaps.poselog");
//! let log = std::fs::read(path)?;
//! let out = pipeline::replay_log(&log, &ReplayConfig::default(), pipeline::default_document(), "doc", false, None)?;
//! assert_eq!(out.metrics.gestures.strokes_applied, 2);
//! assert_eq!(out.document.strokes().len(), 2);
//! // A malformed .tilt file is a clear error, not a panic.
//! assert!(replay::tilt::read_tilt(b"not a tilt file").unwrap_err().to_string().contains("16-byte header"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub mod check;
pub mod config;
pub mod error;
pub mod output;
pub mod pipeline;
pub mod render;
pub mod serve;
pub mod sessions;

pub use error::{Error, Result};
pub use tracking::{import, tilt};
