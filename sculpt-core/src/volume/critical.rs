//! Critical points of a velocity attribute (Park 2005, sec. 5.2, eqs. 46 to 50).
//!
//! A critical point is a zero of the velocity `V`. Where the map `B` is regular,
//! `V(B(u)) = 0` exactly where the volume's velocity attributes `V(u)` vanish, so the
//! zeros are searched in parameter space:
//!
//! 1. **Exclusion by the convex hull.** With positive weights, `V(u)` over a knot span
//!    is a convex combination of the span's `prod (p_d + 1)` control velocities
//!    (P&T sec. 4.2, property 4.3, for each component): a span where one component's
//!    control values all have the same strict sign holds no zero. The volume is first
//!    refined (P&T A5.4, direction by direction) so that every direction has at least
//!    [`MIN_SPANS`] spans and every original span is split in two at least, which
//!    tightens the hulls.
//! 2. **Newton's method** from the centre (then the eight quarter points) of every span
//!    not excluded: `J du = -V` with `J_ij = dV_i / du_j`, kept within the span widened
//!    by half its size, until `|V| <= CRITICAL_ZERO_REL` times the largest control
//!    velocity (a rank-deficient `J` takes the minimum-norm step). Zeros closer than
//!    `CRITICAL_SAME_REL` of the domain are one. Where the velocity vanishes on a
//!    curve or a surface, every candidate span contributes a point of it (all
//!    `degenerate`), up to [`MAX_CRITICAL_POINTS`].
//! 3. **Classification** from the eigenvalues of the velocity gradient tensor
//!    `dV_i / dx_j` in physical space (eqs. 46, 47, through the contravariant base
//!    vectors of eq. 32), after Chong, Perry and Cantwell, *A general classification
//!    of three-dimensional flow fields* (Phys. Fluids A 2, 1990): an eigenvalue within
//!    `CRITICAL_EIGEN_REL` of the largest modulus of zero makes the point
//!    `degenerate`; otherwise a complex pair makes it a `focus`, or a `center` when its
//!    real part is zero; three real eigenvalues of one sign make a `node`, of mixed
//!    signs a `saddle`.

use glam::DVec3;
use nalgebra::Matrix3;

use super::{Volume, VolumeError, VolumeResult, odometer_next};
use crate::tolerance::{CRITICAL_EIGEN_REL, CRITICAL_SAME_REL, CRITICAL_ZERO_REL};

/// Every direction is refined to at least this many knot spans before the hull test.
pub const MIN_SPANS: usize = 8;
/// The refined net may hold at most this many points (the hull test's work).
const MAX_REFINED_POINTS: usize = 1 << 20;
/// Newton iterations per start (double roots converge only linearly).
const NEWTON_ITERATIONS: usize = 60;
/// The most critical points reported: more means the velocity vanishes on a curve or
/// a region, which is refused rather than listed point by point.
pub const MAX_CRITICAL_POINTS: usize = 10_000;

/// The topological kind of a critical point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CriticalKind {
    /// Real eigenvalues of both signs.
    Saddle,
    /// Real eigenvalues of one sign (a source or a sink).
    Node,
    /// A complex pair with a non-zero real part (a spiral).
    Focus,
    /// A complex pair with a zero real part (closed orbits around the point).
    Center,
    /// An eigenvalue is zero: the linearisation does not decide.
    Degenerate,
}

impl CriticalKind {
    /// The name the command line prints: `saddle`, `node`, `focus`, `center`,
    /// `degenerate`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Saddle => "saddle",
            Self::Node => "node",
            Self::Focus => "focus",
            Self::Center => "center",
            Self::Degenerate => "degenerate",
        }
    }

    /// Classifies eigenvalues `(re, im)` (module docs).
    pub fn classify(eigenvalues: &[[f64; 2]; 3]) -> Self {
        let scale = eigenvalues
            .iter()
            .map(|e| e[0].hypot(e[1]))
            .fold(0.0, f64::max);
        let zero = CRITICAL_EIGEN_REL * scale;
        if scale.is_nan() || scale <= 0.0 || eigenvalues.iter().any(|e| e[0].hypot(e[1]) <= zero) {
            return Self::Degenerate;
        }
        if let Some(pair) = eigenvalues.iter().find(|e| e[1].abs() > zero) {
            return if pair[0].abs() <= zero {
                Self::Center
            } else {
                Self::Focus
            };
        }
        let positive = eigenvalues.iter().filter(|e| e[0] > 0.0).count();
        if positive == 0 || positive == 3 {
            Self::Node
        } else {
            Self::Saddle
        }
    }
}

/// A zero of the velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalPoint {
    /// Its parameters.
    pub params: [f64; 3],
    /// Its physical position `B(u)`.
    pub point: DVec3,
    /// The velocity gradient `dV_i / dx_j` there (eqs. 46, 47).
    pub gradient: [[f64; 3]; 3],
    /// The gradient's eigenvalues as `(re, im)`, sorted by real then imaginary part.
    pub eigenvalues: [[f64; 2]; 3],
    /// The classification.
    pub kind: CriticalKind,
}

/// The eigenvalues of a real 3 x 3 matrix as `(re, im)`, sorted.
pub fn eigenvalues3(m: &[[f64; 3]; 3]) -> [[f64; 2]; 3] {
    let mat = Matrix3::from_fn(|i, j| m[i][j]);
    let ev = mat.complex_eigenvalues();
    let mut out = [
        [ev[0].re, ev[0].im],
        [ev[1].re, ev[1].im],
        [ev[2].re, ev[2].im],
    ];
    out.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    out
}

/// The minimum-norm solution of `m x = b` (SVD; singular values below 64 ulps of the
/// largest are dropped), so that a rank-deficient Jacobian still gives a step: where
/// the velocity vanishes on a curve or surface, Newton then walks straight onto it.
fn solve3(m: &[[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let mat = Matrix3::from_fn(|i, j| m[i][j]);
    let svd = mat.svd(true, true);
    let smax = svd.singular_values.max();
    if !(smax > 0.0 && smax.is_finite()) {
        return None;
    }
    let x = svd
        .solve(&nalgebra::Vector3::from(b), 64.0 * f64::EPSILON * smax)
        .ok()?;
    let x = [x[0], x[1], x[2]];
    x.iter().all(|v| v.is_finite()).then_some(x)
}

impl Volume {
    /// All zeros of the velocity attributes `velocity` (three attribute indices) in
    /// the volume, classified (module docs). The volume must be trivariate with
    /// geometry `x, y, z`.
    pub fn critical_points(&self, velocity: [usize; 3]) -> VolumeResult<Vec<CriticalPoint>> {
        self.geometry3("critical points")?;
        for &v in &velocity {
            self.check_attribute(v)?;
        }
        let refined = self.refined_for_hulls()?;
        let k = self.components();
        let dim = k + 1;
        let vscale = (0..self.point_count())
            .flat_map(|i| {
                let p = self.control_values(i);
                velocity.map(|c| p[c].abs())
            })
            .fold(0.0, f64::max);
        let domain = self.domain();
        let width: [f64; 3] = std::array::from_fn(|d| domain[d].1 - domain[d].0);
        let mut found: Vec<[f64; 3]> = Vec::new();
        let mut row = vec![0.0; 4 * k];
        // Spans of the refined volume: (knot index, start, end) per direction.
        let spans: Vec<Vec<(usize, f64, f64)>> = refined
            .knot_vectors()
            .iter()
            .map(|kv| {
                let t = kv.knots();
                (kv.degree()..kv.count())
                    .filter(|&s| t[s + 1] > t[s])
                    .map(|s| (s, t[s], t[s + 1]))
                    .collect()
            })
            .collect();
        let degrees = refined.degrees();
        let cw = refined.homogeneous();
        let mut idx = [0usize; 3];
        loop {
            let span: [(usize, f64, f64); 3] = std::array::from_fn(|d| spans[d][idx[d]]);
            // The hull test on the span's control velocities (signs of h V = signs of V).
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            let mut offs = [0usize; 3];
            loop {
                let flat: usize = (0..3)
                    .map(|d| (span[d].0 - degrees[d] + offs[d]) * refined.strides[d])
                    .sum();
                let p = &cw[flat * dim..(flat + 1) * dim];
                for (c, &a) in velocity.iter().enumerate() {
                    lo[c] = lo[c].min(p[a]);
                    hi[c] = hi[c].max(p[a]);
                }
                if !odometer_next(&mut offs, |d| degrees[d] + 1) {
                    break;
                }
            }
            if (0..3).all(|c| lo[c] <= 0.0 && hi[c] >= 0.0) {
                let bounds: [(f64, f64); 3] = std::array::from_fn(|d| {
                    let h = (span[d].2 - span[d].1) / 2.0;
                    (
                        (span[d].1 - h).max(domain[d].0),
                        (span[d].2 + h).min(domain[d].1),
                    )
                });
                let starts = std::iter::once([0.5; 3]).chain(
                    (0..8).map(|b| [0, 1, 2].map(|d| if b >> d & 1 == 1 { 0.75 } else { 0.25 })),
                );
                for f in starts {
                    let u0: [f64; 3] =
                        std::array::from_fn(|d| span[d].1 + f[d] * (span[d].2 - span[d].1));
                    if let Some(u) = self.newton_zero(u0, velocity, bounds, vscale, &mut row)? {
                        let same = found.iter().any(|z| {
                            (0..3).all(|d| (z[d] - u[d]).abs() <= CRITICAL_SAME_REL * width[d])
                        });
                        if !same {
                            if found.len() >= MAX_CRITICAL_POINTS {
                                return Err(VolumeError::TooManyCriticalPoints {
                                    max: MAX_CRITICAL_POINTS,
                                });
                            }
                            found.push(u);
                        }
                        break;
                    }
                }
            }
            if !odometer_next(&mut idx, |d| spans[d].len()) {
                break;
            }
        }
        found
            .into_iter()
            .map(|u| {
                let vd = self.vector_derivatives(&u, velocity)?;
                let frame = self.frame(&u)?;
                let eigenvalues = eigenvalues3(&vd.gradient);
                Ok(CriticalPoint {
                    params: u,
                    point: frame.point,
                    gradient: vd.gradient,
                    eigenvalues,
                    kind: CriticalKind::classify(&eigenvalues),
                })
            })
            .collect()
    }

    /// The volume refined for the hull test (module docs).
    fn refined_for_hulls(&self) -> VolumeResult<Volume> {
        let mut vol = self.clone();
        for d in 0..3 {
            let kv = self.knots(d);
            let t = kv.knots();
            let spans: Vec<(f64, f64)> = t
                .windows(2)
                .filter(|w| w[1] > w[0])
                .map(|w| (w[0], w[1]))
                .collect();
            let parts = MIN_SPANS.div_ceil(spans.len()).max(2);
            let grown = (vol.point_count() / vol.counts()[d])
                * (vol.counts()[d] + spans.len() * (parts - 1));
            if grown > MAX_REFINED_POINTS {
                continue; // fine enough already: keep this direction's spans
            }
            let mut x = Vec::with_capacity(spans.len() * (parts - 1));
            for (a, b) in spans {
                x.extend((1..parts).map(|j| a + (b - a) * j as f64 / parts as f64));
            }
            vol = vol.refine_knots(d, &x)?;
        }
        Ok(vol)
    }

    /// Newton's method for `V(u) = 0` from `u0`, within `bounds`; `None` when it
    /// leaves them or does not converge.
    fn newton_zero(
        &self,
        u0: [f64; 3],
        velocity: [usize; 3],
        bounds: [(f64, f64); 3],
        vscale: f64,
        row: &mut [f64],
    ) -> VolumeResult<Option<[f64; 3]>> {
        let k = self.components();
        let tol = CRITICAL_ZERO_REL * vscale;
        let mut u = u0;
        for _ in 0..NEWTON_ITERATIONS {
            self.eval_d1_into(&u, row)?;
            let v = velocity.map(|c| row[c]);
            if v.iter().map(|x| x.abs()).fold(0.0, f64::max) <= tol {
                return Ok(Some(u));
            }
            let jac: [[f64; 3]; 3] =
                std::array::from_fn(|i| std::array::from_fn(|d| row[(1 + d) * k + velocity[i]]));
            let Some(du) = solve3(&jac, v.map(|x| -x)) else {
                return Ok(None);
            };
            for d in 0..3 {
                u[d] += du[d];
                if !(bounds[d].0..=bounds[d].1).contains(&u[d]) {
                    return Ok(None);
                }
            }
        }
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classification_by_eigenvalues() {
        let real = |a: f64, b: f64, c: f64| [[a, 0.0], [b, 0.0], [c, 0.0]];
        assert_eq!(
            CriticalKind::classify(&real(-1.0, 1.0, 2.0)),
            CriticalKind::Saddle
        );
        assert_eq!(
            CriticalKind::classify(&real(-3.0, -1.0, -2.0)),
            CriticalKind::Node
        );
        assert_eq!(
            CriticalKind::classify(&real(1.0, 1.0, 2.0)),
            CriticalKind::Node
        );
        assert_eq!(
            CriticalKind::classify(&real(0.0, 1.0, 2.0)),
            CriticalKind::Degenerate
        );
        let pair = [[-0.5, 0.0], [-0.2, -1.0], [-0.2, 1.0]];
        assert_eq!(CriticalKind::classify(&pair), CriticalKind::Focus);
        let pair = [[-0.5, 0.0], [0.0, -1.0], [0.0, 1.0]];
        assert_eq!(CriticalKind::classify(&pair), CriticalKind::Center);
        assert_eq!(
            CriticalKind::classify(&[[0.0; 2]; 3]),
            CriticalKind::Degenerate
        );
    }

    #[test]
    fn eigenvalues_of_a_rotation_block() {
        let ev = eigenvalues3(&[[-0.2, -1.0, 0.0], [1.0, -0.2, 0.0], [0.0, 0.0, -0.5]]);
        let want = [[-0.5, 0.0], [-0.2, -1.0], [-0.2, 1.0]];
        for (a, b) in ev.iter().zip(want) {
            crate::assert_near!(a[0], b[0], crate::tolerance::CRITICAL_POSITION_EPS);
            crate::assert_near!(a[1], b[1], crate::tolerance::CRITICAL_POSITION_EPS);
        }
    }
}
