//! The UV vector map: a quadtree of render nodes over the normalised parameter square.
//!
//! The map starts as an `n x n` grid of root nodes (the tessellator's `GridPlan` picks
//! `n`, and a minimum level for roots where the surface curves tightly, from the
//! measured chord error; [`base_grid`] is a quick estimate from a curvature bound). Each
//! node is classified against the region hidden by
//! strokes ([`Region`]): exterior nodes are drawn, interior nodes are hidden, boundary
//! nodes are subdivided down to a depth cap (coarse while a stroke is live, fine for the
//! final render), and the tree is **graded**: neighbouring leaves differ by at most one
//! level (2:1), also across root cells and across the seams of a closed surface (see
//! [`GRADING_REACH`]), so that the mesh steps from the fine rim down to the root grid
//! one level at a time. New children start with their parent's classification, so merging a
//! node's children restores the node as it was; [`UvMap::update`] returns an [`Edit`]
//! that [`UvMap::restore`] undoes exactly.
//!
//! ```
//! use glam::DVec2;
//! use sculpt_core::sculpt::jordan::{NodeClass, Region};
//! use sculpt_core::sculpt::uvmap::UvMap;
//! let mut map = UvMap::new(4);
//! let tri = vec![DVec2::new(0.1, 0.1), DVec2::new(0.9, 0.1), DVec2::new(0.5, 0.9)];
//! let edit = map.update(&Region::new(vec![tri]), None, 3);
//! assert!(map.leaves().any(|(_, n)| n.class == NodeClass::Interior));
//! assert!(map.leaves().all(|(_, n)| n.class != NodeClass::Boundary || n.level == 3));
//! map.restore(edit);
//! assert_eq!(map.leaves().count(), 16);
//! ```

use super::jordan::{NodeClass, Rect, Region};
use super::surface::SurfaceExtent;
use glam::DVec2;

/// How far (in multiples of a node's own side) the grading looks for finer neighbours.
///
/// A node at level `l` below the cap is subdivided when the hidden region's outline
/// comes within `GRADING_REACH` of its sides (L-infinity distance in the parameter
/// square) and `l + 1 < cap`, or when a root demanding a deeper minimum level does
/// (`l + 1 <` that level). Balance follows for any reach of at least 1: a neighbour two
/// levels finer has a subdivided ancestor `A` of side `s <= side / 2` touching the node,
/// whose reason lies within `(1 + reach) s <= (1 + reach) side / 2 <= reach * side` of the
/// node, so the node would have been subdivided too. 1.25 keeps a margin against
/// rounding in the rectangle tests.
pub const GRADING_REACH: f64 = 1.25;

/// Index of a node in the map's arena.
pub type NodeId = u32;

/// One quadtree node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    /// Depth below its root (roots are level 0).
    pub level: u8,
    /// Parameter rectangle.
    pub rect: Rect,
    /// Classification against the hidden region.
    pub class: NodeClass,
    /// First of four children (in the order SW, SE, NW, NE), if subdivided.
    pub children: Option<NodeId>,
    /// The root this node belongs to.
    pub root: u32,
}

/// What an update changed, so that it can be undone.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Edit {
    /// Nodes whose class changed, with the class before.
    reclassified: Vec<(NodeId, NodeClass)>,
    /// Nodes that were subdivided by the update (restore merges them).
    subdivided: Vec<NodeId>,
    /// Nodes that were merged by the update, with their former child block.
    merged: Vec<(NodeId, NodeId)>,
}

impl Edit {
    /// The roots this edit touched.
    pub fn is_empty(&self) -> bool {
        self.reclassified.is_empty() && self.subdivided.is_empty() && self.merged.is_empty()
    }
}

/// The quadtree over `[0, 1]^2`.
#[derive(Debug, Clone, PartialEq)]
pub struct UvMap {
    n: u32,
    nodes: Vec<Node>,
    free: Vec<NodeId>,
    /// Per root, the level every leaf reaches whatever its class (where the surface
    /// curves too much for a flat root cell).
    min_levels: Vec<u8>,
    /// The largest of `min_levels` (0: the grading need not look for them).
    deepest_min_level: u8,
    /// Whether the square wraps in u and in v (a closed surface): the grading looks
    /// across the seam.
    wrap: [bool; 2],
}

/// Chooses the base grid size `n` so that a flat quad of parameter size `1/n` deviates
/// from the surface by at most `tol` (chord error `h^2 |S''| / 8`), between 2 and 64.
pub fn base_grid(extent: &SurfaceExtent, tol: f64) -> u32 {
    let tol = if tol > 0.0 {
        tol
    } else {
        crate::tolerance::DEFAULT_CHORD_TOL
    };
    let n = (extent.curvature / (8.0 * tol)).sqrt().ceil();
    if n.is_finite() {
        (n as u32).clamp(2, 64)
    } else {
        64
    }
}

impl UvMap {
    /// An unclassified (all exterior) `n x n` grid of roots.
    pub fn new(n: u32) -> Self {
        let n = n.clamp(1, 256);
        let h = 1.0 / n as f64;
        let mut nodes = Vec::with_capacity((n * n) as usize);
        for j in 0..n {
            for i in 0..n {
                let min = DVec2::new(i as f64 * h, j as f64 * h);
                let max = if i + 1 == n { 1.0 } else { (i + 1) as f64 * h };
                let maxy = if j + 1 == n { 1.0 } else { (j + 1) as f64 * h };
                nodes.push(Node {
                    level: 0,
                    rect: Rect::new(min, DVec2::new(max, maxy)),
                    class: NodeClass::Exterior,
                    children: None,
                    root: j * n + i,
                });
            }
        }
        Self {
            n,
            nodes,
            free: Vec::new(),
            min_levels: vec![0; (n * n) as usize],
            deepest_min_level: 0,
            wrap: [false; 2],
        }
    }

    /// Sets whether the square wraps in u and in v (the seams of a closed surface), so
    /// that leaves on both sides of a seam are graded against each other; takes effect
    /// at the next [`Self::update`] of each root.
    pub fn set_wrap(&mut self, closed_u: bool, closed_v: bool) {
        self.wrap = [closed_u, closed_v];
    }

    /// Sets, per root (row-major), the level that every leaf reaches whatever its class;
    /// takes effect at the next [`Self::update`] of each root. Missing entries are 0.
    pub fn set_min_levels(&mut self, levels: &[u8]) {
        for (k, m) in self.min_levels.iter_mut().enumerate() {
            *m = levels.get(k).copied().unwrap_or(0);
        }
        self.deepest_min_level = self.min_levels.iter().copied().max().unwrap_or(0);
    }

    /// The level every leaf of `root` reaches (see [`Self::set_min_levels`]).
    pub fn min_level(&self, root: u32) -> u8 {
        self.min_levels.get(root as usize).copied().unwrap_or(0)
    }

    /// Roots per side.
    pub fn n(&self) -> u32 {
        self.n
    }

    /// A node.
    pub fn node(&self, id: NodeId) -> &Node {
        &self.nodes[id as usize]
    }

    /// The root node of grid cell `(i, j)`.
    pub fn root(&self, i: u32, j: u32) -> NodeId {
        j * self.n + i
    }

    /// Splits a leaf into four children that inherit its class.
    pub fn subdivide(&mut self, id: NodeId) -> NodeId {
        let parent = self.nodes[id as usize];
        if let Some(c) = parent.children {
            return c;
        }
        let (lo, hi) = (parent.rect.min, parent.rect.max);
        let mid = (lo + hi) * 0.5;
        let rects = [
            Rect::new(lo, mid),
            Rect::new(DVec2::new(mid.x, lo.y), DVec2::new(hi.x, mid.y)),
            Rect::new(DVec2::new(lo.x, mid.y), DVec2::new(mid.x, hi.y)),
            Rect::new(mid, hi),
        ];
        let first = match self.free.pop() {
            Some(f) => f,
            None => {
                let f = self.nodes.len() as NodeId;
                self.nodes.extend([parent; 4]);
                f
            }
        };
        for (k, rect) in rects.into_iter().enumerate() {
            self.nodes[first as usize + k] = Node {
                level: parent.level + 1,
                rect,
                class: parent.class,
                children: None,
                root: parent.root,
            };
        }
        self.nodes[id as usize].children = Some(first);
        first
    }

    /// Merges a node's children (recursively) back into it; returns the freed block.
    pub fn merge(&mut self, id: NodeId) -> Option<NodeId> {
        let first = self.nodes[id as usize].children.take()?;
        for k in 0..4 {
            self.merge(first + k);
        }
        self.free.push(first);
        Some(first)
    }

    /// Reclassifies the roots whose rectangle meets `area` (all roots when `None`)
    /// against `region`, subdividing boundary nodes down to level `cap` and merging nodes
    /// that are no longer boundary. Returns the undo record.
    pub fn update(&mut self, region: &Region, area: Option<Rect>, cap: u8) -> Edit {
        let mut edit = Edit::default();
        for r in 0..self.n * self.n {
            if area.is_none_or(|a| a.touches(&self.nodes[r as usize].rect)) {
                self.classify_node(r, region, cap, &mut edit);
            }
        }
        edit
    }

    /// [`Self::update`] for the listed roots only (the caller knows the region changed
    /// nowhere else).
    pub fn update_roots(
        &mut self,
        region: &Region,
        roots: impl IntoIterator<Item = u32>,
        cap: u8,
    ) -> Edit {
        let mut edit = Edit::default();
        for r in roots {
            if r < self.n * self.n {
                self.classify_node(r, region, cap, &mut edit);
            }
        }
        edit
    }

    fn classify_node(&mut self, id: NodeId, region: &Region, cap: u8, edit: &mut Edit) {
        let node = self.nodes[id as usize];
        let class = region.classify(node.rect);
        if class != node.class {
            edit.reclassified.push((id, node.class));
            self.nodes[id as usize].class = class;
        }
        let wants_children = (class == NodeClass::Boundary && node.level < cap)
            || node.level < self.min_level(node.root)
            || self.grading_wants_children(&node, region, cap);
        match (wants_children, node.children) {
            (true, None) => {
                let first = self.subdivide(id);
                edit.subdivided.push(id);
                for k in 0..4 {
                    self.classify_node(first + k, region, cap, edit);
                }
            }
            (true, Some(first)) => {
                for k in 0..4 {
                    self.classify_node(first + k, region, cap, edit);
                }
            }
            (false, Some(_)) => {
                // Keep the children's records for restore: detach instead of freeing.
                let first = self.nodes[id as usize].children.take().unwrap_or_default();
                edit.merged.push((id, first));
            }
            (false, None) => {}
        }
    }

    /// The grading rule of [`GRADING_REACH`]: true when the outline, or a root with a
    /// deeper minimum level, lies within reach of the node.
    fn grading_wants_children(&self, node: &Node, region: &Region, cap: u8) -> bool {
        let l = node.level;
        let reach = (node.rect.max - node.rect.min) * GRADING_REACH;
        let near = Rect::new(node.rect.min - reach, node.rect.max + reach);
        let outline = l + 1 < cap
            && !region.is_empty()
            && self.wrapped(near).any(|r| region.meets_outline(r));
        outline || (l + 1 < self.deepest_min_level && l + 1 < self.deepest_min_level_near(near))
    }

    /// The rectangle and, on a closed surface, its copies shifted by one period where
    /// it reaches past the square.
    fn wrapped(&self, r: Rect) -> impl Iterator<Item = Rect> + use<> {
        // The shifts by one period (at most two per direction) that bring it back.
        let shifts = |wrap: bool, lo: f64, hi: f64| {
            let mut out = ([0.0; 3], 1);
            for (reaches, d) in [(lo < 0.0, 1.0), (hi > 1.0, -1.0)] {
                if wrap && reaches {
                    out.0[out.1] = d;
                    out.1 += 1;
                }
            }
            out
        };
        let (su, nu) = shifts(self.wrap[0], r.min.x, r.max.x);
        let (sv, nv) = shifts(self.wrap[1], r.min.y, r.max.y);
        (0..nv).flat_map(move |j| {
            (0..nu).map(move |i| {
                let d = DVec2::new(su[i], sv[j]);
                Rect::new(r.min + d, r.max + d)
            })
        })
    }

    /// The deepest minimum level among the roots that the rectangle touches (across
    /// the seams of a closed surface).
    fn deepest_min_level_near(&self, r: Rect) -> u8 {
        let n = self.n as i64;
        let cells = |lo: f64, hi: f64, wrap: bool| -> Vec<u32> {
            let (a, b) = (
                (lo * n as f64).floor() as i64,
                (hi * n as f64).floor() as i64,
            );
            let mut out: Vec<u32> = (a..=b)
                .filter_map(|i| {
                    if (0..n).contains(&i) {
                        Some(i as u32)
                    } else if wrap {
                        Some(i.rem_euclid(n) as u32)
                    } else {
                        None
                    }
                })
                .collect();
            out.sort_unstable();
            out.dedup();
            out
        };
        let is = cells(r.min.x, r.max.x, self.wrap[0]);
        let js = cells(r.min.y, r.max.y, self.wrap[1]);
        let mut deepest = 0;
        for &j in &js {
            for &i in &is {
                deepest = deepest.max(self.min_level(self.root(i, j)));
            }
        }
        deepest
    }

    /// The parameters along side `side` (0 = u-min, 1 = u-max, 2 = v-min, 3 = v-max) of
    /// root `root` where the corners of its leaves touching that side lie (`v` for the
    /// u sides, `u` for the v sides), sorted, without repeats. Computed by the same
    /// halving from the root's rectangle as the leaves, so two roots sharing a side
    /// (whose rows or columns have the same bounds) give the same bits.
    pub fn side_params(&self, root: u32, side: u8) -> Vec<f64> {
        let mut out = Vec::new();
        self.side_params_into(root, side, &mut out);
        out
    }

    /// [`Self::side_params`] into `out` (cleared first). Walks only the children that
    /// touch the side (SW, SE, NW, NE: u-min holds 0 and 2, u-max 1 and 3, v-min 0 and
    /// 1, v-max 2 and 3), in order along it.
    pub fn side_params_into(&self, root: u32, side: u8, out: &mut Vec<f64>) {
        out.clear();
        let kids: [u32; 2] = match side {
            0 => [0, 2],
            1 => [1, 3],
            2 => [0, 1],
            _ => [2, 3],
        };
        let mut stack = vec![root];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id as usize];
            match node.children {
                Some(c) => stack.extend(kids.iter().rev().map(|&k| c + k)),
                None => {
                    let r = node.rect;
                    let (lo, hi) = if side < 2 {
                        (r.min.y, r.max.y)
                    } else {
                        (r.min.x, r.max.x)
                    };
                    out.push(lo);
                    out.push(hi);
                }
            }
        }
        out.sort_by(f64::total_cmp);
        out.dedup();
    }

    /// Undoes an [`Edit`], restoring every node touched to its state before the update.
    pub fn restore(&mut self, edit: Edit) {
        for &(id, first) in edit.merged.iter().rev() {
            self.nodes[id as usize].children = Some(first);
        }
        for &id in edit.subdivided.iter().rev() {
            self.merge(id);
        }
        for &(id, class) in edit.reclassified.iter().rev() {
            self.nodes[id as usize].class = class;
        }
    }

    /// All leaves, root by root.
    pub fn leaves(&self) -> impl Iterator<Item = (NodeId, &Node)> + '_ {
        (0..self.n * self.n).flat_map(move |r| self.leaves_of(r))
    }

    /// The leaves under one root.
    pub fn leaves_of(&self, root: u32) -> Vec<(NodeId, &Node)> {
        let mut out = Vec::new();
        let mut stack = vec![root];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id as usize];
            match node.children {
                Some(c) => stack.extend((0..4).rev().map(|k| c + k)),
                None => out.push((id, node)),
            }
        }
        out
    }

    /// The finest level among the leaves of `root` that touch one of its sides
    /// (0 = u-min, 1 = u-max, 2 = v-min, 3 = v-max).
    pub fn side_level(&self, root: u32, side: u8) -> u8 {
        if self.nodes[root as usize].children.is_none() {
            return self.nodes[root as usize].level;
        }
        let r = self.nodes[root as usize].rect;
        self.leaves_of(root)
            .into_iter()
            .filter(|(_, n)| match side {
                0 => n.rect.min.x == r.min.x,
                1 => n.rect.max.x == r.max.x,
                2 => n.rect.min.y == r.min.y,
                _ => n.rect.max.y == r.max.y,
            })
            .map(|(_, n)| n.level)
            .max()
            .unwrap_or(0)
    }

    /// Memory held by the node arena, bytes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.free.capacity() * std::mem::size_of::<NodeId>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(c: DVec2, r: f64) -> Vec<DVec2> {
        (0..64)
            .map(|i| {
                let a = i as f64 / 64.0 * std::f64::consts::TAU;
                c + DVec2::new(a.cos(), a.sin()) * r
            })
            .collect()
    }

    #[test]
    fn boundary_leaves_reach_the_cap_and_restore_is_exact() {
        let mut map = UvMap::new(4);
        let before = map.clone();
        let e1 = map.update(&Region::new(vec![disc(DVec2::splat(0.5), 0.3)]), None, 4);
        let after_first = map.clone();
        for (_, n) in map.leaves() {
            if n.class == NodeClass::Boundary {
                assert_eq!(n.level, 4);
            }
        }
        let e2 = map.update(
            &Region::new(vec![
                disc(DVec2::splat(0.5), 0.3),
                disc(DVec2::splat(0.2), 0.1),
            ]),
            None,
            4,
        );
        map.restore(e2);
        assert_eq!(
            map.leaves().map(|(_, n)| *n).collect::<Vec<_>>(),
            after_first.leaves().map(|(_, n)| *n).collect::<Vec<_>>()
        );
        map.restore(e1);
        assert_eq!(
            map.leaves().map(|(_, n)| *n).collect::<Vec<_>>(),
            before.leaves().map(|(_, n)| *n).collect::<Vec<_>>()
        );
    }

    #[test]
    fn interior_nodes_are_not_subdivided() {
        let mut map = UvMap::new(8);
        map.update(&Region::new(vec![disc(DVec2::splat(0.5), 0.45)]), None, 3);
        let interior_root = map.node(map.root(4, 4));
        assert_eq!(interior_root.class, NodeClass::Interior);
        assert!(interior_root.children.is_none());
    }

    /// The largest level difference between two leaves sharing a stretch of side (not
    /// only a corner), across roots and, where the map wraps, across the seam.
    fn worst_step(map: &UvMap) -> u8 {
        let leaves: Vec<Node> = map.leaves().map(|(_, n)| *n).collect();
        let overlap = |a0: f64, a1: f64, b0: f64, b1: f64| a0.max(b0) < a1.min(b1);
        let mut worst = 0;
        for a in &leaves {
            for b in &leaves {
                let shares = |du: f64, dv: f64| {
                    let (bmin, bmax) = (
                        b.rect.min + DVec2::new(du, dv),
                        b.rect.max + DVec2::new(du, dv),
                    );
                    ((a.rect.max.x == bmin.x || a.rect.min.x == bmax.x)
                        && overlap(a.rect.min.y, a.rect.max.y, bmin.y, bmax.y))
                        || ((a.rect.max.y == bmin.y || a.rect.min.y == bmax.y)
                            && overlap(a.rect.min.x, a.rect.max.x, bmin.x, bmax.x))
                };
                let wrap_u = if map.wrap[0] {
                    vec![0.0, 1.0, -1.0]
                } else {
                    vec![0.0]
                };
                if wrap_u.iter().any(|&du| shares(du, 0.0)) {
                    worst = worst.max(a.level.abs_diff(b.level));
                }
            }
        }
        worst
    }

    /// Issue 20: the tree is balanced (2:1) from the outline's cap level down to the
    /// root grid, across root cells, across the u seam of a closed surface, and around
    /// a root with a deeper minimum level; without grading the same outline leaves
    /// steps of several levels.
    #[test]
    fn leaves_are_graded_two_to_one_across_roots_and_the_seam() {
        // A disc across the u seam (both halves), and a small one in the middle.
        let region = Region::new(vec![
            disc(DVec2::new(0.02, 0.5), 0.1),
            disc(DVec2::new(1.02, 0.5), 0.1),
            disc(DVec2::new(0.5, 0.3), 0.05),
        ]);
        let mut plain = UvMap::new(8);
        plain.set_wrap(true, false);
        let mut levels = vec![0; 64];
        levels[plain.root(5, 6) as usize] = 4;
        plain.set_min_levels(&levels);
        plain.update(&region, None, 5);
        assert_eq!(worst_step(&plain), 1);
        assert!(plain.leaves().any(|(_, n)| n.level == 5));
        assert!(plain.leaves().any(|(_, n)| n.level == 0));
        // The seam's two sides reach the cap together.
        let deepest_at = |u: f64| {
            plain
                .leaves()
                .filter(|(_, n)| n.rect.min.x == u || n.rect.max.x == u)
                .map(|(_, n)| n.level)
                .max()
        };
        assert_eq!(deepest_at(0.0), deepest_at(1.0));
        // Restore is still exact after graded updates.
        let before = plain.clone();
        let edit = plain.update(&Region::new(vec![disc(DVec2::splat(0.7), 0.2)]), None, 5);
        plain.restore(edit);
        assert_eq!(
            plain.leaves().map(|(_, n)| *n).collect::<Vec<_>>(),
            before.leaves().map(|(_, n)| *n).collect::<Vec<_>>()
        );
    }
}
