//! Surface materials (`[render] material = "clay"`, the `M` key in desktop mode) and
//! the colours that tell surfaces apart: the sculpted targets take the material, a
//! sketched surface the same material tinted blue, the selected target (when there is
//! more than one) an amber silhouette outline, and a stroke ribbon its own blue-grey.
//!
//! Colours here are linear RGB (the eye images are sRGB render targets, so the
//! hardware encodes them; see [`crate::render`]).
//!
//! ```
//! use vr_app::render::material::Material;
//! let m: Material = "stone".parse()?;
//! assert_eq!(m, Material::Stone);
//! assert_eq!(Material::Wood.next(), Material::Clay);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use bytemuck::{Pod, Zeroable};
use serde::{Deserialize, Serialize};

use crate::error::{VrError, VrResult};
pub use crate::scene::SurfaceClass;

/// A surface material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Material {
    /// Warm grey modelling clay: soft, broad highlight.
    #[default]
    Clay,
    /// Pale grey stone with a fine speckle and almost no highlight.
    Stone,
    /// Light wood with growth rings and a satin highlight.
    Wood,
}

impl Material {
    /// Every material, in the order the `M` key steps through them.
    pub const ALL: [Material; 3] = [Material::Clay, Material::Stone, Material::Wood];

    /// The next material (wraps around).
    pub fn next(self) -> Self {
        let i = Self::ALL.iter().position(|&m| m == self).unwrap_or(0);
        Self::ALL[(i + 1) % Self::ALL.len()]
    }

    /// Its name, as in the config file.
    pub fn name(self) -> &'static str {
        match self {
            Material::Clay => "clay",
            Material::Stone => "stone",
            Material::Wood => "wood",
        }
    }

    /// The shading parameters of this material for a surface of `class`.
    /// The albedo of `class` in this material (linear RGB), before its pattern and
    /// any paint ([`crate::render::paint_texture`]).
    pub fn albedo(self, class: SurfaceClass) -> [f32; 3] {
        let a = self.uniform(class).albedo;
        [a[0], a[1], a[2]]
    }

    pub(crate) fn uniform(self, class: SurfaceClass) -> MaterialUniform {
        // albedo (linear), specular strength, Blinn-Phong exponent, pattern.
        let (albedo, spec, power, pattern) = match self {
            Material::Clay => ([0.60, 0.46, 0.35], 0.10, 16.0, 0.0),
            Material::Stone => ([0.50, 0.50, 0.48], 0.04, 8.0, 1.0),
            Material::Wood => ([0.55, 0.33, 0.16], 0.18, 40.0, 2.0),
        };
        let albedo = match class {
            // A sketched surface: the material, tinted towards blue.
            SurfaceClass::Sketched => [
                albedo[0] * 0.55,
                albedo[1] * 0.75 + 0.05,
                albedo[2] * 0.9 + 0.25,
            ],
            SurfaceClass::Preview => [0.25, 0.42, 0.65],
            SurfaceClass::Target | SurfaceClass::Selected => albedo,
        };
        let pattern = match class {
            SurfaceClass::Preview => 0.0,
            _ => pattern,
        };
        MaterialUniform {
            albedo: [albedo[0], albedo[1], albedo[2], 1.0],
            wire_color: [0.004, 0.008, 0.015, 1.0],
            params: [spec, power, pattern, class.id()],
        }
    }
}

impl std::str::FromStr for Material {
    type Err = VrError;
    fn from_str(s: &str) -> VrResult<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| VrError::Config(crate::ConfigError::Material(s.to_string())))
    }
}

/// The material uniform of the scene shaders (`Material` in `shaders.wgsl`).
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub(crate) struct MaterialUniform {
    /// Linear albedo.
    pub albedo: [f32; 4],
    /// Wireframe colour (linear).
    pub wire_color: [f32; 4],
    /// Specular strength, exponent, pattern (0 none, 1 speckle, 2 rings), class id.
    pub params: [f32; 4],
}

/// sRGB-encoded display value of a linear channel (IEC 61966-2-1).
pub fn linear_to_srgb(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear value of an sRGB-encoded channel (IEC 61966-2-1).
pub fn srgb_to_linear(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::POINT_EPS;

    /// The published values below are given to six digits.
    const SIX_DIGITS: f64 = crate::tolerance::SIX_DIGITS_EPS;

    #[test]
    fn materials_parse_by_name_and_cycle_through_all() {
        for m in Material::ALL {
            assert_eq!(m.name().parse::<Material>().unwrap(), m);
        }
        let e = "marble".parse::<Material>().unwrap_err().to_string();
        assert!(e.contains("marble") && e.contains("clay"), "{e}");
        let mut m = Material::Clay;
        let mut seen = Vec::new();
        for _ in 0..Material::ALL.len() {
            seen.push(m);
            m = m.next();
        }
        assert_eq!(m, Material::Clay);
        assert_eq!(seen, Material::ALL.to_vec());
    }

    #[test]
    fn sketched_surfaces_differ_in_colour_from_targets() {
        for m in Material::ALL {
            let t = m.uniform(SurfaceClass::Target).albedo;
            let s = m.uniform(SurfaceClass::Sketched).albedo;
            assert!(s[2] - s[0] > t[2] - t[0] + 0.2, "{m:?}: {t:?} vs {s:?}");
        }
    }

    #[test]
    fn srgb_transfer_round_trips_and_matches_known_values() {
        assert_near!(linear_to_srgb(0.214_041), 0.5, 2.0 * SIX_DIGITS);
        assert_near!(srgb_to_linear(0.5), 0.214_041, SIX_DIGITS);
        for i in 0..=20 {
            let c = f64::from(i) / 20.0;
            assert_near!(srgb_to_linear(linear_to_srgb(c)), c, POINT_EPS);
        }
    }
}
