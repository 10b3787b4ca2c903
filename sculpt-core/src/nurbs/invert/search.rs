//! Branch and bound over the hierarchy (steps 2 to 4 of the module docs): the nearest-box
//! tree walk, the exclusion tests, and the Newton runs of the leaves it keeps.

use glam::{DVec2, DVec3};

use super::hierarchy::{LEAF, Leaf, STACK_LEN, sign_is_fixed, to_frame};
use super::{Candidate, Reached, SurfaceInverter, Visited, box_dist2};
use crate::tolerance::CERTIFY_TOL;
impl SurfaceInverter {
    /// The closer of `start` and the domain corners. The corners are candidates of their
    /// own (a minimum there need not be a stationary point of any leaf), and they make a
    /// cheap first bound.
    fn best_corner(&self, p: DVec3, start: Option<Candidate>) -> Candidate {
        let mut best = start.unwrap_or(Candidate {
            uv: self.domain_lo,
            point: DVec3::ZERO,
            dist2: f64::INFINITY,
            iters: 0,
            converged: false,
            on_leaf_edge: true,
        });
        for &(uv, point) in &self.corners {
            best.offer_point(uv, point, p);
        }
        best
    }

    /// Branch and bound over the hierarchy; `start` is an optional starting answer.
    ///
    /// Two phases. The walk collects the leaves whose boxes could hold a closer point
    /// than the best so far, and tightens that bound on the way with the leaves' corner
    /// points (Bezier corners are surface points, so they cost no Newton run). Then the
    /// collected leaves are solved in increasing order of their lower bound, stopping at
    /// the first bound no smaller than the best answer. Every skip compares a lower bound
    /// of the distance to a sub-patch with the distance to a real surface point, so no
    /// closer point is ever skipped.
    pub(super) fn search(
        &self,
        p: DVec3,
        start: Option<Candidate>,
        solved: &mut Visited,
    ) -> Candidate {
        let mut best = self.best_corner(p, start);
        let mut iters = best.iters;
        // Leaves to solve: (lower bound of the squared distance, leaf index).
        let mut found = [(0.0f64, 0u32); 16];
        let mut n_found = 0;
        // Entries to visit with the lower bound of their squared distance.
        let mut stack = [(self.root, 0.0f64); STACK_LEN];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (entry, bound) = stack[top];
            if bound >= best.dist2 {
                continue;
            }
            if entry & LEAF != 0 {
                let index = entry & !LEAF;
                let leaf = &self.leaves[index as usize];
                let p_local = to_frame(&leaf.frame, p);
                let bound = box_dist2(p_local, leaf.obb.0, leaf.obb.1);
                if bound >= best.dist2 {
                    continue;
                }
                let [c00, c10, c01, c11] = leaf.corners;
                let (lo, hi) = (leaf.uv_lo, leaf.uv_hi);
                best.offer_point(lo, c00, p);
                best.offer_point(DVec2::new(hi.x, lo.y), c10, p);
                best.offer_point(DVec2::new(lo.x, hi.y), c01, p);
                best.offer_point(hi, c11, p);
                found[n_found] = (bound, index);
                n_found += 1;
                solved.reach(index);
                if n_found == found.len() {
                    self.solve_leaves(p, &mut found, &mut best, &mut iters, solved);
                    n_found = 0;
                }
                continue;
            }
            let node = &self.nodes[entry as usize];
            let d2 = node.child_dist2(p);
            // Push the farther child first so the nearer one is examined first; a child
            // no nearer than the best point so far is written but not kept. Branch-free:
            // which child is nearer is a coin toss to the branch predictor. The stack
            // holds at most one entry per level of the tree plus one (`STACK_LEN`).
            let nearer = usize::from(d2[1] < d2[0]);
            for k in [1 - nearer, nearer] {
                stack[top] = (node.child[k], d2[k]);
                top += usize::from(d2[k] < best.dist2);
            }
        }
        self.solve_leaves(p, &mut found[..n_found], &mut best, &mut iters, solved);
        best.iters = iters;
        best
    }

    /// Runs the leaf Newton searches for the collected `leaves` (bound, index), nearest
    /// bound first, while a bound is below the best distance.
    fn solve_leaves(
        &self,
        p: DVec3,
        leaves: &mut [(f64, u32)],
        best: &mut Candidate,
        iters: &mut u32,
        solved: &mut Visited,
    ) {
        leaves.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for &(bound, index) in leaves.iter() {
            if bound >= best.dist2 {
                break;
            }
            if best.converged {
                // A leaf that holds a stationary answer (the seed's, or one on a shared
                // side) would only find it again: the certificate decides the leaf.
                if !best.on_leaf_edge && self.holds(&self.leaves[index as usize], best.uv) {
                    continue;
                }
                // Most leaves left are neighbours of the answer's leaf with nothing
                // closer in them: the distance net proves that with one dot product per
                // coefficient, more cheaply than their Newton runs.
                if self.net_clears(p, index as usize, best.dist2) {
                    solved.record(index as usize, Reached::Cleared);
                    continue;
                }
            }
            let before = best.dist2;
            if let Some(uv) = self.solve_leaf(p, index as usize, best, iters, true) {
                solved.record(index as usize, Reached::Minimum(uv));
            }
            // The leaf's run stopped on its edge: the minimum lies beyond, usually in the
            // next leaf. Newton on the whole domain goes on from there, more cheaply
            // than that leaf's own run from its bilinear start; the leaf is then left
            // to the certificate, as it holds the answer.
            if best.on_leaf_edge && best.dist2 < before {
                let c = self.newton(p, best.uv, self.domain_lo, self.domain_hi, self.closed);
                *iters += c.iters;
                if c.dist2 < best.dist2 {
                    *best = c;
                }
            }
        }
    }

    /// True when the leaf's distance net has no coefficient below its threshold: no
    /// point of the leaf is closer to `p` than `sqrt(f_star) - CERTIFY_TOL`.
    fn net_clears(&self, p: DVec3, index: usize, f_star: f64) -> bool {
        let Some(nets) = &self.nets else {
            return false;
        };
        let (low, threshold) = nets.query_min(index, p, f_star, CERTIFY_TOL);
        low >= threshold
    }

    /// The Newton runs of one leaf: its interior (when the exclusion test allows a
    /// stationary point there), and each side on a domain edge that could be closer than
    /// `best`. With `prune` false, every run is made (the reference the tests compare
    /// the pruned search with).
    fn solve_leaf(
        &self,
        p: DVec3,
        index: usize,
        best: &mut Candidate,
        iters: &mut u32,
        prune: bool,
    ) -> Option<DVec2> {
        let leaf = &self.leaves[index];
        let p_local = to_frame(&leaf.frame, p);
        let (r_lo, r_hi) = (leaf.obb.0 - p_local, leaf.obb.1 - p_local);
        let fixed_u = prune && sign_is_fixed(r_lo, r_hi, leaf.du);
        let fixed_v = prune && sign_is_fixed(r_lo, r_hi, leaf.dv);
        let mut interior_uv = None;
        let start = leaf.estimate(p);
        let ran_interior = !fixed_u && !fixed_v;
        if ran_interior {
            let c = self.newton(p, start, leaf.uv_lo, leaf.uv_hi, [false; 2]);
            *iters += c.iters;
            if c.converged {
                interior_uv = Some(c.uv);
            }
            let on_domain_edge = |uv: DVec2| {
                (0..2).any(|k| {
                    !self.closed[k] && (uv[k] <= self.domain_lo[k] || uv[k] >= self.domain_hi[k])
                })
            };
            let slid_along_edge = on_domain_edge(start) && on_domain_edge(c.uv);
            if c.dist2 < best.dist2 {
                *best = c;
            }
            // A start on a domain edge can stay on the edge, at a minimum of the edge, and
            // miss an interior minimum of the same leaf (both are local minima of the
            // domain): run again from the leaf's centre. With the certificate's nets
            // there is no need: it proves the leaf holds nothing closer, or finds it.
            if slid_along_edge && !(prune && self.nets.is_some()) {
                let centre = (leaf.uv_lo + leaf.uv_hi) * 0.5;
                let c = self.newton(p, centre, leaf.uv_lo, leaf.uv_hi, [false; 2]);
                *iters += c.iters;
                if c.dist2 < best.dist2 {
                    *best = c;
                }
            }
        }
        // Leaves on an edge of the domain also search that edge by itself: a minimum on
        // the boundary curve is then found even when the leaf's interior holds another
        // local minimum.
        for (side, (k, at_hi)) in [(0, false), (0, true), (1, false), (1, true)]
            .into_iter()
            .enumerate()
        {
            // Along a side u = const only v moves, so f_v must vanish there.
            let fixed = if k == 0 { fixed_v } else { fixed_u };
            if fixed || !self.edge_leaf(leaf, k, at_hi) {
                continue;
            }
            // No point of this side is closer than the best answer so far.
            let (side_lo, side_hi) = self.sides[index][side];
            if prune && box_dist2(p_local, side_lo, side_hi) >= best.dist2 {
                continue;
            }
            // The interior run already converged onto this very edge.
            let edge_value = if at_hi { leaf.uv_hi[k] } else { leaf.uv_lo[k] };
            if prune && interior_uv.is_some_and(|uv| uv[k] == edge_value) {
                continue;
            }
            // The interior run found the leaf's minimum, unless the leaf holds two; the
            // certificate's nets then find the other one.
            if prune && ran_interior && self.nets.is_some() {
                continue;
            }
            let (mut lo, mut hi) = (leaf.uv_lo, leaf.uv_hi);
            if at_hi {
                lo[k] = hi[k];
            } else {
                hi[k] = lo[k];
            }
            let c = self.newton(p, start, lo, hi, [false; 2]);
            *iters += c.iters;
            if c.dist2 < best.dist2 {
                *best = c;
            }
        }
        interior_uv
    }

    /// The closest point with no pruning at all: the domain corners, then every leaf's
    /// interior and domain-edge sides from its bilinear start, then the polish. Slow; the
    /// reference that proves the bounds of [`Self::search`] skip nothing.
    #[cfg(test)]
    pub(super) fn closest_point_exhaustive(&self, p: DVec3) -> super::Projection {
        let mut best = self.best_corner(p, None);
        let mut iters = 0;
        let mut solved = Visited::new();
        solved.overflow = true;
        for index in 0..self.leaves.len() {
            if let Some(uv) = self.solve_leaf(p, index, &mut best, &mut iters, false) {
                solved.record(index, Reached::Minimum(uv));
            }
        }
        best.iters = iters;
        self.finish(p, best, &solved)
    }

    /// True when the leaf's side `at_hi` in direction `k` lies on a domain edge that is
    /// not a seam.
    #[inline]
    fn edge_leaf(&self, leaf: &Leaf, k: usize, at_hi: bool) -> bool {
        !self.closed[k]
            && if at_hi {
                leaf.uv_hi[k] >= self.domain_hi[k]
            } else {
                leaf.uv_lo[k] <= self.domain_lo[k]
            }
    }
}
