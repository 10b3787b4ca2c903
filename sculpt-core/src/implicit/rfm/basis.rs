//! The tensor-product B-spline basis `chi_ij(x, y) = N_i(u(x)) N_j(v(y))` on a box
//! around the domain (Shin, Kim and Sheen 2007, sec. 3.2.2.3: "Phi_2 = sum c_2,i chi_i",
//! bicubic with 10 x 10 control points in sec. 3.2.4).
//!
//! Clamped, uniform knots in each direction map the box to `[0, 1]^2`; values and
//! derivatives up to the second come from the kernel's Cox-de Boor routines (P&T A2.2
//! and eq. 2.7) and are returned as [`Jet2`]s in the box's coordinates.

use crate::nurbs::knots::KnotVector;

use super::RfmError;
use super::jet::Jet2;

/// The lowest degree the method accepts: the solution structure carries
/// `grad omega . grad chi`, whose gradient needs square-integrable second derivatives.
pub const MIN_DEGREE: usize = 2;
/// The highest degree (the kernel's stack arrays).
pub const MAX_DEGREE: usize = crate::nurbs::knots::MAX_DEGREE;
/// The most control points per direction.
pub const MAX_COUNT: usize = 48;

/// A tensor-product B-spline basis on the box `lo..hi`.
#[derive(Debug, Clone)]
pub struct TensorBasis {
    knots: [KnotVector; 2],
    lo: [f64; 2],
    hi: [f64; 2],
    count: [usize; 2],
    degree: usize,
}

/// The basis functions that do not vanish at a point: their global indices
/// (`i + nx j`) and jets.
#[derive(Debug, Clone, Default)]
pub struct LocalBasis {
    /// Global indices.
    pub index: Vec<usize>,
    /// Values and derivatives in x, y.
    pub jet: Vec<Jet2>,
}

impl TensorBasis {
    /// A basis of degree `degree` with `count = [nx, ny]` functions per direction on
    /// the box `lo..hi`.
    pub fn new(
        degree: usize,
        count: [usize; 2],
        lo: [f64; 2],
        hi: [f64; 2],
    ) -> Result<Self, RfmError> {
        if !(MIN_DEGREE..=MAX_DEGREE).contains(&degree) {
            return Err(RfmError::Degree { degree });
        }
        if count.iter().any(|&n| n < degree + 1 || n > MAX_COUNT) {
            return Err(RfmError::Count { count, degree });
        }
        if (0..2).any(|a| !(lo[a].is_finite() && hi[a].is_finite() && lo[a] < hi[a])) {
            return Err(RfmError::NoInterior);
        }
        let kv = |n| {
            KnotVector::uniform_clamped(degree, n).map_err(|_| RfmError::Count { count, degree })
        };
        Ok(Self {
            knots: [kv(count[0])?, kv(count[1])?],
            lo,
            hi,
            count,
            degree,
        })
    }

    /// The number of functions.
    pub fn len(&self) -> usize {
        self.count[0] * self.count[1]
    }

    /// Whether the basis is empty (never, once built).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Functions per direction.
    pub fn count(&self) -> [usize; 2] {
        self.count
    }

    /// The degree.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The box.
    pub fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        (self.lo, self.hi)
    }

    /// The knot spans' edges in display-frame coordinates, per axis: the cells on which every
    /// function is one polynomial (the quadrature's starting cells).
    pub fn breaks(&self, axis: usize) -> Vec<f64> {
        let n = self.count[axis] - self.degree;
        (0..=n)
            .map(|i| self.lo[axis] + (self.hi[axis] - self.lo[axis]) * i as f64 / n as f64)
            .collect()
    }

    /// The functions that do not vanish at `p` (in the box), with their jets.
    pub fn eval(&self, p: [f64; 2], out: &mut LocalBasis) {
        out.index.clear();
        out.jet.clear();
        let deg = self.degree;
        let mut rows = [[[0.0; crate::nurbs::knots::MAX_ORDER]; 3]; 2];
        let mut first = [0usize; 2];
        for a in 0..2 {
            let scale = 1.0 / (self.hi[a] - self.lo[a]);
            let u = self.knots[a].clamp((p[a] - self.lo[a]) * scale);
            let span = self.knots[a].find_span(u);
            let d = self.knots[a].basis_ders2(span, u);
            first[a] = span - deg;
            rows[a] = [
                d[0],
                d[1].map(|v| v * scale),
                d[2].map(|v| v * scale * scale),
            ];
        }
        let [rx, ry] = rows;
        for (j, ((y0, y1), y2)) in ry[0]
            .iter()
            .zip(&ry[1])
            .zip(&ry[2])
            .take(deg + 1)
            .enumerate()
        {
            for (i, ((x0, x1), x2)) in rx[0]
                .iter()
                .zip(&rx[1])
                .zip(&rx[2])
                .take(deg + 1)
                .enumerate()
            {
                out.index
                    .push(first[0] + i + self.count[0] * (first[1] + j));
                out.jet.push(Jet2 {
                    v: x0 * y0,
                    dx: x1 * y0,
                    dy: x0 * y1,
                    dxx: x2 * y0,
                    dxy: x1 * y1,
                    dyy: x0 * y2,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{EXACT_EPS, RFM_FD_STEP, RFM_JET_FD_REL};

    /// Partition of unity (value 1, zero derivatives) and the derivatives against
    /// central differences of the values.
    #[test]
    fn basis_is_a_partition_of_unity_with_consistent_derivatives() {
        let b = TensorBasis::new(3, [10, 7], [-1.0, 0.5], [2.0, 1.5]).unwrap();
        let mut loc = LocalBasis::default();
        let value_of = |b: &TensorBasis, p: [f64; 2], k: usize| {
            let mut l = LocalBasis::default();
            b.eval(p, &mut l);
            l.index
                .iter()
                .position(|&i| i == k)
                .map_or(0.0, |at| l.jet[at].v)
        };
        for p in [[0.13, 0.77], [-0.9, 1.4], [1.7, 0.6]] {
            b.eval(p, &mut loc);
            assert_eq!(loc.index.len(), 16);
            let s: Jet2 = loc.jet.iter().fold(Jet2::default(), |a, &j| a + j);
            assert_near!(
                [s.v, s.dx, s.dy, s.dxx, s.dxy, s.dyy],
                [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                EXACT_EPS * 1e3
            );
            let h = RFM_FD_STEP;
            for (k, j) in loc.index.iter().zip(&loc.jet) {
                let f = |dx: f64, dy: f64| value_of(&b, [p[0] + dx, p[1] + dy], *k);
                let fx = (f(h, 0.0) - f(-h, 0.0)) / (2.0 * h);
                let fyy = (f(0.0, h) - 2.0 * j.v + f(0.0, -h)) / (h * h);
                assert_near!(j.dx, fx, RFM_JET_FD_REL * (1.0 + fx.abs()) * 10.0);
                assert_near!(j.dyy, fyy, RFM_JET_FD_REL * (1.0 + fyy.abs()) * 1e3);
            }
        }
    }

    #[test]
    fn bad_bases_are_refused() {
        assert!(matches!(
            TensorBasis::new(1, [5, 5], [0.0; 2], [1.0; 2]),
            Err(RfmError::Degree { .. })
        ));
        assert!(matches!(
            TensorBasis::new(3, [3, 5], [0.0; 2], [1.0; 2]),
            Err(RfmError::Count { .. })
        ));
        assert!(TensorBasis::new(3, [4, 4], [0.0; 2], [1.0; 2]).is_ok());
    }
}
