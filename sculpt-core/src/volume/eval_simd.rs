//! The all-cubic trivariate evaluator (values and all first derivatives) in explicit
//! SIMD: AVX2 and FMA, chosen at run time through `pulp` (no `unsafe` here), for
//! homogeneous points of 4 to 8 values (3 to 7 attributes and the weight).
//!
//! The arithmetic is that of the scalar path ([`super::eval`]): the four cubic basis
//! values and derivatives of each direction once (P&T A2.2 and A2.3 with `n = 1`,
//! unrolled; here the three directions in the lanes of one vector), then the tensor contracted direction by direction (P&T A3.6 / A4.3):
//! along the last direction (contiguous rows of four points) value and `d/du_3`
//! together, then the middle one, then the first, and the rational quotient rule last
//! (P&T eq. 4.8 differentiated). The vectors run over the components of the
//! homogeneous point, the weight being one more lane: a point of `D` values is held as
//! two 4-lane vectors, lanes `0..4` and `D - 4..D` (they overlap when `D < 8`, and are
//! one vector when `D = 4`), so every multiply-add covers the whole point in two
//! instructions. 384 vector multiply-adds per point for `D` from 5 to 8, against
//! about 1,150 scalar multiplies and 1,150 adds on the scalar path.

use pulp::x86::V3;
use pulp::{Simd, WithSimd, f64x4};

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
/// directions at `u` at once: lane `d` of each vector is direction `d` (lane 3 repeats
/// direction 0). The arithmetic of the scalar `cubic_basis` (P&T A2.2, A2.3 with `n = 1`,
/// unrolled) lane by lane, so its six divisions are done once for all directions.
#[inline(always)]
fn cubic_bases3(simd: V3, vol: &Volume, u: &[f64]) -> ([usize; 3], [[f64; 4]; 3], [[f64; 4]; 3]) {
    let mut spans = [0; 3];
    // kk[i][d] = u_{s_d - 2 + i} of direction d.
    let mut kk = [[0.0; 4]; 6];
    let mut t = [0.0; 4];
    for (d, kv) in vol.knots.iter().take(3).enumerate() {
        let td = kv.clamp(u[d]);
        let s = span_of(kv, td);
        spans[d] = s;
        t[d] = td;
        let k: &[f64; 6] = kv.knots()[s - 2..s + 4]
            .try_into()
            .expect("a cubic span has two knots on each side");
        for i in 0..6 {
            kk[i][d] = k[i];
        }
    }
    t[3] = t[0];
    for row in &mut kk {
        row[3] = row[0];
    }
    // No `array::map` in here: it is not inlined, and the code it calls runs without
    // the AVX2 and FMA this function is compiled for.
    let v = |a: [f64; 4]| f64x4(a[0], a[1], a[2], a[3]);
    let t = v(t);
    let k = [v(kk[0]), v(kk[1]), v(kk[2]), v(kk[3]), v(kk[4]), v(kk[5])];
    let (l1, l2, l3) = (
        simd.sub_f64x4(t, k[2]),
        simd.sub_f64x4(t, k[1]),
        simd.sub_f64x4(t, k[0]),
    );
    let (r1, r2, r3) = (
        simd.sub_f64x4(k[3], t),
        simd.sub_f64x4(k[4], t),
        simd.sub_f64x4(k[5], t),
    );
    let one = simd.splat_f64x4(1.0);
    // Degree 1.
    let tmp = simd.div_f64x4(one, simd.add_f64x4(r1, l1));
    let (a0, a1) = (simd.mul_f64x4(r1, tmp), simd.mul_f64x4(l1, tmp));
    // Degree 2.
    let tmp0 = simd.div_f64x4(a0, simd.add_f64x4(r1, l2));
    let tmp1 = simd.div_f64x4(a1, simd.add_f64x4(r2, l1));
    let b0 = simd.mul_f64x4(r1, tmp0);
    let b1 = simd.mul_add_f64x4(l2, tmp0, simd.mul_f64x4(r2, tmp1));
    let b2 = simd.mul_f64x4(l1, tmp1);
    // Degree 3: q_r = N_{s-2+r,2} / (u_{s+1+r} - u_{s-2+r}).
    let q0 = simd.div_f64x4(b0, simd.add_f64x4(r1, l3));
    let q1 = simd.div_f64x4(b1, simd.add_f64x4(r2, l2));
    let q2 = simd.div_f64x4(b2, simd.add_f64x4(r3, l1));
    let n = [
        simd.mul_f64x4(r1, q0),
        simd.mul_add_f64x4(l3, q0, simd.mul_f64x4(r2, q1)),
        simd.mul_add_f64x4(l2, q1, simd.mul_f64x4(r3, q2)),
        simd.mul_f64x4(l1, q2),
    ];
    let three = simd.splat_f64x4(3.0);
    let dn = [
        simd.mul_f64x4(simd.splat_f64x4(-3.0), q0),
        simd.mul_f64x4(three, simd.sub_f64x4(q0, q1)),
        simd.mul_f64x4(three, simd.sub_f64x4(q1, q2)),
        simd.mul_f64x4(three, q2),
    ];
    // Transposed: per direction, the four functions.
    let mut nd = [[0.0; 4]; 3];
    let mut dnd = [[0.0; 4]; 3];
    for l in 0..4 {
        let (f64x4(a, b, c, _), f64x4(da, db, dc, _)) = (n[l], dn[l]);
        [nd[0][l], nd[1][l], nd[2][l]] = [a, b, c];
        [dnd[0][l], dnd[1][l], dnd[2][l]] = [da, db, dc];
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
/// from 4 to 8) at `u` into `out`, as [`Volume::eval_d1_into`] lays them out; false
/// (and `out` untouched) when the processor lacks AVX2 or FMA or `D` is out of range.
#[inline(always)]
pub(super) fn d1_cubic<const D: usize>(vol: &Volume, u: &[f64], out: &mut [f64]) -> bool {
    if !(4..=8).contains(&D) {
        return false;
    }
    let Some(simd) = V3::try_new() else {
        return false;
    };
    <V3 as Simd>::vectorize(simd, CubicD1::<D, true> { simd, vol, u, out });
    true
}

/// The values of every attribute and the first derivatives of the last three of the
/// all-cubic trivariate `vol` (`D = k + 1` from 5 to 8) at `u` into `out`, as
/// [`Volume::eval_d1_last3_into`] lays them out: the derivatives are contracted in the
/// upper vector alone, 224 vector multiply-adds per point against 384 for every
/// component. False (and `out` untouched) when the processor lacks AVX2 or FMA or `D`
/// is out of range.
#[inline(always)]
pub(super) fn d1_cubic_last3<const D: usize>(vol: &Volume, u: &[f64], out: &mut [f64]) -> bool {
    if !(5..=8).contains(&D) {
        return false;
    }
    let Some(simd) = V3::try_new() else {
        return false;
    };
    <V3 as Simd>::vectorize(simd, CubicD1::<D, false> { simd, vol, u, out });
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

    fn check<const D: usize>() {
        let vol = wavy(D - 1);
        for u in params(&vol) {
            let mut simd = vec![0.0; 4 * (D - 1)];
            let mut scalar = simd.clone();
            assert!(d1_cubic::<D>(&vol, &u, &mut simd), "D {D}: path not taken");
            vol.d1_cubic_scalar::<D>(&u, &mut scalar);
            let scale = scalar.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
            assert_near!(simd, scalar, VOLUME_EVAL_REL * scale, "D {D} at {u:?}");
            // The geometry-only kernel: the same values, and the derivatives of the
            // last three attributes, from the public entry and from the kernel.
            if D >= 5 {
                let k = D - 1;
                let mut part = vec![0.0; k + 9];
                assert!(
                    d1_cubic_last3::<D>(&vol, &u, &mut part),
                    "D {D}: path not taken"
                );
                let mut public = vec![0.0; k + 9];
                vol.eval_d1_last3_into(&u, &mut public).unwrap();
                assert_eq!(part, public, "D {D} at {u:?}: the entry takes the kernel");
                let mut expected = scalar[..k].to_vec();
                for d in 1..4 {
                    expected.extend_from_slice(&scalar[d * k + k - 3..(d + 1) * k]);
                }
                assert_near!(part, expected, VOLUME_EVAL_REL * scale, "D {D} at {u:?}");
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
    fn simd_path_matches_the_scalar_cubic_path_for_every_width() {
        if V3::try_new().is_none() {
            eprintln!("no AVX2 and FMA on this processor: the SIMD path is never taken");
            return;
        }
        check::<4>();
        check::<5>();
        check::<6>();
        check::<7>();
        check::<8>();
        // Outside 4..=8 the SIMD path declines and the caller falls back.
        let mut out = [0.0; 8];
        assert!(!d1_cubic::<3>(&wavy(2), &[0.0; 3], &mut out));
    }
}
