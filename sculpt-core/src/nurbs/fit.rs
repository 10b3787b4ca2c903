//! Fitting surfaces to data (P&T chapter 9; Park, "VNURBS-based representation of multidimensional heterogeneous volumetric objects", 2005, section 3.1).
//!
//! - [`NurbsSurface::interpolate_grid`]: global interpolation of a grid of points
//!   (P&T A9.4), chord-length parameters averaged over rows and columns (eq. 9.5 and
//!   the surface rule of section 9.2.5), knots by averaging (eq. 9.8).
//! - [`NurbsSurface::approximate_grid`]: least-squares approximation of a grid with a
//!   smaller control net (A9.7 style, the tensor-product least-squares solution applied
//!   per direction; knots by P&T eq. 9.69).
//! - [`NurbsSurface::approximate_scattered`]: scattered points with given parameters and
//!   uniform knots (Park 2005, sec. 3.1): least squares (normal equations, eq. 11)
//!   when there are more points than control points, the minimum-norm pseudo-inverse
//!   solution (eqs. 12 to 15) when there are fewer.
//!
//! The linear algebra is nalgebra's (Cholesky, LU, SVD for rank-deficient systems).

use glam::{DVec2, DVec3};
use nalgebra::DMatrix;

use super::knots::KnotVector;
use super::surface::NurbsSurface;
use crate::error::{Error, FitError, Result};

fn check_grid(points: &[Vec<DVec3>]) -> Result<(usize, usize)> {
    let n_u = points.len();
    let n_v = points.first().map_or(0, Vec::len);
    if n_u == 0 || n_v == 0 {
        return Err(Error::FitFailed(FitError::EmptyGrid));
    }
    if let Some(i) = points.iter().position(|r| r.len() != n_v) {
        return Err(Error::FitFailed(FitError::RaggedGrid {
            row: i,
            got: points[i].len(),
            need: n_v,
        }));
    }
    if points.iter().flatten().any(|p| !p.is_finite()) {
        return Err(Error::FitFailed(FitError::NotFinite {
            what: "grid points",
        }));
    }
    Ok((n_u, n_v))
}

/// Chord-length parameters of the polylines `lines`, averaged over all of them
/// (P&T section 9.2.5); lines of zero length are skipped, and uniform parameters are
/// used if all are degenerate.
fn averaged_chord_params(lines: &[Vec<DVec3>]) -> Vec<f64> {
    let n = lines[0].len();
    let mut acc = vec![0.0; n];
    let mut used = 0;
    for line in lines {
        let total: f64 = line.windows(2).map(|w| w[0].distance(w[1])).sum();
        if total <= 0.0 {
            continue;
        }
        used += 1;
        let mut s = 0.0;
        for k in 1..n {
            s += line[k].distance(line[k - 1]);
            acc[k] += s / total;
        }
    }
    if used == 0 {
        return (0..n).map(|k| k as f64 / (n - 1).max(1) as f64).collect();
    }
    let mut t: Vec<f64> = acc.iter().map(|a| a / used as f64).collect();
    t[0] = 0.0;
    t[n - 1] = 1.0;
    t
}

/// Knots by averaging (P&T eq. 9.8) for interpolation at parameters `t`.
fn averaged_knots(t: &[f64], p: usize) -> Vec<f64> {
    let n = t.len() - 1;
    let mut k = vec![0.0; p + 1];
    for j in 1..=n - p {
        k.push(t[j..j + p].iter().sum::<f64>() / p as f64);
    }
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// Knots for least squares with `count` control points at parameters `t` (P&T
/// eq. 9.69: every knot span holds at least one parameter).
fn approximation_knots(t: &[f64], p: usize, count: usize) -> Vec<f64> {
    let m = t.len() - 1;
    let n = count - 1;
    let d = (m + 1) as f64 / (n - p + 1) as f64;
    let mut k = vec![0.0; p + 1];
    for j in 1..=n - p {
        let i = (j as f64 * d).floor() as usize;
        let alpha = j as f64 * d - i as f64;
        let i = i.min(m);
        k.push((1.0 - alpha) * t[i - 1] + alpha * t[i]);
    }
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// The collocation matrix `N[k][i] = N_{i,p}(t_k)`.
fn collocation(kv: &KnotVector, t: &[f64]) -> DMatrix<f64> {
    let n = kv.count();
    let mut m = DMatrix::zeros(t.len(), n);
    for (r, &tk) in t.iter().enumerate() {
        for (c, v) in kv.basis_row(tk).into_iter().enumerate() {
            m[(r, c)] = v;
        }
    }
    m
}

/// Solves `a x = b` for three right-hand sides (x, y, z): exactly when square, by
/// least squares (normal equations) when tall, by the minimum-norm solution when wide.
/// Rank-deficient systems fall back to the SVD pseudo-inverse.
fn solve(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let (m, n) = a.shape();
    let direct = if m == n {
        a.clone().lu().solve(b)
    } else if m > n {
        // Seed paper eq. 11: (N^T N) A = N^T P.
        a.tr_mul(a).cholesky().map(|c| c.solve(&a.tr_mul(b)))
    } else {
        // Seed paper eqs. 12 to 15: Q = (N N^T)^{-1} P, A = N^T Q.
        (a * a.transpose())
            .cholesky()
            .map(|c| a.tr_mul(&c.solve(b)))
    };
    let x = match direct {
        Some(x) if x.iter().all(|v| v.is_finite()) => x,
        _ => a
            .clone()
            .svd(true, true)
            .solve(b, crate::tolerance::SINGULAR_REL)
            .map_err(|e| Error::FitFailed(FitError::Singular(e)))?,
    };
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(Error::FitFailed(FitError::NonFiniteSolution))
    }
}

fn to_matrix(points: &[DVec3]) -> DMatrix<f64> {
    DMatrix::from_fn(points.len(), 3, |r, c| points[r][c])
}

/// Fits every row of `grid` (rows of equal length) with the same collocation matrix.
fn fit_rows(grid: &[Vec<DVec3>], a: &DMatrix<f64>) -> Result<Vec<Vec<DVec3>>> {
    grid.iter()
        .map(|row| {
            let x = solve(a, &to_matrix(row))?;
            Ok((0..x.nrows())
                .map(|r| DVec3::new(x[(r, 0)], x[(r, 1)], x[(r, 2)]))
                .collect())
        })
        .collect()
}

fn transpose(grid: &[Vec<DVec3>]) -> Vec<Vec<DVec3>> {
    (0..grid[0].len())
        .map(|j| grid.iter().map(|row| row[j]).collect())
        .collect()
}

/// Fits the tensor-product system in two passes: along `u` (each column of the grid),
/// then along `v` (each row of the intermediate net).
fn tensor_fit(
    points: &[Vec<DVec3>],
    ku: &KnotVector,
    kv: &KnotVector,
    tu: &[f64],
    tv: &[f64],
) -> Result<Vec<Vec<DVec3>>> {
    let cols = transpose(points); // cols[j][k] = Q_{k,j}
    let r = fit_rows(&cols, &collocation(ku, tu))?; // r[j][i] = R_{i,j}
    fit_rows(&transpose(&r), &collocation(kv, tv)) // [i][j]
}

impl NurbsSurface {
    /// Interpolates a grid `points[k][l]` (`k` along `u`) with a non-rational surface
    /// of degrees `(degree_u, degree_v)` (P&T A9.4). The surface passes through every
    /// point, at the parameters returned alongside it (`(t_u, t_v)`).
    pub fn interpolate_grid(
        points: &[Vec<DVec3>],
        degree_u: usize,
        degree_v: usize,
    ) -> Result<(Self, Vec<f64>, Vec<f64>)> {
        let (n_u, n_v) = check_grid(points)?;
        if n_u <= degree_u || n_v <= degree_v {
            return Err(Error::FitFailed(FitError::GridTooSmall {
                n_u,
                n_v,
                degree_u,
                degree_v,
            }));
        }
        let tu = averaged_chord_params(&transpose(points));
        let tv = averaged_chord_params(points);
        let ku = KnotVector::new(degree_u, averaged_knots(&tu, degree_u))?;
        let kv = KnotVector::new(degree_v, averaged_knots(&tv, degree_v))?;
        let net = tensor_fit(points, &ku, &kv, &tu, &tv)?;
        let s = NurbsSurface::new(
            degree_u,
            degree_v,
            ku.knots().to_vec(),
            kv.knots().to_vec(),
            net,
            None,
        )?;
        Ok((s, tu, tv))
    }

    /// Least-squares approximation of a grid `points[k][l]` with a `count_u x count_v`
    /// control net (A9.7 style). Parameters by averaged chord length, knots by P&T
    /// eq. 9.69. Needs `degree < count <= grid size` in each direction.
    pub fn approximate_grid(
        points: &[Vec<DVec3>],
        count_u: usize,
        count_v: usize,
        degree_u: usize,
        degree_v: usize,
    ) -> Result<Self> {
        let (n_u, n_v) = check_grid(points)?;
        if count_u <= degree_u || count_v <= degree_v || count_u > n_u || count_v > n_v {
            return Err(Error::FitFailed(FitError::NetSize {
                n_u,
                n_v,
                count_u,
                count_v,
                degree_u,
                degree_v,
            }));
        }
        let tu = averaged_chord_params(&transpose(points));
        let tv = averaged_chord_params(points);
        let ku = KnotVector::new(degree_u, approximation_knots(&tu, degree_u, count_u))?;
        let kv = KnotVector::new(degree_v, approximation_knots(&tv, degree_v, count_v))?;
        let net = tensor_fit(points, &ku, &kv, &tu, &tv)?;
        NurbsSurface::new(
            degree_u,
            degree_v,
            ku.knots().to_vec(),
            kv.knots().to_vec(),
            net,
            None,
        )
    }

    /// Approximates scattered `points` given their parameters `params` (in `[0,1]^2`)
    /// with a `count_u x count_v` non-rational surface on uniform clamped knots (seed
    /// paper 000, sec. 3.1): least squares when there are more points than control
    /// points, the minimum-norm (pseudo-inverse) solution when there are fewer.
    pub fn approximate_scattered(
        points: &[DVec3],
        params: &[DVec2],
        count_u: usize,
        count_v: usize,
        degree_u: usize,
        degree_v: usize,
    ) -> Result<Self> {
        if points.is_empty() || points.len() != params.len() {
            return Err(Error::FitFailed(FitError::ParamCount {
                points: points.len(),
                params: params.len(),
            }));
        }
        if points.iter().any(|p| !p.is_finite()) || params.iter().any(|t| !t.is_finite()) {
            return Err(Error::FitFailed(FitError::NotFinite {
                what: "points and parameters",
            }));
        }
        let ku = KnotVector::uniform_clamped(degree_u, count_u)?;
        let kv = KnotVector::uniform_clamped(degree_v, count_v)?;
        let n = count_u * count_v;
        let mut a = DMatrix::zeros(points.len(), n);
        for (r, t) in params.iter().enumerate() {
            let bu = ku.basis_row(t.x);
            let bv = kv.basis_row(t.y);
            for (i, &nu) in bu.iter().enumerate().filter(|(_, x)| **x != 0.0) {
                for (j, &nv) in bv.iter().enumerate().filter(|(_, x)| **x != 0.0) {
                    a[(r, i * count_v + j)] = nu * nv;
                }
            }
        }
        let x = solve(&a, &to_matrix(points))?;
        let net = (0..count_u)
            .map(|i| {
                (0..count_v)
                    .map(|j| {
                        let r = i * count_v + j;
                        DVec3::new(x[(r, 0)], x[(r, 1)], x[(r, 2)])
                    })
                    .collect()
            })
            .collect();
        NurbsSurface::new(
            degree_u,
            degree_v,
            ku.knots().to_vec(),
            kv.knots().to_vec(),
            net,
            None,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{APPROX_FIT_TOL, EXACT_EPS, FIT_EPS, POINT_EPS};

    fn grid(n_u: usize, n_v: usize) -> Vec<Vec<DVec3>> {
        (0..n_u)
            .map(|i| {
                (0..n_v)
                    .map(|j| {
                        let (x, y) = (i as f64 / (n_u - 1) as f64, j as f64 / (n_v - 1) as f64);
                        DVec3::new(x * 2.0, y, 0.3 * (3.0 * x).sin() * (2.0 * y).cos())
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn interpolation_reproduces_its_data() {
        let pts = grid(7, 5);
        let (s, tu, tv) = NurbsSurface::interpolate_grid(&pts, 3, 2).unwrap();
        for (k, row) in pts.iter().enumerate() {
            for (l, p) in row.iter().enumerate() {
                assert_near!(s.point(tu[k], tv[l]).to_array(), p.to_array(), EXACT_EPS);
            }
        }
    }

    #[test]
    fn least_squares_is_exact_for_a_surface_in_the_space() {
        // Points sampled from a bicubic surface are fitted back exactly when the knots
        // can represent it: here a plane-like bilinear surface with a 4x4 net.
        let pts: Vec<Vec<DVec3>> = (0..9)
            .map(|i| {
                (0..8)
                    .map(|j| DVec3::new(i as f64, j as f64, 0.5 * i as f64 - 0.25 * j as f64))
                    .collect()
            })
            .collect();
        let s = NurbsSurface::approximate_grid(&pts, 4, 4, 3, 3).unwrap();
        let inv = s.inverter();
        for p in pts.iter().flatten() {
            assert!(inv.closest_point(*p).distance < POINT_EPS);
        }
        // A wavy grid is approximated with a small residual.
        let pts = grid(20, 15);
        let s = NurbsSurface::approximate_grid(&pts, 8, 6, 3, 3).unwrap();
        let inv = s.inverter();
        let worst = pts
            .iter()
            .flatten()
            .map(|p| inv.closest_point(*p).distance)
            .fold(0.0, f64::max);
        assert!(worst < APPROX_FIT_TOL, "worst residual {worst}");
    }

    #[test]
    fn scattered_points_over_and_under_determined() {
        let f = |t: DVec2| DVec3::new(t.x, t.y, 0.2 * t.x * t.y + 0.1 * t.x);
        // A bilinear-in-parameters function lies in the spline space: least squares
        // with more points than unknowns reproduces it.
        let params: Vec<DVec2> = (0..60)
            .map(|k| DVec2::new((k * 7 % 60) as f64 / 59.0, (k * 13 % 60) as f64 / 59.0))
            .collect();
        let points: Vec<DVec3> = params.iter().map(|&t| f(t)).collect();
        let s = NurbsSurface::approximate_scattered(&points, &params, 4, 4, 3, 3).unwrap();
        for (t, p) in params.iter().zip(&points) {
            assert_near!(s.point_uv(*t).to_array(), p.to_array(), FIT_EPS);
        }
        // Fewer points (10) than control points (36): the minimum-norm solution
        // interpolates every point.
        let few: Vec<DVec2> = params.iter().take(10).copied().collect();
        let pts: Vec<DVec3> = few
            .iter()
            .map(|&t| f(t) + DVec3::Z * (t.x * 9.0).sin() * 0.1)
            .collect();
        let s = NurbsSurface::approximate_scattered(&pts, &few, 6, 6, 3, 3).unwrap();
        for (t, p) in few.iter().zip(&pts) {
            assert_near!(s.point_uv(*t).to_array(), p.to_array(), POINT_EPS);
        }
        assert!(NurbsSurface::approximate_scattered(&pts, &few[..3], 6, 6, 3, 3).is_err());
        assert!(
            NurbsSurface::approximate_scattered(&[DVec3::NAN], &[DVec2::ZERO], 4, 4, 3, 3).is_err()
        );
    }
}
