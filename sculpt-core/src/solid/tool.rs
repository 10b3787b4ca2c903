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
use crate::tolerance::SOLID_NEWTON_STEPS;

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
        let length = self.arc.last().copied().unwrap_or(0.0);
        let mut best: Option<f64> = None;
        for i in segments {
            let (a, b) = (self.points[i - 1], self.points[i]);
            let lo = a.min(b) - DVec3::splat(self.reach);
            let hi = a.max(b) + DVec3::splat(self.reach);
            if p.cmplt(lo).any() || p.cmpgt(hi).any() {
                continue;
            }
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
            let g = (self.cap - v)
                .min(v + depth * self.profile.shape(across / self.half_width))
                .min(self.half_width - across);
            best = Some(best.map_or(g, |b| b.max(g)));
        }
        best
    }
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
