//! Knot insertion and refinement (P&T chapter 5).
//!
//! All routines work on homogeneous points `(w P, w)`, so they are exact for rational
//! curves and surfaces: the shape does not change, only its representation.

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

use glam::DVec4;

use super::curve::NurbsCurve;
pub use super::direction::Direction;
use super::knots::KnotVector;
use super::surface::NurbsSurface;
use crate::error::{Error, ParameterError, Result};

/// P&T A2.1 exactly as the book has it (`n` at the right end), as A5.1 and A5.4 expect.
fn book_span(knots: &[f64], p: usize, n: usize, u: f64) -> usize {
    if u >= knots[n + 1] {
        return n;
    }
    let (mut lo, mut hi) = (p, n + 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if u < knots[mid] {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    lo
}

fn check_in_domain(kv: &KnotVector, u: f64) -> Result<()> {
    let (a, b) = kv.domain();
    if u.is_finite() && u >= a && u <= b {
        Ok(())
    } else {
        Err(Error::InvalidParameter(ParameterError::KnotOutsideDomain {
            knot: u,
            start: a,
            end: b,
        }))
    }
}

/// Inserts `u` `r` times into one homogeneous polygon (P&T A5.1, `CurveKnotIns`).
///
/// Requires `s + r <= p` where `s` is the multiplicity `u` already has.
pub(crate) fn insert_pw(
    kv: &KnotVector,
    pw: &[DVec4],
    u: f64,
    r: usize,
) -> Result<(Vec<f64>, Vec<DVec4>)> {
    check_in_domain(kv, u)?;
    let p = kv.degree();
    let up = kv.knots();
    let np = pw.len() - 1;
    let s = kv.multiplicity(u);
    if r == 0 {
        return Ok((up.to_vec(), pw.to_vec()));
    }
    if s + r > p {
        return Err(Error::InvalidParameter(
            ParameterError::MultiplicityAboveDegree {
                knot: u,
                times: r,
                multiplicity: s,
                degree: p,
            },
        ));
    }
    let k = book_span(up, p, np, u);
    let mp = np + p + 1;
    let mut uq = vec![0.0; mp + r + 1];
    uq[..=k].copy_from_slice(&up[..=k]);
    for x in uq.iter_mut().skip(k + 1).take(r) {
        *x = u;
    }
    uq[k + 1 + r..=mp + r].copy_from_slice(&up[k + 1..=mp]);
    let mut qw = vec![DVec4::ZERO; np + r + 1];
    qw[..=k - p].copy_from_slice(&pw[..=k - p]);
    qw[k - s + r..=np + r].copy_from_slice(&pw[k - s..=np]);
    let mut rw: Vec<DVec4> = (0..=p - s).map(|i| pw[k - p + i]).collect();
    let mut l = k - p;
    for j in 1..=r {
        l = k - p + j;
        for i in 0..=p - j - s {
            let alpha = (u - up[l + i]) / (up[i + k + 1] - up[l + i]);
            rw[i] = rw[i + 1] * alpha + rw[i] * (1.0 - alpha);
        }
        qw[l] = rw[0];
        qw[k + r - j - s] = rw[p - j - s];
    }
    if l + 1 < k - s {
        qw[l + 1..k - s].copy_from_slice(&rw[1..k - s - l]);
    }
    Ok((uq, qw))
}

/// Inserts all knots of the non-decreasing vector `x` into one homogeneous polygon
/// (P&T A5.4, `RefineKnotVectCurve`).
pub(crate) fn refine_pw(
    kv: &KnotVector,
    pw: &[DVec4],
    x: &[f64],
) -> Result<(Vec<f64>, Vec<DVec4>)> {
    if x.is_empty() {
        return Ok((kv.knots().to_vec(), pw.to_vec()));
    }
    for &u in x {
        check_in_domain(kv, u)?;
    }
    if x.windows(2).any(|w| w[1] < w[0]) {
        return Err(Error::InvalidParameter(ParameterError::UnsortedKnots));
    }
    let p = kv.degree();
    let u = kv.knots();
    let n = pw.len() - 1;
    let m = n + p + 1;
    let r = x.len() - 1;
    let a = book_span(u, p, n, x[0]);
    let b = book_span(u, p, n, x[r]) + 1;
    let mut ub = vec![0.0; m + r + 2];
    let mut qw = vec![DVec4::ZERO; n + r + 2];
    qw[..=a - p].copy_from_slice(&pw[..=a - p]);
    for j in b - 1..=n {
        qw[j + r + 1] = pw[j];
    }
    ub[..=a].copy_from_slice(&u[..=a]);
    for j in b + p..=m {
        ub[j + r + 1] = u[j];
    }
    let mut i = b + p - 1;
    let mut k = b + p + r;
    for j in (0..=r).rev() {
        while x[j] <= u[i] && i > a {
            qw[k - p - 1] = pw[i - p - 1];
            ub[k] = u[i];
            k -= 1;
            i -= 1;
        }
        qw[k - p - 1] = qw[k - p];
        for l in 1..=p {
            let ind = k - p + l;
            let alfa = ub[k + l] - x[j];
            if alfa.abs() == 0.0 {
                qw[ind - 1] = qw[ind];
            } else {
                let alfa = alfa / (ub[k + l] - u[i + l - p]);
                qw[ind - 1] = qw[ind - 1] * alfa + qw[ind] * (1.0 - alfa);
            }
        }
        ub[k] = x[j];
        k = k.wrapping_sub(1);
    }
    Ok((ub, qw))
}

impl NurbsCurve {
    /// Inserts the knot `u` `r` times (P&T A5.1). The curve keeps its shape exactly.
    pub fn insert_knot(&self, u: f64, r: usize) -> Result<Self> {
        let (k, pw) = insert_pw(self.knots(), self.homogeneous(), u, r)?;
        Ok(Self::from_parts(KnotVector::new(self.degree(), k)?, pw))
    }

    /// Inserts every knot of the sorted vector `x` (P&T A5.4). The shape is unchanged.
    pub fn refine_knots(&self, x: &[f64]) -> Result<Self> {
        let (k, pw) = refine_pw(self.knots(), self.homogeneous(), x)?;
        Ok(Self::from_parts(KnotVector::new(self.degree(), k)?, pw))
    }

    /// `C(u)` computed by repeated knot insertion (P&T A5.3, `CurvePntByCornerCut`):
    /// insert `u` until its multiplicity is `p`; the point is then a control point.
    /// Slower than [`NurbsCurve::point`]; useful as an independent check.
    pub fn point_by_corner_cut(&self, u: f64) -> Result<glam::DVec3> {
        let (a, b) = self.domain();
        check_in_domain(self.knots(), u)?;
        let pw = self.homogeneous();
        let n = pw.len() - 1;
        let clamped = self.knots().is_clamped();
        let q = if u == a && clamped {
            pw[0]
        } else if u == b {
            if !clamped {
                return Ok(self.point(b));
            }
            pw[n]
        } else {
            let p = self.degree();
            let knots = self.knots().knots();
            let s = self.knots().multiplicity(u);
            let k = book_span(knots, p, n, u);
            let r = p.saturating_sub(s);
            let mut rw: Vec<DVec4> = (0..=r).map(|i| pw[k - p + i]).collect();
            for j in 1..=r {
                for i in 0..=r - j {
                    let alfa =
                        (u - knots[k - p + j + i]) / (knots[i + k + 1] - knots[k - p + j + i]);
                    rw[i] = rw[i + 1] * alfa + rw[i] * (1.0 - alfa);
                }
            }
            rw[0]
        };
        Ok(q.truncate() / q.w)
    }
}

impl NurbsSurface {
    /// Applies a polygon operation to every column (direction `U`) or row (`V`).
    fn map_polygons(
        &self,
        dir: Direction,
        op: impl Fn(&KnotVector, &[DVec4]) -> Result<(Vec<f64>, Vec<DVec4>)>,
    ) -> Result<Self> {
        let (n_u, n_v) = (self.count_u(), self.count_v());
        let pw = self.homogeneous();
        match dir {
            Direction::U => {
                let mut knots = Vec::new();
                let mut cols = Vec::with_capacity(n_v);
                for j in 0..n_v {
                    let col: Vec<DVec4> = (0..n_u).map(|i| pw[i * n_v + j]).collect();
                    let (k, q) = op(self.knots_u(), &col)?;
                    knots = k;
                    cols.push(q);
                }
                let new_n_u = cols[0].len();
                let mut out = Vec::with_capacity(new_n_u * n_v);
                for i in 0..new_n_u {
                    out.extend(cols.iter().map(|c| c[i]));
                }
                let ku = KnotVector::new(self.degree_u(), knots)?;
                Ok(Self::from_parts(ku, self.knots_v().clone(), out))
            }
            Direction::V => {
                let mut knots = Vec::new();
                let mut out = Vec::new();
                for row in pw.chunks(n_v) {
                    let (k, q) = op(self.knots_v(), row)?;
                    knots = k;
                    out.extend(q);
                }
                let kv = KnotVector::new(self.degree_v(), knots)?;
                Ok(Self::from_parts(self.knots_u().clone(), kv, out))
            }
        }
    }

    /// Inserts the knot `t` `r` times in direction `dir` (P&T A5.3 for surfaces:
    /// A5.1 applied to every row or column). The shape is unchanged.
    pub fn insert_knot(&self, dir: Direction, t: f64, r: usize) -> Result<Self> {
        self.map_polygons(dir, |kv, pw| insert_pw(kv, pw, t, r))
    }

    /// Inserts every knot of the sorted vector `x` in direction `dir` (P&T A5.5, the
    /// surface form of A5.4). The shape is unchanged.
    pub fn refine_knots(&self, dir: Direction, x: &[f64]) -> Result<Self> {
        self.map_polygons(dir, |kv, pw| refine_pw(kv, pw, x))
    }

    /// The knots to insert so that every knot value in the domain of `kv` (ends
    /// included) has multiplicity at least `p`: afterwards each knot span is a Bezier
    /// segment (P&T A5.6 by refinement).
    pub(crate) fn bezier_insertions(kv: &KnotVector) -> Vec<f64> {
        let p = kv.degree();
        let (a, b) = kv.domain();
        let mut x = Vec::new();
        for _ in kv.multiplicity(a)..p {
            x.push(a);
        }
        for (t, m) in kv.interior_breaks() {
            for _ in m..p {
                x.push(t);
            }
        }
        for _ in kv.multiplicity(b)..p {
            x.push(b);
        }
        x
    }

    /// The surface with every knot span a Bezier patch in both directions.
    pub fn to_bezier_form(&self) -> Result<Self> {
        let su = self.refine_knots(Direction::U, &Self::bezier_insertions(self.knots_u()))?;
        su.refine_knots(Direction::V, &Self::bezier_insertions(self.knots_v()))
    }
}
