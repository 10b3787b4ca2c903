//! R-functions: Boolean operations on implicit solids by arithmetic (Shin, Kim and
//! Sheen 2007, sec. 2.2; Rvachev's systems).
//!
//! In the paper's convention (omega >= 0 inside), an R-function's sign depends only on
//! the signs of its arguments, the way the Boolean operation's truth value depends on
//! its operands' (sec. 2.2.1). The systems of sec. 2.2.2 ('-' is AND, '+' is OR):
//!
//! - `R_alpha = (x + y -/+ sqrt(x^2 + y^2 - 2 alpha x y)) / (1 + alpha)`, `-1 < alpha <= 1`
//!   (`alpha = 1` is min / max);
//! - `R_0^m = (x + y -/+ sqrt(x^2 + y^2)) (x^2 + y^2)^(m/2)`;
//! - `R_p = x + y -/+ (x^p + y^p)^(1/p)`, p even;
//!
//! and negation is `-x` in all of them. `R_alpha` and `R_0^0` keep a first-order
//! normalised argument normalised on the boundary away from the other's zero set.
//! [`normalize`] is the first-order normaliser `f / sqrt(f^2 + |grad f|^2)` (sec.
//! 2.1.4).

use super::ImplicitError;
use super::expr::{Binary, Graph, NodeId, Unary, Var};
use super::interval::Interval;
pub use super::rsystem::{MonotoneR, RSystem};
use crate::tolerance::{
    RFUNC_INTERVAL_ABS, RFUNC_INTERVAL_ERR_MARGIN, RFUNC_INTERVAL_MAX_ARG, RFUNC_INTERVAL_MIN_ARG,
    RFUNC_INTERVAL_NAN_ALPHA,
};

/// The largest `m` of `R_0^m` and `p` of `R_p` accepted.
pub const MAX_R_EXPONENT: u32 = 16;

impl RSystem {
    /// Checks the parameter's range; `at` names the place in a document.
    pub fn check(self, at: &str) -> Result<Self, ImplicitError> {
        let bad = |name, value, expected| ImplicitError::Parameter {
            at: at.to_owned(),
            name,
            value,
            expected,
        };
        match self {
            RSystem::RAlpha { alpha } if !(alpha > -1.0 && alpha <= 1.0) => {
                Err(bad("alpha", alpha, "in (-1, 1]"))
            }
            RSystem::R0 { m } if m > MAX_R_EXPONENT => Err(bad("m", f64::from(m), "at most 16")),
            RSystem::Rp { p } if !(2..=MAX_R_EXPONENT).contains(&p) || p % 2 == 1 => {
                Err(bad("p", f64::from(p), "even, 2 to 16"))
            }
            ok => Ok(ok),
        }
    }

    /// `x AND y` in f64 (`sign = -1`) or `x OR y` (`sign = +1`), written directly from
    /// the formulas of sec. 2.2.2.
    fn combine_f64(self, x: f64, y: f64, sign: f64) -> f64 {
        match self {
            RSystem::RAlpha { alpha } => {
                (x + y + sign * (x * x + y * y - 2.0 * alpha * x * y).sqrt()) / (1.0 + alpha)
            }
            RSystem::R0 { m } => {
                let s = x * x + y * y;
                (x + y + sign * s.sqrt()) * s.powf(f64::from(m) / 2.0)
            }
            RSystem::Rp { p } => {
                // Scaled by m = max(|x|, |y|): a zero argument gives exactly m.
                let p = f64::from(p);
                let m = x.abs().max(y.abs());
                let norm = if m > 0.0 {
                    m * ((x / m).abs().powf(p) + (y / m).abs().powf(p)).powf(1.0 / p)
                } else {
                    0.0
                };
                x + y + sign * norm
            }
            RSystem::MinMax => {
                if sign < 0.0 {
                    x.min(y)
                } else {
                    x.max(y)
                }
            }
        }
    }

    /// Conjunction (AND) in f64.
    pub fn and_f64(self, x: f64, y: f64) -> f64 {
        self.combine_f64(x, y, -1.0)
    }

    /// Disjunction (OR) in f64.
    pub fn or_f64(self, x: f64, y: f64) -> f64 {
        self.combine_f64(x, y, 1.0)
    }

    /// Conjunction (AND) as graph nodes.
    pub fn and(self, g: &mut Graph, a: NodeId, b: NodeId) -> NodeId {
        self.combine(g, a, b, -1.0)
    }

    /// Disjunction (OR) as graph nodes.
    pub fn or(self, g: &mut Graph, a: NodeId, b: NodeId) -> NodeId {
        self.combine(g, a, b, 1.0)
    }

    fn combine(self, g: &mut Graph, x: NodeId, y: NodeId, sign: f64) -> NodeId {
        let root = self.combine_nodes(g, x, y, sign);
        let op = MonotoneR {
            system: self,
            or: sign > 0.0,
        };
        if op.is_monotone() {
            g.mark_monotone(root, [x, y], op);
        }
        root
    }

    fn combine_nodes(self, g: &mut Graph, x: NodeId, y: NodeId, sign: f64) -> NodeId {
        let sum = g.add(x, y);
        match self {
            RSystem::MinMax => {
                let op = if sign < 0.0 { Binary::Min } else { Binary::Max };
                g.binary(op, x, y)
            }
            RSystem::RAlpha { alpha } => {
                let s = g.norm2(&[x, y]);
                let xy = g.mul(x, y);
                let cross = g.scale(xy, -2.0 * alpha);
                let inner = g.add(s, cross);
                let root = g.sqrt(inner);
                let signed = g.scale(root, sign);
                let total = g.add(sum, signed);
                g.scale(total, 1.0 / (1.0 + alpha))
            }
            RSystem::R0 { m } => {
                let s = g.norm2(&[x, y]);
                let root = g.sqrt(s);
                let signed = g.scale(root, sign);
                let base = g.add(sum, signed);
                // (x^2 + y^2)^(m/2) = s^(m div 2) * sqrt(s)^(m mod 2).
                let mut factor = g.constant(1.0);
                for _ in 0..m / 2 {
                    factor = g.mul(factor, s);
                }
                if m % 2 == 1 {
                    factor = g.mul(factor, root);
                }
                g.mul(base, factor)
            }
            RSystem::Rp { p } => {
                // (x^p + y^p)^(1/p) for even p: by square roots when p is a power of
                // two (exact when one argument is 0); otherwise as
                // m ((x/m)^p + (y/m)^p)^(1/p), m = max(|x|, |y|), so that a zero
                // argument gives exactly m (the sign at the boundary is kept) and
                // nothing overflows.
                let powp = |g: &mut Graph, v: NodeId| {
                    let sq = g.square(v);
                    (1..p / 2).fold(sq, |acc, _| g.mul(acc, sq))
                };
                let root = if p.is_power_of_two() {
                    let (xp, yp) = (powp(g, x), powp(g, y));
                    let s = g.add(xp, yp);
                    (0..p.trailing_zeros()).fold(s, |acc, _| g.sqrt(acc))
                } else {
                    let (ax, ay) = (g.unary(Unary::Abs, x), g.unary(Unary::Abs, y));
                    let m = g.binary(Binary::Max, ax, ay);
                    let tiny = g.constant(f64::from(f32::MIN_POSITIVE));
                    let safe = g.binary(Binary::Max, m, tiny);
                    let (xs, ys) = (g.div(x, safe), g.div(y, safe));
                    let (xp, yp) = (powp(g, xs), powp(g, ys));
                    let s = g.add(xp, yp);
                    let l = g.unary(Unary::Ln, s);
                    let l = g.scale(l, 1.0 / f64::from(p));
                    let r = g.unary(Unary::Exp, l);
                    g.mul(m, r)
                };
                let signed = g.scale(root, sign);
                g.add(sum, signed)
            }
        }
    }
}

impl MonotoneR {
    /// Whether the corner rule holds for this system: `R_alpha`, `R_0^0` and `R_p`
    /// (`R_0^m`, m > 0, is not monotone).
    pub fn is_monotone(self) -> bool {
        matches!(
            self.system,
            RSystem::RAlpha { .. } | RSystem::R0 { m: 0 } | RSystem::Rp { .. }
        )
    }

    /// The value in f64 (sec. 2.2.2).
    pub fn eval_f64(self, x: f64, y: f64) -> f64 {
        if self.or {
            self.system.or_f64(x, y)
        } else {
            self.system.and_f64(x, y)
        }
    }

    /// Bounds on the tape's f32 values of this R-function over `x` by `y`: the f64
    /// values at the low and high corners widened by a bound on the f32 formula's
    /// error, or `None` where the rule does not apply (a NaN argument, magnitudes
    /// where the f32 squares could overflow or underflow, a system that is not
    /// monotone).
    ///
    /// The error bound, with `M = max|x| + max|y|` and `u = 2^-24`: every op of the
    /// formula (`x + y`, the squares, their sum, the root, the final sum) adds at most
    /// a few `u M`; the radicand `r = x^2 + y^2 - 2 alpha x y` may cancel, and an
    /// absolute error `d <= 5 u M^2` in it moves the root by at most
    /// `min(sqrt(d), d / sqrt(r))`, where `r >= (1 - |alpha|) (x^2 + y^2) >=
    /// (1 - |alpha|) M^2 / 2`: at most `min(2 sqrt(u), 8 u / sqrt(1 - |alpha|)) M`
    /// (`R_0`'s radicand is a sum of squares and does not cancel); everything is
    /// divided by `1 + alpha`. The bound taken is [`RFUNC_INTERVAL_ERR_MARGIN`] times
    /// that sum, plus [`RFUNC_INTERVAL_ABS`] for squares that underflow.
    ///
    /// `R_p = x + y -/+ ||(x, y)||_p` (p even) is monotone: `d||(x, y)||_p / dx =
    /// (x / ||(x, y)||_p)^(p - 1)` lies in `[-1, 1]`, so both partial derivatives of
    /// AND and OR lie in `[0, 2]`. Its f32 norm (in [`RSystem::and`]'s graph) is
    /// either `p/2` products and a sum of non-negative terms followed by `log2 p`
    /// square roots (p a power of two: relative error at most `(p/2 + 1) u / p +
    /// log2(p) u <= 5 u`), or `m exp(ln(sum of (x/m)^p) / p)` with `m = max(|x|,
    /// |y|)` and the sum in `[1, 2]` (a division, `p/2` products, a sum, `ln`, a
    /// scale, `exp` and a product, each at most one `u` relative or absolute on an
    /// argument below 1: at most `12 u`); with the norm at most `M` and the two sums
    /// `4 u M`, the bound taken is the margin times `(16 + p) u M`. The rule is
    /// refused where a power could overflow (`M^p > 2^120`, powers of two) or where
    /// the larger argument's power could underflow (`a^p < 2^-100`, `a` the least
    /// over the box of `max(|x|, |y|)`: a box at both arguments' zero), so that
    /// subnormal rounding (absolute `2^-149` per op) is below `2^-45` relative.
    pub fn corner_interval(self, x: Interval, y: Interval) -> Option<Interval> {
        if !self.is_monotone() || x.nan || y.nan {
            return None;
        }
        let mag = |i: Interval| f64::from(i.lo.abs().max(i.hi.abs()));
        let m = mag(x) + mag(y);
        if !(RFUNC_INTERVAL_MIN_ARG..=RFUNC_INTERVAL_MAX_ARG).contains(&m) {
            return None;
        }
        let u = f64::from(f32::EPSILON) / 2.0;
        let (root_err, scale) = match self.system {
            RSystem::RAlpha { alpha } => (
                (2.0 * u.sqrt()).min(8.0 * u / (1.0 - alpha.abs()).sqrt()) * m,
                1.0 / (1.0 + alpha),
            ),
            RSystem::Rp { p } => {
                let least = |i: Interval| {
                    if i.lo <= 0.0 && 0.0 <= i.hi {
                        0.0
                    } else {
                        f64::from(i.lo.abs().min(i.hi.abs()))
                    }
                };
                let a = least(x).max(least(y));
                let pi = p as i32;
                if a.powi(pi) < 2f64.powi(-100)
                    || (p.is_power_of_two() && m.powi(pi) > 2f64.powi(120))
                {
                    return None;
                }
                (f64::from(16 + p) * u * m, 1.0)
            }
            _ => (4.0 * u * m, 1.0),
        };
        let err = RFUNC_INTERVAL_ERR_MARGIN * (root_err + 8.0 * u * m) * scale + RFUNC_INTERVAL_ABS;
        let lo = self.eval_f64(f64::from(x.lo), f64::from(y.lo)) - err;
        let hi = self.eval_f64(f64::from(x.hi), f64::from(y.hi)) + err;
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        // Rounded outward to f32.
        let (lo32, hi32) = (lo as f32, hi as f32);
        let lo32 = if f64::from(lo32) > lo {
            lo32.next_down()
        } else {
            lo32
        };
        let hi32 = if f64::from(hi32) < hi {
            hi32.next_up()
        } else {
            hi32
        };
        // R_0's radicand is a sum of squares, never negative in f32; R_alpha's may
        // round below zero (NaN from the root) where alpha is within rounding of 1.
        let nan = match self.system {
            RSystem::RAlpha { alpha } => alpha.abs() >= 1.0 - RFUNC_INTERVAL_NAN_ALPHA,
            _ => false,
        };
        Some(Interval {
            lo: lo32,
            hi: hi32,
            nan,
        })
    }
}

/// Negation (NOT): `-x` in every system.
pub fn not(g: &mut Graph, a: NodeId) -> NodeId {
    g.neg(a)
}

/// The first-order normaliser `f / sqrt(f^2 + |grad f|^2)` of sec. 2.1.4 (eq. after
/// eq. 1): zero where `f` is, with |grad| = 1 there.
pub fn normalize(g: &mut Graph, f: NodeId) -> NodeId {
    let grads: Vec<NodeId> = [Var::X, Var::Y, Var::Z].map(|v| g.deriv(f, v)).to_vec();
    let mut all = grads;
    all.push(f);
    let s = g.norm2(&all);
    let r = g.sqrt(s);
    g.div(f, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{IMPLICIT_F32_REL, IMPLICIT_F64_EPS, IMPLICIT_UNIT_GRAD_EPS};
    use proptest::prelude::*;

    fn system() -> impl Strategy<Value = RSystem> {
        prop_oneof![
            (-0.99f64..=1.0).prop_map(|alpha| RSystem::RAlpha { alpha }),
            (0u32..=4).prop_map(|m| RSystem::R0 { m }),
            (1u32..=4).prop_map(|h| RSystem::Rp { p: 2 * h }),
            Just(RSystem::MinMax),
        ]
    }

    /// A value away from zero by more than rounding can blur, or exactly zero.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            1 => Just(0.0),
            8 => (0.01f64..10.0, any::<bool>()).prop_map(|(v, neg)| if neg { -v } else { v }),
        ]
    }

    fn sign(v: f64) -> i8 {
        if v > 0.0 {
            1
        } else if v < 0.0 {
            -1
        } else {
            0
        }
    }

    proptest! {
        /// The signs of AND, OR and NOT agree with min, max and negation (sec. 2.2.1),
        /// for the formulas in f64 and for the graphs the tapes run.
        #[test]
        fn signs_agree_with_min_max(sys in system(), x in value(), y in value()) {
            prop_assert_eq!(sign(sys.and_f64(x, y)), sign(x.min(y)));
            prop_assert_eq!(sign(sys.or_f64(x, y)), sign(x.max(y)));
            let mut g = Graph::new();
            let [vx, vy, _] = g.xyz();
            let and = sys.and(&mut g, vx, vy);
            let or = sys.or(&mut g, vx, vy);
            let nx = not(&mut g, vx);
            let p = [x, y, 0.0];
            prop_assert_eq!(sign(g.eval_f64(and, p)), sign(x.min(y)));
            prop_assert_eq!(sign(g.eval_f64(or, p)), sign(x.max(y)));
            prop_assert_eq!(sign(g.eval_f64(nx, p)), sign(-x));
            let tol = IMPLICIT_F32_REL * (1.0 + sys.and_f64(x, y).abs());
            prop_assert!((g.eval_f64(and, p) - sys.and_f64(x, y)).abs() <= tol);
        }
    }

    /// The interval over `x in [x0, x0 + wx]`, `y in [y0, y0 + wy]` of AND or OR as
    /// the tape evaluates it, and the range of its f32 values sampled on a 17 x 17
    /// lattice of the box (corners included).
    fn interval_and_samples(
        sys: RSystem,
        and: bool,
        x0: f32,
        wx: f32,
        y0: f32,
        wy: f32,
    ) -> (crate::implicit::interval::Interval, f32, f32) {
        let (tape, region) = r_tape(sys, and, x0, wx, y0, wy);
        let range = tape.eval_interval(region);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for i in 0..=16 {
            for j in 0..=16 {
                let x = (x0 + wx * i as f32 / 16.0).min(x0 + wx);
                let y = (y0 + wy * j as f32 / 16.0).min(y0 + wy);
                let v = tape.eval_point([x, y, 0.0]);
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (range, lo, hi)
    }

    proptest! {
        /// Interval bounds of the R-function compositions hold every sampled value.
        /// Their width is not bounded here, because it is not small: where
        /// `x + y -/+ sqrt(...)` cancels (one argument far from zero, or alpha near
        /// -1), the interval is as wide as the arguments' magnitudes, and not
        /// sign-definite even where both arguments are (measured in docs/implicit.md,
        /// "Interval bounds of R-functions").
        #[test]
        fn r_function_intervals_are_sound(sys in system(), and in any::<bool>(),
                x0 in -4.0f32..4.0, y0 in -4.0f32..4.0, wx in 0.001f32..1.0, wy in 0.001f32..1.0) {
            let (range, lo, hi) = interval_and_samples(sys, and, x0, wx, y0, wy);
            prop_assert!(range.lo <= lo && hi <= range.hi, "{range:?} misses [{lo}, {hi}]");
        }
    }

    fn monotone_system() -> impl Strategy<Value = RSystem> {
        prop_oneof![
            (-0.99f64..=1.0).prop_map(|alpha| RSystem::RAlpha { alpha }),
            Just(RSystem::R0 { m: 0 }),
            (1u32..=8).prop_map(|h| RSystem::Rp { p: 2 * h }),
        ]
    }

    proptest! {
        /// The corner bounds of the monotone R-functions (R_alpha, R_0^0, R_p) hold every
        /// sampled value, wide or narrow boxes, near zero or far; they are used (one
        /// bound on the tape), and never wider than the formula's interval.
        #[test]
        fn r_function_corner_intervals_hold_every_sample(sys in monotone_system(),
                and in any::<bool>(), x0 in -40.0f32..40.0, y0 in -40.0f32..40.0,
                wx in prop_oneof![Just(0.0f32), 1e-6f32..1e-3, 1e-3f32..20.0], // not a tolerance: box widths to sample
                wy in prop_oneof![Just(0.0f32), 1e-6f32..1e-3, 1e-3f32..20.0]) { // not a tolerance: box widths to sample
            let (range, lo, hi) = interval_and_samples(sys, and, x0, wx, y0, wy);
            prop_assert!(range.lo <= lo && hi <= range.hi, "{range:?} misses [{lo}, {hi}]");
            let (tape, region) = r_tape(sys, and, x0, wx, y0, wy);
            prop_assert_eq!(tape.r_bounds(), 1);
            let formula = tape.without_r_bounds().eval_interval(region);
            prop_assert!(range.hi - range.lo <= formula.hi - formula.lo);
        }
    }

    /// The tape of AND or OR of x and y, and the box `[x0, x0 + wx] x [y0, y0 + wy]`.
    fn r_tape(
        sys: RSystem,
        and: bool,
        x0: f32,
        wx: f32,
        y0: f32,
        wy: f32,
    ) -> (crate::implicit::tape::Tape, [Interval; 3]) {
        let mut g = Graph::new();
        let [vx, vy, _] = g.xyz();
        let r = if and {
            sys.and(&mut g, vx, vy)
        } else {
            sys.or(&mut g, vx, vy)
        };
        let region = [
            Interval::new(x0, x0 + wx),
            Interval::new(y0, y0 + wy),
            Interval::point(0.0),
        ];
        (crate::implicit::tape::Tape::compile(&g, r), region)
    }

    /// The worst cases measured before the corner bounds (docs/implicit.md, "Interval
    /// bounds of R-functions"): a far argument's width surviving the cancellation, and
    /// alpha near -1 multiplying it until not even the sign was decided.
    #[test]
    fn corner_bounds_fix_the_measured_worst_cases() {
        let (tape, region) = r_tape(
            RSystem::RAlpha { alpha: 0.0 },
            false,
            -3.50,
            0.74,
            0.0,
            0.001,
        );
        let (new, old) = (
            tape.eval_interval(region),
            tape.without_r_bounds().eval_interval(region),
        );
        eprintln!("R_alpha OR, alpha 0: corner {new:?}, formula {old:?}");
        assert!(old.hi - old.lo > 1.0, "{old:?}");
        assert!(new.hi - new.lo < 0.01, "{new:?}");
        let (tape, region) = r_tape(
            RSystem::RAlpha { alpha: -0.983 },
            false,
            1.265,
            0.001,
            -3.17,
            0.31,
        );
        let (new, old) = (
            tape.eval_interval(region),
            tape.without_r_bounds().eval_interval(region),
        );
        eprintln!("R_alpha OR, alpha -0.983: corner {new:?}, formula {old:?}");
        assert!(old.lo < 0.0 && old.hi > 0.0, "{old:?}");
        assert!(new.lo > 0.0 && !new.nan, "the sign is decided: {new:?}");
    }

    /// R_p's corner bound where its formula's interval is widest: a far argument's
    /// width surviving the cancellation of `x + ||(x, y)||_p` (OR), for a power of
    /// two and for the `exp`/`ln` form; at both arguments' zero the rule steps aside
    /// and the formula's interval stays.
    #[test]
    fn r_p_corner_bounds_are_narrow_where_the_formula_is_not() {
        for p in [4, 6] {
            let (tape, region) = r_tape(RSystem::Rp { p }, false, -3.50, 0.74, 0.0, 0.001);
            let (new, old) = (
                tape.eval_interval(region),
                tape.without_r_bounds().eval_interval(region),
            );
            eprintln!("R_{p} OR: corner {new:?}, formula {old:?}");
            assert!(old.hi - old.lo > 1.0, "{old:?}");
            assert!(new.hi - new.lo < 0.01, "{new:?}");
            let (tape, region) = r_tape(RSystem::Rp { p }, true, -0.5, 1.0, -0.5, 1.0);
            assert_eq!(
                tape.eval_interval(region),
                tape.without_r_bounds().eval_interval(region)
            );
        }
    }

    #[test]
    fn r_alpha_one_is_min_max() {
        let sys = RSystem::RAlpha { alpha: 1.0 };
        assert_near!(sys.and_f64(0.3, -1.2), -1.2, IMPLICIT_F64_EPS);
        assert_near!(sys.or_f64(0.3, -1.2), 0.3, IMPLICIT_F64_EPS);
    }

    #[test]
    fn parameters_out_of_range_are_refused() {
        assert!(RSystem::RAlpha { alpha: -1.0 }.check("t").is_err());
        assert!(RSystem::RAlpha { alpha: f64::NAN }.check("t").is_err());
        assert!(RSystem::Rp { p: 3 }.check("t").is_err());
        assert!(RSystem::R0 { m: 17 }.check("t").is_err());
        assert!(RSystem::Rp { p: 6 }.check("t").is_ok());
    }

    /// The normaliser makes an ellipse's |grad| 1 on its boundary (eq. 1, condition 2).
    #[test]
    fn normaliser_has_unit_gradient_on_the_boundary() {
        let mut g = Graph::new();
        let [x, y, _] = g.xyz();
        // 1 - x^2 / 4 - y^2: an ellipse with semi-axes 2 and 1, positive inside.
        let x2 = g.square(x);
        let x2 = g.scale(x2, -0.25);
        let y2 = g.square(y);
        let s = g.sub(x2, y2);
        let f = g.offset(s, 1.0);
        let n = normalize(&mut g, f);
        let (dx, dy) = (g.deriv(n, Var::X), g.deriv(n, Var::Y));
        for k in 0..12 {
            let t = f64::from(k) * 0.5;
            let p = [2.0 * t.cos(), t.sin(), 0.0];
            assert_near!(g.eval_f64(n, p), 0.0, IMPLICIT_UNIT_GRAD_EPS);
            let norm = g.eval_f64(dx, p).hypot(g.eval_f64(dy, p));
            assert_near!(norm, 1.0, IMPLICIT_UNIT_GRAD_EPS);
        }
    }
}
