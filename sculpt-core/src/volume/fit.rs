//! Building volumes from data (Park 2005, sec. 3).
//!
//! - [`Volume::fit_scattered`] (sec. 3.1): `M` samples with known parameters, uniform
//!   clamped knots, weights 1. With `M >= N` control points, least squares through the
//!   normal equations `(N^T N) A = N^T P` (eq. 11); with `M < N` the minimum-norm
//!   (pseudo-inverse) solution `A = N^T (N N^T)^{-1} P` (eqs. 12 to 15), which
//!   interpolates the samples.
//! - [`Volume::refit_local`] (the `local` module): the least squares of sec. 3.1 on the
//!   control points near a change only, the others held, warm-started.
//! - [`Volume::interpolate_grid`] (sec. 3.2): a curvilinear grid of points with
//!   attributes; knots per direction by Hartley and Judd's method averaged over all grid
//!   lines of that direction (eq. 24), parameters at the Greville abscissae of those
//!   knots (eq. 25), the control net solved one direction at a time (eqs. 16 to 27).
//!
//! # Solvers
//!
//! - Least squares: the normal matrix is sparse (a control point couples only with
//!   those within `p_d` indices in every direction: at most `prod (2 p_d + 1)` entries a
//!   row, 343 for cubics). It is assembled cell by cell: the samples are bucketed by
//!   knot-span cell and each cell's block `B^T B` (`B` the cell's samples x
//!   `prod (p_d + 1)` basis products) is one dense matrix product, added once into
//!   compressed rows. The system is solved by preconditioned conjugate gradients, all
//!   `k` attributes at once, with a scaled tensor-product preconditioner: the Kronecker
//!   product of the per-direction Gram matrices of the samples' marginals, rescaled
//!   row by row to the normal matrix's diagonal (Jacobi when a direction's Gram matrix
//!   is singular). A control point no sample reaches has a zero row and a zero scale;
//!   CG started at zero leaves it at zero (the least-squares solution of smallest norm
//!   in those unknowns).
//! - Minimum norm: `N N^T` is `M x M` with `M < N`; it is assembled through the control
//!   points each sample touches and factored by nalgebra's dense Cholesky (the SVD
//!   pseudo-inverse when samples repeat and it is singular).
//! - Grid interpolation: one collocation matrix per direction (banded, bandwidth `p`),
//!   LU-factored once by nalgebra and applied to every grid line of that direction.

use nalgebra::{DMatrix, DMatrixView};
use thiserror::Error;

use super::vtk::StructuredGrid;
use super::{MAX_COMPONENTS, MAX_CONTROL_POINTS, MAX_DIRECTIONS, Volume, VolumeError};
use crate::nurbs::knots::{KnotVector, MAX_DEGREE, MAX_ORDER};

mod local;
pub use local::LocalRegion;

/// Why a fit or interpolation failed.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FitError {
    /// Fewer samples than the control points of one knot span (`prod (p_d + 1)`).
    #[error(
        "{samples} samples are fewer than one knot span needs ({need} = product of degree + 1)"
    )]
    TooFewSamples {
        /// Samples given.
        samples: usize,
        /// `prod (p_d + 1)`.
        need: usize,
    },
    /// The degrees, counts and sample widths disagree, or are out of range.
    #[error(
        "direction {direction}: {count} control points cannot carry degree {degree} (need degree + 1 <= count, degree 1..={max})"
    )]
    CountDegree {
        /// The direction.
        direction: usize,
        /// Control points asked for.
        count: usize,
        /// The degree.
        degree: usize,
        /// The highest degree.
        max: usize,
    },
    /// The shape of the input is wrong (parameter or value counts).
    #[error("{what}: got {got}, need {need}")]
    Shape {
        /// What is wrong.
        what: &'static str,
        /// Found.
        got: usize,
        /// Needed.
        need: usize,
    },
    /// A sample has a NaN or infinite parameter or value.
    #[error("sample {sample}: a parameter or value is not finite")]
    NotFinite {
        /// 0-based sample.
        sample: usize,
    },
    /// All samples share one parameter value in a direction: no domain to fit over.
    #[error(
        "direction {direction}: every sample has the parameter {value}; the knots need a range"
    )]
    FlatParameters {
        /// The direction.
        direction: usize,
        /// The common value.
        value: f64,
    },
    /// The conjugate gradients did not converge (the data leave the system too
    /// ill-conditioned for the requested net).
    #[error(
        "least squares did not converge: relative residual {residual:e} after {iterations} iterations"
    )]
    NotConverged {
        /// The relative residual reached.
        residual: f64,
        /// Iterations run.
        iterations: usize,
    },
    /// A dense solve failed (the samples' system is singular beyond repair).
    #[error("the sample system is singular: {0}")]
    Singular(&'static str),
    /// The grid is too small for the degree in some direction.
    #[error("grid direction {direction} has {points} points, fewer than degree {degree} + 1")]
    GridTooSmall {
        /// The direction.
        direction: usize,
        /// Grid points along it.
        points: usize,
        /// The degree asked for.
        degree: usize,
    },
    /// A local refit of a rational volume ([`Volume::refit_local`] fits Cartesian
    /// values with weights 1).
    #[error("a local refit needs a non-rational volume (weights 1)")]
    Rational,
    /// The fitted volume is invalid (values beyond the caps).
    #[error("{0}")]
    Volume(#[from] VolumeError),
}

/// The most entries the sparse normal matrix of a least-squares fit may take before
/// compression (control points x stencil): 512 MB.
pub const MAX_NORMAL_ENTRIES: usize = 1 << 26;
/// The most samples of a minimum-norm fit (`M < N`): its dense `M x M` system.
pub const MAX_MIN_NORM_SAMPLES: usize = 4096;

/// Relative residual at which the conjugate gradients of the least-squares fit stop.
const CG_TOL: f64 = crate::tolerance::VOLUME_CG_REL;

/// Compressed sparse rows of a square symmetric matrix.
struct Csr {
    start: Vec<usize>,
    col: Vec<usize>,
    val: Vec<f64>,
}

impl Csr {
    /// The diagonal entry of row `r` (0 when it is not stored).
    fn diagonal(&self, r: usize) -> f64 {
        (self.start[r]..self.start[r + 1])
            .find(|&e| self.col[e] == r)
            .map_or(0.0, |e| self.val[e])
    }

    /// `y = A x` for `k` right-hand sides stored point-major (`x[i * k + c]`).
    fn mul(&self, x: &[f64], y: &mut [f64], k: usize) {
        for (r, w) in self.start.windows(2).enumerate() {
            let out = &mut y[r * k..(r + 1) * k];
            out.iter_mut().for_each(|v| *v = 0.0);
            for e in w[0]..w[1] {
                let (c, a) = (self.col[e], self.val[e]);
                for (o, xi) in out.iter_mut().zip(&x[c * k..(c + 1) * k]) {
                    *o += a * xi;
                }
            }
        }
    }
}

/// A preconditioner `z = P^{-1} r` for `k` right-hand sides stored point-major.
trait Preconditioner {
    /// Writes `P^{-1} r` into `z`.
    fn apply(&self, r: &[f64], z: &mut [f64], k: usize);
}

/// The Jacobi preconditioner `P = diag(A)` (zero where the diagonal is).
struct Jacobi(Vec<f64>);

impl Jacobi {
    fn new(a: &Csr) -> Self {
        let n = a.start.len() - 1;
        Self(
            (0..n)
                .map(|r| {
                    let d = a.diagonal(r);
                    if d > 0.0 { 1.0 / d } else { 0.0 }
                })
                .collect(),
        )
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[f64], z: &mut [f64], k: usize) {
        for ((zs, rs), &s) in z.chunks_mut(k).zip(r.chunks(k)).zip(&self.0) {
            for (zi, ri) in zs.iter_mut().zip(rs) {
                *zi = s * ri;
            }
        }
    }
}

/// The scaled tensor-product preconditioner `P^{-1} = S (G_1 (x) .. (x) G_n)^{-1} S`.
///
/// `G_d = sum_s b_d(s) b_d(s)^T` is the Gram matrix of direction `d`'s basis over the
/// samples' `d`-th parameters (the marginal of the normal matrix: for samples spread
/// independently in each direction, `E[N^T N]` is proportional to the Kronecker
/// product of the `G_d`). `S = diag(sqrt(K_II / A_II))` rescales it to the actual
/// normal matrix `A` row by row (the local sample density), and is zero on the rows
/// no sample reaches, which CG then leaves at zero. `K^{-1}` is applied one direction
/// at a time, each line of the net multiplied by the dense `G_d^{-1}`
/// (`count_d <= 128`).
struct Tensor {
    /// `G_d^{-1}`, row-major `count_d x count_d`.
    inv: Vec<Vec<f64>>,
    counts: Vec<usize>,
    /// `S` per control point.
    scale: Vec<f64>,
}

impl Tensor {
    /// The preconditioner of `a` from the per-direction Gram matrices `grams`
    /// (`count_d x count_d`, row-major); `None` when one of them is singular (too few
    /// distinct parameters in that direction): the caller uses [`Jacobi`].
    fn new(a: &Csr, grams: &[Vec<f64>], counts: &[usize]) -> Option<Self> {
        let mut inv = Vec::with_capacity(grams.len());
        for (g, &c) in grams.iter().zip(counts) {
            // A basis function no sample's parameter reaches: an identity row (the
            // matching rows of A are zero, and S removes them).
            let mut g = nalgebra::DMatrix::from_row_slice(c, c, g);
            for i in 0..c {
                if g[(i, i)] == 0.0 {
                    g[(i, i)] = 1.0;
                }
            }
            let gi = g.cholesky()?.inverse();
            inv.push((0..c * c).map(|e| gi[(e / c, e % c)]).collect());
        }
        let n = counts.len();
        let total: usize = counts.iter().product();
        let mut scale = vec![0.0; total];
        let mut idx = vec![0usize; n];
        for (r, s) in scale.iter_mut().enumerate() {
            let mut rest = r;
            for d in (0..n).rev() {
                idx[d] = rest % counts[d];
                rest /= counts[d];
            }
            let a_rr = a.diagonal(r);
            if a_rr > 0.0 {
                // K_II, the product of the G_d diagonals (positive: A_II > 0 means
                // some sample reaches every one of the point's basis functions).
                let k_rr: f64 = (0..n)
                    .map(|d| grams[d][idx[d] * counts[d] + idx[d]])
                    .product();
                *s = (k_rr / a_rr).sqrt();
            }
        }
        Some(Self {
            inv,
            counts: counts.to_vec(),
            scale,
        })
    }
}

impl Preconditioner for Tensor {
    fn apply(&self, r: &[f64], z: &mut [f64], k: usize) {
        for ((zs, rs), &s) in z.chunks_mut(k).zip(r.chunks(k)).zip(&self.scale) {
            for (zi, ri) in zs.iter_mut().zip(rs) {
                *zi = s * ri;
            }
        }
        // K^{-1} = G_1^{-1} (x) .. (x) G_n^{-1}: every line of every direction.
        let total = self.scale.len();
        let mut line = Vec::new();
        let mut stride = total;
        for (d, &c) in self.counts.iter().enumerate() {
            stride /= c;
            let inv = &self.inv[d];
            line.resize(c * k, 0.0);
            for outer in 0..total / (c * stride) {
                for inner in 0..stride {
                    let at = |i: usize| ((outer * c + i) * stride + inner) * k;
                    for i in 0..c {
                        line[i * k..(i + 1) * k].copy_from_slice(&z[at(i)..at(i) + k]);
                    }
                    for i in 0..c {
                        let out = &mut z[at(i)..at(i) + k];
                        out.iter_mut().for_each(|v| *v = 0.0);
                        for (j, &g) in inv[i * c..(i + 1) * c].iter().enumerate() {
                            for (o, l) in out.iter_mut().zip(&line[j * k..(j + 1) * k]) {
                                *o += g * l;
                            }
                        }
                    }
                }
            }
        }
        for (zs, &s) in z.chunks_mut(k).zip(&self.scale) {
            zs.iter_mut().for_each(|v| *v *= s);
        }
    }
}

/// Preconditioned conjugate gradients for `A X = B` with `k` columns solved together
/// (each column has its own step lengths).
///
/// `x0` starts the iteration (a warm start); zero when `None`.
fn pcg(
    a: &Csr,
    b: &[f64],
    k: usize,
    pre: &dyn Preconditioner,
    x0: Option<Vec<f64>>,
) -> Result<Vec<f64>, FitError> {
    let n = a.start.len() - 1;
    let mut r = b.to_vec();
    let mut x = match x0 {
        Some(x) => {
            let mut ax = vec![0.0; n * k];
            a.mul(&x, &mut ax, k);
            r.iter_mut().zip(&ax).for_each(|(ri, v)| *ri -= v);
            x
        }
        None => vec![0.0; n * k],
    };
    let mut z = vec![0.0; n * k];
    pre.apply(&r, &mut z, k);
    let mut p = z.clone();
    let mut ap = vec![0.0; n * k];
    let dot = |u: &[f64], v: &[f64], c: usize| -> f64 {
        (0..n).map(|i| u[i * k + c] * v[i * k + c]).sum()
    };
    let b_norm: Vec<f64> = (0..k).map(|c| dot(b, b, c).sqrt()).collect();
    let mut rz: Vec<f64> = (0..k).map(|c| dot(&r, &z, c)).collect();
    let max_iter = (10 * n).max(100);
    let mut worst = 0.0;
    for it in 0..max_iter {
        worst = (0..k)
            .map(|c| {
                if b_norm[c] > 0.0 {
                    dot(&r, &r, c).sqrt() / b_norm[c]
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        if worst <= CG_TOL {
            return Ok(x);
        }
        a.mul(&p, &mut ap, k);
        for c in 0..k {
            let pap = dot(&p, &ap, c);
            if pap <= 0.0 || rz[c] == 0.0 {
                continue;
            }
            let alpha = rz[c] / pap;
            for i in 0..n {
                x[i * k + c] += alpha * p[i * k + c];
                r[i * k + c] -= alpha * ap[i * k + c];
            }
        }
        pre.apply(&r, &mut z, k);
        for c in 0..k {
            let new = dot(&r, &z, c);
            let beta = if rz[c] > 0.0 { new / rz[c] } else { 0.0 };
            rz[c] = new;
            for i in 0..n {
                p[i * k + c] = z[i * k + c] + beta * p[i * k + c];
            }
        }
        if it + 1 == max_iter {
            break;
        }
    }
    Err(FitError::NotConverged {
        residual: worst,
        iterations: max_iter,
    })
}

/// The flat offsets (from the first local point) of the local block, odometer order.
fn local_offsets(degrees: &[usize], strides: &[usize]) -> Vec<usize> {
    let mut out = vec![0usize];
    for (d, &p) in degrees.iter().enumerate() {
        out = out
            .iter()
            .flat_map(|&o| (0..=p).map(move |i| o + i * strides[d]))
            .collect();
    }
    out
}

/// The samples' knot spans and basis functions, direction by direction.
struct SampleBases {
    /// Per sample: the flat index of its first local control point.
    start: Vec<usize>,
    /// Per sample and direction: the first basis index (`span - p_d`).
    first: Vec<usize>,
    /// Per sample and direction: the `p_d + 1` non-zero basis functions
    /// (P&T A2.2), padded to [`MAX_ORDER`].
    basis: Vec<[f64; MAX_ORDER]>,
    n: usize,
}

impl SampleBases {
    fn new(kvs: &[KnotVector], strides: &[usize], params: &[f64]) -> Self {
        let n = kvs.len();
        let m = params.len() / n;
        let mut out = Self {
            start: Vec::with_capacity(m),
            first: Vec::with_capacity(m * n),
            basis: Vec::with_capacity(m * n),
            n,
        };
        for u in params.chunks_exact(n) {
            let mut start = 0;
            for (d, kv) in kvs.iter().enumerate() {
                let t = kv.clamp(u[d]);
                let s = kv.find_span(t);
                let first = s - kv.degree();
                start += first * strides[d];
                out.first.push(first);
                out.basis.push(kv.basis(s, t));
            }
            out.start.push(start);
        }
        out
    }

    fn len(&self) -> usize {
        self.start.len()
    }

    /// The `prod (p_d + 1)` basis products `N_I(u)` of sample `s` in the local
    /// odometer order (last direction fastest), into `coef`.
    fn products(&self, s: usize, degrees: &[usize], coef: &mut Vec<f64>) {
        coef.clear();
        coef.push(1.0);
        for (d, &p) in degrees.iter().enumerate() {
            let b = &self.basis[s * self.n + d];
            let len = coef.len();
            coef.resize(len * (p + 1), 0.0);
            // Expand in place from the back so no entry is overwritten before use.
            for i in (0..len).rev() {
                let c = coef[i];
                for (j, &v) in b[..=p].iter().enumerate().rev() {
                    coef[i * (p + 1) + j] = c * v;
                }
            }
        }
    }
}

impl Volume {
    /// Fits a non-rational volume to `M` scattered samples with known parameters
    /// (Park 2005, sec. 3.1; see the module docs for the solvers).
    ///
    /// - `params`: `M x n` values (sample after sample); the knots are uniform and
    ///   clamped over the parameters' range in each direction.
    /// - `values`: `M x k` values, in the order of `attributes`.
    /// - `degrees`, `counts`: per direction, `degree + 1 <= count`.
    pub fn fit_scattered(
        params: &[f64],
        values: &[f64],
        attributes: Vec<String>,
        degrees: &[usize],
        counts: &[usize],
    ) -> Result<Self, FitError> {
        let n = degrees.len();
        let k = attributes.len();
        if n == 0 || n > MAX_DIRECTIONS || counts.len() != n {
            return Err(FitError::Shape {
                what: "directions (degrees and counts)",
                got: n.max(counts.len()),
                need: MAX_DIRECTIONS,
            });
        }
        if k == 0 || k > MAX_COMPONENTS {
            return Err(FitError::Shape {
                what: "attributes",
                got: k,
                need: MAX_COMPONENTS,
            });
        }
        for d in 0..n {
            if degrees[d] == 0 || degrees[d] > MAX_DEGREE || counts[d] < degrees[d] + 1 {
                return Err(FitError::CountDegree {
                    direction: d,
                    count: counts[d],
                    degree: degrees[d],
                    max: MAX_DEGREE,
                });
            }
        }
        let m = sample_count(params, values, n, k)?;
        let need: usize = degrees.iter().map(|p| p + 1).product();
        if m < need {
            return Err(FitError::TooFewSamples { samples: m, need });
        }
        let total = counts.iter().try_fold(1usize, |a, &c| a.checked_mul(c));
        let total = match total {
            Some(t) if t <= MAX_CONTROL_POINTS => t,
            _ => {
                return Err(FitError::Volume(VolumeError::TooManyControlPoints {
                    count: total.unwrap_or(usize::MAX),
                    max: MAX_CONTROL_POINTS,
                }));
            }
        };
        check_finite(params, values, n, k)?;
        // Uniform clamped knots over the parameters' range.
        let mut kvs = Vec::with_capacity(n);
        let mut knots = Vec::with_capacity(n);
        for d in 0..n {
            let (lo, hi) = (0..m).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                (lo.min(params[s * n + d]), hi.max(params[s * n + d]))
            });
            if hi <= lo {
                return Err(FitError::FlatParameters {
                    direction: d,
                    value: lo,
                });
            }
            let unit = KnotVector::uniform_clamped(degrees[d], counts[d]).map_err(|reason| {
                FitError::Volume(VolumeError::Knots {
                    direction: d,
                    reason,
                })
            })?;
            let k_d: Vec<f64> = unit.knots().iter().map(|t| lo + (hi - lo) * t).collect();
            kvs.push(KnotVector::new(degrees[d], k_d.clone()).map_err(|reason| {
                FitError::Volume(VolumeError::Knots {
                    direction: d,
                    reason,
                })
            })?);
            knots.push(k_d);
        }
        let mut strides = vec![1; n];
        for d in (0..n - 1).rev() {
            strides[d] = strides[d + 1] * counts[d + 1];
        }
        let layout = Layout::new(degrees, counts, &strides);
        let rows = SampleBases::new(&kvs, &strides, params);
        let stencil: usize = degrees.iter().map(|p| 2 * p + 1).product();
        if m >= total && total.saturating_mul(stencil) > MAX_NORMAL_ENTRIES {
            return Err(FitError::Shape {
                what: "normal matrix entries (control points x stencil)",
                got: total.saturating_mul(stencil),
                need: MAX_NORMAL_ENTRIES,
            });
        }
        if m < total && m > MAX_MIN_NORM_SAMPLES {
            return Err(FitError::Shape {
                what: "samples of a minimum-norm fit (fewer samples than control points)",
                got: m,
                need: MAX_MIN_NORM_SAMPLES,
            });
        }
        let coeffs = if m >= total {
            least_squares(&rows, &layout, values, k)?
        } else {
            minimum_norm(&rows, &layout.offsets, values, total, k, degrees)?
        };
        Ok(Volume::new(
            degrees.to_vec(),
            knots,
            attributes,
            coeffs,
            None,
        )?)
    }
}

/// The index layout of a volume's normal matrix: every row's stencil of
/// `prod (2 p_d + 1)` columns (the control points within `p_d` indices in every
/// direction) and where each entry of a cell's block lands in it.
struct Layout {
    degrees: Vec<usize>,
    counts: Vec<usize>,
    strides: Vec<usize>,
    /// `2 p_d + 1` per direction.
    widths: Vec<usize>,
    /// `prod widths`.
    stencil: usize,
    /// The cell's local control points, from its first (odometer order).
    offsets: Vec<usize>,
    /// `slot[a * nl + b]`: where `N_a N_b` goes in row `a`'s stencil.
    slot: Vec<usize>,
}

impl Layout {
    fn new(degrees: &[usize], counts: &[usize], strides: &[usize]) -> Self {
        let n = degrees.len();
        let offsets = local_offsets(degrees, strides);
        let nl = offsets.len();
        let widths: Vec<usize> = degrees.iter().map(|p| 2 * p + 1).collect();
        let stencil: usize = widths.iter().product();
        let mut sstrides = vec![1; n];
        for d in (0..n - 1).rev() {
            sstrides[d] = sstrides[d + 1] * widths[d + 1];
        }
        // local index -> multi-index within the block.
        let local: Vec<Vec<usize>> = (0..nl)
            .map(|mut l| {
                let mut idx = vec![0; n];
                for d in (0..n).rev() {
                    idx[d] = l % (degrees[d] + 1);
                    l /= degrees[d] + 1;
                }
                idx
            })
            .collect();
        let sstrides = &sstrides;
        let slot: Vec<usize> = local
            .iter()
            .flat_map(|a| {
                local.iter().map(move |b| {
                    (0..n)
                        .map(|d| (b[d] + degrees[d] - a[d]) * sstrides[d])
                        .sum::<usize>()
                })
            })
            .collect();
        Self {
            degrees: degrees.to_vec(),
            counts: counts.to_vec(),
            strides: strides.to_vec(),
            widths,
            stencil,
            offsets,
            slot,
        }
    }

    fn total(&self) -> usize {
        self.counts.iter().product()
    }

    /// The multi-index of flat control point `flat`, into `idx`.
    fn unflatten(&self, mut flat: usize, idx: &mut [usize]) {
        for d in (0..self.counts.len()).rev() {
            idx[d] = flat % self.counts[d];
            flat /= self.counts[d];
        }
    }

    /// The flat index of every cell (its first control point) whose block holds a
    /// point `free` marks: `first_d <= count_d - p_d - 1` in every direction.
    fn cells_touching(&self, free: &[bool]) -> Vec<bool> {
        let n = self.counts.len();
        let mut idx = vec![0usize; n];
        (0..self.total())
            .map(|cell| {
                self.unflatten(cell, &mut idx);
                (0..n).all(|d| idx[d] + self.degrees[d] < self.counts[d])
                    && self.offsets.iter().any(|&o| free[cell + o])
            })
            .collect()
    }

    /// Sums the normal equations' rows `N^T N` (stencil-wise) and `N^T P` over the
    /// cells `cells` marks (all when `None`) into the rows `row_of` gives each control
    /// point (`FIXED`: not summed), `rows` of them.
    ///
    /// Cell by cell: the samples are bucketed by their knot-span cell (counting sort on
    /// the cell's first control point), each cell's `prod (p_d + 1)`-square block
    /// `sum_s N(s) N(s)^T` is one dense product, added once into the rows' stencils.
    /// Also the per-direction Gram matrices of the samples' marginals (for
    /// [`Tensor`]).
    fn assemble(
        &self,
        samples: &SampleBases,
        values: &[f64],
        k: usize,
        (row_of, rows): (&[usize], usize),
        cells: Option<&[bool]>,
    ) -> Normal {
        let n = self.degrees.len();
        let (degrees, counts, offsets) = (&self.degrees, &self.counts, &self.offsets);
        let total = self.total();
        let (nl, stencil) = (offsets.len(), self.stencil);
        let m = samples.len();
        // Bucket the samples by cell (counting sort on the first control point).
        let mut bucket = vec![0usize; total + 1];
        for &st in &samples.start {
            bucket[st + 1] += 1;
        }
        for i in 0..total {
            bucket[i + 1] += bucket[i];
        }
        let mut order = vec![0usize; m];
        let mut fill = bucket.clone();
        for (s, &st) in samples.start.iter().enumerate() {
            order[fill[st]] = s;
            fill[st] += 1;
        }
        let mut out = Normal {
            ata: vec![0.0; rows * stencil],
            atb: vec![0.0; rows * k],
            grams: counts.iter().map(|&c| vec![0.0; c * c]).collect(),
        };
        let mut block = DMatrix::<f64>::zeros(nl, nl);
        // The cell's samples' basis products, one column per sample.
        let mut products: Vec<f64> = Vec::new();
        let mut coef = Vec::with_capacity(nl);
        for cell in 0..total {
            let in_cell = &order[bucket[cell]..bucket[cell + 1]];
            if in_cell.is_empty() || cells.is_some_and(|c| !c[cell]) {
                continue;
            }
            products.clear();
            for &s in in_cell {
                samples.products(s, degrees, &mut coef);
                products.extend_from_slice(&coef);
                let val = &values[s * k..(s + 1) * k];
                for (a, &ca) in coef.iter().enumerate() {
                    let ia = row_of[cell + offsets[a]];
                    if ia == FIXED {
                        continue;
                    }
                    for (t, v) in out.atb[ia * k..(ia + 1) * k].iter_mut().zip(val) {
                        *t += ca * v;
                    }
                }
                for (d, g) in out.grams.iter_mut().enumerate() {
                    let (c, p) = (counts[d], degrees[d]);
                    let f = samples.first[s * n + d];
                    let b = &samples.basis[s * n + d];
                    for i in 0..=p {
                        for j in 0..=p {
                            g[(f + i) * c + f + j] += b[i] * b[j];
                        }
                    }
                }
            }
            // block = B^T B with B the samples x nl matrix of products (a BLAS-3
            // product, nalgebra's gemm through matrixmultiply): `bt` holds B^T
            // column-major, and the view reads the same memory as B.
            let bt = DMatrixView::from_slice(&products, nl, in_cell.len());
            let b = DMatrixView::from_slice_with_strides(&products, in_cell.len(), nl, nl, 1);
            block.gemm(1.0, &bt, &b, 0.0);
            for a in 0..nl {
                let row = row_of[cell + offsets[a]];
                if row == FIXED {
                    continue;
                }
                let base = row * stencil;
                for b in 0..nl {
                    out.ata[base + self.slot[a * nl + b]] += block[(a, b)];
                }
            }
        }
        out
    }

    /// Compressed rows of the stencil rows `ata` (row `r` is control point
    /// `points[r]`): every non-zero entry is offered to `keep(row, column point,
    /// value)`, which gives its column in the result or `None` to leave it out.
    fn compress(
        &self,
        ata: &[f64],
        points: &[usize],
        mut keep: impl FnMut(usize, usize, f64) -> Option<usize>,
    ) -> Csr {
        let n = self.degrees.len();
        let mut csr = Csr {
            start: Vec::with_capacity(points.len() + 1),
            col: Vec::new(),
            val: Vec::new(),
        };
        csr.start.push(0);
        let mut idx = vec![0usize; n];
        for (r, &point) in points.iter().enumerate() {
            self.unflatten(point, &mut idx);
            for sidx in 0..self.stencil {
                let v = ata[r * self.stencil + sidx];
                if v == 0.0 {
                    continue;
                }
                let mut col = 0isize;
                let mut rest = sidx;
                for d in (0..n).rev() {
                    let off = (rest % self.widths[d]) as isize - self.degrees[d] as isize;
                    rest /= self.widths[d];
                    col += (idx[d] as isize + off) * self.strides[d] as isize;
                }
                if let Some(c) = keep(r, col as usize, v) {
                    csr.col.push(c);
                    csr.val.push(v);
                }
            }
            csr.start.push(csr.col.len());
        }
        csr
    }
}

/// `row_of` marks a control point held fixed (not a row of the system).
const FIXED: usize = usize::MAX;

/// Summed normal equations: stencil rows of `N^T N`, `N^T P` (`k` per row) and the
/// per-direction Gram matrices of the samples' marginals.
struct Normal {
    ata: Vec<f64>,
    atb: Vec<f64>,
    grams: Vec<Vec<f64>>,
}

/// The number of samples of `n` parameters and `k` values each; refused when the
/// lengths disagree ([`FitError::Shape`]).
fn sample_count(params: &[f64], values: &[f64], n: usize, k: usize) -> Result<usize, FitError> {
    let m = params.len() / n;
    if params.len() != m * n || values.len() != m * k {
        return Err(FitError::Shape {
            what: "values (samples x attributes)",
            got: values.len(),
            need: m * k,
        });
    }
    Ok(m)
}

/// The first sample (`n` parameters and `k` values each) with a NaN or infinite
/// number is refused ([`FitError::NotFinite`]).
fn check_finite(params: &[f64], values: &[f64], n: usize, k: usize) -> Result<(), FitError> {
    match params
        .chunks_exact(n)
        .zip(values.chunks_exact(k))
        .position(|(u, v)| u.iter().chain(v).any(|x| !x.is_finite()))
    {
        Some(sample) => Err(FitError::NotFinite { sample }),
        None => Ok(()),
    }
}

/// The normal equations `(N^T N) A = N^T P` (Park 2005, eq. 11), sparse, by PCG.
///
/// Assembled cell by cell ([`Layout::assemble`]) and solved by conjugate gradients
/// with the scaled tensor-product preconditioner ([`Tensor`]), or Jacobi when a
/// direction's Gram matrix is singular.
fn least_squares(
    rows: &SampleBases,
    layout: &Layout,
    values: &[f64],
    k: usize,
) -> Result<Vec<f64>, FitError> {
    let total = layout.total();
    let identity: Vec<usize> = (0..total).collect();
    let normal = layout.assemble(rows, values, k, (&identity, total), None);
    // Compress: keep the non-zero stencil entries, with their column indices.
    let csr = layout.compress(&normal.ata, &identity, |_, col, _| Some(col));
    drop(normal.ata);
    match Tensor::new(&csr, &normal.grams, &layout.counts) {
        Some(pre) => pcg(&csr, &normal.atb, k, &pre, None),
        None => pcg(&csr, &normal.atb, k, &Jacobi::new(&csr), None),
    }
}

/// The minimum-norm solution `A = N^T (N N^T)^{-1} P` (Park 2005, eqs. 12 to 15).
fn minimum_norm(
    rows: &SampleBases,
    offsets: &[usize],
    values: &[f64],
    total: usize,
    k: usize,
    degrees: &[usize],
) -> Result<Vec<f64>, FitError> {
    let m = rows.len();
    let mut coef = Vec::with_capacity(offsets.len());
    // For each control point, the samples touching it.
    let mut touching: Vec<Vec<(usize, f64)>> = vec![Vec::new(); total];
    for s in 0..m {
        rows.products(s, degrees, &mut coef);
        for (&o, &c) in offsets.iter().zip(&coef) {
            if c != 0.0 {
                touching[rows.start[s] + o].push((s, c));
            }
        }
    }
    let mut g = DMatrix::<f64>::zeros(m, m);
    for list in &touching {
        for &(a, ca) in list {
            for &(b, cb) in list {
                g[(a, b)] += ca * cb;
            }
        }
    }
    let p = DMatrix::from_fn(m, k, |r, c| values[r * k + c]);
    let q = match g.clone().cholesky() {
        Some(ch) => ch.solve(&p),
        None => g
            .svd(true, true)
            .solve(&p, crate::tolerance::SINGULAR_REL)
            .map_err(FitError::Singular)?,
    };
    let mut out = vec![0.0; total * k];
    for (i, list) in touching.iter().enumerate() {
        for &(s, c) in list {
            for col in 0..k {
                out[i * k + col] += c * q[(s, col)];
            }
        }
    }
    Ok(out)
}

/// Hartley-Judd knots (Hartley and Judd, *Parametrization and shape of B-spline curves
/// for CAD*, 1980) of degree `p` for the points `line[0..=n]` on `[0, 1]`: interior
/// knot `t_i` grows by the length of the `p` chords before it, normalised. `None` for
/// a line of zero length.
fn hartley_judd(line: &[[f64; 3]], p: usize) -> Option<Vec<f64>> {
    let n = line.len() - 1;
    let chord: Vec<f64> = line
        .windows(2)
        .map(|w| {
            ((w[1][0] - w[0][0]).powi(2)
                + (w[1][1] - w[0][1]).powi(2)
                + (w[1][2] - w[0][2]).powi(2))
            .sqrt()
        })
        .collect(); // chord[s - 1] = |Q_s - Q_{s-1}|, s = 1..=n
    // Order k = p + 1; for i = k..=n + 1: sum of chords s = i - p ..= i - 1.
    let span = |i: usize| -> f64 { (i - p..i).map(|s| chord[s - 1]).sum() };
    let total: f64 = (p + 1..=n + 1).map(span).sum();
    if total <= 0.0 {
        return None;
    }
    let mut knots = vec![0.0; p + 1];
    let mut t = 0.0;
    for i in p + 1..=n {
        t += span(i) / total;
        knots.push(t);
    }
    knots.extend(std::iter::repeat_n(1.0, p + 1));
    Some(knots)
}

/// The Greville abscissae of a knot vector (Park 2005, eq. 25).
fn greville(knots: &[f64], p: usize, count: usize) -> Vec<f64> {
    (0..count)
        .map(|i| knots[i + 1..=i + p].iter().sum::<f64>() / p as f64)
        .collect()
}

impl Volume {
    /// Interpolates a curvilinear grid with a non-rational volume (Park 2005, sec. 3.2).
    ///
    /// The grid's directions with more than one point become the volume's directions
    /// (in VTK's order: the first index varies fastest in the grid, and is the first
    /// direction of the volume). The attributes are `x, y, z` and then every
    /// point-data array (components named `name`, or `name_0`, `name_1`, ..). The
    /// degree of direction `d` is `degrees[d]`, lowered to the grid size minus one.
    ///
    /// Returns the volume and the parameters of the grid points per direction (the
    /// volume takes the grid's values there exactly).
    pub fn interpolate_grid(
        grid: &StructuredGrid,
        degrees: &[usize],
    ) -> Result<(Self, Vec<Vec<f64>>), FitError> {
        let dirs: Vec<usize> = (0..3).filter(|&a| grid.dims[a] > 1).collect();
        let n = dirs.len();
        if n == 0 || degrees.len() != n {
            return Err(FitError::Shape {
                what: "degrees (one per grid direction with more than one point)",
                got: degrees.len(),
                need: n,
            });
        }
        let gdims: Vec<usize> = dirs.iter().map(|&a| grid.dims[a]).collect();
        let gstride = [1, grid.dims[0], grid.dims[0] * grid.dims[1]];
        let mut attributes: Vec<String> = vec!["x".into(), "y".into(), "z".into()];
        for a in &grid.arrays {
            if a.components == 1 {
                attributes.push(a.name.clone());
            } else {
                attributes.extend((0..a.components).map(|c| format!("{}_{c}", a.name)));
            }
        }
        let k = attributes.len();
        if k > MAX_COMPONENTS {
            return Err(FitError::Shape {
                what: "attributes",
                got: k,
                need: MAX_COMPONENTS,
            });
        }
        let mut knots = Vec::with_capacity(n);
        let mut kvs = Vec::with_capacity(n);
        let mut params = Vec::with_capacity(n);
        for (d, &axis) in dirs.iter().enumerate() {
            let count = gdims[d];
            if degrees[d] == 0 || degrees[d] > MAX_DEGREE {
                return Err(FitError::CountDegree {
                    direction: d,
                    count,
                    degree: degrees[d],
                    max: MAX_DEGREE,
                });
            }
            let p = degrees[d].min(count - 1);
            // Hartley-Judd knots of every grid line along this axis, averaged (eq. 24).
            let mut sum = vec![0.0; count + p + 1];
            let mut used = 0usize;
            let others: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
            for i in 0..grid.dims[others[0]] {
                for j in 0..grid.dims[others[1]] {
                    let base = i * gstride[others[0]] + j * gstride[others[1]];
                    let line: Vec<[f64; 3]> = (0..count)
                        .map(|t| grid.points[base + t * gstride[axis]])
                        .collect();
                    if let Some(kn) = hartley_judd(&line, p) {
                        used += 1;
                        for (s, v) in sum.iter_mut().zip(kn) {
                            *s += v;
                        }
                    }
                }
            }
            let kd: Vec<f64> = if used == 0 {
                KnotVector::uniform_clamped(p, count)
                    .map_err(|reason| {
                        FitError::Volume(VolumeError::Knots {
                            direction: d,
                            reason,
                        })
                    })?
                    .knots()
                    .to_vec()
            } else {
                sum.iter().map(|s| s / used as f64).collect()
            };
            let kv = KnotVector::new(p, kd.clone()).map_err(|reason| {
                FitError::Volume(VolumeError::Knots {
                    direction: d,
                    reason,
                })
            })?;
            params.push(greville(&kd, p, count));
            kvs.push(kv);
            knots.push(kd);
        }
        // Grid values in volume order: the first direction slowest (row-major).
        let mut vstride = vec![1; n];
        for d in (0..n - 1).rev() {
            vstride[d] = vstride[d + 1] * gdims[d + 1];
        }
        let total: usize = gdims.iter().product();
        let mut net = vec![0.0; total * k];
        for flat in 0..total {
            let mut g = 0;
            let mut rest = flat;
            for d in (0..n).rev() {
                g += (rest % gdims[d]) * gstride[dirs[d]];
                rest /= gdims[d];
            }
            let row = &mut net[flat * k..(flat + 1) * k];
            row[..3].copy_from_slice(&grid.points[g]);
            let mut c = 3;
            for a in &grid.arrays {
                row[c..c + a.components]
                    .copy_from_slice(&a.values[g * a.components..(g + 1) * a.components]);
                c += a.components;
            }
        }
        // Solve one direction at a time (eqs. 16 to 27): every line along d.
        for d in 0..n {
            let count = gdims[d];
            let colloc = DMatrix::from_fn(count, count, |r, c| {
                let row = kvs[d].basis_row(params[d][r]);
                row[c]
            });
            let lu = colloc.lu();
            let inner = vstride[d];
            let outer = total / (count * inner);
            for o in 0..outer {
                for r in 0..inner {
                    let at = |i: usize| ((o * count + i) * inner + r) * k;
                    let rhs = DMatrix::from_fn(count, k, |i, c| net[at(i) + c]);
                    let x = lu
                        .solve(&rhs)
                        .ok_or(FitError::Singular("collocation matrix"))?;
                    for i in 0..count {
                        for c in 0..k {
                            net[at(i) + c] = x[(i, c)];
                        }
                    }
                }
            }
        }
        let degrees: Vec<usize> = kvs.iter().map(KnotVector::degree).collect();
        let vol = Volume::new(degrees, knots, attributes, net, None)?;
        Ok((vol, params))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hartley_judd_knots_of_even_points_are_uniform() {
        let line: Vec<[f64; 3]> = (0..7).map(|i| [i as f64, 0.0, 0.0]).collect();
        let k = hartley_judd(&line, 3).unwrap();
        assert_eq!(k.len(), 7 + 3 + 1);
        crate::assert_near!(
            k[4..7].to_vec(),
            vec![0.25, 0.5, 0.75],
            crate::tolerance::ROUNDING_EPS
        );
        assert!(hartley_judd(&[[1.0, 2.0, 3.0]; 5], 2).is_none());
    }
}
