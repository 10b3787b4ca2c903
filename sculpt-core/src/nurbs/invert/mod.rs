//! Point inversion and closest points on surfaces (P&T section 6.1, eqs. 6.5 to 6.7).
//!
//! # How it works
//!
//! [`SurfaceInverter`] is built once per surface (`surface.inverter()`), and answers any
//! number of queries without re-tessellating:
//!
//! 1. **Cached bounding hierarchy.** The surface is split into Bezier patches (knot
//!    refinement, P&T A5.4), each patch is subdivided by de Casteljau into a few
//!    sub-patches (about 16 per surface length, at most 16 per span), and each sub-patch
//!    ("leaf") keeps the axis-aligned box of its control points and a thin oriented box
//!    in a frame fitted to it. Weights are positive, so the boxes contain the sub-patch
//!    (convex-hull property). A binary tree over the leaf grid holds the unions; each
//!    inner node stores its two children's boxes side by side, so one SSE2 pass gives
//!    both lower bounds.
//! 2. **Branch and bound.** A query walks the tree nearest box first and skips every box
//!    farther than the best distance found so far. The leaves it reaches are collected
//!    with the lower bound their oriented box gives, and their Bezier corners (surface
//!    points, so free upper bounds) tighten the best distance before any Newton run.
//!    The collected leaves are then solved in increasing order of their bound, stopping
//!    at the first bound no smaller than the best distance. Every skip compares a lower
//!    bound of a sub-patch's distance (convex hull) with the distance to a real surface
//!    point, so a closer point is never skipped.
//! 3. **Exclusion tests.** A leaf whose derivative cone shows that `(S - P) . S_u` (or
//!    `. S_v`) cannot vanish inside it holds no stationary point and is skipped (see
//!    `Leaf`); the domain corners are always candidates. Once a run has converged, a
//!    leaf whose distance net (step 6) has no coefficient below zero holds nothing
//!    closer and is skipped for good (most leaves after the first are such neighbours
//!    of the answer's leaf), and a leaf that holds the converged answer is left to the
//!    certificate (its run would only find the answer again).
//! 4. **Bounded Newton per leaf.** In each remaining leaf, Newton's method on
//!    `f(u,v) = |S(u,v) - P|^2 / 2` (the system of eq. 6.5 with the Jacobian of eq. 6.6,
//!    update eq. 6.7) runs inside the leaf's parameter box. When a step wants to leave
//!    the box, the variable that hits the bound is fixed there (an active set) and the
//!    iteration continues along the boundary curve, so minima on the edge of the
//!    domain, and corners, are found exactly. A halving line search keeps every step
//!    descending, and an indefinite Hessian is shifted to positive definite.
//!    The start is the nearest point of the bilinear patch through the leaf's corners.
//!    A run that stops on its leaf's edge (the minimum lies beyond) goes on with Newton
//!    on the whole domain from there; the leaf holding that minimum is then left to the
//!    certificate.
//!    Leaves on a domain edge whose interior holds no stationary point run Newton along
//!    that edge alone, unless the box of that side (its Bezier control points) is no
//!    closer than the best distance. A leaf that holds two local minima (one on a domain
//!    edge, say) needs no second run: the certificate finds the other one. Each Newton
//!    step evaluates `S` and its derivatives from the Bezier
//!    patches converted once to power form (`power.rs`): a few Horner sweeps, with no
//!    span search and no basis-function divisions.
//! 5. **Polish.** A last Newton run on the whole domain starts from the best leaf answer;
//!    in closed directions (the seam of a sphere or torus) it wraps around instead of
//!    stopping at the seam.
//! 6. **Global certificate.** A Newton run finds *a* local minimum of its leaf; a query
//!    near a centre of curvature can see two in one leaf, and the farther one may be the
//!    one found. So the answer is proven global, or beaten: for every leaf the search
//!    reached whose box could still hold a closer point, `g = w^2 (|S - P|^2 - d*^2)`
//!    must be `>= 0`. A leaf whose `g` is convex (an O(1) test from precomputed bounds
//!    of its second differences) has one minimum, the answer or its own run's, and is
//!    cleared at once; otherwise the Bernstein net of `g` (`distance_net.rs`) clears it
//!    when no coefficient is negative; or when the net rises monotonically away from one
//!    side (a query beyond a domain edge) and that side's net, a curve's, clears it;
//!    or when the net is convex and its tangent plane at the answer stays above zero;
//!    or else it is split in four, up to `MAX_CERTIFY_DEPTH` levels, where a bounded
//!    Newton run from the lowest coefficient decides. A closer point found on the way becomes the answer and the certificate
//!    runs again. Points closer by less than `CERTIFY_TOL` (1e-10 m) are not sought.
//!
//! Stopping rules are P&T's: point coincidence `|S - P| <= POINT_EPS` (criterion 1),
//! zero cosine `|S_u . (S - P)| <= COSINE_EPS |S_u| |S - P|` and the same for `v`
//! (criterion 2, on the directions not held at a bound; also met when the tangential
//! residual `|S_u . (S - P)| / |S_u|` is below `POINT_EPS / 1000`, where `|S - P|` is too
//! small for the cosine to resolve), and a full Newton step that moves the point by
//! less than `POINT_EPS` (criterion 3).
//!
//! Poles (an edge collapsed to a point, where `S_u` or `S_v` vanishes) need nothing
//! special: a vanishing derivative satisfies its cosine test, and the shifted Hessian
//! keeps the step finite.

// The book's algorithms index arrays by span offsets; keeping its loops keeps the
// code checkable against the book.
#![allow(clippy::needless_range_loop)]

mod certify;
mod curve;
mod hierarchy;
mod newton;
mod search;
#[cfg(test)]
mod tests;

use glam::{DVec2, DVec3};

use super::distance_net::DistanceNets;
use super::power::PowerPatches;
use super::surface::{NurbsSurface, SurfaceDerivs};

pub use curve::CurveProjection;
use hierarchy::{LEAF, Leaf, Node, SideBoxes};

/// The answer to a closest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// The parameter `(u, v)` of the closest point found, in the surface's **knot
    /// domain** ([`NurbsSurface::domain_u`] x [`NurbsSurface::domain_v`]), the
    /// parameter [`NurbsSurface::derivatives`] takes. Sculpting's
    /// [`TargetProjection`](crate::sculpt::surface::TargetProjection) maps it into the
    /// normalised square.
    pub uv_in_knots: DVec2,
    /// `S(u, v)`.
    pub point: DVec3,
    /// `|S(u, v) - P|`.
    pub distance: f64,
    /// Newton iterations spent on this query (all runs together).
    pub iterations: u32,
    /// True when the final Newton run stopped by one of P&T's criteria (rather than by
    /// the iteration cap or a stalled line search).
    pub converged: bool,
    /// True when `uv_in_knots` lies on an edge of the domain that is not a seam.
    pub on_boundary: bool,
    /// How the answer was obtained: proven global, or which exit left it unproven.
    pub certificate: Certificate,
}

/// How a [`Projection`] was obtained: [`Certificate::Certified`] when the Bernstein-net
/// certificate proved that no point of the surface is closer (by more than
/// `CERTIFY_TOL`, 1e-10 m), otherwise the exit that left the answer unproven. An
/// unproven answer is still the best point the search found, usually the true one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Certificate {
    /// Proven global: every leaf that could hold a closer point was cleared by its
    /// distance net (or its convexity, or its one-sided net).
    Certified,
    /// The certificate round spent its split budget (`MAX_CERTIFY_SPLITS` net
    /// splits): a sub-patch was settled by a bounded Newton run, which proves nothing.
    SplitBudgetSpent,
    /// A sub-patch was split down to `MAX_CERTIFY_DEPTH` levels and settled by a
    /// bounded Newton run, which proves nothing.
    DepthCap,
    /// The certificate found a closer point `MAX_CERTIFY_ROUNDS` times in a row; the
    /// last one was not certified in turn.
    TooManyImprovements,
    /// A degree above 5 in `u` or `v`: the nets (degree `2p x 2q`) are not built.
    DegreeAboveFive,
    /// More than `MAX_NET_COEFFICIENTS` (2^20) net coefficients: the nets are not
    /// built.
    TooManyNetCoefficients,
    /// The surface could not be split into Bezier patches: no nets (never happens for
    /// a valid surface).
    NoBezierForm,
    /// A local answer by request ([`SurfaceInverter::newton_from`]): no global search.
    Local,
    /// A non-finite query point (or seed of [`SurfaceInverter::newton_from`]): no
    /// answer, `distance` is infinite.
    InvalidQuery,
}

impl Certificate {
    /// Every kind, in declaration order (for counting them).
    pub const ALL: [Certificate; 9] = [
        Certificate::Certified,
        Certificate::SplitBudgetSpent,
        Certificate::DepthCap,
        Certificate::TooManyImprovements,
        Certificate::DegreeAboveFive,
        Certificate::TooManyNetCoefficients,
        Certificate::NoBezierForm,
        Certificate::Local,
        Certificate::InvalidQuery,
    ];

    /// True only for [`Certificate::Certified`].
    pub fn is_certified(self) -> bool {
        self == Certificate::Certified
    }
}

/// A Newton run's result.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    uv: DVec2,
    point: DVec3,
    dist2: f64,
    iters: u32,
    converged: bool,
    /// The run ended on a bound of its box that lies inside the domain (a leaf edge):
    /// a constrained answer of the leaf, not a stationary point of the surface.
    on_leaf_edge: bool,
}

impl Candidate {
    /// Takes the surface point `point = S(uv)` as the answer when it is closer to `p`
    /// (a corner: not a stationary point, so the final polish runs from it).
    #[inline]
    fn offer_point(&mut self, uv: DVec2, point: DVec3, p: DVec3) {
        let dist2 = point.distance_squared(p);
        if dist2 < self.dist2 {
            *self = Candidate {
                uv,
                point,
                dist2,
                iters: self.iters,
                converged: false,
                on_leaf_edge: true,
            };
        }
    }
}

/// What the search learnt of one leaf it reached.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Reached {
    /// No interior minimum: the leaf was not solved, or its run did not converge inside.
    Open,
    /// The interior minimum the leaf's Newton run converged to.
    Minimum(DVec2),
    /// Its distance net proved that no point of the leaf is closer than the best
    /// distance at the time, less [`CERTIFY_TOL`](crate::tolerance::CERTIFY_TOL). The best distance only decreases, so
    /// the proof stands for the final answer: the certificate skips the leaf.
    Cleared,
}

/// The leaves one query's search reached (those whose boxes could hold a point closer
/// than the best so far), with what the search learnt of each. The certificate only
/// needs these leaves: every other one was skipped by a lower bound no smaller than a
/// real surface point's distance. A leaf whose net is convex is cleared by its tangent
/// plane at the recorded minimum, with no new run.
#[derive(Debug, Clone, Copy)]
struct Visited {
    leaves: [(u32, Reached); 16],
    len: usize,
    /// More leaves were reached than recorded: the certificate walks the tree instead.
    overflow: bool,
}

impl Visited {
    fn new() -> Self {
        Self {
            leaves: [(0, Reached::Open); 16],
            len: 0,
            overflow: false,
        }
    }

    fn reach(&mut self, leaf: u32) {
        if self.len < self.leaves.len() {
            self.leaves[self.len] = (leaf, Reached::Open);
            self.len += 1;
        } else {
            self.overflow = true;
        }
    }

    fn record(&mut self, leaf: usize, what: Reached) {
        if let Some(entry) = self.leaves[..self.len]
            .iter_mut()
            .rev()
            .find(|e| e.0 as usize == leaf)
        {
            entry.1 = what;
        }
    }

    fn get(&self, leaf: usize) -> Reached {
        self.leaves[..self.len]
            .iter()
            .find(|e| e.0 as usize == leaf)
            .map_or(Reached::Open, |e| e.1)
    }
}

/// Cached acceleration structure for closest-point queries on one surface.
///
/// Owns a copy of the surface, so it can be stored next to it freely.
#[derive(Debug, Clone)]
pub struct SurfaceInverter {
    surface: NurbsSurface,
    /// Inner nodes of the tree; the walk starts at `root`.
    nodes: Vec<Node>,
    /// Node 0, or [`LEAF`] `|` 0 when the tree is one leaf.
    root: u32,
    leaves: Vec<Leaf>,
    /// The side boxes of each leaf (kept apart: only edge leaves read them).
    sides: Vec<SideBoxes>,
    domain_lo: DVec2,
    domain_hi: DVec2,
    closed: [bool; 2],
    /// The four domain corners and their points.
    corners: [(DVec2, DVec3); 4],
    /// The Bezier patches in power form, for fast Newton steps (`None` only when the
    /// Bezier form is unavailable or too big; B-spline evaluation is used then).
    power: Option<PowerPatches>,
    /// The distance nets of the leaves, for the global certificate (`None` for degrees
    /// above 5 or very big surfaces, see [`hierarchy::MAX_NET_COEFFICIENTS`]).
    nets: Option<DistanceNets>,
    /// Why `nets` is `None` (the certificate every answer then carries).
    no_nets: Certificate,
}

fn box_dist2(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
}

impl NurbsSurface {
    /// Builds the cached closest-point structure for this surface.
    pub fn inverter(&self) -> SurfaceInverter {
        SurfaceInverter::new(self)
    }

    /// [`SurfaceInverter::newton_from`] without building the inverter's hierarchy and
    /// certificate nets: a local closest point (P&T eq. 6.6 with its stopping
    /// criteria), for a caller that asks one surface only a few local questions.
    pub fn newton_closest(&self, p: DVec3, seed_uv: DVec2) -> Projection {
        SurfaceInverter::unbuilt(self).newton_from(p, seed_uv)
    }
}

impl SurfaceInverter {
    /// Builds the bounding hierarchy (see the module docs). Cost: one knot refinement
    /// and a de Casteljau subdivision; a few microseconds for a bicubic 6x6 patch.
    pub fn new(surface: &NurbsSurface) -> Self {
        let mut inv = Self::unbuilt(surface);
        inv.build();
        inv
    }

    /// The inverter's fields without the hierarchy: enough for local Newton only.
    fn unbuilt(surface: &NurbsSurface) -> Self {
        let (u0, u1) = surface.domain_u();
        let (v0, v1) = surface.domain_v();
        Self {
            surface: surface.clone(),
            nodes: Vec::new(),
            root: LEAF,
            leaves: Vec::new(),
            sides: Vec::new(),
            domain_lo: DVec2::new(u0, v0),
            domain_hi: DVec2::new(u1, v1),
            closed: [surface.is_closed_u(), surface.is_closed_v()],
            corners: [(u0, v0), (u0, v1), (u1, v0), (u1, v1)]
                .map(|(u, v)| (DVec2::new(u, v), surface.point(u, v))),
            power: None,
            nets: None,
            no_nets: Certificate::NoBezierForm,
        }
    }

    /// The surface this inverter answers for.
    pub fn surface(&self) -> &NurbsSurface {
        &self.surface
    }

    /// The power-form patches, when built.
    #[cfg(test)]
    pub(crate) fn power(&self) -> Option<&PowerPatches> {
        self.power.as_ref()
    }

    /// `S` and its derivatives to second order at `uv` (clamped into the domain).
    #[inline]
    fn derivs(&self, uv: DVec2) -> SurfaceDerivs {
        match &self.power {
            Some(pp) => pp.derivatives(uv),
            None => self.surface.derivatives(uv.x, uv.y),
        }
    }

    /// Number of leaf sub-patches in the hierarchy.
    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }
}

impl SurfaceInverter {
    /// The closest point of the surface to `p` (global: branch and bound over the
    /// cached hierarchy, then Newton; see the module docs).
    ///
    /// A non-finite `p` gives `distance = f64::INFINITY`, `converged = false` and the
    /// domain's first corner: never NaN.
    pub fn closest_point(&self, p: DVec3) -> Projection {
        if !p.is_finite() {
            return self.invalid_query();
        }
        let mut solved = Visited::new();
        let best = self.search(p, None, &mut solved);
        self.finish(p, best, &solved)
    }

    /// Like [`Self::closest_point`], but first runs Newton from `seed_uv` (for example
    /// the previous sample of a stroke). The seed's answer bounds the search, so most of
    /// the hierarchy is skipped; the result is still the global closest point.
    pub fn closest_point_from(&self, p: DVec3, seed_uv: DVec2) -> Projection {
        if !p.is_finite() {
            return self.invalid_query();
        }
        let seed = if seed_uv.is_finite() {
            self.newton(p, seed_uv, self.domain_lo, self.domain_hi, self.closed)
        } else {
            self.newton(
                p,
                (self.domain_lo + self.domain_hi) * 0.5,
                self.domain_lo,
                self.domain_hi,
                self.closed,
            )
        };
        let mut solved = Visited::new();
        let best = self.search(p, Some(seed), &mut solved);
        self.finish(p, best, &solved)
    }

    /// Local Newton only, from `seed_uv`, on the whole domain (wrapping in closed
    /// directions): the fast path for tracking a point that moves a little. It finds a
    /// local minimum of the distance, which need not be the global one.
    pub fn newton_from(&self, p: DVec3, seed_uv: DVec2) -> Projection {
        if !p.is_finite() || !seed_uv.is_finite() {
            return self.invalid_query();
        }
        let c = self.newton(p, seed_uv, self.domain_lo, self.domain_hi, self.closed);
        self.to_projection(c, Certificate::Local)
    }

    /// Closest points for many query points, in parallel (rayon) when the `parallel`
    /// feature is on (the default). Output order matches input order.
    pub fn closest_points(&self, points: &[DVec3]) -> Vec<Projection> {
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            // One rayon task per chunk of queries (a few hundred microseconds of work)
            // keeps the scheduling overhead negligible and the cores balanced.
            const CHUNK: usize = 256;
            let mut out = vec![self.invalid_query(); points.len()];
            out.par_chunks_mut(CHUNK)
                .zip(points.par_chunks(CHUNK))
                .for_each(|(answers, queries)| {
                    for (a, &p) in answers.iter_mut().zip(queries) {
                        *a = self.closest_point(p);
                    }
                });
            out
        }
        #[cfg(not(feature = "parallel"))]
        {
            points.iter().map(|&p| self.closest_point(p)).collect()
        }
    }

    /// Closest points for consecutive samples of a stroke: each query is seeded with the
    /// previous answer ([`Self::closest_point_from`]).
    pub fn closest_points_along(&self, points: &[DVec3]) -> Vec<Projection> {
        let mut out: Vec<Projection> = Vec::with_capacity(points.len());
        for &p in points {
            let pr = match out.last() {
                Some(prev) if prev.distance.is_finite() => {
                    self.closest_point_from(p, prev.uv_in_knots)
                }
                _ => self.closest_point(p),
            };
            out.push(pr);
        }
        out
    }

    fn invalid_query(&self) -> Projection {
        let uv = self.domain_lo;
        Projection {
            uv_in_knots: uv,
            point: self.surface.point_uv(uv),
            distance: f64::INFINITY,
            iterations: 0,
            converged: false,
            on_boundary: true,
            certificate: Certificate::InvalidQuery,
        }
    }

    fn to_projection(&self, c: Candidate, certificate: Certificate) -> Projection {
        let eps = crate::tolerance::DOMAIN_EDGE_REL * (self.domain_hi - self.domain_lo);
        let on = |k: usize| {
            !self.closed[k]
                && (c.uv[k] <= self.domain_lo[k] + eps[k] || c.uv[k] >= self.domain_hi[k] - eps[k])
        };
        Projection {
            uv_in_knots: c.uv,
            point: c.point,
            distance: c.dist2.sqrt(),
            iterations: c.iters,
            converged: c.converged,
            on_boundary: on(0) || on(1),
            certificate,
        }
    }

    /// Polishes the best leaf answer on the whole domain, proves it global (or finds
    /// the closer point the leaf runs missed, see [`Self::certify`]) and converts it.
    fn finish(&self, p: DVec3, best: Candidate, solved: &Visited) -> Projection {
        let polished = self.polish(p, best);
        let (answer, certificate) = self.certify(p, polished, solved);
        self.to_projection(answer, certificate)
    }
}
