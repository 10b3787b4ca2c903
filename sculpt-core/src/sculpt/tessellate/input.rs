//! A patch's triangulation input: its points (merged within a snap distance) and
//! constraint segments, made a planar straight-line graph and triangulated by
//! constrained Delaunay (spade).

use super::height::FxMap;
use crate::sculpt::jordan::Rect;
use crate::tolerance::{MESH_MERGE_EPS, MESH_SNAP_EPS, MESH_ZERO_COORD};
use glam::DVec2;
use rustc_hash::FxHasher;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use std::hash::{BuildHasherDefault, Hash, Hasher};

#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Kind {
    Plain,
    Rim,
}

pub(super) struct PatchInput {
    pub(super) rect: Rect,
    pub(super) points: Vec<(DVec2, Kind)>,
    pub(super) index: FxMap<(u64, u64), usize>,
    /// The first and last point of each [`MESH_MERGE_EPS`] grid cell (chained through
    /// `next_near` in order of insertion), to find near-duplicates.
    pub(super) near: FxMap<(i64, i64), (usize, usize)>,
    /// Per point, the next point of its merge cell (`usize::MAX`: none).
    pub(super) next_near: Vec<usize>,
    pub(super) constraints: Vec<([usize; 2], Kind)>,
    pub(super) interior_hidden: bool,
}

/// Orientation of `c` against the line `a -> b` (twice the signed triangle area).
pub(super) fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// Parameter of the foot of `p` on the segment `a-b` when `p` lies within
/// [`MESH_SNAP_EPS`] of its interior.
pub(super) fn on_segment(p: DVec2, a: DVec2, b: DVec2) -> Option<f64> {
    let d = b - a;
    let l2 = d.length_squared();
    if l2 == 0.0 {
        return None;
    }
    let t = (p - a).dot(d) / l2;
    (t > 0.0 && t < 1.0 && p.distance(a + d * t) <= MESH_SNAP_EPS).then_some(t)
}

impl PatchInput {
    pub(super) fn new(rect: Rect) -> Self {
        let mut me = Self {
            rect,
            points: Vec::new(),
            index: FxMap::default(),
            near: FxMap::default(),
            next_near: Vec::new(),
            constraints: Vec::new(),
            interior_hidden: false,
        };
        for c in [
            rect.min,
            DVec2::new(rect.max.x, rect.min.y),
            DVec2::new(rect.min.x, rect.max.y),
            rect.max,
        ] {
            me.point(c, Kind::Plain);
        }
        me
    }

    pub(super) fn point(&mut self, p: DVec2, kind: Kind) -> usize {
        // spade merges -0.0 with 0.0 and rejects subnormal-scale coordinates: the
        // index must agree, so such values become 0.0.
        let p = DVec2::new(p.x, p.y).map(|x| if x.abs() < MESH_ZERO_COORD { 0.0 } else { x });
        let key = (p.x.to_bits(), p.y.to_bits());
        let cell = (
            (p.x / MESH_MERGE_EPS).floor() as i64,
            (p.y / MESH_MERGE_EPS).floor() as i64,
        );
        let existing = self.index.get(&key).copied().or_else(|| {
            (-1..=1)
                .flat_map(|dx| (-1..=1).map(move |dy| (cell.0 + dx, cell.1 + dy)))
                .filter_map(|c| self.near.get(&c))
                .flat_map(|&(first, _)| {
                    std::iter::successors(Some(first), |&i| {
                        Some(self.next_near[i]).filter(|&n| n != usize::MAX)
                    })
                })
                .find(|&i| self.points[i].0.distance(p) <= MESH_MERGE_EPS)
        });
        if let Some(i) = existing {
            if kind == Kind::Rim {
                self.points[i].1 = Kind::Rim;
            }
            return i;
        }
        let i = self.points.len();
        self.points.push((p, kind));
        self.index.insert(key, i);
        self.next_near.push(usize::MAX);
        match self.near.get_mut(&cell) {
            Some((_, last)) => {
                self.next_near[*last] = i;
                *last = i;
            }
            None => {
                self.near.insert(cell, (i, i));
            }
        }
        i
    }

    /// Makes the constraints a planar straight-line graph: every crossing of two
    /// constraint segments becomes a vertex (on the outline when either segment is),
    /// and segments are split at the vertices lying on them. spade's own splitting
    /// (`add_constraint_and_split`) asserts on shallow crossings whose computed split
    /// point is off both lines, as where a stroke's centreline leaves its own
    /// footprint at a hooked, tapered end. Two passes catch crossings through new
    /// vertices; what rounding leaves is skipped by [`Self::triangulate`].
    pub(super) fn resolve_crossings(&mut self) {
        for _ in 0..2 {
            if !self.split_pass() {
                break;
            }
        }
        let mut seen = std::collections::HashSet::<_, BuildHasherDefault<FxHasher>>::default();
        self.constraints
            .retain(|&([a, b], _)| a != b && seen.insert((a.min(b), a.max(b))));
    }

    /// One pass of [`Self::resolve_crossings`]: true when a crossing added a vertex.
    pub(super) fn split_pass(&mut self) -> bool {
        let m = self.constraints.len();
        let boxes: Vec<Rect> = self
            .constraints
            .iter()
            .map(|&([a, b], _)| Rect::of_segment(self.points[a].0, self.points[b].0))
            .collect();
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by(|&i, &j| boxes[i].min.x.total_cmp(&boxes[j].min.x));
        let mut splits: Vec<Vec<(f64, usize)>> = vec![Vec::new(); m];
        let mut added = false;
        for (k, &i) in order.iter().enumerate() {
            for &j in &order[k + 1..] {
                if boxes[j].min.x > boxes[i].max.x {
                    break;
                }
                if boxes[i].touches(&boxes[j]) {
                    added |= self.split_pair(i, j, &mut splits);
                }
            }
        }
        let old = std::mem::take(&mut self.constraints);
        for (([a, b], kind), mut cuts) in old.into_iter().zip(splits) {
            cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut prev = a;
            for (_, v) in cuts.into_iter().chain(std::iter::once((1.0, b))) {
                if v != prev {
                    self.constraints.push(([prev, v], kind));
                    prev = v;
                }
            }
        }
        added
    }

    /// Records where constraints `i` and `j` meet: an end of one on the other, or a
    /// proper crossing (a new vertex). True when a vertex was added.
    pub(super) fn split_pair(
        &mut self,
        i: usize,
        j: usize,
        splits: &mut [Vec<(f64, usize)>],
    ) -> bool {
        let ([a0, a1], ka) = self.constraints[i];
        let ([b0, b1], kb) = self.constraints[j];
        let (a, b) = (self.points[a0].0, self.points[a1].0);
        let (c, d) = (self.points[b0].0, self.points[b1].0);
        let mut touching = false;
        for (k, ends, (s0, s1), (e0, e1), kind) in [
            (i, [(b0, c), (b1, d)], (a, b), (a0, a1), ka),
            (j, [(a0, a), (a1, b)], (c, d), (b0, b1), kb),
        ] {
            for (v, p) in ends {
                if v != e0
                    && v != e1
                    && let Some(t) = on_segment(p, s0, s1)
                {
                    splits[k].push((t, v));
                    touching = true;
                    // An end on the outline is on the rim (a groove wall's rung ending
                    // where collinear rim points were merged into one outline edge).
                    if kind == Kind::Rim {
                        self.points[v].1 = Kind::Rim;
                    }
                }
            }
        }
        let shared = a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1;
        if touching || shared {
            return false;
        }
        let (o1, o2) = (orient(c, d, a), orient(c, d, b));
        let (o3, o4) = (orient(a, b, c), orient(a, b, d));
        if !(o1 * o2 < 0.0 && o3 * o4 < 0.0) {
            return false;
        }
        let (t, u) = (o1 / (o1 - o2), o3 / (o3 - o4));
        let p = a + (b - a) * t;
        if !p.is_finite() {
            return false;
        }
        let p = p.clamp(self.rect.min, self.rect.max);
        let kind = if ka == Kind::Rim || kb == Kind::Rim {
            Kind::Rim
        } else {
            Kind::Plain
        };
        // A crossing at an end is that end.
        let end = [(a0, a), (a1, b), (b0, c), (b1, d)]
            .into_iter()
            .find(|&(_, q)| q.distance(p) <= MESH_SNAP_EPS);
        let v = match end {
            Some((v, _)) => v,
            None => self.point(p, kind),
        };
        if v != a0 && v != a1 {
            splits[i].push((t, v));
        }
        if v != b0 && v != b1 {
            splits[j].push((u, v));
        }
        end.is_none()
    }

    /// The constrained Delaunay triangulation of the points and constraints, built
    /// point by point in input order: deterministic, so an incremental tessellation
    /// equals a fresh one bit for bit (spade's bulk loader inserts the vertices it
    /// defers in hash-set order, which varies from run to run). Never panics:
    /// constraints still crossing after [`Self::resolve_crossings`] (rounding at
    /// near-coincident crossings) are left out, as are points spade cannot take.
    pub(super) fn triangulate(&mut self) -> ConstrainedDelaunayTriangulation<Point2<f64>> {
        self.resolve_crossings();
        // Bulk loading keeps the vertex order (the points are distinct: `point` merges
        // repeats) and is several times faster than inserting one by one; it refuses
        // only invalid coordinates, for which the one-by-one insertion below skips the
        // offending points.
        let vertices: Vec<Point2<f64>> = self
            .points
            .iter()
            .map(|(p, _)| Point2::new(p.x, p.y))
            .collect();
        let edges: Vec<[usize; 2]> = self
            .constraints
            .iter()
            .map(|&(e, _)| e)
            .filter(|e| e[0] != e[1])
            .collect();
        if let Ok(cdt) =
            ConstrainedDelaunayTriangulation::try_bulk_load_cdt(vertices, edges, |_| {})
            && cdt.num_vertices() == self.points.len()
        {
            return cdt;
        }
        let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
        let handles: Vec<_> = self
            .points
            .iter()
            .map(|(p, _)| cdt.insert(Point2::new(p.x, p.y)).ok())
            .collect();
        for &([a, b], _) in &self.constraints {
            if let (Some(a), Some(b)) = (handles[a], handles[b])
                && a != b
            {
                cdt.try_add_constraint(a, b);
            }
        }
        cdt
    }

    pub(super) fn hash_into(&self, h: &mut impl Hasher) {
        for (p, k) in &self.points {
            p.x.to_bits().hash(h);
            p.y.to_bits().hash(h);
            (*k == Kind::Rim).hash(h);
        }
        self.constraints.hash(h);
        self.interior_hidden.hash(h);
    }
}
