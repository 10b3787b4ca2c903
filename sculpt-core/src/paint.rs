//! Painted attributes: colour (and any scalar the sculptor names, e.g. `density`)
//! carried by a VNURBS **attribute volume** over a target's bounding box (Park,
//! *Volumetric NURBS representation of multidimensional and heterogeneous objects*,
//! 2005, sec. 3.1: scattered-data approximation).
//!
//! - A paint stroke ([`PaintEdit`]) is the wand's path, a brush radius, the attribute's
//!   name and the value painted. [`deposit`] turns it into samples **on the target**:
//!   for every wand sample within the brush radius of the target, its closest point `c`
//!   and the closest points of a disc of [`RING_POINTS`] points on each of two rings
//!   (radius `r/2` and `r`) in the tangent plane at `c`.
//! - An [`AttributeField`] keeps every sample deposited so far (a new sample replaces
//!   the older ones within [`AttributeField::spacing`] of it, so painting over a spot
//!   recolours it) and the volume fitted to them. The fit is redone **once per stroke**
//!   and **locally** ([`AttributeField::painted`]): only the control points whose
//!   support meets the brush around the stroke's samples are solved for
//!   ([`crate::volume::Volume::refit_local`]), the rest keep their values;
//!   [`AttributeField::painted_whole`] refits the whole volume (the reference).
//! - The fitted volume's attributes are the value times a **coverage** `a` (1 where
//!   paint was deposited), and `a` itself: premultiplied, so the background, sampled
//!   as coverage 0 on the target and on a grid of the box away from the paint, pulls
//!   both to zero. Grid cells near the paint take its nearest value instead, so every
//!   control point has samples around it (paint on a surface alone would leave the
//!   field free across the surface, and the normal equations singular).
//!   [`AttributeField::eval`] returns `(value, coverage)` with `value = A / a` and `a`
//!   clamped to `[0, 1]`; [`AttributeField::colour_over`] blends a colour field over a
//!   base colour.
//!
//! The box is the target's control-point bounding box (which holds the surface, P&T
//! sec. 3.4) padded like a lattice's ([`crate::lattice::BOX_PAD_REL`]); the volume is
//! quadratic with [`FIELD_RESOLUTION`] control points along the box's longest side and
//! proportionally fewer (at least 3) along the others.
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::paint::AttributeField;
//! let field = AttributeField::new("colour", 3, DVec3::ZERO, DVec3::ONE).unwrap();
//! let spot: Vec<DVec3> = (0..30)
//!     .map(|i| DVec3::new(0.3 + 0.01 * (i % 6) as f64, 0.5 + 0.01 * (i / 6) as f64, 0.5))
//!     .collect();
//! let painted = field.painted(&spot, &[1.0, 0.0, 0.0], 0.05).unwrap();
//! let (value, coverage) = painted.eval(DVec3::new(0.32, 0.52, 0.5));
//! assert!(coverage > 0.9 && (value[0] - 1.0).abs() < 0.1);
//! assert!(painted.eval(DVec3::new(0.9, 0.1, 0.1)).1 < 0.1);
//! ```

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::sculpt::document::TargetId;
use crate::sculpt::surface::{ParamSurface, TargetSurface, normal_from};
use crate::volume::{FitError, Volume, VolumeError};

/// The name of the colour attribute (three components, linear RGB in `[0, 1]`).
pub const COLOUR: &str = "colour";
/// Control points of an attribute volume along its box's longest side.
pub const FIELD_RESOLUTION: usize = 20;
/// Degree of an attribute volume in each direction.
pub const FIELD_DEGREE: usize = 2;
/// Knot spans by which a paint stroke's local refit reaches beyond its brush
/// ([`AttributeField::painted`]).
pub const LOCAL_REFIT_RINGS: usize = 2;
/// Points on each of the brush's two rings around a wand sample's closest point.
pub const RING_POINTS: usize = 6;
/// Most wand samples of one paint stroke.
pub const MAX_STROKE_SAMPLES: usize = 4096;
/// Most samples an attribute field keeps (older ones are replaced, see the module docs).
pub const MAX_FIELD_SAMPLES: usize = 60_000;
/// Largest brush radius (metres).
pub const MAX_BRUSH_RADIUS_M: f64 = 1.0;
/// Longest attribute name (characters): a word such as `density` or `hardness`.
pub const MAX_NAME_CHARS: usize = 32;
/// Largest magnitude of a painted scalar.
pub const MAX_SCALAR: f64 = 1.0e6;

pub use crate::error::PaintError;

/// The number of values an attribute takes: 3 for [`COLOUR`], 1 for any other.
pub fn components_of(attribute: &str) -> usize {
    if attribute == COLOUR { 3 } else { 1 }
}

/// Checks an attribute's name (see [`PaintError::Name`]).
pub fn check_name(name: &str) -> Result<(), PaintError> {
    let ok = !name.is_empty()
        && name.chars().count() <= MAX_NAME_CHARS
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_');
    if ok {
        Ok(())
    } else {
        Err(PaintError::Name {
            name: name.chars().take(MAX_NAME_CHARS + 1).collect(),
            max: MAX_NAME_CHARS,
        })
    }
}

/// One paint stroke: what the interaction asks for and the journal records, as
/// `{"edit": "paint", "target": 1, "attribute": "colour", "value": [r, g, b],
/// "radius": 0.03, "samples": [[x, y, z], ...]}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PaintEdit {
    /// The painted target's id.
    pub target: TargetId,
    /// The attribute: [`COLOUR`] or a scalar's name.
    pub attribute: String,
    /// The value painted: linear RGB in `[0, 1]` for colour, one number otherwise.
    pub value: Vec<f64>,
    /// The brush radius (metres).
    pub radius: f64,
    /// The wand tip's path (display frame metres).
    pub samples: Vec<DVec3>,
}

impl PaintEdit {
    /// Checks every field (see [`PaintError`]).
    pub fn validate(&self) -> Result<(), PaintError> {
        check_name(&self.attribute)?;
        let need = components_of(&self.attribute);
        if self.value.len() != need {
            return Err(PaintError::ValueCount {
                attribute: self.attribute.clone(),
                got: self.value.len(),
                need,
            });
        }
        for &v in &self.value {
            if !v.is_finite() {
                return Err(PaintError::NotFinite { what: "value" });
            }
            let ok = if need == 3 {
                (0.0..=1.0).contains(&v)
            } else {
                v.abs() <= MAX_SCALAR
            };
            if !ok {
                return Err(PaintError::ValueRange {
                    attribute: self.attribute.clone(),
                    value: v,
                });
            }
        }
        if !(self.radius.is_finite() && self.radius > 0.0 && self.radius <= MAX_BRUSH_RADIUS_M) {
            return Err(PaintError::Radius {
                radius: self.radius,
                max: MAX_BRUSH_RADIUS_M,
            });
        }
        if self.samples.is_empty() {
            return Err(PaintError::NoSamples);
        }
        if self.samples.len() > MAX_STROKE_SAMPLES {
            return Err(PaintError::TooManySamples {
                count: self.samples.len(),
                max: MAX_STROKE_SAMPLES,
            });
        }
        if self.samples.iter().any(|p| !p.is_finite()) {
            return Err(PaintError::NotFinite {
                what: "wand sample",
            });
        }
        Ok(())
    }
}

/// The colour of unpainted surface in exports with vertex colours (linear RGB): a
/// light clay grey.
pub const UNPAINTED: [f32; 3] = [0.8, 0.8, 0.78];

/// The default brush radius (metres): a broad paintbrush.
pub const DEFAULT_BRUSH_RADIUS_M: f64 = 0.03;
/// The default brush colour (linear RGB): terracotta.
pub const DEFAULT_BRUSH_COLOUR: [f64; 3] = [0.8, 0.3, 0.15];

/// What a paint stroke paints: the attribute, its value and the brush radius (the
/// interaction's paint settings; `{"attribute": "density", "value": [250.0],
/// "radius": 0.03}` in a [`crate::interaction::Command::SetBrush`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Brush {
    /// [`COLOUR`] or a scalar's name.
    pub attribute: String,
    /// The value painted (3 components for colour, 1 otherwise).
    pub value: Vec<f64>,
    /// The radius (metres).
    pub radius: f64,
}

impl Default for Brush {
    fn default() -> Self {
        Self {
            attribute: COLOUR.into(),
            value: DEFAULT_BRUSH_COLOUR.to_vec(),
            radius: DEFAULT_BRUSH_RADIUS_M,
        }
    }
}

impl Brush {
    /// The paint stroke of this brush on `target` along `samples`.
    pub fn stroke(&self, target: TargetId, samples: Vec<DVec3>) -> PaintEdit {
        PaintEdit {
            target,
            attribute: self.attribute.clone(),
            value: self.value.clone(),
            radius: self.radius,
            samples,
        }
    }

    /// Checks the brush as [`PaintEdit::validate`] does (a stroke of one sample).
    pub fn validate(&self) -> Result<(), PaintError> {
        self.stroke(0, vec![DVec3::ZERO]).validate()
    }
}

/// The samples a paint stroke deposits on `target` (see the module docs): for every
/// wand sample within `radius` of the target, its closest point and the closest
/// points of two rings of [`RING_POINTS`] around it in the tangent plane. Wand samples
/// closer than `radius / 4` to the last one that deposited add nothing (a resting
/// wand does not pile samples up). Empty when no wand sample reaches the target.
pub fn deposit(target: &TargetSurface, samples: &[DVec3], radius: f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    let mut seed: Option<DVec2> = None;
    let mut last: Option<DVec3> = None;
    for &p in samples {
        if last.is_some_and(|l| l.distance(p) < 0.25 * radius) {
            continue;
        }
        let c = match seed {
            None => target.closest_point(p),
            Some(s) => target.closest_point_from(p, s),
        };
        if c.distance > radius {
            continue;
        }
        seed = Some(c.uv_in_square);
        last = Some(p);
        let sp = target.eval(c.uv_in_square);
        let n = normal_from(target, c.uv_in_square, &sp);
        // An orthonormal tangent frame at the closest point (P&T sec. 6.1: the
        // normal is du x dv; any unit vector orthogonal to it spans the plane).
        let t1 = n.any_orthonormal_vector();
        let t2 = n.cross(t1);
        out.push(sp.p);
        for ring in [0.5 * radius, radius] {
            for k in 0..RING_POINTS {
                let angle = std::f64::consts::TAU * k as f64 / RING_POINTS as f64;
                let q = sp.p + (t1 * angle.cos() + t2 * angle.sin()) * ring;
                let on = target.closest_point_from(q, c.uv_in_square);
                out.push(on.point);
            }
        }
    }
    out
}

/// An attribute field over a box: the samples deposited so far and the VNURBS volume
/// fitted to them (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct AttributeField {
    name: String,
    components: usize,
    box_min: DVec3,
    box_size: DVec3,
    counts: [usize; 3],
    /// `(position, value)` of every sample kept.
    samples: Vec<(DVec3, Vec<f64>)>,
    /// Points of the target (coverage 0 where no paint is near, see [`Self::around`]).
    background: Vec<DVec3>,
    /// Attributes: the value's components times coverage, then coverage.
    volume: Option<Volume>,
}

impl AttributeField {
    /// An empty field named `name` of `components` values over the box `lo..hi`.
    pub fn new(name: &str, components: usize, lo: DVec3, hi: DVec3) -> Result<Self, PaintError> {
        check_name(name)?;
        let size = hi - lo;
        if !lo.is_finite() || !size.is_finite() || size.min_element() <= 0.0 {
            return Err(PaintError::Box);
        }
        let longest = size.max_element();
        let counts = size.to_array().map(|s| {
            ((FIELD_RESOLUTION as f64 * s / longest).ceil() as usize)
                .clamp(FIELD_DEGREE + 1, FIELD_RESOLUTION)
        });
        Ok(Self {
            name: name.to_owned(),
            components,
            box_min: lo,
            box_size: size,
            counts,
            samples: Vec::new(),
            background: Vec::new(),
            volume: None,
        })
    }

    /// The field for a target: the bounding box of `surface`'s control points,
    /// padded like a lattice's box ([`crate::lattice::BOX_PAD_REL`], at least
    /// [`crate::lattice::BOX_PAD_MIN_M`]), with background samples on the surface
    /// itself (`target`, the same surface): a grid of `2 FIELD_RESOLUTION` points a
    /// side of its parameter square, so the fit is held to "unpainted" where the
    /// surface is and the paint is not.
    pub fn around(
        name: &str,
        components: usize,
        surface: &crate::nurbs::NurbsSurface,
        target: &TargetSurface,
    ) -> Result<Self, PaintError> {
        let (lo, hi) = surface.control_bounds();
        let pad = (crate::lattice::BOX_PAD_REL * (hi - lo).max_element())
            .max(crate::lattice::BOX_PAD_MIN_M);
        let mut field = Self::new(
            name,
            components,
            lo - DVec3::splat(pad),
            hi + DVec3::splat(pad),
        )?;
        let n = 2 * FIELD_RESOLUTION;
        field.background = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| {
                let uv = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                target.eval(uv).p
            })
            .filter(|p| p.is_finite())
            .collect();
        Ok(field)
    }

    /// The attribute's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Values per sample.
    pub fn components(&self) -> usize {
        self.components
    }

    /// The box, `(min, max)`.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.box_min, self.box_min + self.box_size)
    }

    /// The samples kept.
    pub fn sample_count(&self) -> usize {
        self.samples.len()
    }

    /// The fitted volume (none before the first stroke).
    pub fn volume(&self) -> Option<&Volume> {
        self.volume.as_ref()
    }

    /// Half the volume's smallest control spacing: a new sample replaces the kept ones
    /// closer than this.
    pub fn spacing(&self) -> f64 {
        let cell = (0..3)
            .map(|d| self.box_size[d] / (self.counts[d] - FIELD_DEGREE) as f64)
            .fold(f64::INFINITY, f64::min);
        0.5 * cell
    }

    /// The box parameter of `p`: `(p - min) / size`, clamped to the unit cube.
    fn param(&self, p: DVec3) -> DVec3 {
        ((p - self.box_min) / self.box_size).clamp(DVec3::ZERO, DVec3::ONE)
    }

    /// This field with `positions` painted `value` (one stroke) and refitted: the
    /// kept samples within [`Self::spacing`] of a new one are dropped, the new ones
    /// added, and the volume refitted **locally** (Park 2005, sec. 3.1, on the control
    /// points near the stroke, [`Volume::refit_local`]): the free control points are
    /// those whose support meets the brush (`radius`) around a new or dropped sample,
    /// the others keep their values, and the samples are those of
    /// [`Self::refit_whole`] in the cells that touch a free point: the painted ones,
    /// a sample at every cell centre of a grid of the box (the volume's control counts
    /// per direction), coverage 0 farther than `radius` from every painted sample and
    /// the nearest painted value within it, and the target's own background points
    /// (coverage 0) farther than `radius` from the paint. The first stroke starts
    /// from the unpainted field (all zeros: the whole fit of unpainted samples).
    pub fn painted(
        &self,
        positions: &[DVec3],
        value: &[f64],
        radius: f64,
    ) -> Result<Self, PaintError> {
        self.painted_local(positions, value, radius, LOCAL_REFIT_RINGS)
    }

    /// [`Self::painted`] with the free control points' region grown by `rings` knot
    /// spans beyond the brush in every direction.
    fn painted_local(
        &self,
        positions: &[DVec3],
        value: &[f64],
        radius: f64,
        rings: usize,
    ) -> Result<Self, PaintError> {
        let (field, removed) = self.with_samples(positions, value)?;
        let start = match &self.volume {
            Some(v) => v.clone(),
            None => self.unpainted()?,
        };
        let changed: Vec<f64> = positions
            .iter()
            .chain(&removed)
            .flat_map(|p| self.param(*p).to_array())
            .collect();
        let span = DVec3::from_array(self.counts.map(|c| 1.0 / (c - FIELD_DEGREE) as f64));
        let reach = (DVec3::splat(radius) / self.box_size + rings as f64 * span).to_array();
        let fit = |e| PaintError::Fit(Box::new(e));
        let region = start.local_region(&changed, &reach).map_err(fit)?;
        let (params, values) =
            field.fit_samples(radius, |s| start.region_takes(&region, &s.to_array()));
        let volume = start.refit_local(&region, &params, &values).map_err(fit)?;
        Ok(Self {
            volume: Some(volume),
            ..field
        })
    }

    /// This field with `positions` painted `value` and the whole volume fitted afresh
    /// to every sample ([`Volume::fit_scattered`], see [`Self::painted`] for the
    /// samples): the reference [`Self::painted`]'s local refit is tested against.
    pub fn painted_whole(
        &self,
        positions: &[DVec3],
        value: &[f64],
        radius: f64,
    ) -> Result<Self, PaintError> {
        let (field, _) = self.with_samples(positions, value)?;
        field.refit_whole(radius)
    }

    /// This field with its volume fitted afresh to all its samples (the whole fit of
    /// [`Self::painted_whole`]; samples as [`Self::painted`] lists them, `radius` the
    /// brush's).
    pub fn refit_whole(&self, radius: f64) -> Result<Self, PaintError> {
        let (params, values) = self.fit_samples(radius, |_| true);
        let volume = Volume::fit_scattered(
            &params,
            &values,
            self.volume_attributes(),
            &[FIELD_DEGREE; 3],
            &self.counts,
        )
        .map_err(|e| PaintError::Fit(Box::new(e)))?;
        Ok(Self {
            volume: Some(volume),
            ..self.clone()
        })
    }

    /// This field's samples with `positions` painted `value` (the kept ones within
    /// [`Self::spacing`] of a new one dropped), no volume; and the positions dropped.
    fn with_samples(
        &self,
        positions: &[DVec3],
        value: &[f64],
    ) -> Result<(Self, Vec<DVec3>), PaintError> {
        if value.len() != self.components {
            return Err(PaintError::ValueCount {
                attribute: self.name.clone(),
                got: value.len(),
                need: self.components,
            });
        }
        let spacing = self.spacing();
        let grid = SpatialGrid::new(positions, spacing);
        let mut removed = Vec::new();
        let mut samples: Vec<(DVec3, Vec<f64>)> =
            Vec::with_capacity(self.samples.len() + positions.len());
        for (p, v) in &self.samples {
            if grid.any_within(*p, spacing) {
                removed.push(*p);
            } else {
                samples.push((*p, v.clone()));
            }
        }
        samples.extend(positions.iter().map(|&p| (p, value.to_vec())));
        if samples.len() > MAX_FIELD_SAMPLES {
            return Err(PaintError::FieldFull {
                count: samples.len(),
                max: MAX_FIELD_SAMPLES,
            });
        }
        let field = Self {
            name: self.name.clone(),
            components: self.components,
            box_min: self.box_min,
            box_size: self.box_size,
            counts: self.counts,
            samples,
            background: self.background.clone(),
            volume: None,
        };
        Ok((field, removed))
    }

    /// The volume's attribute names: the value's components, then coverage.
    fn volume_attributes(&self) -> Vec<String> {
        let mut names: Vec<String> = (0..self.components)
            .map(|c| format!("{}{c}", self.name))
            .collect();
        names.push("coverage".into());
        names
    }

    /// The unpainted field's volume: zeros on the knots every fit of the field has
    /// (uniform and clamped over the unit box parameter: the fit's samples always
    /// include the box's corners).
    fn unpainted(&self) -> Result<Volume, PaintError> {
        let fit = |e| PaintError::Fit(Box::new(e));
        let knots = self
            .counts
            .iter()
            .enumerate()
            .map(|(direction, &c)| {
                crate::nurbs::KnotVector::uniform_clamped(FIELD_DEGREE, c)
                    .map(|kv| kv.knots().to_vec())
                    .map_err(|reason| {
                        fit(FitError::Volume(VolumeError::Knots { direction, reason }))
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let total: usize = self.counts.iter().product();
        Volume::new(
            vec![FIELD_DEGREE; 3],
            knots,
            self.volume_attributes(),
            vec![0.0; total * (self.components + 1)],
            None,
        )
        .map_err(|e| fit(FitError::Volume(e)))
    }

    /// The fit's samples (see [`Self::painted`]) whose box parameter `take` accepts:
    /// `(params, values)`, 3 and `components + 1` values a sample.
    fn fit_samples(&self, radius: f64, take: impl Fn(DVec3) -> bool) -> (Vec<f64>, Vec<f64>) {
        let k = self.components + 1;
        let all: Vec<DVec3> = self.samples.iter().map(|(p, _)| *p).collect();
        let near = SpatialGrid::new(&all, radius.max(self.spacing()));
        let mut params = Vec::with_capacity(3 * (self.samples.len() + 1024));
        let mut values = Vec::with_capacity(k * (self.samples.len() + 1024));
        for (p, v) in &self.samples {
            let s = self.param(*p);
            if take(s) {
                params.extend(s.to_array());
                values.extend(v);
                values.push(1.0);
            }
        }
        // The background: cell centres of the control grid, away from the paint; the
        // box's corners always (they span the parameter range, so the knots cover the
        // whole box).
        let [nx, ny, nz] = self.counts;
        for i in 0..nx {
            for j in 0..ny {
                for l in 0..nz {
                    let s = DVec3::new(
                        (i as f64 + 0.5) / nx as f64,
                        (j as f64 + 0.5) / ny as f64,
                        (l as f64 + 0.5) / nz as f64,
                    );
                    if !take(s) {
                        continue;
                    }
                    let p = self.box_min + s * self.box_size;
                    // Near the paint, the cell takes the nearest painted value: every
                    // control point then has samples around it, and the normal
                    // equations are well posed (paint on a surface alone leaves the
                    // field free across it).
                    params.extend(s.to_array());
                    match near.nearest_within(p, radius) {
                        Some(i) => {
                            values.extend(&self.samples[i].1);
                            values.push(1.0);
                        }
                        None => values.extend(std::iter::repeat_n(0.0, k)),
                    }
                }
            }
        }
        for p in &self.background {
            let s = self.param(*p);
            if take(s) && !near.any_within(*p, radius) {
                params.extend(s.to_array());
                values.extend(std::iter::repeat_n(0.0, k));
            }
        }
        for corner in 0..8 {
            let s = DVec3::new(
                f64::from(corner & 1),
                f64::from((corner >> 1) & 1),
                f64::from((corner >> 2) & 1),
            );
            if take(s) {
                params.extend(s.to_array());
                values.extend(std::iter::repeat_n(0.0, k));
            }
        }
        (params, values)
    }

    /// The field at `p`: `(value, coverage)`, coverage in `[0, 1]` (0 where nothing
    /// was painted; the value is then zeros).
    pub fn eval(&self, p: DVec3) -> (Vec<f64>, f64) {
        let mut out = vec![0.0; self.components + 1];
        let Some(volume) = &self.volume else {
            return (vec![0.0; self.components], 0.0);
        };
        if volume
            .eval_into(&self.param(p).to_array(), &mut out)
            .is_err()
        {
            return (vec![0.0; self.components], 0.0);
        }
        let a = out[self.components];
        let coverage = a.clamp(0.0, 1.0);
        if a <= crate::tolerance::PAINT_COVERAGE_MIN {
            return (vec![0.0; self.components], 0.0);
        }
        let value = out[..self.components].iter().map(|v| v / a).collect();
        (value, coverage)
    }

    /// A colour field's colour at `p` blended over `base` by its coverage, each
    /// component clamped to `[0, 1]`.
    pub fn colour_over(&self, p: DVec3, base: [f32; 3]) -> [f32; 3] {
        let (value, a) = self.eval(p);
        blend(base, &value, a)
    }

    /// The least and greatest first component of the samples kept (`None` before the
    /// first stroke): the range a heat map spans.
    pub fn value_range(&self) -> Option<(f64, f64)> {
        self.samples
            .iter()
            .map(|(_, v)| v[0])
            .fold(None, |r, v| match r {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
    }
}

/// `value` (each component clamped to `[0, 1]`) over `base` by coverage `a`:
/// `base (1 - a) + value a`.
pub fn blend(base: [f32; 3], value: &[f64], a: f64) -> [f32; 3] {
    let mut out = base;
    for (c, o) in out.iter_mut().enumerate() {
        let v = value.get(c).copied().unwrap_or(0.0).clamp(0.0, 1.0);
        *o = (f64::from(*o) * (1.0 - a) + v * a) as f32;
    }
    out
}

/// The heat-map colour of `t` in `[0, 1]` (clamped): blue, cyan, green, yellow, red,
/// piecewise linear between them.
pub fn heat(t: f64) -> [f32; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
    ];
    let x = t * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    [0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * f) as f32)
}

/// Points bucketed in cubes of side `cell`, for "is any point within `r`" and "which
/// is the nearest within `r`" queries.
struct SpatialGrid {
    cell: f64,
    buckets: std::collections::HashMap<(i64, i64, i64), Vec<(DVec3, usize)>>,
}

impl SpatialGrid {
    fn new(points: &[DVec3], cell: f64) -> Self {
        let mut g = Self {
            cell: cell.max(f64::MIN_POSITIVE),
            buckets: std::collections::HashMap::new(),
        };
        for (i, &p) in points.iter().enumerate() {
            let key = g.key(p);
            g.buckets.entry(key).or_default().push((p, i));
        }
        g
    }

    fn key(&self, p: DVec3) -> (i64, i64, i64) {
        let k = (p / self.cell).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    }

    fn any_within(&self, p: DVec3, r: f64) -> bool {
        self.nearest_within(p, r).is_some()
    }

    /// The index of the point nearest `p` closer than `r` (the first of equals).
    fn nearest_within(&self, p: DVec3, r: f64) -> Option<usize> {
        let reach = (r / self.cell).ceil() as i64;
        let (x, y, z) = self.key(p);
        let mut best: Option<(f64, usize)> = None;
        for i in -reach..=reach {
            for j in -reach..=reach {
                for l in -reach..=reach {
                    let Some(b) = self.buckets.get(&(x + i, y + j, z + l)) else {
                        continue;
                    };
                    for &(q, index) in b {
                        let d = q.distance_squared(p);
                        if d < r * r && best.is_none_or(|(bd, bi)| (d, index) < (bd, bi)) {
                            best = Some((d, index));
                        }
                    }
                }
            }
        }
        best.map(|(_, i)| i)
    }
}

mod shading;
pub use shading::{PaintShading, Shown, strongest};

#[cfg(test)]
mod tests;
