//! Lattice deformation: a trivariate B-spline volume used as a free-form deformer
//! (Sederberg and Parry, *Free-form deformation of solid geometric models*, 1986, with
//! the B-spline lattice of Griessmair and Purgathofer, *Deformation of solids with
//! trivariate B-splines*, 1989).
//!
//! A [`Lattice`] is fitted to the bounding box of one or more targets' control points
//! (padded by [`BOX_PAD_REL`]); its control points sit at the **Greville abscissae** of
//! the box, so at rest it maps every point to itself (linear precision, P&T eq. 9.4 and
//! sec. 9.2.3: `sum_i N_i,p(u) g_i = u`). Moving a group of its control points by `d_I`
//! makes the map
//!
//! `F(x) = x + sum_I N_I(s(x)) d_I`, with `s(x) = (x - box_min) / box_size` (1)
//!
//! evaluated as a three-attribute [`Volume`] (Park 2005, eq. 1) holding the
//! displacements `d_I`. Writing `F` as the identity plus a displacement volume is the
//! same map as evaluating the volume of the moved control points `g_I + d_I`
//! (linear precision), but it is *bit-exact* at rest and wherever no moved control
//! point's basis function reaches: untouched geometry does not drift.
//!
//! A target deforms by mapping each of its control points through (1)
//! ([`Lattice::deform_surface`]); weights are kept. This is the usual FFD
//! approximation: the exact image `F(S(u, v))` is a surface of degree `3 p` in each of
//! `u`, `v` (for a polynomial `S` of degree `p` and a tricubic lattice), which the
//! mapped control net does not represent. [`composition_error`] measures the gap on a
//! sample grid; `docs/lattice.md` reports it for a test bend and how knot refinement of
//! the target shrinks it.
//!
//! A deformation as a document edit is a [`DeformEdit`]: which targets, the lattice's
//! shape ([`LatticeSpec`]), the grabbed point, the radius of the group and the
//! displacement. It is what the journal records (`{"edit":"deform",...}`), and its
//! reader checks every field ([`LatticeError`]).
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::editor::default_surface;
//! use sculpt_core::lattice::{Lattice, LatticeSpec};
//!
//! let sheet = default_surface();
//! let mut lattice = Lattice::around(LatticeSpec::default(), &[&sheet])?;
//! // At rest the lattice is the identity, bit for bit.
//! let p = sheet.point(0.3, 0.6);
//! assert_eq!(lattice.map_point(p), p);
//! // Grab the control points near the top middle of the cage and pull them forward.
//! let (lo, hi) = lattice.bounds();
//! let grab = DVec3::new(0.5 * (lo.x + hi.x), hi.y, hi.z);
//! let group = lattice.group(grab, 0.4)?;
//! lattice.displace(&group, DVec3::new(0.0, 0.0, 0.1))?;
//! let bent = lattice.deform_surface(&sheet)?;
//! assert!(bent.point(0.5, 1.0).z > sheet.point(0.5, 1.0).z);
//! # Ok::<(), sculpt_core::Error>(())
//! ```

use glam::{DVec2, DVec3, DVec4};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::nurbs::NurbsSurface;
use crate::sculpt::ids::{MAX_TARGETS, TargetId};
use crate::volume::{Volume, VolumeError};

#[cfg(test)]
mod tests;

/// Each side of a fitted lattice's box lies this fraction of the box's largest extent
/// outside the targets' control points, so flat targets get a box with volume and the
/// cage does not sit on the surface.
pub const BOX_PAD_REL: f64 = 0.05;
/// The least padding of each side of a fitted box (metres): 1 mm, for targets that are
/// a point.
pub const BOX_PAD_MIN_M: f64 = 0.001;
/// Most control points of a lattice per direction.
pub const MAX_COUNT: usize = 16;
/// Highest lattice degree per direction.
pub const MAX_DEGREE: usize = 5;
/// Largest grab radius and displacement length of one deformation (metres): far beyond
/// any sculpting gesture, small enough that nothing overflows.
pub const MAX_REACH_M: f64 = 100.0;

/// Why a lattice or a deformation is refused.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum LatticeError {
    /// A direction's control point count is outside `2..=MAX_COUNT`.
    #[error("direction {direction}: {count} control points is outside 2..={max}")]
    Count {
        /// 0, 1 or 2 (x, y, z).
        direction: usize,
        /// The count asked for.
        count: usize,
        /// [`MAX_COUNT`].
        max: usize,
    },
    /// A direction's degree is 0, above [`MAX_DEGREE`], or not below its count.
    #[error(
        "direction {direction}: degree {degree} needs 1..={max} and fewer than {count} control points"
    )]
    Degree {
        /// 0, 1 or 2 (x, y, z).
        direction: usize,
        /// The degree asked for.
        degree: usize,
        /// The direction's count.
        count: usize,
        /// [`MAX_DEGREE`].
        max: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which value.
        what: &'static str,
    },
    /// A length is negative or beyond [`MAX_REACH_M`].
    #[error("{what} {value} m is outside 0..={max} m")]
    Reach {
        /// `radius` or `displacement`.
        what: &'static str,
        /// The length.
        value: f64,
        /// [`MAX_REACH_M`].
        max: f64,
    },
    /// A deformation names no target.
    #[error("a deformation needs at least one target")]
    NoTargets,
    /// A deformation names more targets than a document holds.
    #[error("{count} targets, more than the {max} a document holds")]
    TooManyTargets {
        /// Targets named.
        count: usize,
        /// [`MAX_TARGETS`].
        max: usize,
    },
    /// A deformation names a target twice.
    #[error("target {id} is named twice")]
    DuplicateTarget {
        /// The id.
        id: TargetId,
    },
    /// No lattice control point lies within the radius of the grabbed point.
    #[error(
        "no lattice control point within {radius} m of {grab} (the nearest is {nearest_m:.4} m away)"
    )]
    NothingGrabbed {
        /// The grabbed point (display frame metres).
        grab: DVec3,
        /// The group radius.
        radius: f64,
        /// Distance to the nearest control point.
        nearest_m: f64,
    },
    /// A control point index is past the lattice's points.
    #[error("lattice control point {index} does not exist ({count} points)")]
    Index {
        /// The flat index.
        index: usize,
        /// Points in the lattice.
        count: usize,
    },
    /// The displacement volume could not be built.
    #[error("lattice volume")]
    Volume(#[source] Box<VolumeError>),
}

/// The shape of a lattice: degree and control point count along x, y and z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LatticeSpec {
    /// Degree along x, y, z.
    pub degree: [usize; 3],
    /// Control points along x, y, z.
    pub counts: [usize; 3],
}

impl Default for LatticeSpec {
    /// Tricubic, 4 x 4 x 4: one Bézier volume.
    fn default() -> Self {
        Self {
            degree: [3; 3],
            counts: [4; 3],
        }
    }
}

impl LatticeSpec {
    /// Checks the counts (`2..=MAX_COUNT`) and degrees (`1..=MAX_DEGREE`, below the
    /// count).
    pub fn validate(&self) -> Result<(), LatticeError> {
        for d in 0..3 {
            let (count, degree) = (self.counts[d], self.degree[d]);
            if !(2..=MAX_COUNT).contains(&count) {
                return Err(LatticeError::Count {
                    direction: d,
                    count,
                    max: MAX_COUNT,
                });
            }
            if degree == 0 || degree > MAX_DEGREE || degree >= count {
                return Err(LatticeError::Degree {
                    direction: d,
                    degree,
                    count,
                    max: MAX_DEGREE,
                });
            }
        }
        Ok(())
    }

    /// Control points in all.
    pub fn point_count(&self) -> usize {
        self.counts.iter().product()
    }
}

/// The clamped uniform knot vector on `[0, 1]` of `count` control points of degree
/// `degree` (P&T eq. 2.13 with equally spaced interior knots).
fn uniform_knots(degree: usize, count: usize) -> Vec<f64> {
    let spans = count - degree;
    let mut k = vec![0.0; degree + 1];
    k.extend((1..spans).map(|i| i as f64 / spans as f64));
    k.extend(std::iter::repeat_n(1.0, degree + 1));
    k
}

/// The Greville abscissae `g_i = (t_{i+1} + .. + t_{i+p}) / p` of a knot vector (P&T
/// eq. 9.4): the parameters at which control points reproduce the identity.
fn greville(knots: &[f64], degree: usize, count: usize) -> Vec<f64> {
    (0..count)
        .map(|i| knots[i + 1..=i + degree].iter().sum::<f64>() / degree as f64)
        .collect()
}

/// A trivariate B-spline lattice over an axis-aligned box (display frame metres) and
/// the displacements of its control points; see the module docs for the map.
#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    spec: LatticeSpec,
    box_min: DVec3,
    box_size: DVec3,
    knots: [Vec<f64>; 3],
    /// Greville abscissae per direction, in `[0, 1]`.
    greville: [Vec<f64>; 3],
    /// Displacement per control point, flat (x index slowest, z fastest).
    displacement: Vec<DVec3>,
    /// The displacement volume; `None` while every displacement is zero.
    volume: Option<Volume>,
}

impl Lattice {
    /// A lattice at rest over the box `(min, max)`: the box as given, no padding.
    /// A box side of zero length is refused ([`LatticeError::Reach`] for its size).
    pub fn fit(spec: LatticeSpec, min: DVec3, max: DVec3) -> Result<Self, LatticeError> {
        spec.validate()?;
        if !min.is_finite() || !max.is_finite() {
            return Err(LatticeError::NotFinite {
                what: "lattice box",
            });
        }
        let box_size = max - min;
        if box_size.min_element() <= 0.0 {
            return Err(LatticeError::Reach {
                what: "lattice box side",
                value: box_size.min_element(),
                max: f64::INFINITY,
            });
        }
        let knots = std::array::from_fn(|d| uniform_knots(spec.degree[d], spec.counts[d]));
        let greville = std::array::from_fn(|d| greville(&knots[d], spec.degree[d], spec.counts[d]));
        Ok(Self {
            spec,
            box_min: min,
            box_size,
            knots,
            greville,
            displacement: vec![DVec3::ZERO; spec.point_count()],
            volume: None,
        })
    }

    /// A lattice at rest around `surfaces`: the bounding box of their control points
    /// (which holds the surfaces: convex hull property, P&T sec. 3.4, property 4),
    /// padded on each side by [`BOX_PAD_REL`] of its largest extent, at least
    /// [`BOX_PAD_MIN_M`].
    pub fn around(spec: LatticeSpec, surfaces: &[&NurbsSurface]) -> Result<Self, LatticeError> {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for s in surfaces {
            let (a, b) = s.control_bounds();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        if surfaces.is_empty() {
            return Err(LatticeError::NoTargets);
        }
        let pad = (BOX_PAD_REL * (hi - lo).max_element()).max(BOX_PAD_MIN_M);
        Self::fit(spec, lo - DVec3::splat(pad), hi + DVec3::splat(pad))
    }

    /// Its shape.
    pub fn spec(&self) -> LatticeSpec {
        self.spec
    }

    /// The box `(min, max)`, display frame metres.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.box_min, self.box_min + self.box_size)
    }

    /// The flat index of control point `(i, j, k)` (x, y, z).
    pub fn flat(&self, [i, j, k]: [usize; 3]) -> usize {
        let c = self.spec.counts;
        (i * c[1] + j) * c[2] + k
    }

    fn unflat(&self, flat: usize) -> [usize; 3] {
        let c = self.spec.counts;
        [flat / (c[1] * c[2]), (flat / c[2]) % c[1], flat % c[2]]
    }

    /// Control point `flat` at rest: the box point at its Greville abscissae.
    pub fn rest_point(&self, flat: usize) -> DVec3 {
        let [i, j, k] = self.unflat(flat);
        let g = DVec3::new(
            self.greville[0][i],
            self.greville[1][j],
            self.greville[2][k],
        );
        self.box_min + g * self.box_size
    }

    /// The control points as they are now (rest plus displacement), flat.
    pub fn control_points(&self) -> Vec<DVec3> {
        (0..self.displacement.len())
            .map(|f| self.rest_point(f) + self.displacement[f])
            .collect()
    }

    /// True while no control point has moved.
    pub fn at_rest(&self) -> bool {
        self.volume.is_none()
    }

    /// The control points whose current position lies within `radius` of `grab`
    /// (flat indices, ascending); [`LatticeError::NothingGrabbed`] when there are none.
    pub fn group(&self, grab: DVec3, radius: f64) -> Result<Vec<usize>, LatticeError> {
        check_point("grab point", grab)?;
        check_reach("radius", radius)?;
        let points = self.control_points();
        let group: Vec<usize> = (0..points.len())
            .filter(|&f| points[f].distance(grab) <= radius)
            .collect();
        if group.is_empty() {
            let nearest_m = points
                .iter()
                .map(|p| p.distance(grab))
                .fold(f64::INFINITY, f64::min);
            return Err(LatticeError::NothingGrabbed {
                grab,
                radius,
                nearest_m,
            });
        }
        Ok(group)
    }

    /// Moves the control points `group` (flat indices) by `by` and rebuilds the
    /// displacement volume.
    pub fn displace(&mut self, group: &[usize], by: DVec3) -> Result<(), LatticeError> {
        check_point("displacement", by)?;
        check_reach("displacement", by.length())?;
        let count = self.displacement.len();
        if let Some(&index) = group.iter().find(|&&f| f >= count) {
            return Err(LatticeError::Index { index, count });
        }
        for &f in group {
            self.displacement[f] += by;
        }
        self.rebuild()
    }

    fn rebuild(&mut self) -> Result<(), LatticeError> {
        if self.displacement.iter().all(|d| *d == DVec3::ZERO) {
            self.volume = None;
            return Ok(());
        }
        let values: Vec<f64> = self
            .displacement
            .iter()
            .flat_map(|d| d.to_array())
            .collect();
        let volume = Volume::new(
            self.spec.degree.to_vec(),
            self.knots.to_vec(),
            ["dx", "dy", "dz"].map(String::from).to_vec(),
            values,
            None,
        )
        .map_err(|e| LatticeError::Volume(Box::new(e)))?;
        self.volume = Some(volume);
        Ok(())
    }

    /// The lattice parameters of `p_in_display`: its place in the box, each in `[0, 1]`
    /// (points outside the box are clamped onto it).
    pub fn local(&self, p_in_display: DVec3) -> DVec3 {
        ((p_in_display - self.box_min) / self.box_size).clamp(DVec3::ZERO, DVec3::ONE)
    }

    /// The displacement `sum_I N_I(s(p)) d_I` at `p_in_display` (eq. 1 of the module
    /// docs); exactly zero at rest.
    pub fn displacement_at(&self, p_in_display: DVec3) -> DVec3 {
        let Some(volume) = &self.volume else {
            return DVec3::ZERO;
        };
        let s = self.local(p_in_display);
        let mut out = [0.0; 3];
        // The parameters are clamped into the domain and `out` holds the three
        // attributes, so evaluation cannot fail; zero is the safe fallback.
        match volume.eval_into(&s.to_array(), &mut out) {
            Ok(()) => DVec3::from_array(out),
            Err(_) => DVec3::ZERO,
        }
    }

    /// `F(p) = p + displacement_at(p)`: the lattice map (eq. 1 of the module docs).
    pub fn map_point(&self, p_in_display: DVec3) -> DVec3 {
        if self.volume.is_none() {
            return p_in_display;
        }
        p_in_display + self.displacement_at(p_in_display)
    }

    /// `surface` deformed: each control point mapped by [`Self::map_point`], weights
    /// and knots kept (so `(u, v)` keeps naming the same place on the surface).
    pub fn deform_surface(&self, surface: &NurbsSurface) -> crate::Result<NurbsSurface> {
        let pw: Vec<DVec4> = surface
            .homogeneous()
            .iter()
            .map(|h| {
                let p = self.map_point(h.truncate() / h.w);
                (p * h.w).extend(h.w)
            })
            .collect();
        // Checks every mapped point (finite, positive weight) as any new surface.
        NurbsSurface::from_homogeneous(surface.knots_u().clone(), surface.knots_v().clone(), pw)
    }

    /// The cage: segments between neighbouring control points along x, y and z, as
    /// they are now (for drawing).
    pub fn cage_edges(&self) -> Vec<(DVec3, DVec3)> {
        let c = self.spec.counts;
        let points = self.control_points();
        let mut edges = Vec::new();
        for i in 0..c[0] {
            for j in 0..c[1] {
                for k in 0..c[2] {
                    let a = points[self.flat([i, j, k])];
                    if i + 1 < c[0] {
                        edges.push((a, points[self.flat([i + 1, j, k])]));
                    }
                    if j + 1 < c[1] {
                        edges.push((a, points[self.flat([i, j + 1, k])]));
                    }
                    if k + 1 < c[2] {
                        edges.push((a, points[self.flat([i, j, k + 1])]));
                    }
                }
            }
        }
        edges
    }
}

fn check_point(what: &'static str, p: DVec3) -> Result<(), LatticeError> {
    if p.is_finite() {
        Ok(())
    } else {
        Err(LatticeError::NotFinite { what })
    }
}

fn check_reach(what: &'static str, value: f64) -> Result<(), LatticeError> {
    if !value.is_finite() {
        return Err(LatticeError::NotFinite { what });
    }
    if !(0.0..=MAX_REACH_M).contains(&value) {
        return Err(LatticeError::Reach {
            what,
            value,
            max: MAX_REACH_M,
        });
    }
    Ok(())
}

/// How far a control-point-mapped surface is from the exact composition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompositionError {
    /// Largest distance `|S_F(u, v) - F(S(u, v))|` over the samples (metres).
    pub max_m: f64,
    /// Mean distance over the samples (metres).
    pub mean_m: f64,
    /// Samples taken.
    pub samples: usize,
}

/// Compares `deformed` (the control-point-mapped surface, [`Lattice::deform_surface`])
/// with the exact composition `F(S(u, v))` on an `n x n` grid of the normalised
/// parameter square (`n >= 2`).
pub fn composition_error(
    lattice: &Lattice,
    original: &NurbsSurface,
    deformed: &NurbsSurface,
    n: usize,
) -> CompositionError {
    let n = n.max(2);
    let ((u0, u1), (v0, v1)) = (original.domain_u(), original.domain_v());
    let mut max_m: f64 = 0.0;
    let mut sum = 0.0;
    for a in 0..n {
        for b in 0..n {
            let uv = DVec2::new(a as f64, b as f64) / (n - 1) as f64;
            let (u, v) = (u0 + uv.x * (u1 - u0), v0 + uv.y * (v1 - v0));
            let exact = lattice.map_point(original.point(u, v));
            let d = deformed.point(u, v).distance(exact);
            max_m = max_m.max(d);
            sum += d;
        }
    }
    CompositionError {
        max_m,
        mean_m: sum / (n * n) as f64,
        samples: n * n,
    }
}

/// A deformation as one document edit (and one journal record): fit a lattice of
/// shape `lattice` around `targets` ([`Lattice::around`]), grab its control points
/// within `radius` of `grab` ([`Lattice::group`]) and move them by `displacement`;
/// every target is then mapped ([`Lattice::deform_surface`]) and its strokes follow
/// in UV.
///
/// Written `{"edit":"deform","targets":[1],"lattice":{"degree":[3,3,3],"counts":[4,4,4]},
/// "grab":[x,y,z],"radius":0.05,"displacement":[dx,dy,dz]}`; the reader checks every
/// field ([`DeformEdit::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DeformEditJson", into = "DeformEditJson")]
pub struct DeformEdit {
    /// The targets the lattice wraps, by id.
    pub targets: Vec<TargetId>,
    /// The lattice's shape.
    pub lattice: LatticeSpec,
    /// Where the wand grabbed (display frame metres).
    pub grab: DVec3,
    /// Control points within this distance of `grab` move (metres).
    pub radius: f64,
    /// How far they move (metres).
    pub displacement: DVec3,
}

impl DeformEdit {
    /// Checks every field: at least one target and at most [`MAX_TARGETS`], none
    /// twice; a valid [`LatticeSpec`]; finite points; radius and displacement length
    /// within `0..=MAX_REACH_M`.
    pub fn validate(&self) -> Result<(), LatticeError> {
        if self.targets.is_empty() {
            return Err(LatticeError::NoTargets);
        }
        if self.targets.len() > MAX_TARGETS {
            return Err(LatticeError::TooManyTargets {
                count: self.targets.len(),
                max: MAX_TARGETS,
            });
        }
        let mut seen = self.targets.clone();
        seen.sort_unstable();
        if let Some(w) = seen.windows(2).find(|w| w[0] == w[1]) {
            return Err(LatticeError::DuplicateTarget { id: w[0] });
        }
        self.lattice.validate()?;
        check_point("grab point", self.grab)?;
        check_reach("radius", self.radius)?;
        check_point("displacement", self.displacement)?;
        check_reach("displacement", self.displacement.length())
    }

    /// The lattice of this edit around `surfaces`, its group moved: the map the edit
    /// applies.
    pub fn lattice_around(&self, surfaces: &[&NurbsSurface]) -> Result<Lattice, LatticeError> {
        self.validate()?;
        let mut lattice = Lattice::around(self.lattice, surfaces)?;
        let group = lattice.group(self.grab, self.radius)?;
        lattice.displace(&group, self.displacement)?;
        Ok(lattice)
    }
}

/// [`DeformEdit`] as written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeformEditJson {
    targets: Vec<TargetId>,
    #[serde(default)]
    lattice: LatticeSpec,
    grab: DVec3,
    radius: f64,
    displacement: DVec3,
}

impl TryFrom<DeformEditJson> for DeformEdit {
    type Error = LatticeError;
    fn try_from(j: DeformEditJson) -> Result<Self, LatticeError> {
        let edit = Self {
            targets: j.targets,
            lattice: j.lattice,
            grab: j.grab,
            radius: j.radius,
            displacement: j.displacement,
        };
        edit.validate()?;
        Ok(edit)
    }
}

impl From<DeformEdit> for DeformEditJson {
    fn from(e: DeformEdit) -> Self {
        Self {
            targets: e.targets,
            lattice: e.lattice,
            grab: e.grab,
            radius: e.radius,
            displacement: e.displacement,
        }
    }
}
