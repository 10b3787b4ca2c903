//! The joint least-squares fit of a whole patch network: every control point is an
//! unknown once, however many patches hold it (the points on a shared side and at a
//! corner belong to all of their patches), so the patches meet exactly by
//! construction and a side can move towards the data on either side of it.
//!
//! Each patch contributes rows `w (S_q(u, v) - p)` (its grid points and the data
//! points whose closest point lies on it); the normal equations are the sum of the
//! patches' dense local normal matrices (`c^2 x c^2` each) scattered into the shared
//! numbering, and are solved by conjugate gradients with a Jacobi preconditioner
//! (Saad, "Iterative methods for sparse linear systems", Algorithm 9.1), patch by
//! patch without assembling the global matrix: the product with it gathers each
//! patch's unknowns, multiplies by its local matrix and scatters the result back.

use std::collections::BTreeMap;

use glam::{DVec2, DVec3};
use nalgebra::DMatrix;

use super::polygon::QuadCorner;
use super::quads::{BoundaryKey, Grid, Side, boundary_key, par_map, sides};
use crate::nurbs::KnotVector;
use crate::tolerance::{CG_MAX_ITERATIONS, CG_REL_TOL};

/// One least-squares row: the point, its parameter on the patch, its weight.
pub(super) type Row = (DVec3, DVec2, f64);

/// Every control point of every patch numbered, the ones shared by patches once.
#[derive(Debug, Clone)]
pub(super) struct Unknowns {
    /// `index[q][i * c + j]`: the unknown of control point `(i, j)` of patch `q`.
    index: Vec<Vec<usize>>,
    count: usize,
    /// Control points per direction of every patch.
    c: usize,
}

impl Unknowns {
    /// Numbers the control points of `quads` with `c x c` nets: a side's points are
    /// shared by the quads that hold the side (matched along the side's key, so both
    /// run it the same way), a corner's by every quad at it.
    pub(super) fn new(quads: &[[QuadCorner; 4]], c: usize) -> Self {
        let m = c - 1;
        let mut shared: BTreeMap<BoundaryKey, usize> = BTreeMap::new();
        let mut count = 0;
        let mut index = vec![vec![usize::MAX; c * c]; quads.len()];
        for (qi, q) in quads.iter().enumerate() {
            for s in sides(q, m) {
                let s: Side = s.canonical();
                let key = s.key().0;
                for (k, &(i, j)) in s.on.iter().enumerate() {
                    let n = *shared.entry(boundary_key(key, k, m)).or_insert_with(|| {
                        count += 1;
                        count - 1
                    });
                    index[qi][i * c + j] = n;
                }
            }
            for slot in index[qi].iter_mut().filter(|s| **s == usize::MAX) {
                *slot = count;
                count += 1;
            }
        }
        Self { index, count, c }
    }

    /// The unknown of control point `(i, j)` of patch `q`.
    pub(super) fn of(&self, q: usize, (i, j): (usize, usize)) -> usize {
        self.index[q][i * self.c + j]
    }

    /// The number of unknowns.
    pub(super) fn count(&self) -> usize {
        self.count
    }
}

/// A linear condition on the unknowns, `sum c_i . x_i = value` (dot products: a
/// condition on one coordinate has an axis as its `c_i`, one across a plane its
/// normal), held in the least-squares sense with a weight.
#[derive(Debug, Clone)]
pub(super) struct Penalty {
    /// The terms `(unknown, c_i)`.
    pub(super) terms: Vec<(usize, DVec3)>,
    /// The right-hand side.
    pub(super) value: f64,
    /// The weight of the condition against a data point's 1.
    pub(super) weight: f64,
}

/// One patch's share of the normal equations, dense: `A^T W A` (`c^2 x c^2`) and
/// `A^T W P` (`c^2 x 3`).
#[derive(Debug, Clone)]
pub(super) struct Normal {
    normal: DMatrix<f64>,
    rhs: DMatrix<f64>,
}

impl Normal {
    /// The normal equations of `rows` on a patch with `c x c` control points on
    /// `knots` in both directions.
    pub(super) fn new(rows: &[Row], knots: &KnotVector, c: usize) -> Self {
        let mut n = Self {
            normal: DMatrix::zeros(c * c, c * c),
            rhs: DMatrix::zeros(c * c, 3),
        };
        n.add(rows, knots, c);
        n
    }

    /// Adds `rows` to the equations.
    fn add(&mut self, rows: &[Row], knots: &KnotVector, c: usize) {
        let mut nz: Vec<(usize, f64)> = Vec::with_capacity(16);
        for (p, uv, w) in rows {
            let bu = knots.basis_row(uv.x);
            let bv = knots.basis_row(uv.y);
            nz.clear();
            for (i, &a) in bu.iter().enumerate().filter(|(_, a)| **a != 0.0) {
                for (j, &b) in bv.iter().enumerate().filter(|(_, b)| **b != 0.0) {
                    nz.push((i * c + j, a * b));
                }
            }
            for &(r, a) in &nz {
                for &(s, b) in &nz {
                    self.normal[(r, s)] += w * a * b;
                }
                for k in 0..3 {
                    self.rhs[(r, k)] += w * a * p[k];
                }
            }
        }
    }
}

/// One patch's share of the normal equations as used by the iterations: the nonzero
/// entries `(r, s, value)` of `A^T W A` (local indices) and `A^T W P`.
struct Local {
    normal: Vec<(usize, usize, f64)>,
    rhs: DMatrix<f64>,
}

impl From<Normal> for Local {
    fn from(n: Normal) -> Self {
        let size = n.normal.nrows();
        let normal = (0..size)
            .flat_map(|r| (0..size).map(move |s| (r, s)))
            .filter(|&(r, s)| n.normal[(r, s)] != 0.0)
            .map(|(r, s)| (r, s, n.normal[(r, s)]))
            .collect();
        Self { normal, rhs: n.rhs }
    }
}

/// Solves the joint least squares for the control nets `nets` (read as the starting
/// guess, written with the solution): patch `q`'s equations are `base[q]` (made
/// once, for the rows that do not change between calls, such as its grid) plus its
/// `rows[q]`, on the common `knots` with `c` control points per direction, together
/// with the `penalties`. Every control point must be reached by some row (each
/// patch's grid does that). Returns the conjugate gradient iterations taken, or
/// `None`, leaving `nets` as they were, when the solution is not finite (a row or
/// condition that is: the caller keeps its previous nets).
pub(super) fn solve(
    unknowns: &Unknowns,
    nets: &mut [Grid],
    base: &[Normal],
    rows: &[Vec<Row>],
    penalties: &[Penalty],
    knots: &KnotVector,
    c: usize,
) -> Option<usize> {
    let pairs: Vec<(&Normal, &Vec<Row>)> = base.iter().zip(rows).collect();
    let locals: Vec<Local> = par_map(&pairs, |(base, rows)| {
        let mut n = (*base).clone();
        n.add(rows, knots, c);
        Local::from(n)
    });
    let n = unknowns.count();
    let mut b = vec![DVec3::ZERO; n];
    let mut diag = vec![DVec3::ZERO; n];
    let mut x = vec![DVec3::ZERO; n];
    for (q, local) in locals.iter().enumerate() {
        for (r, &g) in unknowns.index[q].iter().enumerate() {
            b[g] += DVec3::new(local.rhs[(r, 0)], local.rhs[(r, 1)], local.rhs[(r, 2)]);
            x[g] = nets[q][r / c][r % c];
        }
    }
    for (q, local) in locals.iter().enumerate() {
        for &(r, _, v) in local.normal.iter().filter(|(r, s, _)| r == s) {
            diag[unknowns.index[q][r]] += DVec3::splat(v);
        }
    }
    for c in penalties {
        for &(g, a) in &c.terms {
            diag[g] += c.weight * a * a;
            b[g] += c.weight * c.value * a;
        }
    }
    let patches: Vec<usize> = (0..locals.len()).collect();
    let product = |v: &[DVec3]| {
        let mut out = vec![DVec3::ZERO; n];
        let parts = par_map(&patches, |&q| {
            let idx = &unknowns.index[q];
            let mut part = vec![DVec3::ZERO; idx.len()];
            for &(r, s, a) in &locals[q].normal {
                part[r] += a * v[idx[s]];
            }
            part
        });
        for (q, part) in parts.into_iter().enumerate() {
            for (r, value) in part.into_iter().enumerate() {
                out[unknowns.index[q][r]] += value;
            }
        }
        for c in penalties {
            let value: f64 = c.terms.iter().map(|&(g, a)| a.dot(v[g])).sum();
            for &(g, a) in &c.terms {
                out[g] += c.weight * value * a;
            }
        }
        out
    };
    let precondition = |r: &[DVec3]| -> Vec<DVec3> {
        r.iter()
            .zip(&diag)
            .map(|(r, d)| DVec3::select(d.cmpgt(DVec3::ZERO), *r / *d, *r))
            .collect()
    };
    if !b.iter().chain(&diag).all(|v| v.is_finite()) {
        return None;
    }
    let dot = |a: &[DVec3], b: &[DVec3]| -> f64 { a.iter().zip(b).map(|(a, b)| a.dot(*b)).sum() };
    let ax = product(&x);
    let mut r: Vec<DVec3> = b.iter().zip(&ax).map(|(b, a)| *b - *a).collect();
    let mut z = precondition(&r);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let b_norm = dot(&b, &b).sqrt().max(f64::MIN_POSITIVE);
    let mut iterations = 0;
    while iterations < CG_MAX_ITERATIONS {
        if dot(&r, &r).sqrt() <= CG_REL_TOL * b_norm {
            break;
        }
        iterations += 1;
        let ap = product(&p);
        let pap = dot(&p, &ap);
        if pap.is_nan() || pap <= 0.0 {
            break;
        }
        let alpha = rz / pap;
        for ((x, r), (p, ap)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&ap)) {
            *x += alpha * *p;
            *r -= alpha * *ap;
        }
        z = precondition(&r);
        let rz_next = dot(&r, &z);
        let beta = if rz > 0.0 { rz_next / rz } else { 0.0 };
        rz = rz_next;
        for (p, z) in p.iter_mut().zip(&z) {
            *p = *z + beta * *p;
        }
    }
    if !x.iter().all(|p| p.is_finite()) {
        return None;
    }
    for (q, net) in nets.iter_mut().enumerate() {
        for (r, &g) in unknowns.index[q].iter().enumerate() {
            net[r / c][r % c] = x[g];
        }
    }
    Some(iterations)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reconstruct::network::shared_sides;

    /// How far the joint fit of an exactly representable surface (heights up to 6)
    /// may land from it: the conjugate gradients stop at a relative residual of
    /// `CG_REL_TOL`, from a start of all zeros.
    const EXACT_FIT_TOL: f64 = 100.0 * CG_REL_TOL;

    /// Two unit quads side by side along `x`, sharing the side `x = 1`.
    fn two_quads() -> Vec<[QuadCorner; 4]> {
        use QuadCorner::Patch as P;
        vec![[P(0), P(1), P(2), P(3)], [P(1), P(4), P(5), P(2)]]
    }

    /// `z = x^2 + xy - y^2 / 2` over `x` in `[0, 2]`: degree 2, so bicubic patches on
    /// uniform knots hold it exactly; quad `q` covers `x` in `[q, q + 1]`.
    fn height(q: usize, uv: DVec2) -> DVec3 {
        let (x, y) = (q as f64 + uv.x, uv.y);
        DVec3::new(x, y, x * x + x * y - 0.5 * y * y)
    }

    fn rows_on_surface(weight: f64) -> Vec<Vec<Row>> {
        (0..2)
            .map(|q| {
                (0..=8)
                    .flat_map(|i| (0..=8).map(move |j| DVec2::new(i as f64, j as f64) / 8.0))
                    .map(|uv| (height(q, uv), uv, weight))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_shared_side_is_numbered_once() {
        let c = 6;
        let u = Unknowns::new(&two_quads(), c);
        assert_eq!(u.count(), 2 * c * c - c);
        for k in 0..c {
            assert_eq!(u.of(0, (c - 1, k)), u.of(1, (0, k)));
        }
        assert_ne!(u.of(0, (0, 0)), u.of(1, (c - 1, 0)));
    }

    /// Control points per direction of the two test patches.
    const C: usize = 6;

    /// The two quads, their common bicubic knots, the unknowns, and empty base
    /// equations.
    fn fixture() -> (Vec<[QuadCorner; 4]>, KnotVector, Unknowns, Vec<Normal>) {
        let quads = two_quads();
        let knots = KnotVector::uniform_clamped(3, C).unwrap();
        let unknowns = Unknowns::new(&quads, C);
        let none = vec![Normal::new(&[], &knots, C); 2];
        (quads, knots, unknowns, none)
    }

    #[test]
    fn the_joint_fit_reproduces_a_surface_it_can_hold() {
        let c = C;
        let (quads, knots, unknowns, none) = fixture();
        let mut nets = vec![vec![vec![DVec3::ZERO; c]; c]; 2];
        let iterations = solve(
            &unknowns,
            &mut nets,
            &none,
            &rows_on_surface(1.0),
            &[],
            &knots,
            c,
        );
        assert!(iterations.is_some_and(|i| i > 0));
        let check = |nets: &[Grid]| {
            for (q, net) in nets.iter().enumerate() {
                let s = crate::nurbs::NurbsSurface::new(
                    3,
                    3,
                    knots.knots().to_vec(),
                    knots.knots().to_vec(),
                    net.clone(),
                    None,
                )
                .unwrap();
                for t in [0.0, 0.13, 0.5, 0.77, 1.0] {
                    for w in [0.0, 0.31, 1.0] {
                        let uv = DVec2::new(t, w);
                        let err = s.point_uv(uv).distance(height(q, uv));
                        assert!(err < EXACT_FIT_TOL, "quad {q} at {uv}: {err}");
                    }
                }
            }
        };
        check(&nets);
        // The smoothness condition across the side holds for this surface already
        // (one polynomial, the same speed on both sides), so adding it changes
        // nothing; a condition that contradicts the data moves the fit.
        let smooth: Vec<Penalty> = shared_sides(&quads, c - 1)
            .iter()
            .flat_map(|[(qa, sa), (qb, sb)]| {
                let u = &unknowns;
                (1..c - 1).flat_map(move |k| {
                    [DVec3::X, DVec3::Y, DVec3::Z].map(|axis| Penalty {
                        terms: vec![
                            (u.of(*qa, sa.inner[k]), axis),
                            (u.of(*qb, sb.inner[k]), axis),
                            (u.of(*qa, sa.on[k]), -2.0 * axis),
                        ],
                        value: 0.0,
                        weight: 10.0,
                    })
                })
            })
            .collect();
        let mut again = vec![vec![vec![DVec3::ZERO; c]; c]; 2];
        // The same rows as a base made once: the same answer.
        let base: Vec<Normal> = rows_on_surface(1.0)
            .iter()
            .map(|r| Normal::new(r, &knots, c))
            .collect();
        let empty = vec![Vec::new(); 2];
        solve(&unknowns, &mut again, &base, &empty, &smooth, &knots, c);
        check(&again);
        let pin = Penalty {
            terms: vec![(unknowns.of(0, (2, 2)), DVec3::Z)],
            value: 10.0,
            weight: 1e3,
        };
        let mut pinned = nets.clone();
        solve(
            &unknowns,
            &mut pinned,
            &none,
            &rows_on_surface(1.0),
            &[pin],
            &knots,
            c,
        );
        assert!(
            pinned[0][2][2].z > nets[0][2][2].z + 1.0,
            "{}",
            pinned[0][2][2]
        );
    }

    #[test]
    fn a_solution_that_is_not_finite_leaves_the_nets_alone() {
        let c = C;
        let (_, knots, unknowns, none) = fixture();
        let start = vec![vec![vec![DVec3::ONE; c]; c]; 2];
        let mut nets = start.clone();
        let mut rows = rows_on_surface(1.0);
        rows[1][5].0 = DVec3::new(f64::NAN, 0.0, 0.0);
        assert_eq!(
            solve(&unknowns, &mut nets, &none, &rows, &[], &knots, c),
            None
        );
        assert_eq!(nets, start);
    }
}
