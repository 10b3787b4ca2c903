//! Rational B-spline (NURBS) curves (P&T chapters 3 and 4).

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

use glam::{DVec3, DVec4};
use serde::{Deserialize, Serialize};

use super::knots::KnotVector;
use crate::error::{ControlNetError, Error, NetIndex, Result, WeightError};

/// A NURBS curve `C(u) = sum N_{i,p}(u) w_i P_i / sum N_{i,p}(u) w_i`.
///
/// Control points are stored in homogeneous form `P^w_i = (w_i P_i, w_i)` (P&T eq. 4.2),
/// so evaluation is a B-spline evaluation in four dimensions followed by one division.
/// Weights are finite and positive (checked), so the convex-hull property holds.
///
/// JSON (serde): `{"degree": 3, "knots": [...], "control_points": [[x,y,z], ...],
/// "weights": [w, ...]}` with `weights` optional (default 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CurveJson", into = "CurveJson")]
pub struct NurbsCurve {
    knots: KnotVector,
    pw: Vec<DVec4>,
    rational: bool,
}

/// A curve point with its first and second derivatives with respect to `u`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveDerivs {
    /// `C(u)`.
    pub point: DVec3,
    /// `C'(u)`.
    pub d1: DVec3,
    /// `C''(u)`.
    pub d2: DVec3,
}

/// The serde form of [`NurbsCurve`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CurveJson {
    degree: usize,
    knots: Vec<f64>,
    control_points: Vec<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    weights: Option<Vec<f64>>,
}

impl TryFrom<CurveJson> for NurbsCurve {
    type Error = Error;
    fn try_from(j: CurveJson) -> Result<Self> {
        let pts = j.control_points.into_iter().map(DVec3::from).collect();
        NurbsCurve::new(j.degree, j.knots, pts, j.weights)
    }
}

impl From<NurbsCurve> for CurveJson {
    fn from(c: NurbsCurve) -> Self {
        CurveJson {
            degree: c.degree(),
            knots: c.knots.knots().to_vec(),
            control_points: c
                .control_points()
                .into_iter()
                .map(|p| p.to_array())
                .collect(),
            weights: c.rational.then(|| c.weights()),
        }
    }
}

pub(crate) fn check_weight(w: f64, at: NetIndex) -> Result<()> {
    if w.is_finite() && w > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidWeights(WeightError::NotPositive {
            at,
            weight: w,
        }))
    }
}

pub(crate) fn check_point(p: DVec3, at: NetIndex) -> Result<()> {
    if p.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidControlNet(ControlNetError::NotFinite {
            at,
            point: p,
        }))
    }
}

impl NurbsCurve {
    /// Builds a curve from Cartesian control points and optional weights (default 1).
    pub fn new(
        degree: usize,
        knots: Vec<f64>,
        control_points: Vec<DVec3>,
        weights: Option<Vec<f64>>,
    ) -> Result<Self> {
        let knots = KnotVector::new(degree, knots)?;
        if control_points.len() != knots.count() {
            return Err(Error::InvalidControlNet(ControlNetError::CurveCount {
                got: control_points.len(),
                knots: knots.knots().len(),
                degree,
                need: knots.count(),
            }));
        }
        if let Some(w) = &weights
            && w.len() != control_points.len()
        {
            return Err(Error::InvalidWeights(WeightError::Count {
                got: w.len(),
                need: control_points.len(),
            }));
        }
        let mut pw = Vec::with_capacity(control_points.len());
        for (i, p) in control_points.iter().enumerate() {
            check_point(*p, NetIndex::Curve(i))?;
            let w = weights.as_ref().map_or(1.0, |w| w[i]);
            check_weight(w, NetIndex::Curve(i))?;
            pw.push((*p * w).extend(w));
        }
        let rational = weights.is_some_and(|w| w.iter().any(|&x| x != 1.0));
        Ok(Self {
            knots,
            pw,
            rational,
        })
    }

    /// Builds a curve from a validated knot vector and homogeneous points `(w P, w)`.
    pub fn from_homogeneous(knots: KnotVector, pw: Vec<DVec4>) -> Result<Self> {
        if pw.len() != knots.count() {
            return Err(Error::InvalidControlNet(
                ControlNetError::HomogeneousCount {
                    got: pw.len(),
                    need: knots.count(),
                },
            ));
        }
        for (i, q) in pw.iter().enumerate() {
            check_weight(q.w, NetIndex::Curve(i))?;
            check_point(q.truncate() / q.w, NetIndex::Curve(i))?;
        }
        let rational = pw.iter().any(|q| q.w != 1.0);
        Ok(Self {
            knots,
            pw,
            rational,
        })
    }

    /// Reads the JSON schema above: text that is not JSON or not the schema is
    /// [`Error::Json`] (with its line and column); a curve the schema allows but that
    /// is invalid is the error saying which entry is wrong.
    pub fn from_json(text: &str) -> Result<Self> {
        let json: CurveJson = serde_json::from_str(text).map_err(|e| Error::Json(e.into()))?;
        Self::try_from(json)
    }

    /// Writes the JSON schema above.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// The degree `p`.
    pub fn degree(&self) -> usize {
        self.knots.degree()
    }

    /// The knot vector.
    pub fn knots(&self) -> &KnotVector {
        &self.knots
    }

    /// The parameter domain.
    pub fn domain(&self) -> (f64, f64) {
        self.knots.domain()
    }

    /// True when some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }

    /// The homogeneous control points `(w P, w)`.
    pub fn homogeneous(&self) -> &[DVec4] {
        &self.pw
    }

    /// The Cartesian control points.
    pub fn control_points(&self) -> Vec<DVec3> {
        self.pw.iter().map(|q| q.truncate() / q.w).collect()
    }

    /// The weights.
    pub fn weights(&self) -> Vec<f64> {
        self.pw.iter().map(|q| q.w).collect()
    }

    /// `C(u)` (P&T A4.1); `u` is clamped into the domain.
    #[inline]
    pub fn point(&self, u: f64) -> DVec3 {
        let u = self.knots.clamp(u);
        let p = self.degree();
        let s = self.knots.find_span(u);
        let n = self.knots.basis(s, u);
        let mut cw = DVec4::ZERO;
        for (j, nj) in n.iter().enumerate().take(p + 1) {
            cw += self.pw[s - p + j] * *nj;
        }
        cw.truncate() / cw.w
    }

    /// `C`, `C'` and `C''` at `u` (P&T A3.2 on the homogeneous points, then A4.2).
    #[inline]
    pub fn derivatives(&self, u: f64) -> CurveDerivs {
        let u = self.knots.clamp(u);
        let p = self.degree();
        let s = self.knots.find_span(u);
        let nd = self.knots.basis_ders2(s, u);
        let mut a = [DVec4::ZERO; 3];
        for (k, ak) in a.iter_mut().enumerate() {
            for j in 0..=p {
                *ak += self.pw[s - p + j] * nd[k][j];
            }
        }
        let w = a[0].w;
        let c = a[0].truncate() / w;
        let d1 = (a[1].truncate() - a[1].w * c) / w;
        let d2 = (a[2].truncate() - 2.0 * a[1].w * d1 - a[2].w * c) / w;
        CurveDerivs { point: c, d1, d2 }
    }

    /// The unit tangent at `u` (zero where `C'` vanishes).
    pub fn tangent(&self, u: f64) -> DVec3 {
        self.derivatives(u).d1.normalize_or_zero()
    }

    /// Replaces the knot vector and control points (used by refinement).
    pub(crate) fn from_parts(knots: KnotVector, pw: Vec<DVec4>) -> Self {
        let rational = pw.iter().any(|q| q.w != 1.0);
        Self {
            knots,
            pw,
            rational,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{FD_D1_EPS, FD_EPS, FD_STEP, ROUNDING_EPS, ULP_EPS};

    /// The rational quadratic quarter circle (P&T Ex4.1 style).
    fn quarter_circle() -> NurbsCurve {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        NurbsCurve::new(
            2,
            vec![0., 0., 0., 1., 1., 1.],
            vec![DVec3::X, DVec3::new(1., 1., 0.), DVec3::Y],
            Some(vec![1., h, 1.]),
        )
        .unwrap()
    }

    #[test]
    fn quarter_circle_is_exact() {
        let c = quarter_circle();
        for i in 0..=50 {
            let u = i as f64 / 50.0;
            assert_near!(c.point(u).length(), 1.0, ULP_EPS);
            let d = c.derivatives(u);
            // Tangent is perpendicular to the radius.
            assert_near!(d.point.dot(d.d1), 0.0, ROUNDING_EPS);
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let c = quarter_circle();
        let h = FD_STEP;
        for &u in &[0.1, 0.37, 0.5, 0.9] {
            let d = c.derivatives(u);
            let fd1 = (c.point(u + h) - c.point(u - h)) / (2.0 * h);
            let fd2 = (c.derivatives(u + h).d1 - c.derivatives(u - h).d1) / (2.0 * h);
            assert_near!(d.d1.to_array(), fd1.to_array(), FD_D1_EPS);
            assert_near!(d.d2.to_array(), fd2.to_array(), FD_EPS);
        }
    }

    #[test]
    fn json_round_trip_and_errors() {
        let c = quarter_circle();
        let back = NurbsCurve::from_json(&c.to_json()).unwrap();
        assert_eq!(c, back);
        assert!(matches!(
            NurbsCurve::from_json(r#"{"degree":1,"knots":[0,0,1,1],"control_points":[[0,0,0]]}"#),
            Err(Error::InvalidControlNet(ControlNetError::CurveCount {
                got: 1,
                need: 2,
                ..
            }))
        ));
        assert!(matches!(
            NurbsCurve::from_json(r#"{"degree":1,"knots":[0,0,1,1]"#),
            Err(Error::Json(_))
        ));
        assert!(matches!(
            NurbsCurve::new(
                1,
                vec![0., 0., 1., 1.],
                vec![DVec3::ZERO, DVec3::X],
                Some(vec![1., 0.])
            ),
            Err(Error::InvalidWeights(WeightError::NotPositive {
                at: NetIndex::Curve(1),
                ..
            }))
        ));
    }
}
