//! Stroke surfaces: each stroke's groove (or ridge) as its own NURBS surface with its own
//! UV vector map, trimmed where other strokes remove it (paper 4.3).
//!
//! **The surface.** [`StrokeSurface::build`] samples the groove of a [`Stroke`] on a grid
//! of `rows x columns` points and interpolates the grid (P&T A9.4,
//! [`NurbsSurface::interpolate_grid`]):
//! - rows follow the projected centreline, one per stroke sample (at most [`MAX_ROWS`],
//!   evenly picked beyond that), plus [`TAPER_ROWS`] rows between samples whose depth
//!   or width changes by more than a tenth (tapered ends, where the depth field is the
//!   envelope of the sections' cones); the surface is **cubic along the stroke**;
//! - columns run across the profile from the left rim (`t = 0`) through the centre to the
//!   right rim (`t = 1`), at target parameters `lerp(centre_uv, rim_uv, |f|)` for profile
//!   fractions `f` in `[-1, 1]`. A **V** profile is **degree 1** across with every column
//!   a knot, so the centre crease is a control line; **U** and custom profiles are
//!   **cubic** across (the U's columns are at `f = sin(theta)`, evenly spaced in
//!   `theta`, so the steep walls near the rims are sampled as densely as the bottom);
//! - a grid point is `S(uv) + sign * depth_at(uv, S(uv)) * N(uv)`: rims (`|f| = 1`) lie
//!   on the target along the footprint outline, the centre at the tool depth, tapered
//!   ends go to zero depth; `sign` is `-1` to carve (inward) and `+1` to emboss. The
//!   target is evaluated through [`wrap_uv`], so strokes whose parameters leave the
//!   square across the seam of a closed target are evaluated where they are.
//!
//! The **fit tolerance** is [`StrokeSurface::fit_tolerance`]: 7.5 % of the tool depth
//! plus 0.1 % of the tool width. [`StrokeSurface::fit_error`] is the measured worst
//! distance (by point inversion) from the groove to the surface at every stroke sample
//! (also those not interpolated) and midway between rows, on every profile column and
//! midway between columns.
//! The grid points themselves are interpolated exactly; the error lies between columns,
//! mostly in tapered ends, where the swept depth field does not fall linearly to the
//! rims (a wider neighbouring section reaches past a narrower section's rim, and the
//! rims are held on the target). The paper scenes stay within the tolerance (tested);
//! a stroke that does not (a tight hook folding over itself) still gets its surface,
//! and [`StrokeSurface::fit_error`] says how far off it is.
//!
//! **The trim region** (paper 4.3). Where strokes overlap, the part of a stroke surface
//! inside another stroke's removed (carve) or added (emboss) volume is removed from the
//! stroke surface's UV map. The rendered mesh combines the strokes in document order
//! (carving lowers to `min(h, -depth)`, embossing raises to `max(h, height)`,
//! [`super::tessellate::height`]); a stroke surface point is visible exactly when that
//! combination ends at its own value. [`visibility_margin`] is a signed margin for that
//! test (negative: removed): against the strokes before it, `h_before - v` for carving
//! (`v - h_before` for embossing), and against each later stroke `j` acting there,
//! `-d_j - v` (carve `j`) or `v - d_j` (emboss `j`), with `v = sign * depth` the stroke
//! surface's own displacement, all at the foot of the stroke surface point on the target
//! ([`StrokeSurface::target_foot`]). The trim region is found by **marching squares on the
//! sign of that margin** over the stroke surface's own `(s, t)` domain: a grid of
//! [`MARCH_SUB_S`] cells per row interval and [`MARCH_SUB_T`] per column interval, edge
//! crossings placed by bisection of the visibility test (robust where the margin jumps,
//! at the outline of a later stroke of the other mode), and the cells' removed parts
//! united by a polygon boolean into a [`Region`]. It works for any number of mutually
//! overlapping strokes. Features smaller than one marching cell (about an eighth of the
//! tool width) may be missed.
//!
//! **The UV vector map** of a stroke surface is a [`UvMap`] over its normalised domain
//! (the knot domain, which is `[0, 1]^2`), its nodes classified against the trim region
//! by the Jordan test: interior nodes are removed, boundary nodes subdivided to the
//! detail's depth cap ([`map_cap`]). [`StrokeSurface::tessellate`] triangulates the
//! visible part through it.
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::nurbs::NurbsSurface;
//! use sculpt_core::sculpt::stroke::{Mode, Profile, Stroke, StrokeInput, Tool};
//! use sculpt_core::sculpt::stroke_surface::StrokeSurface;
//! use sculpt_core::sculpt::surface::TargetSurface;
//! let plane = NurbsSurface::new(1, 1, vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0],
//!     vec![vec![DVec3::ZERO, DVec3::Y], vec![DVec3::X, DVec3::new(1.0, 1.0, 0.0)]], None)?;
//! let tool = Tool { profile: Profile::V, width: 0.05, depth: 0.01, mode: Mode::Carve, taper: 0.02 };
//! let samples = (0..=50).map(|i| (i as f64, DVec3::new(0.2 + 0.012 * i as f64, 0.5, 0.0))).collect();
//! let target = TargetSurface::new(&plane);
//! let stroke = Stroke::build(&target, &StrokeInput { samples, tool }, 0.1)?;
//! let surf = StrokeSurface::build(&target, &stroke)?;
//! assert!(surf.fit_error() <= surf.fit_tolerance());
//! // The middle of the centre line sits at the tool depth below the plane.
//! let p = surf.point(glam::DVec2::new(0.5, 0.5));
//! assert!((p.z + 0.01).abs() < 1e-3);
//! # Ok::<(), sculpt_core::Error>(())
//! ```

use super::jordan::{Location, NodeClass, Rect, Region};
use super::stroke::{Mode, Profile, Stroke, domain_overlay, region_from_shapes};
use super::surface::{ParamSurface, TargetSurface, normal_from, wrap_uv};
use super::tessellate::{Detail, StrokeRef};
use super::uvmap::UvMap;
use crate::error::{Error, FitError, Result};
use crate::mesh::{MeshSink, MeshVertex, PatchKey};
use crate::nurbs::NurbsSurface;
use glam::{DVec2, DVec3};
use i_overlay::core::overlay_rule::OverlayRule;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use std::collections::HashMap;

/// At most this many rows (stroke samples) are interpolated; longer strokes use evenly
/// picked samples (the others are still checked by [`StrokeSurface::fit_error`]).
pub const MAX_ROWS: usize = 256;
/// Rows inserted between two samples across which the depth or width changes by more
/// than a tenth (tapered ends).
pub const TAPER_ROWS: usize = 3;
/// Marching-squares cells per row interval of the stroke surface.
pub const MARCH_SUB_S: usize = 2;
/// Marching-squares cells per column interval of the stroke surface.
pub const MARCH_SUB_T: usize = 2;
/// Bisection steps placing a trim outline crossing on a marching-squares cell edge.
const BISECTIONS: usize = 16;
/// Root cells per side of a stroke surface's UV map.
pub const MAP_ROOTS: u32 = 8;

/// Quadtree levels below the roots that boundary nodes of a stroke surface's UV map
/// reach: one more than the target's cap at each detail.
pub fn map_cap(detail: Detail) -> u8 {
    detail.cap() + 2
}

/// Profile fractions (`-1` left rim, `0` centre, `1` right rim) of the grid columns.
fn fractions(profile: &Profile) -> Vec<f64> {
    match profile {
        Profile::V => (0..=8).map(|k| -1.0 + 0.25 * k as f64).collect(),
        Profile::U => (0..=12)
            .map(|k| {
                let theta = -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * k as f64 / 12.0;
                // Exact ends and centre (sin of the rounded angles is not).
                match k {
                    0 => -1.0,
                    6 => 0.0,
                    12 => 1.0,
                    _ => theta.sin(),
                }
            })
            .collect(),
        Profile::Custom(_) => (0..=16).map(|k| -1.0 + 0.125 * k as f64).collect(),
    }
}

/// One stroke's surface: a NURBS surface over `[0, 1]^2` (`s` along the stroke, `t`
/// across), the target parameters of its grid, its trim region and its UV maps.
#[derive(Debug, Clone)]
pub struct StrokeSurface {
    surface: NurbsSurface,
    /// Parameter `s` of each grid row.
    s_params: Vec<f64>,
    /// Parameter `t` of each grid column.
    t_params: Vec<f64>,
    /// Stroke sample coordinate of each grid row (`i + a`: between samples `i` and
    /// `i + 1` at fraction `a`).
    rows: Vec<f64>,
    /// Profile fraction of each grid column.
    fracs: Vec<f64>,
    /// Target parameter (in the stroke's frame, unwrapped) of each grid point `[row][col]`.
    uv: Vec<Vec<DVec2>>,
    mode: Mode,
    /// Length along `s` over width along `t` (metres per unit of each), for shaping the
    /// tessellation's triangles in 3D rather than in the stretched domain.
    aspect: f64,
    fit_error: f64,
    fit_tolerance: f64,
    trim: Region,
    maps: [UvMap; 2],
}

fn fail(why: FitError) -> Error {
    Error::FitFailed(why)
}

/// The target parameter of the groove point at profile fraction `f` of sample `i`.
/// At a fractional sample coordinate `x`, the centre and rim lerp between the samples
/// on either side.
fn groove_uv(stroke: &Stroke, x: f64, f: f64) -> DVec2 {
    let rim = if f < 0.0 {
        &stroke.rims_uv[0]
    } else {
        &stroke.rims_uv[1]
    };
    let n = stroke.centre_uv.len();
    let x = x.clamp(0.0, (n - 1) as f64);
    let i = (x.floor() as usize).min(n - 2);
    let a = x - i as f64;
    let c = stroke.centre_uv[i].lerp(stroke.centre_uv[i + 1], a);
    let r = rim[i].lerp(rim[i + 1], a);
    c.lerp(r, f.abs())
}

/// The index of the centre column (fraction 0).
fn centre_col(fracs: &[f64]) -> usize {
    fracs
        .iter()
        .position(|&f| f == 0.0)
        .unwrap_or(fracs.len() / 2)
}

/// True when the section changes by more than a tenth between samples `i` and `i + 1`.
fn steep(stroke: &Stroke, i: usize) -> bool {
    let change = |a: f64, b: f64| (a - b).abs() > 0.1 * a.max(b);
    change(stroke.depth[i], stroke.depth[i + 1])
        || change(stroke.half_width[i], stroke.half_width[i + 1])
}

/// The groove point at target parameter `uv` (stroke frame): `S + sign * depth * N`,
/// with zero depth on the rims.
fn groove_point(target: &dyn ParamSurface, stroke: &Stroke, uv: DVec2, rim: bool) -> DVec3 {
    let w = wrap_uv(uv);
    let sp = target.eval(w);
    if rim {
        return sp.p;
    }
    let d = stroke.depth_at(uv, sp.p);
    sp.p + normal_from(target, w, &sp) * (sign(stroke.tool.mode) * d)
}

fn sign(mode: Mode) -> f64 {
    match mode {
        Mode::Carve => -1.0,
        Mode::Emboss => 1.0,
    }
}

/// Piecewise-linear position of `x` in the increasing `params`: `(k, a)` with `x`
/// between `params[k]` and `params[k + 1]` at fraction `a`.
fn locate(params: &[f64], x: f64) -> (usize, f64) {
    let n = params.len();
    if n < 2 {
        return (0, 0.0);
    }
    let x = if x.is_finite() { x } else { 0.5 };
    let k = params.partition_point(|&p| p <= x).clamp(1, n - 1) - 1;
    let span = params[k + 1] - params[k];
    let a = if span > 0.0 {
        ((x - params[k]) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (k, a)
}

impl StrokeSurface {
    /// Fits the stroke surface of `stroke` on `target` (see the module docs); untrimmed,
    /// with its UV maps all exterior. Fails (never panics) for a degenerate stroke: no
    /// width anywhere, a non-finite grid or a failed fit.
    pub fn build(target: &TargetSurface, stroke: &Stroke) -> Result<Self> {
        let n = stroke.centre_uv.len();
        if n < 2
            || stroke.rims_uv[0].len() != n
            || stroke.rims_uv[1].len() != n
            || stroke.half_width.len() != n
        {
            return Err(fail(FitError::StrokeTooFewSamples));
        }
        let widest = stroke.half_width.iter().copied().fold(0.0, f64::max);
        if widest.is_nan() || widest <= crate::tolerance::POINT_EPS {
            return Err(fail(FitError::StrokeNoWidth));
        }
        if stroke.depth.len() != n {
            return Err(fail(FitError::StrokeDepthCount));
        }
        let picked: Vec<usize> = if n <= MAX_ROWS {
            (0..n).collect()
        } else {
            let mut r: Vec<usize> = (0..MAX_ROWS)
                .map(|k| (k as f64 * (n - 1) as f64 / (MAX_ROWS - 1) as f64).round() as usize)
                .collect();
            r.dedup();
            r
        };
        let mut rows: Vec<f64> = Vec::with_capacity(picked.len() + 4 * TAPER_ROWS);
        // Steep intervals get TAPER_ROWS rows, their neighbours one (a graded spacing:
        // the interpolating cubic overshoots where the spacing jumps).
        let is_steep = |i: usize| i + 1 < n && steep(stroke, i);
        for w in picked.windows(2) {
            rows.push(w[0] as f64);
            let extra = if w[1] != w[0] + 1 {
                0
            } else if is_steep(w[0]) {
                TAPER_ROWS
            } else if (w[0] > 0 && is_steep(w[0] - 1)) || is_steep(w[0] + 1) {
                1
            } else {
                0
            };
            for k in 1..=extra {
                rows.push(w[0] as f64 + k as f64 / (extra + 1) as f64);
            }
        }
        rows.push((n - 1) as f64);
        let fracs = fractions(&stroke.tool.profile);
        let mut uv = Vec::with_capacity(rows.len());
        let mut grid = Vec::with_capacity(rows.len());
        for &i in &rows {
            let row_uv: Vec<DVec2> = fracs.iter().map(|&f| groove_uv(stroke, i, f)).collect();
            let row: Vec<DVec3> = row_uv
                .iter()
                .zip(&fracs)
                .map(|(&q, &f)| groove_point(target, stroke, q, f.abs() == 1.0))
                .collect();
            if row.iter().any(|p| !p.is_finite()) || row_uv.iter().any(|q| !q.is_finite()) {
                return Err(fail(FitError::StrokeSampleNotFinite { at: i }));
            }
            uv.push(row_uv);
            grid.push(row);
        }
        let degree_u = 3.min(rows.len() - 1);
        let degree_v = match stroke.tool.profile {
            Profile::V => 1,
            _ => 3,
        };
        let (surface, s_params, t_params) =
            NurbsSurface::interpolate_grid(&grid, degree_u, degree_v)?;
        let along: f64 = grid
            .windows(2)
            .map(|w| w[0][centre_col(&fracs)].distance(w[1][centre_col(&fracs)]))
            .sum();
        let across = grid
            .iter()
            .map(|row| row.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>())
            .fold(0.0, f64::max);
        let aspect = if along > 0.0 && across > 0.0 && (along / across).is_finite() {
            (along / across).clamp(crate::tolerance::ASPECT_MIN, 1e6)
        } else {
            1.0
        };
        let mut me = Self {
            surface,
            aspect,
            s_params,
            t_params,
            rows,
            fracs,
            uv,
            mode: stroke.tool.mode,
            fit_error: 0.0,
            fit_tolerance: crate::tolerance::FIT_TOL_DEPTH_REL * stroke.tool.depth
                + crate::tolerance::FIT_TOL_WIDTH_REL * stroke.tool.width,
            trim: Region::empty(),
            maps: [UvMap::new(MAP_ROOTS), UvMap::new(MAP_ROOTS)],
        };
        me.fit_error = me.measure_fit(target, stroke);
        if !me.fit_error.is_finite() {
            return Err(fail(FitError::NotFinite {
                what: "the stroke surface",
            }));
        }
        Ok(me)
    }

    /// The worst distance between the surface and the groove: at every stroke sample and
    /// midway between rows, on every grid column and midway between columns. Each
    /// distance is the groove point's deviation from the stroke surface: Newton point
    /// inversion (P&T eqs. 6.5 to 6.7) through the stroke surface's own inverter
    /// ([`crate::nurbs::SurfaceInverter::newton_from`]), seeded at the point's `(s, t)`,
    /// where the groove point belongs. Local on purpose: the global, certified query
    /// cost `scene4_stroke_surfaces` about 65 % more, and a fit is judged where its
    /// samples are.
    fn measure_fit(&self, target: &TargetSurface, stroke: &Stroke) -> f64 {
        let fitted = TargetSurface::new(&self.surface);
        let n = stroke.centre_uv.len();
        let mut worst: f64 = 0.0;
        // Every sample and every midpoint between rows.
        let mut probes: Vec<f64> = (0..n).map(|i| i as f64).collect();
        probes.extend(self.rows.windows(2).map(|w| 0.5 * (w[0] + w[1])));
        for x in probes {
            // s at sample coordinate x: linear in x between the rows around it.
            let (k, a) = locate(&self.rows, x);
            let k1 = (k + 1).min(self.rows.len() - 1);
            let s = self.s_params[k] + a * (self.s_params[k1] - self.s_params[k]);
            for c in 0..self.fracs.len() {
                let mut probes = vec![(self.t_params[c], self.fracs[c])];
                if c + 1 < self.fracs.len() {
                    probes.push((
                        0.5 * (self.t_params[c] + self.t_params[c + 1]),
                        0.5 * (self.fracs[c] + self.fracs[c + 1]),
                    ));
                }
                for (t, f) in probes {
                    let truth =
                        groove_point(target, stroke, groove_uv(stroke, x, f), f.abs() == 1.0);
                    // Geometric deviation: the distance from the groove point to the
                    // surface near its own parameter.
                    let d = fitted
                        .inverter()
                        .newton_from(truth, DVec2::new(s, t))
                        .distance;
                    worst = if d.is_finite() {
                        worst.max(d)
                    } else {
                        f64::INFINITY
                    };
                }
            }
        }
        worst
    }

    /// The NURBS surface (`u = s` along the stroke, `v = t` across, domain `[0, 1]^2`).
    pub fn surface(&self) -> &NurbsSurface {
        &self.surface
    }

    /// The point at `st` in the normalised domain.
    pub fn point(&self, st: DVec2) -> DVec3 {
        ParamSurface::eval(&self.surface, super::surface::clamp_uv(st)).p
    }

    /// Carve or emboss.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The measured fit error, metres (see the module docs).
    pub fn fit_error(&self) -> f64 {
        self.fit_error
    }

    /// The stated fit tolerance, metres: 7.5 % of the tool depth plus 0.1 % of the tool
    /// width.
    pub fn fit_tolerance(&self) -> f64 {
        self.fit_tolerance
    }

    /// The `s` parameters of the grid rows (one per interpolated stroke sample).
    pub fn row_params(&self) -> &[f64] {
        &self.s_params
    }

    /// The `t` parameters of the grid columns (left rim 0, right rim 1).
    pub fn column_params(&self) -> &[f64] {
        &self.t_params
    }

    /// The stroke sample coordinate of each grid row: `i` for sample `i`, `i + a` for a
    /// row inserted between samples `i` and `i + 1` (tapered ends).
    pub fn row_positions(&self) -> &[f64] {
        &self.rows
    }

    /// The profile fraction of each grid column (`-1` left rim, `0` centre, `1` right).
    pub fn column_fractions(&self) -> &[f64] {
        &self.fracs
    }

    /// The target parameter (in the stroke's frame: apply [`wrap_uv`] before evaluating
    /// the target) under the stroke surface point at `st`: bilinear in the grid.
    pub fn target_uv(&self, st: DVec2) -> DVec2 {
        let (k, a) = locate(&self.s_params, st.x);
        let (l, b) = locate(&self.t_params, st.y);
        let (k1, l1) = (
            (k + 1).min(self.uv.len() - 1),
            (l + 1).min(self.fracs.len() - 1),
        );
        let lo = self.uv[k][l].lerp(self.uv[k][l1], b);
        let hi = self.uv[k1][l].lerp(self.uv[k1][l1], b);
        lo.lerp(hi, a)
    }

    /// The target parameter (stroke frame) of the foot of the stroke surface point at
    /// `st` on the target: its closest point through the target's certified inverter,
    /// seeded at [`Self::target_uv`]. The point is `S(foot) + h N(foot)` with `h` its
    /// signed height; the bilinear [`Self::target_uv`] can sit off to the side on the
    /// steep walls of a U profile.
    pub fn target_foot(&self, target: &TargetSurface, st: DVec2) -> DVec2 {
        let uv = self.target_uv(st);
        let w = wrap_uv(uv);
        let foot = target.closest_point_from(self.point(st), w).uv_in_square;
        let moved = foot - w;
        // Stay in the stroke's frame (a step across the seam comes back as a small one).
        let moved = DVec2::new(
            moved.x - moved.x.round() * f64::from(u8::from(moved.x.abs() > 0.5)),
            moved.y - moved.y.round() * f64::from(u8::from(moved.y.abs() > 0.5)),
        );
        uv + moved
    }

    /// The trim region: the part of the domain removed by other strokes (empty when
    /// nothing overlaps).
    pub fn trim(&self) -> &Region {
        &self.trim
    }

    /// True when the point at `st` is drawn (not in the trim region).
    pub fn is_visible(&self, st: DVec2) -> bool {
        self.trim.locate(st) != Location::Inside
    }

    /// The UV vector map at a detail (classified against the trim region).
    pub fn map(&self, detail: Detail) -> &UvMap {
        &self.maps[detail_index(detail)]
    }

    /// Computes the trim region of the stroke `strokes[own]` against the other strokes
    /// on the same target (`strokes` in document order, as the tessellator takes them)
    /// and reclassifies both UV maps. `closed` says which directions of the target are
    /// closed (other strokes are also looked up across the seam there).
    pub fn trim_against(
        &mut self,
        target: &TargetSurface,
        strokes: &[StrokeRef<'_>],
        own: usize,
        closed: [bool; 2],
    ) {
        self.trim = self.trim_region(target, strokes, own, closed);
        for detail in [Detail::Interactive, Detail::Final] {
            let map = &mut self.maps[detail_index(detail)];
            *map = UvMap::new(MAP_ROOTS);
            map.update(&self.trim, None, map_cap(detail));
        }
    }

    fn trim_region(
        &self,
        target: &TargetSurface,
        strokes: &[StrokeRef<'_>],
        own: usize,
        closed: [bool; 2],
    ) -> Region {
        let Some((_, me)) = strokes.get(own) else {
            return Region::empty();
        };
        let pad = DVec2::splat(crate::tolerance::UV_PAD);
        let reach = Rect::new(me.bounds.min - pad, me.bounds.max + pad);
        let others: Vec<usize> = (0..strokes.len())
            .filter(|&j| j != own)
            .filter(|&j| {
                let b = strokes[j].1.bounds;
                shifts(closed)
                    .iter()
                    .any(|&d| Rect::new(b.min + d, b.max + d).touches(&reach))
            })
            .collect();
        if others.is_empty() {
            return Region::empty();
        }
        let ctx = Ctx {
            target,
            strokes,
            own,
            others: &others,
            closed,
        };
        let ss = subdivide(&self.s_params, MARCH_SUB_S);
        let ts = subdivide(&self.t_params, MARCH_SUB_T);
        let removed = |st: DVec2| ctx.removed(self, st);
        let (ns, nt) = (ss.len(), ts.len());
        let mut inside = vec![false; ns * nt];
        for (j, &t) in ts.iter().enumerate() {
            for (i, &s) in ss.iter().enumerate() {
                inside[j * ns + i] = removed(DVec2::new(s, t));
            }
        }
        let at = |i: usize, j: usize| inside[j * ns + i];
        let mut pieces: Vec<Vec<[f64; 2]>> = Vec::new();
        for j in 0..nt - 1 {
            let mut run: Option<usize> = None;
            for i in 0..ns - 1 {
                let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                let flags = corners.map(|(a, b)| at(a, b));
                let full = flags.iter().all(|&f| f);
                if full {
                    run.get_or_insert(i);
                    continue;
                }
                if let Some(r) = run.take() {
                    pieces.push(rect_piece(ss[r], ss[i], ts[j], ts[j + 1]));
                }
                if !flags.iter().any(|&f| f) {
                    continue;
                }
                let pts = corners.map(|(a, b)| DVec2::new(ss[a], ts[b]));
                let mut poly = Vec::with_capacity(8);
                for k in 0..4 {
                    let k1 = (k + 1) % 4;
                    if flags[k] {
                        poly.push(pts[k]);
                    }
                    if flags[k] != flags[k1] {
                        let (a, b) = if flags[k] {
                            (pts[k], pts[k1])
                        } else {
                            (pts[k1], pts[k])
                        };
                        poly.push(bisect(a, b, &removed));
                    }
                }
                if poly.len() >= 3 {
                    pieces.push(poly.iter().map(|p| [p.x, p.y]).collect());
                }
            }
            if let Some(r) = run {
                pieces.push(rect_piece(ss[r], ss[ns - 1], ts[j], ts[j + 1]));
            }
        }
        if pieces.is_empty() {
            return Region::empty();
        }
        region_from_shapes(domain_overlay(&pieces, &[], OverlayRule::Subject))
    }

    /// Tessellates the visible part of the stroke surface into `sink` as one patch
    /// `key`, through its UV map at `detail`: a constrained Delaunay triangulation (in
    /// the normalised domain) of the grid points, the corners of the map's boundary
    /// leaves (subdivided to the detail's cap along the trim outline) and the trim
    /// outline (as constraints), keeping the triangles outside the trim region. Normals face out of the material (along the target's
    /// normal at the groove). Returns the number of triangles written.
    pub fn tessellate(&self, detail: Detail, key: PatchKey, sink: &mut dyn MeshSink) -> usize {
        let mut points: Vec<DVec2> = Vec::new();
        let mut seen: HashMap<(u64, u64), usize> = HashMap::new();
        let mut add = |p: DVec2, points: &mut Vec<DVec2>| -> Option<usize> {
            if !p.is_finite() {
                return None;
            }
            let k = (p.x.to_bits(), p.y.to_bits());
            Some(*seen.entry(k).or_insert_with(|| {
                points.push(p);
                points.len() - 1
            }))
        };
        for &s in &self.s_params {
            for &t in &self.t_params {
                let p = DVec2::new(s, t);
                if self.trim.locate(p) != Location::Inside {
                    add(p, &mut points);
                }
            }
        }
        for (_, leaf) in self.map(detail).leaves() {
            // The grid covers the exterior leaves (their corners, square in (s, t) while
            // the surface is long along s, would make long chords); boundary leaves
            // refine the grid along the trim outline.
            if leaf.class != NodeClass::Boundary {
                continue;
            }
            let r = leaf.rect;
            for p in [
                r.min,
                DVec2::new(r.max.x, r.min.y),
                r.max,
                DVec2::new(r.min.x, r.max.y),
            ] {
                if self.trim.locate(p) != Location::Inside {
                    add(p, &mut points);
                }
            }
        }
        let mut constraints: Vec<(usize, usize)> = Vec::new();
        for c in self.trim.contours() {
            let ids: Vec<Option<usize>> = c.iter().map(|&p| add(p, &mut points)).collect();
            for k in 0..ids.len() {
                if let (Some(a), Some(b)) = (ids[k], ids[(k + 1) % ids.len()])
                    && a != b
                {
                    constraints.push((a, b));
                }
            }
        }
        // Triangulated with s stretched to the surface's proportions, so that the
        // triangles are well shaped on the surface, not in the unit square.
        let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
        let handles: Vec<_> = points
            .iter()
            .map(|p| cdt.insert(Point2::new(p.x * self.aspect, p.y)).ok())
            .collect();
        for (a, b) in constraints {
            if let (Some(a), Some(b)) = (handles[a], handles[b])
                && a != b
            {
                cdt.try_add_constraint(a, b);
            }
        }
        let by_handle: HashMap<usize, usize> = handles
            .iter()
            .enumerate()
            .filter_map(|(i, h)| h.map(|h| (h.index(), i)))
            .collect();
        let mut index = HashMap::new();
        let mut verts: Vec<MeshVertex> = Vec::new();
        let mut tris: Vec<[u32; 3]> = Vec::new();
        for f in cdt.inner_faces() {
            let vs = f.vertices();
            let Some(st) = vs
                .iter()
                .map(|v| by_handle.get(&v.fix().index()).map(|&i| points[i]))
                .collect::<Option<Vec<DVec2>>>()
            else {
                continue;
            };
            let centroid = (st[0] + st[1] + st[2]) / 3.0;
            if self.trim.locate(centroid) == Location::Inside {
                continue;
            }
            let mut ids = [0u32; 3];
            for k in 0..3 {
                let h = vs[k].fix().index();
                ids[k] = *index.entry(h).or_insert_with(|| {
                    verts.push(self.vertex(st[k]));
                    verts.len() as u32 - 1
                });
            }
            // Counter-clockwise in (s, t) faces -N: reverse to face out of the material.
            tris.push([ids[0], ids[2], ids[1]]);
        }
        sink.begin_patch(key);
        for v in verts {
            sink.push_vertex(v);
        }
        for &[a, b, c] in &tris {
            sink.push_triangle(a, b, c);
        }
        sink.end_patch();
        tris.len()
    }

    fn vertex(&self, st: DVec2) -> MeshVertex {
        let st = super::surface::clamp_uv(st);
        let sp = ParamSurface::eval(&self.surface, st);
        // dv x du faces out of the material (see the module docs).
        let mut n = sp.dv.cross(sp.du).normalize_or_zero();
        if n == DVec3::ZERO || !n.is_finite() {
            // A degenerate point (a tapered end): the normal a little way inside.
            let q = st + (DVec2::splat(0.5) - st) * crate::tolerance::DEGENERATE_NORMAL_INSET;
            let sq = ParamSurface::eval(&self.surface, q);
            n = sq.dv.cross(sq.du).normalize_or_zero();
        }
        let p = if sp.p.is_finite() { sp.p } else { DVec3::ZERO };
        let n = if n.is_finite() { n } else { DVec3::Z };
        MeshVertex {
            position: p.as_vec3().to_array(),
            normal: n.as_vec3().to_array(),
            uv: st.as_vec2().to_array(),
        }
    }

    /// Memory held, bytes (approximate).
    pub fn memory_bytes(&self) -> usize {
        let grid = self.uv.len() * self.fracs.len();
        grid * (16 + 32)
            + self.trim.segments().len() * 48
            + self.maps.iter().map(UvMap::memory_bytes).sum::<usize>()
    }
}

fn detail_index(detail: Detail) -> usize {
    match detail {
        Detail::Interactive => 0,
        Detail::Final => 1,
    }
}

fn rect_piece(s0: f64, s1: f64, t0: f64, t1: f64) -> Vec<[f64; 2]> {
    vec![[s0, t0], [s1, t0], [s1, t1], [s0, t1]]
}

/// `params` with `sub - 1` evenly spaced values inserted in every interval.
fn subdivide(params: &[f64], sub: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(params.len() * sub);
    for w in params.windows(2) {
        for k in 0..sub {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / sub as f64);
        }
    }
    if let Some(&last) = params.last() {
        out.push(last);
    }
    out.dedup();
    out
}

/// The point where `removed` changes between `a` (removed) and `b` (not), by bisection.
fn bisect(a: DVec2, b: DVec2, removed: &impl Fn(DVec2) -> bool) -> DVec2 {
    let (mut lo, mut hi) = (a, b);
    for _ in 0..BISECTIONS {
        let m = (lo + hi) * 0.5;
        if removed(m) {
            lo = m;
        } else {
            hi = m;
        }
    }
    (lo + hi) * 0.5
}

/// The offsets by which a stroke's parameters may differ from another's on a target
/// closed in the given directions.
fn shifts(closed: [bool; 2]) -> Vec<DVec2> {
    let mut out = vec![DVec2::ZERO];
    for (axis, &c) in closed.iter().enumerate() {
        if c {
            let e = if axis == 0 { DVec2::X } else { DVec2::Y };
            let now = out.clone();
            for d in now {
                out.push(d + e);
                out.push(d - e);
            }
        }
    }
    out
}

/// The parameters of `uv` in every frame another stroke may use: itself, wrapped into
/// the square, and shifted across the seams of closed directions.
fn variants(uv: DVec2, closed: [bool; 2]) -> Vec<DVec2> {
    let mut out = vec![uv];
    let w = wrap_uv(uv);
    for d in shifts(closed) {
        let q = w + d;
        if !out.contains(&q) {
            out.push(q);
        }
    }
    out
}

/// What the visibility margin needs.
struct Ctx<'a, 'b> {
    target: &'a TargetSurface,
    strokes: &'a [StrokeRef<'b>],
    own: usize,
    /// Strokes whose bounds meet the own stroke's, in document order.
    others: &'a [usize],
    closed: [bool; 2],
}

impl Ctx<'_, '_> {
    /// Whether another stroke removes the stroke surface point `st`: its margin at the
    /// foot (see [`StrokeSurface::target_foot`]) is negative. No other stroke near
    /// means not removed.
    fn removed(&self, me: &StrokeSurface, st: DVec2) -> bool {
        let uv = me.target_uv(st);
        let vars = variants(uv, self.closed);
        let near: Vec<usize> = self
            .others
            .iter()
            .copied()
            .filter(|&j| {
                let b = self.strokes[j].1.bounds;
                vars.iter().any(|&q| b.contains(q))
            })
            .collect();
        if near.is_empty() {
            return false;
        }
        let uv = me.target_foot(self.target, st);
        let p = self.target.eval(wrap_uv(uv)).p;
        visibility_margin_at(
            self.strokes,
            self.own,
            &near,
            uv,
            p,
            self.closed,
            Need::Sign,
        ) < 0.0
    }
}

/// The depth of `s` at `p` if it acts at the target parameter `uv` (its footprint
/// contains `uv` in one of the frames of [`variants`]), else 0; as the tessellator's
/// `height` decides.
fn acting_depth(s: &Stroke, uv: DVec2, p: DVec3, closed: [bool; 2]) -> f64 {
    variants(uv, closed)
        .into_iter()
        .filter(|&q| s.bounds.contains(q) && s.footprint.locate(q) != Location::Outside)
        .map(|q| s.depth_at(q, p))
        .fold(0.0, f64::max)
}

/// How much of the visibility margin a caller needs.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Need {
    /// The exact signed margin.
    Margin,
    /// Only its sign: the scan stops at the first stroke that proves the margin
    /// negative and returns a negative value (not the exact margin). With many
    /// overlapping strokes this turns the common "removed" case from a scan of every
    /// stroke into a scan up to the first that removes the point (issue 15: exporting
    /// 60 nearly coincident strokes spent most of its time here).
    Sign,
}

fn visibility_margin_at(
    strokes: &[StrokeRef<'_>],
    own: usize,
    near: &[usize],
    uv: DVec2,
    p: DVec3,
    closed: [bool; 2],
    need: Need,
) -> f64 {
    let me = strokes[own].1;
    let v = sign(me.tool.mode) * me.depth_at(uv, p);
    let margin_of = |h: f64| match me.tool.mode {
        Mode::Carve => h - v,
        Mode::Emboss => v - h,
    };
    // Strokes of my own mode only push the envelope of the earlier strokes further
    // past me (carving deeper, embossing higher), so once the margin is negative and
    // no earlier stroke of the other mode is left, it stays negative.
    let last_other_mode = near
        .iter()
        .copied()
        .filter(|&j| j < own && strokes[j].1.tool.mode != me.tool.mode)
        .max();
    let mut h_before: f64 = 0.0;
    for &j in near.iter().filter(|&&j| j < own) {
        let s = strokes[j].1;
        let d = acting_depth(s, uv, p, closed);
        if d > 0.0 {
            h_before = match s.tool.mode {
                Mode::Carve => h_before.min(-d),
                Mode::Emboss => h_before.max(d),
            };
        }
        if need == Need::Sign && margin_of(h_before) < 0.0 && last_other_mode.is_none_or(|k| j >= k)
        {
            return margin_of(h_before);
        }
    }
    let mut margin = margin_of(h_before);
    for &j in near.iter().filter(|&&j| j > own) {
        if need == Need::Sign && margin < 0.0 {
            return margin;
        }
        let s = strokes[j].1;
        let d = acting_depth(s, uv, p, closed);
        if d > 0.0 {
            margin = margin.min(match s.tool.mode {
                Mode::Carve => -d - v,
                Mode::Emboss => v - d,
            });
        }
    }
    margin
}

/// The signed visibility margin (metres) of the stroke surface of `strokes[own]` at the
/// target parameter `uv` (the stroke's frame): non-negative where its groove is the
/// final surface, negative where another stroke removes it (see the module docs).
pub fn visibility_margin(
    target: &dyn ParamSurface,
    strokes: &[StrokeRef<'_>],
    own: usize,
    uv: DVec2,
    closed: [bool; 2],
) -> f64 {
    if own >= strokes.len() {
        return f64::INFINITY;
    }
    let p = target.eval(wrap_uv(uv)).p;
    let near: Vec<usize> = (0..strokes.len()).filter(|&j| j != own).collect();
    visibility_margin_at(strokes, own, &near, uv, p, closed, Need::Margin)
}
