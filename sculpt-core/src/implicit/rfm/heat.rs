//! Steady heat conduction `lambda lap T = 0` on an implicit plane domain with film
//! (Robin) conditions on its boundary pieces, by the R-function method (Shin, Kim and
//! Sheen 2007, sec. 3.2).
//!
//! **Domain.** Piece `k` is a model whose inside is the domain's side of that boundary;
//! `omega_k >= 0` there (the paper's convention, sec. 2.1.2), and the domain is their
//! R-function conjunction `omega = omega_1 AND ... AND omega_n` (sec. 2.2.2; `R_0` by
//! default, which keeps the pieces' normalisation away from corners).
//!
//! **Boundary condition.** On piece `k`, `-lambda dT/dn = alpha_k (T - T_k)` with `n`
//! the outward normal (eq. 6 with `alpha / lambda = 100 / 7` in the paper's ring). On
//! the boundary of a normalised omega (eq. 1) the inward normal is `grad omega`, so the
//! condition reads `dT/d(grad omega) = (alpha / lambda)(T - T_env)`.
//!
//! **Solution structure** (eqs. 4, 5, 7 and 8). The generalised Taylor expansion about
//! the boundary, `T = T0* + T1 omega + omega^2 Phi_2`, with `T0 = Phi_1` unknown and
//! normalised by eq. 5, `T0* = Phi_1 - omega grad omega . grad Phi_1`, and `T1` the
//! normal derivative the condition prescribes, `T1 = (alpha / lambda)(Phi_1 - T_env)`:
//!
//! `T = Phi_1 - omega grad omega . grad Phi_1 + omega (h Phi_1 - q) + omega^2 Phi_2`,
//!
//! where `h = alpha / lambda` and `q = alpha T_env / lambda` are carried into the
//! domain by transfinite interpolation of the pieces' values with the weights of eq. 9
//! (`W_k = omega_k^-1 / sum_j omega_j^-1`), so on piece `k` they are exactly
//! `alpha_k / lambda` and `alpha_k T_k / lambda`. Every `T` of this form meets the film
//! conditions (to the normalisation of omega); the paper writes `T1` with the outward
//! derivative of eq. 6, which flips its sign against `grad omega`. `Phi_1` and
//! `Phi_2` are B-spline sums (sec. 3.2.2.3), so `T = g + sum_i c_i psi_i` with
//! `psi = chi - omega grad omega . grad chi + omega h chi` for the `c_1` and
//! `psi = omega^2 chi` for the `c_2` unknowns, and `g = -omega q`.
//!
//! **Ritz method** (eqs. 11 and 12, sec. 3.2.3). `T` minimises
//! `I = int lambda |grad T|^2 dA + int alpha (T - T_env)^2 ds` (whose Euler-Lagrange
//! equations are `lambda lap T = 0` and the film condition), so the coefficients solve
//! the symmetric positive definite system
//! `sum_j (int lambda grad psi_i . grad psi_j dA + int alpha psi_i psi_j ds) c_j =
//!  -int lambda grad psi_i . grad g dA + int alpha (T_env - g) psi_i ds`,
//! integrated by the domain-adapted [`quadrature`] and solved by
//! Cholesky factorisation.

use nalgebra::{DMatrix, DVector};

use crate::implicit::expr::{Graph, NodeId};
use crate::implicit::material::{import_graph, interpolate};
use crate::implicit::rfunc::RSystem;
use crate::implicit::tape::Grid;
use crate::implicit::{Convention, Model, Tape};
use crate::tolerance::{RFM_DROP_REL, RFM_SINGULAR_REL};

use super::RfmError;
use super::basis::{LocalBasis, TensorBasis};
use super::jet::{Jet2, JetProgram};
use super::quadrature::{self, Quadrature, WeightedPoint};

/// The most boundary pieces a problem may have.
pub const MAX_PIECES: usize = 64;
/// The most quadrature refinement levels of cut cells.
pub const MAX_DEPTH: u32 = 8;
/// Half sides of the squares about the origin searched for the domain, largest first,
/// when no bounds are given.
pub const SEARCH_HALF_SIDES: [f64; 7] = [1000.0, 100.0, 10.0, 1.0, 0.1, 0.01, 0.001];
/// Samples per axis of each search grid.
pub const BOX_SAMPLES: usize = 128;

/// One boundary piece: a model whose inside is the domain's side, and its film
/// condition.
#[derive(Debug, Clone)]
pub struct Piece {
    /// The model (its inside, in its own convention, is the domain's side).
    pub model: Model,
    /// Ambient temperature `T_k` (K).
    pub ambient: f64,
    /// Film coefficient `alpha_k` (W/m^2K).
    pub film: f64,
}

/// The numerical settings of a problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeatSettings {
    /// Conductivity `lambda` (W/mK).
    pub conductivity: f64,
    /// B-spline degree (3: bicubic).
    pub degree: usize,
    /// Functions per direction (10 x 10 in the paper).
    pub count: [usize; 2],
    /// The conjunction that joins the pieces.
    pub system: RSystem,
    /// Refinement levels of the cells the boundary cuts.
    pub depth: u32,
    /// The box the basis covers, `[xlo, ylo, xhi, yhi]`; found from the domain when
    /// `None`.
    pub bounds: Option<[f64; 4]>,
}

impl Default for HeatSettings {
    fn default() -> Self {
        Self {
            conductivity: 1.0,
            degree: 3,
            count: [10, 10],
            system: RSystem::default(),
            depth: 3,
            bounds: None,
        }
    }
}

/// Counts describing a solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeatCounts {
    /// Unknowns `c_1, c_2` (twice the basis size).
    pub unknowns: usize,
    /// Unknowns whose basis function meets the domain (the rest are 0).
    pub active: usize,
    /// Area quadrature points.
    pub interior_points: usize,
    /// Boundary quadrature points.
    pub boundary_points: usize,
}

/// A solved problem: evaluates the temperature anywhere in the domain.
#[derive(Debug, Clone)]
pub struct HeatSolution {
    basis: TensorBasis,
    /// Roots: omega, h, q.
    fields: JetProgram,
    /// The domain's tape (omega >= 0 inside), f32.
    tape: Tape,
    coeffs: Vec<f64>,
    pieces: Vec<(f64, f64)>,
    counts: HeatCounts,
    boundary_means: Vec<f64>,
    range: (f64, f64),
}

/// The problem's fields as jet programs and the domain's tape.
struct Fields {
    fields: JetProgram,
    omega: JetProgram,
    pieces: JetProgram,
    tape: Tape,
}

fn build_fields(settings: &HeatSettings, pieces: &[Piece]) -> Result<Fields, RfmError> {
    let mut g = Graph::new();
    let omegas: Vec<NodeId> = pieces
        .iter()
        .map(|p| {
            let mut m = p.model.clone();
            let r = m.root_in(Convention::PositiveInside);
            import_graph(&mut g, &m.graph, r)
        })
        .collect();
    let omega = omegas[1..]
        .iter()
        .fold(omegas[0], |acc, &w| settings.system.and(&mut g, acc, w));
    let lambda = settings.conductivity;
    let h_sites: Vec<_> = omegas
        .iter()
        .zip(pieces)
        .map(|(&w, p)| (w, 1.0, p.film / lambda))
        .collect();
    let q_sites: Vec<_> = omegas
        .iter()
        .zip(pieces)
        .map(|(&w, p)| (w, 1.0, p.film * p.ambient / lambda))
        .collect();
    let h = interpolate(&mut g, &h_sites);
    let q = interpolate(&mut g, &q_sites);
    Ok(Fields {
        fields: JetProgram::new(&g, &[omega, h, q]),
        omega: JetProgram::new(&g, &[omega]),
        pieces: JetProgram::new(&g, &omegas),
        tape: Tape::compile(&g, omega),
    })
}

fn check(settings: &HeatSettings, pieces: &[Piece]) -> Result<(), RfmError> {
    let lambda = settings.conductivity;
    if !(lambda.is_finite() && lambda > 0.0) {
        return Err(RfmError::Conductivity { value: lambda });
    }
    if pieces.is_empty() || pieces.len() > MAX_PIECES {
        return Err(RfmError::Pieces {
            count: pieces.len(),
        });
    }
    for (i, p) in pieces.iter().enumerate() {
        if !(p.ambient.is_finite() && p.ambient > 0.0) {
            return Err(RfmError::Ambient {
                piece: i,
                value: p.ambient,
            });
        }
        if !(p.film.is_finite() && p.film >= 0.0) {
            return Err(RfmError::Film {
                piece: i,
                value: p.film,
            });
        }
    }
    if pieces.iter().all(|p| p.film == 0.0) {
        return Err(RfmError::Insulated);
    }
    if settings.depth > MAX_DEPTH {
        return Err(RfmError::Depth {
            depth: settings.depth,
        });
    }
    Ok(())
}

/// A box around the domain, by sampling: grids of [`BOX_SAMPLES`]^2 points on squares
/// of half side 1000, 100, ... 0.001 about the origin until one has a point inside;
/// then the box of the inside points, grown by a grid step, is sampled again, twice,
/// and the last box of inside points grown by a step is returned. (Interval arithmetic
/// over large boxes is too loose on R-function compositions to bound the domain.)
fn domain_box(tape: &Tape) -> Result<[f64; 4], RfmError> {
    let inside_box = |b: [f64; 4]| -> Option<[f64; 4]> {
        let n = BOX_SAMPLES;
        let grid = Grid::new([n, n, 1], [b[0], b[1], -0.5], [b[2], b[3], 0.5]).ok()?;
        let values = tape.eval_grid(&grid);
        let (sx, sy) = ((b[2] - b[0]) / n as f64, (b[3] - b[1]) / n as f64);
        let mut found: Option<[f64; 4]> = None;
        for (k, v) in values.iter().enumerate() {
            if *v > 0.0 {
                let (x, y) = (grid.centre(0, k % n), grid.centre(1, k / n));
                let f = found.get_or_insert([x, y, x, y]);
                *f = [f[0].min(x), f[1].min(y), f[2].max(x), f[3].max(y)];
            }
        }
        found.map(|f| [f[0] - sx, f[1] - sy, f[2] + sx, f[3] + sy])
    };
    let mut b = SEARCH_HALF_SIDES
        .iter()
        .find_map(|&s| inside_box([-s, -s, s, s]))
        .ok_or(RfmError::NoInterior)?;
    for _ in 0..2 {
        b = inside_box(b).ok_or(RfmError::NoInterior)?;
    }
    Ok(b)
}

/// Solves the problem (see the module docs).
pub fn solve(settings: &HeatSettings, pieces: &[Piece]) -> Result<HeatSolution, RfmError> {
    check(settings, pieces)?;
    let f = build_fields(settings, pieces)?;
    let b = match settings.bounds {
        Some(b) => b,
        None => domain_box(&f.tape)?,
    };
    let basis = TensorBasis::new(settings.degree, settings.count, [b[0], b[1]], [b[2], b[3]])?;
    let mut scratch = Vec::new();
    let mut one = [Jet2::default()];
    let mut omega = |p: [f64; 2]| {
        f.omega.eval(p, &mut scratch, &mut one);
        one[0]
    };
    let quad = quadrature::build(
        &f.tape,
        &mut omega,
        &basis.breaks(0),
        &basis.breaks(1),
        settings.depth,
    );
    if quad.interior.is_empty() {
        return Err(RfmError::NoInterior);
    }
    let piece_of = assign_pieces(&f.pieces, &quad.boundary);
    let params: Vec<(f64, f64)> = pieces.iter().map(|p| (p.film, p.ambient)).collect();
    let (a, rhs) = assemble(
        settings.conductivity,
        &basis,
        &f.fields,
        &quad,
        &piece_of,
        &params,
    );
    let (coeffs, active) = solve_spd(a, rhs)?;
    let mut sol = HeatSolution {
        basis,
        fields: f.fields,
        tape: f.tape,
        coeffs,
        pieces: params,
        counts: HeatCounts {
            unknowns: 0,
            active,
            interior_points: quad.interior.len(),
            boundary_points: quad.boundary.len(),
        },
        boundary_means: Vec::new(),
        range: (f64::INFINITY, f64::NEG_INFINITY),
    };
    sol.counts.unknowns = 2 * sol.basis.len();
    sol.summarise(&quad, &piece_of);
    Ok(sol)
}

/// Which piece each boundary point lies on: the one whose omega is nearest zero.
fn assign_pieces(pieces: &JetProgram, boundary: &[WeightedPoint]) -> Vec<usize> {
    let mut scratch = Vec::new();
    let mut out = vec![Jet2::default(); pieces.roots()];
    boundary
        .iter()
        .map(|b| {
            pieces.eval(b.p, &mut scratch, &mut out);
            (0..out.len())
                .min_by(|&i, &j| out[i].v.abs().total_cmp(&out[j].v.abs()))
                .unwrap_or(0)
        })
        .collect()
}

/// The structure's functions at a point: the gradients (or values) of `psi` for the
/// local basis, first the `c_1` then the `c_2` unknowns, and `g`.
struct Local {
    index: Vec<usize>,
    value: Vec<f64>,
    grad: Vec<[f64; 2]>,
    g: f64,
    grad_g: [f64; 2],
}

impl Local {
    fn new() -> Self {
        Self {
            index: Vec::new(),
            value: Vec::new(),
            grad: Vec::new(),
            g: 0.0,
            grad_g: [0.0; 2],
        }
    }

    /// Fills the structure's functions from the jets of omega, h, q and the basis.
    fn fill(&mut self, n: usize, w: Jet2, h: Jet2, q: Jet2, loc: &LocalBasis) {
        self.index.clear();
        self.value.clear();
        self.grad.clear();
        let gw = w.grad();
        let wh = w * h;
        for (&i, c) in loc.index.iter().zip(&loc.jet) {
            // s = grad omega . grad chi and its gradient H_omega grad chi + H_chi grad omega.
            let s = gw[0] * c.dx + gw[1] * c.dy;
            let ds = [
                w.dxx * c.dx + w.dxy * c.dy + c.dxx * gw[0] + c.dxy * gw[1],
                w.dxy * c.dx + w.dyy * c.dy + c.dxy * gw[0] + c.dyy * gw[1],
            ];
            self.index.push(i);
            self.value.push(c.v - w.v * s + wh.v * c.v);
            self.grad.push([
                c.dx - s * gw[0] - w.v * ds[0] + wh.dx * c.v + wh.v * c.dx,
                c.dy - s * gw[1] - w.v * ds[1] + wh.dy * c.v + wh.v * c.dy,
            ]);
        }
        for (&i, c) in loc.index.iter().zip(&loc.jet) {
            self.index.push(n + i);
            self.value.push(w.v * w.v * c.v);
            self.grad.push([
                2.0 * w.v * c.v * gw[0] + w.v * w.v * c.dx,
                2.0 * w.v * c.v * gw[1] + w.v * w.v * c.dy,
            ]);
        }
        let g = -(w * q);
        self.g = g.v;
        self.grad_g = g.grad();
    }
}

fn assemble(
    lambda: f64,
    basis: &TensorBasis,
    fields: &JetProgram,
    quad: &Quadrature,
    piece_of: &[usize],
    pieces: &[(f64, f64)],
) -> (DMatrix<f64>, DVector<f64>) {
    let n = basis.len();
    let mut a = DMatrix::<f64>::zeros(2 * n, 2 * n);
    let mut rhs = DVector::<f64>::zeros(2 * n);
    let mut scratch = Vec::new();
    let mut jets = [Jet2::default(); 3];
    let mut loc = LocalBasis::default();
    let mut l = Local::new();
    // Points come cell by cell, and the points of one knot-span cell share their basis
    // functions: their products are summed in a dense local block (contiguous rows,
    // gradients split by component) that is added to `a` when the cell changes.
    let mut block: Vec<f64> = Vec::new();
    let mut block_index: Vec<usize> = Vec::new();
    let (mut gx, mut gy) = (Vec::new(), Vec::new());
    let flush = |a: &mut DMatrix<f64>, block: &mut Vec<f64>, index: &[usize]| {
        let m = index.len();
        for (x, &i) in index.iter().enumerate() {
            for (y, &j) in index[..=x].iter().enumerate() {
                a[(i.max(j), i.min(j))] += block[x * m + y];
            }
        }
        block.iter_mut().for_each(|v| *v = 0.0);
    };
    for wp in &quad.interior {
        fields.eval(wp.p, &mut scratch, &mut jets);
        basis.eval(wp.p, &mut loc);
        l.fill(n, jets[0], jets[1], jets[2], &loc);
        if block_index != l.index {
            if !block_index.is_empty() {
                flush(&mut a, &mut block, &block_index);
            }
            block_index.clone_from(&l.index);
            block.resize(l.index.len() * l.index.len(), 0.0);
        }
        let m = l.index.len();
        gx.clear();
        gy.clear();
        gx.extend(l.grad.iter().map(|g| g[0]));
        gy.extend(l.grad.iter().map(|g| g[1]));
        let k = lambda * wp.w;
        for x in 0..m {
            let (kx, ky) = (k * gx[x], k * gy[x]);
            rhs[l.index[x]] -= kx * l.grad_g[0] + ky * l.grad_g[1];
            let row = &mut block[x * m..x * m + x + 1];
            for ((r, &u), &v) in row.iter_mut().zip(&gx).zip(&gy) {
                *r += kx * u + ky * v;
            }
        }
    }
    if !block_index.is_empty() {
        flush(&mut a, &mut block, &block_index);
    }
    for (wp, &piece) in quad.boundary.iter().zip(piece_of) {
        let (alpha, ambient) = pieces[piece];
        fields.eval(wp.p, &mut scratch, &mut jets);
        basis.eval(wp.p, &mut loc);
        l.fill(n, jets[0], jets[1], jets[2], &loc);
        let k = alpha * wp.w;
        for (x, (&i, vi)) in l.index.iter().zip(&l.value).enumerate() {
            rhs[i] += k * (ambient - l.g) * vi;
            for (&j, vj) in l.index[..=x].iter().zip(&l.value) {
                a[(i.max(j), i.min(j))] += k * vi * vj;
            }
        }
    }
    (a, rhs)
}

/// Solves `A c = b` for the symmetric `A` (lower triangle filled) by Cholesky, leaving
/// out the unknowns whose diagonal is negligible (their functions barely meet the
/// domain) and scaling the rest to a unit diagonal. Returns the coefficients and the
/// number of unknowns kept.
fn solve_spd(a: DMatrix<f64>, rhs: DVector<f64>) -> Result<(Vec<f64>, usize), RfmError> {
    let n = rhs.len();
    let max = (0..n).map(|i| a[(i, i)]).fold(0.0f64, f64::max);
    if !(max > 0.0 && max.is_finite()) {
        return Err(RfmError::Singular);
    }
    let keep: Vec<usize> = (0..n).filter(|&i| a[(i, i)] > RFM_DROP_REL * max).collect();
    let m = keep.len();
    let scale: Vec<f64> = keep.iter().map(|&i| 1.0 / a[(i, i)].sqrt()).collect();
    let reduced = DMatrix::from_fn(m, m, |r, c| {
        let (i, j) = (keep[r], keep[c]);
        a[(i.max(j), i.min(j))] * scale[r] * scale[c]
    });
    let b = DVector::from_fn(m, |r, _| rhs[keep[r]] * scale[r]);
    let chol = nalgebra::Cholesky::new(reduced).ok_or(RfmError::Singular)?;
    let l = chol.l_dirty();
    let (lo, hi) = (0..m).fold((f64::INFINITY, 0.0f64), |(lo, hi), i| {
        let d = l[(i, i)] * l[(i, i)];
        (lo.min(d), hi.max(d))
    });
    if lo.is_nan() || lo <= RFM_SINGULAR_REL * hi {
        return Err(RfmError::Singular);
    }
    let y = chol.solve(&b);
    if y.iter().any(|v| !v.is_finite()) {
        return Err(RfmError::Singular);
    }
    let mut c = vec![0.0; n];
    for (r, &i) in keep.iter().enumerate() {
        c[i] = y[r] * scale[r];
    }
    Ok((c, m))
}

impl HeatSolution {
    /// The temperature at `p` (meaningful where [`Self::omega`] >= 0).
    pub fn temperature(&self, p: [f64; 2]) -> f64 {
        let mut scratch = Vec::new();
        let mut loc = LocalBasis::default();
        let mut l = Local::new();
        self.temperature_with(p, &mut scratch, &mut loc, &mut l)
    }

    fn temperature_with(
        &self,
        p: [f64; 2],
        scratch: &mut Vec<Jet2>,
        loc: &mut LocalBasis,
        l: &mut Local,
    ) -> f64 {
        let mut jets = [Jet2::default(); 3];
        self.fields.eval(p, scratch, &mut jets);
        self.basis.eval(p, loc);
        l.fill(self.basis.len(), jets[0], jets[1], jets[2], loc);
        l.g + l
            .index
            .iter()
            .zip(&l.value)
            .map(|(&i, v)| self.coeffs[i] * v)
            .sum::<f64>()
    }

    /// The temperature at many points.
    pub fn temperatures(&self, points: &[[f64; 2]]) -> Vec<f64> {
        let mut scratch = Vec::new();
        let mut loc = LocalBasis::default();
        let mut l = Local::new();
        points
            .iter()
            .map(|&p| self.temperature_with(p, &mut scratch, &mut loc, &mut l))
            .collect()
    }

    /// The domain function omega at `p` (>= 0 in the domain), f64.
    pub fn omega(&self, p: [f64; 2]) -> f64 {
        let mut scratch = Vec::new();
        let mut jets = [Jet2::default(); 3];
        self.fields.eval(p, &mut scratch, &mut jets);
        jets[0].v
    }

    /// The domain's tape (omega >= 0 inside, f32).
    pub fn tape(&self) -> &Tape {
        &self.tape
    }

    /// The basis.
    pub fn basis(&self) -> &TensorBasis {
        &self.basis
    }

    /// Counts of unknowns and quadrature points.
    pub fn counts(&self) -> HeatCounts {
        self.counts
    }

    /// The mean temperature over each boundary piece (`int T ds / int ds` on the
    /// points of the boundary rule nearest that piece); NaN for a piece with no
    /// boundary in the domain.
    pub fn boundary_means(&self) -> &[f64] {
        &self.boundary_means
    }

    /// The smallest and largest temperature at the quadrature points.
    pub fn range(&self) -> (f64, f64) {
        self.range
    }

    /// The film parameters `(alpha, T_env)` per piece.
    pub fn pieces(&self) -> &[(f64, f64)] {
        &self.pieces
    }

    fn summarise(&mut self, quad: &Quadrature, piece_of: &[usize]) {
        let pts: Vec<[f64; 2]> = quad
            .interior
            .iter()
            .chain(&quad.boundary)
            .map(|w| w.p)
            .collect();
        let t = self.temperatures(&pts);
        self.range = t
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        let tb = &t[quad.interior.len()..];
        let mut sums = vec![(0.0, 0.0); self.pieces.len()];
        for ((w, &k), &v) in quad.boundary.iter().zip(piece_of).zip(tb) {
            sums[k].0 += w.w * v;
            sums[k].1 += w.w;
        }
        self.boundary_means = sums
            .iter()
            .map(|&(s, l)| if l > 0.0 { s / l } else { f64::NAN })
            .collect();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::RFM_RING_PROBE_K;

    const INNER: f64 = 0.5;
    const OUTER: f64 = 1.0;
    const LAMBDA: f64 = 7.0;
    const ALPHA: f64 = 100.0;
    const T_IN: f64 = 1073.0;
    const T_OUT: f64 = 1573.0;

    fn ring() -> Vec<Piece> {
        let circle = |r: f64| format!(r#"{{"circle": {{"center": [0, 0], "radius": {r}}}}}"#);
        let outer = Model::from_solid_json(&format!(r#"{{"solid": {}}}"#, circle(OUTER))).unwrap();
        let inner = Model::from_solid_json(&format!(
            r#"{{"solid": {{"not": {{"solid": {}}}}}}}"#,
            circle(INNER)
        ))
        .unwrap();
        vec![
            Piece {
                model: outer,
                ambient: T_OUT,
                film: ALPHA,
            },
            Piece {
                model: inner,
                ambient: T_IN,
                film: ALPHA,
            },
        ]
    }

    /// `T = C + D ln r` with `C`, `D` from the two film conditions
    /// (outer: `-lambda D / b = alpha (C + D ln b - T_out)`,
    ///  inner, outward normal `-r`: `lambda D / a = alpha (C + D ln a - T_in)`), by Cramer's rule.
    fn exact(r: f64) -> f64 {
        let (a, b) = (INNER, OUTER);
        let m = [
            [ALPHA, ALPHA * b.ln() + LAMBDA / b],
            [ALPHA, ALPHA * a.ln() - LAMBDA / a],
        ];
        let rhs = [ALPHA * T_OUT, ALPHA * T_IN];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let c = (rhs[0] * m[1][1] - m[0][1] * rhs[1]) / det;
        let d = (m[0][0] * rhs[1] - rhs[0] * m[1][0]) / det;
        c + d * r.ln()
    }

    fn probe_error(count: usize) -> f64 {
        let settings = HeatSettings {
            conductivity: LAMBDA,
            count: [count, count],
            ..Default::default()
        };
        let sol = solve(&settings, &ring()).unwrap();
        let mut worst = 0.0f64;
        for k in 0..24 {
            let t = f64::from(k) * 0.61;
            for r in [0.5, 0.55, 0.62, 0.75, 0.87, 0.95, 1.0] {
                let got = sol.temperature([r * t.cos(), r * t.sin()]);
                worst = worst.max((got - exact(r)).abs());
            }
        }
        worst
    }

    /// The paper's ring (sec. 3.2.1) against its exact solution.
    #[test]
    fn ring_matches_the_exact_solution_and_converges() {
        let e6 = probe_error(6);
        let e10 = probe_error(10);
        let e16 = probe_error(16);
        eprintln!("ring probe errors: 6x6 {e6} K, 10x10 {e10} K, 16x16 {e16} K");
        assert!(e10 <= RFM_RING_PROBE_K, "10 x 10: {e10} K");
        assert!(e16 < e10 && e10 < e6, "errors {e6} {e10} {e16}");
    }

    /// The boundary means of the ring equal the exact temperature on each circle.
    #[test]
    fn ring_boundary_means() {
        let settings = HeatSettings {
            conductivity: LAMBDA,
            ..Default::default()
        };
        let sol = solve(&settings, &ring()).unwrap();
        let m = sol.boundary_means();
        assert!((m[0] - exact(OUTER)).abs() <= RFM_RING_PROBE_K, "{m:?}");
        assert!((m[1] - exact(INNER)).abs() <= RFM_RING_PROBE_K, "{m:?}");
        let (lo, hi) = sol.range();
        assert!(lo >= exact(INNER) - RFM_RING_PROBE_K && hi <= exact(OUTER) + RFM_RING_PROBE_K);
    }

    #[test]
    fn bad_problems_are_refused() {
        let settings = HeatSettings {
            conductivity: LAMBDA,
            ..Default::default()
        };
        // Two disjoint discs: their conjunction is empty.
        let disc = |cx: f64| {
            Model::from_solid_json(&format!(
                r#"{{"solid": {{"circle": {{"center": [{cx}, 0], "radius": 0.5}}}}}}"#
            ))
            .unwrap()
        };
        let pieces = vec![
            Piece {
                model: disc(-2.0),
                ambient: 300.0,
                film: 10.0,
            },
            Piece {
                model: disc(2.0),
                ambient: 300.0,
                film: 10.0,
            },
        ];
        assert_eq!(solve(&settings, &pieces).unwrap_err(), RfmError::NoInterior);
        let mut insulated = ring();
        for p in &mut insulated {
            p.film = 0.0;
        }
        assert_eq!(
            solve(&settings, &insulated).unwrap_err(),
            RfmError::Insulated
        );
        let bad = HeatSettings {
            conductivity: 0.0,
            ..settings
        };
        assert!(matches!(
            solve(&bad, &ring()),
            Err(RfmError::Conductivity { .. })
        ));
    }

    /// The paper's heating pipe (sec. 3.2): inner fins raise the outer surface's mean
    /// temperature (the shipped specs' geometry and films, tests/data/rfm).
    #[test]
    fn fins_raise_the_outer_surface_temperature() {
        let outer = include_str!("../../../../tests/data/rfm/pipe-outer.json");
        let inners = [
            include_str!("../../../../tests/data/rfm/pipe-inner-0.json"),
            include_str!("../../../../tests/data/rfm/pipe-inner-4.json"),
            include_str!("../../../../tests/data/rfm/pipe-inner-8.json"),
        ];
        let settings = HeatSettings {
            conductivity: 400.0,
            depth: 5,
            ..Default::default()
        };
        let means: Vec<f64> = inners
            .iter()
            .map(|inner| {
                let pieces = [
                    Piece {
                        model: Model::from_text(outer).unwrap(),
                        ambient: 293.15,
                        film: 30.0,
                    },
                    Piece {
                        model: Model::from_text(inner).unwrap(),
                        ambient: 353.15,
                        film: 150.0,
                    },
                ];
                solve(&settings, &pieces).unwrap().boundary_means()[0]
            })
            .collect();
        eprintln!(
            "outer surface mean temperature (K): no fins {}, 4 fins {}, 8 fins {}",
            means[0], means[1], means[2]
        );
        assert!(means[0] < means[1] && means[1] < means[2], "{means:?}");
        // Without fins the wall is nearly isothermal (Biot number ~ 1e-3): the lumped
        // balance per unit length, 2 pi (r_i h_i (T_w - T) + r_o h_o (T_a - T)) = 0.
        let lumped = (0.05 * 150.0 * 353.15 + 0.06 * 30.0 * 293.15) / (0.05 * 150.0 + 0.06 * 30.0);
        assert!((means[0] - lumped).abs() < 0.1, "{} vs {lumped}", means[0]);
    }

    /// A singular system is refused (a rank-1 matrix, and one with no energy at all),
    /// and a regular one is solved.
    #[test]
    fn singular_systems_are_refused() {
        let rank1 = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        let b = DVector::from_row_slice(&[1.0, 2.0]);
        assert_eq!(solve_spd(rank1, b.clone()).unwrap_err(), RfmError::Singular);
        assert_eq!(
            solve_spd(DMatrix::zeros(2, 2), b.clone()).unwrap_err(),
            RfmError::Singular
        );
        let (c, active) =
            solve_spd(DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 1.0, 2.0]), b).unwrap();
        assert_eq!(active, 2);
        // [[2, 1], [1, 2]] c = [1, 2]: c = [0, 1].
        crate::assert_near!(
            c.as_slice(),
            [0.0, 1.0].as_slice(),
            crate::tolerance::EXACT_EPS
        );
    }
}
