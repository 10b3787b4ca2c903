//! The chisel as an implicit solid: a stroke's swept profile.
//!
//! A stroke on a solid target keeps its wand samples and tool, as on a NURBS target.
//! Each sample is first moved onto the solid's surface along the gradient (Newton's
//! method on `omega(p) = 0`, `p <- p - omega grad / |grad|^2`, for a first-order
//! normalised omega one step from anywhere near the surface; Shin, Kim and Sheen 2007,
//! sec. 2.1.4), and the outward unit normal `n = -grad / |grad|` is kept there (omega is
//! positive inside, so its gradient points in).
//!
//! The tool solid is the union of one piece per polyline segment. For a point `p`,
//! `c` is its closest point on the segment, `n` the normal interpolated there, and in
//! the frame of the groove `v = (p - c) . n` (height above the surface; `-v` for an
//! emboss) and `l = |p - c - v n|` (distance across, rounded around `n` past the ends).
//! With half width `w`, depth `d` (tapered to 0 over the tool's taper at each end, as
//! the NURBS grooves are), the profile's shape `s(x)` (1 at the centre, 0 at the rim;
//! [`Profile::shape`]) and a cap `h` above the surface,
//!
//! `g = min(h - v, v + d s(l / w), w - l)`
//!
//! is positive exactly inside the groove's cross-section: below the surface down to
//! the profile, up to the cap, and no wider than the tool. The union of the segments'
//! pieces is their maximum (R_1, the min/max R-system of sec. 2.2.2); the target then
//! becomes `min(omega, -g)` (carve: AND NOT) or `max(omega, g)` (emboss: OR).

use glam::DVec3;

use super::SolidError;
use crate::implicit::tape::Tape;
use crate::sculpt::stroke::{Mode, Profile, StrokeInput};
use crate::tolerance::{SOLID_NEWTON_STEPS, SOLID_TOOL_BOUND_SLACK};

/// A stroke's tool as an implicit solid (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SweptTool {
    /// Carve (subtract) or emboss (add).
    pub mode: Mode,
    profile: Profile,
    half_width: f64,
    depth: f64,
    cap: f64,
    taper: f64,
    /// The samples on the surface (metres).
    points: Vec<DVec3>,
    /// Outward unit normals at the points.
    normals: Vec<DVec3>,
    /// Arc length at each point.
    arc: Vec<f64>,
    /// Box holding every point where [`Self::value`] is not `None`.
    lo: DVec3,
    hi: DVec3,
    /// How far from a segment its piece reaches (metres).
    reach: f64,
    /// Per segment (at its end's index less one): unit direction, length and a bound
    /// on `|n . direction|` over the normals interpolated along it
    /// ([`Self::along_above`]).
    axes: Vec<(DVec3, f64, f64)>,
}

impl SweptTool {
    /// The tool of `input` on the solid whose field (positive inside) `tape` computes.
    /// Every sample must lie within `snap` of the surface; `margin` widens the region
    /// where the tool is evaluated (a couple of grid cells, so that the field is the
    /// same as with the tool everywhere wherever the mesh reads it).
    pub fn new(
        tape: &Tape,
        input: &StrokeInput,
        snap: f64,
        margin: f64,
    ) -> Result<Self, SolidError> {
        input
            .tool
            .validate()
            .map_err(|e| SolidError::Tool(Box::new(e)))?;
        let mut points: Vec<DVec3> = Vec::with_capacity(input.samples.len());
        let mut normals = Vec::with_capacity(input.samples.len());
        for (index, &(_, p)) in input.samples.iter().enumerate() {
            let (on, n) = project(tape, p).ok_or(SolidError::NoNormal { index })?;
            let distance = on.distance(p);
            if distance.is_nan() || distance > snap {
                return Err(SolidError::OffSurface {
                    index,
                    distance,
                    max: snap,
                });
            }
            // Repeated positions add no segment.
            if points.last() != Some(&on) {
                points.push(on);
                normals.push(n);
            }
        }
        if points.len() < 2 {
            return Err(SolidError::TooFewSamples {
                count: points.len(),
            });
        }
        let mut arc = Vec::with_capacity(points.len());
        let mut s = 0.0;
        for (i, p) in points.iter().enumerate() {
            if i > 0 {
                s += p.distance(points[i - 1]);
            }
            arc.push(s);
        }
        let tool = &input.tool;
        let half_width = tool.width / 2.0;
        let cap = tool.depth.max(half_width);
        let reach = half_width.max(tool.depth).max(cap) + margin;
        let lo = points.iter().fold(DVec3::INFINITY, |a, p| a.min(*p)) - DVec3::splat(reach);
        let hi = points.iter().fold(DVec3::NEG_INFINITY, |a, p| a.max(*p)) + DVec3::splat(reach);
        let axes = (1..points.len())
            .map(|i| {
                let ab = points[i] - points[i - 1];
                let length = ab.length();
                let u = ab / length;
                let (n0, n1) = (normals[i - 1], normals[i]);
                // |(1 - t) n0 + t n1| >= sqrt((1 + n0 . n1) / 2) for unit n0, n1, and
                // the lerp's component along u lies between the ends'.
                let least = (0.5 * (1.0 + n0.dot(n1))).max(0.0).sqrt();
                let cosine = n0.dot(u).abs().max(n1.dot(u).abs());
                let bound = if least > 0.0 {
                    cosine / least
                } else {
                    f64::INFINITY
                };
                (u, length, bound)
            })
            .collect();
        Ok(Self {
            mode: tool.mode,
            profile: tool.profile.clone(),
            half_width,
            depth: tool.depth,
            cap,
            taper: tool.taper,
            points,
            normals,
            arc,
            lo,
            hi,
            reach,
            axes,
        })
    }

    /// The box outside which the tool leaves the field alone: `(lo, hi)`, metres.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    /// The samples moved onto the surface.
    pub fn points(&self) -> &[DVec3] {
        &self.points
    }

    /// The tool's function at `p` (positive inside the groove's cross-section), or
    /// `None` where no segment reaches (the field is then left alone).
    pub fn value(&self, p: DVec3) -> Option<f64> {
        if p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return None;
        }
        self.value_among(p, 1..self.points.len())
    }

    /// The segments (by their end's index) whose reach meets the box `lo..hi`: for
    /// every point of the box, [`Self::value_among`] over them equals [`Self::value`].
    pub fn segments_near(&self, lo: DVec3, hi: DVec3) -> Vec<usize> {
        (1..self.points.len())
            .filter(|&i| {
                let (a, b) = (self.points[i - 1], self.points[i]);
                let slo = a.min(b) - DVec3::splat(self.reach);
                let shi = a.max(b) + DVec3::splat(self.reach);
                slo.cmple(hi).all() && shi.cmpge(lo).all()
            })
            .collect()
    }

    /// [`Self::value`] over the segments `segments` only (ends' indices).
    pub fn value_among(&self, p: DVec3, segments: impl IntoIterator<Item = usize>) -> Option<f64> {
        let mut best: Option<f64> = None;
        for i in segments {
            if let Some(g) = self.piece(i, p) {
                best = Some(best.map_or(g, |b| b.max(g)));
            }
        }
        best
    }

    /// The piece `g` of segment `i` (its end's index) at `p` (see the module docs), or
    /// `None` outside the segment's reach box.
    fn piece(&self, i: usize, p: DVec3) -> Option<f64> {
        let (a, b) = (self.points[i - 1], self.points[i]);
        let lo = a.min(b) - DVec3::splat(self.reach);
        let hi = a.max(b) + DVec3::splat(self.reach);
        if p.cmplt(lo).any() || p.cmpgt(hi).any() {
            return None;
        }
        let length = self.arc.last().copied().unwrap_or(0.0);
        let ab = b - a;
        let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
        let c = a + ab * t;
        let n = self.normals[i - 1]
            .lerp(self.normals[i], t)
            .try_normalize()
            .unwrap_or(self.normals[i]);
        let q = p - c;
        let v = match self.mode {
            Mode::Carve => q.dot(n),
            Mode::Emboss => -q.dot(n),
        };
        let across = (q - n * q.dot(n)).length();
        let s = self.arc[i - 1] + t * (self.arc[i] - self.arc[i - 1]);
        let depth = self.depth * taper_factor(s, length, self.taper);
        Some(
            (self.cap - v)
                .min(v + depth * self.profile.shape(across / self.half_width))
                .min(self.half_width - across),
        )
    }

    /// The distance from `p` to segment `i` (its end's index).
    fn distance_to_segment(&self, i: usize, p: DVec3) -> f64 {
        let (a, b) = (self.points[i - 1], self.points[i]);
        let ab = b - a;
        let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
        p.distance(a + ab * t)
    }

    /// The most any piece can be: `g <= w - l <= w` and `g <= min(h - v, v + d) <=
    /// (h + d) / 2` (the shape is at most 1 and the taper only lowers `d`).
    fn ceiling(&self) -> f64 {
        self.half_width.min(0.5 * (self.cap + self.depth))
    }

    /// A radius `r(tau)` with: a piece above `tau` at `p` means `p` is closer than `r`
    /// to its segment. From the module docs' `g`, `g > tau` needs `l < w - tau` and
    /// `tau - d < v < h - tau`, and `|p - c|^2 = v^2 + l^2` (`n` is a unit vector), so
    /// `r^2 = max(w - tau, 0)^2 + max(|tau - d|, |h - tau|)^2`. Both terms are convex in
    /// `tau`, so over an interval of `tau` the largest `r` is at one of its ends.
    /// [`SOLID_TOOL_BOUND_SLACK`] is added for the rounding of the f64 arithmetic.
    fn radius_above(&self, tau: f64) -> f64 {
        let across = (self.half_width - tau).max(0.0);
        let height = self.height_above(tau);
        (across * across + height * height).sqrt() + SOLID_TOOL_BOUND_SLACK
    }

    /// The most `|v|` can be where a piece is above `tau`: `max(|tau - d|, |h - tau|)`.
    fn height_above(&self, tau: f64) -> f64 {
        (tau - self.depth).abs().max((self.cap - tau).abs())
    }

    /// How far `p` lies past the ends of segment `i` along it (0 beside it).
    fn beyond(&self, i: usize, p: DVec3) -> f64 {
        let (u, length, _) = self.axes[i - 1];
        let s = (p - self.points[i - 1]).dot(u);
        (-s).max(s - length).max(0.0)
    }

    /// A length `a_i(tau)` with: a piece of segment `i` above `tau` at `p` means `p`
    /// lies less than `a_i` past the segment's ends along it ([`Self::beyond`]). Where
    /// the closest point `c` is an end, `q = p - c` has `|q . u| = beyond` along the
    /// segment's direction `u`, and the distance across is
    /// `l = |q - n (q . n)| >= |q . u| - |v| |n . u|`; with `|n . u| <= e_i` (the
    /// interpolated normals' bound), `l < w - tau` and `|v| <` [`Self::height_above`],
    /// `beyond < max(w - tau, 0) + e_i max(|tau - d|, |h - tau|)`: convex in `tau`, like
    /// [`Self::radius_above`]. [`SOLID_TOOL_BOUND_SLACK`] is added for rounding.
    fn along_above(&self, i: usize, tau: f64) -> f64 {
        let bound = self.axes[i - 1].2;
        (self.half_width - tau).max(0.0) + bound * self.height_above(tau) + SOLID_TOOL_BOUND_SLACK
    }

    /// The maximum of the pieces of the segments `near` at `p` where it is above
    /// `tau` (`None` or at most `tau` otherwise): a segment is skipped when `p` lies
    /// outside either bound ([`Self::along_above`], [`Self::radius_above`]) of
    /// `beta = max(tau, best so far)` (its piece can neither change a value above
    /// `tau` nor raise the maximum), and the scan stops once `beta` reaches `ceiling`
    /// ([`Self::ceiling`]). NaN distances are evaluated.
    fn above(&self, p: DVec3, tau: f64, near: &[(f64, usize)], ceiling: f64) -> Option<f64> {
        let mut best: Option<f64> = None;
        let mut beta = tau;
        let (mut across, mut height) = ((self.half_width - beta).max(0.0), self.height_above(beta));
        let mut radius = self.radius_above(beta);
        for &(_, s) in near {
            if beta >= ceiling {
                break;
            }
            // along_above(s, beta), with the terms shared by every segment.
            let along = across + self.axes[s - 1].2 * height + SOLID_TOOL_BOUND_SLACK;
            if self.beyond(s, p) >= along || self.distance_to_segment(s, p) >= radius {
                continue;
            }
            if let Some(g) = self.piece(s, p) {
                best = Some(best.map_or(g, |b| b.max(g)));
                if g > beta {
                    beta = g;
                    across = (self.half_width - beta).max(0.0);
                    height = self.height_above(beta);
                    radius = self.radius_above(beta);
                }
            }
        }
        best
    }

    /// Combines this tool into the corner values `values` of a box of grid corners
    /// (`m` corners per axis, x fastest; `points` their positions): each becomes what
    /// `combine` of [`Self::value_among`] over every segment gives, bit for bit
    /// up to the sign of a zero, while the tool is evaluated only where it can change
    /// the value. Returns whether any value changed.
    ///
    /// A carve leaves `v` alone where `g <= -v`, an emboss where `g <= v` (the f32
    /// rounding of `g` is monotone and `v` is an f32), so with `tau = -v` (carve) or `v`
    /// (emboss) a segment matters at a corner only within `radius_above``(tau)`
    /// of it, and only less than `along_above``(tau)` past its ends along it.
    /// The box is split into sub-boxes of [`SUB_CORNERS`] corners a side; for each, the
    /// segments whose reach box meets it ([`Self::segments_near`]) are kept when the
    /// sub-box's nearest point may lie within both bounds at its extreme `tau` (the
    /// distances from its centre less its half diagonal), nearest first. A sub-box keeping none is left alone. At each corner of the rest a
    /// segment is skipped when the corner lies outside either bound of
    /// `max(tau, best so far)` (its piece can neither change the value nor raise the
    /// maximum past `tau`), and the scan stops once that exceeds `ceiling`. A
    /// corner whose value is NaN (the R-functions' "undefined") takes every kept segment.
    pub fn apply(&self, points: &[[f32; 3]], m: [usize; 3], values: &mut [f32]) -> bool {
        let tau = |v: f32| match self.mode {
            Mode::Carve => -f64::from(v),
            Mode::Emboss => f64::from(v),
        };
        let to_d = |p: [f32; 3]| DVec3::from(p.map(f64::from));
        let at = |i: usize, j: usize, k: usize| i + m[0] * (j + m[1] * k);
        let ceiling = self.ceiling();
        let mut changed = false;
        let mut near: Vec<(f64, usize)> = Vec::new();
        for z in sub_ranges(m[2]) {
            for y in sub_ranges(m[1]) {
                for x in sub_ranges(m[0]) {
                    let lo = to_d(points[at(x.start, y.start, z.start)]);
                    let hi = to_d(points[at(x.end - 1, y.end - 1, z.end - 1)]);
                    let candidates = self.segments_near(lo, hi);
                    if candidates.is_empty() {
                        continue;
                    }
                    let (mut t_lo, mut t_hi, mut nan) = (f64::INFINITY, f64::NEG_INFINITY, false);
                    for k in z.clone() {
                        for j in y.clone() {
                            for i in x.clone() {
                                let v = values[at(i, j, k)];
                                nan |= v.is_nan();
                                t_lo = t_lo.min(tau(v));
                                t_hi = t_hi.max(tau(v));
                            }
                        }
                    }
                    if !nan && t_lo >= ceiling {
                        continue;
                    }
                    let r_max = if nan {
                        f64::INFINITY
                    } else {
                        self.radius_above(t_lo).max(self.radius_above(t_hi))
                    };
                    let (centre, half) = ((lo + hi) / 2.0, lo.distance(hi) / 2.0);
                    near.clear();
                    near.extend(candidates.into_iter().filter_map(|s| {
                        let d = self.distance_to_segment(s, centre);
                        let a_max = if nan {
                            f64::INFINITY
                        } else {
                            self.along_above(s, t_lo).max(self.along_above(s, t_hi))
                        };
                        let past = self.beyond(s, centre) - half;
                        // NaN keeps the segment.
                        let may = !(d - half >= r_max || past >= a_max);
                        may.then_some((d, s))
                    }));
                    if near.is_empty() {
                        continue;
                    }
                    near.sort_by(|a, b| a.0.total_cmp(&b.0));
                    for k in z.clone() {
                        for j in y.clone() {
                            for i in x.clone() {
                                let c = at(i, j, k);
                                let p = to_d(points[c]);
                                let old = values[c];
                                let g = if old.is_nan() {
                                    self.value_among(p, near.iter().map(|s| s.1))
                                } else {
                                    self.above(p, tau(old), &near, ceiling)
                                };
                                super::combine(self.mode, g, &mut values[c]);
                                changed |= values[c].to_bits() != old.to_bits();
                            }
                        }
                    }
                }
            }
        }
        changed
    }
}

/// Corners a side of the sub-boxes [`SweptTool::apply`] bounds the tool over.
pub const SUB_CORNERS: usize = 4;

/// `0..m` cut into ranges of [`SUB_CORNERS`] (the last one shorter).
fn sub_ranges(m: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
    (0..m)
        .step_by(SUB_CORNERS)
        .map(move |s| s..(s + SUB_CORNERS).min(m))
}

/// 1 along the stroke, falling linearly to 0 over `taper` at each end.
fn taper_factor(s: f64, length: f64, taper: f64) -> f64 {
    if taper > 0.0 {
        (s / taper).min((length - s) / taper).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// `p` moved onto the zero set of `tape` (positive inside) by Newton steps along the
/// gradient, with the outward unit normal there; `None` where the gradient vanishes or
/// is not finite.
pub fn project(tape: &Tape, p: DVec3) -> Option<(DVec3, DVec3)> {
    let mut q = p;
    let mut normal = DVec3::ZERO;
    for _ in 0..SOLID_NEWTON_STEPS {
        let (f, g) = tape.eval_grad(q.as_vec3().to_array());
        let g = DVec3::from(g.map(f64::from));
        let len2 = g.length_squared();
        if !(len2 > 0.0 && len2.is_finite() && f.is_finite()) {
            return None;
        }
        normal = -g / len2.sqrt();
        q -= g * (f64::from(f) / len2);
    }
    q.is_finite().then_some((q, normal))
}
