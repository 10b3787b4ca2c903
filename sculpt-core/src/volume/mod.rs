//! Volumetric NURBS (VNURBS): an `n`-direction rational tensor-product map whose
//! control points carry `k` attributes (Park, *Volumetric NURBS representation of
//! multidimensional and heterogeneous objects: modeling and applications*, 2005).
//!
//! `A(u_1..u_n) = sum_I h_I A_I N_I(u) / sum_I h_I N_I(u)` (Park 2005, sec. 2, eqs. 1
//! to 5): `n = 1..=4` parameter directions, any degree up to
//! [`crate::nurbs::MAX_DEGREE`] in each, clamped knot vectors over any interval, `k`
//! attributes per control point (geometry `x, y, z`, density, velocity ...) and
//! optional positive weights `h_I`.
//!
//! - [`Volume`]: validation ([`VolumeError`]), evaluation and partial derivatives up to
//!   order 2 ([`Volume::derivatives`]), with a fast path for all first derivatives of
//!   a trivariate volume ([`Volume::eval_d1_into`]) that never allocates.
//! - [`refine`]: knot insertion (P&T A5.1), refinement (A5.4) and degree elevation
//!   (A5.9), each applied direction by direction to every line of the control net.
//! - [`json`]: the `wandsculpt-volume` file format (`docs/formats/volume.md`).
//! - [`fit`]: scattered-data approximation (sec. 3.1) and curvilinear grid
//!   interpolation (sec. 3.2).
//! - [`vtk`]: legacy VTK `STRUCTURED_GRID` files, bytes in and out.
//! - [`analysis`]: the curvilinear frame (covariant and contravariant base vectors,
//!   Jacobian, metric tensors, elements), gradient, divergence and curl of attributes
//!   in physical space, and the inverse map (sec. 4).
//! - [`integrate`]: Gauss-Legendre quadrature per knot span: the volume (or area,
//!   length) and the integral of every attribute.
//!
//! The basis functions are the NURBS kernel's ([`KnotVector::basis_ders2`], P&T A2.2
//! with eq. 2.7); evaluation computes them once per direction and contracts the tensor
//! product direction by direction on the homogeneous net (P&T A4.3 and A4.4 extended
//! to `n` directions).
//!
//! # Example
//!
//! ```
//! use sculpt_core::volume::Volume;
//!
//! // A trilinear unit cube carrying x, y, z and a density that grows with z.
//! let mut values = Vec::new();
//! for i in 0..2 {
//!     for j in 0..2 {
//!         for l in 0..2 {
//!             let (x, y, z) = (i as f64, j as f64, l as f64);
//!             values.extend([x, y, z, 1.0 + z]);
//!         }
//!     }
//! }
//! let k = vec![0.0, 0.0, 1.0, 1.0];
//! let vol = Volume::new(
//!     vec![1, 1, 1],
//!     vec![k.clone(), k.clone(), k],
//!     ["x", "y", "z", "rho"].map(String::from).to_vec(),
//!     values,
//!     None,
//! )?;
//! let mut out = [0.0; 4 * 4];
//! vol.eval_d1_into(&[0.5, 0.25, 0.75], &mut out)?;
//! assert_eq!(&out[..4], &[0.5, 0.25, 0.75, 1.75]);
//! assert_eq!(out[4 * 3 + 3], 1.0); // d rho / d u3
//! let totals = vol.integrate(4);
//! sculpt_core::assert_near!(totals.measure, 1.0, sculpt_core::tolerance::EXACT_EPS);
//! sculpt_core::assert_near!(totals.integrals[3], 1.5, sculpt_core::tolerance::EXACT_EPS);
//! # Ok::<(), sculpt_core::volume::VolumeError>(())
//! ```

pub mod analysis;
pub mod critical;
mod error;
mod eval;
#[cfg(target_arch = "x86_64")]
mod eval_simd;
pub mod fit;
mod grid;
pub mod integrate;
pub mod isosurface;
pub mod json;
pub mod morph;
pub mod refine;
mod span_poly;
pub mod streamline;
pub mod vtk;

pub use analysis::{Frame, VectorDerivatives, VolumeInverter};
pub use critical::{CriticalKind, CriticalPoint};
pub use error::{NetIndex, VolumeError, VolumeResult};
pub use eval::Derivatives;
pub use fit::{FitError, LocalRegion};
pub use integrate::Integrals;
pub use streamline::{FlowField, Streamline, StreamlineEnd, StreamlineOptions};
pub use vtk::{PointArray, StructuredGrid, VtkError};

use crate::nurbs::KnotVector;

/// The most parameter directions a volume may have.
pub const MAX_DIRECTIONS: usize = 4;
/// The most attributes (components) a control point may carry: evaluation keeps the
/// homogeneous sums in stack arrays of `MAX_COMPONENTS + 1` values.
pub const MAX_COMPONENTS: usize = 32;
/// The most control points a volume may have (a 128^3 net): refinement and the file
/// reader refuse more, so a hostile file cannot ask for gigabytes.
pub const MAX_CONTROL_POINTS: usize = 1 << 21;
/// The largest absolute control value a volume may hold: beyond it products in the
/// analysis overflow long before any real data set gets there.
pub const MAX_JSON_VALUE: f64 = 1e12;
/// Weights lie in `[1 / MAX_WEIGHT, MAX_WEIGHT]`, as for surfaces
/// ([`crate::nurbs::surface::MAX_JSON_WEIGHT`]).
pub const MAX_WEIGHT: f64 = 1e6;

/// A volumetric NURBS: `n` knot vectors, `k` named attributes and the homogeneous
/// control net `(h A_I, h)`.
///
/// The net is flat, with the first direction's index varying slowest: the point
/// `control_points[i1][i2]..[in]` of the file has index
/// `((i1 * c2 + i2) * c3 + i3) ...` (row-major, as the JSON nests it). Each point
/// takes `k + 1` consecutive values, the weight last.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    knots: Vec<KnotVector>,
    attributes: Vec<String>,
    /// Control points per direction.
    counts: Vec<usize>,
    /// Stride (in points) of each direction's index.
    strides: Vec<usize>,
    /// `k + 1`: values per homogeneous point.
    dim: usize,
    /// The homogeneous net `(h a_1, .., h a_k, h)` per point.
    cw: Vec<f64>,
    rational: bool,
    /// The basis of each direction as polynomials per span, for the SIMD evaluator:
    /// one table per direction when the volume is trivariate and all-cubic, else
    /// none ([`span_poly`]; derived from `knots`).
    cubic_spans: Vec<span_poly::CubicSpans>,
}

/// Advances the multi-index `idx` (last position fastest, `idx[d] < limit(d)`) by one;
/// false once it has run through all of them (it is then back at zero).
pub(crate) fn odometer_next(idx: &mut [usize], limit: impl Fn(usize) -> usize) -> bool {
    for d in (0..idx.len()).rev() {
        idx[d] += 1;
        if idx[d] < limit(d) {
            return true;
        }
        idx[d] = 0;
    }
    false
}

/// The multi-index of flat point `flat` for the counts `counts`.
fn unflatten(mut flat: usize, counts: &[usize]) -> NetIndex {
    let mut idx = vec![0; counts.len()];
    for d in (0..counts.len()).rev() {
        idx[d] = flat % counts[d];
        flat /= counts[d];
    }
    NetIndex(idx)
}

/// Validates the degrees and knots of every direction (clamped, [`KnotVector`] rules).
pub(crate) fn knot_vectors(
    degrees: &[usize],
    knots: Vec<Vec<f64>>,
) -> VolumeResult<Vec<KnotVector>> {
    let n = degrees.len();
    if n == 0 || n > MAX_DIRECTIONS {
        return Err(VolumeError::Directions {
            got: n,
            max: MAX_DIRECTIONS,
        });
    }
    if knots.len() != n {
        return Err(VolumeError::DegreeKnotCount {
            degrees: n,
            knots: knots.len(),
        });
    }
    let mut out = Vec::with_capacity(n);
    for (d, (k, &p)) in knots.into_iter().zip(degrees).enumerate() {
        let kv = KnotVector::new(p, k).map_err(|reason| VolumeError::Knots {
            direction: d,
            reason,
        })?;
        if !kv.is_clamped() {
            return Err(VolumeError::NotClamped {
                direction: d,
                need: p + 1,
            });
        }
        out.push(kv);
    }
    let mut total: usize = 1;
    for kv in &out {
        total = total.saturating_mul(kv.count());
    }
    if total > MAX_CONTROL_POINTS {
        return Err(VolumeError::TooManyControlPoints {
            count: total,
            max: MAX_CONTROL_POINTS,
        });
    }
    Ok(out)
}

fn check_attributes(attributes: &[String]) -> VolumeResult<()> {
    if attributes.is_empty() || attributes.len() > MAX_COMPONENTS {
        return Err(VolumeError::AttributeCount {
            got: attributes.len(),
            max: MAX_COMPONENTS,
        });
    }
    for (i, a) in attributes.iter().enumerate() {
        if a.is_empty() || attributes[..i].contains(a) {
            return Err(VolumeError::AttributeName {
                index: i,
                name: a.clone(),
            });
        }
    }
    Ok(())
}

impl Volume {
    /// Builds a volume from degrees, full clamped knot vectors, attribute names, the
    /// Cartesian control values (flat, row-major as the type docs say, `k` per point)
    /// and optional weights (one per point, default 1).
    pub fn new(
        degrees: Vec<usize>,
        knots: Vec<Vec<f64>>,
        attributes: Vec<String>,
        control_values: Vec<f64>,
        weights: Option<Vec<f64>>,
    ) -> VolumeResult<Self> {
        let knots = knot_vectors(&degrees, knots)?;
        check_attributes(&attributes)?;
        let k = attributes.len();
        let counts: Vec<usize> = knots.iter().map(KnotVector::count).collect();
        let total: usize = counts.iter().product();
        if control_values.len() != total * k {
            return Err(VolumeError::ControlValueCount {
                got: control_values.len(),
                need: total * k,
            });
        }
        if let Some(w) = weights.as_ref().filter(|w| w.len() != total) {
            return Err(VolumeError::ControlValueCount {
                got: w.len() * k,
                need: total * k,
            });
        }
        let mut cw = Vec::with_capacity(total * (k + 1));
        for (flat, point) in control_values.chunks(k).enumerate() {
            if let Some(c) = point
                .iter()
                .position(|v| !v.is_finite() || v.abs() > MAX_JSON_VALUE)
            {
                return Err(VolumeError::ControlValue {
                    at: unflatten(flat, &counts),
                    attribute: c,
                    value: point[c],
                    max: MAX_JSON_VALUE,
                });
            }
            let h = weights.as_ref().map_or(1.0, |w| w[flat]);
            if !(h.is_finite() && (1.0 / MAX_WEIGHT..=MAX_WEIGHT).contains(&h)) {
                return Err(VolumeError::Weight {
                    at: unflatten(flat, &counts),
                    weight: h,
                    max: MAX_WEIGHT,
                });
            }
            cw.extend(point.iter().map(|v| v * h));
            cw.push(h);
        }
        Ok(Self::from_parts(knots, attributes, cw))
    }

    /// Builds a volume from validated parts: knot vectors, names and the homogeneous
    /// net (`k + 1` values per point). The weights must be positive (refinement and
    /// elevation of a valid volume keep them so: they are convex combinations).
    pub(crate) fn from_parts(
        knots: Vec<KnotVector>,
        attributes: Vec<String>,
        cw: Vec<f64>,
    ) -> Self {
        let counts: Vec<usize> = knots.iter().map(KnotVector::count).collect();
        let mut strides = vec![1; counts.len()];
        for d in (0..counts.len().saturating_sub(1)).rev() {
            strides[d] = strides[d + 1] * counts[d + 1];
        }
        let dim = attributes.len() + 1;
        let rational = cw.chunks(dim).any(|p| p[dim - 1] != 1.0);
        let cubic_spans = if knots.len() == 3 {
            knots
                .iter()
                .map(span_poly::CubicSpans::new)
                .collect::<Option<Vec<_>>>()
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        Self {
            knots,
            attributes,
            counts,
            strides,
            dim,
            cw,
            rational,
            cubic_spans,
        }
    }

    /// The number of parameter directions `n`.
    pub fn directions(&self) -> usize {
        self.knots.len()
    }
    /// The number of attributes `k`.
    pub fn components(&self) -> usize {
        self.dim - 1
    }
    /// The attribute names.
    pub fn attributes(&self) -> &[String] {
        &self.attributes
    }
    /// The index of the attribute named `name`.
    pub fn attribute(&self, name: &str) -> Option<usize> {
        self.attributes.iter().position(|a| a == name)
    }
    /// The knot vector of direction `d`.
    pub fn knots(&self, d: usize) -> &KnotVector {
        &self.knots[d]
    }
    /// All knot vectors.
    pub fn knot_vectors(&self) -> &[KnotVector] {
        &self.knots
    }
    /// The degrees, one per direction.
    pub fn degrees(&self) -> Vec<usize> {
        self.knots.iter().map(KnotVector::degree).collect()
    }
    /// Control points per direction.
    pub fn counts(&self) -> &[usize] {
        &self.counts
    }
    /// The parameter domain of every direction.
    pub fn domain(&self) -> Vec<(f64, f64)> {
        self.knots.iter().map(KnotVector::domain).collect()
    }
    /// True when some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }
    /// The homogeneous net, `k + 1` values per point, flat row-major.
    pub fn homogeneous(&self) -> &[f64] {
        &self.cw
    }
    /// The total number of control points.
    pub fn point_count(&self) -> usize {
        self.cw.len() / self.dim
    }
    /// The Cartesian values `A_I` of flat point `flat` (the homogeneous values divided
    /// by the weight).
    pub fn control_values(&self, flat: usize) -> Vec<f64> {
        let p = &self.cw[flat * self.dim..(flat + 1) * self.dim];
        let h = p[self.dim - 1];
        p[..self.dim - 1].iter().map(|v| v / h).collect()
    }
    /// The weight `h_I` of flat point `flat`.
    pub fn weight(&self, flat: usize) -> f64 {
        self.cw[(flat + 1) * self.dim - 1]
    }

    /// The indices of the geometry attributes `x`, `y`, `z` that are present, in that
    /// order (stopping at the first missing one).
    pub fn geometry(&self) -> Vec<usize> {
        ["x", "y", "z"]
            .iter()
            .map_while(|name| self.attribute(name))
            .collect()
    }

    /// Checks a parameter tuple: `n` finite values.
    pub fn check_params(&self, u: &[f64]) -> VolumeResult<()> {
        if u.len() != self.directions() {
            return Err(VolumeError::ParamCount {
                got: u.len(),
                need: self.directions(),
            });
        }
        if let Some(d) = u.iter().position(|x| !x.is_finite()) {
            return Err(VolumeError::ParamNotFinite {
                direction: d,
                value: u[d],
            });
        }
        Ok(())
    }

    pub(crate) fn check_direction(&self, d: usize) -> VolumeResult<()> {
        if d < self.directions() {
            Ok(())
        } else {
            Err(VolumeError::NoSuchDirection {
                got: d,
                count: self.directions(),
            })
        }
    }
}

/// The rational values and first derivatives (`k = D - 1` each, in the layout of
/// [`Volume::eval_d1_into`]) from the homogeneous ones `a = [A^w, d/du_1 A^w, ..]`
/// (P&T eq. 4.8 differentiated: `A_d = (A^w_d - w_d A) / w`).
#[inline(always)]
pub(crate) fn d1_quotient<const D: usize>(a: &[[f64; D]; 4], out: &mut [f64]) {
    let k = D - 1;
    let inv_w = 1.0 / a[0][k];
    for c in 0..k {
        out[c] = a[0][c] * inv_w;
    }
    for d in 1..4 {
        let wd = a[d][k];
        for c in 0..k {
            out[d * k + c] = (a[d][c] - wd * out[c]) * inv_w;
        }
    }
}
