//! Polygon helpers of the footprint (whole-period shifts, box clipping, the polygon
//! boolean on a fixed grid) and the segment buckets of the depth lookup.

use crate::sculpt::jordan::{Rect, Region, signed_area};
use glam::DVec2;
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;

/// On a closed target, the most whole-period copies per direction of a footprint piece
/// or a depth query (a stroke may wind round a torus a few times).
const MAX_PERIODS: i64 = 8;

/// Bounding rectangle of a non-empty polygon.
pub(super) fn bounds_of(poly: &[DVec2]) -> Rect {
    poly.iter().fold(Rect::new(poly[0], poly[0]), |r, &p| {
        Rect::new(r.min.min(p), r.max.max(p))
    })
}

/// The whole-period shifts (zero in open directions) that bring a copy of `rect` to
/// meet the closed unit square.
pub(super) fn period_shifts(rect: &Rect, closed: [bool; 2]) -> impl Iterator<Item = DVec2> + use<> {
    let (u0, u1) = whole_range(-rect.max.x, 1.0 - rect.min.x, closed[0]);
    let (v0, v1) = whole_range(-rect.max.y, 1.0 - rect.min.y, closed[1]);
    (v0..=v1).flat_map(move |kv| (u0..=u1).map(move |ku| DVec2::new(ku as f64, kv as f64)))
}

/// The whole numbers in `[a, b]`, at most [`MAX_PERIODS`], as an inclusive range;
/// `(0, 0)` in an open direction (`closed` false), empty when `a` or `b` is not finite.
fn whole_range(a: f64, b: f64, closed: bool) -> (i64, i64) {
    let (a, b) = (a.ceil(), b.floor());
    if !closed {
        (0, 0)
    } else if a.is_finite() && b.is_finite() {
        (a as i64, (b as i64).min(a as i64 + MAX_PERIODS - 1))
    } else {
        (0, -1)
    }
}

/// Sutherland-Hodgman clipping of a polygon against the box `[lo, hi]` (any simple or
/// self-touching polygon; the result may have zero-width spikes, which a non-zero fill
/// ignores). Keeps shifted pieces on the polygon boolean's grid (see
/// [`domain_overlay`]) without moving their part inside the square.
pub(super) fn clip_to_box(poly: &[DVec2], lo: DVec2, hi: DVec2) -> Vec<DVec2> {
    let mut out = poly.to_vec();
    // (axis, bound, keep-below)
    for (axis, bound, below) in [
        (0, lo.x, false),
        (0, hi.x, true),
        (1, lo.y, false),
        (1, hi.y, true),
    ] {
        let input = std::mem::take(&mut out);
        let inside = |p: DVec2| {
            if below {
                p[axis] <= bound
            } else {
                p[axis] >= bound
            }
        };
        let cut = |a: DVec2, b: DVec2| {
            let t = (bound - a[axis]) / (b[axis] - a[axis]);
            let mut p = a + (b - a) * t;
            p[axis] = bound;
            p
        };
        for (k, &b) in input.iter().enumerate() {
            let a = input[(k + input.len() - 1) % input.len()];
            match (inside(a), inside(b)) {
                (true, true) => out.push(b),
                (true, false) => out.push(cut(a, b)),
                (false, true) => {
                    out.push(cut(a, b));
                    out.push(b);
                }
                (false, false) => {}
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// The segments of an unwrapped polyline brought into the square (see
/// [`Stroke::centre_segments`]).
pub(super) fn wrapped_segments(line: &[DVec2], closed: [bool; 2]) -> Vec<[DVec2; 2]> {
    let mut out = Vec::with_capacity(line.len());
    let mut cuts: Vec<(f64, DVec2)> = Vec::new();
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        if a == b || !(a.is_finite() && b.is_finite()) {
            continue;
        }
        // Where a closed coordinate crosses a whole number, the point with that
        // coordinate exact.
        cuts.clear();
        cuts.push((0.0, a));
        cuts.push((1.0, b));
        for axis in 0..2 {
            if !closed[axis] || a[axis] == b[axis] {
                continue;
            }
            let (lo, hi) = (a[axis].min(b[axis]), a[axis].max(b[axis]));
            let mut m = lo.floor() + 1.0;
            while m < hi && cuts.len() < 16 {
                let t = (m - a[axis]) / (b[axis] - a[axis]);
                let mut p = a + (b - a) * t;
                p[axis] = m;
                cuts.push((t, p));
                m += 1.0;
            }
        }
        cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
        for c in cuts.windows(2) {
            let (p, q) = (c[0].1, c[1].1);
            if p == q {
                continue;
            }
            let mid = (p + q) * 0.5;
            let shift = DVec2::new(
                if closed[0] { -mid.x.floor() } else { 0.0 },
                if closed[1] { -mid.y.floor() } else { 0.0 },
            );
            out.push([p + shift, q + shift]);
        }
    }
    out
}

/// Converts i_overlay shapes into a [`Region`] (outer contours counter-clockwise, holes
/// clockwise).
pub fn region_from_shapes(shapes: Vec<Vec<Vec<[f64; 2]>>>) -> Region {
    let mut contours = Vec::new();
    for shape in shapes {
        for (k, c) in shape.into_iter().enumerate() {
            let mut c: Vec<DVec2> = c.into_iter().map(|p| DVec2::new(p[0], p[1])).collect();
            let a = signed_area(&c);
            if (k == 0) != (a > 0.0) {
                c.reverse();
            }
            contours.push(c);
        }
    }
    Region::new(contours)
}

/// Region contours in i_overlay's form.
pub fn region_to_contours(region: &Region) -> Vec<Vec<[f64; 2]>> {
    region
        .contours()
        .iter()
        .map(|c| c.iter().map(|p| [p.x, p.y]).collect())
        .collect()
}

/// Union of several regions (non-zero fill of their oriented contours).
pub fn union(regions: &[&Region]) -> Region {
    let subject: Vec<Vec<[f64; 2]>> = regions.iter().flat_map(|r| region_to_contours(r)).collect();
    if subject.is_empty() {
        return Region::empty();
    }
    region_from_shapes(domain_overlay(&subject, &[], OverlayRule::Subject))
}

/// A polygon boolean (non-zero fill) of contours in the parameter square, on one fixed
/// integer grid over `[-1, 2]^2` rather than one fitted to each input's bounds: a
/// vertex snaps to the same point whatever else takes part, so a union grown one
/// footprint at a time changes only where the new footprint is.
pub fn domain_overlay(
    subject: &[Vec<[f64; 2]>],
    clip: &[Vec<[f64; 2]>],
    rule: OverlayRule,
) -> Vec<Vec<Vec<[f64; 2]>>> {
    use i_overlay::core::overlay::ShapeType;
    use i_overlay::float::overlay::FloatOverlay;
    use i_overlay::i_float::adapter::FloatPointAdapter;
    use i_overlay::i_float::float::rect::FloatRect;
    let domain = FloatRect {
        min_x: -1.0,
        max_x: 2.0,
        min_y: -1.0,
        max_y: 2.0,
    };
    let adapter = FloatPointAdapter::<[f64; 2], i64>::new(domain);
    let count = subject.iter().chain(clip).map(Vec::len).sum();
    let mut overlay = FloatOverlay::with_adapter(adapter, count);
    // The grid covers [-1, 2]^2 only: keep every point on it (NaN to the centre).
    let on_grid = |x: f64| {
        if x.is_finite() {
            x.clamp(-1.0, 2.0)
        } else {
            0.5
        }
    };
    let inside = |c: &Vec<[f64; 2]>| {
        c.iter()
            .map(|p| [on_grid(p[0]), on_grid(p[1])])
            .collect::<Vec<_>>()
    };
    for c in subject {
        overlay = overlay.unsafe_add_contour(&inside(c), ShapeType::Subject);
    }
    for c in clip {
        overlay = overlay.unsafe_add_contour(&inside(c), ShapeType::Clip);
    }
    overlay.overlay(rule, FillRule::NonZero)
}

/// A uniform grid over the stroke's unwrapped bounds (centreline, rims and caps in the
/// plane of [`Stroke::centre_uv`]) listing the centreline segments near each cell, so
/// that [`Stroke::depth_at`] tests only a few segments. On a closed target a query is
/// also made at its copies shifted by whole periods ([`Self::shifts`]), so the stroke is
/// found from both sides of the seam.
#[derive(Debug, Clone)]
pub(super) struct Buckets {
    bounds: Rect,
    pub(super) closed: [bool; 2],
    n: usize,
    pub(super) cells: Vec<Vec<u32>>,
}

impl Buckets {
    pub(super) fn new(
        centre: &[DVec2],
        rims: &[Vec<DVec2>; 2],
        bounds: Rect,
        closed: [bool; 2],
    ) -> Self {
        let n = 32usize;
        let mut cells = vec![Vec::new(); n * n];
        let mut me = Self {
            bounds,
            closed,
            n,
            cells: Vec::new(),
        };
        for i in 0..centre.len().saturating_sub(1) {
            let mut lo = centre[i].min(centre[i + 1]);
            let mut hi = centre[i].max(centre[i + 1]);
            for rim in rims {
                lo = lo.min(rim[i]).min(rim[i + 1]);
                hi = hi.max(rim[i]).max(rim[i + 1]);
            }
            let pad = (hi - lo) * 0.25 + DVec2::splat(crate::tolerance::UV_PAD);
            let (a, b) = (me.cell_of(lo - pad), me.cell_of(hi + pad));
            for y in a.1..=b.1 {
                for x in a.0..=b.0 {
                    cells[y * n + x].push(i as u32);
                }
            }
        }
        me.cells = cells;
        me
    }

    fn pad(&self) -> DVec2 {
        (self.bounds.max - self.bounds.min) * 0.25 + DVec2::splat(crate::tolerance::UV_PAD)
    }

    fn cell_of(&self, p: DVec2) -> (usize, usize) {
        let size =
            (self.bounds.max - self.bounds.min).max(DVec2::splat(crate::tolerance::UV_EXTENT_MIN));
        let f = ((p - self.bounds.min) / size * self.n as f64).floor();
        let c = |x: f64| (x.max(0.0) as usize).min(self.n - 1);
        (c(f.x), c(f.y))
    }

    /// Per direction, the range of whole-period shifts `k` for which `uv + k` lies in
    /// the padded bounds (only `0` in an open direction).
    pub(super) fn shifts(&self, uv: DVec2) -> [(i64, i64); 2] {
        if self.closed == [false, false] {
            return [(0, 0); 2];
        }
        let pad = self.pad();
        let (lo, hi) = (self.bounds.min - pad, self.bounds.max + pad);
        [
            whole_range(lo.x - uv.x, hi.x - uv.x, self.closed[0]),
            whole_range(lo.y - uv.y, hi.y - uv.y, self.closed[1]),
        ]
    }

    pub(super) fn candidates(&self, uv: DVec2) -> &[u32] {
        let pad = self.pad();
        if !uv.is_finite()
            || uv.cmplt(self.bounds.min - pad).any()
            || uv.cmpgt(self.bounds.max + pad).any()
        {
            return &[];
        }
        let (x, y) = self.cell_of(uv);
        &self.cells[y * self.n + x]
    }
}
