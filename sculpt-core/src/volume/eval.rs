//! Evaluation and partial derivatives of a volume.
//!
//! The basis functions of each direction are computed once per point
//! ([`crate::nurbs::KnotVector::basis_ders2`]: P&T A2.2 with eq. 2.7), then the tensor
//! product is contracted over the `(p_1 + 1) .. (p_n + 1)` homogeneous control points of
//! the point's knot spans (P&T A3.6 / A4.3 extended to `n` directions). Rational
//! derivatives follow from the homogeneous ones by the quotient rule (P&T eq. 4.20,
//! A4.4, here for multi-indices of order up to 2). All-cubic trivariate volumes (values
//! and first derivatives) take an unrolled path on fixed-size arrays.

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

use super::{
    MAX_COMPONENTS, MAX_DIRECTIONS, Volume, VolumeError, VolumeResult, d1_quotient, odometer_next,
};
use crate::nurbs::knots::{BasisDers, MAX_ORDER};

/// Values per homogeneous point at most.
const MAX_DIM: usize = MAX_COMPONENTS + 1;
/// Multi-indices of order <= 2 in 4 directions: 1 + 4 + 10.
const MAX_MULTI: usize = 1 + MAX_DIRECTIONS + MAX_DIRECTIONS * (MAX_DIRECTIONS + 1) / 2;

/// Calls `$vol.$method::<D, ..>(..)` with the homogeneous width `D = $vol.dim` as a
/// compile-time constant (2 to 9), or evaluates `$other` for wider points.
macro_rules! by_width {
    ($vol:ident . $method:ident :: <_ $(, $p:literal)?> ($($arg:expr),*) else $other:expr) => {
        match $vol.dim {
            2 => $vol.$method::<2 $(, $p)?>($($arg),*),
            3 => $vol.$method::<3 $(, $p)?>($($arg),*),
            4 => $vol.$method::<4 $(, $p)?>($($arg),*),
            5 => $vol.$method::<5 $(, $p)?>($($arg),*),
            6 => $vol.$method::<6 $(, $p)?>($($arg),*),
            7 => $vol.$method::<7 $(, $p)?>($($arg),*),
            8 => $vol.$method::<8 $(, $p)?>($($arg),*),
            9 => $vol.$method::<9 $(, $p)?>($($arg),*),
            _ => $other,
        }
    };
}

/// The value and partial derivatives of every attribute at one parameter.
///
/// Layout: position 0 is the value, positions `1..=n` the first derivatives
/// `d/du_d`, then the second derivatives `d^2/du_a du_b` for `a <= b` in order
/// `(0,0), (0,1), .., (0,n-1), (1,1), ..`. Each position holds `k` values.
#[derive(Debug, Clone, PartialEq)]
pub struct Derivatives {
    n: usize,
    k: usize,
    order: usize,
    values: Vec<f64>,
}

/// The position of the second derivative `(a, b)`, `a <= b`, among `n` directions.
fn second_slot(n: usize, a: usize, b: usize) -> usize {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    // Rows before `a` hold n, n - 1, .. entries.
    1 + n + a * n - a * a.saturating_sub(1) / 2 + (b - a)
}

/// The multi-indices (orders per direction) of every slot up to `order`.
fn multi_indices(n: usize, order: usize) -> ([[u8; MAX_DIRECTIONS]; MAX_MULTI], usize) {
    let mut out = [[0u8; MAX_DIRECTIONS]; MAX_MULTI];
    let mut m = 1;
    if order >= 1 {
        for d in 0..n {
            out[m][d] = 1;
            m += 1;
        }
    }
    if order >= 2 {
        for a in 0..n {
            for b in a..n {
                out[m][a] += 1;
                out[m][b] += 1;
                m += 1;
            }
        }
    }
    (out, m)
}

/// The four cubic basis functions `N_{s-3,3} .. N_{s,3}` at `t` on the non-empty span
/// `s` of the knots `k`, and (when `DERIVS`) their first derivatives.
///
/// P&T A2.2 (eq. 2.5) unrolled for `p = 3`; the derivatives follow A2.3 with `n = 1`:
/// the last step of the triangle divides `N_{s-2+r,2}` by `u_{s+1+r} - u_{s-2+r}`, which
/// is the quotient of eq. 2.7, so `N'_{s-3+r,3} = 3 (q_{r-1} - q_r)` with `q_{-1} = q_3 = 0`.
/// Every denominator spans the knot interval `[u_s, u_{s+1}]`, so none is zero.
#[inline(always)]
pub(super) fn cubic_basis<const DERIVS: bool>(k: &[f64], s: usize, t: f64) -> ([f64; 4], [f64; 4]) {
    // kk[i] = u_{s-2+i}, i = 0..6.
    let kk: &[f64; 6] = k[s - 2..s + 4]
        .try_into()
        .expect("a cubic span has two knots on each side");
    let (l1, l2, l3) = (t - kk[2], t - kk[1], t - kk[0]);
    let (r1, r2, r3) = (kk[3] - t, kk[4] - t, kk[5] - t);
    // Degree 1.
    let tmp = 1.0 / (r1 + l1);
    let (a0, a1) = (r1 * tmp, l1 * tmp);
    // Degree 2.
    let tmp0 = a0 / (r1 + l2);
    let tmp1 = a1 / (r2 + l1);
    let (b0, b1, b2) = (r1 * tmp0, l2 * tmp0 + r2 * tmp1, l1 * tmp1);
    // Degree 3: q_r = N_{s-2+r,2} / (u_{s+1+r} - u_{s-2+r}).
    let q0 = b0 / (r1 + l3);
    let q1 = b1 / (r2 + l2);
    let q2 = b2 / (r3 + l1);
    let n = [r1 * q0, l3 * q0 + r2 * q1, l2 * q1 + r3 * q2, l1 * q2];
    let dn = if DERIVS {
        [-3.0 * q0, 3.0 * (q0 - q1), 3.0 * (q1 - q2), 3.0 * q2]
    } else {
        [0.0; 4]
    };
    (n, dn)
}

/// `sum_l w_l p_l` over four points of `D` values (one step of the tensor contraction).
#[inline(always)]
fn combine<const D: usize>(w: &[f64; 4], p: &[[f64; D]; 4]) -> [f64; D] {
    let mut out = [0.0; D];
    for e in 0..D {
        out[e] = (w[0] * p[0][e] + w[1] * p[1][e]) + (w[2] * p[2][e] + w[3] * p[3][e]);
    }
    out
}

/// [`combine`] with two weight sets over the same points (one pass over `p`).
#[inline(always)]
fn combine2<const D: usize>(w: &[f64; 4], v: &[f64; 4], p: &[[f64; D]; 4]) -> ([f64; D], [f64; D]) {
    let mut out_w = [0.0; D];
    let mut out_v = [0.0; D];
    for e in 0..D {
        let (p0, p1, p2, p3) = (p[0][e], p[1][e], p[2][e], p[3][e]);
        out_w[e] = (w[0] * p0 + w[1] * p1) + (w[2] * p2 + w[3] * p3);
        out_v[e] = (v[0] * p0 + v[1] * p1) + (v[2] * p2 + v[3] * p3);
    }
    (out_w, out_v)
}

impl Derivatives {
    /// The number of directions.
    pub fn directions(&self) -> usize {
        self.n
    }
    /// The highest order computed.
    pub fn order(&self) -> usize {
        self.order
    }
    /// The attribute values `A(u)`.
    pub fn value(&self) -> &[f64] {
        &self.values[..self.k]
    }
    /// `dA/du_d` (empty when the order is 0).
    pub fn d1(&self, d: usize) -> &[f64] {
        if self.order < 1 || d >= self.n {
            return &[];
        }
        let s = 1 + d;
        &self.values[s * self.k..(s + 1) * self.k]
    }
    /// `d^2 A / du_a du_b` (empty when the order is below 2).
    pub fn d2(&self, a: usize, b: usize) -> &[f64] {
        if self.order < 2 || a >= self.n || b >= self.n {
            return &[];
        }
        let s = second_slot(self.n, a, b);
        &self.values[s * self.k..(s + 1) * self.k]
    }
    /// All values in the layout of the type docs.
    pub fn as_slice(&self) -> &[f64] {
        &self.values
    }
}

impl Volume {
    /// The knot spans and basis functions (with first and second derivatives when
    /// `order > 0`) of every direction at `u` (clamped into the domain).
    #[inline]
    fn bases(
        &self,
        u: &[f64],
        order: usize,
    ) -> ([usize; MAX_DIRECTIONS], [BasisDers; MAX_DIRECTIONS]) {
        let mut spans = [0; MAX_DIRECTIONS];
        let mut ders = [[[0.0; MAX_ORDER]; 3]; MAX_DIRECTIONS];
        for (d, kv) in self.knots.iter().enumerate() {
            let t = kv.clamp(u[d]);
            let s = kv.find_span(t);
            spans[d] = s;
            if order == 0 {
                ders[d][0] = kv.basis(s, t);
            } else {
                ders[d] = kv.basis_ders2(s, t);
            }
        }
        (spans, ders)
    }

    /// The attribute values and partial derivatives up to `order <= 2` at `u`
    /// (clamped into the domain), any number of directions (P&T A3.6 on the
    /// homogeneous net, then the quotient rule of A4.4 per multi-index).
    pub fn derivatives(&self, u: &[f64], order: usize) -> VolumeResult<Derivatives> {
        self.check_params(u)?;
        if order > 2 {
            return Err(VolumeError::DerivativeOrder { got: order, max: 2 });
        }
        let n = self.directions();
        let dim = self.dim;
        let (spans, ders) = self.bases(u, order);
        let (alphas, slots) = multi_indices(n, order);
        // aw[m][c]: the homogeneous derivative of multi-index m.
        let mut aw = [[0.0; MAX_DIM]; MAX_MULTI];
        let degrees: Vec<usize> = self.knots.iter().map(|kv| kv.degree()).collect();
        let mut offs = [0usize; MAX_DIRECTIONS];
        loop {
            let mut flat = 0;
            for d in 0..n {
                flat += (spans[d] - degrees[d] + offs[d]) * self.strides[d];
            }
            let pt = &self.cw[flat * dim..(flat + 1) * dim];
            for m in 0..slots {
                let mut coef = 1.0;
                for d in 0..n {
                    coef *= ders[d][alphas[m][d] as usize][offs[d]];
                }
                if coef != 0.0 {
                    for (acc, v) in aw[m][..dim].iter_mut().zip(pt) {
                        *acc += coef * v;
                    }
                }
            }
            // Odometer over the local control points, last direction fastest.
            if !odometer_next(&mut offs[..n], |d| degrees[d] + 1) {
                return Ok(self.quotient(&aw, &alphas, slots, order));
            }
        }
    }

    /// The rational quotient rule (P&T eq. 4.20 for multi-indices, order <= 2):
    /// `A_a = (Aw_a - sum_{0 < b <= a} C(a, b) w_b A_{a - b}) / w`.
    fn quotient(
        &self,
        aw: &[[f64; MAX_DIM]; MAX_MULTI],
        alphas: &[[u8; MAX_DIRECTIONS]; MAX_MULTI],
        slots: usize,
        order: usize,
    ) -> Derivatives {
        let n = self.directions();
        let k = self.dim - 1;
        let mut values = vec![0.0; slots * k];
        let w = aw[0][k];
        let inv_w = 1.0 / w;
        for c in 0..k {
            values[c] = aw[0][c] * inv_w;
        }
        for m in 1..slots {
            let alpha = alphas[m];
            // The directions of this multi-index: one (first order) or two.
            let mut dirs = (0..n).filter(|&d| alpha[d] > 0);
            let a = dirs.next().unwrap_or(0);
            let second = if alpha[a] == 2 { Some(a) } else { dirs.next() };
            let pair = if alpha.iter().map(|&x| x as usize).sum::<usize>() == 2 {
                second.map(|b| (a, b))
            } else {
                None
            };
            for c in 0..k {
                let mut v = aw[m][c] - aw[m][k] * values[c];
                if let Some((a, b)) = pair {
                    // Second order: subtract w_a A_b + w_b A_a.
                    v -= aw[1 + a][k] * values[(1 + b) * k + c]
                        + aw[1 + b][k] * values[(1 + a) * k + c];
                }
                values[m * k + c] = v * inv_w;
            }
        }
        Derivatives {
            n,
            k,
            order,
            values,
        }
    }

    /// The attribute values at `u` (clamped into the domain) into `out` (`k` values).
    /// Never allocates.
    pub fn eval_into(&self, u: &[f64], out: &mut [f64]) -> VolumeResult<()> {
        self.check_params(u)?;
        let k = self.components();
        if out.len() != k {
            return Err(VolumeError::OutputLength {
                got: out.len(),
                need: k,
            });
        }
        let n = self.directions();
        if n == 3 && self.knots.iter().all(|kv| kv.degree() == 3) {
            by_width!(self.value_cubic::<_>(u, out) else self.value_general(u, out));
        } else {
            self.value_general(u, out);
        }
        Ok(())
    }

    /// The all-cubic trivariate path of [`Self::eval_into`].
    #[inline(always)]
    fn value_cubic<const D: usize>(&self, u: &[f64], out: &mut [f64]) {
        let [aw, ..] = self.cubic_trivariate::<D, false>(u);
        let inv_w = 1.0 / aw[D - 1];
        for (o, v) in out.iter_mut().zip(&aw[..D - 1]) {
            *o = v * inv_w;
        }
    }

    /// The generic path of [`Self::eval_into`], any number of directions and degrees.
    fn value_general(&self, u: &[f64], out: &mut [f64]) {
        let n = self.directions();
        let k = self.components();
        let dim = self.dim;
        let (spans, ders) = self.bases(u, 0);
        let mut acc = [0.0; MAX_DIM];
        let mut offs = [0usize; MAX_DIRECTIONS];
        loop {
            let mut flat = 0;
            let mut coef = 1.0;
            for d in 0..n {
                let p = self.knots[d].degree();
                flat += (spans[d] - p + offs[d]) * self.strides[d];
                coef *= ders[d][0][offs[d]];
            }
            for (a, v) in acc[..dim]
                .iter_mut()
                .zip(&self.cw[flat * dim..(flat + 1) * dim])
            {
                *a += coef * v;
            }
            if !odometer_next(&mut offs[..n], |d| self.knots[d].degree() + 1) {
                let inv_w = 1.0 / acc[k];
                for c in 0..k {
                    out[c] = acc[c] * inv_w;
                }
                return;
            }
        }
    }

    /// The attribute values at `u`.
    pub fn point(&self, u: &[f64]) -> VolumeResult<Vec<f64>> {
        let mut out = vec![0.0; self.components()];
        self.eval_into(u, &mut out)?;
        Ok(out)
    }

    /// The values and all first partial derivatives at `u` (clamped into the domain)
    /// into `out`: `k` values, then `dA/du_1` (`k` values), `dA/du_2`, .. : `k (n + 1)`
    /// in all, the order `sculpt-tools volume eval --derivatives 1` prints.
    ///
    /// Never allocates. Trivariate volumes take a fast path: the basis functions of
    /// each direction once (P&T A2.2, eq. 2.7), then the tensor contracted one
    /// direction at a time (last direction innermost, over contiguous memory), with
    /// the homogeneous width a compile-time constant for up to 8 attributes. All-cubic
    /// ones compute only the cubic values and first derivatives, in one pass
    /// (P&T A2.3 with `n = 1`, unrolled), and contract fixed 4 x 4 x 4 blocks.
    pub fn eval_d1_into(&self, u: &[f64], out: &mut [f64]) -> VolumeResult<()> {
        self.check_params(u)?;
        let n = self.directions();
        let k = self.components();
        if out.len() != k * (n + 1) {
            return Err(VolumeError::OutputLength {
                got: out.len(),
                need: k * (n + 1),
            });
        }
        if n == 3 {
            let degrees = [
                self.knots[0].degree(),
                self.knots[1].degree(),
                self.knots[2].degree(),
            ];
            // Constant widths and (for all-quadratic volumes) constant degrees let the
            // compiler unroll the contraction; all-cubic volumes take their own path.
            match degrees {
                [3, 3, 3] => by_width!(self.d1_cubic::<_>(u, out) else self.d1_general(u, out)),
                [2, 2, 2] => {
                    by_width!(self.d1_trivariate::<_, 2>(u, out) else self.d1_general(u, out))
                }
                _ => by_width!(self.d1_trivariate::<_, 0>(u, out) else self.d1_general(u, out)),
            }
        } else {
            self.d1_general(u, out);
        }
        Ok(())
    }

    /// The values of every attribute and the first derivatives of only the last
    /// `m = min(3, k)` attributes at `u`, into `out` of `k + n m` numbers: the `k`
    /// values, then for each direction `d` the derivatives `d/du_d` of attributes
    /// `k - m .. k`.
    ///
    /// The streamlines' right-hand side ([`FlowField`](super::FlowField), Park 2005
    /// eq. 49) stores the geometry `x, y, z` last and differentiates nothing else:
    /// for an all-cubic trivariate volume of 4 to 7 attributes the AVX2 kernel then
    /// contracts the derivatives in one 4-lane vector (the three attributes and the
    /// weight) instead of two, 224 vector multiply-adds per point against 384 (the
    /// AVX-512 kernel holds a whole point in one vector and differentiates it all, 192).
    /// Other volumes and processors take [`Self::eval_d1_into`] and keep the part asked
    /// for.
    pub fn eval_d1_last3_into(&self, u: &[f64], out: &mut [f64]) -> VolumeResult<()> {
        self.check_params(u)?;
        let n = self.directions();
        let k = self.components();
        let m = k.min(3);
        if out.len() != k + n * m {
            return Err(VolumeError::OutputLength {
                got: out.len(),
                need: k + n * m,
            });
        }
        let cubic3 = n == 3 && self.knots.iter().all(|kv| kv.degree() == 3);
        #[cfg(target_arch = "x86_64")]
        if cubic3 {
            use super::eval_simd::d1_cubic_last3;
            let done = match self.dim {
                5 => d1_cubic_last3::<5>(self, u, out),
                6 => d1_cubic_last3::<6>(self, u, out),
                7 => d1_cubic_last3::<7>(self, u, out),
                8 => d1_cubic_last3::<8>(self, u, out),
                _ => false,
            };
            if done {
                return Ok(());
            }
        }
        let mut full = [0.0; MAX_DIM * (1 + MAX_DIRECTIONS)];
        let full = &mut full[..k * (n + 1)];
        self.eval_d1_into(u, full)?;
        out[..k].copy_from_slice(&full[..k]);
        for d in 0..n {
            let from = (d + 1) * k + k - m;
            out[k + d * m..k + (d + 1) * m].copy_from_slice(&full[from..from + m]);
        }
        Ok(())
    }

    /// The generic first-derivative path: [`Self::derivatives`] without its
    /// allocation, for any `n`.
    fn d1_general(&self, u: &[f64], out: &mut [f64]) {
        let n = self.directions();
        let dim = self.dim;
        let k = dim - 1;
        let (spans, ders) = self.bases(u, 1);
        let mut aw = [[0.0; MAX_DIM]; 1 + MAX_DIRECTIONS];
        let mut offs = [0usize; MAX_DIRECTIONS];
        loop {
            let mut flat = 0;
            let mut n0 = [0.0; MAX_DIRECTIONS];
            let mut n1 = [0.0; MAX_DIRECTIONS];
            for d in 0..n {
                let p = self.knots[d].degree();
                flat += (spans[d] - p + offs[d]) * self.strides[d];
                n0[d] = ders[d][0][offs[d]];
                n1[d] = ders[d][1][offs[d]];
            }
            let pt = &self.cw[flat * dim..(flat + 1) * dim];
            let all: f64 = n0[..n].iter().product();
            for (a, v) in aw[0][..dim].iter_mut().zip(pt) {
                *a += all * v;
            }
            for d in 0..n {
                let mut coef = n1[d];
                for e in (0..n).filter(|&e| e != d) {
                    coef *= n0[e];
                }
                for (a, v) in aw[1 + d][..dim].iter_mut().zip(pt) {
                    *a += coef * v;
                }
            }
            if !odometer_next(&mut offs[..n], |d| self.knots[d].degree() + 1) {
                break;
            }
        }
        let inv_w = 1.0 / aw[0][k];
        for c in 0..k {
            out[c] = aw[0][c] * inv_w;
        }
        for d in 0..n {
            let wd = aw[1 + d][k];
            for c in 0..k {
                out[(1 + d) * k + c] = (aw[1 + d][c] - wd * out[c]) * inv_w;
            }
        }
    }

    /// The homogeneous value `A^w` and (when `DERIVS`) its first partial derivatives
    /// `d/du_1, d/du_2, d/du_3` at `u` of an all-cubic trivariate volume with `D = k + 1`
    /// values per homogeneous point.
    ///
    /// The basis of each direction once ([`cubic_basis`]), then P&T A3.6 / A4.3 on the
    /// tensor one direction at a time: the last direction over each contiguous row of
    /// four points (2 sums), the middle one over the four rows (3 sums), the first one
    /// over the four slabs (4 sums). Fixed-size arrays only: no allocation, and the
    /// loops unroll.
    #[inline(always)]
    fn cubic_trivariate<const D: usize, const DERIVS: bool>(&self, u: &[f64]) -> [[f64; D]; 4] {
        let mut spans = [0; 3];
        let mut n = [[0.0; 4]; 3];
        let mut dn = [[0.0; 4]; 3];
        for (d, kv) in self.knots.iter().take(3).enumerate() {
            let t = kv.clamp(u[d]);
            let s = kv.find_span(t);
            spans[d] = s;
            (n[d], dn[d]) = cubic_basis::<DERIVS>(kv.knots(), s, t);
        }
        let (st0, st1) = (self.strides[0], self.strides[1]);
        let start = (spans[0] - 3) * st0 + (spans[1] - 3) * st1 + spans[2] - 3;
        let (pts, _) = self.cw.as_chunks::<D>();
        // Per slab i: the last direction, c0[j] = sum_l N_l P_ijl, c1[j] = sum_l N'_l P_ijl,
        // then the middle one, b0 = sum_j N_j c0, b1 = sum_j N'_j c0, b2 = sum_j N_j c1.
        let mut b0 = [[0.0; D]; 4];
        let mut b1 = [[0.0; D]; 4];
        let mut b2 = [[0.0; D]; 4];
        for i in 0..4 {
            let mut c0 = [[0.0; D]; 4];
            let mut c1 = [[0.0; D]; 4];
            for j in 0..4 {
                let first = start + i * st0 + j * st1;
                let row: &[[f64; D]; 4] = pts[first..first + 4]
                    .try_into()
                    .expect("four points per cubic row");
                if DERIVS {
                    (c0[j], c1[j]) = combine2(&n[2], &dn[2], row);
                } else {
                    c0[j] = combine(&n[2], row);
                }
            }
            if DERIVS {
                (b0[i], b1[i]) = combine2(&n[1], &dn[1], &c0);
                b2[i] = combine(&n[1], &c1);
            } else {
                b0[i] = combine(&n[1], &c0);
            }
        }
        // First direction: A^w and d/du_1, d/du_2, d/du_3 of A^w.
        let mut a = [[0.0; D]; 4];
        if DERIVS {
            (a[0], a[1]) = combine2(&n[0], &dn[0], &b0);
            a[2] = combine(&n[0], &b1);
            a[3] = combine(&n[0], &b2);
        } else {
            a[0] = combine(&n[0], &b0);
        }
        a
    }

    /// The trivariate fast path of [`Self::eval_d1_into`] with `D = k + 1` known at
    /// compile time, and the degrees too when `P > 0` (all three equal to `P`).
    #[inline(always)]
    fn d1_trivariate<const D: usize, const P: usize>(&self, u: &[f64], out: &mut [f64]) {
        let (spans, ders) = self.bases(u, 1);
        let [p0, p1, p2] = if P > 0 {
            [P; 3]
        } else {
            [
                self.knots[0].degree(),
                self.knots[1].degree(),
                self.knots[2].degree(),
            ]
        };
        let (st0, st1) = (self.strides[0], self.strides[1]);
        let start = (spans[0] - p0) * st0 + (spans[1] - p1) * st1 + spans[2] - p2;
        // a[0] = A^w, a[1..4] = d/du_1, d/du_2, d/du_3 of A^w.
        let mut a = [[0.0; D]; 4];
        for i in 0..=p0 {
            // b[0] = sum_j N1 c0, b[1] = sum_j N1' c0, b[2] = sum_j N1 c1.
            let mut b = [[0.0; D]; 3];
            for j in 0..=p1 {
                let base = (start + i * st0 + j * st1) * D;
                let row = &self.cw[base..base + (p2 + 1) * D];
                let mut c0 = [0.0; D];
                let mut c1 = [0.0; D];
                for (l, pt) in row.chunks_exact(D).enumerate() {
                    let (n, dn) = (ders[2][0][l], ders[2][1][l]);
                    for e in 0..D {
                        c0[e] += n * pt[e];
                        c1[e] += dn * pt[e];
                    }
                }
                let (n, dn) = (ders[1][0][j], ders[1][1][j]);
                for e in 0..D {
                    b[0][e] += n * c0[e];
                    b[1][e] += dn * c0[e];
                    b[2][e] += n * c1[e];
                }
            }
            let (n, dn) = (ders[0][0][i], ders[0][1][i]);
            for e in 0..D {
                a[0][e] += n * b[0][e];
                a[1][e] += dn * b[0][e];
                a[2][e] += n * b[1][e];
                a[3][e] += n * b[2][e];
            }
        }
        d1_quotient(&a, out);
    }

    /// The all-cubic trivariate path of [`Self::eval_d1_into`]: explicit SIMD
    /// ([`super::eval_simd`]) where the processor has AVX2 and FMA and the point has 4
    /// to 8 homogeneous values, else [`Self::d1_cubic_scalar`].
    #[inline(always)]
    fn d1_cubic<const D: usize>(&self, u: &[f64], out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if (4..=8).contains(&D) && super::eval_simd::d1_cubic::<D>(self, u, out) {
            return;
        }
        self.d1_cubic_scalar::<D>(u, out);
    }

    /// The scalar all-cubic trivariate path (any `D`, any processor).
    #[inline(always)]
    pub(super) fn d1_cubic_scalar<const D: usize>(&self, u: &[f64], out: &mut [f64]) {
        d1_quotient(&self.cubic_trivariate::<D, true>(u), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn second_slots_follow_the_documented_order() {
        for n in 1..=4 {
            let (alphas, slots) = multi_indices(n, 2);
            let mut m = 1 + n;
            for a in 0..n {
                for b in a..n {
                    assert_eq!(second_slot(n, a, b), m, "n {n} ({a},{b})");
                    assert_eq!(second_slot(n, b, a), m);
                    let mut want = [0u8; MAX_DIRECTIONS];
                    want[a] += 1;
                    want[b] += 1;
                    assert_eq!(alphas[m], want);
                    m += 1;
                }
            }
            assert_eq!(m, slots);
        }
    }
}
