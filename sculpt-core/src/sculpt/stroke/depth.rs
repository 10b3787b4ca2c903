//! The depth field of a stroke and its gradient, for the tessellator and the normals.

use super::{CREASE_FRACTION, Stroke};
use glam::{DVec2, DVec3};

impl Stroke {
    /// The groove depth (carve) or ridge height (emboss) at the surface point `p = S(uv)`;
    /// zero outside the footprint. Always finite and non-negative.
    ///
    /// `uv` may lie in the square or in the unwrapped plane of [`Self::centre_uv`]: on a
    /// closed target the stroke is found from both sides of the seam (the depth is
    /// measured in 3D, so it is continuous across the seam).
    pub fn depth_at(&self, uv: DVec2, p: DVec3) -> f64 {
        self.deepest_segment(uv, p).0
    }

    /// [`Self::depth_at`] and the centreline segment that gives it (the first of the
    /// deepest; `None` where the depth is zero).
    pub fn deepest_segment(&self, uv: DVec2, p: DVec3) -> (f64, Option<usize>) {
        let mut best: f64 = 0.0;
        let mut segment = None;
        for &i in self.gradient_candidates(uv) {
            let d = self.segment_depth(i as usize, p);
            if d > best {
                best = d;
                segment = Some(i as usize);
            }
        }
        if best.is_finite() {
            (best, segment)
        } else {
            (0.0, None)
        }
    }

    /// [`Self::depth_at`] found from the 3D point alone, over every centreline segment
    /// (no parameter buckets): for a pole of the target, one point for a whole side of
    /// the square, which must get one depth whichever parameter it is reached from.
    pub fn depth_at_point(&self, p: DVec3) -> f64 {
        let best = (0..self.centre.len().saturating_sub(1))
            .map(|i| self.segment_depth(i, p))
            .fold(0.0, f64::max);
        if best.is_finite() { best } else { 0.0 }
    }

    /// The gradient (3D, depth per metre) of [`Self::depth_at`] at `p = S(uv)`, for the
    /// normals of the sculpted surface. The depth comes from one centreline segment:
    /// the one that gives the largest depth at `p` or, where `p` lies on the rim or just
    /// outside, at `toward`, a point inside the triangle being shaded. On the
    /// centreline (within [`CREASE_FRACTION`] of the half-width) the gradient is taken
    /// on `toward`'s side, as the limit from inside that triangle: across the segment
    /// in the plane of `normal`, the target's unit normal at `p`. Zero where neither
    /// point is in the footprint.
    pub fn depth_gradient(&self, uv: DVec2, p: DVec3, toward: DVec3, normal: DVec3) -> DVec3 {
        self.depth_gradient_from(self.gradient_segment(uv, p), uv, p, toward, normal)
    }

    /// The part of [`Self::depth_gradient`] that depends on the vertex alone (a mesher
    /// computes it once per vertex, not once per triangle): the centreline segment that
    /// gives `p = S(uv)` its largest depth or, on the rim, the nearest one in units of
    /// its half-width. `None` where `p` lies outside the footprint.
    pub fn gradient_segment(&self, uv: DVec2, p: DVec3) -> Option<usize> {
        if let (_, Some(i)) = self.deepest_segment(uv, p) {
            return Some(i);
        }
        // On the rim (depth 0), the segment nearest in units of its half-width.
        let mut best: Option<(f64, usize)> = None;
        for &i in self.gradient_candidates(uv) {
            let x = self.segment_reach(i as usize, p);
            if x.is_finite() && best.is_none_or(|b| x < b.0) {
                best = Some((x, i as usize));
            }
        }
        best.filter(|b| b.0 <= 1.0 + CREASE_FRACTION).map(|b| b.1)
    }

    /// [`Self::depth_gradient`] given `segment`, the [`Self::gradient_segment`] of
    /// `(uv, p)`: where that is `None`, the segment giving `toward` its largest depth.
    pub fn depth_gradient_from(
        &self,
        segment: Option<usize>,
        uv: DVec2,
        p: DVec3,
        toward: DVec3,
        normal: DVec3,
    ) -> DVec3 {
        let pick = |q: DVec3| {
            let mut best: Option<(f64, usize)> = None;
            for &i in self.gradient_candidates(uv) {
                let d = self.segment_depth(i as usize, q);
                if d > 0.0 && best.is_none_or(|b| d > b.0) {
                    best = Some((d, i as usize));
                }
            }
            best.map(|b| b.1)
        };
        match segment.or_else(|| pick(toward)) {
            Some(i) => self.segment_gradient(i, p, toward, normal),
            None => DVec3::ZERO,
        }
    }

    /// The centreline segments whose buckets hold `uv` (and its shifted copies).
    fn gradient_candidates(&self, uv: DVec2) -> impl Iterator<Item = &u32> + '_ {
        let [(u0, u1), (v0, v1)] = self.buckets.shifts(uv);
        (v0..=v1)
            .flat_map(move |kv| (u0..=u1).map(move |ku| DVec2::new(ku as f64, kv as f64)))
            .flat_map(move |k| self.buckets.candidates(uv + k))
    }

    /// The distance from `p` to segment `i` in units of its half-width there.
    fn segment_reach(&self, i: usize, p: DVec3) -> f64 {
        let (_, r, hw) = self.segment_foot(i, p);
        r / hw
    }

    /// Where `p` falls on segment `i`: the clamped parameter `t` of its foot, the
    /// distance `r` to the foot and the half-width `hw` interpolated there.
    fn segment_foot(&self, i: usize, p: DVec3) -> (f64, f64, f64) {
        let (a, b) = (self.centre[i], self.centre[i + 1]);
        let d = b - a;
        let l2 = d.length_squared();
        let t = if l2 > 0.0 {
            ((p - a).dot(d) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let hw = self.half_width[i] + (self.half_width[i + 1] - self.half_width[i]) * t;
        (t, p.distance(a + d * t), hw)
    }

    /// The gradient of segment `i`'s depth (see [`Self::segment_depth`]) at `p`, on
    /// `toward`'s side of the centreline where `p` lies on it.
    fn segment_gradient(&self, i: usize, p: DVec3, toward: DVec3, normal: DVec3) -> DVec3 {
        let (a, b) = (self.centre[i], self.centre[i + 1]);
        let d = b - a;
        let l2 = d.length_squared();
        let raw = if l2 > 0.0 { (p - a).dot(d) / l2 } else { 0.0 };
        let t = raw.clamp(0.0, 1.0);
        let interior = raw > 0.0 && raw < 1.0;
        let c = a + d * t;
        let (hw0, hw1) = (self.half_width[i], self.half_width[i + 1]);
        let (dep0, dep1) = (self.depth[i], self.depth[i + 1]);
        let hw = hw0 + (hw1 - hw0) * t;
        if hw.is_nan() || hw <= 0.0 {
            return DVec3::ZERO;
        }
        let dep = dep0 + (dep1 - dep0) * t;
        let r = p.distance(c);
        // Across the segment in the target's tangent plane: one direction per side of
        // the centreline, the same bits for every triangle on that side.
        let across = d.cross(normal).normalize_or_zero();
        let dir = if r > CREASE_FRACTION * hw {
            (p - c) / r
        } else {
            let w = toward - c;
            // Across the segment, unless `p` is beyond the stroke's tip (a cone there).
            let tip = (i == 0 && raw < 0.0) || (i + 2 == self.centre.len() && raw > 1.0);
            if tip || across == DVec3::ZERO {
                w.normalize_or_zero()
            } else if w.dot(across) >= 0.0 {
                across
            } else {
                -across
            }
        };
        let x = (r / hw).min(1.0);
        let profile = &self.tool.profile;
        let dt = if interior { d / l2 } else { DVec3::ZERO };
        // depth = dep(t) shape(r / hw(t)); r's gradient is `dir` (the foot moves along
        // the segment, perpendicular to p - c).
        let g = dt * ((dep1 - dep0) * profile.shape(x))
            + (dir / hw - dt * (r * (hw1 - hw0) / (hw * hw))) * (dep * profile.slope(x));
        if g.is_finite() { g } else { DVec3::ZERO }
    }

    /// The depth segment `i` of the centreline gives the point `p` (zero beyond its
    /// half-width).
    fn segment_depth(&self, i: usize, p: DVec3) -> f64 {
        let (t, r, hw) = self.segment_foot(i, p);
        if hw > 0.0 && r < hw {
            let dep = self.depth[i] + (self.depth[i + 1] - self.depth[i]) * t;
            dep * self.tool.profile.shape(r / hw)
        } else {
            0.0
        }
    }
}
