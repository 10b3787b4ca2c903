//! Knot insertion, knot refinement and degree elevation of a volume, one direction at
//! a time.
//!
//! A tensor-product volume is refined in direction `d` by applying the curve algorithm
//! to every line of control points along `d` (the other indices fixed), on the
//! homogeneous points `(h A, h)`, with the same knots for every line (P&T sec. 5.3 and
//! 5.5 do this for surfaces; the volume case is the same argument once more). The map
//! does not change, only its representation.
//!
//! - [`Volume::insert_knot`]: P&T A5.1 per line (the kernel's `insert_pw`).
//! - [`Volume::refine_knots`]: P&T A5.4 per line (the kernel's `refine_pw`).
//! - [`Volume::elevate_degree`]: P&T A5.9 per line.
//!
//! The kernel's A5.1 and A5.4 work on 4-vectors; a homogeneous point of `k + 1`
//! values is cut into 4-vector chunks, each refined with the same knots (the
//! algorithms are linear in the points, so the chunks are independent).

// The book's algorithms index arrays by span offsets and count with explicit
// counters; keeping its loops keeps the code checkable against the book.
#![allow(
    clippy::needless_range_loop,
    clippy::explicit_counter_loop,
    clippy::manual_memcpy
)]

use glam::DVec4;

use super::{MAX_CONTROL_POINTS, Volume, VolumeError, VolumeResult};
use crate::nurbs::knots::{KnotVector, MAX_DEGREE};
use crate::nurbs::refine::{insert_pw, refine_pw};

/// A line operation: the direction's knots and one line of homogeneous points
/// (`dim` values each) in, the new knots and line out.
type LineOp<'a> = dyn FnMut(&KnotVector, &[f64]) -> VolumeResult<(Vec<f64>, Vec<f64>)> + 'a;

/// Runs a 4-vector polygon operation of the kernel on a line of `dim`-value points,
/// one 4-value chunk at a time.
fn by_chunks(
    kv: &KnotVector,
    line: &[f64],
    dim: usize,
    op: impl Fn(&KnotVector, &[DVec4]) -> crate::Result<(Vec<f64>, Vec<DVec4>)>,
) -> crate::Result<(Vec<f64>, Vec<f64>)> {
    let np = line.len() / dim;
    let mut knots = Vec::new();
    let mut out = Vec::new();
    for c0 in (0..dim).step_by(4) {
        let width = (dim - c0).min(4);
        let poly: Vec<DVec4> = (0..np)
            .map(|i| {
                let mut v = [0.0; 4];
                v[..width].copy_from_slice(&line[i * dim + c0..i * dim + c0 + width]);
                DVec4::from_array(v)
            })
            .collect();
        let (k, q) = op(kv, &poly)?;
        if out.is_empty() {
            out = vec![0.0; q.len() * dim];
        }
        for (i, v) in q.iter().enumerate() {
            out[i * dim + c0..i * dim + c0 + width].copy_from_slice(&v.to_array()[..width]);
        }
        knots = k;
    }
    Ok((knots, out))
}

/// `n choose k` as a float (small arguments: degrees up to [`MAX_DEGREE`]).
fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// `dst = a * x + b * y` on `dim`-value rows.
fn blend(dst: &mut [f64], a: f64, x: &[f64], b: f64, y: &[f64]) {
    for ((d, xi), yi) in dst.iter_mut().zip(x).zip(y) {
        *d = a * xi + b * yi;
    }
}

/// Degree elevation of one clamped homogeneous polygon by `t` (P&T A5.9,
/// `DegreeElevateCurve`): Bezier decomposition by knot insertion, elevation of each
/// segment (eq. 5.36), removal of the inserted knots. Returns the new knots and points.
pub(crate) fn elevate_line(
    kv: &KnotVector,
    pw: &[f64],
    dim: usize,
    t: usize,
) -> (Vec<f64>, Vec<f64>) {
    let p = kv.degree();
    let u = kv.knots();
    let n = pw.len() / dim - 1;
    if t == 0 {
        return (u.to_vec(), pw.to_vec());
    }
    let row = |v: &[f64], i: usize| v[i * dim..(i + 1) * dim].to_vec();
    let m = n + p + 1;
    let ph = p + t;
    let ph2 = ph / 2;
    // Bezier degree elevation coefficients.
    let mut bezalfs = vec![vec![0.0; p + 1]; ph + 1];
    bezalfs[0][0] = 1.0;
    bezalfs[ph][p] = 1.0;
    for i in 1..=ph2 {
        let inv = 1.0 / binomial(ph, i);
        let mpi = p.min(i);
        for j in i.saturating_sub(t)..=mpi {
            bezalfs[i][j] = inv * binomial(p, j) * binomial(t, i - j);
        }
    }
    for i in ph2 + 1..ph {
        let mpi = p.min(i);
        for j in i.saturating_sub(t)..=mpi {
            bezalfs[i][j] = bezalfs[ph - i][p - j];
        }
    }
    // Enough room for every knot span to gain t knots.
    let distinct = 1 + u.windows(2).filter(|w| w[1] > w[0]).count();
    let max_pts = n + 1 + t * distinct;
    let mut qw = vec![vec![0.0; dim]; max_pts];
    let mut uh = vec![0.0; max_pts + ph + 1];
    let mut bpts = vec![vec![0.0; dim]; p + 1];
    let mut ebpts = vec![vec![0.0; dim]; ph + 1];
    let mut next_bpts = vec![vec![0.0; dim]; p.saturating_sub(1).max(1)];
    let mut alfs = vec![0.0; p.max(1)];
    let mut mh = ph;
    let mut kind = ph + 1;
    let mut r: isize = -1;
    let mut a = p;
    let mut b = p + 1;
    let mut cind = 1;
    let mut ua = u[0];
    qw[0] = row(pw, 0);
    for x in uh.iter_mut().take(ph + 1) {
        *x = ua;
    }
    for i in 0..=p {
        bpts[i] = row(pw, i);
    }
    while b < m {
        let i0 = b;
        while b < m && u[b] == u[b + 1] {
            b += 1;
        }
        let mul = b - i0 + 1;
        mh += mul + t;
        let ub = u[b];
        let oldr = r;
        r = p as isize - mul as isize;
        let lbz = if oldr > 0 { (oldr as usize + 2) / 2 } else { 1 };
        let rbz = if r > 0 {
            ph - (r as usize).div_ceil(2)
        } else {
            ph
        };
        if r > 0 {
            // Insert ub r times to get the Bezier segment.
            let numer = ub - ua;
            for k in (mul + 1..=p).rev() {
                alfs[k - mul - 1] = numer / (u[a + k] - ua);
            }
            for j in 1..=r as usize {
                let save = r as usize - j;
                let s = mul + j;
                for k in (s..=p).rev() {
                    let al = alfs[k - s];
                    let (lo, hi) = bpts.split_at_mut(k);
                    let prev = lo[k - 1].clone();
                    let cur = hi[0].clone();
                    blend(&mut hi[0], al, &cur, 1.0 - al, &prev);
                }
                next_bpts[save] = bpts[p].clone();
            }
        }
        // Degree-elevate the Bezier segment (only lbz..=ph are used below).
        for i in lbz..=ph {
            ebpts[i].iter_mut().for_each(|v| *v = 0.0);
            let mpi = p.min(i);
            for j in i.saturating_sub(t)..=mpi {
                for c in 0..dim {
                    ebpts[i][c] += bezalfs[i][j] * bpts[j][c];
                }
            }
        }
        if oldr > 1 {
            // Remove the knot u = ua oldr - 1 times.
            let oldr = oldr as usize;
            let mut first = kind - 2;
            let mut last = kind;
            let den = ub - ua;
            let bet = (ub - uh[kind - 1]) / den;
            for tr in 1..oldr {
                let mut i = first;
                let mut j = last;
                let mut kj = j - kind + 1;
                while j - i > tr {
                    if i < cind {
                        let alf = (ub - uh[i]) / (ua - uh[i]);
                        let (cur, prev) = (qw[i].clone(), qw[i - 1].clone());
                        blend(&mut qw[i], alf, &cur, 1.0 - alf, &prev);
                    }
                    if j >= lbz {
                        let (cur, nxt) = (ebpts[kj].clone(), ebpts[kj + 1].clone());
                        let g = if j - tr <= kind - ph + oldr {
                            (ub - uh[j - tr]) / den
                        } else {
                            bet
                        };
                        blend(&mut ebpts[kj], g, &cur, 1.0 - g, &nxt);
                    }
                    i += 1;
                    j -= 1;
                    kj -= 1;
                }
                first -= 1;
                last += 1;
            }
        }
        if a != p {
            // Load the knot ua.
            for _ in 0..ph - oldr.max(0) as usize {
                uh[kind] = ua;
                kind += 1;
            }
        }
        for j in lbz..=rbz {
            qw[cind] = ebpts[j].clone();
            cind += 1;
        }
        if b < m {
            // Set up for the next segment.
            let r = r.max(0) as usize;
            for j in 0..r {
                bpts[j] = next_bpts[j].clone();
            }
            for j in r..=p {
                bpts[j] = row(pw, b - p + j);
            }
            a = b;
            b += 1;
            ua = ub;
        } else {
            for i in 0..=ph {
                uh[kind + i] = ub;
            }
        }
    }
    let nh = mh - ph - 1;
    uh.truncate(nh + ph + 2);
    let pts: Vec<f64> = qw.into_iter().take(nh + 1).flatten().collect();
    (uh, pts)
}

impl Volume {
    /// Applies `op` to every line of control points along direction `d`; all lines
    /// must come back with the same knots (they do: the knots depend only on `d`).
    fn map_lines(&self, d: usize, degree: usize, op: &mut LineOp<'_>) -> VolumeResult<Self> {
        self.check_direction(d)?;
        let dim = self.dim;
        let c = self.counts[d];
        let inner = self.strides[d];
        let outer = self.point_count() / (c * inner);
        let kv = &self.knots[d];
        let mut line = vec![0.0; c * dim];
        let mut new_knots = Vec::new();
        let mut new_c = 0;
        let mut out = Vec::new();
        for o in 0..outer {
            for r in 0..inner {
                for i in 0..c {
                    let flat = (o * c + i) * inner + r;
                    line[i * dim..(i + 1) * dim]
                        .copy_from_slice(&self.cw[flat * dim..(flat + 1) * dim]);
                }
                let (k, q) = op(kv, &line)?;
                if out.is_empty() {
                    new_c = q.len() / dim;
                    let total = outer * new_c * inner;
                    if total > MAX_CONTROL_POINTS {
                        return Err(VolumeError::TooManyControlPoints {
                            count: total,
                            max: MAX_CONTROL_POINTS,
                        });
                    }
                    out = vec![0.0; total * dim];
                    new_knots = k;
                }
                for i in 0..new_c {
                    let flat = (o * new_c + i) * inner + r;
                    out[flat * dim..(flat + 1) * dim].copy_from_slice(&q[i * dim..(i + 1) * dim]);
                }
            }
        }
        let kv = KnotVector::new(degree, new_knots).map_err(|reason| VolumeError::Insertion {
            direction: d,
            reason,
        })?;
        let mut knots = self.knots.clone();
        knots[d] = kv;
        Ok(Self::from_parts(knots, self.attributes.clone(), out))
    }

    /// Inserts the knot `t` `r` times in direction `d` (P&T A5.1 on every line along
    /// `d`). The map is unchanged.
    pub fn insert_knot(&self, d: usize, t: f64, r: usize) -> VolumeResult<Self> {
        let dim = self.dim;
        let p = self.knots.get(d).map_or(1, KnotVector::degree);
        self.map_lines(d, p, &mut |kv, line| {
            by_chunks(kv, line, dim, |kv, pw| insert_pw(kv, pw, t, r)).map_err(|reason| {
                VolumeError::Insertion {
                    direction: d,
                    reason,
                }
            })
        })
    }

    /// Inserts every knot of the sorted vector `x` in direction `d` (P&T A5.4 on every
    /// line along `d`). The map is unchanged.
    pub fn refine_knots(&self, d: usize, x: &[f64]) -> VolumeResult<Self> {
        let dim = self.dim;
        let p = self.knots.get(d).map_or(1, KnotVector::degree);
        self.map_lines(d, p, &mut |kv, line| {
            by_chunks(kv, line, dim, |kv, pw| refine_pw(kv, pw, x)).map_err(|reason| {
                VolumeError::Insertion {
                    direction: d,
                    reason,
                }
            })
        })
    }

    /// Raises the degree of direction `d` by `t` (P&T A5.9 on every line along `d`).
    /// The map is unchanged.
    pub fn elevate_degree(&self, d: usize, t: usize) -> VolumeResult<Self> {
        self.check_direction(d)?;
        let p = self.knots[d].degree();
        if p + t > MAX_DEGREE {
            return Err(VolumeError::ElevationTooHigh {
                direction: d,
                degree: p,
                by: t,
                max: MAX_DEGREE,
            });
        }
        let dim = self.dim;
        self.map_lines(d, p + t, &mut |kv, line| Ok(elevate_line(kv, line, dim, t)))
    }
}
