//! The global certificate (step 6 of the module docs): proves a Newton answer global
//! from the leaves' distance nets, or finds the closer point the leaf runs missed.

use glam::{DVec2, DVec3};

use super::hierarchy::{LEAF, Leaf, STACK_LEN, to_frame};
use super::{Candidate, Certificate, Reached, SurfaceInverter, Visited, box_dist2};
use crate::nurbs::distance_net::{
    DistanceNets, MAX_SIDE, convex_bound_at, curve_clears, is_convex, monotone_side, net_min,
    side_net, split4,
};
use crate::tolerance::CERTIFY_TOL;
/// Subdivision depth of a leaf's net before the certificate settles for a Newton run.
const MAX_CERTIFY_DEPTH: u32 = 6;

/// Certificate rounds per query: each round that finds a closer point starts another
/// from it; the answer of the last round is left unproven.
const MAX_CERTIFY_ROUNDS: u32 = 4;

/// Net splits one certificate round may make before every patch left is settled by a
/// Newton run (bounds the work where the distance is nearly constant: a query near a
/// sphere's centre, or over a pole, where the parametrisation degenerates).
const MAX_CERTIFY_SPLITS: u32 = 16;

/// One certificate round: the query, the answer to beat, and the splits left.
struct Probe<'a> {
    p: DVec3,
    best: &'a Candidate,
    splits_left: std::cell::Cell<u32>,
    /// The exit that settled a sub-patch without proof, if one did.
    unproven: std::cell::Cell<Option<Certificate>>,
}

/// A (sub-)patch's net of `g` with its parameter box and clearing threshold.
#[derive(Clone, Copy)]
struct NetPatch<'a> {
    net: &'a [f64],
    /// Net rows and columns.
    size: (usize, usize),
    lo: DVec2,
    hi: DVec2,
    /// A coefficient at or above this proves nothing closer there (see
    /// `DistanceNets::query`).
    threshold: f64,
}

impl SurfaceInverter {
    /// The global certificate (see `distance_net`): proves that no point of the surface
    /// is closer to `p` than `best` by more than [`CERTIFY_TOL`], or finds one and
    /// starts again from it.
    ///
    /// A leaf's Newton run finds one local minimum; when a sub-patch holds two (a query
    /// near a centre of curvature), the other can be the global one. For every leaf whose
    /// box could still hold a closer point, the Bernstein net of
    /// `g = w^2 (|S - P|^2 - |S* - P|^2)` decides: no negative coefficient proves the
    /// leaf clear; a net monotone across the box leaves its minimum on one side, whose
    /// own net (a curve's) decides the same way; a convex `g` is cleared by its tangent
    /// plane at the answer (or at the box's own Newton minimum, which is the closer
    /// point if there is one); otherwise
    /// the net is split in four and each quarter is decided the same way, down to
    /// [`MAX_CERTIFY_DEPTH`] levels, where a bounded Newton run has the last word.
    ///
    /// Returns the answer with how it was obtained: [`Certificate::Certified`], or the
    /// exit that left it unproven (a Newton run had the last word, the rounds ran out,
    /// or the surface has no nets).
    pub(super) fn certify(
        &self,
        p: DVec3,
        mut best: Candidate,
        solved: &Visited,
    ) -> (Candidate, Certificate) {
        let Some(nets) = &self.nets else {
            return (best, self.no_nets);
        };
        for _ in 0..MAX_CERTIFY_ROUNDS {
            let probe = Probe {
                p,
                best: &best,
                splits_left: std::cell::Cell::new(MAX_CERTIFY_SPLITS),
                unproven: std::cell::Cell::new(None),
            };
            let Some(closer) = self.find_closer(nets, &probe, solved) else {
                let certificate = probe.unproven.get().unwrap_or(Certificate::Certified);
                return (best, certificate);
            };
            let iters = best.iters;
            best = self.polish(p, closer);
            best.iters += iters;
        }
        (best, Certificate::TooManyImprovements)
    }

    /// A point closer than `best` by more than [`CERTIFY_TOL`] in a leaf that cannot be
    /// cleared, or `None` when every leaf is cleared. Only the leaves the search reached
    /// can hold a closer point; when there were too many to record, the tree is walked.
    fn find_closer(
        &self,
        nets: &DistanceNets,
        probe: &Probe<'_>,
        visited: &Visited,
    ) -> Option<Candidate> {
        let (p, best) = (probe.p, probe.best);
        if !visited.overflow {
            return visited.leaves[..visited.len]
                .iter()
                .find_map(|&(index, what)| self.closer_in_leaf(nets, probe, index as usize, what));
        }
        let mut stack = [(self.root, 0.0f64); STACK_LEN];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (entry, bound) = stack[top];
            if bound >= best.dist2 {
                continue;
            }
            if entry & LEAF != 0 {
                let index = (entry & !LEAF) as usize;
                let found = self.closer_in_leaf(nets, probe, index, visited.get(index));
                if found.is_some() {
                    return found;
                }
                continue;
            }
            let node = &self.nodes[entry as usize];
            let d2 = node.child_dist2(p);
            for k in 0..2 {
                stack[top] = (node.child[k], d2[k]);
                top += 1;
            }
        }
        None
    }

    /// Decides one leaf, given what the search learnt of it.
    fn closer_in_leaf(
        &self,
        nets: &DistanceNets,
        probe: &Probe<'_>,
        index: usize,
        what: Reached,
    ) -> Option<Candidate> {
        let run = match what {
            Reached::Cleared => return None,
            Reached::Minimum(uv) => Some(uv),
            Reached::Open => None,
        };
        let (p, best) = (probe.p, probe.best);
        let leaf = &self.leaves[index];
        if box_dist2(to_frame(&leaf.frame, p), leaf.obb.0, leaf.obb.1) >= best.dist2 {
            return None;
        }
        // A convex leaf has one minimum: the answer, when it lies in the leaf, or the
        // one the search's run found in it. Either clears the leaf without a net.
        if best.converged
            && (run.is_some() || self.holds(leaf, best.uv))
            && nets.leaf_is_convex(index, p, best.dist2)
        {
            return None;
        }
        let (m1, n1) = nets.size();
        let mut buf = [0.0; MAX_SIDE * MAX_SIDE];
        let net = &mut buf[..m1 * n1];
        let threshold = nets.query(index, p, best.dist2, CERTIFY_TOL, net);
        let patch = NetPatch {
            net,
            size: (m1, n1),
            lo: leaf.uv_lo,
            hi: leaf.uv_hi,
            threshold,
        };
        self.closer_in_net(probe, &patch, run, 0)
    }

    /// `uv`, then its copies one period away in the closed directions (across a seam).
    fn copies(&self, uv: DVec2) -> impl Iterator<Item = DVec2> {
        let period = self.domain_hi - self.domain_lo;
        let shifts: &[f64] = if self.closed[0] || self.closed[1] {
            &[0.0, -1.0, 1.0]
        } else {
            &[0.0]
        };
        let closed = self.closed;
        shifts.iter().map(move |&shift| {
            let mut copy = uv;
            for k in 0..2 {
                if closed[k] {
                    copy[k] += shift * period[k];
                }
            }
            copy
        })
    }

    /// True when the leaf's parameter box holds `uv` (or its copy across a seam).
    pub(super) fn holds(&self, leaf: &Leaf, uv: DVec2) -> bool {
        let period = self.domain_hi - self.domain_lo;
        (0..2).all(|k| {
            let inside = |x: f64| x >= leaf.uv_lo[k] && x <= leaf.uv_hi[k];
            inside(uv[k])
                || (self.closed[k] && (inside(uv[k] + period[k]) || inside(uv[k] - period[k])))
        })
    }

    /// Decides one (sub-)patch with its net (see [`Self::certify`]); `hint` is a known
    /// minimum of the patch (the search's run in a leaf).
    fn closer_in_net(
        &self,
        probe: &Probe<'_>,
        patch: &NetPatch<'_>,
        hint: Option<DVec2>,
        depth: u32,
    ) -> Option<Candidate> {
        let NetPatch {
            net,
            size: (m1, n1),
            lo,
            hi,
            threshold,
        } = *patch;
        let (p, best) = (probe.p, probe.best);
        if net_min(net) >= threshold {
            return None;
        }
        let local = |uv: DVec2| ((uv - lo) / (hi - lo)).clamp(DVec2::ZERO, DVec2::ONE);
        // `g` monotone across the patch (a query beyond a domain edge, whose answer lies
        // on the edge): the side that holds its minimum decides, by its own net.
        if let Some(side) = monotone_side(net, m1, n1) {
            let mut edge = [0.0; MAX_SIDE];
            let len = side_net(net, m1, n1, side, &mut edge);
            let k = side.along();
            let at = self.copies(best.uv).chain(hint).map(|uv| local(uv)[k]);
            if curve_clears(&edge[..len], threshold, at) {
                return None;
            }
        }
        let convex = is_convex(net, m1, n1);
        if convex {
            // The tangent plane at the answer (or its copy across a seam), clamped into
            // the box, then at the patch's known minimum.
            for uv in self.copies(best.uv).chain(hint) {
                let st = local(uv);
                if convex_bound_at(net, m1, n1, st.x, st.y) >= threshold {
                    return None;
                }
            }
        }
        // Out of depth or of the query's split budget: a bounded Newton run decides.
        let last = depth >= MAX_CERTIFY_DEPTH || probe.splits_left.get() == 0;
        if convex || last {
            // The box's own minimum, from its smallest coefficient.
            let k = (0..m1 * n1)
                .min_by(|&a, &b| net[a].total_cmp(&net[b]))
                .unwrap_or(0);
            let st = DVec2::new(
                (k / n1) as f64 / (m1 - 1) as f64,
                (k % n1) as f64 / (n1 - 1) as f64,
            );
            let c = self.newton(p, lo + st * (hi - lo), lo, hi, [false; 2]);
            if c.dist2.sqrt() < best.dist2.sqrt() - CERTIFY_TOL {
                return Some(c);
            }
            let st = local(c.uv);
            if convex && convex_bound_at(net, m1, n1, st.x, st.y) >= threshold {
                return None;
            }
            if last {
                // Settled by the Newton run alone: no proof for this sub-patch.
                if probe.unproven.get().is_none() {
                    probe.unproven.set(Some(if depth >= MAX_CERTIFY_DEPTH {
                        Certificate::DepthCap
                    } else {
                        Certificate::SplitBudgetSpent
                    }));
                }
                return None;
            }
        }
        probe.splits_left.set(probe.splits_left.get() - 1);
        // Quarter nets on the stack, sized for bicubic patches when they fit.
        if m1 * n1 <= 49 {
            self.closer_in_quarters::<49>(probe, patch, depth)
        } else {
            self.closer_in_quarters::<{ MAX_SIDE * MAX_SIDE }>(probe, patch, depth)
        }
    }

    /// Splits a patch's net in four and decides each quarter, the lowest first. `L` is
    /// the length of the stack buffers (at least `m1 * n1`).
    fn closer_in_quarters<const L: usize>(
        &self,
        probe: &Probe<'_>,
        patch: &NetPatch<'_>,
        depth: u32,
    ) -> Option<Candidate> {
        let (lo, hi, (m1, n1)) = (patch.lo, patch.hi, patch.size);
        let mid = (lo + hi) * 0.5;
        let boxes = [
            (lo, mid),
            (DVec2::new(mid.x, lo.y), DVec2::new(hi.x, mid.y)),
            (DVec2::new(lo.x, mid.y), DVec2::new(mid.x, hi.y)),
            (mid, hi),
        ];
        let mut quarters = [[0.0; L]; 4];
        split4(patch.net, m1, n1, &mut quarters);
        let mut order = [0usize, 1, 2, 3];
        let mins = quarters.each_ref().map(|q| net_min(&q[..m1 * n1]));
        order.sort_unstable_by(|&a, &b| mins[a].total_cmp(&mins[b]));
        for q in order {
            let quarter = NetPatch {
                net: &quarters[q][..m1 * n1],
                lo: boxes[q].0,
                hi: boxes[q].1,
                ..*patch
            };
            let found = self.closer_in_net(probe, &quarter, None, depth + 1);
            if found.is_some() {
                return found;
            }
        }
        None
    }
}
