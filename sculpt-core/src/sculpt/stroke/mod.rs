//! Strokes: from a timed wand polyline to a footprint in the target's UV square and a
//! depth field.
//!
//! [`StrokePieces::build`] runs the pipeline (and [`Stroke::build`] for a stroke that
//! must be one piece):
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
//!    runs** at every jump and wherever it leaves the surface, and **every run is
//!    carved** as a piece of the one stroke ([`StrokePieces`]): a groove never bridges
//!    a jump, never follows a local minimum that is not the closest point (which a
//!    local Newton projection did, silently), and no part of the stroke whose closest
//!    points run continuously is lost. Runs no longer than the minimum stroke length
//!    (a lone foot between two jumps) are dropped and counted
//!    ([`StrokePieces::dropped`]); a stroke with no piece left is rejected. Steps 4
//!    and 5 run for each piece: each has its own tapered ends, rims and footprint.
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

mod build;
mod depth;
mod polygon;
mod resample;
#[cfg(test)]
mod tests;
mod tool;

use super::jordan::{Rect, Region};
#[cfg(doc)]
use super::surface::{TargetSurface, extent_sampled, unwrap_near, wrap_uv};
use crate::error::{Error, StrokeRejection};
#[cfg(doc)]
use crate::tolerance::BASIN_JUMP_RATIO;
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use polygon::{Buckets, wrapped_segments};
pub use polygon::{domain_overlay, region_from_shapes, region_to_contours, union};
pub use resample::resample;
pub use tool::{DEFAULT_TAPER, MAX_TOOL_SIZE, Mode, Profile, Tool};

/// Turns sharper than this (degrees, measured over one tool width) are corners.
pub const CORNER_ANGLE_DEG: f64 = 50.0;
pub use crate::tolerance::{CREASE_FRACTION, PROFILE_EDGE};
/// At most this many resampled samples per stroke (longer strokes get a wider spacing).
pub const MAX_SAMPLES: usize = 2000;
/// At most this many input samples are accepted.
pub const MAX_INPUT_SAMPLES: usize = 1_000_000;

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

/// A stroke as it is carved: one operation (one record in the document, its journal
/// entry, one undo step) made of **pieces**, one [`Stroke`] per run of the projected
/// centreline between basin jumps or gaps off the surface (see the module docs), in
/// drawing order. Each piece is grooved at the true closest points of its samples.
#[derive(Debug, Clone)]
pub struct StrokePieces {
    /// The carved pieces, in drawing order; never empty.
    pub pieces: Vec<Stroke>,
    /// Runs that were left uncarved: no longer than the minimum stroke length
    /// (`tool.width * MIN_STROKE_LEN_REL`), or with an empty footprint.
    pub dropped: usize,
}

impl StrokePieces {
    /// The pieces' footprint bounds together (the area the stroke changes).
    pub fn bounds(&self) -> Rect {
        let mut r = Rect::new(DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in &self.pieces {
            r = Rect::new(r.min.min(p.bounds.min), r.max.max(p.bounds.max));
        }
        r
    }

    /// Memory held by the pieces, bytes (approximate).
    pub fn memory_bytes(&self) -> usize {
        self.pieces.iter().map(Stroke::memory_bytes).sum()
    }
}

fn reject(why: StrokeRejection) -> Error {
    Error::StrokeRejected(why)
}

impl Stroke {
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
