//! The R-function systems and the monotone ones among them, as plain data (the
//! formulas are in [`super::rfunc`]), so that the expression graph can record them
//! without depending on the R-function builders.

use serde::{Deserialize, Serialize};

/// An R-function system, with its parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RSystem {
    /// `R_alpha`, `-1 < alpha <= 1`.
    RAlpha {
        /// The parameter alpha.
        alpha: f64,
    },
    /// `R_0^m`, `m >= 0` (m = 0 is the paper's benchmark conjunction, Fig. 12).
    R0 {
        /// The exponent m.
        m: u32,
    },
    /// `R_p`, p even, `2 <= p <= 16`.
    Rp {
        /// The exponent p.
        p: u32,
    },
    /// min / max (`R_1`).
    MinMax,
}

impl Default for RSystem {
    fn default() -> Self {
        RSystem::R0 { m: 0 }
    }
}

/// An R-function that is non-decreasing in each argument, so that its exact range
/// over a box of arguments `[x_lo, x_hi] x [y_lo, y_hi]` is
/// `[R(x_lo, y_lo), R(x_hi, y_hi)]` (docs/implicit.md, "Interval bounds of
/// R-functions"): `R_alpha` (|alpha| <= 1: the partial derivatives are
/// `(1 -/+ (x - alpha y) / sqrt(x^2 + y^2 - 2 alpha x y)) / (1 + alpha)` and
/// `|x - alpha y|` is at most the root), `R_0^0` (alpha = 0 of the same) and `R_p`
/// (the partial derivatives of the p-norm lie in `[-1, 1]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonotoneR {
    /// The system.
    pub system: RSystem,
    /// Disjunction (OR) rather than conjunction (AND).
    pub or: bool,
}
