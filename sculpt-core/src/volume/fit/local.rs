//! Local least-squares refits (Park 2005, sec. 3.1, restricted): when the samples of a
//! fit change only in one region, only the control points whose support meets it are
//! solved for, the rest held at their values.
//!
//! With the control points split into free `F` and fixed `X`, the least-squares
//! problem `min |N_F A_F + N_X A_X - P|^2` over `A_F` has the normal equations
//! `(N_F^T N_F) A_F = N_F^T P - (N_F^T N_X) A_X` (eq. 11 with the fixed columns moved
//! to the right). Only samples in cells whose block holds a free point enter them, so
//! they are summed over those cells alone ([`super::Layout::assemble`], the same
//! assembly as the whole fit's). They are solved for the correction to the current
//! net (a warm start: `A_FF D = b_F - A_FF A_F^0`, `A_F = A_F^0 + D`) by an envelope
//! Cholesky factor ([`Envelope`]), the free points ordered with the free region's
//! longest direction slowest; where a pivot is not positive, by Jacobi-preconditioned
//! conjugate gradients started at the current `A_F`. The conjugate gradients alone
//! were far slower here: the free points off the painted surface are held only by a
//! sample a cell, and the system is ill-conditioned (the paint bench's strokes, in a
//! test build: 4.4 to 5.1 s by conjugate gradients, 45 to 79 ms by the factor).
//!
//! The result is the block-coordinate step of the whole fit on the free block: exact
//! on the fixed points (bit for bit: untouched), and equal to the whole refit where
//! the change of the whole refit's solution outside the free block is negligible
//! (it decays with the distance from the change; `sculpt_core::paint` measures it).

use super::{Csr, FIXED, FitError, Jacobi, Layout, SampleBases, check_finite, pcg, sample_count};
use crate::volume::Volume;

/// The control points a local refit solves for, and the cells whose samples enter it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LocalRegion {
    /// Per control point (flat): its row in the local system, or [`FIXED`].
    row_of: Vec<usize>,
    /// The free points (flat, ascending).
    free: Vec<usize>,
    /// Per cell (flat index of its first control point): its block holds a free point.
    cells: Vec<bool>,
}

impl LocalRegion {
    /// The free control points (flat indices, ascending).
    pub fn free_points(&self) -> &[usize] {
        &self.free
    }

    /// Whether control point `flat` is solved for.
    pub fn is_free(&self, flat: usize) -> bool {
        self.row_of.get(flat).is_some_and(|&r| r != FIXED)
    }
}

impl Volume {
    /// The control points whose support meets the box `u - reach ..= u + reach` (per
    /// direction) around any of the parameter points `params` (`n` values each):
    /// for each, the knot spans of the box's ends (P&T A2.1) and the `p_d` points
    /// before the first. Parameters outside the domain are clamped to it.
    pub fn local_region(&self, params: &[f64], reach: &[f64]) -> Result<LocalRegion, FitError> {
        let n = self.directions();
        if reach.len() != n || !params.len().is_multiple_of(n) {
            return Err(FitError::Shape {
                what: "parameters and reach (one per direction)",
                got: reach.len(),
                need: n,
            });
        }
        if let Some(s) = params
            .chunks_exact(n)
            .position(|u| u.iter().chain(reach).any(|v| !v.is_finite()))
        {
            return Err(FitError::NotFinite { sample: s });
        }
        let layout = self.layout();
        let total = layout.total();
        let mut free = vec![false; total];
        let mut lo = vec![0usize; n];
        let mut hi = vec![0usize; n];
        for u in params.chunks_exact(n) {
            for (d, kv) in self.knot_vectors().iter().enumerate() {
                let first = kv.find_span(kv.clamp(u[d] - reach[d].abs()));
                lo[d] = first - kv.degree();
                hi[d] = kv.find_span(kv.clamp(u[d] + reach[d].abs()));
            }
            let mut rel = vec![0usize; n];
            loop {
                let flat: usize = (0..n).map(|d| (lo[d] + rel[d]) * layout.strides[d]).sum();
                free[flat] = true;
                if !crate::volume::odometer_next(&mut rel, |d| hi[d] - lo[d] + 1) {
                    break;
                }
            }
        }
        let cells = layout.cells_touching(&free);
        let mut row_of = vec![FIXED; total];
        let mut list = Vec::new();
        for (flat, _) in free.iter().enumerate().filter(|(_, f)| **f) {
            row_of[flat] = list.len();
            list.push(flat);
        }
        Ok(LocalRegion {
            row_of,
            free: list,
            cells,
        })
    }

    /// Whether a sample at parameter `u` enters a local refit over `region`: its knot
    /// span cell's block holds a free point (otherwise it touches none).
    pub fn region_takes(&self, region: &LocalRegion, u: &[f64]) -> bool {
        if u.len() != self.directions() || u.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let cell: usize = self
            .knot_vectors()
            .iter()
            .enumerate()
            .map(|(d, kv)| (kv.find_span(kv.clamp(u[d])) - kv.degree()) * self.strides[d])
            .sum();
        region.cells.get(cell).copied().unwrap_or(false)
    }

    /// This volume refitted to scattered samples on `region`'s control points only
    /// (see the module docs): `params` (`n` values a sample) and `values` (`k` a
    /// sample, the volume's attributes) as for [`Volume::fit_scattered`], but on this
    /// volume's knots; samples outside the region's cells are ignored. The points
    /// outside the region keep their values exactly.
    ///
    /// Refused for a rational volume ([`FitError::Rational`]: the fit is of the
    /// Cartesian values with weights 1), for bad shapes or non-finite samples, and
    /// when the conjugate gradients do not converge.
    pub fn refit_local(
        &self,
        region: &LocalRegion,
        params: &[f64],
        values: &[f64],
    ) -> Result<Volume, FitError> {
        if self.is_rational() {
            return Err(FitError::Rational);
        }
        let (n, k) = (self.directions(), self.components());
        sample_count(params, values, n, k)?;
        if region.row_of.len() != self.point_count() {
            return Err(FitError::Shape {
                what: "control points of the region",
                got: region.row_of.len(),
                need: self.point_count(),
            });
        }
        check_finite(params, values, n, k)?;
        let dim = k + 1;
        let mut net: Vec<f64> = self
            .homogeneous()
            .chunks_exact(dim)
            .flat_map(|p| p[..k].iter().copied())
            .collect();
        if region.free.is_empty() {
            return Ok(self.clone());
        }
        let layout = self.layout();
        let rows = SampleBases::new(self.knot_vectors(), &layout.strides, params);
        let nf = region.free.len();
        let normal = layout.assemble(&rows, values, k, (&region.row_of, nf), Some(&region.cells));
        // The fixed columns move to the right-hand side.
        let mut rhs = normal.atb;
        let csr = layout.compress(&normal.ata, &region.free, |r, col, v| {
            match region.row_of[col] {
                FIXED => {
                    for (t, a) in rhs[r * k..(r + 1) * k]
                        .iter_mut()
                        .zip(&net[col * k..(col + 1) * k])
                    {
                        *t -= v * a;
                    }
                    None
                }
                c => Some(c),
            }
        });
        let x0: Vec<f64> = region
            .free
            .iter()
            .flat_map(|&f| net[f * k..(f + 1) * k].iter().copied())
            .collect();
        let order = envelope_order(&region.free, self.counts());
        let x = match Envelope::factor(&csr, &order) {
            // The correction to the current net: A d = rhs - A x0, x = x0 + d.
            Some(chol) => {
                let mut ax = vec![0.0; nf * k];
                csr.mul(&x0, &mut ax, k);
                let mut d: Vec<f64> = rhs.iter().zip(&ax).map(|(b, a)| b - a).collect();
                chol.solve(&mut d, k);
                x0.iter().zip(&d).map(|(a, b)| a + b).collect()
            }
            // Not positive definite to working precision: conjugate gradients,
            // warm-started.
            None => pcg(&csr, &rhs, k, &Jacobi::new(&csr), Some(x0))?,
        };
        for (r, &f) in region.free.iter().enumerate() {
            net[f * k..(f + 1) * k].copy_from_slice(&x[r * k..(r + 1) * k]);
        }
        let knots = self
            .knot_vectors()
            .iter()
            .map(|kv| kv.knots().to_vec())
            .collect();
        Ok(Volume::new(
            self.degrees(),
            knots,
            self.attributes().to_vec(),
            net,
            None,
        )?)
    }

    /// The normal-matrix layout of this volume's net.
    fn layout(&self) -> Layout {
        Layout::new(&self.degrees(), self.counts(), &self.strides)
    }
}

/// The free points' order for the envelope factor: the direction along which the
/// free points' bounding box is longest varies slowest (then the next longest), so
/// a row's envelope spans the fewest points (about twice the box's cross-section).
/// Returns, per position, the free point's row (its index in `free`).
fn envelope_order(free: &[usize], counts: &[usize]) -> Vec<usize> {
    let n = counts.len();
    let index = |mut flat: usize| {
        let mut idx = [0usize; crate::volume::MAX_DIRECTIONS];
        for d in (0..n).rev() {
            idx[d] = flat % counts[d];
            flat /= counts[d];
        }
        idx
    };
    let mut lo = [usize::MAX; crate::volume::MAX_DIRECTIONS];
    let mut hi = [0usize; crate::volume::MAX_DIRECTIONS];
    for &f in free {
        let idx = index(f);
        for d in 0..n {
            lo[d] = lo[d].min(idx[d]);
            hi[d] = hi[d].max(idx[d]);
        }
    }
    let mut axes: Vec<usize> = (0..n).collect();
    // Longest first; ties in direction order (a stable sort).
    axes.sort_by_key(|&d| std::cmp::Reverse(hi[d].saturating_sub(lo[d])));
    let mut order: Vec<usize> = (0..free.len()).collect();
    order.sort_by_key(|&r| {
        let idx = index(free[r]);
        let mut key = [0usize; crate::volume::MAX_DIRECTIONS];
        for (slot, &d) in key.iter_mut().zip(&axes) {
            *slot = idx[d];
        }
        key
    });
    order
}

/// The Cholesky factor `L` (`A = L L^T`) of a symmetric positive definite matrix in
/// envelope (skyline) storage: row `i` of `L` holds the columns `first[i]..=i`, where
/// `first[i]` is the leftmost non-zero of row `i` of `A`; `L` has no fill outside that
/// envelope (George and Liu, *Computer Solution of Large Sparse Positive Definite
/// Systems*, 1981, ch. 4). Rows and columns are in a given order of the matrix's.
struct Envelope {
    /// Per position: the first column stored.
    first: Vec<usize>,
    /// Per position: where its row starts in `val` (one more at the end).
    start: Vec<usize>,
    val: Vec<f64>,
    /// Per position: the matrix's row.
    order: Vec<usize>,
}

impl Envelope {
    /// Factors `a` (symmetric, compressed rows) in the order `order` (position ->
    /// row); `None` when a pivot is not positive (not positive definite to working
    /// precision).
    fn factor(a: &Csr, order: &[usize]) -> Option<Self> {
        let n = order.len();
        let mut pos = vec![0usize; n];
        for (i, &r) in order.iter().enumerate() {
            pos[r] = i;
        }
        let first: Vec<usize> = order
            .iter()
            .enumerate()
            .map(|(i, &r)| {
                (a.start[r]..a.start[r + 1])
                    .map(|e| pos[a.col[e]])
                    .fold(i, usize::min)
            })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        for (i, &f) in first.iter().enumerate() {
            start.push(start[i] + i - f + 1);
        }
        let mut val = vec![0.0; start[n]];
        for (i, &r) in order.iter().enumerate() {
            for e in a.start[r]..a.start[r + 1] {
                let j = pos[a.col[e]];
                if j <= i {
                    val[start[i] + j - first[i]] = a.val[e];
                }
            }
        }
        // Row by row (the bordering form): for j < i, L_ij = (A_ij - sum_k L_ik L_jk)
        // / L_jj over the rows' common envelope, then L_ii = sqrt(A_ii - sum_k L_ik^2).
        for i in 0..n {
            let (fi, si) = (first[i], start[i]);
            let (before, rest) = val.split_at_mut(si);
            let row_i = &mut rest[..i - fi + 1];
            for j in fi..i {
                let (fj, sj) = (first[j], start[j]);
                let row_j = &before[sj..sj + j - fj + 1];
                let from = fi.max(fj);
                let s = row_i[j - fi] - dot(&row_i[from - fi..j - fi], &row_j[from - fj..j - fj]);
                row_i[j - fi] = s / row_j[j - fj];
            }
            let d = row_i[i - fi] - dot(&row_i[..i - fi], &row_i[..i - fi]);
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            row_i[i - fi] = d.sqrt();
        }
        Some(Self {
            first,
            start,
            val,
            order: order.to_vec(),
        })
    }
}

impl Envelope {
    /// Solves `A x = b` for `k` right-hand sides stored point-major (`b[r * k + c]`,
    /// `r` the matrix's row), in place: `L y = b` forward, `L^T x = y` backward.
    fn solve(&self, b: &mut [f64], k: usize) {
        let n = self.order.len();
        let mut y = vec![0.0; n * k];
        for (i, &r) in self.order.iter().enumerate() {
            y[i * k..(i + 1) * k].copy_from_slice(&b[r * k..(r + 1) * k]);
        }
        for i in 0..n {
            let fi = self.first[i];
            let row = &self.val[self.start[i]..self.start[i + 1]];
            for c in 0..k {
                let mut s = y[i * k + c];
                for (m, l) in row[..i - fi].iter().enumerate() {
                    s -= l * y[(fi + m) * k + c];
                }
                y[i * k + c] = s / row[i - fi];
            }
        }
        for i in (0..n).rev() {
            let fi = self.first[i];
            let row = &self.val[self.start[i]..self.start[i + 1]];
            for c in 0..k {
                let xi = y[i * k + c] / row[i - fi];
                y[i * k + c] = xi;
                for (m, l) in row[..i - fi].iter().enumerate() {
                    y[(fi + m) * k + c] -= l * xi;
                }
            }
        }
        for (i, &r) in self.order.iter().enumerate() {
            b[r * k..(r + 1) * k].copy_from_slice(&y[i * k..(i + 1) * k]);
        }
    }
}

/// `sum u_i v_i`, four partial sums (in a fixed order: deterministic).
fn dot(u: &[f64], v: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (uc, vc) = (u.chunks_exact(4), v.chunks_exact(4));
    let (ur, vr) = (uc.remainder(), vc.remainder());
    for (a, b) in uc.zip(vc) {
        for l in 0..4 {
            acc[l] += a[l] * b[l];
        }
    }
    let tail: f64 = ur.iter().zip(vr).map(|(a, b)| a * b).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth field on the unit cube, sampled on a jittered grid.
    fn samples(f: impl Fn(f64, f64, f64) -> f64, m: usize) -> (Vec<f64>, Vec<f64>) {
        let mut params = Vec::new();
        let mut values = Vec::new();
        for i in 0..m {
            for j in 0..m {
                for l in 0..m {
                    // A fixed jitter (no randomness: the fit is deterministic).
                    let jit = |a: usize| ((a * 7919 + 13) % 97) as f64 / 97.0 - 0.5;
                    let u = [
                        ((i as f64 + 0.5 + 0.4 * jit(i + 3 * j)) / m as f64).clamp(0.0, 1.0),
                        ((j as f64 + 0.5 + 0.4 * jit(j + 5 * l)) / m as f64).clamp(0.0, 1.0),
                        ((l as f64 + 0.5 + 0.4 * jit(l + 7 * i)) / m as f64).clamp(0.0, 1.0),
                    ];
                    params.extend(u);
                    values.push(f(u[0], u[1], u[2]));
                }
            }
        }
        // The corners span the knots' range.
        for c in 0..8 {
            let u = [c & 1, (c >> 1) & 1, (c >> 2) & 1].map(f64::from);
            params.extend(u);
            values.push(f(u[0], u[1], u[2]));
        }
        (params, values)
    }

    fn fit(params: &[f64], values: &[f64]) -> Volume {
        Volume::fit_scattered(params, values, vec!["f".into()], &[2, 2, 2], &[8, 8, 8]).unwrap()
    }

    #[test]
    fn an_unchanged_sample_set_refits_to_the_same_field() {
        let (params, values) = samples(|x, y, z| x * y + z * z, 14);
        let whole = fit(&params, &values);
        let region = whole.local_region(&[0.5, 0.5, 0.5], &[0.1; 3]).unwrap();
        assert!(!region.free_points().is_empty());
        let local = whole.refit_local(&region, &params, &values).unwrap();
        let (a, b) = (whole.homogeneous(), local.homogeneous());
        let worst = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < crate::tolerance::LOCAL_REFIT_SOLVED,
            "moved {worst}"
        );
    }

    #[test]
    fn a_local_change_moves_only_the_free_points_and_matches_the_whole_refit_there() {
        let counts = [12; 3];
        let fit = |p: &[f64], v: &[f64]| {
            Volume::fit_scattered(p, v, vec!["f".into()], &[2, 2, 2], &counts).unwrap()
        };
        let (params, mut values) = samples(|x, y, z| x + y - z, 18);
        let before = fit(&params, &values);
        // A smooth bump of height 1 around (0.25, 0.75, 0.5), 0.05 wide.
        let centre = [0.25, 0.75, 0.5];
        let width = 0.05;
        let bump = |u: &[f64]| {
            let r2: f64 = (0..3).map(|d| (u[d] - centre[d]).powi(2)).sum();
            (-r2 / (width * width)).exp()
        };
        for (u, v) in params.chunks_exact(3).zip(values.iter_mut()) {
            *v += bump(u);
        }
        let whole = fit(&params, &values);
        let mut out = [0.0];
        let mut out2 = [0.0];
        // The change reaches 3 widths (the bump is below 1e-3 beyond it); the free
        // points reach `rings` knot spans (a tenth each) beyond that.
        let mut worst_with = |rings: f64| {
            let reach = [3.0 * width + rings / 10.0; 3];
            let region = before.local_region(&centre, &reach).unwrap();
            let local = before.refit_local(&region, &params, &values).unwrap();
            for flat in 0..before.point_count() {
                let (b, l) = (
                    before.homogeneous()[flat * 2],
                    local.homogeneous()[flat * 2],
                );
                if !region.is_free(flat) {
                    assert_eq!(b.to_bits(), l.to_bits(), "fixed point {flat} moved");
                }
            }
            // Bit for bit outside every free point's support.
            let far = [0.95, 0.05, 0.05];
            assert!(!before.region_takes(&region, &far));
            before.eval_into(&far, &mut out).unwrap();
            local.eval_into(&far, &mut out2).unwrap();
            assert_eq!(out[0].to_bits(), out2[0].to_bits());
            // At the samples the bump raised: local against whole.
            let mut worst: f64 = 0.0;
            for u in params.chunks_exact(3).filter(|u| bump(u) > 0.1) {
                local.eval_into(u, &mut out).unwrap();
                whole.eval_into(u, &mut out2).unwrap();
                worst = worst.max((out[0] - out2[0]).abs());
            }
            worst
        };
        let (tight, wide) = (worst_with(0.0), worst_with(2.0));
        assert!(wide <= tight, "{wide} > {tight}");
        assert!(
            wide < crate::tolerance::LOCAL_REFIT_BUMP,
            "local vs whole: {wide}"
        );
    }

    #[test]
    fn a_rational_volume_or_a_bad_shape_is_refused() {
        let (params, values) = samples(|x, _, _| x, 6);
        let v = fit(&params, &values);
        let region = v.local_region(&[0.5, 0.5, 0.5], &[0.1; 3]).unwrap();
        assert!(matches!(
            v.refit_local(&region, &params[..5], &values),
            Err(FitError::Shape { .. })
        ));
        assert!(matches!(
            v.local_region(&[0.5, 0.5], &[0.1; 3]),
            Err(FitError::Shape { .. })
        ));
        assert!(matches!(
            v.local_region(&[0.5, f64::NAN, 0.5], &[0.1; 3]),
            Err(FitError::NotFinite { .. })
        ));
        let knots: Vec<Vec<f64>> = v
            .knot_vectors()
            .iter()
            .map(|k| k.knots().to_vec())
            .collect();
        let weights: Vec<f64> = (0..v.point_count()).map(|i| 1.0 + (i % 2) as f64).collect();
        let values: Vec<f64> = vec![0.0; v.point_count()];
        let rational =
            Volume::new(v.degrees(), knots, vec!["f".into()], values, Some(weights)).unwrap();
        assert_eq!(
            rational.refit_local(&region, &params, &samples(|x, _, _| x, 6).1),
            Err(FitError::Rational)
        );
    }
}
