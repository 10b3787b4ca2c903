//! The cubic B-spline basis of one knot vector as one polynomial per span, for the
//! SIMD evaluator ([`super::eval_simd`]).
//!
//! On a non-empty span `[u_s, u_{s+1})` the four basis functions `N_{s-3,3} ..
//! N_{s,3}` that do not vanish are cubic polynomials (P&T sec. 2.2, property P2.1 and
//! eq. 2.5). In the span's local coordinate `x = (t - u_s) / (u_{s+1} - u_s)`, in
//! `[0, 1]`, each is `sum_m c_m x^m`. The coefficients come from the triangle of
//! P&T A2.2 run once per span on polynomials in `x` instead of numbers: every
//! `left_j = t - u_{s+1-j}` and `right_j = u_{s+j} - t` is linear in `x`, and every
//! denominator `right_{r+1} + left_{j-r} = u_{s+r+1} - u_{s+1-j+r}` is a knot
//! difference, a constant (non-zero on a non-empty span). The first derivatives'
//! coefficients are those of `d/dx` divided by the span's length.
//!
//! An evaluation is then two Horner schemes whose four lanes are the four functions,
//! three and two multiply-adds, with no division: A2.2 and eq. 2.7 as the scalar
//! path runs them ([`super::eval::cubic_basis`]) divide six times per direction, three
//! of them one after the other.

use crate::nurbs::KnotVector;

/// The four cubic basis functions on one span, as polynomials in the span's local
/// coordinate (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SpanPoly {
    /// `u_s`, where `x = 0`.
    pub start: f64,
    /// `1 / (u_{s+1} - u_s)`: `x = (t - start) * inv_len`.
    pub inv_len: f64,
    /// `value[m][r]`: the coefficient of `x^m` in `N_{s-3+r,3}`.
    pub value: [[f64; 4]; 4],
    /// `slope[m][r]`: the coefficient of `x^m` in `dN_{s-3+r,3} / dt`.
    pub slope: [[f64; 4]; 3],
}

/// A polynomial in `x` of degree at most 3, `p[m]` the coefficient of `x^m`.
type Poly = [f64; 4];

/// `(a + b x) p`, for `p` of degree at most 2.
fn times_linear([a, b]: [f64; 2], p: &Poly) -> Poly {
    [
        a * p[0],
        a * p[1] + b * p[0],
        a * p[2] + b * p[1],
        a * p[3] + b * p[2],
    ]
}

impl SpanPoly {
    /// The polynomials of the non-empty span `s` of the cubic knots `k` (P&T A2.2 on
    /// polynomials, module docs).
    fn new(k: &[f64], s: usize) -> Self {
        let start = k[s];
        let len = k[s + 1] - start;
        let mut n: [Poly; 4] = [[0.0; 4]; 4];
        n[0][0] = 1.0;
        for j in 1..=3 {
            let mut saved: Poly = [0.0; 4];
            for r in 0..j {
                // right_{r+1} = u_{s+r+1} - t, left_{j-r} = t - u_{s+1-j+r}.
                let right = [k[s + r + 1] - start, -len];
                let left = [start - k[s + 1 - j + r], len];
                let inv = 1.0 / (k[s + r + 1] - k[s + 1 - j + r]);
                let temp = n[r].map(|c| c * inv);
                let rt = times_linear(right, &temp);
                n[r] = std::array::from_fn(|m| saved[m] + rt[m]);
                saved = times_linear(left, &temp);
            }
            n[j] = saved;
        }
        let inv_len = 1.0 / len;
        Self {
            start,
            inv_len,
            value: std::array::from_fn(|m| std::array::from_fn(|r| n[r][m])),
            slope: std::array::from_fn(|m| {
                std::array::from_fn(|r| (m + 1) as f64 * n[r][m + 1] * inv_len)
            }),
        }
    }

    /// The four values and first derivatives at `t` (in or at the ends of the span),
    /// in scalar arithmetic (what the SIMD kernel does lane by lane).
    #[cfg(test)]
    fn eval(&self, t: f64) -> ([f64; 4], [f64; 4]) {
        let x = (t - self.start) * self.inv_len;
        let v = &self.value;
        let d = &self.slope;
        (
            std::array::from_fn(|r| v[0][r] + x * (v[1][r] + x * (v[2][r] + x * v[3][r]))),
            std::array::from_fn(|r| d[0][r] + x * (d[1][r] + x * d[2][r])),
        )
    }
}

/// The [`SpanPoly`] of every span of one cubic knot vector.
#[derive(Clone, PartialEq, Default)]
pub(super) struct CubicSpans {
    /// Index `s - 3` for the span `s`; empty spans hold zeros (no span search returns
    /// them).
    polys: Vec<SpanPoly>,
}

impl std::fmt::Debug for CubicSpans {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The table is derived from the knots: its size says enough.
        f.debug_struct("CubicSpans")
            .field("spans", &self.polys.len())
            .finish()
    }
}

impl CubicSpans {
    /// The table of the cubic knot vector `kv`, or none for another degree.
    pub(super) fn new(kv: &KnotVector) -> Option<Self> {
        if kv.degree() != 3 {
            return None;
        }
        let k = kv.knots();
        let polys = (3..kv.count())
            .map(|s| {
                if k[s] < k[s + 1] {
                    SpanPoly::new(k, s)
                } else {
                    SpanPoly {
                        start: k[s],
                        inv_len: 0.0,
                        value: [[0.0; 4]; 4],
                        slope: [[0.0; 4]; 3],
                    }
                }
            })
            .collect();
        Some(Self { polys })
    }

    /// The polynomials of span `s` (a span index [`KnotVector::find_span`] returns).
    #[inline(always)]
    pub(super) fn span(&self, s: usize) -> &SpanPoly {
        &self.polys[s - 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::VOLUME_EVAL_REL;
    use crate::volume::eval::cubic_basis;

    /// Uneven knots over unequal intervals, with double and triple interior knots.
    fn vectors() -> Vec<Vec<f64>> {
        vec![
            vec![0., 0., 0., 0., 1., 1., 1., 1.],
            vec![-1., -1., -1., -1., 0.2, 2., 2., 2., 2.],
            vec![0., 0., 0., 0., 1., 2.5, 2.5, 4., 4., 4., 4.],
            vec![3., 3., 3., 3., 3.1, 3.1, 3.1, 7., 9., 9.5, 9.5, 9.5, 9.5],
            vec![0., 0., 0., 0., 0.001, 0.4, 0.4001, 0.9, 1., 1., 1., 1.],
        ]
    }

    /// The polynomial of each span agrees with the scalar A2.2 / A2.3 at the span's
    /// ends and inside it, values and derivatives.
    #[test]
    fn span_polynomials_match_cox_de_boor() {
        for knots in vectors() {
            let kv = KnotVector::new(3, knots.clone()).expect("valid knots");
            let table = CubicSpans::new(&kv).expect("cubic");
            for s in 3..kv.count() {
                let (a, b) = (knots[s], knots[s + 1]);
                if a >= b {
                    continue;
                }
                for i in 0..=16 {
                    let t = a + (b - a) * f64::from(i) / 16.0;
                    let (n, dn) = table.span(s).eval(t);
                    let (en, edn) = cubic_basis::<true>(&knots, s, t);
                    assert_near!(n, en, VOLUME_EVAL_REL, "knots {knots:?}, span {s}, t {t}");
                    let scale = edn.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
                    assert_near!(
                        dn,
                        edn,
                        VOLUME_EVAL_REL * scale,
                        "knots {knots:?}, span {s}, t {t}"
                    );
                }
            }
        }
    }

    /// Only cubic vectors get a table.
    #[test]
    fn other_degrees_have_no_table() {
        let kv = KnotVector::new(2, vec![0., 0., 0., 1., 1., 1.]).expect("valid knots");
        assert!(CubicSpans::new(&kv).is_none());
    }
}
