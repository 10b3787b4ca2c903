//! One percentile rule for every median and 99th percentile the workspace reports
//! (frame times, latencies, stroke timings). Issue 32 found four hand-written medians
//! and two different p99 rules; they all call this now.
//!
//! **The rule.** Of `n` samples sorted ascending, the `q`-quantile (`0 <= q <= 1`) is
//! the sample at 0-based rank `round(q (n - 1))`, halves rounded up. That is the
//! measured sample nearest the point that linear interpolation would report (Hyndman
//! and Fan 1996, "Sample quantiles in statistical packages", definition 7: position
//! `(n - 1) q + 1`, 1-based), so every figure is a value that was measured.
//! Consequences:
//! - the median of an even count is its upper middle (rank `n / 2`), of an odd count
//!   its middle;
//! - the p99 of 100 samples is the 99th smallest, of 200 samples the 198th, of 60
//!   samples the 59th: one slow frame among 100 shows only in the maximum, two show in
//!   the p99;
//! - one sample is its own every quantile; no samples have none.
//!
//! ```
//! use sculpt_core::percentile;
//! let mut ms: Vec<f64> = (1..=100).rev().map(f64::from).collect();
//! ms.sort_by(f64::total_cmp);
//! assert_eq!(percentile::median(&ms), Some(51.0));
//! assert_eq!(percentile::p99(&ms), Some(99.0));
//! assert_eq!(percentile::median::<f64>(&[]), None);
//! ```

/// The median's `q`.
pub const MEDIAN: f64 = 0.5;
/// The 99th percentile's `q`.
pub const P99: f64 = 0.99;

/// The 0-based rank of the `q`-quantile among `n` sorted samples: `round(q (n - 1))`
/// (`q` clamped to `[0, 1]`, NaN taken as 0); `None` when `n == 0`.
pub fn rank(n: usize, q: f64) -> Option<usize> {
    let last = n.checked_sub(1)?;
    let q = if q.is_nan() { 0.0 } else { q.clamp(0.0, 1.0) };
    // `as` saturates, and the product is at most `last`.
    Some(((last as f64 * q).round() as usize).min(last))
}

/// The `q`-quantile of `sorted` (ascending), by the module's rule; `None` when empty.
pub fn quantile<T: Copy>(sorted: &[T], q: f64) -> Option<T> {
    sorted.get(rank(sorted.len(), q)?).copied()
}

/// The median of `sorted` (ascending): the upper middle of an even count.
pub fn median<T: Copy>(sorted: &[T]) -> Option<T> {
    quantile(sorted, MEDIAN)
}

/// The 99th percentile of `sorted` (ascending).
pub fn p99<T: Copy>(sorted: &[T]) -> Option<T> {
    quantile(sorted, P99)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ranks worked by hand from `round(q (n - 1))`.
    #[test]
    fn ranks_follow_the_documented_rule() {
        assert_eq!(rank(0, MEDIAN), None);
        assert_eq!(rank(1, MEDIAN), Some(0));
        assert_eq!(rank(1, P99), Some(0));
        // Even counts: the upper middle; odd: the middle.
        assert_eq!(rank(2, MEDIAN), Some(1));
        assert_eq!(rank(4, MEDIAN), Some(2));
        assert_eq!(rank(5, MEDIAN), Some(2));
        // p99: 0.99 * 99 = 98.01; 0.99 * 199 = 197.01; 0.99 * 59 = 58.41; 0.99 * 9 = 8.91.
        assert_eq!(rank(100, P99), Some(98));
        assert_eq!(rank(200, P99), Some(197));
        assert_eq!(rank(60, P99), Some(58));
        assert_eq!(rank(10, P99), Some(9));
        // The ends, and q outside [0, 1].
        assert_eq!(rank(7, 0.0), Some(0));
        assert_eq!(rank(7, 1.0), Some(6));
        assert_eq!(rank(7, 2.0), Some(6));
        assert_eq!(rank(7, -1.0), Some(0));
        assert_eq!(rank(7, f64::NAN), Some(0));
    }

    /// The median is the sample at `n / 2` for every count: what the display server's
    /// and replay's reports printed before there was one rule.
    #[test]
    fn the_median_is_the_upper_middle_for_every_count() {
        for n in 1..=1000usize {
            let v: Vec<usize> = (0..n).collect();
            assert_eq!(median(&v), Some(n / 2), "n = {n}");
        }
    }

    #[test]
    fn quantiles_pick_measured_samples() {
        let v = [1.0, 2.0, 4.0, 8.0];
        assert_eq!(median(&v), Some(4.0));
        assert_eq!(p99(&v), Some(8.0));
        assert_eq!(quantile(&v, 0.25), Some(2.0)); // round(0.75) = 1
        assert_eq!(p99::<f64>(&[]), None);
        let d = [std::time::Duration::from_millis(3)];
        assert_eq!(median(&d), Some(std::time::Duration::from_millis(3)));
    }
}
