//! Knot vectors and B-spline basis functions (P&T chapter 2).
//!
//! A [`KnotVector`] is validated once, at construction; everything downstream can then
//! index it without checks. The basis-function routines write into fixed-size stack
//! arrays ([`Basis`], [`BasisDers`]) so that evaluation never allocates.

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

use crate::error::{Error, KnotError, Result};

pub use super::limits::{MAX_DEGREE, MAX_DERIV, MAX_ORDER};

/// The `p + 1` non-zero basis values on one knot span; entries past `p` are zero.
pub type Basis = [f64; MAX_ORDER];
/// Rows `k = 0..=2` hold the `k`-th derivatives of the `p + 1` non-zero basis functions.
pub type BasisDers = [[f64; MAX_ORDER]; MAX_DERIV + 1];

/// A validated, non-decreasing knot vector `U = {u_0, ..., u_m}` for a given degree `p`.
///
/// Invariants checked by [`KnotVector::new`]:
/// - `1 <= p <= MAX_DEGREE`;
/// - at least `2(p + 1)` knots (so at least `p + 1` control points);
/// - all knots finite and non-decreasing;
/// - no interior knot repeated more than `p` times, no end knot more than `p + 1` times;
/// - the domain `[u_p, u_{m-p}]` has positive length.
///
/// Clamped (open, `p + 1` equal end knots) and unclamped vectors are both accepted; the
/// domain is `[u_p, u_{m-p}]` either way (P&T section 2.2).
#[derive(Debug, Clone, PartialEq)]
pub struct KnotVector {
    knots: Vec<f64>,
    degree: usize,
    /// The last span index `s` with `u_s < u_{s+1}` inside the domain.
    last_span: usize,
    /// `1 / (u_{i+p} - u_i)` (0 where the difference is 0), for eq. 2.7.
    inv_p: Vec<f64>,
    /// `1 / (u_{i+p-1} - u_i)` (0 where the difference is 0).
    inv_pm1: Vec<f64>,
}

fn inverse_differences(knots: &[f64], deg: usize) -> Vec<f64> {
    (0..knots.len())
        .map(|i| match knots.get(i + deg) {
            Some(&b) if b > knots[i] => 1.0 / (b - knots[i]),
            _ => 0.0,
        })
        .collect()
}

/// Derivatives of the degree-`deg` functions `N_{s-deg+i,deg}`, `i = 0..=deg`, from the
/// values `lower[i] = N_{s-deg+1+i,deg-1}` and `inv[g] = 1 / (u_{g+deg} - u_g)` (eq. 2.7).
#[inline(always)]
fn differentiate(
    lower: &[f64; MAX_ORDER],
    inv: &[f64],
    span: usize,
    deg: usize,
) -> [f64; MAX_ORDER] {
    let mut out = [0.0; MAX_ORDER];
    let f = deg as f64;
    let inv = &inv[span - deg..=span + 1];
    let mut prev = 0.0; // lower[i - 1] * inv[g]
    for i in 0..=deg {
        let next = if i < deg { lower[i] * inv[i + 1] } else { 0.0 };
        out[i] = f * (prev - next);
        prev = next;
    }
    out
}

fn knot_error(reason: KnotError) -> Error {
    Error::InvalidKnots {
        direction: None,
        reason,
    }
}

impl KnotVector {
    /// Validates `knots` for degree `degree`.
    pub fn new(degree: usize, knots: Vec<f64>) -> Result<Self> {
        if degree == 0 || degree > MAX_DEGREE {
            return Err(Error::InvalidDegree {
                direction: None,
                degree,
            });
        }
        let m = knots.len();
        if m < 2 * (degree + 1) {
            return Err(knot_error(KnotError::TooFew {
                count: m,
                degree,
                need: 2 * (degree + 1),
            }));
        }
        if let Some(i) = knots.iter().position(|k| !k.is_finite()) {
            return Err(knot_error(KnotError::NotFinite { index: i }));
        }
        if let Some(i) = knots.windows(2).position(|w| w[1] < w[0]) {
            return Err(knot_error(KnotError::Decreasing {
                index: i + 1,
                previous: knots[i],
                knot: knots[i + 1],
            }));
        }
        // Multiplicities.
        let mut i = 0;
        while i < m {
            let mut j = i;
            while j + 1 < m && knots[j + 1] == knots[i] {
                j += 1;
            }
            let mult = j - i + 1;
            let is_end = i == 0 || j == m - 1;
            let max = if is_end { degree + 1 } else { degree };
            if mult > max {
                return Err(knot_error(KnotError::Multiplicity {
                    knot: knots[i],
                    multiplicity: mult,
                    max,
                    degree,
                }));
            }
            i = j + 1;
        }
        let n = m - degree - 2; // index of the last control point
        let (a, b) = (knots[degree], knots[n + 1]);
        if b <= a {
            return Err(knot_error(KnotError::EmptyDomain {
                start: a,
                end: b,
                degree,
            }));
        }
        let mut last_span = n;
        while knots[last_span] >= knots[last_span + 1] {
            last_span -= 1;
        }
        let inv_p = inverse_differences(&knots, degree);
        let inv_pm1 = inverse_differences(&knots, degree - 1);
        Ok(Self {
            knots,
            degree,
            last_span,
            inv_p,
            inv_pm1,
        })
    }

    /// A clamped knot vector with uniform interior knots on `[0, 1]` for `count`
    /// control points of degree `degree`.
    pub fn uniform_clamped(degree: usize, count: usize) -> Result<Self> {
        if count < degree + 1 {
            return Err(knot_error(KnotError::TooFewControlPoints { count, degree }));
        }
        let spans = count - degree;
        let mut knots = vec![0.0; degree + 1];
        knots.extend((1..spans).map(|i| i as f64 / spans as f64));
        knots.extend(std::iter::repeat_n(1.0, degree + 1));
        Self::new(degree, knots)
    }

    /// The knots.
    #[inline]
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// The degree `p`.
    #[inline]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The number of control points, `n + 1 = m - p`.
    #[inline]
    pub fn count(&self) -> usize {
        self.knots.len() - self.degree - 1
    }

    /// The parameter domain `[u_p, u_{n+1}]`.
    #[inline]
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.count()])
    }

    /// True when both ends carry `p + 1` equal knots.
    pub fn is_clamped(&self) -> bool {
        let p = self.degree;
        let k = &self.knots;
        let m = k.len() - 1;
        k[..=p].iter().all(|&x| x == k[0]) && k[m - p..].iter().all(|&x| x == k[m])
    }

    /// How many times the value `u` occurs in the knot vector.
    pub fn multiplicity(&self, u: f64) -> usize {
        self.knots.iter().filter(|&&k| k == u).count()
    }

    /// The distinct knot values strictly inside the domain, with their multiplicities.
    pub fn interior_breaks(&self) -> Vec<(f64, usize)> {
        let (a, b) = self.domain();
        let mut out: Vec<(f64, usize)> = Vec::new();
        for &k in self.knots.iter().filter(|&&k| k > a && k < b) {
            match out.last_mut() {
                Some((v, m)) if *v == k => *m += 1,
                _ => out.push((k, 1)),
            }
        }
        out
    }

    /// Clamps `u` into the domain.
    #[inline]
    pub fn clamp(&self, u: f64) -> f64 {
        let (a, b) = self.domain();
        u.clamp(a, b)
    }

    /// The knot span index `s` with `u_s <= u < u_{s+1}` (P&T A2.1, by binary search).
    ///
    /// `u` is clamped into the domain; at the right end the last non-empty span is
    /// returned, so the result always indexes `p + 1` valid control points.
    #[inline]
    pub fn find_span(&self, u: f64) -> usize {
        let p = self.degree;
        let n = self.count() - 1;
        let k = &self.knots;
        if u >= k[n + 1] {
            return self.last_span;
        }
        if u <= k[p] {
            // Skip empty spans at the start of the domain.
            let mut s = p;
            while k[s + 1] <= k[p] {
                s += 1;
            }
            return s;
        }
        let (mut lo, mut hi) = (p, n + 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if u < k[mid] {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        lo
    }

    /// The `p + 1` non-vanishing basis functions `N_{s-p,p}(u) .. N_{s,p}(u)` on span `s`
    /// (P&T A2.2, the triangular scheme of eq. 2.5).
    #[inline]
    pub fn basis(&self, span: usize, u: f64) -> Basis {
        match self.degree {
            2 => self.basis_impl(2, span, u),
            3 => self.basis_impl(3, span, u),
            p => self.basis_impl(p, span, u),
        }
    }

    #[inline(always)]
    fn basis_impl(&self, p: usize, span: usize, u: f64) -> Basis {
        self.triangle(p, span, u)[0]
    }

    /// The triangular scheme of A2.2 (eq. 2.5) on span `s`: returns the non-zero basis
    /// functions of degrees `p`, `p - 1` and `p - 2` (each starting at index 0; the
    /// degree-0 function is `[1]`; a negative degree is all zeros).
    #[inline(always)]
    fn triangle(&self, p: usize, span: usize, u: f64) -> [Basis; 3] {
        let k = &self.knots;
        let mut n = [0.0; MAX_ORDER];
        let mut left = [0.0; MAX_ORDER];
        let mut right = [0.0; MAX_ORDER];
        let mut n_pm1 = [0.0; MAX_ORDER];
        let mut n_pm2 = [0.0; MAX_ORDER];
        n[0] = 1.0;
        if p == 1 {
            n_pm1[0] = 1.0;
        }
        if p == 2 {
            n_pm2[0] = 1.0;
        }
        for j in 1..=p {
            left[j] = u - k[span + 1 - j];
            right[j] = k[span + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                let temp = n[r] / (right[r + 1] + left[j - r]);
                n[r] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            n[j] = saved;
            if j + 2 == p {
                n_pm2 = n;
            } else if j + 1 == p {
                n_pm1 = n;
            }
        }
        [n, n_pm1, n_pm2]
    }

    /// The basis functions and their first and second derivatives on span `s`: row `k`
    /// holds `N^{(k)}_{s-p+j,p}(u)` (rows past `p` are zero).
    ///
    /// The fast path used by evaluation: the triangular scheme of A2.2 keeps the
    /// functions of degrees `p-2` and `p-1`, and the derivative formula P&T eq. 2.7,
    /// `N'_{i,p} = p (N_{i,p-1} / (u_{i+p} - u_i) - N_{i+1,p-1} / (u_{i+p+1} - u_{i+1}))`,
    /// is applied once for `N'` and twice for `N''`. Agrees with [`Self::basis_ders`]
    /// (A2.3) to rounding; see the tests.
    #[inline]
    pub fn basis_ders2(&self, span: usize, u: f64) -> BasisDers {
        // Constant degrees let the compiler unroll the loops for the common cases.
        match self.degree {
            2 => self.basis_ders2_impl(2, span, u),
            3 => self.basis_ders2_impl(3, span, u),
            p => self.basis_ders2_impl(p, span, u),
        }
    }

    #[inline(always)]
    fn basis_ders2_impl(&self, p: usize, span: usize, u: f64) -> BasisDers {
        let [n, n_pm1, n_pm2] = self.triangle(p, span, u);
        let d1 = differentiate(&n_pm1, &self.inv_p, span, p);
        let d2 = if p >= 2 {
            let d1_lower = differentiate(&n_pm2, &self.inv_pm1, span, p - 1);
            differentiate(&d1_lower, &self.inv_p, span, p)
        } else {
            [0.0; MAX_ORDER]
        };
        [n, d1, d2]
    }

    /// The basis functions and their derivatives up to order `nd <= 2` on span `s`
    /// (P&T A2.3). Row `k` holds `N^{(k)}_{s-p+j,p}(u)`; rows past `nd` (or past `p`)
    /// are zero.
    #[inline]
    pub fn basis_ders(&self, span: usize, u: f64, nd: usize) -> BasisDers {
        let p = self.degree;
        let nd = nd.min(MAX_DERIV);
        let k = &self.knots;
        let mut ndu = [[0.0; MAX_ORDER]; MAX_ORDER];
        let mut left = [0.0; MAX_ORDER];
        let mut right = [0.0; MAX_ORDER];
        ndu[0][0] = 1.0;
        for j in 1..=p {
            left[j] = u - k[span + 1 - j];
            right[j] = k[span + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                // Lower triangle: knot differences.
                ndu[j][r] = right[r + 1] + left[j - r];
                let temp = ndu[r][j - 1] / ndu[j][r];
                // Upper triangle: basis functions.
                ndu[r][j] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            ndu[j][j] = saved;
        }
        let mut ders = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        for j in 0..=p {
            ders[0][j] = ndu[j][p];
        }
        let top = nd.min(p);
        let mut a = [[0.0; MAX_ORDER]; 2];
        for r in 0..=p {
            let (mut s1, mut s2) = (0usize, 1usize);
            a[0][0] = 1.0;
            for kk in 1..=top {
                let mut d = 0.0;
                let rk = r as isize - kk as isize;
                let pk = p - kk;
                if r >= kk {
                    let rk = rk as usize;
                    a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
                    d = a[s2][0] * ndu[rk][pk];
                }
                let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
                let j2 = if (r as isize - 1) <= pk as isize {
                    kk - 1
                } else {
                    p - r
                };
                for j in j1..=j2 {
                    let idx = (rk + j as isize) as usize;
                    a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                    d += a[s2][j] * ndu[idx][pk];
                }
                if r <= pk {
                    a[s2][kk] = -a[s1][kk - 1] / ndu[pk + 1][r];
                    d += a[s2][kk] * ndu[r][pk];
                }
                ders[kk][r] = d;
                std::mem::swap(&mut s1, &mut s2);
            }
        }
        let mut fac = p as f64;
        for (kk, row) in ders.iter_mut().enumerate().take(top + 1).skip(1) {
            for v in row.iter_mut().take(p + 1) {
                *v *= fac;
            }
            fac *= (p - kk) as f64;
        }
        ders
    }

    /// All `n + 1` basis functions at `u` as a dense row (zeros outside the span); used
    /// by the fitting routines to build collocation matrices.
    pub fn basis_row(&self, u: f64) -> Vec<f64> {
        let u = self.clamp(u);
        let span = self.find_span(u);
        let b = self.basis(span, u);
        let mut row = vec![0.0; self.count()];
        for j in 0..=self.degree {
            row[span - self.degree + j] = b[j];
        }
        row
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{BASIS_DERIV_REL, ROUNDING_EPS, ULP_EPS};

    /// P&T Ex2.3: U = {0,0,0,1,2,3,4,4,5,5,5}, p = 2, u = 5/2.
    fn book() -> KnotVector {
        KnotVector::new(2, vec![0., 0., 0., 1., 2., 3., 4., 4., 5., 5., 5.]).unwrap()
    }

    #[test]
    fn book_example_2_3_basis() {
        let kv = book();
        let s = kv.find_span(2.5);
        assert_eq!(s, 4);
        let n = kv.basis(s, 2.5);
        // N_{2,2} = 1/8, N_{3,2} = 6/8, N_{4,2} = 1/8.
        assert_near!([n[0], n[1], n[2]], [0.125, 0.75, 0.125], ULP_EPS);
    }

    #[test]
    fn book_example_2_4_derivatives() {
        let kv = book();
        let d = kv.basis_ders(4, 2.5, 2);
        // N'_{2,2}(5/2) = -1/2, N'_{3,2} = 0, N'_{4,2} = 1/2; second derivatives 1, -2, 1.
        assert_near!([d[1][0], d[1][1], d[1][2]], [-0.5, 0.0, 0.5], ROUNDING_EPS);
        assert_near!([d[2][0], d[2][1], d[2][2]], [1.0, -2.0, 1.0], ROUNDING_EPS);
    }

    #[test]
    fn fast_derivatives_agree_with_a2_3() {
        let vectors = [
            KnotVector::new(1, vec![0., 0., 0.3, 1., 1.]).unwrap(),
            book(),
            KnotVector::new(3, vec![0., 0., 0., 0., 0.2, 0.2, 0.7, 1., 1., 1., 1.]).unwrap(),
            KnotVector::new(4, (0..14).map(f64::from).collect()).unwrap(),
            KnotVector::new(5, vec![0., 0., 0., 0., 0., 0., 0.5, 1., 1., 1., 1., 1., 1.]).unwrap(),
        ];
        for kv in vectors {
            let (a, b) = kv.domain();
            for i in 0..=40 {
                let u = a + (b - a) * i as f64 / 40.0;
                let s = kv.find_span(u);
                let slow = kv.basis_ders(s, u, 2);
                let fast = kv.basis_ders2(s, u);
                for r in 0..3 {
                    assert_near!(
                        fast[r],
                        slow[r],
                        BASIS_DERIV_REL
                            * (1.0 + slow[r].iter().fold(0.0, |m: f64, x| m.max(x.abs())))
                    );
                }
            }
        }
    }

    #[test]
    fn find_span_ends_and_repeated_knots() {
        let kv = book();
        assert_eq!(kv.find_span(0.0), 2);
        assert_eq!(kv.find_span(-1.0), 2);
        assert_eq!(kv.find_span(5.0), 7);
        assert_eq!(kv.find_span(4.0), 7);
        assert_eq!(kv.find_span(3.999), 5);
        assert_eq!(kv.find_span(f64::NAN), kv.find_span(f64::NAN)); // no panic
    }

    #[test]
    fn rejects_bad_vectors() {
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 1., 0.5, 1., 1.]),
            Err(Error::InvalidKnots {
                direction: None,
                reason: KnotError::Decreasing { index: 3, .. }
            })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., 1., 1.]),
            Err(Error::InvalidKnots {
                reason: KnotError::TooFew {
                    count: 5,
                    need: 6,
                    ..
                },
                ..
            })
        ));
        assert!(matches!(
            KnotVector::new(2, vec![0., 0., 0., 0.5, 0.5, 0.5, 1., 1., 1.]),
            Err(Error::InvalidKnots {
                reason: KnotError::Multiplicity {
                    multiplicity: 3,
                    max: 2,
                    ..
                },
                ..
            })
        ));
        assert!(matches!(
            KnotVector::new(0, vec![0., 1.]),
            Err(Error::InvalidDegree { degree: 0, .. })
        ));
        assert!(matches!(
            KnotVector::new(1, vec![0., f64::NAN, 1., 1.]),
            Err(Error::InvalidKnots { .. })
        ));
        assert!(matches!(
            KnotVector::new(1, vec![1., 1., 1., 1.]),
            Err(Error::InvalidKnots { .. })
        ));
    }

    #[test]
    fn unclamped_domain() {
        let kv = KnotVector::new(2, (0..8).map(f64::from).collect()).unwrap();
        assert!(!kv.is_clamped());
        assert_eq!(kv.domain(), (2.0, 5.0));
        assert_eq!(kv.find_span(5.0), 4);
        let n = kv.basis(kv.find_span(3.3), 3.3);
        assert_near!(n.iter().sum::<f64>(), 1.0, ULP_EPS);
    }
}
