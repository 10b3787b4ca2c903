//! Tolerances, in one place.
//!
//! Every comparison of floating-point results in Wandsculpt, in code and in tests,
//! names one of these constants and, in tests, goes through [`assert_near!`](crate::assert_near).
//! Lengths are metres in the display frame unless a name says otherwise.

/// Two points closer than this (metres) are the same point (P&T's epsilon 1).
pub const POINT_EPS: f64 = 1e-9;
/// A cosine smaller than this counts as zero (P&T's epsilon 2, for point inversion).
pub const COSINE_EPS: f64 = 1e-9;
/// Parameter values closer than this are the same parameter.
pub const PARAM_EPS: f64 = 1e-12;
/// Exact constructions (rational conics, knot insertion) reproduce shapes to this.
pub const EXACT_EPS: f64 = 1e-12;
/// Consecutive feet of a stroke's samples farther apart along the surface than this
/// many sample spacings jumped to another basin of the distance (see
/// [`crate::sculpt::stroke`]): the stroke is split there.
pub const BASIN_JUMP_RATIO: f64 = 4.0;
/// Finite-difference derivative checks agree to this (relative to the derivative's size).
pub const FD_EPS: f64 = 1e-5;

/// True when `a` and `b` differ by at most `tol`, counting NaN as never near.
#[inline]
pub fn near(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// True when a difference `d` is within tolerance `t`; a NaN difference never is.
#[inline]
pub fn within(d: f64, t: f64) -> bool {
    d <= t
}

/// Asserts that two values are within a tolerance of each other.
///
/// Works on anything that implements [`Near`]: `f64`, `f32`, arrays and slices of
/// them, and tuples of two. The message prints both sides, the difference and the
/// tolerance.
///
/// ```
/// use sculpt_core::assert_near;
/// assert_near!(0.1 + 0.2, 0.3, 1e-15);
/// assert_near!([1.0, 2.0], [1.0, 2.0 + 1e-13], sculpt_core::tolerance::EXACT_EPS);
/// ```
#[macro_export]
macro_rules! assert_near {
    ($left:expr, $right:expr, $tol:expr $(,)?) => {
        $crate::assert_near!($left, $right, $tol, "")
    };
    ($left:expr, $right:expr, $tol:expr, $($msg:tt)+) => {{
        let (l, r, t) = (&$left, &$right, $tol as f64);
        let d = $crate::tolerance::Near::max_abs_diff(l, r);
        if !$crate::tolerance::within(d, t) {
            panic!(
                "assert_near failed: {} vs {}\n  left:  {:?}\n  right: {:?}\n  max |diff| = {:e} > tol {:e}\n  {}",
                stringify!($left), stringify!($right), l, r, d, t, format!($($msg)+)
            );
        }
    }};
}

/// Values that can be compared within a tolerance.
pub trait Near: std::fmt::Debug {
    /// The largest absolute component difference (NaN or infinity when incomparable).
    fn max_abs_diff(&self, other: &Self) -> f64;
}

impl Near for f64 {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        let d = (self - other).abs();
        if d.is_nan() { f64::INFINITY } else { d }
    }
}

impl Near for f32 {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        f64::from(*self).max_abs_diff(&f64::from(*other))
    }
}

impl<T: Near> Near for [T] {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        if self.len() != other.len() {
            return f64::INFINITY;
        }
        self.iter()
            .zip(other)
            .map(|(a, b)| a.max_abs_diff(b))
            .fold(0.0, f64::max)
    }
}

impl<T: Near, const N: usize> Near for [T; N] {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        self.as_slice().max_abs_diff(other.as_slice())
    }
}

impl<T: Near> Near for Vec<T> {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        self.as_slice().max_abs_diff(other.as_slice())
    }
}

impl<A: Near, B: Near> Near for (A, B) {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        self.0
            .max_abs_diff(&other.0)
            .max(self.1.max_abs_diff(&other.1))
    }
}

impl<T: Near + ?Sized> Near for &T {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        (**self).max_abs_diff(*other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_within_tolerance() {
        assert_near!(1.0, 1.0 + 1e-10, 1e-9);
        assert_near!(vec![1.0f32, 2.0], vec![1.0f32, 2.0], 0.0);
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn fails_outside_tolerance() {
        assert_near!(1.0, 1.1, 1e-3);
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn nan_is_never_near() {
        assert_near!(f64::NAN, f64::NAN, 1.0);
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn length_mismatch_fails() {
        assert_near!(vec![1.0], vec![1.0, 2.0], 1.0);
    }

    #[test]
    fn near_fn() {
        assert!(near(1.0, 1.5, 0.5));
        assert!(!near(f64::NAN, 0.0, 1.0));
    }
}
