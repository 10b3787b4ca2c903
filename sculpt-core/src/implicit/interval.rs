//! Interval arithmetic over the op set, for bounding a model over a box of points.
//!
//! An [`Interval`] `[lo, hi]` holds every value the tape's f32 evaluation can give
//! for points in the box, with a flag for "may be NaN" (Moore, *Interval Analysis*,
//! 1966; Fidget prunes with the same arithmetic).
//!
//! The bounds are for the f32 evaluation, which is what pruning must not change:
//! the correctly rounded ops (`+ - * /`, `sqrt`, `square`) need no widening, since
//! round-to-nearest is monotone, so rounding the exact result at the extreme
//! arguments bounds the rounded result at every argument between them. Widening
//! them as well (as this module once did) pushed a lower bound of 0 below zero, so
//! `sqrt` of a sum of squares was flagged "may be NaN" and nothing under a distance
//! was ever pruned. libm's transcendental functions are not correctly rounded,
//! only within a few ulps, and are widened by a few ulps.

use super::expr::{Binary, Unary};

/// A closed range of f32 values, possibly also NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower bound.
    pub lo: f32,
    /// Upper bound.
    pub hi: f32,
    /// Whether some point of the box may give NaN.
    pub nan: bool,
}

/// Ulps by which libm's transcendental results are widened (they are not correctly
/// rounded, but within a few ulps).
const TRANSCENDENTAL_ULPS: u32 = 4;

fn down(x: f32, ulps: u32) -> f32 {
    (0..ulps).fold(x, |v, _| v.next_down())
}

fn up(x: f32, ulps: u32) -> f32 {
    (0..ulps).fold(x, |v, _| v.next_up())
}

impl Interval {
    /// `[lo, hi]`, not NaN.
    pub fn new(lo: f32, hi: f32) -> Self {
        Self::checked(lo, hi, false)
    }

    /// The single value `v`.
    pub fn point(v: f32) -> Self {
        Self::checked(v, v, v.is_nan())
    }

    /// Everything, possibly NaN.
    pub fn everything() -> Self {
        Self {
            lo: f32::NEG_INFINITY,
            hi: f32::INFINITY,
            nan: true,
        }
    }

    /// `[lo, hi]`; a NaN bound (as `inf - inf` gives) widens to everything, NaN.
    fn checked(lo: f32, hi: f32, nan: bool) -> Self {
        if lo.is_nan() || hi.is_nan() {
            Self::everything()
        } else {
            Self { lo, hi, nan }
        }
    }

    /// Widened outward by `ulps`.
    fn widen(self, ulps: u32) -> Self {
        Self::checked(down(self.lo, ulps), up(self.hi, ulps), self.nan)
    }

    /// The values both `self` and `o` allow, where both hold every value of one
    /// quantity; `self` where they do not meet (which sound bounds never do).
    pub fn intersect(self, o: Self) -> Self {
        let (lo, hi) = (self.lo.max(o.lo), self.hi.min(o.hi));
        if lo <= hi {
            Self {
                lo,
                hi,
                nan: self.nan && o.nan,
            }
        } else {
            self
        }
    }

    /// Whether `v` lies in the range.
    pub fn contains(&self, v: f32) -> bool {
        self.lo <= v && v <= self.hi
    }

    fn hull(self, o: Self) -> Self {
        Self::checked(self.lo.min(o.lo), self.hi.max(o.hi), self.nan || o.nan)
    }

    fn map_monotone(self, f: impl Fn(f32) -> f32, ulps: u32) -> Self {
        Self::checked(f(self.lo), f(self.hi), self.nan).widen(ulps)
    }

    /// `op` over the interval.
    pub fn unary(self, op: Unary) -> Self {
        let a = self;
        match op {
            Unary::Neg => Self::checked(-a.hi, -a.lo, a.nan),
            Unary::Abs => {
                if a.lo >= 0.0 {
                    a
                } else if a.hi <= 0.0 {
                    Self::checked(-a.hi, -a.lo, a.nan)
                } else {
                    Self::checked(0.0, (-a.lo).max(a.hi), a.nan)
                }
            }
            Unary::Recip => Self::point(1.0).binary(Binary::Div, a),
            Unary::Sqrt => {
                if a.hi < 0.0 {
                    return Self::everything();
                }
                let lo = a.lo.max(0.0).sqrt();
                Self::checked(lo, a.hi.sqrt(), a.nan || a.lo < 0.0)
            }
            Unary::Square => {
                let abs = a.unary(Unary::Abs);
                Self::checked(abs.lo * abs.lo, abs.hi * abs.hi, a.nan)
            }
            Unary::Floor => a.map_monotone(f32::floor, 0),
            Unary::Ceil => a.map_monotone(f32::ceil, 0),
            Unary::Round => a.map_monotone(f32::round, 0),
            Unary::Sin | Unary::Cos => {
                Self::checked(-1.0, 1.0, a.nan || a.lo.is_infinite() || a.hi.is_infinite())
            }
            Unary::Tan => {
                let pi = std::f32::consts::PI;
                let branch = |v: f32| ((v + pi / 2.0) / pi).floor();
                // One branch, away from the poles by a margin: monotone.
                if a.lo.is_finite()
                    && a.hi.is_finite()
                    && branch(a.lo) == branch(a.hi)
                    && a.hi - a.lo < 3.0
                {
                    a.map_monotone(f32::tan, TRANSCENDENTAL_ULPS)
                } else {
                    Self::checked(
                        f32::NEG_INFINITY,
                        f32::INFINITY,
                        a.nan || !a.lo.is_finite() || !a.hi.is_finite(),
                    )
                }
            }
            Unary::Asin | Unary::Acos => {
                if a.hi < -1.0 || a.lo > 1.0 {
                    return Self::everything();
                }
                let nan = a.nan || a.lo < -1.0 || a.hi > 1.0;
                let (l, h) = (a.lo.max(-1.0), a.hi.min(1.0));
                let r = if op == Unary::Asin {
                    Self::checked(l.asin(), h.asin(), nan)
                } else {
                    Self::checked(h.acos(), l.acos(), nan)
                };
                r.widen(TRANSCENDENTAL_ULPS)
            }
            Unary::Atan => a.map_monotone(f32::atan, TRANSCENDENTAL_ULPS),
            Unary::Exp => {
                let r = a.map_monotone(f32::exp, TRANSCENDENTAL_ULPS);
                Self::checked(r.lo.max(0.0), r.hi, r.nan)
            }
            Unary::Ln => {
                if a.hi < 0.0 {
                    return Self::everything();
                }
                let lo = if a.lo <= 0.0 {
                    f32::NEG_INFINITY
                } else {
                    a.lo.ln()
                };
                Self::checked(lo, a.hi.ln(), a.nan || a.lo < 0.0).widen(TRANSCENDENTAL_ULPS)
            }
            Unary::Not => {
                if !a.contains(0.0) {
                    Self::checked(0.0, 0.0, a.nan)
                } else if a.lo == 0.0 && a.hi == 0.0 {
                    Self::checked(1.0, 1.0, a.nan)
                } else {
                    Self::checked(0.0, 1.0, a.nan)
                }
            }
        }
    }

    /// `op` over two intervals.
    pub fn binary(self, op: Binary, b: Self) -> Self {
        let a = self;
        let nan = a.nan || b.nan;
        match op {
            Binary::Add => Self::checked(a.lo + b.lo, a.hi + b.hi, nan),
            Binary::Sub => Self::checked(a.lo - b.hi, a.hi - b.lo, nan),
            Binary::Mul => {
                let p = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
                if p.iter().any(|v| v.is_nan()) {
                    // 0 * inf somewhere.
                    return Self::everything();
                }
                let lo = p.iter().copied().fold(f32::INFINITY, f32::min);
                let hi = p.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                Self::checked(lo, hi, nan)
            }
            Binary::Div => {
                if b.contains(0.0) {
                    let nan = nan || a.contains(0.0) || b.lo.is_infinite() || b.hi.is_infinite();
                    return Self::checked(f32::NEG_INFINITY, f32::INFINITY, nan);
                }
                let p = [a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi];
                if p.iter().any(|v| v.is_nan()) {
                    return Self::everything();
                }
                let lo = p.iter().copied().fold(f32::INFINITY, f32::min);
                let hi = p.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                Self::checked(lo, hi, nan)
            }
            Binary::Min => Self::checked(a.lo.min(b.lo), a.hi.min(b.hi), nan),
            Binary::Max => Self::checked(a.lo.max(b.lo), a.hi.max(b.hi), nan),
            Binary::Atan2 => {
                let pi = std::f32::consts::PI;
                Self::checked(down(-pi, 1), up(pi, 1), nan)
            }
            Binary::Compare => {
                if a.hi < b.lo {
                    Self::checked(-1.0, -1.0, nan)
                } else if a.lo > b.hi {
                    Self::checked(1.0, 1.0, nan)
                } else if a.lo == a.hi && b.lo == b.hi && a.lo == b.lo {
                    Self::checked(0.0, 0.0, nan)
                } else {
                    Self::checked(-1.0, 1.0, nan)
                }
            }
            Binary::Mod => {
                let m = b.lo.abs().max(b.hi.abs());
                let nan = nan
                    || b.contains(0.0)
                    || !a.lo.is_finite()
                    || !a.hi.is_finite()
                    || !b.lo.is_finite()
                    || !b.hi.is_finite();
                Self::checked(0.0, m, nan)
            }
            Binary::And => {
                if !a.contains(0.0) {
                    Self::checked(b.lo, b.hi, nan)
                } else if a.lo == 0.0 && a.hi == 0.0 {
                    Self::checked(0.0, 0.0, nan)
                } else {
                    b.hull(Self::point(0.0)).hull(Self::checked(0.0, 0.0, nan))
                }
            }
            Binary::Or => {
                if !a.contains(0.0) {
                    Self::checked(a.lo, a.hi, nan)
                } else if a.lo == 0.0 && a.hi == 0.0 {
                    Self::checked(b.lo, b.hi, nan)
                } else {
                    a.hull(b)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ordered(a: f32, b: f32) -> Interval {
        Interval::new(a.min(b), a.max(b))
    }

    proptest! {
        /// Every op's interval holds the op's value at points drawn from the inputs.
        #[test]
        fn intervals_hold_point_values(a0 in -5.0f32..5.0, a1 in -5.0f32..5.0,
                b0 in -5.0f32..5.0, b1 in -5.0f32..5.0, s in 0.0f32..1.0, t in 0.0f32..1.0) {
            let (ia, ib) = (ordered(a0, a1), ordered(b0, b1));
            let a = ia.lo + s * (ia.hi - ia.lo);
            let b = ib.lo + t * (ib.hi - ib.lo);
            let (a, b) = (a.clamp(ia.lo, ia.hi), b.clamp(ib.lo, ib.hi));
            for op in Unary::ALL {
                let v = op.apply(a);
                let r = ia.unary(op);
                prop_assert!(if v.is_nan() { r.nan } else { r.contains(v) }, "{op:?}({a}) = {v} not in {r:?}");
            }
            for op in Binary::ALL {
                let v = op.apply(a, b);
                let r = ia.binary(op, ib);
                prop_assert!(if v.is_nan() { r.nan } else { r.contains(v) }, "{op:?}({a}, {b}) = {v} not in {r:?}");
            }
        }
    }
}
