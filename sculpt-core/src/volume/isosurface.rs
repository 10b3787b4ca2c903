//! Level sets of an attribute (Park 2005, sec. 5.3, eq. 51): implicit surfaces.
//!
//! A volume carrying a distance-like attribute `d` (eq. 51) is an implicit solid: the
//! level set `d(u) = L` bounds it. [`Volume::isosurface`] samples `d - L` at the
//! corners of a uniform grid of the parameter domain and meshes its zero set with the
//! marching tetrahedra of [`crate::implicit::contour::march_tetrahedra`] (Doi and
//! Koide 1991: six tetrahedra per cell, no ambiguous cases), in parameter space; every
//! vertex is then mapped through the geometry `B(u)` (eq. 44). The paper uses
//! marching cubes (Lorensen and Cline 1987); tetrahedra give the same surface without
//! an ambiguity rule.
//!
//! Because the mesh is built on the parameter grid, a vertex is shared by every cell
//! that uses its edge, whatever the map does, so the surface is closed, 2-manifold
//! and consistently oriented where `B` is one-to-one; the domain's faces close it off
//! where the level set leaves the volume (a level the sampled attribute never
//! crosses gives no surface at all). Inside is `d < L`; the triangles face the
//! side where `d > L` (outwards for a distance from a centre). A left-handed map
//! (`sqrt(g) < 0`) would turn them, so they are flipped back. Normals are the
//! physical gradient of `d` (eq. 39), unit length. A volume without geometry is meshed
//! in its parameter space.

use super::{Volume, VolumeResult};
use crate::implicit::contour::march_tetrahedra;
use crate::mesh::{MeshVertex, WeldedMesh};

/// The most grid cells per direction an isosurface may be sampled on.
pub const MAX_ISOSURFACE_RES: usize = 1024;

impl Volume {
    /// The level set `attribute = level` of a trivariate volume, meshed on a grid of
    /// `res[d]` cells per direction of the parameter domain (module docs).
    pub fn isosurface(
        &self,
        attribute: usize,
        level: f64,
        res: [usize; 3],
    ) -> VolumeResult<WeldedMesh> {
        self.check_attribute(attribute)?;
        if self.directions() != 3 {
            return Err(super::VolumeError::NoGeometry {
                what: "an isosurface",
                directions: self.directions(),
                geometry: self
                    .geometry()
                    .iter()
                    .map(|&i| self.attributes()[i].clone())
                    .collect(),
            });
        }
        if let Some(&r) = res.iter().find(|&&r| r == 0 || r > MAX_ISOSURFACE_RES) {
            return Err(super::VolumeError::Resolution {
                got: r,
                max: MAX_ISOSURFACE_RES,
            });
        }
        if !level.is_finite() {
            return Err(super::VolumeError::NotFinite {
                what: "the isosurface level",
                value: level,
            });
        }
        let geometry = self.geometry3("an isosurface").ok();
        let domain = self.domain();
        let param = |c: [f64; 3]| -> [f64; 3] {
            std::array::from_fn(|d| {
                let (a, b) = domain[d];
                a + (b - a) * c[d] / res[d] as f64
            })
        };
        let k = self.components();
        let mut value = vec![0.0; k];
        let (mut any_in, mut any_out) = (false, false);
        let layer = |kk: usize| -> VolumeResult<Vec<f64>> {
            let mut out = Vec::with_capacity((res[0] + 1) * (res[1] + 1));
            for j in 0..=res[1] {
                for i in 0..=res[0] {
                    let u = param([i as f64, j as f64, kk as f64]);
                    self.eval_into(&u, &mut value)?;
                    let v = value[attribute] - level;
                    any_in |= v < 0.0;
                    any_out |= v >= 0.0;
                    out.push(v);
                }
            }
            Ok(out)
        };
        // Forced-outside corners: any positive value closes the surface off there.
        let outside = 1.0;
        let vertex = |a: [usize; 3], b: [usize; 3], t: f64| -> VolumeResult<MeshVertex> {
            let c: [f64; 3] =
                std::array::from_fn(|d| a[d] as f64 + t * (b[d] as f64 - a[d] as f64));
            let u = param(c);
            let (position, normal) = match geometry {
                Some(g) => {
                    let mut row = vec![0.0; 4 * k];
                    self.eval_d1_into(&u, &mut row)?;
                    let p = [row[g[0]], row[g[1]], row[g[2]]];
                    let n = self
                        .frame_from_row(&u, &row, g)
                        .map(|f| {
                            f.gradient([
                                row[k + attribute],
                                row[2 * k + attribute],
                                row[3 * k + attribute],
                            ])
                        })
                        .ok()
                        .and_then(|n| n.try_normalize())
                        .map_or([0.0; 3], |n| n.to_array());
                    (p, n)
                }
                None => {
                    let mut row = vec![0.0; 4 * k];
                    self.eval_d1_into(&u, &mut row)?;
                    let n = glam::DVec3::new(
                        row[k + attribute],
                        row[2 * k + attribute],
                        row[3 * k + attribute],
                    )
                    .try_normalize()
                    .map_or([0.0; 3], |n| n.to_array());
                    (u, n)
                }
            };
            Ok(MeshVertex {
                position: position.map(|x| x as f32),
                normal: normal.map(|x| x as f32),
                uv: [0.0; 2],
            })
        };
        let mut mesh = march_tetrahedra(res, outside, layer, vertex)?;
        if !(any_in && any_out) {
            // The level is not crossed: no surface (not the domain's faces).
            return Ok(WeldedMesh::default());
        }
        if let Some(g) = geometry {
            // A left-handed map turns the triangles: turn them back.
            let centre: [f64; 3] = std::array::from_fn(|d| (domain[d].0 + domain[d].1) / 2.0);
            let mut row = vec![0.0; 4 * k];
            self.eval_d1_into(&centre, &mut row)?;
            if let Ok(f) = self.frame_from_row(&centre, &row, g)
                && f.jacobian < 0.0
            {
                for t in &mut mesh.triangles {
                    t.swap(1, 2);
                }
            }
        }
        Ok(mesh)
    }
}
