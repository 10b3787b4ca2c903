//! The Jordan (crossing-number) test and node-versus-outline classification.
//!
//! A [`Region`] is a set of closed, simple contours in the UV square (outer outlines and
//! holes alike); a point is inside when a ray from it crosses the contours an odd number
//! of times. The ray is `+u`, as in the paper; the half-open rule (an edge counts when
//! exactly one end lies strictly above the ray) makes vertices on the ray count once, so
//! the second `+v` ray the paper adds is not needed. Points within [`ON_EDGE_EPS`] of an
//! edge are reported as [`Location::OnBoundary`].
//!
//! ```
//! use glam::DVec2;
//! use sculpt_core::sculpt::jordan::{Location, NodeClass, Region, Rect};
//! let square = vec![DVec2::new(0.2, 0.2), DVec2::new(0.6, 0.2), DVec2::new(0.6, 0.6), DVec2::new(0.2, 0.6)];
//! let r = Region::new(vec![square]);
//! assert_eq!(r.locate(DVec2::new(0.4, 0.4)), Location::Inside);
//! assert_eq!(r.locate(DVec2::new(0.2, 0.4)), Location::OnBoundary);
//! assert_eq!(r.classify(Rect::new(DVec2::new(0.3, 0.3), DVec2::new(0.4, 0.4))), NodeClass::Interior);
//! assert_eq!(r.classify(Rect::new(DVec2::new(0.5, 0.5), DVec2::new(0.7, 0.7))), NodeClass::Boundary);
//! assert_eq!(r.classify(Rect::new(DVec2::new(0.7, 0.7), DVec2::new(0.9, 0.9))), NodeClass::Exterior);
//! ```

use glam::DVec2;

/// Distance (in normalised parameter units) within which a point counts as on an edge.
pub use crate::tolerance::ON_EDGE_EPS;

/// Number of horizontal bands of the segment index.
const BANDS: usize = 64;

/// Where a point lies relative to a region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// Strictly inside.
    Inside,
    /// Strictly outside.
    Outside,
    /// On an edge or vertex of an outline.
    OnBoundary,
}

/// Classification of a quadtree node against a region.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum NodeClass {
    /// Wholly outside every footprint: the target is drawn here.
    Exterior,
    /// An outline passes through the node: subdivided to the depth cap, then clipped.
    Boundary,
    /// Wholly inside a footprint: the target is hidden here.
    Interior,
}

/// An axis-aligned rectangle in UV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Lower-left corner.
    pub min: DVec2,
    /// Upper-right corner.
    pub max: DVec2,
}

impl Rect {
    /// A rectangle from its corners.
    pub fn new(min: DVec2, max: DVec2) -> Self {
        Self { min, max }
    }

    /// The rectangle's centre.
    pub fn centre(&self) -> DVec2 {
        (self.min + self.max) * 0.5
    }

    /// True when the rectangles overlap or touch.
    pub fn touches(&self, other: &Rect) -> bool {
        self.min.x <= other.max.x
            && other.min.x <= self.max.x
            && self.min.y <= other.max.y
            && other.min.y <= self.max.y
    }

    /// The bounding rectangle of a segment.
    pub fn of_segment(a: DVec2, b: DVec2) -> Self {
        Self::new(a.min(b), a.max(b))
    }

    /// True when the closed segment `a-b` meets this closed rectangle.
    pub fn meets_segment(&self, a: DVec2, b: DVec2) -> bool {
        if !self.touches(&Rect::of_segment(a, b)) {
            return false;
        }
        if self.contains(a) || self.contains(b) {
            return true;
        }
        // Liang-Barsky: clip the parameter interval against the four slabs.
        let d = b - a;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-d.x, a.x - self.min.x),
            (d.x, self.max.x - a.x),
            (-d.y, a.y - self.min.y),
            (d.y, self.max.y - a.y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        t0 <= t1
    }

    /// True when `p` lies in the closed rectangle.
    pub fn contains(&self, p: DVec2) -> bool {
        p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y
    }
}

/// A set of closed contours with a segment index for fast queries.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Region {
    contours: Vec<Vec<DVec2>>,
    segments: Vec<[DVec2; 2]>,
    bands: Vec<Vec<u32>>,
    bounds: Option<Rect>,
}

impl Region {
    /// A region from closed contours (the last point joins the first). Contours with
    /// fewer than three points or non-finite coordinates are dropped.
    pub fn new(contours: Vec<Vec<DVec2>>) -> Self {
        let contours: Vec<Vec<DVec2>> = contours
            .into_iter()
            .filter(|c| c.len() >= 3 && c.iter().all(|p| p.is_finite()))
            .collect();
        let mut segments = Vec::new();
        for c in &contours {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                if a != b {
                    segments.push([a, b]);
                }
            }
        }
        let mut bands = vec![Vec::new(); BANDS];
        for (k, s) in segments.iter().enumerate() {
            let (lo, hi) = (band_of(s[0].y.min(s[1].y)), band_of(s[0].y.max(s[1].y)));
            for band in &mut bands[lo..=hi] {
                band.push(k as u32);
            }
        }
        let bounds = segments.iter().fold(None, |acc: Option<Rect>, s| {
            let r = Rect::of_segment(s[0], s[1]);
            Some(acc.map_or(r, |a| Rect::new(a.min.min(r.min), a.max.max(r.max))))
        });
        Self {
            contours,
            segments,
            bands,
            bounds,
        }
    }

    /// The empty region.
    pub fn empty() -> Self {
        Self::new(Vec::new())
    }

    /// The bounding rectangle of the outline (`None` when empty).
    pub fn bounds(&self) -> Option<Rect> {
        self.bounds
    }

    /// True when the region has no contours.
    pub fn is_empty(&self) -> bool {
        self.contours.is_empty()
    }

    /// The contours.
    pub fn contours(&self) -> &[Vec<DVec2>] {
        &self.contours
    }

    /// All edges as segments.
    pub fn segments(&self) -> &[[DVec2; 2]] {
        &self.segments
    }

    /// Crossing-number point location (see the module docs).
    pub fn locate(&self, p: DVec2) -> Location {
        if !p.is_finite() {
            return Location::Outside;
        }
        let mut inside = false;
        for &k in &self.bands[band_of(p.y)] {
            let [a, b] = self.segments[k as usize];
            // A segment wholly left of `p`, or wholly above or below it, neither
            // crosses the ray to +u nor passes within the edge tolerance: skip it
            // before the distance (most of a band's segments, for a long stroke along u).
            if a.x.max(b.x) < p.x - ON_EDGE_EPS
                || a.y.min(b.y) > p.y + ON_EDGE_EPS
                || a.y.max(b.y) < p.y - ON_EDGE_EPS
            {
                continue;
            }
            if point_segment_distance(p, a, b) <= ON_EDGE_EPS {
                return Location::OnBoundary;
            }
            if (a.y > p.y) != (b.y > p.y) {
                let x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
                if x > p.x {
                    inside = !inside;
                }
            }
        }
        if inside {
            Location::Inside
        } else {
            Location::Outside
        }
    }

    /// True when an outline segment meets `rect` (edges included): the part of
    /// [`Self::classify`] that finds boundary rectangles, without locating the centre.
    pub fn meets_outline(&self, rect: Rect) -> bool {
        if !self.bounds.is_some_and(|b| b.touches(&rect)) {
            return false;
        }
        let (lo, hi) = (band_of(rect.min.y), band_of(rect.max.y));
        self.bands[lo..=hi].iter().any(|band| {
            band.iter().any(|&k| {
                let [a, b] = self.segments[k as usize];
                rect.meets_segment(a, b)
            })
        })
    }

    /// Classifies a node rectangle: boundary when an edge meets it, otherwise interior
    /// or exterior by the location of its centre.
    pub fn classify(&self, rect: Rect) -> NodeClass {
        if self.meets_outline(rect) {
            return NodeClass::Boundary;
        }
        if !self.bounds.is_some_and(|b| b.touches(&rect)) {
            return NodeClass::Exterior;
        }
        match self.locate(rect.centre()) {
            Location::Inside => NodeClass::Interior,
            Location::Outside => NodeClass::Exterior,
            Location::OnBoundary => NodeClass::Boundary,
        }
    }

    /// Signed area (counter-clockwise outer contours positive, holes negative).
    pub fn area(&self) -> f64 {
        self.contours.iter().map(|c| signed_area(c)).sum()
    }
}

fn band_of(y: f64) -> usize {
    let y = if y.is_finite() { y } else { 0.0 };
    ((y * BANDS as f64).floor().max(0.0) as usize).min(BANDS - 1)
}

/// Signed area of a closed polygon (shoelace).
pub fn signed_area(c: &[DVec2]) -> f64 {
    let n = c.len();
    (0..n).map(|i| c[i].perp_dot(c[(i + 1) % n])).sum::<f64>() * 0.5
}

/// Distance from `p` to the closed segment `a-b`.
pub fn point_segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let l2 = d.length_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + d * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::CLASSIFY_MARGIN;
    use proptest::prelude::*;

    fn square(c: DVec2, h: f64) -> Vec<DVec2> {
        vec![
            c + DVec2::new(-h, -h),
            c + DVec2::new(h, -h),
            c + DVec2::new(h, h),
            c + DVec2::new(-h, h),
        ]
    }

    #[test]
    fn vertex_on_ray_counts_once() {
        // A diamond whose left and right vertices lie on the ray through its centre.
        let d = vec![
            DVec2::new(0.5, 0.3),
            DVec2::new(0.7, 0.5),
            DVec2::new(0.5, 0.7),
            DVec2::new(0.3, 0.5),
        ];
        let r = Region::new(vec![d]);
        assert_eq!(r.locate(DVec2::new(0.5, 0.5)), Location::Inside);
        assert_eq!(r.locate(DVec2::new(0.1, 0.5)), Location::Outside);
        assert_eq!(r.locate(DVec2::new(0.7, 0.5)), Location::OnBoundary);
    }

    #[test]
    fn holes_are_outside() {
        let r = Region::new(vec![
            square(DVec2::splat(0.5), 0.4),
            square(DVec2::splat(0.5), 0.1),
        ]);
        assert_eq!(r.locate(DVec2::splat(0.5)), Location::Outside);
        assert_eq!(r.locate(DVec2::splat(0.2)), Location::Inside);
        assert_eq!(
            r.classify(Rect::new(DVec2::splat(0.45), DVec2::splat(0.55))),
            NodeClass::Exterior
        );
    }

    proptest! {
        // Inside a convex polygon exactly when on the inner side of every edge.
        #[test]
        fn crossing_matches_convex_half_planes(px in 0.0..1.0f64, py in 0.0..1.0f64, n in 3usize..12) {
            let c: Vec<DVec2> = (0..n).map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                DVec2::new(0.5 + 0.3 * a.cos(), 0.5 + 0.3 * a.sin())
            }).collect();
            let r = Region::new(vec![c.clone()]);
            let p = DVec2::new(px, py);
            let min_side = (0..n).map(|i| (c[(i + 1) % n] - c[i]).perp_dot(p - c[i])).fold(f64::INFINITY, f64::min);
            let loc = r.locate(p);
            if min_side > CLASSIFY_MARGIN { prop_assert_eq!(loc, Location::Inside); }
            if min_side < -CLASSIFY_MARGIN { prop_assert_eq!(loc, Location::Outside); }
        }

        #[test]
        fn never_panics_on_garbage(xs in proptest::collection::vec((-2.0..2.0f64, -2.0..2.0f64), 0..20), px in -1.0..2.0f64, py in -1.0..2.0f64) {
            let r = Region::new(vec![xs.iter().map(|&(x, y)| DVec2::new(x, y)).collect()]);
            let _ = r.locate(DVec2::new(px, py));
            let _ = r.classify(Rect::new(DVec2::new(px, py), DVec2::new(px + 0.1, py + 0.1)));
        }
    }
}
