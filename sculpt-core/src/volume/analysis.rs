//! Analysis of a trivariate volume in physical space (Park 2005, sec. 4).
//!
//! The geometry `B(u, v, w) = (x, y, z)` (eq. 28) is a curvilinear coordinate system.
//! At any parameter, [`Volume::frame`] gives:
//!
//! - the covariant base vectors `B_u, B_v, B_w` (eqs. 29, 31: first derivatives of the
//!   volume);
//! - the Jacobian `sqrt(g) = B_u . (B_v x B_w)` (eq. 38);
//! - the contravariant base vectors `grad u = (B_v x B_w) / sqrt(g)`,
//!   `grad v = (B_w x B_u) / sqrt(g)`, `grad w = (B_u x B_v) / sqrt(g)` (eqs. 30, 32);
//! - the metric tensors `g_ij = B_i . B_j` (eq. 36) and `g^ij = grad u_i . grad u_j`
//!   (eq. 37);
//! - the arc elements `|B_u|` (eq. 33), area elements `|B_v x B_w|` (eq. 34) and the
//!   volume element `|sqrt(g)|` (eq. 35).
//!
//! Attribute fields `F` carried by the same volume are differentiated in physical space
//! through the contravariant vectors: gradient (eq. 39), divergence (eq. 40), curl
//! (eq. 41) and the velocity gradient tensor `dV_i / dx_j` (eqs. 46, 47).
//!
//! [`VolumeInverter`] maps a physical point back to its parameters by Newton's method
//! `du_i = grad u_i . (x - B(u))` from the nearest of a grid of sampled points (a safe
//! start), clamped to the domain.

use glam::DVec3;

use super::{Volume, VolumeError, VolumeResult};
use crate::tolerance::{VOLUME_INVERT_REL, VOLUME_SINGULAR_REL};

/// The curvilinear frame at one parameter (Park 2005, sec. 4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// `B(u)`.
    pub point: DVec3,
    /// `B_u, B_v, B_w` (eq. 31).
    pub covariant: [DVec3; 3],
    /// `sqrt(g) = B_u . (B_v x B_w)` (eq. 38), signed (negative for a left-handed map).
    pub jacobian: f64,
    /// `grad u, grad v, grad w` (eq. 32).
    pub contravariant: [DVec3; 3],
}

impl Frame {
    /// The covariant metric tensor `g_ij = B_i . B_j` (eq. 36).
    pub fn metric(&self) -> [[f64; 3]; 3] {
        let b = &self.covariant;
        std::array::from_fn(|i| std::array::from_fn(|j| b[i].dot(b[j])))
    }
    /// The contravariant metric tensor `g^ij = grad u_i . grad u_j` (eq. 37), the
    /// inverse of [`Self::metric`].
    pub fn inverse_metric(&self) -> [[f64; 3]; 3] {
        let c = &self.contravariant;
        std::array::from_fn(|i| std::array::from_fn(|j| c[i].dot(c[j])))
    }
    /// The arc elements `|B_u|, |B_v|, |B_w|` (eq. 33).
    pub fn arc_elements(&self) -> [f64; 3] {
        self.covariant.map(|b| b.length())
    }
    /// The area elements of the coordinate surfaces `u, v, w = const`:
    /// `|B_v x B_w|, |B_w x B_u|, |B_u x B_v|` (eq. 34).
    pub fn area_elements(&self) -> [f64; 3] {
        let b = &self.covariant;
        [
            b[1].cross(b[2]).length(),
            b[2].cross(b[0]).length(),
            b[0].cross(b[1]).length(),
        ]
    }
    /// The volume element `|sqrt(g)|` (eq. 35).
    pub fn volume_element(&self) -> f64 {
        self.jacobian.abs()
    }
    /// The physical gradient of a scalar with parameter derivatives `f_u` (eq. 39):
    /// `grad F = sum_i F_{u_i} grad u_i`.
    pub fn gradient(&self, f_u: [f64; 3]) -> DVec3 {
        (0..3).map(|i| self.contravariant[i] * f_u[i]).sum()
    }
}

/// The physical derivatives of a vector attribute at one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VectorDerivatives {
    /// The field's value.
    pub value: DVec3,
    /// `grad[i][j] = dF_i / dx_j` (eqs. 46, 47).
    pub gradient: [[f64; 3]; 3],
    /// `div F` (eq. 40): the trace of the gradient.
    pub divergence: f64,
    /// `curl F` (eq. 41).
    pub curl: DVec3,
}

/// Three attributes `attrs` of slot `slot` (0 the value, `1 + d` the derivative along
/// `d`) of a derivative row with `k` attributes, as a vector.
fn slot_vector(row: &[f64], k: usize, slot: usize, attrs: [usize; 3]) -> DVec3 {
    DVec3::new(
        row[slot * k + attrs[0]],
        row[slot * k + attrs[1]],
        row[slot * k + attrs[2]],
    )
}

impl Volume {
    /// The geometry attributes `x, y, z` of a trivariate volume, or the error naming
    /// what `what` needs.
    pub fn geometry3(&self, what: &'static str) -> VolumeResult<[usize; 3]> {
        let g = self.geometry();
        if self.directions() != 3 || g.len() != 3 {
            return Err(VolumeError::NoGeometry {
                what,
                directions: self.directions(),
                geometry: g.iter().map(|&i| self.attributes()[i].clone()).collect(),
            });
        }
        Ok([g[0], g[1], g[2]])
    }

    /// The index of the attribute `name`, or an error listing the attributes.
    pub fn attribute_index(&self, name: &str) -> VolumeResult<usize> {
        self.attribute(name)
            .ok_or_else(|| VolumeError::NoSuchAttribute {
                name: name.to_string(),
                available: self.attributes().to_vec(),
            })
    }

    /// The frame from a derivative row of [`Volume::eval_d1_into`].
    pub(super) fn frame_from_row(
        &self,
        u: &[f64],
        row: &[f64],
        g: [usize; 3],
    ) -> VolumeResult<Frame> {
        let k = self.components();
        let point = slot_vector(row, k, 0, g);
        let covariant: [DVec3; 3] = std::array::from_fn(|d| slot_vector(row, k, 1 + d, g));
        Frame::from_covariant(u, point, covariant)
    }
}

impl Frame {
    /// The frame at `u` of the point `point` with the covariant base vectors
    /// `covariant` (`dB/du_i`, sec. 4, eq. 29): the Jacobian and the contravariant
    /// base vectors (eq. 32); fails where the Jacobian is singular (naming `u`).
    pub(super) fn from_covariant(
        u: &[f64],
        point: DVec3,
        covariant: [DVec3; 3],
    ) -> VolumeResult<Frame> {
        let (jacobian, cross) = Self::jacobian(u, covariant)?;
        Ok(Frame {
            point,
            covariant,
            jacobian,
            contravariant: cross.map(|c| c / jacobian),
        })
    }

    /// `sqrt(g) = B_u . (B_v x B_w)` (eq. 38) and the cross products `B_v x B_w,
    /// B_w x B_u, B_u x B_v`, the contravariant base vectors times `sqrt(g)` (eq. 32),
    /// of the covariant base vectors at `u`; fails where the Jacobian is singular
    /// (below [`VOLUME_SINGULAR_REL`] of the product of the vectors' lengths, naming
    /// `u`).
    #[inline]
    pub(super) fn jacobian(u: &[f64], covariant: [DVec3; 3]) -> VolumeResult<(f64, [DVec3; 3])> {
        let [bu, bv, bw] = covariant;
        let cross = [bv.cross(bw), bw.cross(bu), bu.cross(bv)];
        let jacobian = bu.dot(cross[0]);
        let scale = bu.length() * bv.length() * bw.length();
        if jacobian.abs() <= VOLUME_SINGULAR_REL * scale || scale == 0.0 || !jacobian.is_finite() {
            return Err(VolumeError::SingularJacobian {
                params: u.to_vec(),
                jacobian,
            });
        }
        Ok((jacobian, cross))
    }
}

impl Volume {
    /// The frame at `u` with the derivative row it came from.
    fn frame_and_row(&self, u: &[f64], what: &'static str) -> VolumeResult<(Frame, Vec<f64>)> {
        let g = self.geometry3(what)?;
        let mut row = vec![0.0; self.components() * 4];
        self.eval_d1_into(u, &mut row)?;
        Ok((self.frame_from_row(u, &row, g)?, row))
    }

    /// The curvilinear frame at `u` (module docs); fails where the volume has no
    /// geometry or the Jacobian is singular (naming the parameters).
    pub fn frame(&self, u: &[f64]) -> VolumeResult<Frame> {
        Ok(self.frame_and_row(u, "the curvilinear frame")?.0)
    }

    /// The physical gradient of attribute `attr` at `u` (eq. 39).
    pub fn gradient(&self, u: &[f64], attr: usize) -> VolumeResult<DVec3> {
        let (f, row) = self.frame_and_row(u, "the gradient")?;
        let k = self.components();
        Ok(f.gradient([row[k + attr], row[2 * k + attr], row[3 * k + attr]]))
    }

    /// The physical derivatives of the vector attribute `attrs` (three attribute
    /// indices) at `u`: gradient tensor, divergence (eq. 40) and curl (eq. 41).
    pub fn vector_derivatives(
        &self,
        u: &[f64],
        attrs: [usize; 3],
    ) -> VolumeResult<VectorDerivatives> {
        let (f, row) = self.frame_and_row(u, "vector derivatives")?;
        let k = self.components();
        let value = slot_vector(row.as_slice(), k, 0, attrs);
        // F_{u_d} as vectors.
        let fu: [DVec3; 3] = std::array::from_fn(|d| slot_vector(&row, k, 1 + d, attrs));
        let gradient: [[f64; 3]; 3] = std::array::from_fn(|i| {
            let gi = f.gradient([fu[0][i], fu[1][i], fu[2][i]]);
            gi.to_array()
        });
        let divergence = (0..3).map(|d| f.contravariant[d].dot(fu[d])).sum();
        let curl = (0..3).map(|d| f.contravariant[d].cross(fu[d])).sum();
        Ok(VectorDerivatives {
            value,
            gradient,
            divergence,
            curl,
        })
    }

    /// A point inverter for this volume (module docs).
    pub fn inverter(&self) -> VolumeResult<VolumeInverter<'_>> {
        VolumeInverter::new(self)
    }
}

/// Physical points to parameters by Newton's method from a safe start (module docs).
#[derive(Debug, Clone)]
pub struct VolumeInverter<'a> {
    vol: &'a Volume,
    geometry: [usize; 3],
    /// Sampled parameters and their points: the starts.
    samples: Vec<([f64; 3], DVec3)>,
    /// The size of the volume (the diagonal of its sampled box).
    size: f64,
}

/// Samples per knot span and direction for the inverter's starts.
const STARTS_PER_SPAN: usize = 4;
/// Newton iterations per start.
const NEWTON_ITERATIONS: usize = 60;
/// Starts tried per query, nearest first.
const STARTS_TRIED: usize = 4;

impl<'a> VolumeInverter<'a> {
    /// Samples the volume on a grid of `STARTS_PER_SPAN` parameters per knot span.
    pub fn new(vol: &'a Volume) -> VolumeResult<Self> {
        let geometry = vol.geometry3("the inverse map")?;
        let axes: Vec<Vec<f64>> =
            vol.knot_vectors()
                .iter()
                .map(|kv| {
                    let mut t: Vec<f64> = Vec::new();
                    for s in kv.knots().windows(2).filter(|s| s[1] > s[0]) {
                        t.extend((0..STARTS_PER_SPAN).map(|i| {
                            s[0] + (s[1] - s[0]) * (i as f64 + 0.5) / STARTS_PER_SPAN as f64
                        }));
                    }
                    t
                })
                .collect();
        let mut samples = Vec::with_capacity(axes.iter().map(Vec::len).product());
        let mut value = vec![0.0; vol.components()];
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &a in &axes[0] {
            for &b in &axes[1] {
                for &c in &axes[2] {
                    vol.eval_into(&[a, b, c], &mut value)?;
                    let p = DVec3::new(value[geometry[0]], value[geometry[1]], value[geometry[2]]);
                    lo = lo.min(p);
                    hi = hi.max(p);
                    samples.push(([a, b, c], p));
                }
            }
        }
        Ok(Self {
            vol,
            geometry,
            samples,
            size: (hi - lo).length().max(f64::MIN_POSITIVE),
        })
    }

    /// The parameters of the physical point `x`, or [`VolumeError::OutsideVolume`]
    /// when no parameter in the domain maps to it (within `VOLUME_INVERT_REL` of the
    /// volume's size).
    pub fn invert(&self, x: DVec3) -> VolumeResult<[f64; 3]> {
        if !x.is_finite() {
            return Err(VolumeError::OutsideVolume {
                point: x.to_array(),
                distance: f64::INFINITY,
            });
        }
        let mut order: Vec<(f64, usize)> = self
            .samples
            .iter()
            .enumerate()
            .map(|(i, s)| (s.1.distance_squared(x), i))
            .collect();
        let take = STARTS_TRIED.min(order.len());
        order.select_nth_unstable_by(take.saturating_sub(1), |a, b| a.0.total_cmp(&b.0));
        order.truncate(take);
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let tol = VOLUME_INVERT_REL * self.size;
        let domain = self.vol.domain();
        let mut best = f64::INFINITY;
        let k = self.vol.components();
        let mut row = vec![0.0; k * 4];
        for &(_, i) in &order {
            let mut u = self.samples[i].0;
            for _ in 0..NEWTON_ITERATIONS {
                self.vol.eval_d1_into(&u, &mut row)?;
                let f = match self.vol.frame_from_row(&u, &row, self.geometry) {
                    Ok(f) => f,
                    Err(_) => break,
                };
                let r = x - f.point;
                best = best.min(r.length());
                if r.length() <= tol {
                    return Ok(u);
                }
                let mut moved = 0.0f64;
                for d in 0..3 {
                    let next = (u[d] + f.contravariant[d].dot(r)).clamp(domain[d].0, domain[d].1);
                    moved = moved.max((next - u[d]).abs() / (domain[d].1 - domain[d].0));
                    u[d] = next;
                }
                if moved == 0.0 {
                    break; // stuck on the boundary: the point is outside
                }
            }
        }
        Err(VolumeError::OutsideVolume {
            point: x.to_array(),
            distance: best,
        })
    }
}
