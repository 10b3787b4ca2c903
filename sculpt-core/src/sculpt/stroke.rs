//! Strokes: from a timed wand polyline to a footprint in the target's UV square and a
//! depth field.
//!
//! [`Stroke::build`] runs the pipeline:
//! 1. **Validate** the input and tool (finite samples, positive width and depth, a width
//!    no larger than the surface): bad input is rejected with a reason.
//! 2. **Clean, resample and smooth** the 3D polyline ([`resample`]): duplicates are
//!    dropped, corners (turns sharper than [`CORNER_ANGLE_DEG`] over one tool width) are
//!    kept exactly, and the pieces between corners are resampled by arc length at a
//!    spacing of a quarter of the tool width and smoothed by a few Laplacian passes with
//!    the corners and ends pinned.
//! 3. **Project** every sample onto the target by Newton point inversion seeded from the
//!    previous sample ([`project_seeded`]). Samples farther than the snap distance from
//!    the surface are off the surface; the longest run on the surface is kept (the
//!    stroke is clipped), and a stroke with no run is rejected. On a closed surface
//!    (sphere, torus) a crossing of the seam also ends a run, and rim points that fall
//!    across it are moved back onto it: strokes are clipped at the seam, not wrapped.
//! 4. Compute the **rims**: the 3D points `C +- w/2 B` (`B = N x T`, the side direction)
//!    projected onto the surface. Tapered ends scale the width and depth smoothly to
//!    zero over the taper length, so the groove starts and ends cleanly.
//! 5. The **footprint** is the union of the strip's triangles (and round end caps when
//!    there is no taper), made simple by a polygon boolean and clipped to the domain;
//!    self-crossing or reversing paths give a simple outline (possibly with holes).
//!
//! The groove's depth at a surface point `p = S(uv)` is a chisel sweep: with `r` the
//! distance from `p` to the projected centreline and `w(s), d(s)` the tapered half-width
//! and depth at the closest point, `depth = d(s) * profile(r / w(s))` for `r < w(s)`
//! ([`Stroke::depth_at`]).
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::sculpt::stroke::{Mode, Profile, Tool};
//! let tool = Tool { profile: Profile::V, width: 0.02, depth: 0.005, mode: Mode::Carve, taper: 0.01 };
//! assert!(tool.validate().is_ok());
//! assert_eq!(Profile::V.shape(0.0), 1.0);
//! assert_eq!(Profile::V.shape(1.0), 0.0);
//! ```

use super::jordan::{Rect, Region, signed_area};
use super::surface::{ParamSurface, extent_sampled, normal_at, project, project_seeded};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;
use serde::{Deserialize, Serialize};

/// Turns sharper than this (degrees, measured over one tool width) are corners.
pub const CORNER_ANGLE_DEG: f64 = 50.0;
/// At most this many resampled samples per stroke (longer strokes get a wider spacing).
pub const MAX_SAMPLES: usize = 2000;
/// At most this many input samples are accepted.
pub const MAX_INPUT_SAMPLES: usize = 1_000_000;

/// Cross-section of the chisel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// Straight walls meeting at a sharp bottom.
    V,
    /// A round (elliptical) bottom.
    U,
    /// A custom half-profile: `(x, f)` pairs with `x` from 0 (centre) to 1 (rim),
    /// increasing, and `f` the depth fraction (interpolated linearly, 0 at the rim).
    Custom(Vec<[f64; 2]>),
}

impl Profile {
    /// The depth fraction at `x = r / half_width` in `[0, 1]`; 0 outside.
    pub fn shape(&self, x: f64) -> f64 {
        if !(0.0..1.0).contains(&x) {
            return 0.0;
        }
        match self {
            Profile::V => 1.0 - x,
            Profile::U => (1.0 - x * x).sqrt(),
            Profile::Custom(pts) => {
                let mut prev = [0.0, pts.first().map_or(1.0, |p| p[1])];
                for &p in pts.iter().chain(std::iter::once(&[1.0, 0.0])) {
                    if x <= p[0] {
                        let span = p[0] - prev[0];
                        let t = if span > 0.0 {
                            (x - prev[0]) / span
                        } else {
                            1.0
                        };
                        return (prev[1] + (p[1] - prev[1]) * t).clamp(0.0, 1.0);
                    }
                    prev = p;
                }
                0.0
            }
        }
    }

    /// True when the profile is curved between centre and rim (needs extra sample lines).
    pub fn is_curved(&self) -> bool {
        !matches!(self, Profile::V)
    }

    fn validate(&self) -> Result<()> {
        if let Profile::Custom(pts) = self {
            if pts.is_empty() || pts.len() > 256 {
                return Err(reject("a custom profile needs 1 to 256 points"));
            }
            let mut last = -1.0;
            for p in pts {
                if !(p[0].is_finite() && p[1].is_finite()) || p[0] <= last || p[0] > 1.0 {
                    return Err(reject(
                        "custom profile x values must increase within [0, 1] and be finite",
                    ));
                }
                if !(0.0..=1.0).contains(&p[1]) {
                    return Err(reject("custom profile depth fractions must lie in [0, 1]"));
                }
                last = p[0];
            }
        }
        Ok(())
    }
}

/// Carve into the surface or emboss onto it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Remove material: the groove goes in against the normal.
    Carve,
    /// Add material: the ridge stands out along the normal.
    Emboss,
}

/// The chisel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    /// Cross-section.
    pub profile: Profile,
    /// Full width at the rims, metres.
    pub width: f64,
    /// Depth (carve) or height (emboss) at the centreline, metres.
    pub depth: f64,
    /// Carve or emboss.
    pub mode: Mode,
    /// Length over which each end tapers to nothing, metres (0: blunt round ends).
    #[serde(default)]
    pub taper: f64,
}

impl Tool {
    /// Checks the parameters; the error says which one is wrong.
    pub fn validate(&self) -> Result<()> {
        if !(self.width.is_finite() && self.width > 0.0) {
            return Err(reject("tool width must be a positive finite number"));
        }
        if !(self.depth.is_finite() && self.depth > 0.0) {
            return Err(reject("tool depth must be a positive finite number"));
        }
        if !(self.taper.is_finite() && self.taper >= 0.0) {
            return Err(reject(
                "tool taper must be zero or a positive finite number",
            ));
        }
        self.profile.validate()
    }
}

/// What the wand gives: timed 3D samples (seconds, display-frame metres) and the tool.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeInput {
    /// `(t, position)` samples in drawing order.
    pub samples: Vec<(f64, DVec3)>,
    /// The chisel.
    pub tool: Tool,
}

/// A stroke projected onto its target: centreline, rims, footprint and depth field.
#[derive(Debug, Clone)]
pub struct Stroke {
    /// The chisel.
    pub tool: Tool,
    /// Centreline parameters on the target.
    pub centre_uv: Vec<DVec2>,
    /// Centreline points `S(centre_uv)`.
    pub centre: Vec<DVec3>,
    /// Unit surface normals at the centreline.
    pub normals: Vec<DVec3>,
    /// Left and right rim parameters.
    pub rims_uv: [Vec<DVec2>; 2],
    /// Tapered half-width per sample, metres.
    pub half_width: Vec<f64>,
    /// Tapered depth per sample, metres.
    pub depth: Vec<f64>,
    /// The simple footprint outline, clipped to the domain.
    pub footprint: Region,
    /// Bounding rectangle of the footprint in UV.
    pub bounds: Rect,
    /// Bounding rectangles of the pieces whose union is the footprint (strip quads and
    /// end caps): together they cover the footprint, the centreline and the profile
    /// sample lines, so a quadtree cell that meets none of them is untouched.
    pieces: Vec<Rect>,
    buckets: Buckets,
}

fn reject(why: &str) -> Error {
    Error::StrokeRejected(why.to_string())
}

/// Cleans, resamples by arc length and smooths a polyline, keeping corners (see the
/// module docs). `spacing` is the target sample distance. Returns the new samples.
pub fn resample(points: &[DVec3], spacing: f64) -> Vec<DVec3> {
    let mut pts: Vec<DVec3> = Vec::with_capacity(points.len());
    for &p in points {
        if pts
            .last()
            .is_none_or(|q: &DVec3| q.distance(p) > crate::tolerance::POINT_EPS)
        {
            pts.push(p);
        }
    }
    if pts.len() < 2 {
        return pts;
    }
    let length: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
    let spacing = spacing.max(length / MAX_SAMPLES as f64).max(1e-12);
    // Corners: the turn between the directions one window back and ahead.
    let mut cum = vec![0.0];
    for w in pts.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let window = spacing * 4.0;
    let at = |s: f64| -> DVec3 { point_at(&pts, &cum, s) };
    let mut corners = vec![0usize];
    let cos_lim = CORNER_ANGLE_DEG.to_radians().cos();
    let mut best: Option<(usize, f64)> = None;
    for i in 1..pts.len() - 1 {
        let s = cum[i];
        let ok = s > window && s < length - window;
        let turn = if ok {
            let a = (pts[i] - at(s - window)).normalize_or_zero();
            let b = (at(s + window) - pts[i]).normalize_or_zero();
            a.dot(b)
        } else {
            1.0
        };
        if turn < cos_lim {
            if best.is_none_or(|(_, t)| turn < t) {
                best = Some((i, turn));
            }
        } else if let Some((k, _)) = best.take() {
            corners.push(k);
        }
    }
    if let Some((k, _)) = best {
        corners.push(k);
    }
    corners.push(pts.len() - 1);
    corners.dedup();
    // Resample each piece between corners, then smooth with its ends pinned.
    let mut out = vec![pts[0]];
    for w in corners.windows(2) {
        let (s0, s1) = (cum[w[0]], cum[w[1]]);
        let n = ((s1 - s0) / spacing).ceil().max(1.0) as usize;
        let mut piece: Vec<DVec3> = (0..=n)
            .map(|k| at(s0 + (s1 - s0) * k as f64 / n as f64))
            .collect();
        piece[0] = pts[w[0]];
        piece[n] = pts[w[1]];
        for _ in 0..3 {
            let prev = piece.clone();
            for k in 1..n {
                piece[k] = prev[k] * 0.5 + (prev[k - 1] + prev[k + 1]) * 0.25;
            }
        }
        out.extend_from_slice(&piece[1..]);
    }
    out
}

fn point_at(pts: &[DVec3], cum: &[f64], s: f64) -> DVec3 {
    let i = cum.partition_point(|&c| c <= s).clamp(1, pts.len() - 1);
    let (a, b) = (cum[i - 1], cum[i]);
    let t = if b > a {
        ((s - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    pts[i - 1].lerp(pts[i], t)
}

impl Stroke {
    /// Runs the pipeline of the module docs. `snap` is the largest distance between a
    /// wand sample and the surface for the sample to count as on it (metres).
    pub fn build(surface: &dyn ParamSurface, input: &StrokeInput, snap: f64) -> Result<Self> {
        let tool = input.tool.clone();
        tool.validate()?;
        if input.samples.len() > MAX_INPUT_SAMPLES {
            return Err(reject("too many samples"));
        }
        if let Some(k) = input
            .samples
            .iter()
            .position(|(t, p)| !(t.is_finite() && p.is_finite()))
        {
            return Err(Error::StrokeRejected(format!("sample {k} is not finite")));
        }
        let ext = extent_sampled(surface, 8);
        if tool.width > ext.diagonal() {
            return Err(Error::StrokeRejected(format!(
                "tool width {} m is larger than the surface ({} m across)",
                tool.width,
                ext.diagonal()
            )));
        }
        let raw: Vec<DVec3> = input.samples.iter().map(|s| s.1).collect();
        let length: f64 = raw.windows(2).map(|w| w[0].distance(w[1])).sum();
        if raw.len() < 2 || length <= tool.width * 1e-3 {
            return Err(reject("the stroke has zero length"));
        }
        let pts = resample(&raw, tool.width * 0.25);
        // Project, seeded from the previous sample; keep the longest on-surface run.
        // On a closed surface a seeded projection stops at the seam: the point is then
        // projected afresh, and a jump across the seam ends the run (strokes are
        // clipped at the seam, not wrapped across it).
        let closed = [ext.closed_u, ext.closed_v];
        let mut runs: Vec<Vec<(DVec2, DVec3)>> = vec![Vec::new()];
        let mut seed = None;
        for &p in &pts {
            let pr = match seed {
                Some(s) => {
                    let pr = project_seeded(surface, p, s);
                    if pr.distance > snap || on_seam(pr.uv, closed) {
                        let fresh = project(surface, p);
                        if fresh.distance < pr.distance {
                            fresh
                        } else {
                            pr
                        }
                    } else {
                        pr
                    }
                }
                None => project(surface, p),
            };
            if pr.distance <= snap && pr.p.is_finite() {
                let jump = seed.is_some_and(|s: DVec2| (pr.uv - s).abs().max_element() > 0.5);
                if jump {
                    runs.push(Vec::new());
                }
                seed = Some(pr.uv);
                if let Some(r) = runs.last_mut() {
                    r.push((pr.uv, pr.p));
                }
            } else {
                seed = None;
                if runs.last().is_some_and(|r| !r.is_empty()) {
                    runs.push(Vec::new());
                }
            }
        }
        let run = runs.into_iter().max_by_key(|r| r.len()).unwrap_or_default();
        let run_len: f64 = run.windows(2).map(|w| w[0].1.distance(w[1].1)).sum();
        if run.len() < 2 || run_len <= tool.width * 1e-3 {
            return Err(reject("the stroke does not lie on the surface"));
        }
        Self::from_centreline(surface, tool, run, closed)
    }

    fn from_centreline(
        surface: &dyn ParamSurface,
        tool: Tool,
        run: Vec<(DVec2, DVec3)>,
        closed: [bool; 2],
    ) -> Result<Self> {
        let n = run.len();
        let centre_uv: Vec<DVec2> = run.iter().map(|r| r.0).collect();
        let centre: Vec<DVec3> = run.iter().map(|r| r.1).collect();
        let normals: Vec<DVec3> = centre_uv.iter().map(|&uv| normal_at(surface, uv)).collect();
        let mut cum = vec![0.0];
        for w in centre.windows(2) {
            cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
        }
        let total = cum[n - 1];
        let taper_len = tool.taper.min(total * 0.5);
        let taper = |s: f64| -> f64 {
            if taper_len <= 0.0 {
                return 1.0;
            }
            let x = (s.min(total - s) / taper_len).clamp(0.0, 1.0);
            x * x * (3.0 - 2.0 * x)
        };
        let half_width: Vec<f64> = cum.iter().map(|&s| 0.5 * tool.width * taper(s)).collect();
        let depth: Vec<f64> = cum.iter().map(|&s| tool.depth * taper(s)).collect();
        let mut rims_uv = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let t = (centre[(i + 1).min(n - 1)] - centre[i.saturating_sub(1)]).normalize_or_zero();
            let side = normals[i].cross(t).normalize_or_zero();
            let sp = surface.eval(centre_uv[i]);
            for (k, sign) in [(0, 1.0), (1, -1.0)] {
                let target = centre[i] + side * (sign * half_width[i]);
                let seed = centre_uv[i] + uv_step(sp.du, sp.dv, target - centre[i]);
                let rim = project_seeded(surface, target, seed).uv;
                rims_uv[k].push(seam_side(rim, centre_uv[i], closed));
            }
        }
        // Footprint: the union of the strip's triangles plus round caps, clipped.
        let mut pieces: Vec<Vec<[f64; 2]>> = Vec::new();
        let mut piece_bounds: Vec<Rect> = Vec::new();
        let mut push = |tri: Vec<DVec2>| {
            let mut tri = tri;
            let r = tri.iter().fold(Rect::new(tri[0], tri[0]), |r, &p| {
                Rect::new(r.min.min(p), r.max.max(p))
            });
            piece_bounds.push(r);
            let a = signed_area(&tri);
            if a.abs() < 1e-18 {
                return;
            }
            if a < 0.0 {
                tri.reverse();
            }
            pieces.push(tri.into_iter().map(|p| [p.x, p.y]).collect());
        };
        let [l, r] = &rims_uv;
        for i in 0..n - 1 {
            let c = [centre_uv[i], centre_uv[i + 1]];
            push(vec![l[i], l[i + 1], c[1], c[0]]);
            push(vec![r[i], c[0], c[1], r[i + 1]]);
        }
        if taper_len <= 0.0 {
            for (end, next) in [(0, 1), (n - 1, n - 2)] {
                let t = (centre[end] - centre[next]).normalize_or_zero();
                let side = normals[end].cross(t).normalize_or_zero();
                let sp = surface.eval(centre_uv[end]);
                let mut cap = vec![centre_uv[end]];
                for k in 0..=16 {
                    let a = std::f64::consts::PI * k as f64 / 16.0;
                    let dir = side * a.cos() + t * a.sin();
                    let target = centre[end] + dir * half_width[end];
                    let seed = centre_uv[end] + uv_step(sp.du, sp.dv, target - centre[end]);
                    let rim = project_seeded(surface, target, seed).uv;
                    cap.push(seam_side(rim, centre_uv[end], closed));
                }
                push(cap);
            }
        }
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let union = domain_overlay(&pieces, &[], OverlayRule::Subject);
        let union: Vec<Vec<[f64; 2]>> = union.into_iter().flatten().collect();
        let clipped = domain_overlay(&union, &[square.to_vec()], OverlayRule::Intersect);
        let footprint = region_from_shapes(clipped);
        if footprint.is_empty() {
            return Err(reject("the stroke's footprint is empty"));
        }
        let mut bounds = Rect::new(DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for c in footprint.contours() {
            for &p in c {
                bounds.min = bounds.min.min(p);
                bounds.max = bounds.max.max(p);
            }
        }
        let buckets = Buckets::new(&centre_uv, &rims_uv, bounds);
        let pieces = piece_bounds;
        Ok(Self {
            tool,
            centre_uv,
            centre,
            normals,
            rims_uv,
            half_width,
            depth,
            footprint,
            bounds,
            pieces,
            buckets,
        })
    }

    /// Bounding rectangles of the pieces of the footprint (see the field docs of
    /// `pieces`): a cell meeting none of them is untouched by this stroke.
    pub fn piece_bounds(&self) -> &[Rect] {
        &self.pieces
    }

    /// The groove depth (carve) or ridge height (emboss) at the surface point `p = S(uv)`;
    /// zero outside the footprint. Always finite and non-negative.
    pub fn depth_at(&self, uv: DVec2, p: DVec3) -> f64 {
        let mut best: f64 = 0.0;
        for &i in self.buckets.candidates(uv) {
            let i = i as usize;
            let (a, b) = (self.centre[i], self.centre[i + 1]);
            let d = b - a;
            let l2 = d.length_squared();
            let t = if l2 > 0.0 {
                ((p - a).dot(d) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let r = p.distance(a + d * t);
            let hw = self.half_width[i] + (self.half_width[i + 1] - self.half_width[i]) * t;
            if hw > 0.0 && r < hw {
                let dep = self.depth[i] + (self.depth[i + 1] - self.depth[i]) * t;
                best = best.max(dep * self.tool.profile.shape(r / hw));
            }
        }
        if best.is_finite() { best } else { 0.0 }
    }

    /// Memory held by this stroke, bytes (approximate).
    pub fn memory_bytes(&self) -> usize {
        let n = self.centre.len();
        n * (2 * 16 + 2 * 24 + 2 * 16 + 2 * 8)
            + self.footprint.segments().len() * 48
            + self
                .buckets
                .cells
                .iter()
                .map(|c| c.len() * 4 + 24)
                .sum::<usize>()
    }
}

/// True when `uv` lies on the seam of a closed direction (`closed` = [u, v]).
fn on_seam(uv: DVec2, closed: [bool; 2]) -> bool {
    (closed[0] && (uv.x <= 0.0 || uv.x >= 1.0)) || (closed[1] && (uv.y <= 0.0 || uv.y >= 1.0))
}

/// A rim point that projected across the seam of a closed direction, moved back onto
/// the seam on its centre's side: the groove is clipped at the seam.
fn seam_side(rim: DVec2, centre: DVec2, closed: [bool; 2]) -> DVec2 {
    let fix = |r: f64, c: f64, closed: bool| {
        if closed && (r - c).abs() > 0.5 {
            if c > 0.5 { 1.0 } else { 0.0 }
        } else {
            r
        }
    };
    DVec2::new(
        fix(rim.x, centre.x, closed[0]),
        fix(rim.y, centre.y, closed[1]),
    )
}

/// Parameter step that best realises the 3D displacement `d` (least squares on `[Su Sv]`).
fn uv_step(du: DVec3, dv: DVec3, d: DVec3) -> DVec2 {
    let (aa, ab, bb) = (du.dot(du), du.dot(dv), dv.dot(dv));
    let det = aa * bb - ab * ab;
    if det.abs() <= 1e-300 || !det.is_finite() {
        return DVec2::ZERO;
    }
    let (ga, gb) = (du.dot(d), dv.dot(d));
    let s = DVec2::new((ga * bb - gb * ab) / det, (aa * gb - ab * ga) / det);
    if s.is_finite() {
        s.clamp(DVec2::splat(-1.0), DVec2::splat(1.0))
    } else {
        DVec2::ZERO
    }
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

/// A uniform grid over the stroke's bounds listing the centreline segments near each
/// cell, so that [`Stroke::depth_at`] tests only a few segments.
#[derive(Debug, Clone)]
struct Buckets {
    bounds: Rect,
    n: usize,
    cells: Vec<Vec<u32>>,
}

impl Buckets {
    fn new(centre: &[DVec2], rims: &[Vec<DVec2>; 2], bounds: Rect) -> Self {
        let n = 32usize;
        let mut cells = vec![Vec::new(); n * n];
        let mut me = Self {
            bounds,
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
            let pad = (hi - lo) * 0.25 + DVec2::splat(1e-9);
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

    fn cell_of(&self, p: DVec2) -> (usize, usize) {
        let size = (self.bounds.max - self.bounds.min).max(DVec2::splat(1e-12));
        let f = ((p - self.bounds.min) / size * self.n as f64).floor();
        let c = |x: f64| (x.max(0.0) as usize).min(self.n - 1);
        (c(f.x), c(f.y))
    }

    fn candidates(&self, uv: DVec2) -> &[u32] {
        let pad = (self.bounds.max - self.bounds.min) * 0.25 + DVec2::splat(1e-9);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::sculpt::jordan::Location;
    use crate::sculpt::surface::test_surfaces::plane;

    fn tool() -> Tool {
        Tool {
            profile: Profile::V,
            width: 0.1,
            depth: 0.02,
            mode: Mode::Carve,
            taper: 0.0,
        }
    }

    /// Builds a stroke with the test tool and a snap distance of 0.1.
    fn build(s: &dyn ParamSurface, samples: Vec<(f64, DVec3)>) -> Stroke {
        Stroke::build(
            s,
            &StrokeInput {
                samples,
                tool: tool(),
            },
            0.1,
        )
        .unwrap()
    }

    fn line(a: DVec3, b: DVec3, n: usize) -> Vec<(f64, DVec3)> {
        (0..n)
            .map(|i| {
                let t = i as f64 / (n - 1) as f64;
                (t, a.lerp(b, t))
            })
            .collect()
    }

    #[test]
    fn straight_groove_on_a_plane() {
        let s = plane(1.0);
        let input = StrokeInput {
            samples: line(DVec3::new(0.2, 0.5, 0.01), DVec3::new(0.8, 0.5, 0.01), 50),
            tool: tool(),
        };
        let st = Stroke::build(&s, &input, 0.1).unwrap();
        assert_near!(
            st.depth_at(DVec2::new(0.5, 0.5), DVec3::new(0.5, 0.5, 0.0)),
            0.02,
            1e-9
        );
        assert_near!(
            st.depth_at(DVec2::new(0.5, 0.525), DVec3::new(0.5, 0.525, 0.0)),
            0.01,
            1e-9
        );
        assert_eq!(
            st.depth_at(DVec2::new(0.5, 0.6), DVec3::new(0.5, 0.6, 0.0)),
            0.0
        );
        assert_eq!(st.footprint.locate(DVec2::new(0.5, 0.5)), Location::Inside);
        assert_eq!(
            st.footprint.locate(DVec2::new(0.5, 0.56)),
            Location::Outside
        );
        // Area of the footprint: 0.6 x 0.1 plus two half discs of radius 0.05.
        assert_near!(
            st.footprint.area(),
            0.06 + std::f64::consts::PI * 0.0025,
            1e-4
        );
    }

    #[test]
    fn self_crossing_path_gives_a_simple_outline() {
        let s = plane(1.0);
        let samples: Vec<(f64, DVec3)> = (0..200)
            .map(|i| {
                let a = i as f64 / 199.0 * 1.8 * std::f64::consts::TAU;
                (
                    i as f64,
                    DVec3::new(0.5 + 0.2 * a.cos(), 0.5 + 0.2 * a.sin(), 0.0),
                )
            })
            .collect();
        let st = build(&s, samples);
        // A loop: an outer outline and a hole; the hole's centre is outside.
        assert_eq!(st.footprint.contours().len(), 2);
        assert_eq!(st.footprint.locate(DVec2::splat(0.5)), Location::Outside);
        assert_eq!(st.footprint.locate(DVec2::new(0.7, 0.5)), Location::Inside);
    }

    #[test]
    fn bad_strokes_are_rejected_with_reasons() {
        let s = plane(1.0);
        let mut samples = line(DVec3::new(0.2, 0.5, 0.0), DVec3::new(0.8, 0.5, 0.0), 5);
        samples[2].1.x = f64::NAN;
        let err = Stroke::build(
            &s,
            &StrokeInput {
                samples,
                tool: tool(),
            },
            0.1,
        )
        .unwrap_err();
        assert!(err.to_string().contains("not finite"), "{err}");
        let zero = vec![(0.0, DVec3::splat(0.5)); 10];
        let err = Stroke::build(
            &s,
            &StrokeInput {
                samples: zero,
                tool: tool(),
            },
            0.1,
        )
        .unwrap_err();
        assert!(err.to_string().contains("zero length"), "{err}");
        let off = line(DVec3::new(0.2, 0.5, 3.0), DVec3::new(0.8, 0.5, 3.0), 10);
        let err = Stroke::build(
            &s,
            &StrokeInput {
                samples: off,
                tool: tool(),
            },
            0.1,
        )
        .unwrap_err();
        assert!(err.to_string().contains("does not lie"), "{err}");
        let mut wide = tool();
        wide.width = 5.0;
        let ok = line(DVec3::new(0.2, 0.5, 0.0), DVec3::new(0.8, 0.5, 0.0), 10);
        let err = Stroke::build(
            &s,
            &StrokeInput {
                samples: ok,
                tool: wide,
            },
            0.1,
        )
        .unwrap_err();
        assert!(err.to_string().contains("larger than the surface"), "{err}");
    }

    #[test]
    fn stroke_off_the_edge_is_clipped_to_the_domain() {
        let s = plane(1.0);
        let input = StrokeInput {
            samples: line(DVec3::new(0.5, 0.5, 0.0), DVec3::new(1.3, 0.5, 0.0), 50),
            tool: tool(),
        };
        let st = Stroke::build(&s, &input, 0.1).unwrap();
        assert!(st.bounds.max.x <= 1.0 && st.bounds.min.x >= 0.0);
        assert!(st.centre_uv.iter().all(|c| c.x <= 1.0));
    }

    #[test]
    fn stroke_across_the_seam_of_a_sphere_is_clipped_there() {
        use crate::sculpt::surface::test_surfaces::sphere;
        let s = sphere(1.0);
        // Along the equator from -30 to +25 degrees: the seam u = 0 = 1 is at 0 degrees.
        let samples = (0..56)
            .map(|k| {
                let a = (-30.0 + k as f64).to_radians();
                (k as f64, DVec3::new(a.cos(), a.sin(), 0.0))
            })
            .collect();
        let st = build(&s, samples);
        // The longer part, before the seam, is kept; nothing wraps across the domain.
        assert!(st.bounds.min.x > 0.5, "{:?}", st.bounds);
        assert!(st.centre_uv.iter().all(|c| c.x > 0.5));
        assert!(st.rims_uv.iter().flatten().all(|c| c.x > 0.5));
        let length = 30f64.to_radians() / std::f64::consts::TAU;
        assert!(st.bounds.max.x - st.bounds.min.x < length * 1.5);
    }

    #[test]
    fn resampling_keeps_corners() {
        let pts = vec![
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
        ];
        let out = resample(&pts, 0.05);
        assert!(
            out.iter()
                .any(|p| p.distance(DVec3::new(1.0, 0.0, 0.0)) < 1e-12)
        );
        for w in out.windows(2) {
            assert!(w[0].distance(w[1]) <= 0.05 + 1e-9);
        }
    }
}
