//! Grid planning: how finely a target's UV square is cut into root cells, from the
//! chord error measured on the surface ([`GridPlan`], [`chord_errors`]).

use crate::sculpt::surface::{ParamSurface, normal_from};
use glam::{DVec2, DVec3};

/// Largest root grid, cells per side.
pub const MAX_GRID: u32 = 64;

/// Smallest root grid, cells per side: root cells are the unit of incremental
/// re-tessellation, so even a flat target is cut into `8 x 8` of them to keep an edit's
/// work local.
pub const MIN_GRID: u32 = 8;

/// The deviation the grid is planned for, as a fraction of the stated tolerance: the
/// chord error is measured at cell midpoints, where it peaks for smooth patches; the
/// margin covers higher-order terms between them.
pub(crate) const GRID_MARGIN: f64 = 0.8;

/// Most root cells refined beyond this many levels by [`GridPlan`].
pub const MAX_REFINE: u8 = 4;

/// How a target is cut for tessellation: an `n x n` root grid, and per root the
/// quadtree level its leaves reach at least, so that every cell, drawn as two flat
/// triangles, deviates from the surface by at most `GRID_MARGIN * tol`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridPlan {
    /// Root cells per side.
    pub n: u32,
    /// Per root (row-major), the minimum leaf level.
    pub min_levels: Vec<u8>,
}

impl GridPlan {
    /// Plans the grid for a chord tolerance `tol` (metres).
    ///
    /// The chord error is measured, not estimated from derivative bounds: at every
    /// cell's edge midpoints and centre, the distance along the surface normal between
    /// the surface and the chord through the cell's corners (both diagonals at the
    /// centre) ([`chord_errors`]). Tangential parametric distortion (a clamped knot
    /// vector, a rational weight) moves no vertex off the surface and does not count.
    /// The uniform root grid `n` ([`MIN_GRID`] to [`MAX_GRID`]) is grown until 95 % of the cells
    /// hold (the error of a smooth patch falls as `1 / n^2`); the cells that still do
    /// not (creases, tight spots) are refined by `log2(error / goal)` levels, at most
    /// [`MAX_REFINE`] (the error falls at least by half per level).
    pub fn new(surface: &dyn ParamSurface, tol: f64) -> Self {
        let goal = tol * GRID_MARGIN;
        if !(goal > 0.0 && goal.is_finite()) {
            return Self::uniform(MAX_GRID);
        }
        let quantile = |e: &[f64]| {
            let mut v = e.to_vec();
            v.sort_by(f64::total_cmp);
            v[(v.len() * 95 / 100).min(v.len() - 1)]
        };
        let probe = 4u32;
        let d = quantile(&chord_errors(surface, probe));
        if !d.is_finite() {
            return Self::uniform(MAX_GRID);
        }
        let mut n =
            ((f64::from(probe) * (d / goal).sqrt()).ceil() as u32).clamp(MIN_GRID, MAX_GRID);
        loop {
            let errors = chord_errors(surface, n);
            let q = quantile(&errors);
            if q <= goal || n >= MAX_GRID {
                let min_levels = errors
                    .iter()
                    .map(|&e| {
                        if e <= goal {
                            0
                        } else if e.is_finite() {
                            ((e / goal).log2().ceil() as u8).min(MAX_REFINE)
                        } else {
                            MAX_REFINE
                        }
                    })
                    .collect();
                return Self { n, min_levels };
            }
            let next = (f64::from(n) * (q / goal).sqrt() * 1.05).ceil() as u32;
            n = next.clamp(n + 1, MAX_GRID);
        }
    }

    pub(super) fn uniform(n: u32) -> Self {
        Self {
            n,
            min_levels: vec![0; (n * n) as usize],
        }
    }
}

/// The chord error (metres, along the normal) of each cell of an `n x n` grid of flat
/// cells over the surface (row-major), measured at its edge midpoints and centre (see
/// [`GridPlan::new`]); infinite where the surface is not finite.
pub fn chord_errors(surface: &dyn ParamSurface, n: u32) -> Vec<f64> {
    let n = n.max(1) as usize;
    let m = 2 * n + 1;
    let h = 0.5 / n as f64;
    let mut grid = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            let uv = DVec2::new(i as f64 * h, j as f64 * h).min(DVec2::ONE);
            let sp = surface.eval(uv);
            grid.push((sp.p, normal_from(surface, uv, &sp)));
        }
    }
    let at = |i: usize, j: usize| grid[j * m + i];
    let off = |mid: (DVec3, DVec3), a: DVec3, b: DVec3| mid.1.dot(mid.0 - (a + b) * 0.5).abs();
    let mut out = Vec::with_capacity(n * n);
    for cj in 0..n {
        for ci in 0..n {
            let (i, j) = (2 * ci + 1, 2 * cj + 1);
            let c = at(i, j);
            let e = [
                off(at(i, j - 1), at(i - 1, j - 1).0, at(i + 1, j - 1).0),
                off(at(i, j + 1), at(i - 1, j + 1).0, at(i + 1, j + 1).0),
                off(at(i - 1, j), at(i - 1, j - 1).0, at(i - 1, j + 1).0),
                off(at(i + 1, j), at(i + 1, j - 1).0, at(i + 1, j + 1).0),
                off(c, at(i - 1, j - 1).0, at(i + 1, j + 1).0),
                off(c, at(i + 1, j - 1).0, at(i - 1, j + 1).0),
            ];
            let worst = e.iter().fold(0.0f64, |w, &x| {
                if x.is_finite() {
                    w.max(x)
                } else {
                    f64::INFINITY
                }
            });
            out.push(worst);
        }
    }
    out
}
