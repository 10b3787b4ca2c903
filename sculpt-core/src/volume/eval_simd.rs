//! The all-cubic trivariate evaluator (values and all first derivatives) in explicit
//! SIMD, chosen at run time through `pulp` (no `unsafe` here): AVX-512 ([`V4`]) where
//! the processor has it, else AVX2 and FMA ([`V3`]), for homogeneous points of 4 to 8
//! values (3 to 7 attributes and the weight).
//!
//! The arithmetic is that of the scalar path ([`super::eval`]): the four cubic basis
//! values and derivatives of each direction once (P&T A2.2 and A2.3 with `n = 1`, here
//! from the per-span polynomials of [`super::span_poly`]: two Horner schemes and no
//! division), then the tensor contracted direction by direction (P&T A3.6 / A4.3):
//! along the last direction (contiguous rows of four points) value and `d/du_3`
//! together, then the middle one, then the first, and the rational quotient rule last
//! (P&T eq. 4.8 differentiated). The vectors run over the components of the
//! homogeneous point, the weight being one more lane. With AVX-512 a point is one
//! 8-lane vector: 192 vector multiply-adds per point, and the accumulators and basis
//! values fit the 32 registers. With AVX2 a point of `D` values is two 4-lane vectors,
//! lanes `0..4` and `D - 4..D` (they overlap when `D < 8`, and are one vector when
//! `D = 4`): 384 vector multiply-adds per point for `D` from 5 to 8, against about
//! 1,150 scalar multiplies and 1,150 adds on the scalar path.

use pulp::x86::{V3, V4};
use pulp::{Simd, WithSimd, cast, f64x4, f64x8, u64x8};
use std::arch::x86_64::__m512i;

use super::Volume;
use super::d1_quotient;
use crate::nurbs::KnotVector;

/// A homogeneous point of `D` (4 to 8) values as two 4-lane vectors: lanes `0..4`
/// (`lo`) and `D - 4..D` (`hi`); `hi` is unused when `D = 4`.
#[derive(Clone, Copy)]
struct Hp {
    lo: f64x4,
    hi: f64x4,
}

const ZERO: f64x4 = f64x4(0.0, 0.0, 0.0, 0.0);
const HP_ZERO: Hp = Hp { lo: ZERO, hi: ZERO };

impl Hp {
    #[inline(always)]
    fn load<const D: usize>(p: &[f64; D]) -> Self {
        Hp {
            lo: f64x4(p[0], p[1], p[2], p[3]),
            hi: if D > 4 {
                f64x4(p[D - 4], p[D - 3], p[D - 2], p[D - 1])
            } else {
                ZERO
            },
        }
    }

    /// `w p + acc`.
    #[inline(always)]
    fn mul_add<const D: usize>(simd: V3, w: f64x4, p: Hp, acc: Hp) -> Self {
        Hp {
            lo: simd.mul_add_f64x4(w, p.lo, acc.lo),
            hi: if D > 4 {
                simd.mul_add_f64x4(w, p.hi, acc.hi)
            } else {
                ZERO
            },
        }
    }

    /// `w p`.
    #[inline(always)]
    fn mul<const D: usize>(simd: V3, w: f64x4, p: Hp) -> Self {
        Hp {
            lo: simd.mul_f64x4(w, p.lo),
            hi: if D > 4 { simd.mul_f64x4(w, p.hi) } else { ZERO },
        }
    }

    /// [`Self::mul_add`] in the lanes a derivative needs: all of them (`ALL`), or
    /// only `hi` (the last three attributes and the weight; `lo` stays zero).
    #[inline(always)]
    fn mul_add_d<const D: usize, const ALL: bool>(simd: V3, w: f64x4, p: Hp, acc: Hp) -> Self {
        if ALL {
            Self::mul_add::<D>(simd, w, p, acc)
        } else {
            Hp {
                lo: ZERO,
                hi: simd.mul_add_f64x4(w, p.hi, acc.hi),
            }
        }
    }

    /// [`Self::mul`] in the lanes a derivative needs (see [`Self::mul_add_d`]).
    #[inline(always)]
    fn mul_d<const D: usize, const ALL: bool>(simd: V3, w: f64x4, p: Hp) -> Self {
        if ALL {
            Self::mul::<D>(simd, w, p)
        } else {
            Hp {
                lo: ZERO,
                hi: simd.mul_f64x4(w, p.hi),
            }
        }
    }

    #[inline(always)]
    fn store<const D: usize>(self) -> [f64; D] {
        let mut out = [0.0; D];
        let f64x4(a, b, c, d) = self.lo;
        out[..4].copy_from_slice(&[a, b, c, d]);
        if D > 4 {
            let f64x4(a, b, c, d) = self.hi;
            out[D - 4..].copy_from_slice(&[a, b, c, d]);
        }
        out
    }
}

/// `sum_l w_l p_l` over four points, in every lane (`ALL`) or only in `hi`
/// ([`Hp::mul_add_d`]).
#[inline(always)]
fn combine<const D: usize, const ALL: bool>(simd: V3, w: &[f64x4; 4], p: &[Hp; 4]) -> Hp {
    let mut acc = Hp::mul_d::<D, ALL>(simd, w[0], p[0]);
    acc = Hp::mul_add_d::<D, ALL>(simd, w[1], p[1], acc);
    acc = Hp::mul_add_d::<D, ALL>(simd, w[2], p[2], acc);
    Hp::mul_add_d::<D, ALL>(simd, w[3], p[3], acc)
}

/// The knot span of `t` (clamped into the domain) as [`KnotVector::find_span`] finds
/// it, without branches on the data for short knot vectors: inside the domain the span
/// is `p` plus the number of interior knots at or below `t` (the knots do not
/// decrease), a count the processor does without mispredicting; the ends and long
/// vectors go to the binary search.
#[inline(always)]
fn span_of(kv: &KnotVector, t: f64) -> usize {
    let (k, p) = (kv.knots(), kv.degree());
    let n = kv.count() - 1;
    if n - p <= SHORT_INTERIOR && t > k[p] && t < k[n + 1] {
        p + k[p + 1..=n]
            .iter()
            .map(|&x| usize::from(x <= t))
            .sum::<usize>()
    } else {
        kv.find_span(t)
    }
}

/// The most interior knots [`span_of`] counts through.
const SHORT_INTERIOR: usize = 16;

/// The spans, and the four cubic basis values and derivatives, of the three
/// directions at `u`: per direction the span's polynomials ([`super::span_poly`]) in
/// two Horner schemes whose lanes are the four functions (P&T A2.2 and A2.3 with
/// `n = 1`, evaluated from the per-span coefficients: five multiply-adds and no
/// division per direction).
#[inline(always)]
fn cubic_bases3(simd: V3, vol: &Volume, u: &[f64]) -> ([usize; 3], [[f64; 4]; 3], [[f64; 4]; 3]) {
    let mut spans = [0; 3];
    let mut nd = [[0.0; 4]; 3];
    let mut dnd = [[0.0; 4]; 3];
    // No `array::map` in here: it is not inlined, and the code it calls runs without
    // the AVX2 and FMA this function is compiled for.
    let v = |a: &[f64; 4]| f64x4(a[0], a[1], a[2], a[3]);
    for (d, kv) in vol.knots.iter().take(3).enumerate() {
        let td = kv.clamp(u[d]);
        let s = span_of(kv, td);
        spans[d] = s;
        let poly = vol.cubic_spans[d].span(s);
        let x = simd.splat_f64x4((td - poly.start) * poly.inv_len);
        let (c, e) = (&poly.value, &poly.slope);
        let n = simd.mul_add_f64x4(x, v(&c[3]), v(&c[2]));
        let n = simd.mul_add_f64x4(x, n, v(&c[1]));
        let n = simd.mul_add_f64x4(x, n, v(&c[0]));
        let dn = simd.mul_add_f64x4(x, v(&e[2]), v(&e[1]));
        let dn = simd.mul_add_f64x4(x, dn, v(&e[0]));
        let (f64x4(a, b, c, dd), f64x4(da, db, dc, ddd)) = (n, dn);
        nd[d] = [a, b, c, dd];
        dnd[d] = [da, db, dc, ddd];
    }
    (spans, nd, dnd)
}

/// The kernel with its arguments, run by [`V3::vectorize`] with AVX2 and FMA enabled:
/// the first derivatives of every component (`ALL`, [`d1_cubic`]) or of the last three
/// attributes only ([`d1_cubic_last3`]).
struct CubicD1<'a, const D: usize, const ALL: bool> {
    simd: V3,
    vol: &'a Volume,
    u: &'a [f64],
    out: &'a mut [f64],
}

impl<const D: usize, const ALL: bool> WithSimd for CubicD1<'_, D, ALL> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _: S) {
        let CubicD1 { simd, vol, u, out } = self;
        let (spans, nb, dnb) = cubic_bases3(simd, vol, u);
        let mut n = [[ZERO; 4]; 3];
        let mut dn = [[ZERO; 4]; 3];
        for d in 0..3 {
            for l in 0..4 {
                n[d][l] = simd.splat_f64x4(nb[d][l]);
                dn[d][l] = simd.splat_f64x4(dnb[d][l]);
            }
        }
        let (st0, st1) = (vol.strides[0], vol.strides[1]);
        let start = (spans[0] - 3) * st0 + (spans[1] - 3) * st1 + spans[2] - 3;
        let (pts, _) = vol.cw.as_chunks::<D>();
        // a[0] = A^w, a[1..4] = d/du_1, d/du_2, d/du_3 of A^w.
        let mut a = [HP_ZERO; 4];
        for i in 0..4 {
            // b[0] = sum_j N_j c0, b[1] = sum_j N'_j c0, b[2] = sum_j N_j c1.
            let mut b = [HP_ZERO; 3];
            for j in 0..4 {
                let first = start + i * st0 + j * st1;
                let row: &[[f64; D]; 4] = pts[first..first + 4]
                    .try_into()
                    .expect("four points per cubic row");
                let p = [
                    Hp::load(&row[0]),
                    Hp::load(&row[1]),
                    Hp::load(&row[2]),
                    Hp::load(&row[3]),
                ];
                // The last direction: c0 = sum_l N_l P_ijl, c1 = sum_l N'_l P_ijl.
                let c0 = combine::<D, true>(simd, &n[2], &p);
                let c1 = combine::<D, ALL>(simd, &dn[2], &p);
                b[0] = Hp::mul_add::<D>(simd, n[1][j], c0, b[0]);
                b[1] = Hp::mul_add_d::<D, ALL>(simd, dn[1][j], c0, b[1]);
                b[2] = Hp::mul_add_d::<D, ALL>(simd, n[1][j], c1, b[2]);
            }
            a[0] = Hp::mul_add::<D>(simd, n[0][i], b[0], a[0]);
            a[1] = Hp::mul_add_d::<D, ALL>(simd, dn[0][i], b[0], a[1]);
            a[2] = Hp::mul_add_d::<D, ALL>(simd, n[0][i], b[1], a[2]);
            a[3] = Hp::mul_add_d::<D, ALL>(simd, n[0][i], b[2], a[3]);
        }
        let h: [[f64; D]; 4] = [a[0].store(), a[1].store(), a[2].store(), a[3].store()];
        if ALL {
            d1_quotient(&h, out);
        } else {
            d1_quotient_last3(&h, out);
        }
    }
}

/// An 8-lane vector of zeros.
const ZERO8: f64x8 = f64x8(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);

/// The eight values `s[0..8]` as one vector.
#[inline(always)]
fn load8(s: &[f64]) -> f64x8 {
    let a: &[f64; 8] = s[..8].try_into().expect("eight values");
    f64x8(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7])
}

/// `sum_l w_l p_l` over four points in 8-lane vectors.
#[inline(always)]
fn combine8(simd: V4, w: &[f64x8; 4], p: &[f64x8; 4]) -> f64x8 {
    let acc = simd.mul_f64x8(w[0], p[0]);
    let acc = simd.mul_add_f64x8(w[1], p[1], acc);
    let acc = simd.mul_add_f64x8(w[2], p[2], acc);
    simd.mul_add_f64x8(w[3], p[3], acc)
}

/// The AVX-512 kernel, run by [`V4::vectorize`]: the arithmetic of [`CubicD1`] with a
/// homogeneous point of `D` (4 to 8) values in the lanes of one 8-lane vector (lanes
/// `D..8` carry whatever follows the point in memory and are never read out), so the
/// contraction is 192 vector multiply-adds per point, and the 32 vector registers hold
/// its accumulators and basis values without spilling. Every derivative is computed;
/// `ALL` only chooses the output layout ([`d1_quotient`] or [`d1_quotient_last3`]).
struct CubicD1x8<'a, const D: usize, const ALL: bool> {
    simd: V4,
    vol: &'a Volume,
    u: &'a [f64],
    out: &'a mut [f64],
}

impl<const D: usize, const ALL: bool> WithSimd for CubicD1x8<'_, D, ALL> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _: S) {
        let CubicD1x8 { simd, vol, u, out } = self;
        let (spans, nb, dnb) = cubic_bases3(*simd, vol, u);
        let mut n = [[ZERO8; 4]; 3];
        let mut dn = [[ZERO8; 4]; 3];
        for d in 0..3 {
            for l in 0..4 {
                n[d][l] = simd.splat_f64x8(nb[d][l]);
                dn[d][l] = simd.splat_f64x8(dnb[d][l]);
            }
        }
        // A row of four points is `4 D >= 16` consecutive values: the first three
        // points are read from where they start, the last one from the row's last
        // eight values and moved down `8 - D` lanes, so no read leaves the row.
        let shift: __m512i = cast(u64x8(
            (8 - D as u64).min(7),
            (9 - D as u64).min(7),
            (10 - D as u64).min(7),
            (11 - D as u64).min(7),
            (12 - D as u64).min(7),
            (13 - D as u64).min(7),
            (14 - D as u64).min(7),
            (15 - D as u64).min(7),
        ));
        let (st0, st1) = (vol.strides[0], vol.strides[1]);
        let start = (spans[0] - 3) * st0 + (spans[1] - 3) * st1 + spans[2] - 3;
        // a[0] = A^w, a[1..4] = d/du_1, d/du_2, d/du_3 of A^w.
        let mut a = [ZERO8; 4];
        for i in 0..4 {
            // b[0] = sum_j N_j c0, b[1] = sum_j N'_j c0, b[2] = sum_j N_j c1.
            let mut b = [ZERO8; 3];
            for j in 0..4 {
                let first = (start + i * st0 + j * st1) * D;
                let row = &vol.cw[first..first + 4 * D];
                let last = load8(&row[4 * D - 8..]);
                let p = [
                    load8(row),
                    load8(&row[D..]),
                    load8(&row[2 * D..]),
                    if D == 8 {
                        last
                    } else {
                        cast(simd.avx512f._mm512_permutexvar_pd(shift, cast(last)))
                    },
                ];
                // The last direction: c0 = sum_l N_l P_ijl, c1 = sum_l N'_l P_ijl.
                let c0 = combine8(simd, &n[2], &p);
                let c1 = combine8(simd, &dn[2], &p);
                b[0] = simd.mul_add_f64x8(n[1][j], c0, b[0]);
                b[1] = simd.mul_add_f64x8(dn[1][j], c0, b[1]);
                b[2] = simd.mul_add_f64x8(n[1][j], c1, b[2]);
            }
            a[0] = simd.mul_add_f64x8(n[0][i], b[0], a[0]);
            a[1] = simd.mul_add_f64x8(dn[0][i], b[0], a[1]);
            a[2] = simd.mul_add_f64x8(n[0][i], b[1], a[2]);
            a[3] = simd.mul_add_f64x8(n[0][i], b[2], a[3]);
        }
        let store = |v: f64x8| -> [f64; D] {
            let f64x8(x0, x1, x2, x3, x4, x5, x6, x7) = v;
            let all = [x0, x1, x2, x3, x4, x5, x6, x7];
            all[..D].try_into().expect("D <= 8 lanes")
        };
        let h: [[f64; D]; 4] = [store(a[0]), store(a[1]), store(a[2]), store(a[3])];
        if ALL {
            d1_quotient(&h, out);
        } else {
            d1_quotient_last3(&h, out);
        }
    }
}

/// The rational values of all `k = D - 1` attributes and the first derivatives of the
/// last three, in the layout of [`Volume::eval_d1_last3_into`], from the homogeneous
/// `a = [A^w, d/du_1 A^w, ..]` of which only the last four components of the
/// derivatives are read (P&T eq. 4.8 differentiated, as [`d1_quotient`]).
#[inline(always)]
fn d1_quotient_last3<const D: usize>(a: &[[f64; D]; 4], out: &mut [f64]) {
    let k = D - 1;
    let inv_w = 1.0 / a[0][k];
    for c in 0..k {
        out[c] = a[0][c] * inv_w;
    }
    for d in 1..4 {
        let wd = a[d][k];
        for c in 0..3 {
            out[k + 3 * (d - 1) + c] = (a[d][k - 3 + c] - wd * out[k - 3 + c]) * inv_w;
        }
    }
}

/// The values and first derivatives of the all-cubic trivariate `vol` (`D = k + 1`
/// from 4 to 8) at `u` into `out`, as [`Volume::eval_d1_into`] lays them out, with
/// the AVX-512 kernel ([`CubicD1x8`]) where the processor has it, else the AVX2 one
/// ([`CubicD1`]); false (and `out` untouched) when it has neither or `D` is out of
/// range.
#[inline(always)]
pub(super) fn d1_cubic<const D: usize>(vol: &Volume, u: &[f64], out: &mut [f64]) -> bool {
    d1_kernel::<D, true>(vol, u, out)
}

/// The values of every attribute and the first derivatives of the last three of the
/// all-cubic trivariate `vol` (`D = k + 1` from 5 to 8) at `u` into `out`, as
/// [`Volume::eval_d1_last3_into`] lays them out: the AVX-512 kernel where the
/// processor has it, else the AVX2 one contracting the derivatives in the upper
/// 4-lane vector alone (224 vector multiply-adds per point against 384 for every
/// component). False (and `out` untouched) when the processor has neither or `D` is
/// out of range.
#[inline(always)]
pub(super) fn d1_cubic_last3<const D: usize>(vol: &Volume, u: &[f64], out: &mut [f64]) -> bool {
    D >= 5 && d1_kernel::<D, false>(vol, u, out)
}

/// [`d1_cubic`] (`ALL`) or [`d1_cubic_last3`]: the widest kernel the processor runs.
#[inline(always)]
fn d1_kernel<const D: usize, const ALL: bool>(vol: &Volume, u: &[f64], out: &mut [f64]) -> bool {
    if !(4..=8).contains(&D) {
        return false;
    }
    if let Some(simd) = V4::try_new() {
        <V4 as Simd>::vectorize(simd, CubicD1x8::<D, ALL> { simd, vol, u, out });
    } else if let Some(simd) = V3::try_new() {
        <V3 as Simd>::vectorize(simd, CubicD1::<D, ALL> { simd, vol, u, out });
    } else {
        return false;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::VOLUME_EVAL_REL;

    /// A rational all-cubic volume with `k` attributes on a 5 x 6 x 7 net, uneven
    /// knots (a double interior knot in the last direction) over unequal intervals.
    fn wavy(k: usize) -> Volume {
        let knots = vec![
            vec![-1.0, -1.0, -1.0, -1.0, 0.2, 2.0, 2.0, 2.0, 2.0],
            vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.4, 1.0, 1.0, 1.0, 1.0],
            vec![0.0, 0.0, 0.0, 0.0, 1.0, 2.5, 2.5, 4.0, 4.0, 4.0, 4.0],
        ];
        let counts = [5, 6, 7];
        let mut values = Vec::new();
        let mut weights = Vec::new();
        for i in 0..counts[0] {
            for j in 0..counts[1] {
                for l in 0..counts[2] {
                    let (x, y, z) = (i as f64, j as f64, l as f64);
                    values.extend(
                        (0..k).map(|c| (x * 0.7 + c as f64).sin() * y - z * (c as f64 + 0.5)),
                    );
                    weights.push(1.1 + (0.9 * x - 1.3 * y + 0.4 * z).sin());
                }
            }
        }
        let names = (0..k).map(|c| format!("a{c}")).collect();
        Volume::new(vec![3, 3, 3], knots, names, values, Some(weights)).expect("valid volume")
    }

    /// The parameters checked: a grid over the domain, its ends and the knots included.
    fn params(vol: &Volume) -> Vec<[f64; 3]> {
        let dom = vol.domain();
        let at = |d: usize, t: f64| dom[d].0 + t * (dom[d].1 - dom[d].0);
        let mut out = Vec::new();
        for a in 0..=6 {
            for b in 0..=6 {
                for c in 0..=6 {
                    let t = |m: i32| f64::from(m) / 6.0;
                    out.push([at(0, t(a)), at(1, t(b)), at(2, t(c))]);
                }
            }
        }
        out.push([0.2, 0.3, 2.5]);
        out.push([0.2, 0.4, 1.0]);
        out
    }

    /// Runs the AVX2 (`wide` false) or the AVX-512 kernel on `u`; false when the
    /// processor lacks it.
    fn kernel<const D: usize, const ALL: bool>(
        wide: bool,
        vol: &Volume,
        u: &[f64],
        out: &mut [f64],
    ) -> bool {
        if wide {
            let Some(simd) = V4::try_new() else {
                return false;
            };
            <V4 as Simd>::vectorize(simd, CubicD1x8::<D, ALL> { simd, vol, u, out });
        } else {
            let Some(simd) = V3::try_new() else {
                return false;
            };
            <V3 as Simd>::vectorize(simd, CubicD1::<D, ALL> { simd, vol, u, out });
        }
        true
    }

    fn check<const D: usize>(wide: bool) {
        let vol = wavy(D - 1);
        for u in params(&vol) {
            let mut simd = vec![0.0; 4 * (D - 1)];
            let mut scalar = simd.clone();
            assert!(
                kernel::<D, true>(wide, &vol, &u, &mut simd),
                "D {D}: path not taken"
            );
            vol.d1_cubic_scalar::<D>(&u, &mut scalar);
            let scale = scalar.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
            assert_near!(simd, scalar, VOLUME_EVAL_REL * scale, "D {D} at {u:?}");
            // The geometry-only kernel: the same values, and the derivatives of the
            // last three attributes, from the public entry and from the kernel.
            if D >= 5 {
                let k = D - 1;
                let mut part = vec![0.0; k + 9];
                assert!(
                    kernel::<D, false>(wide, &vol, &u, &mut part),
                    "D {D}: path not taken"
                );
                let mut expected = scalar[..k].to_vec();
                for d in 1..4 {
                    expected.extend_from_slice(&scalar[d * k + k - 3..(d + 1) * k]);
                }
                assert_near!(part, expected, VOLUME_EVAL_REL * scale, "D {D} at {u:?}");
                let mut public = vec![0.0; k + 9];
                vol.eval_d1_last3_into(&u, &mut public).unwrap();
                assert_near!(
                    public,
                    expected,
                    VOLUME_EVAL_REL * scale,
                    "D {D} at {u:?}: the public entry"
                );
            }
        }
    }

    /// The entry's other paths (a quadratic volume, a volume of two attributes, a
    /// wrong output length) keep the part of [`Volume::eval_d1_into`] asked for.
    #[test]
    fn last3_entry_keeps_the_part_of_the_full_row_on_every_path() {
        for (vol, m) in [(wavy(5).elevate_degree(0, 1).unwrap(), 3), (wavy(2), 2)] {
            let k = vol.components();
            for u in params(&vol) {
                let mut full = vec![0.0; 4 * k];
                vol.eval_d1_into(&u, &mut full).unwrap();
                let mut part = vec![0.0; k + 3 * m];
                vol.eval_d1_last3_into(&u, &mut part).unwrap();
                let mut expected = full[..k].to_vec();
                for d in 1..4 {
                    expected.extend_from_slice(&full[d * k + k - m..(d + 1) * k]);
                }
                let scale = full.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
                assert_near!(part, expected, VOLUME_EVAL_REL * scale, "k {k} at {u:?}");
            }
        }
        let mut short = [0.0; 5];
        assert!(matches!(
            wavy(5).eval_d1_last3_into(&[0.0, 0.5, 1.0], &mut short),
            Err(crate::volume::VolumeError::OutputLength { got: 5, need: 14 })
        ));
    }

    #[test]
    fn span_count_agrees_with_the_binary_search() {
        // Short and long vectors, repeated interior knots, and parameters on every
        // knot, between knots and outside the domain.
        for interior in [0usize, 1, 3, 16, 17, 40] {
            let mut knots = vec![0.0; 4];
            for i in 0..interior {
                // Every third knot doubled.
                knots.push(((i - i % 3 / 2) as f64 + 1.0) / (interior as f64 + 1.0));
            }
            knots.extend([1.0; 4]);
            let kv = KnotVector::new(3, knots.clone()).expect("valid knots");
            let mut ts: Vec<f64> = knots.clone();
            ts.extend(knots.windows(2).map(|w| 0.5 * (w[0] + w[1])));
            ts.extend([-0.5, 1.5]);
            for t in ts {
                let t = kv.clamp(t);
                assert_eq!(
                    span_of(&kv, t),
                    kv.find_span(t),
                    "{interior} interior, t {t}"
                );
            }
        }
    }

    #[test]
    fn simd_paths_match_the_scalar_cubic_path_for_every_width() {
        for wide in [false, true] {
            let available = if wide {
                V4::try_new().is_some()
            } else {
                V3::try_new().is_some()
            };
            if !available {
                eprintln!("this processor lacks the kernel (AVX-512: {wide}): not tested");
                continue;
            }
            check::<4>(wide);
            check::<5>(wide);
            check::<6>(wide);
            check::<7>(wide);
            check::<8>(wide);
        }
        // Outside 4..=8 the SIMD path declines and the caller falls back.
        let mut out = [0.0; 8];
        assert!(!d1_cubic::<3>(&wavy(2), &[0.0; 3], &mut out));
    }
}
