//! The named tolerances used only by `sculpt-tools` (its code and its tests), next to
//! their users; the workspace-wide ones stay in `sculpt_core::tolerance`. Each says
//! what it compares and in what unit. A float literal with a negative exponent outside
//! a crate's tolerance module fails `sculpt-core/tests/tolerance_literals.rs`.
//!
//! `sculpt-tools` is a binary crate: its integration tests include this file with
//! `#[path = "../src/tolerance.rs"]`.

// ---------------------------------------------------------------------------------
// Mesh export (`mesh`, `reconstruct`).
// ---------------------------------------------------------------------------------

/// Command-line mesh export welds vertices closer than this fraction of the scene's
/// size (metres per metre).
pub const MESH_WELD_REL: f64 = 1e-7;
/// The smallest weld distance of a command-line mesh export (metres).
pub const MESH_WELD_MIN: f64 = 1e-9;

// ---------------------------------------------------------------------------------
// The GOMS harness: synthetic sessions, plots, tables, labels.
// ---------------------------------------------------------------------------------

/// Uniform samples are clamped to at least this before a logarithm (Box-Muller).
pub const LOG_ARG_MIN: f64 = 1e-12;
/// A time span (seconds) of a plot is at least this.
pub const MIN_PLOT_SPAN: f64 = 1e-3;
/// Added before truncating a percentage to two decimals so values that are exact in
/// decimal but not in binary (7.74 stored as 7.7399999...) are not truncated down.
pub const TRUNCATE_EPS: f64 = 1e-9;
/// The smallest upper end of a plot's value axis (an all-zero series still draws).
pub const PLOT_RANGE_MIN: f64 = 1e-9;
/// The smallest upper end of a plot's speed axis.
pub const PLOT_SPEED_MIN: f64 = 1e-6;
/// A movement's amplitude (metres) below this has no Fitts width.
pub const AMPLITUDE_EPS: f64 = 1e-9;
/// Printed statistical tables give 6 significant digits.
pub const PRINTED_TABLE_EPS: f64 = 1e-5;
/// Sums and ratios of a few two-decimal numbers (the tools' CSV cells) agree to this.
pub const DECIMAL_SUM_EPS: f64 = 1e-9;
/// A glyph's ink in a rasterised plot label against the font's metrics: whole pixels,
/// an antialiased edge counting on either side (pixels).
pub const GLYPH_INK_PX: f64 = 1.0;
/// Sums of a few dozen glyph advances in `f32` pixels, added in another order (pixels).
pub const GLYPH_ADVANCE_SUM_EPS: f64 = 1e-3;
