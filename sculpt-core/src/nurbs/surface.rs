//! Rational tensor-product (NURBS) surfaces (P&T chapters 3 and 4).

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

use glam::{DVec2, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use super::curve::{check_point, check_weight};
use super::direction::Direction;
use super::knots::KnotVector;
use crate::error::{ControlNetError, Error, NetIndex, Result, WeightError};

/// A NURBS surface `S(u,v) = sum_i sum_j N_{i,p}(u) N_{j,q}(v) w_ij P_ij / sum sum N N w`.
///
/// - `control_points[i][j]`: `i` runs along `u` (`count_u()` rows), `j` along `v`.
/// - Stored as homogeneous points `(w P, w)` in one flat row-major vector, index
///   `i * count_v + j`, so evaluation touches `(p+1)(q+1)` contiguous-ish points and
///   never allocates.
/// - Weights are finite and positive (checked), so every sub-patch lies in the convex
///   hull of its control points; point inversion relies on that.
/// - Parameters outside the domain are clamped to it.
///
/// JSON (serde) follows the schema in the module docs of [`crate::nurbs`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SurfaceJson", into = "SurfaceJson")]
pub struct NurbsSurface {
    knots_u: KnotVector,
    knots_v: KnotVector,
    n_v: usize,
    pw: Vec<DVec4>,
    rational: bool,
}

/// A surface point with all partial derivatives up to second order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceDerivs {
    /// `S(u, v)`.
    pub point: DVec3,
    /// `S_u`.
    pub du: DVec3,
    /// `S_v`.
    pub dv: DVec3,
    /// `S_uu`.
    pub duu: DVec3,
    /// `S_uv`.
    pub duv: DVec3,
    /// `S_vv`.
    pub dvv: DVec3,
}

impl SurfaceDerivs {
    /// The unit normal `S_u x S_v / |S_u x S_v|`, or zero where it is undefined.
    pub fn normal(&self) -> DVec3 {
        self.du.cross(self.dv).normalize_or_zero()
    }
}

/// First (`E, F, G`) and second (`L, M, N`) fundamental forms at a point, with the
/// curvatures they give (do Carmo 3.3; P&T section 2 of ch. 4 uses the same symbols).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FundamentalForms {
    /// `E = S_u . S_u`.
    pub e: f64,
    /// `F = S_u . S_v`.
    pub f: f64,
    /// `G = S_v . S_v`.
    pub g: f64,
    /// `L = S_uu . n`.
    pub l: f64,
    /// `M = S_uv . n`.
    pub m: f64,
    /// `N = S_vv . n`.
    pub n: f64,
    /// The unit normal `n` the second form was taken against.
    pub normal: DVec3,
}

impl FundamentalForms {
    /// Gaussian curvature `K = (LN - M^2) / (EG - F^2)` (0 where the first form is
    /// singular).
    pub fn gaussian_curvature(&self) -> f64 {
        let den = self.e * self.g - self.f * self.f;
        if den > 0.0 {
            (self.l * self.n - self.m * self.m) / den
        } else {
            0.0
        }
    }

    /// Mean curvature `H = (EN - 2FM + GL) / (2(EG - F^2))` (sign follows the normal).
    pub fn mean_curvature(&self) -> f64 {
        let den = self.e * self.g - self.f * self.f;
        if den > 0.0 {
            (self.e * self.n - 2.0 * self.f * self.m + self.g * self.l) / (2.0 * den)
        } else {
            0.0
        }
    }

    /// Principal curvatures `(k1, k2)`, `k1 >= k2`.
    pub fn principal_curvatures(&self) -> (f64, f64) {
        let h = self.mean_curvature();
        let k = self.gaussian_curvature();
        let d = (h * h - k).max(0.0).sqrt();
        (h + d, h - d)
    }
}

/// The serde form of [`NurbsSurface`]: the schema tools and tests rely on.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SurfaceJson {
    degree_u: usize,
    degree_v: usize,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    control_points: Vec<Vec<[f64; 3]>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    weights: Option<Vec<Vec<f64>>>,
}

/// The most control points a surface read from JSON (a surface file, or a document's
/// target) may have: a 256 x 256 net. Beyond it the reader refuses the surface, so a
/// hostile file cannot make `project` or the tessellator take gigabytes (a 10^6-point
/// net took 1 GB).
pub const MAX_JSON_CONTROL_POINTS: usize = 65_536;
/// The largest control point coordinate (metres, absolute) a surface read from JSON
/// may have: squared distances of larger ones overflow in the point inversion
/// (coordinates near 1e308 gave `inf`), and a sculpted object is never 1000 km wide.
pub const MAX_JSON_COORDINATE_M: f64 = 1e6;
/// Weights of a surface read from JSON lie in `[1 / MAX_JSON_WEIGHT, MAX_JSON_WEIGHT]`:
/// weights of 1e150 made `project` return `inf`.
pub const MAX_JSON_WEIGHT: f64 = 1e6;

impl SurfaceJson {
    /// The reader's caps (see [`MAX_JSON_CONTROL_POINTS`], [`MAX_JSON_COORDINATE_M`],
    /// [`MAX_JSON_WEIGHT`]), checked before the surface is built.
    fn check_caps(&self) -> Result<()> {
        let count: usize = self.control_points.iter().map(Vec::len).sum();
        if count > MAX_JSON_CONTROL_POINTS {
            return Err(Error::InvalidControlNet(ControlNetError::TooMany {
                count,
                max: MAX_JSON_CONTROL_POINTS,
            }));
        }
        for (i, row) in self.control_points.iter().enumerate() {
            for (j, p) in row.iter().enumerate() {
                if p.iter().any(|c| c.abs() > MAX_JSON_COORDINATE_M) {
                    return Err(Error::InvalidControlNet(ControlNetError::TooFar {
                        at: NetIndex::Surface(i, j),
                        point: DVec3::from_array(*p),
                        max_m: MAX_JSON_COORDINATE_M,
                    }));
                }
            }
        }
        for (i, row) in self.weights.iter().flatten().enumerate() {
            for (j, &w) in row.iter().enumerate() {
                // Non-positive and non-finite weights get their own error below.
                if w.is_finite()
                    && w > 0.0
                    && !(1.0 / MAX_JSON_WEIGHT..=MAX_JSON_WEIGHT).contains(&w)
                {
                    return Err(Error::InvalidWeights(WeightError::OutOfRange {
                        at: NetIndex::Surface(i, j),
                        weight: w,
                        max: MAX_JSON_WEIGHT,
                    }));
                }
            }
        }
        Ok(())
    }
}

impl TryFrom<SurfaceJson> for NurbsSurface {
    type Error = Error;
    fn try_from(j: SurfaceJson) -> Result<Self> {
        j.check_caps()?;
        let pts = j
            .control_points
            .into_iter()
            .map(|row| row.into_iter().map(DVec3::from).collect())
            .collect();
        NurbsSurface::new(j.degree_u, j.degree_v, j.knots_u, j.knots_v, pts, j.weights)
    }
}

impl From<NurbsSurface> for SurfaceJson {
    fn from(s: NurbsSurface) -> Self {
        SurfaceJson {
            degree_u: s.degree_u(),
            degree_v: s.degree_v(),
            knots_u: s.knots_u.knots().to_vec(),
            knots_v: s.knots_v.knots().to_vec(),
            control_points: s
                .control_points()
                .into_iter()
                .map(|row| row.into_iter().map(|p| p.to_array()).collect())
                .collect(),
            weights: s.rational.then(|| s.weights()),
        }
    }
}

/// A knot vector error of a surface, naming its direction.
fn in_direction(e: Error, d: Direction) -> Error {
    match e {
        Error::InvalidKnots { reason, .. } => Error::InvalidKnots {
            direction: Some(d),
            reason,
        },
        Error::InvalidDegree { degree, .. } => Error::InvalidDegree {
            direction: Some(d),
            degree,
        },
        e => e,
    }
}

impl NurbsSurface {
    /// Builds a surface from Cartesian control points `control_points[i][j]` (`i` along
    /// `u`) and optional weights of the same shape (default 1).
    pub fn new(
        degree_u: usize,
        degree_v: usize,
        knots_u: Vec<f64>,
        knots_v: Vec<f64>,
        control_points: Vec<Vec<DVec3>>,
        weights: Option<Vec<Vec<f64>>>,
    ) -> Result<Self> {
        let knots_u =
            KnotVector::new(degree_u, knots_u).map_err(|e| in_direction(e, Direction::U))?;
        let knots_v =
            KnotVector::new(degree_v, knots_v).map_err(|e| in_direction(e, Direction::V))?;
        let (n_u, n_v) = (knots_u.count(), knots_v.count());
        if control_points.len() != n_u {
            return Err(Error::InvalidControlNet(ControlNetError::RowCount {
                got: control_points.len(),
                degree: degree_u,
                need: n_u,
            }));
        }
        if let Some(i) = control_points.iter().position(|r| r.len() != n_v) {
            return Err(Error::InvalidControlNet(ControlNetError::RowLength {
                row: i,
                got: control_points[i].len(),
                degree: degree_v,
                need: n_v,
            }));
        }
        if let Some(w) = &weights {
            if w.len() != n_u {
                return Err(Error::InvalidWeights(WeightError::RowCount {
                    got: w.len(),
                    need: n_u,
                }));
            }
            if let Some(i) = w.iter().position(|r| r.len() != n_v) {
                return Err(Error::InvalidWeights(WeightError::RowLength {
                    row: i,
                    got: w[i].len(),
                    need: n_v,
                }));
            }
        }
        let mut pw = Vec::with_capacity(n_u * n_v);
        for (i, row) in control_points.iter().enumerate() {
            for (j, p) in row.iter().enumerate() {
                check_point(*p, NetIndex::Surface(i, j))?;
                let w = weights.as_ref().map_or(1.0, |w| w[i][j]);
                check_weight(w, NetIndex::Surface(i, j))?;
                pw.push((*p * w).extend(w));
            }
        }
        Ok(Self::from_parts(knots_u, knots_v, pw))
    }

    /// Builds a surface from validated knot vectors and homogeneous points `(w P, w)`,
    /// flat and row-major (`i * count_v + j`).
    pub fn from_homogeneous(
        knots_u: KnotVector,
        knots_v: KnotVector,
        pw: Vec<DVec4>,
    ) -> Result<Self> {
        let (n_u, n_v) = (knots_u.count(), knots_v.count());
        if pw.len() != n_u * n_v {
            return Err(Error::InvalidControlNet(
                ControlNetError::HomogeneousCount {
                    got: pw.len(),
                    need: n_u * n_v,
                },
            ));
        }
        for (k, q) in pw.iter().enumerate() {
            let at = NetIndex::Surface(k / n_v, k % n_v);
            check_weight(q.w, at)?;
            check_point(q.truncate() / q.w, at)?;
        }
        Ok(Self::from_parts(knots_u, knots_v, pw))
    }

    pub(crate) fn from_parts(knots_u: KnotVector, knots_v: KnotVector, pw: Vec<DVec4>) -> Self {
        let n_v = knots_v.count();
        let rational = pw.iter().any(|q| q.w != 1.0);
        Self {
            knots_u,
            knots_v,
            n_v,
            pw,
            rational,
        }
    }

    /// Reads the JSON schema of the module docs: text that is not JSON or not the
    /// schema is [`Error::Json`] (with its line and column); a surface the schema
    /// allows but that is invalid is the error naming the entry (knots in which
    /// direction, control point `[i][j]`, weight row).
    pub fn from_json(text: &str) -> Result<Self> {
        let json: SurfaceJson = serde_json::from_str(text).map_err(|e| Error::Json(e.into()))?;
        Self::try_from(json)
    }

    /// Writes the JSON schema of the module docs (`weights` only when rational).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// Degree in `u`.
    pub fn degree_u(&self) -> usize {
        self.knots_u.degree()
    }
    /// Degree in `v`.
    pub fn degree_v(&self) -> usize {
        self.knots_v.degree()
    }
    /// Knot vector in `u`.
    pub fn knots_u(&self) -> &KnotVector {
        &self.knots_u
    }
    /// Knot vector in `v`.
    pub fn knots_v(&self) -> &KnotVector {
        &self.knots_v
    }
    /// Number of control points along `u` (rows).
    pub fn count_u(&self) -> usize {
        self.knots_u.count()
    }
    /// Number of control points along `v` (columns).
    pub fn count_v(&self) -> usize {
        self.n_v
    }
    /// The `u` domain `[u_min, u_max]`.
    pub fn domain_u(&self) -> (f64, f64) {
        self.knots_u.domain()
    }
    /// The `v` domain `[v_min, v_max]`.
    pub fn domain_v(&self) -> (f64, f64) {
        self.knots_v.domain()
    }
    /// True when some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }
    /// The homogeneous control points `(w P, w)`, flat row-major.
    pub fn homogeneous(&self) -> &[DVec4] {
        &self.pw
    }
    /// The Cartesian control point `P_ij`.
    pub fn control_point(&self, i: usize, j: usize) -> DVec3 {
        let q = self.pw[i * self.n_v + j];
        q.truncate() / q.w
    }
    /// The weight `w_ij`.
    pub fn weight(&self, i: usize, j: usize) -> f64 {
        self.pw[i * self.n_v + j].w
    }
    /// All Cartesian control points, `[i][j]`.
    pub fn control_points(&self) -> Vec<Vec<DVec3>> {
        self.pw
            .chunks(self.n_v)
            .map(|row| row.iter().map(|q| q.truncate() / q.w).collect())
            .collect()
    }
    /// All weights, `[i][j]`.
    pub fn weights(&self) -> Vec<Vec<f64>> {
        self.pw
            .chunks(self.n_v)
            .map(|row| row.iter().map(|q| q.w).collect())
            .collect()
    }

    /// Clamps `(u, v)` into the domain.
    #[inline]
    pub fn clamp_uv(&self, uv: DVec2) -> DVec2 {
        DVec2::new(self.knots_u.clamp(uv.x), self.knots_v.clamp(uv.y))
    }

    /// `S(u, v)` (P&T A4.3: A3.5 on the homogeneous net, then one division).
    #[inline]
    pub fn point(&self, u: f64, v: f64) -> DVec3 {
        match (self.degree_u(), self.degree_v()) {
            (3, 3) => self.point_impl(3, 3, u, v),
            (2, 2) => self.point_impl(2, 2, u, v),
            (p, q) => self.point_impl(p, q, u, v),
        }
    }

    #[inline(always)]
    fn point_impl(&self, p: usize, q: usize, u: f64, v: f64) -> DVec3 {
        let (u, v) = (self.knots_u.clamp(u), self.knots_v.clamp(v));
        let su = self.knots_u.find_span(u);
        let sv = self.knots_v.find_span(v);
        let nu = self.knots_u.basis(su, u);
        let nv = self.knots_v.basis(sv, v);
        let mut sw = DVec4::ZERO;
        for (k, nuk) in nu.iter().enumerate().take(p + 1) {
            let base = (su - p + k) * self.n_v + sv - q;
            let row = &self.pw[base..base + q + 1];
            let mut temp = DVec4::ZERO;
            for (l, pt) in row.iter().enumerate() {
                temp += *pt * nv[l];
            }
            sw += temp * *nuk;
        }
        sw.truncate() / sw.w
    }

    /// `S(u, v)` at a `DVec2` parameter.
    #[inline]
    pub fn point_uv(&self, uv: DVec2) -> DVec3 {
        self.point(uv.x, uv.y)
    }

    /// The point and all partial derivatives up to second order (P&T A3.6 on the
    /// homogeneous net, then the rational quotient rule A4.4).
    #[inline]
    pub fn derivatives(&self, u: f64, v: f64) -> SurfaceDerivs {
        // Constant degrees let the compiler unroll the tensor loops.
        match (self.degree_u(), self.degree_v()) {
            (3, 3) => self.derivatives_impl(3, 3, u, v),
            (2, 2) => self.derivatives_impl(2, 2, u, v),
            (p, q) => self.derivatives_impl(p, q, u, v),
        }
    }

    #[inline(always)]
    fn derivatives_impl(&self, p: usize, q: usize, u: f64, v: f64) -> SurfaceDerivs {
        let (u, v) = (self.knots_u.clamp(u), self.knots_v.clamp(v));
        let su = self.knots_u.find_span(u);
        let sv = self.knots_v.find_span(v);
        let nu = self.knots_u.basis_ders2(su, u);
        let nv = self.knots_v.basis_ders2(sv, v);
        // a[k][l] = d^{k+l} S^w / du^k dv^l for k + l <= 2.
        let mut a = [[DVec4::ZERO; 3]; 3];
        for r in 0..=p {
            let base = (su - p + r) * self.n_v + sv - q;
            let row = &self.pw[base..base + q + 1];
            let mut t = [DVec4::ZERO; 3];
            for (s, pt) in row.iter().enumerate() {
                t[0] += *pt * nv[0][s];
                t[1] += *pt * nv[1][s];
                t[2] += *pt * nv[2][s];
            }
            a[0][0] += t[0] * nu[0][r];
            a[0][1] += t[1] * nu[0][r];
            a[0][2] += t[2] * nu[0][r];
            a[1][0] += t[0] * nu[1][r];
            a[1][1] += t[1] * nu[1][r];
            a[2][0] += t[0] * nu[2][r];
        }
        let w = a[0][0].w;
        let inv_w = 1.0 / w;
        let s = a[0][0].truncate() * inv_w;
        let (w10, w01) = (a[1][0].w, a[0][1].w);
        let su_ = (a[1][0].truncate() - w10 * s) * inv_w;
        let sv_ = (a[0][1].truncate() - w01 * s) * inv_w;
        let suu = (a[2][0].truncate() - 2.0 * w10 * su_ - a[2][0].w * s) * inv_w;
        let suv = (a[1][1].truncate() - w10 * sv_ - w01 * su_ - a[1][1].w * s) * inv_w;
        let svv = (a[0][2].truncate() - 2.0 * w01 * sv_ - a[0][2].w * s) * inv_w;
        SurfaceDerivs {
            point: s,
            du: su_,
            dv: sv_,
            duu: suu,
            duv: suv,
            dvv: svv,
        }
    }

    /// The unit normal `S_u x S_v` normalised.
    ///
    /// Where the normal is undefined (a pole, where `S_u` or `S_v` vanishes), it is
    /// taken as the limit from inside the domain: the normal a tiny step towards the
    /// domain centre. Returns zero only for a surface degenerate around `(u, v)`.
    pub fn normal(&self, u: f64, v: f64) -> DVec3 {
        let d = self.derivatives(u, v);
        let n = d.du.cross(d.dv);
        let scale = d.du.length_squared().max(d.dv.length_squared());
        if n.length_squared() > crate::tolerance::NORMAL_DEGENERATE_REL2 * scale * scale
            && n.length_squared() > 0.0
        {
            return n.normalize();
        }
        let (u0, u1) = self.domain_u();
        let (v0, v1) = self.domain_v();
        let c = DVec2::new(0.5 * (u0 + u1), 0.5 * (v0 + v1));
        let uv = self.clamp_uv(DVec2::new(u, v));
        for t in crate::tolerance::POLE_NORMAL_STEPS {
            let p = uv + (c - uv) * t;
            let d = self.derivatives(p.x, p.y);
            let n = d.du.cross(d.dv);
            if n.length_squared() > 0.0 {
                return n.normalize();
            }
        }
        DVec3::ZERO
    }

    /// The first and second fundamental forms at `(u, v)`.
    pub fn fundamental_forms(&self, u: f64, v: f64) -> FundamentalForms {
        let d = self.derivatives(u, v);
        let n = self.normal(u, v);
        FundamentalForms {
            e: d.du.dot(d.du),
            f: d.du.dot(d.dv),
            g: d.dv.dot(d.dv),
            l: d.duu.dot(n),
            m: d.duv.dot(n),
            n: d.dvv.dot(n),
            normal: n,
        }
    }

    /// The axis-aligned bounding box of the control net (it contains the surface).
    pub fn control_bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for q in &self.pw {
            let p = q.truncate() / q.w;
            lo = lo.min(p);
            hi = hi.max(p);
        }
        (lo, hi)
    }

    /// A length scale of the surface: the diagonal of the control-net box.
    pub fn size(&self) -> f64 {
        let (lo, hi) = self.control_bounds();
        (hi - lo).length()
    }

    /// True when the surface closes on itself in `u`: the first and last rows of the
    /// (clamped) control net coincide, so `S(u_min, v) = S(u_max, v)` (a seam).
    pub fn is_closed_u(&self) -> bool {
        let n_u = self.count_u();
        self.knots_u.is_clamped()
            && (0..self.n_v).all(|j| self.same_node(j, (n_u - 1) * self.n_v + j))
    }

    /// True when the surface closes on itself in `v` (see [`Self::is_closed_u`]).
    pub fn is_closed_v(&self) -> bool {
        let n_v = self.n_v;
        self.knots_v.is_clamped()
            && (0..self.count_u()).all(|i| self.same_node(i * n_v, i * n_v + n_v - 1))
    }

    /// Which boundary edges collapse to a single point (poles), in the order
    /// `[u = u_min, u = u_max, v = v_min, v = v_max]`.
    pub fn poles(&self) -> [bool; 4] {
        let (n_u, n_v) = (self.count_u(), self.n_v);
        let row = |i: usize| (0..n_v).all(|j| self.same_point(i * n_v, i * n_v + j));
        let col = |j: usize| (0..n_u).all(|i| self.same_point(j, i * n_v + j));
        let clamped_u = self.knots_u.is_clamped();
        let clamped_v = self.knots_v.is_clamped();
        [
            clamped_u && row(0),
            clamped_u && row(n_u - 1),
            clamped_v && col(0),
            clamped_v && col(n_v - 1),
        ]
    }

    /// Same Cartesian point and same weight.
    fn same_node(&self, a: usize, b: usize) -> bool {
        let (wa, wb) = (self.pw[a].w, self.pw[b].w);
        self.same_point(a, b) && (wa - wb).abs() <= crate::tolerance::REL_EPS * wa.max(wb)
    }

    fn same_point(&self, a: usize, b: usize) -> bool {
        let (pa, pb) = (self.pw[a], self.pw[b]);
        let (ca, cb) = (pa.truncate() / pa.w, pb.truncate() / pb.w);
        let tol =
            crate::tolerance::REL_EPS * (1.0 + ca.abs().max_element().max(cb.abs().max_element()));
        (ca - cb).abs().max_element() <= tol
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A degree-1 surface JSON with an `n x n` net spanning `size` metres, all weights
    /// `weight`.
    fn grid_json(n: usize, size: f64, weight: f64) -> String {
        let knots: Vec<f64> = std::iter::once(0.0)
            .chain((0..n).map(|i| i as f64 / (n - 1) as f64))
            .chain(std::iter::once(1.0))
            .collect();
        let pts: Vec<Vec<[f64; 3]>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| [i as f64 * size / n as f64, j as f64 * size / n as f64, 0.0])
                    .collect()
            })
            .collect();
        let w = vec![vec![weight; n]; n];
        serde_json::json!({
            "degree_u": 1, "degree_v": 1, "knots_u": knots, "knots_v": knots,
            "control_points": pts, "weights": w,
        })
        .to_string()
    }

    /// Regression (issue 15, item 7): a 10^6-control-point surface took 1 GB in
    /// `project`, and coordinates near 1e308 or weights of 1e150 made it return `inf`.
    /// The JSON reader now refuses such surfaces with a message naming the cap.
    #[test]
    fn surfaces_beyond_the_reader_caps_are_refused_with_the_cap_named() {
        assert!(NurbsSurface::from_json(&grid_json(4, 1.0, 1.0)).is_ok());
        assert!(NurbsSurface::from_json(&grid_json(256, 1.0, 2.0)).is_ok());
        let e = NurbsSurface::from_json(&grid_json(257, 1.0, 1.0)).unwrap_err();
        assert!(e.to_string().contains("65536"), "{e}");
        let e = NurbsSurface::from_json(&grid_json(4, 1e300, 1.0)).unwrap_err();
        assert!(e.to_string().contains("beyond 1000000 m"), "{e}");
        let e = NurbsSurface::from_json(&grid_json(4, 1.0, 1e150)).unwrap_err();
        assert!(e.to_string().contains("weight 1e150"), "{e}");
        // not a tolerance: a hostile weight, far below the reader's cap
        let e = NurbsSurface::from_json(&grid_json(4, 1.0, 1e-150)).unwrap_err();
        assert!(e.to_string().contains("outside"), "{e}");
    }
}
