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
//! 3. **Project** every sample onto the target: its true closest point, through the
//!    target's cached certified inverter ([`TargetSurface::closest_point_near`], seeded
//!    from the previous sample's foot; global for the first sample and after a gap).
//!    Samples farther than the snap distance from the surface are off the surface.
//!    **Basin jumps**: where the stroke passes over a valley whose far side is nearer
//!    (a finely waved sheet, a stroke hovering above it), the true closest point jumps
//!    from one slope to the other; consecutive feet are then much farther apart along
//!    the surface than the sample spacing justifies (more than
//!    [`BASIN_JUMP_RATIO`] times it, see `basin_jump`). The stroke is **split into
//!    runs** at every jump and wherever it leaves the surface, and the **longest run is
//!    kept** (the stroke is clipped): a groove never bridges a jump, and never follows
//!    a local minimum that is not the closest point (which a local Newton projection
//!    did, silently). A stroke with no run is rejected.
//! 4. Compute the **rims**: the 3D points `C +- w/2 B` (`B = N x T`, the side direction)
//!    projected onto the surface. Tapered ends scale the width and depth smoothly to
//!    zero over the taper length, so the groove starts and ends cleanly. A stroke whose
//!    end comes back within half a tool width of its start is a **loop**: it is closed
//!    by one more segment and has no tapered ends, so it carves one continuous groove.
//! 5. The **footprint** is the union of the strip's quads (and round end caps when
//!    there is no taper), made simple by a polygon boolean and clipped to the domain;
//!    self-crossing or reversing paths give a simple outline (possibly with holes).
//!
//! **Closed targets wrap.** On a target closed in u or v (a sphere around its axis, a
//! torus both ways: [`extent_sampled`]'s `closed_u`, `closed_v`) a stroke crosses the
//! seam as the user expects. The projected centreline is **unwrapped**: the inverter
//! wraps around the seam, and each foot's parameter is moved by whole periods to lie
//! within half a period of the previous one ([`unwrap_near`]), so a
//! parameter continues past 1 or below 0 instead of jumping ([`Stroke::centre_uv`] and
//! [`Stroke::rims_uv`] are unwrapped; the target is only ever evaluated at
//! [`wrap_uv`]`(uv)`). Rims and footprint pieces are built in that unwrapped plane, and
//! the footprint is brought into the square by taking each piece's copies shifted by
//! whole periods (-1, 0, +1 ...) that meet the square, uniting them and clipping the
//! union to the square. Piece bounds are the shifted copies' bounds, the depth lookup
//! queries the shifted copies of its parameter, and [`Stroke::centre_segments`] splits
//! the centreline exactly on the seam: the depth field is continuous across the seam and
//! the tessellation stays crack-free (watertight on a closed target) there. Poles (a
//! sphere's collapsed edges) and open directions are clamped as before.
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
use super::surface::{
    ParamSurface, SurfacePoint, TargetSurface, extent_sampled, normal_at, unwrap_near, wrap_uv,
};
use crate::error::{Error, Result, StrokeRejection, ToolParam, ToolRangeError};
use crate::tolerance::BASIN_JUMP_RATIO;
use glam::{DVec2, DVec3};
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;
use serde::{Deserialize, Serialize};

/// Turns sharper than this (degrees, measured over one tool width) are corners.
pub const CORNER_ANGLE_DEG: f64 = 50.0;
pub use crate::tolerance::{CREASE_FRACTION, PROFILE_EDGE};
/// At most this many resampled samples per stroke (longer strokes get a wider spacing).
pub const MAX_SAMPLES: usize = 2000;
/// Chords of the surface path between two feet that [`basin_jump`] measures.
const JUMP_PATH_SEGMENTS: usize = 8;
/// At most this many input samples are accepted.
pub const MAX_INPUT_SAMPLES: usize = 1_000_000;
/// On a closed target, the most whole-period copies per direction of a footprint piece
/// or a depth query (a stroke may wind round a torus a few times).
const MAX_PERIODS: i64 = 8;

/// Cross-section of the chisel: the one profile type, used by the interaction (its
/// current tool, commands, the journal) and by the sculpting layer (strokes, the
/// document).
///
/// Written as `"v"`, `"u"` or `{"custom": [[x, f], ...]}` in every format (journal,
/// document, scene, TOML configuration); the kebab-case and lowercase spellings the
/// interaction and the sculpting layer once wrote separately are the same words.
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

    /// The slope `d shape / dx` at `x` in `[0, 1]` (clamped), for normals. A U profile is
    /// vertical at its rim: its slope is taken at [`PROFILE_EDGE`] short of the rim.
    pub fn slope(&self, x: f64) -> f64 {
        let x = if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.0
        };
        match self {
            Profile::V => -1.0,
            Profile::U => {
                let x = x.min(1.0 - PROFILE_EDGE);
                -x / (1.0 - x * x).sqrt()
            }
            Profile::Custom(pts) => {
                let mut prev = [0.0, pts.first().map_or(1.0, |p| p[1])];
                for &p in pts.iter().chain(std::iter::once(&[1.0, 0.0])) {
                    if x <= p[0] {
                        let span = p[0] - prev[0];
                        return if span > 0.0 {
                            (p[1] - prev[1]) / span
                        } else {
                            0.0
                        };
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

    /// The profile a profile button switches to: V to U, U (or a custom profile) to V.
    pub fn toggled(&self) -> Self {
        match self {
            Profile::V => Profile::U,
            Profile::U | Profile::Custom(_) => Profile::V,
        }
    }

    fn validate(&self) -> Result<()> {
        if let Profile::Custom(pts) = self {
            if pts.is_empty() || pts.len() > 256 {
                return Err(reject(StrokeRejection::ProfilePointCount {
                    count: pts.len(),
                    max: 256,
                }));
            }
            let mut last = -1.0;
            for (index, p) in pts.iter().enumerate() {
                if !(p[0].is_finite() && p[1].is_finite()) || p[0] <= last || p[0] > 1.0 {
                    return Err(reject(StrokeRejection::ProfileX { index }));
                }
                if !(0.0..=1.0).contains(&p[1]) {
                    return Err(reject(StrokeRejection::ProfileDepth { index }));
                }
                last = p[0];
            }
        }
        Ok(())
    }
}

/// Carve into the surface or emboss onto it: the one carve/emboss type (the
/// interaction re-exports it as `StrokeMode`, next to its
/// [`InteractionMode`](crate::interaction::InteractionMode), which adds sketching).
///
/// Written as `"carve"` or `"emboss"` in every format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Remove material: the groove goes in against the normal.
    Carve,
    /// Add material: the ridge stands out along the normal.
    Emboss,
}

/// The chisel and what it does: the one tool type, the interaction's current tool
/// (its [`Interaction::tool`](crate::interaction::Interaction::tool)) and every
/// stroke's tool in the document.
///
/// **Defaults** ([`Tool::default`]): a V profile, 2 cm wide, 5 mm deep, carving, with
/// ends tapered over [`DEFAULT_TAPER`] (1 cm). **Caps** ([`Tool::validate`]): width
/// and depth in `(0, MAX_TOOL_SIZE]`, the taper in `[0, MAX_TOOL_SIZE]`
/// ([`MAX_TOOL_SIZE`] is 10 m), and a custom profile of 1 to 256 increasing points.
///
/// Serialized with its mode (`{"profile", "width", "depth", "mode", "taper"}`, the
/// document's and scene files' stroke tools); a stored stroke without `taper` has
/// blunt ends (0), as files written before tapers existed meant. The journal writes a
/// stroke's mode beside its tool instead (see
/// [`StrokeEdit`](crate::interaction::StrokeEdit)).
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

/// The largest tool width, depth and taper (metres) anywhere: the interaction's tool,
/// a stroke built from the wand, and every stroke of a document or scene file read
/// back, so that no mesh or file written from them holds a non-finite number.
pub const MAX_TOOL_SIZE: f64 = 10.0;

/// The default end taper (metres): [`Tool::default`]'s, and the taper of a journalled
/// stroke or a configured tool that does not give one.
pub const DEFAULT_TAPER: f64 = 0.01;

impl Default for Tool {
    fn default() -> Self {
        Self {
            profile: Profile::V,
            width: 0.02,
            depth: 0.005,
            mode: Mode::Carve,
            taper: DEFAULT_TAPER,
        }
    }
}

impl Tool {
    /// Checks the parameters: width and depth in `(0, MAX_TOOL_SIZE]`, the taper in
    /// `[0, MAX_TOOL_SIZE]`, and the profile; the error says which one is wrong.
    pub fn validate(&self) -> Result<()> {
        let size = |param: ToolParam, v: f64| {
            let zero_ok = param == ToolParam::Taper;
            let low_ok = if zero_ok { v >= 0.0 } else { v > 0.0 };
            if v.is_finite() && low_ok && v <= MAX_TOOL_SIZE {
                Ok(())
            } else {
                Err(reject(StrokeRejection::Tool(ToolRangeError {
                    param,
                    value: v,
                    max: MAX_TOOL_SIZE,
                })))
            }
        };
        size(ToolParam::Width, self.width)?;
        size(ToolParam::Depth, self.depth)?;
        size(ToolParam::Taper, self.taper)?;
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
    /// Centreline parameters on the target, **unwrapped**: on a closed target (sphere,
    /// torus) a parameter continues past 1 or below 0 where the stroke crosses the
    /// seam, so consecutive samples are never more than half a period apart. Evaluate
    /// the target at [`wrap_uv`]`(uv)`; on an open target every value lies in the square.
    pub centre_uv: Vec<DVec2>,
    /// Centreline points `S(centre_uv)`.
    pub centre: Vec<DVec3>,
    /// Unit surface normals at the centreline.
    pub normals: Vec<DVec3>,
    /// Left and right rim parameters, unwrapped like [`Self::centre_uv`]: each within
    /// half a period of its centre sample (evaluate the target at [`wrap_uv`]`(uv)`).
    pub rims_uv: [Vec<DVec2>; 2],
    /// Tapered half-width per sample, metres.
    pub half_width: Vec<f64>,
    /// Tapered depth per sample, metres.
    pub depth: Vec<f64>,
    /// The simple footprint outline in the square: on a closed target the union of the
    /// unwrapped footprint's copies shifted by whole periods, clipped to the square.
    pub footprint: Region,
    /// Bounding rectangle of the footprint in UV.
    pub bounds: Rect,
    /// Bounding rectangles of the pieces whose union is the footprint (strip quads and
    /// end caps): together they cover the footprint, the centreline and the profile
    /// sample lines, so a quadtree cell that meets none of them is untouched.
    /// On a closed target these are the pieces' copies shifted into the square.
    pieces: Vec<Rect>,
    centre_segments: Vec<[DVec2; 2]>,
    is_loop: bool,
    buckets: Buckets,
}

fn reject(why: StrokeRejection) -> Error {
    Error::StrokeRejected(why)
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
    let spacing = spacing
        .max(length / MAX_SAMPLES as f64)
        .max(crate::tolerance::MIN_SPACING);
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
    pub fn build(target: &TargetSurface, input: &StrokeInput, snap: f64) -> Result<Self> {
        let surface: &dyn ParamSurface = target;
        let tool = input.tool.clone();
        tool.validate()?;
        if input.samples.len() > MAX_INPUT_SAMPLES {
            return Err(reject(StrokeRejection::TooManySamples {
                count: input.samples.len(),
                max: MAX_INPUT_SAMPLES,
            }));
        }
        if let Some(k) = input
            .samples
            .iter()
            .position(|(t, p)| !(t.is_finite() && p.is_finite()))
        {
            return Err(reject(StrokeRejection::SampleNotFinite { index: k }));
        }
        let ext = extent_sampled(surface, 8);
        if tool.width > ext.diagonal() {
            return Err(reject(StrokeRejection::ToolWiderThanSurface {
                width_m: tool.width,
                across_m: ext.diagonal(),
            }));
        }
        let raw: Vec<DVec3> = input.samples.iter().map(|s| s.1).collect();
        let length: f64 = raw.windows(2).map(|w| w[0].distance(w[1])).sum();
        if raw.len() < 2 || length <= tool.width * crate::tolerance::MIN_STROKE_LEN_REL {
            return Err(reject(StrokeRejection::TooShort {
                length_m: length,
                min_m: tool.width * crate::tolerance::MIN_STROKE_LEN_REL,
            }));
        }
        let pts = resample(&raw, tool.width * 0.25);
        // Project through the target's certified inverter, seeded from the previous
        // sample's foot; split into runs where a sample leaves the surface or the feet
        // jump to another basin; keep the longest run. In a closed direction the
        // parameter is unwrapped next to the previous foot, so it crosses the seam and
        // continues past 1 (or below 0) instead of jumping.
        let closed = [ext.closed_u, ext.closed_v];
        let mut runs: Vec<Vec<(DVec2, DVec3)>> = vec![Vec::new()];
        // The previous on-surface sample and its foot (unwrapped parameter, point).
        let mut prev: Option<(DVec3, DVec2, DVec3)> = None;
        for &p in &pts {
            let pr = match prev {
                Some((_, uv, _)) => target.closest_point_near(p, closed, uv, uv),
                None => target.closest_point(p),
            };
            if pr.distance <= snap && pr.point.is_finite() && pr.uv.is_finite() {
                let foot = (pr.uv, pr.point);
                if prev.is_some_and(|(q, uv, point)| {
                    basin_jump(surface, p.distance(q), (uv, point), foot)
                }) {
                    runs.push(Vec::new());
                }
                prev = Some((p, pr.uv, pr.point));
                if let Some(r) = runs.last_mut() {
                    r.push(foot);
                }
            } else {
                prev = None;
                if runs.last().is_some_and(|r| !r.is_empty()) {
                    runs.push(Vec::new());
                }
            }
        }
        let mut run = runs.into_iter().max_by_key(|r| r.len()).unwrap_or_default();
        run = through_poles(&run);
        let run_len: f64 = run.windows(2).map(|w| w[0].1.distance(w[1].1)).sum();
        if run.len() < 2 || run_len <= tool.width * crate::tolerance::MIN_STROKE_LEN_REL {
            return Err(reject(StrokeRejection::OffSurface));
        }
        // A stroke whose end comes back to its start is a loop: it is closed with one
        // more segment and carved without tapered ends, one continuous groove.
        let (first, last) = (run[0], run[run.len() - 1]);
        let is_loop = run.len() > 3
            && run_len > 2.0 * tool.width
            && first.1.distance(last.1) <= 0.5 * tool.width;
        if is_loop && first.1.distance(last.1) > crate::tolerance::POINT_EPS {
            run.push((unwrap_near(first.0, last.0, closed), first.1));
        }
        Self::from_centreline(target, tool, run, closed, is_loop)
    }

    fn from_centreline(
        target: &TargetSurface,
        tool: Tool,
        run: Vec<(DVec2, DVec3)>,
        closed: [bool; 2],
        is_loop: bool,
    ) -> Result<Self> {
        let surface: &dyn ParamSurface = target;
        let n = run.len();
        let centre_uv: Vec<DVec2> = run.iter().map(|r| r.0).collect();
        let centre: Vec<DVec3> = run.iter().map(|r| r.1).collect();
        // The target is evaluated at wrapped parameters only.
        let normals: Vec<DVec3> = centre_uv
            .iter()
            .map(|&uv| normal_at(surface, wrap_uv(uv)))
            .collect();
        let mut cum = vec![0.0];
        for w in centre.windows(2) {
            cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
        }
        let total = cum[n - 1];
        let taper_len = if is_loop {
            0.0
        } else {
            tool.taper.min(total * 0.5)
        };
        let taper = |s: f64| -> f64 {
            if taper_len <= 0.0 {
                return 1.0;
            }
            let x = (s.min(total - s) / taper_len).clamp(0.0, 1.0);
            x * x * (3.0 - 2.0 * x)
        };
        let half_width: Vec<f64> = cum.iter().map(|&s| 0.5 * tool.width * taper(s)).collect();
        let depth: Vec<f64> = cum.iter().map(|&s| tool.depth * taper(s)).collect();
        // A rim point: the 3D point `centre[i] + offset` projected onto the target, seeded
        // by the parameter step that best realises the offset, in the unwrapped plane
        // within half a period of the centre.
        let rim_of = |i: usize, sp: &SurfacePoint, offset: DVec3| -> DVec2 {
            let seed = centre_uv[i] + uv_step(sp.du, sp.dv, offset);
            target
                .closest_point_near(centre[i] + offset, closed, centre_uv[i], seed)
                .uv
        };
        let mut rims_uv = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let t = (centre[(i + 1).min(n - 1)] - centre[i.saturating_sub(1)]).normalize_or_zero();
            let side = normals[i].cross(t).normalize_or_zero();
            let sp = surface.eval(wrap_uv(centre_uv[i]));
            for (k, sign) in [(0, 1.0), (1, -1.0)] {
                rims_uv[k].push(rim_of(i, &sp, side * (sign * half_width[i])));
            }
        }
        // Footprint pieces in the unwrapped plane: the strip's quads plus round caps.
        let mut polys: Vec<Vec<DVec2>> = Vec::with_capacity(2 * n + 2);
        let [l, r] = &rims_uv;
        for i in 0..n - 1 {
            let c = [centre_uv[i], centre_uv[i + 1]];
            polys.push(vec![l[i], l[i + 1], c[1], c[0]]);
            polys.push(vec![r[i], c[0], c[1], r[i + 1]]);
        }
        if taper_len <= 0.0 {
            for (end, next) in [(0, 1), (n - 1, n - 2)] {
                let t = (centre[end] - centre[next]).normalize_or_zero();
                let side = normals[end].cross(t).normalize_or_zero();
                let sp = surface.eval(wrap_uv(centre_uv[end]));
                let mut cap = vec![centre_uv[end]];
                for k in 0..=16 {
                    let a = std::f64::consts::PI * k as f64 / 16.0;
                    let dir = side * a.cos() + t * a.sin();
                    cap.push(rim_of(end, &sp, dir * half_width[end]));
                }
                polys.push(cap);
            }
        }
        // Into the square: each piece's copies shifted by whole periods in the closed
        // directions, those meeting the square kept; their union clipped to the square.
        let mut pieces: Vec<Vec<[f64; 2]>> = Vec::with_capacity(polys.len());
        let mut piece_bounds: Vec<Rect> = Vec::with_capacity(polys.len());
        let mut unwrapped = Rect::new(centre_uv[0], centre_uv[0]);
        for poly in &polys {
            let rect = bounds_of(poly);
            unwrapped = Rect::new(unwrapped.min.min(rect.min), unwrapped.max.max(rect.max));
            for shift in period_shifts(&rect, closed) {
                piece_bounds.push(Rect::new(
                    (rect.min + shift).max(DVec2::ZERO),
                    (rect.max + shift).min(DVec2::ONE),
                ));
                let mut piece: Vec<DVec2> = poly.iter().map(|&p| p + shift).collect();
                if shift != DVec2::ZERO {
                    piece = clip_to_box(&piece, DVec2::splat(-1.0), DVec2::splat(2.0));
                }
                let a = signed_area(&piece);
                if piece.len() < 3 || a.abs() < crate::tolerance::UV_AREA_EPS || !a.is_finite() {
                    continue;
                }
                if a < 0.0 {
                    piece.reverse();
                }
                pieces.push(piece.into_iter().map(|p| [p.x, p.y]).collect());
            }
        }
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let union = domain_overlay(&pieces, &[], OverlayRule::Subject);
        let union: Vec<Vec<[f64; 2]>> = union.into_iter().flatten().collect();
        let clipped = domain_overlay(&union, &[square.to_vec()], OverlayRule::Intersect);
        let footprint = region_from_shapes(clipped);
        if footprint.is_empty() {
            return Err(reject(StrokeRejection::EmptyFootprint));
        }
        let mut bounds = Rect::new(DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for c in footprint.contours() {
            for &p in c {
                bounds.min = bounds.min.min(p);
                bounds.max = bounds.max.max(p);
            }
        }
        let buckets = Buckets::new(&centre_uv, &rims_uv, unwrapped, closed);
        let centre_segments = wrapped_segments(&centre_uv, closed);
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
            is_loop,
            pieces: piece_bounds,
            centre_segments,
            buckets,
        })
    }

    /// Bounding rectangles of the pieces of the footprint (see the field docs of
    /// `pieces`): a cell meeting none of them is untouched by this stroke.
    pub fn piece_bounds(&self) -> &[Rect] {
        &self.pieces
    }

    /// The centreline brought into the square: the segments of [`Self::centre_uv`]
    /// split where they cross the seam of a closed direction and shifted by whole
    /// periods into the square. A split point lies exactly on the seam (`0.0` or `1.0`)
    /// with the same other coordinate on both sides. Zero-length segments are left out.
    /// On an open target these are the segments of `centre_uv`.
    pub fn centre_segments(&self) -> &[[DVec2; 2]] {
        &self.centre_segments
    }

    /// The groove wall's strip lines in the square, for a tessellator: with `fracs` the
    /// profile sample fractions of the half-width (strictly between 0 and 1, ascending),
    /// the point `p(i, k, f) = centre_uv[i] + f (rims_uv[k][i] - centre_uv[i])` on each
    /// side `k`, and
    /// - **rungs** across the stroke: `centre_uv[i]`, then `p(i, k, f)` for each `f`, then
    ///   `rims_uv[k][i]`, as consecutive segments;
    /// - **rows** along the stroke: `p(i, k, f)` for consecutive `i`, one row per side
    ///   and fraction.
    ///
    /// Rows, rungs, the centreline and the rims cut the footprint's strip into quads
    /// with the profile's sample points at their corners, so each quad spans one step
    /// along the stroke and one profile interval across it. Wrapped into the square
    /// like [`Self::centre_segments`]; zero-length segments (a tapered end, where the
    /// rim meets the centre) are left out.
    pub fn wall_segments(&self, fracs: &[f64]) -> Vec<[DVec2; 2]> {
        let closed = self.buckets.closed;
        let n = self.centre_uv.len();
        let mut out = Vec::with_capacity(2 * n * (2 * fracs.len() + 1));
        let mut line: Vec<DVec2> = Vec::with_capacity(n.max(fracs.len() + 2));
        for rim in &self.rims_uv {
            for (&c, &r) in self.centre_uv.iter().zip(rim) {
                line.clear();
                line.push(c);
                line.extend(fracs.iter().map(|&f| c.lerp(r, f)));
                line.push(r);
                out.extend(wrapped_segments(&line, closed));
            }
            for &f in fracs {
                line.clear();
                line.extend(self.centre_uv.iter().zip(rim).map(|(c, r)| c.lerp(*r, f)));
                out.extend(wrapped_segments(&line, closed));
            }
        }
        out
    }

    /// True when `uv` (in the square) lies in the strip that [`Self::wall_segments`]
    /// cuts into quads, edges included: in one of the triangles `(c_i, c_i+1, x_i+1)`
    /// and `(c_i, x_i+1, x_i)` where `c` is the centreline and `x` either rim (those of
    /// no area, at a tapered end, left out). The end caps of blunt ends are not part of
    /// the strip.
    pub fn in_strip(&self, uv: DVec2) -> bool {
        let inside = |p: DVec2, t: [DVec2; 3]| {
            if (t[1] - t[0]).perp_dot(t[2] - t[0]).abs() <= crate::tolerance::UV_AREA_EPS {
                return false;
            }
            let s = [
                (t[1] - t[0]).perp_dot(p - t[0]),
                (t[2] - t[1]).perp_dot(p - t[1]),
                (t[0] - t[2]).perp_dot(p - t[2]),
            ];
            s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
        };
        let (c, [l, r]) = (&self.centre_uv, &self.rims_uv);
        let [(u0, u1), (v0, v1)] = self.buckets.shifts(uv);
        (v0..=v1)
            .flat_map(|kv| (u0..=u1).map(move |ku| uv + DVec2::new(ku as f64, kv as f64)))
            .any(|p| {
                self.buckets.candidates(p).iter().any(|&i| {
                    let i = i as usize;
                    [l, r].iter().any(|x| {
                        inside(p, [c[i], c[i + 1], x[i + 1]]) || inside(p, [c[i], x[i + 1], x[i]])
                    })
                })
            })
    }

    /// True when the stroke closes on itself (its end came back to its start): the
    /// centreline's last point is its first (up to whole periods on a closed target) and
    /// the ends are not tapered.
    pub fn is_loop(&self) -> bool {
        self.is_loop
    }

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
        let (a, b) = (self.centre[i], self.centre[i + 1]);
        let d = b - a;
        let l2 = d.length_squared();
        let t = if l2 > 0.0 {
            ((p - a).dot(d) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let hw = self.half_width[i] + (self.half_width[i + 1] - self.half_width[i]) * t;
        p.distance(a + d * t) / hw
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
            dep * self.tool.profile.shape(r / hw)
        } else {
            0.0
        }
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

/// True when consecutive feet `a` and `b` (unwrapped parameter, point) of samples
/// `spacing` apart lie in different basins of the distance: the true closest point
/// jumped (the stroke passed over a valley whose far side is nearer) rather than slid.
///
/// The closest-point map moves a foot by `spacing / |1 - d k|` for a query at distance
/// `d` over a principal curvature `k` (Euler's formula along the motion, do Carmo
/// section 3-2): no faster than the query over convex or flat ground, unboundedly only
/// at a focal point, where it tears. So the feet jumped when the way between them
/// along the surface, the length of the surface path over the straight parameter
/// segment (an upper bound of the geodesic, sampled at [`JUMP_PATH_SEGMENTS`] chords),
/// exceeds [`BASIN_JUMP_RATIO`] times the sample spacing. Feet no farther apart in 3D
/// than the spacing are never a jump (valleys narrower than the sample spacing, a
/// quarter of the tool width, are below the stroke's resolution).
fn basin_jump(
    surface: &dyn ParamSurface,
    spacing: f64,
    a: (DVec2, DVec3),
    b: (DVec2, DVec3),
) -> bool {
    let limit = BASIN_JUMP_RATIO * spacing;
    if a.1.distance(b.1) <= spacing {
        return false;
    }
    let mut length = 0.0;
    let mut last = a.1;
    for k in 1..=JUMP_PATH_SEGMENTS {
        let t = k as f64 / JUMP_PATH_SEGMENTS as f64;
        let point = if k == JUMP_PATH_SEGMENTS {
            b.1
        } else {
            surface.eval(wrap_uv(a.0.lerp(b.0, t))).p
        };
        length += last.distance(point);
        if length > limit {
            return true;
        }
        last = point;
    }
    false
}

/// The centreline through a pole: where a step leaves (or reaches) the side `v = 0`
/// or `v = 1` with a jump in `u`, the projection went over a pole (a whole side of the
/// square that is one point), and the centreline first runs along that side to the new
/// `u`, a step of no 3D length, so that no segment cuts across the cells round the
/// pole.
fn through_poles(run: &[(DVec2, DVec3)]) -> Vec<(DVec2, DVec3)> {
    let mut out: Vec<(DVec2, DVec3)> = Vec::with_capacity(run.len() + 2);
    for (k, &(uv, p)) in run.iter().enumerate() {
        if let Some(&(prev, q)) = out.last()
            && k > 0
            && (uv.x - prev.x).abs() > 0.25
        {
            let side = |y: f64| y == 0.0 || y == 1.0;
            if side(prev.y) {
                out.push((DVec2::new(uv.x, prev.y), q));
            } else if side(uv.y) {
                out.push((DVec2::new(prev.x, uv.y), p));
            }
        }
        out.push((uv, p));
    }
    out
}

/// Bounding rectangle of a non-empty polygon.
fn bounds_of(poly: &[DVec2]) -> Rect {
    poly.iter().fold(Rect::new(poly[0], poly[0]), |r, &p| {
        Rect::new(r.min.min(p), r.max.max(p))
    })
}

/// The whole-period shifts (zero in open directions) that bring a copy of `rect` to
/// meet the closed unit square.
fn period_shifts(rect: &Rect, closed: [bool; 2]) -> impl Iterator<Item = DVec2> + use<> {
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
fn clip_to_box(poly: &[DVec2], lo: DVec2, hi: DVec2) -> Vec<DVec2> {
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
fn wrapped_segments(line: &[DVec2], closed: [bool; 2]) -> Vec<[DVec2; 2]> {
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

/// Parameter step that best realises the 3D displacement `d` (least squares on `[Su Sv]`).
fn uv_step(du: DVec3, dv: DVec3, d: DVec3) -> DVec2 {
    let (aa, ab, bb) = (du.dot(du), du.dot(dv), dv.dot(dv));
    let det = aa * bb - ab * ab;
    if det.abs() <= crate::tolerance::DIVISOR_MIN || !det.is_finite() {
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

/// A uniform grid over the stroke's unwrapped bounds (centreline, rims and caps in the
/// plane of [`Stroke::centre_uv`]) listing the centreline segments near each cell, so
/// that [`Stroke::depth_at`] tests only a few segments. On a closed target a query is
/// also made at its copies shifted by whole periods ([`Self::shifts`]), so the stroke is
/// found from both sides of the seam.
#[derive(Debug, Clone)]
struct Buckets {
    bounds: Rect,
    closed: [bool; 2],
    n: usize,
    cells: Vec<Vec<u32>>,
}

impl Buckets {
    fn new(centre: &[DVec2], rims: &[Vec<DVec2>; 2], bounds: Rect, closed: [bool; 2]) -> Self {
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
    fn shifts(&self, uv: DVec2) -> [(i64, i64); 2] {
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

    fn candidates(&self, uv: DVec2) -> &[u32] {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::sculpt::jordan::Location;
    use crate::sculpt::surface::test_surfaces::plane;
    use crate::tolerance::{
        AREA_SYMMETRY_EPS, EXACT_EPS, FOOTPRINT_AREA_TOL, POINT_EPS, SEAM_DEPTH_TOL,
    };

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
    fn build(s: &TargetSurface, samples: Vec<(f64, DVec3)>) -> Stroke {
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
            POINT_EPS
        );
        assert_near!(
            st.depth_at(DVec2::new(0.5, 0.525), DVec3::new(0.5, 0.525, 0.0)),
            0.01,
            POINT_EPS
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
            FOOTPRINT_AREA_TOL
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

    /// Along the equator of the unit sphere from `from` to `to` degrees (the seam
    /// u = 0 = 1 of the test sphere is at 180 degrees, u growing with the angle), one
    /// sample per degree.
    fn equator(from: f64, to: f64) -> Vec<(f64, DVec3)> {
        let n = (to - from).round() as usize + 1;
        (0..n)
            .map(|k| {
                let a = (from + k as f64).to_radians();
                (k as f64, DVec3::new(a.cos(), a.sin(), 0.0))
            })
            .collect()
    }

    #[test]
    fn stroke_across_the_seam_of_a_sphere_wraps() {
        use crate::sculpt::surface::test_surfaces::sphere;
        let s = sphere(1.0);
        let st = build(&s, equator(150.0, 205.0));
        // One run, unwrapped: u continues past 1 instead of jumping back to 0.
        assert!(
            st.centre_uv
                .windows(2)
                .all(|w| (w[1] - w[0]).length() < 0.01)
        );
        let (first, last) = (st.centre_uv[0], st.centre_uv[st.centre_uv.len() - 1]);
        assert!(first.x < 1.0 && first.x > 0.9, "{first:?}");
        assert!(last.x > 1.0 && last.x < 1.1, "{last:?}");
        // On the equator, where the samples are (the ends are exact resampled points).
        let at = |deg: f64| {
            let a = f64::to_radians(deg);
            [a.cos(), a.sin(), 0.0]
        };
        assert_near!(s.eval(wrap_uv(first)).p.to_array(), at(150.0), POINT_EPS);
        assert_near!(s.eval(wrap_uv(last)).p.to_array(), at(205.0), POINT_EPS);
        // The footprint in the square covers both sides of the seam.
        for u in [0.002, 0.05, 0.95, 0.998] {
            assert_eq!(
                st.footprint.locate(DVec2::new(u, 0.5)),
                Location::Inside,
                "{u}"
            );
        }
        assert!(
            st.footprint
                .contours()
                .iter()
                .flatten()
                .all(|p| (0.0..=1.0).contains(&p.x))
        );
        // Same area as the stroke turned half-way round, away from the seam (the
        // sphere's four quarter arcs have the same parametrisation).
        let away = build(&s, equator(-30.0, 25.0));
        assert_near!(
            st.footprint.area(),
            away.footprint.area(),
            AREA_SYMMETRY_EPS
        );
        // Full depth on the centreline either side of the seam, from either copy (the
        // depth is measured from the centreline's chords: their sag, spacing^2 / 8R, is
        // under 1e-4 m).
        for u in [0.999, 0.001, 1.001, -0.001] {
            let uv = DVec2::new(u, 0.5);
            assert_near!(
                st.depth_at(uv, s.eval(wrap_uv(uv)).p),
                0.02,
                SEAM_DEPTH_TOL,
                "{u}"
            );
        }
    }

    #[test]
    fn a_stroke_back_at_its_start_is_an_untapered_loop() {
        let s = plane(1.0);
        let circle = |turns: f64| -> Vec<(f64, DVec3)> {
            (0..=100)
                .map(|i| {
                    let a = i as f64 / 100.0 * turns * std::f64::consts::TAU;
                    (
                        i as f64,
                        DVec3::new(0.5 + 0.2 * a.cos(), 0.5 + 0.2 * a.sin(), 0.0),
                    )
                })
                .collect()
        };
        let mut tapered = tool();
        tapered.taper = 0.1;
        let input = |samples| StrokeInput {
            samples,
            tool: tapered.clone(),
        };
        let round = Stroke::build(&s, &input(circle(1.0)), 0.1).unwrap();
        assert!(round.is_loop());
        assert!(round.depth.iter().all(|&d| d == 0.02));
        // Full depth at the join (the start, at angle 0).
        let join = DVec2::new(0.7, 0.5);
        assert_near!(round.depth_at(join, join.extend(0.0)), 0.02, POINT_EPS);
        // Three quarters of a turn is no loop: its ends taper.
        let open = Stroke::build(&s, &input(circle(0.75)), 0.1).unwrap();
        assert!(!open.is_loop());
        assert_eq!(open.depth[0], 0.0);
    }

    #[test]
    fn wrapped_centre_segments_split_exactly_on_the_seam() {
        let line = [
            DVec2::new(0.9, 0.95),
            DVec2::new(1.1, 1.05),
            DVec2::new(1.1, 1.05),
            DVec2::new(1.3, 1.2),
        ];
        let segs = wrapped_segments(&line, [true, true]);
        // Cut at u = 1 and at v = 1 (both at t = 0.5 here: one corner point), then
        // shifted into the square; the repeated point gives no segment.
        assert_eq!(segs.len(), 3, "{segs:?}");
        assert_eq!(segs[0], [DVec2::new(0.9, 0.95), DVec2::new(1.0, 1.0)]);
        assert_eq!(segs[1][0], DVec2::new(0.0, 0.0));
        assert!(
            segs.iter()
                .flatten()
                .all(|p| (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y))
        );
        // Open directions are left alone.
        let open = wrapped_segments(&line[..2], [false, false]);
        assert_eq!(open, vec![[line[0], line[1]]]);
    }

    #[test]
    fn clip_to_box_keeps_the_part_inside() {
        let tri = [
            DVec2::new(-2.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
        ];
        let c = clip_to_box(&tri, DVec2::splat(-1.0), DVec2::splat(2.0));
        assert!(c.iter().all(|p| p.x >= -1.0));
        // The triangle's area right of x = -1: the integral of (x + 2) / 3 over [-1, 1].
        assert_near!(signed_area(&c).abs(), 4.0 / 3.0, EXACT_EPS);
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
                .any(|p| p.distance(DVec3::new(1.0, 0.0, 0.0)) < EXACT_EPS)
        );
        for w in out.windows(2) {
            assert!(w[0].distance(w[1]) <= 0.05 + POINT_EPS);
        }
    }
}
