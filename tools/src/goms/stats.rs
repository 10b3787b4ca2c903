//! Descriptive statistics for study aggregation: mean, SD, 95 % confidence intervals
//! (Student t with n-1 degrees of freedom, and a percentile bootstrap with a fixed seed),
//! and paired comparisons. Nothing here returns NaN: undefined values are `None`.

use statrs::distribution::{ContinuousCDF, StudentsT};

/// Bootstrap settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bootstrap {
    /// Resamples (0 turns the bootstrap off).
    pub reps: usize,
    /// Seed of the resampling generator, so reports are reproducible.
    pub seed: u64,
}

impl Default for Bootstrap {
    fn default() -> Self {
        Self {
            reps: 2000,
            seed: 0x5eed_2006,
        }
    }
}

/// Mean, spread and intervals of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Describe {
    /// Sample size.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n-1), when n >= 2.
    pub sd: Option<f64>,
    /// 95 % t interval of the mean, when n >= 2.
    pub ci_t: Option<(f64, f64)>,
    /// 95 % percentile-bootstrap interval of the mean, when n >= 2 and reps > 0.
    pub ci_boot: Option<(f64, f64)>,
}

/// Mean of a sample (`None` when empty).
pub fn mean(xs: &[f64]) -> Option<f64> {
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

/// Sample standard deviation with n-1 (`None` below two values).
pub fn sd(xs: &[f64]) -> Option<f64> {
    let m = mean(xs)?;
    (xs.len() >= 2).then(|| {
        let ss: f64 = xs.iter().map(|x| (x - m).powi(2)).sum();
        (ss / (xs.len() - 1) as f64).sqrt()
    })
}

/// The two-sided 95 % Student t critical value for `df` degrees of freedom.
pub fn t_crit95(df: usize) -> Option<f64> {
    let t = StudentsT::new(0.0, 1.0, df as f64).ok()?;
    let q = t.inverse_cdf(0.975);
    q.is_finite().then_some(q)
}

/// Percentile bootstrap 95 % interval of the mean.
pub fn bootstrap_ci(xs: &[f64], b: Bootstrap) -> Option<(f64, f64)> {
    if xs.len() < 2 || b.reps == 0 {
        return None;
    }
    let mut rng = fastrand::Rng::with_seed(b.seed);
    let n = xs.len();
    let mut means: Vec<f64> = (0..b.reps)
        .map(|_| (0..n).map(|_| xs[rng.usize(..n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    // The workspace's one percentile rule: the resampled mean at rank round(q (n - 1)).
    let at = |q: f64| sculpt_core::percentile::quantile(&means, q);
    Some((at(0.025)?, at(0.975)?))
}

/// Describes a sample (`None` when empty).
pub fn describe(xs: &[f64], b: Bootstrap) -> Option<Describe> {
    let m = mean(xs)?;
    let s = sd(xs);
    let ci_t = s.and_then(|s| {
        let h = t_crit95(xs.len() - 1)? * s / (xs.len() as f64).sqrt();
        Some((m - h, m + h))
    });
    Some(Describe {
        n: xs.len(),
        mean: m,
        sd: s,
        ci_t,
        ci_boot: bootstrap_ci(xs, b),
    })
}

/// A paired comparison `a - b` over matched participants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paired {
    /// Matched pairs.
    pub n: usize,
    /// Mean difference a - b.
    pub mean_diff: f64,
    /// SD of the differences, when n >= 2.
    pub sd_diff: Option<f64>,
    /// Paired t statistic, when defined (n >= 2 and SD > 0).
    pub t: Option<f64>,
    /// Degrees of freedom, n - 1.
    pub df: usize,
    /// Two-sided p value of the paired t test.
    pub p: Option<f64>,
    /// 95 % t interval of the mean difference.
    pub ci: Option<(f64, f64)>,
}

/// Paired t comparison of matched samples (`None` when no pairs).
pub fn paired(a: &[f64], b: &[f64]) -> Option<Paired> {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let m = mean(&d)?;
    let s = sd(&d);
    let n = d.len();
    let df = n.saturating_sub(1);
    let se = s.map(|s| s / (n as f64).sqrt());
    let t = se.filter(|&se| se > 0.0).map(|se| m / se);
    let p = t.and_then(|t| {
        let dist = StudentsT::new(0.0, 1.0, df as f64).ok()?;
        let p = 2.0 * (1.0 - dist.cdf(t.abs()));
        p.is_finite().then_some(p.clamp(0.0, 1.0))
    });
    let ci = se.and_then(|se| {
        let h = t_crit95(df)? * se;
        Some((m - h, m + h))
    });
    Some(Paired {
        n,
        mean_diff: m,
        sd_diff: s,
        t,
        df,
        p,
        ci,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::PRINTED_TABLE_EPS;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::EXACT_EPS;

    #[test]
    fn describe_by_hand() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, sum of squares 32, SD sqrt(32/7).
        let xs = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        let d = describe(&xs, Bootstrap::default()).unwrap();
        assert_near!(d.mean, 5.0, EXACT_EPS);
        assert_near!(d.sd.unwrap(), (32.0f64 / 7.0).sqrt(), EXACT_EPS);
        // t(0.975, 7) = 2.364624 (tables).
        let h = 2.364_624 * (32.0f64 / 7.0).sqrt() / 8f64.sqrt();
        let (lo, hi) = d.ci_t.unwrap();
        assert_near!(lo, 5.0 - h, PRINTED_TABLE_EPS);
        assert_near!(hi, 5.0 + h, PRINTED_TABLE_EPS);
        let (blo, bhi) = d.ci_boot.unwrap();
        assert!(blo < 5.0 && bhi > 5.0 && blo >= 2.0 && bhi <= 9.0);
        // Same seed, same interval.
        assert_eq!(
            bootstrap_ci(&xs, Bootstrap::default()),
            bootstrap_ci(&xs, Bootstrap::default())
        );
    }

    #[test]
    fn t_critical_values() {
        assert_near!(t_crit95(4).unwrap(), 2.776_445, PRINTED_TABLE_EPS);
        assert_near!(t_crit95(1).unwrap(), 12.706_2, 100.0 * PRINTED_TABLE_EPS);
        assert!(t_crit95(0).is_none());
    }

    #[test]
    fn small_samples_have_no_spread() {
        let d = describe(&[3.0], Bootstrap::default()).unwrap();
        assert_eq!((d.sd, d.ci_t, d.ci_boot), (None, None, None));
        assert!(describe(&[], Bootstrap::default()).is_none());
    }

    #[test]
    fn paired_by_hand() {
        // Differences 1, 2, 3: mean 2, SD 1, t = 2 / (1/sqrt 3) = 3.4641, df 2, p = 0.0742.
        let p = paired(&[11.0, 12.0, 13.0], &[10.0, 10.0, 10.0]).unwrap();
        assert_near!(p.mean_diff, 2.0, EXACT_EPS);
        assert_near!(p.t.unwrap(), 2.0 * 3f64.sqrt(), EXACT_EPS);
        assert_eq!(p.df, 2);
        assert_near!(p.p.unwrap(), 0.074_180, PRINTED_TABLE_EPS);
        // Constant differences: no t.
        let c = paired(&[2.0, 3.0], &[1.0, 2.0]).unwrap();
        assert_eq!((c.t, c.p), (None, None));
    }
}
