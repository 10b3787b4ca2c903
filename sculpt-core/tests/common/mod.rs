//! Helpers shared by the integration tests of `sculpt-core`.

use glam::DVec2;
use sculpt_core::mesh::PatchMesh;
use sculpt_core::sculpt::surface::{ParamSurface, normal_at};

/// Signed height of the mesh above the target along its normal at `uv`: a ray from
/// `lift` above the surface, coming down the normal, to the mesh's first hit.
pub fn height_along_normal(
    mesh: &PatchMesh,
    surface: &dyn ParamSurface,
    uv: DVec2,
    lift: f64,
) -> f64 {
    let p = surface.eval(uv).p;
    let n = normal_at(surface, uv);
    let o = p + n * lift;
    let t = mesh
        .first_hit(o.to_array(), (-n).to_array())
        .unwrap_or_else(|| panic!("no hit at {uv}"));
    lift - t
}
