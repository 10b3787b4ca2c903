//! Integrals over a volume by Gauss-Legendre quadrature per knot span (Park 2005,
//! sec. 4: the volume element `dV = sqrt(g) du dv dw`, eq. 35, with
//! `sqrt(g) = B_u . (B_v x B_w)`, eq. 38).
//!
//! Inside one knot span of every direction the map is smooth (a rational polynomial),
//! so an `m`-point Gauss rule per direction and span converges fast: it is exact for
//! polynomial integrands of degree `2m - 1`, and geometrically convergent for the
//! rational ones of weighted volumes.
//!
//! Where the volume carries the geometry attributes `x, y, z` (at least as many as it
//! has directions), integrals are over physical space with the measure
//! `sqrt(det(J^T J))`, `J` the Jacobian of the geometry (for a trivariate volume in
//! 3D that is `|sqrt(g)|`; for a surface in 3D the area element, eq. 34; for a curve
//! the arc element, eq. 33). Without geometry, over the parameter domain.

// Small dense matrices indexed as the formulas write them.
#![allow(clippy::needless_range_loop)]

use super::Volume;

/// The nodes on `[-1, 1]` and weights of the `m`-point Gauss-Legendre rule (Newton on
/// the Legendre polynomial from the Chebyshev-like start `cos(pi (i - 1/4) / (m + 1/2))`,
/// Press et al., *Numerical Recipes*, `gauleg`).
pub fn gauss_legendre(m: usize) -> (Vec<f64>, Vec<f64>) {
    let m = m.max(1);
    let mut x = vec![0.0; m];
    let mut w = vec![0.0; m];
    for i in 0..m.div_ceil(2) {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (m as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_m(z) by the three-term recurrence, and its derivative.
            let (mut p0, mut p1) = (1.0, 0.0);
            for j in 0..m {
                let p2 = p1;
                p1 = p0;
                p0 = ((2 * j + 1) as f64 * z * p1 - j as f64 * p2) / (j + 1) as f64;
            }
            dp = m as f64 * (z * p0 - p1) / (z * z - 1.0);
            let step = p0 / dp;
            z -= step;
            if step.abs() <= crate::tolerance::ULP_EPS {
                break;
            }
        }
        x[i] = -z;
        x[m - 1 - i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        w[m - 1 - i] = w[i];
    }
    (x, w)
}

/// The `m`-point Gauss-Legendre rule on every non-empty knot span of `kv`, as
/// `(parameter, weight)` pairs in increasing order.
pub fn span_rule(kv: &crate::nurbs::KnotVector, m: usize) -> Vec<(f64, f64)> {
    let (gx, gw) = gauss_legendre(m);
    let mut pts = Vec::new();
    for s in kv.knots().windows(2).filter(|s| s[1] > s[0]) {
        let (mid, half) = (0.5 * (s[0] + s[1]), 0.5 * (s[1] - s[0]));
        pts.extend(gx.iter().zip(&gw).map(|(x, w)| (mid + half * x, half * w)));
    }
    pts
}

/// The result of [`Volume::integrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Integrals {
    /// The measure of the volume: its physical volume (area, length) with geometry,
    /// the parameter domain's measure without.
    pub measure: f64,
    /// The integral of every attribute over the same measure, in attribute order.
    pub integrals: Vec<f64>,
    /// True when the measure is physical (the volume has geometry).
    pub physical: bool,
}

/// `sqrt(det(G))` of the `n x n` Gram matrix `G` by Gaussian elimination with partial
/// pivoting (`n <= 4`).
fn sqrt_det(mut g: [[f64; 4]; 4], n: usize) -> f64 {
    let mut det = 1.0;
    for c in 0..n {
        let piv = (c..n)
            .max_by(|&a, &b| g[a][c].abs().total_cmp(&g[b][c].abs()))
            .unwrap_or(c);
        if g[piv][c] == 0.0 {
            return 0.0;
        }
        if piv != c {
            g.swap(piv, c);
            det = -det;
        }
        det *= g[c][c];
        for r in c + 1..n {
            let f = g[r][c] / g[c][c];
            for k in c..n {
                g[r][k] -= f * g[c][k];
            }
        }
    }
    det.abs().sqrt()
}

impl Volume {
    /// The volume element at the given derivative row (`k` values then `n x k` first
    /// derivatives, the layout of [`Volume::eval_d1_into`]): `|det J|` when the
    /// geometry has exactly `n` components, `sqrt(det(J^T J))` when it has more, 1
    /// without geometry.
    pub(crate) fn measure_element(&self, row: &[f64], geometry: &[usize]) -> f64 {
        let n = self.directions();
        let k = self.components();
        if geometry.len() < n {
            return 1.0;
        }
        let col = |d: usize, g: usize| row[(1 + d) * k + geometry[g]];
        if geometry.len() == 3 && n == 3 {
            // sqrt(g) = B_u . (B_v x B_w) (Park 2005, eq. 38).
            let b = |d: usize| glam::DVec3::new(col(d, 0), col(d, 1), col(d, 2));
            return b(0).dot(b(1).cross(b(2))).abs();
        }
        let mut gram = [[0.0; 4]; 4];
        for a in 0..n {
            for b in 0..n {
                gram[a][b] = (0..geometry.len()).map(|g| col(a, g) * col(b, g)).sum();
            }
        }
        sqrt_det(gram, n)
    }

    /// The measure of the volume and the integral of every attribute, by an
    /// `m`-point Gauss-Legendre rule in every direction of every knot span (see the
    /// module docs for which measure).
    pub fn integrate(&self, m: usize) -> Integrals {
        let n = self.directions();
        let k = self.components();
        let geometry = self.geometry();
        let rules: Vec<Vec<(f64, f64)>> = self
            .knot_vectors()
            .iter()
            .map(|kv| span_rule(kv, m))
            .collect();
        let mut row = vec![0.0; k * (n + 1)];
        let mut u = vec![0.0; n];
        let mut idx = vec![0usize; n];
        let mut measure = 0.0;
        let mut integrals = vec![0.0; k];
        loop {
            let mut w = 1.0;
            for d in 0..n {
                let (t, wt) = rules[d][idx[d]];
                u[d] = t;
                w *= wt;
            }
            // The parameters come from the knots, so they are valid.
            if self.eval_d1_into(&u, &mut row).is_ok() {
                let dv = w * self.measure_element(&row, &geometry);
                measure += dv;
                for (acc, v) in integrals.iter_mut().zip(&row[..k]) {
                    *acc += v * dv;
                }
            }
            if !super::odometer_next(&mut idx, |d| rules[d].len()) {
                break;
            }
        }
        Integrals {
            measure,
            integrals,
            physical: geometry.len() >= n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::ROUNDING_EPS;

    #[test]
    fn gauss_rules_integrate_polynomials_of_degree_2m_minus_1_exactly() {
        for m in 1..=12 {
            let (x, w) = gauss_legendre(m);
            for deg in 0..2 * m {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let want = if deg % 2 == 1 {
                    0.0
                } else {
                    2.0 / (deg + 1) as f64
                };
                assert_near!(got, want, ROUNDING_EPS, "m {m} degree {deg}");
            }
            // One degree more is not integrated exactly (x^{2m} is even, positive).
            let got: f64 = x
                .iter()
                .zip(&w)
                .map(|(x, w)| w * x.powi(2 * m as i32))
                .sum();
            assert!(
                (got - 2.0 / (2 * m + 1) as f64).abs() > ROUNDING_EPS,
                "m {m}"
            );
        }
    }
}
