//! Fast repeated evaluation of one fixed surface: every Bezier patch of the surface in
//! power (monomial) form, for the Newton iterations of point inversion.
//!
//! A B-spline evaluation (P&T A3.6) spends most of its time on the span search (A2.1)
//! and the triangular basis scheme (A2.2, A2.3, with one division per entry). For a
//! surface that is queried many times both can be paid once: after refinement to Bezier
//! form (P&T A5.4), each patch `(a, c)` is the polynomial
//!
//! `S^w(s, t) = sum_k sum_l c_kl s^k t^l`, with the local parameters
//! `s = (u - u_a) / (u_{a+1} - u_a)` and `t = (v - v_c) / (v_{c+1} - v_c)` in `[0, 1]`,
//!
//! whose coefficients follow from the Bezier points by the change of basis
//! `c_k = C(n, k) sum_{i <= k} (-1)^{k-i} C(k, i) b_i` (P&T eq. 6.2's matrix form,
//! `M_n`), applied along `u` and then along `v`. Point and derivatives to second order
//! are then a few Horner sweeps (P&T A1.1 with derivatives), with no division except the
//! rational quotient (A4.4). On `[0, 1]` the monomial form of a cubic loses at most a
//! few units of the last digit against de Casteljau, far below the inversion
//! tolerances.

// Horner and the tensor sweeps index by degree, like the book.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, Mul};

use glam::{DVec2, DVec3, DVec4};

use super::knots::MAX_ORDER;
use super::surface::{NurbsSurface, SurfaceDerivs};

/// Degrees above this keep B-spline evaluation: the monomial coefficients of a degree-n
/// Bezier piece reach `C(n, k) 2^k` times the control points (forward differences), so
/// their rounding grows with n; up to degree 5 it stays below 1e-14 relative.
const MAX_POWER_DEGREE: usize = 5;

/// Patches with more coefficients than this are not converted (the evaluator falls back
/// to plain B-spline evaluation): 2^18 homogeneous points is 8 MiB.
const MAX_COEFFICIENTS: usize = 1 << 18;

/// A vector space element the Horner sweeps work on (`DVec3` for polynomial surfaces,
/// `DVec4` homogeneous points for rational ones).
trait Lin: Copy + Add<Output = Self> + Mul<f64, Output = Self> {
    const ZERO: Self;
}
impl Lin for DVec3 {
    const ZERO: Self = DVec3::ZERO;
}
impl Lin for DVec4 {
    const ZERO: Self = DVec4::ZERO;
}

/// The power-form patches of a surface in Bezier form; see the module docs.
#[derive(Debug, Clone)]
pub(crate) struct PowerPatches {
    p: usize,
    q: usize,
    /// Span breaks in `u`: `spans_u + 1` increasing values, first and last the domain.
    breaks_u: Vec<f64>,
    breaks_v: Vec<f64>,
    /// `1 / (u_{a+1} - u_a)` per span.
    inv_len_u: Vec<f64>,
    inv_len_v: Vec<f64>,
    /// Coefficients of polynomial surfaces: patch `a * spans_v + c`, then `k * (q+1) + l`.
    poly: Vec<DVec3>,
    /// Homogeneous coefficients of rational surfaces, same layout.
    rat: Vec<DVec4>,
}

/// `C(n, k)` for the small `n` of a degree.
fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// Bezier points `b_0..b_n` to power coefficients on `[0, 1]` (the matrix `M_n`).
fn to_power(b: &[DVec4]) -> Vec<DVec4> {
    let n = b.len() - 1;
    (0..=n)
        .map(|k| {
            let mut sum = DVec4::ZERO;
            for i in 0..=k {
                let sign = if (k - i) % 2 == 0 { 1.0 } else { -1.0 };
                sum += b[i] * (sign * binomial(k, i));
            }
            sum * binomial(n, k)
        })
        .collect()
}

impl PowerPatches {
    /// Converts `bz`, a surface in Bezier form (every interior knot of multiplicity
    /// equal to the degree), whose non-empty spans are `spans_u` and `spans_v` as
    /// `(index, start, end)`. `rational` is the original surface's flag (refinement can
    /// leave weights a rounding error away from 1). `None` for nets too big to be worth
    /// it and for degrees above 5.
    pub(crate) fn new(
        bz: &NurbsSurface,
        spans_u: &[(usize, f64, f64)],
        spans_v: &[(usize, f64, f64)],
        rational: bool,
    ) -> Option<Self> {
        let (p, q) = (bz.degree_u(), bz.degree_v());
        let (p1, q1) = (p + 1, q + 1);
        if p > MAX_POWER_DEGREE
            || q > MAX_POWER_DEGREE
            || spans_u.is_empty()
            || spans_v.is_empty()
            || spans_u.len() * spans_v.len() * p1 * q1 > MAX_COEFFICIENTS
        {
            return None;
        }
        let n_v = bz.count_v();
        let pw = bz.homogeneous();
        let mut coef = Vec::with_capacity(spans_u.len() * spans_v.len() * p1 * q1);
        for &(ku, _, _) in spans_u {
            for &(kv, _, _) in spans_v {
                // Along u for each column, then along v for each row.
                let mut net = vec![DVec4::ZERO; p1 * q1];
                for l in 0..q1 {
                    let col: Vec<DVec4> = (0..p1)
                        .map(|i| {
                            let h = pw[(ku - p + i) * n_v + kv - q + l];
                            if rational {
                                h
                            } else {
                                (h.truncate() / h.w).extend(1.0)
                            }
                        })
                        .collect();
                    for (k, c) in to_power(&col).into_iter().enumerate() {
                        net[k * q1 + l] = c;
                    }
                }
                for k in 0..p1 {
                    coef.extend(to_power(&net[k * q1..(k + 1) * q1]));
                }
            }
        }
        let breaks = |spans: &[(usize, f64, f64)]| -> (Vec<f64>, Vec<f64>) {
            let mut b: Vec<f64> = spans.iter().map(|s| s.1).collect();
            b.push(spans[spans.len() - 1].2);
            let inv = spans.iter().map(|s| 1.0 / (s.2 - s.1)).collect();
            (b, inv)
        };
        let (breaks_u, inv_len_u) = breaks(spans_u);
        let (breaks_v, inv_len_v) = breaks(spans_v);
        let (poly, rat) = if rational {
            (Vec::new(), coef)
        } else {
            (coef.iter().map(|c| c.truncate()).collect(), Vec::new())
        };
        Some(Self {
            p,
            q,
            breaks_u,
            breaks_v,
            inv_len_u,
            inv_len_v,
            poly,
            rat,
        })
    }

    /// The point and partial derivatives to second order at `uv` (clamped into the
    /// domain). Agrees with [`NurbsSurface::derivatives`] to rounding.
    #[inline]
    pub(crate) fn derivatives(&self, uv: DVec2) -> SurfaceDerivs {
        match (self.p, self.q) {
            (3, 3) => self.derivatives_impl(3, 3, uv),
            (2, 2) => self.derivatives_impl(2, 2, uv),
            (p, q) => self.derivatives_impl(p, q, uv),
        }
    }

    #[inline(always)]
    fn derivatives_impl(&self, p: usize, q: usize, uv: DVec2) -> SurfaceDerivs {
        let (nu, nv) = (self.inv_len_u.len(), self.inv_len_v.len());
        let u = uv.x.clamp(self.breaks_u[0], self.breaks_u[nu]);
        let v = uv.y.clamp(self.breaks_v[0], self.breaks_v[nv]);
        // The span holding the parameter, right-continuous like P&T A2.1.
        let a = span_of(&self.breaks_u[1..nu], u);
        let c = span_of(&self.breaks_v[1..nv], v);
        let s = (u - self.breaks_u[a]) * self.inv_len_u[a];
        let t = (v - self.breaks_v[c]) * self.inv_len_v[c];
        let (ku, kv) = (self.inv_len_u[a], self.inv_len_v[c]);
        let start = (a * nv + c) * (p + 1) * (q + 1);
        let len = (p + 1) * (q + 1);
        if self.rat.is_empty() {
            let [a00, a10, a01, a20, a11, a02] =
                sweep(&self.poly[start..start + len], p, q, s, t, ku, kv);
            SurfaceDerivs {
                point: a00,
                du: a10,
                dv: a01,
                duu: a20,
                duv: a11,
                dvv: a02,
            }
        } else {
            let [a00, a10, a01, a20, a11, a02] =
                sweep(&self.rat[start..start + len], p, q, s, t, ku, kv);
            // The rational quotient rule (P&T A4.4), as in `NurbsSurface::derivatives`.
            let inv_w = 1.0 / a00.w;
            let pt = a00.truncate() * inv_w;
            let (w10, w01) = (a10.w, a01.w);
            let su = (a10.truncate() - w10 * pt) * inv_w;
            let sv = (a01.truncate() - w01 * pt) * inv_w;
            SurfaceDerivs {
                point: pt,
                du: su,
                dv: sv,
                duu: (a20.truncate() - 2.0 * w10 * su - a20.w * pt) * inv_w,
                duv: (a11.truncate() - w10 * sv - w01 * su - a11.w * pt) * inv_w,
                dvv: (a02.truncate() - 2.0 * w01 * sv - a02.w * pt) * inv_w,
            }
        }
    }
}

/// The number of interior breakpoints `inner` (increasing) at or below `x`: the span
/// index. A few breakpoints are counted without branches (a binary search mispredicts
/// about half its branches on random parameters); many are bisected.
#[inline(always)]
fn span_of(inner: &[f64], x: f64) -> usize {
    if inner.len() <= 8 {
        inner.iter().map(|&b| usize::from(b <= x)).sum()
    } else {
        inner.partition_point(|&b| b <= x)
    }
}

/// Horner sweeps over one patch's coefficients `c[k * (q+1) + l]` (of `s^k t^l`): first
/// along `t` for every row `k` (value, first and second derivative), then along `s`.
/// Returns `[S, S_u, S_v, S_uu, S_uv, S_vv]` with the chain-rule factors `ku = ds/du`,
/// `kv = dt/dv` applied.
#[inline(always)]
fn sweep<V: Lin>(c: &[V], p: usize, q: usize, s: f64, t: f64, ku: f64, kv: f64) -> [V; 6] {
    let q1 = q + 1;
    // Row sums along t: value, first derivative, half the second derivative.
    let mut r0 = [V::ZERO; MAX_ORDER];
    let mut r1 = [V::ZERO; MAX_ORDER];
    let mut r2 = [V::ZERO; MAX_ORDER];
    for k in 0..=p {
        [r0[k], r1[k], r2[k]] = horner2(&c[k * q1..(k + 1) * q1], t);
    }
    // Along s: the value and two derivatives of the r0 row, value and derivative of r1,
    // value of r2.
    let [a00, a10, a20] = horner2(&r0[..=p], s);
    let [a01, a11] = horner1(&r1[..=p], s);
    let a02 = horner0(&r2[..=p], s);
    [
        a00,
        a10 * ku,
        a01 * kv,
        a20 * (2.0 * ku * ku),
        a11 * (ku * kv),
        a02 * (2.0 * kv * kv),
    ]
}

/// `sum c_l x^l`, its derivative and half its second derivative (Horner, P&T A1.1 with
/// derivatives). The derivative chains start once their first term exists, so no work
/// is spent on multiplying zeros (the compiler may not drop `0 * x` for floats).
#[inline(always)]
fn horner2<V: Lin>(c: &[V], x: f64) -> [V; 3] {
    let n = c.len() - 1;
    let (mut d0, mut d1, mut d2) = (c[n], V::ZERO, V::ZERO);
    for (step, l) in (0..n).rev().enumerate() {
        match step {
            0 => d1 = d0,
            1 => {
                d2 = d1;
                d1 = d1 * x + d0;
            }
            _ => {
                d2 = d2 * x + d1;
                d1 = d1 * x + d0;
            }
        }
        d0 = d0 * x + c[l];
    }
    [d0, d1, d2]
}

/// `sum c_l x^l` and its derivative (see [`horner2`]).
#[inline(always)]
fn horner1<V: Lin>(c: &[V], x: f64) -> [V; 2] {
    let n = c.len() - 1;
    let (mut d0, mut d1) = (c[n], V::ZERO);
    for (step, l) in (0..n).rev().enumerate() {
        d1 = if step == 0 { d0 } else { d1 * x + d0 };
        d0 = d0 * x + c[l];
    }
    [d0, d1]
}

/// `sum c_l x^l` (Horner).
#[inline(always)]
fn horner0<V: Lin>(c: &[V], x: f64) -> V {
    let n = c.len() - 1;
    (0..n).rev().fold(c[n], |d0, l| d0 * x + c[l])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{CONVERSION_REL, EXACT_EPS};

    fn check(s: &NurbsSurface) {
        let inv = s.inverter();
        let pp = inv.power().expect("converted");
        for i in 0..=17 {
            for j in 0..=13 {
                let uv = DVec2::new(i as f64 / 17.0, j as f64 / 13.0);
                let a = s.derivatives(uv.x, uv.y);
                let b = pp.derivatives(uv);
                for (x, y) in [
                    (a.point, b.point),
                    (a.du, b.du),
                    (a.dv, b.dv),
                    (a.duu, b.duu),
                    (a.duv, b.duv),
                    (a.dvv, b.dvv),
                ] {
                    assert_near!(
                        x.to_array(),
                        y.to_array(),
                        CONVERSION_REL * (1.0 + x.length())
                    );
                }
            }
        }
    }

    fn net(nu: usize, nv: usize) -> Vec<Vec<DVec3>> {
        (0..nu)
            .map(|i| {
                (0..nv)
                    .map(|j| {
                        let (x, y) = (i as f64 / (nu - 1) as f64, j as f64 / (nv - 1) as f64);
                        DVec3::new(x, y, (3.0 * x).sin() * (2.0 * y + 0.3).cos())
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn high_degrees_keep_bspline_evaluation() {
        let ku: Vec<f64> = [0.0; 8].into_iter().chain([1.0; 8]).collect();
        let kv = vec![0., 0., 0., 1., 1., 1.];
        let s = NurbsSurface::new(7, 2, ku, kv, net(8, 3), None).expect("valid");
        let inv = s.inverter();
        assert!(inv.power().is_none());
        let p = s.point(0.3, 0.6) + s.normal(0.3, 0.6) * 0.01;
        let got = inv.closest_point(p);
        assert!(got.converged && got.distance <= 0.01 + EXACT_EPS, "{got:?}");
        assert_near!(
            s.point_uv(got.uv_in_knots).to_array(),
            got.point.to_array(),
            EXACT_EPS
        );
    }

    #[test]
    fn power_form_matches_bspline_evaluation() {
        let k = vec![0., 0., 0., 0., 0.3, 0.55, 1., 1., 1., 1.];
        let s = NurbsSurface::new(3, 3, k.clone(), k, net(6, 6), None).expect("valid");
        check(&s);
        // Rational, mixed degrees, a double knot.
        let ku = vec![0., 0., 0., 0.4, 0.4, 1., 1., 1.];
        let kv = vec![0., 0., 0., 0., 0.7, 1., 1., 1., 1.];
        let w: Vec<Vec<f64>> = (0..5)
            .map(|i| {
                (0..5)
                    .map(|j| 0.6 + 0.3 * ((i * 3 + j) % 4) as f64)
                    .collect()
            })
            .collect();
        let s = NurbsSurface::new(2, 3, ku, kv, net(5, 5), Some(w)).expect("valid");
        check(&s);
        // Degree 1 in u.
        let s = NurbsSurface::new(
            1,
            2,
            vec![0., 0., 0.5, 1., 1.],
            vec![0., 0., 0., 1., 1., 1.],
            net(3, 3),
            None,
        )
        .expect("valid");
        check(&s);
    }
}
