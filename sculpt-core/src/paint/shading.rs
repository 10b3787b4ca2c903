//! What a renderer tints a surface with: a snapshot of a document's painted fields
//! ([`PaintShading`]), either the colour ([`PaintShading::colour`]) or one scalar as a
//! heat map ([`PaintShading::heat`]), evaluated at any point of the display frame.
//!
//! At a point `p` the field of the most coverage there is taken (several targets may be
//! painted; their boxes may overlap); [`PaintShading::tint`] returns its colour and
//! coverage `a` in `[0, 1]` (see [`AttributeField::eval`]), which a renderer blends
//! over the surface's own albedo, `albedo (1 - a) + colour a` ([`blend`]), before
//! lighting: the painted colour is multiplied into the lit shading as the albedo is.
//! Exports blend the same tint over [`super::UNPAINTED`]
//! ([`PaintShading::colours_over`]).

use glam::DVec3;

use super::{AttributeField, blend, heat};
use crate::mesh::{Tint, WeldedMesh};

/// What a [`PaintShading`] shows.
#[derive(Debug, Clone, PartialEq)]
pub enum Shown {
    /// The painted colour.
    Colour,
    /// A scalar's painted range, least to greatest, as [`heat`] colours.
    Heat {
        /// The scalar's name.
        attribute: String,
        /// Its least painted value.
        lo: f64,
        /// Its greatest painted value.
        hi: f64,
    },
}

/// A snapshot of the fields of one attribute, as a renderer tints with them.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintShading {
    fields: Vec<AttributeField>,
    shown: Shown,
}

/// Of `fields`, the value and coverage at `p` of the one with the most coverage there;
/// `None` where none has any (the last of equals wins).
pub fn strongest<'a>(
    fields: impl Iterator<Item = &'a AttributeField>,
    p: DVec3,
) -> Option<(Vec<f64>, f64)> {
    fields.map(|f| f.eval(p)).filter(|(_, a)| *a > 0.0).fold(
        None,
        |best: Option<(Vec<f64>, f64)>, (v, a)| match best {
            Some(b) if b.1 > a => Some(b),
            _ => Some((v, a)),
        },
    )
}

impl PaintShading {
    /// The colour fields `fields` (each [`super::COLOUR`]); `None` when there are none.
    pub fn colour(fields: Vec<AttributeField>) -> Option<Self> {
        (!fields.is_empty()).then_some(Self {
            fields,
            shown: Shown::Colour,
        })
    }

    /// The scalar fields `fields` of `attribute` as a heat map over their painted range
    /// ([`AttributeField::value_range`]); `None` when none was painted.
    pub fn heat(attribute: &str, fields: Vec<AttributeField>) -> Option<Self> {
        let (lo, hi) = fields
            .iter()
            .filter_map(AttributeField::value_range)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))?;
        Some(Self {
            fields,
            shown: Shown::Heat {
                attribute: attribute.to_owned(),
                lo,
                hi,
            },
        })
    }

    /// What is shown.
    pub fn shown(&self) -> &Shown {
        &self.shown
    }

    /// The colour (linear RGB, each in `[0, 1]`) and coverage in `[0, 1]` at `p`;
    /// `None` where nothing was painted.
    pub fn at(&self, p: DVec3) -> Option<([f64; 3], f64)> {
        let (value, a) = strongest(self.fields.iter(), p)?;
        let colour = match &self.shown {
            Shown::Colour => {
                [0, 1, 2].map(|c| value.get(c).copied().unwrap_or(0.0).clamp(0.0, 1.0))
            }
            Shown::Heat { lo, hi, .. } => {
                // One painted value only: the top of the scale.
                let t = if hi > lo {
                    (value[0] - lo) / (hi - lo)
                } else {
                    1.0
                };
                heat(t).map(f64::from)
            }
        };
        Some((colour, a))
    }

    /// The tint at `p` as a renderer takes it: `[r, g, b, a]`, all zeros where nothing
    /// was painted (the surface keeps its albedo).
    pub fn tint(&self, p: DVec3) -> [f32; 4] {
        self.at(p).map_or([0.0; 4], |(c, a)| {
            [c[0] as f32, c[1] as f32, c[2] as f32, a as f32]
        })
    }

    /// The box holding every field's box.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.fields.iter().map(AttributeField::bounds).fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
        )
    }

    /// This shading as a renderer's [`Tint`]: [`Self::tint`] of the position over
    /// [`Self::bounds`].
    pub fn into_tint(self) -> Tint {
        let (lo, hi) = self.bounds();
        Tint {
            lo: lo.as_vec3().to_array(),
            hi: hi.as_vec3().to_array(),
            at: std::sync::Arc::new(move |p: [f32; 3]| self.tint(DVec3::from(p.map(f64::from)))),
        }
    }

    /// The colour of every vertex of `mesh` blended over `base` ([`blend`]).
    pub fn colours_over(&self, mesh: &WeldedMesh, base: [f32; 3]) -> Vec<[f32; 3]> {
        mesh.vertices
            .iter()
            .map(|v| {
                let p = DVec3::from(v.position.map(f64::from));
                self.at(p).map_or(base, |(c, a)| blend(base, &c, a))
            })
            .collect()
    }
}
