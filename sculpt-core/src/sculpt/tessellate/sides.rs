//! Fixed sides: vertices along a side of the square handed in from outside, so that a
//! target meshed by the tessellator conforms to a neighbour meshed elsewhere (a patch
//! of a network, [`super::super::conform`]).
//!
//! A fixed side takes exactly the given vertices and no others: its points are the
//! given parameters (the roots' corners on the side and the strokes' ends there must
//! be among them, [`TargetTessellation::side_params`]), leaf corners and outline crossings on it
//! are left out, and a constraint segment ending on it ends at the nearest given
//! parameter of its root's span. Every vertex there is written at the given point,
//! normal and displacement, `point + normal * height`, which the neighbour computes
//! with the same bits.

use super::{StrokeRef, TargetTessellation};
use crate::tolerance::{FIXED_SIDE_SNAP, MESH_MERGE_EPS, MESH_SNAP_EPS};
use glam::{DVec2, DVec3};
use std::hash::{Hash, Hasher};

/// A vertex along a fixed side of the square.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideVertex {
    /// Its parameter along the side (increasing `v` on sides 0 and 1, increasing `u` on
    /// sides 2 and 3).
    pub t: f64,
    /// The point on the surface.
    pub point: DVec3,
    /// The unit normal written with it (and the direction of the displacement).
    pub normal: DVec3,
    /// The displacement along `normal`: the vertex lies at `point + normal * height`.
    pub height: f64,
}

impl SideVertex {
    /// Where the vertex is written: `point + normal * height`, with `-0.0` written as
    /// `0.0` (every mesher of a conforming network writes this, so the bits agree).
    pub fn position(&self) -> DVec3 {
        self.point + self.normal * self.height + DVec3::ZERO
    }
}

/// The fixed vertices of the four sides (0 `u = 0`, 1 `u = 1`, 2 `v = 0`, 3 `v = 1`),
/// each sorted by parameter; `None` where a side is meshed as usual.
pub type FixedSides = [Option<Vec<SideVertex>>; 4];

/// The point of the unit square at parameter `t` along side `k`.
pub(super) fn side_uv(k: usize, t: f64) -> DVec2 {
    match k {
        0 => DVec2::new(0.0, t),
        1 => DVec2::new(1.0, t),
        2 => DVec2::new(t, 0.0),
        _ => DVec2::new(t, 1.0),
    }
}

/// The distance of `p` from side `k`'s line (signed, positive inside the square) and
/// its parameter along the side.
fn across_along(k: usize, p: DVec2) -> (f64, f64) {
    match k {
        0 => (p.x, p.y),
        1 => (1.0 - p.x, p.y),
        2 => (p.y, p.x),
        _ => (1.0 - p.y, p.x),
    }
}

/// The index of the vertex of `list` (sorted by `t`) nearest to `t`.
fn nearest(list: &[SideVertex], t: f64) -> Option<usize> {
    let i = list.partition_point(|v| v.t < t);
    [i.checked_sub(1), (i < list.len()).then_some(i)]
        .into_iter()
        .flatten()
        .min_by(|&a, &b| (list[a].t - t).abs().total_cmp(&(list[b].t - t).abs()))
}

impl TargetTessellation {
    /// Fixes the vertices along the sides of the square (see the module docs); a side
    /// whose list changed has its cells rewritten on the next update (true when any
    /// changed). Only sides with no neighbour (not a seam of a closed target) take fixed
    /// vertices.
    pub fn set_fixed_sides(&mut self, sides: FixedSides) -> bool {
        let mut changed = false;
        for (k, side) in sides.into_iter().enumerate() {
            if self.fixed[k] != side {
                self.fixed[k] = side;
                self.fixed_changed[k] = true;
                changed = true;
            }
        }
        changed
    }

    /// The fixed vertices of side `k`, if any.
    pub fn fixed_side(&self, k: usize) -> Option<&[SideVertex]> {
        self.fixed.get(k).and_then(|s| s.as_deref())
    }

    /// The parameters along side `k` that a fixed side must hold for this target
    /// carved by `strokes`: the root cells' corners there (every cell puts its corners
    /// into its triangulation) and the ends, on the side or within [`FIXED_SIDE_SNAP`]
    /// of it, of the strokes' constraint segments (footprint outlines, centrelines and
    /// groove walls at this detail), so that a groove running up to the side meets it
    /// at vertices its neighbour holds too.
    pub fn side_params(&self, k: usize, strokes: &[StrokeRef<'_>]) -> Vec<f64> {
        let n = self.map.n();
        let mut out: Vec<f64> = (0..n * n)
            .filter(|&r| self.root_on_side(r, k))
            .flat_map(|r| {
                let rect = self.map.node(r).rect;
                if k < 2 {
                    [rect.min.y, rect.max.y]
                } else {
                    [rect.min.x, rect.max.x]
                }
            })
            .collect();
        for (_, s) in strokes {
            let fracs = self.detail.profile_lines(s.tool.profile.is_curved());
            let walls = s.wall_segments(fracs);
            let ends = s
                .footprint
                .segments()
                .iter()
                .chain(s.centre_segments())
                .chain(&walls)
                .flatten();
            for &p in ends {
                let (across, along) = across_along(k, p);
                if across.abs() <= FIXED_SIDE_SNAP {
                    out.push(along);
                }
            }
        }
        out.sort_by(f64::total_cmp);
        out.dedup();
        out
    }

    /// True when side `side` of root `root` is a fixed side of the square.
    pub(super) fn fixed_here(&self, root: u32, side: u8) -> Option<&[SideVertex]> {
        if !self.root_on_side(root, side as usize) || self.neighbour(root, side).is_some() {
            return None;
        }
        self.fixed_side(side as usize)
    }

    /// The fixed vertex at `uv`, if `uv` lies on a fixed side (within
    /// [`MESH_SNAP_EPS`]) at one of its parameters (within [`MESH_MERGE_EPS`]).
    pub(super) fn fixed_at(&self, uv: DVec2) -> Option<SideVertex> {
        for (k, list) in self.fixed.iter().enumerate() {
            let Some(list) = list else { continue };
            let (across, along, at) = match k {
                0 => (uv.x, uv.y, 0.0),
                1 => (uv.x, uv.y, 1.0),
                2 => (uv.y, uv.x, 0.0),
                _ => (uv.y, uv.x, 1.0),
            };
            if (across - at).abs() > MESH_SNAP_EPS {
                continue;
            }
            if let Some(i) = nearest(list, along)
                && (list[i].t - along).abs() <= MESH_MERGE_EPS
            {
                return Some(list[i]);
            }
        }
        None
    }

    /// `p` moved onto the nearest fixed parameter within `[lo, hi]` when it lies on
    /// fixed side `k` or within [`FIXED_SIDE_SNAP`] of it (a constraint's end there);
    /// otherwise `p`.
    pub(super) fn snap_to_fixed(&self, k: usize, p: DVec2, lo: f64, hi: f64) -> DVec2 {
        let Some(list) = self.fixed_side(k) else {
            return p;
        };
        let (across, along) = across_along(k, p);
        if across.abs() > FIXED_SIDE_SNAP {
            return p;
        }
        let within: Vec<SideVertex> = list
            .iter()
            .filter(|v| v.t >= lo - MESH_MERGE_EPS && v.t <= hi + MESH_MERGE_EPS)
            .copied()
            .collect();
        match nearest(&within, along) {
            Some(i) => side_uv(k, within[i].t),
            None => p,
        }
    }

    /// Hashes the fixed vertices on root `root`'s sides (their bits), for its
    /// signature.
    pub(super) fn hash_fixed(&self, root: u32, h: &mut impl Hasher) {
        for side in 0u8..4 {
            if let Some(list) = self.fixed_here(root, side) {
                side.hash(h);
                for v in list {
                    [v.t, v.point.x, v.point.y, v.point.z, v.normal.x, v.normal.y]
                        .map(f64::to_bits)
                        .hash(h);
                    [v.normal.z, v.height].map(f64::to_bits).hash(h);
                }
            }
        }
    }
}
