//! The heat problem file read by `sculpt-tools rfm heat SPEC.toml` (docs/implicit.md).
//!
//! ```toml
//! conductivity = 400.0          # lambda, W/mK
//! depth = 3                     # optional: refinement levels of cut cells
//! bounds = [-1.0, -1.0, 1.0, 1.0] # optional: the basis box; found when missing
//! [basis]
//! degree = 3                    # optional, 3 (bicubic)
//! count = [10, 10]
//! [[boundary]]                  # one per boundary piece
//! model = "outer.json"          # relative to the spec; negative on the domain's side
//! ambient = 293.15              # K
//! film = 30.0                   # W/m2K
//! ```
//!
//! The domain is the R-function conjunction of the pieces (`system`, optional, as in
//! solid documents: `system = { r0 = { m = 0 } }`).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::implicit::rfunc::RSystem;

use super::RfmError;
use super::basis::TensorBasis;
use super::heat::{HeatSettings, MAX_DEPTH, MAX_PIECES};

/// The basis table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BasisSpec {
    /// B-spline degree (3 when missing).
    #[serde(default = "three")]
    pub degree: usize,
    /// Functions per direction, `[nx, ny]`.
    pub count: [usize; 2],
}

fn three() -> usize {
    3
}

fn default_depth() -> u32 {
    3
}

/// One boundary piece.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// The model's path, relative to the spec file.
    pub model: String,
    /// Ambient temperature (K).
    pub ambient: f64,
    /// Film coefficient (W/m^2K).
    pub film: f64,
}

/// A heat problem file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeatSpec {
    /// Conductivity lambda (W/mK).
    pub conductivity: f64,
    /// The basis.
    pub basis: BasisSpec,
    /// The boundary pieces.
    pub boundary: Vec<BoundarySpec>,
    /// The conjunction joining the pieces.
    #[serde(default)]
    pub system: RSystem,
    /// Refinement levels of cut quadrature cells.
    #[serde(default = "default_depth")]
    pub depth: u32,
    /// The basis box `[xlo, ylo, xhi, yhi]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounds: Option<[f64; 4]>,
}

/// Why a spec was refused.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SpecError {
    /// Not TOML, or not the schema.
    #[error("spec")]
    Toml(#[source] toml::de::Error),
    /// A value out of range.
    #[error("spec")]
    Invalid(#[source] RfmError),
    /// `bounds` is not finite with `xlo < xhi`, `ylo < yhi`.
    #[error("spec: bounds {bounds:?} must be finite with xlo < xhi and ylo < yhi")]
    Bounds {
        /// The bounds given.
        bounds: [f64; 4],
    },
    /// A boundary's `model` path is empty.
    #[error("spec: boundary {piece} has an empty model path")]
    EmptyModel {
        /// 0-based piece.
        piece: usize,
    },
}

impl HeatSpec {
    /// Parses and checks a spec.
    pub fn from_toml(text: &str) -> Result<Self, SpecError> {
        let spec: HeatSpec = toml::from_str(text).map_err(SpecError::Toml)?;
        spec.settings()?;
        Ok(spec)
    }

    /// The spec as TOML (what [`from_toml`](Self::from_toml) reads back).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a heat spec always serialises")
    }

    /// The checked numerical settings.
    pub fn settings(&self) -> Result<HeatSettings, SpecError> {
        let inv = SpecError::Invalid;
        if !(self.conductivity.is_finite() && self.conductivity > 0.0) {
            return Err(inv(RfmError::Conductivity {
                value: self.conductivity,
            }));
        }
        TensorBasis::new(self.basis.degree, self.basis.count, [0.0; 2], [1.0; 2]).map_err(inv)?;
        let n = self.boundary.len();
        if n == 0 || n > MAX_PIECES {
            return Err(inv(RfmError::Pieces { count: n }));
        }
        for (i, b) in self.boundary.iter().enumerate() {
            if b.model.trim().is_empty() {
                return Err(SpecError::EmptyModel { piece: i });
            }
            if !(b.ambient.is_finite() && b.ambient > 0.0) {
                return Err(inv(RfmError::Ambient {
                    piece: i,
                    value: b.ambient,
                }));
            }
            if !(b.film.is_finite() && b.film >= 0.0) {
                return Err(inv(RfmError::Film {
                    piece: i,
                    value: b.film,
                }));
            }
        }
        if self.boundary.iter().all(|b| b.film == 0.0) {
            return Err(inv(RfmError::Insulated));
        }
        if self.depth > MAX_DEPTH {
            return Err(inv(RfmError::Depth { depth: self.depth }));
        }
        let system = self
            .system
            .check("system")
            .map_err(|_| inv(RfmError::System))?;
        if let Some(b) = self.bounds
            && !(b.iter().all(|v| v.is_finite()) && b[0] < b[2] && b[1] < b[3])
        {
            return Err(SpecError::Bounds { bounds: b });
        }
        Ok(HeatSettings {
            conductivity: self.conductivity,
            degree: self.basis.degree,
            count: self.basis.count,
            system,
            depth: self.depth,
            bounds: self.bounds,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const RING: &str = r#"
conductivity = 7.0
[basis]
degree = 3
count = [10, 10]
[[boundary]]
model = "outer.json"
ambient = 1573.0
film = 100.0
[[boundary]]
model = "inner.json"
ambient = 1073.0
film = 100.0
"#;

    #[test]
    fn the_ring_spec_reads() {
        let spec = HeatSpec::from_toml(RING).unwrap();
        assert_eq!(spec.boundary.len(), 2);
        assert_eq!(spec.basis.count, [10, 10]);
        let s = spec.settings().unwrap();
        assert_eq!((s.degree, s.depth, s.bounds), (3, 3, None));
    }

    #[test]
    fn bad_specs_are_refused_with_their_reason() {
        type Case = (&'static str, &'static str, fn(&SpecError) -> bool);
        let cases: &[Case] = &[
            ("conductivity = 7.0", "conductivity = -1.0", |e| {
                matches!(e, SpecError::Invalid(RfmError::Conductivity { .. }))
            }),
            ("degree = 3", "degree = 1", |e| {
                matches!(e, SpecError::Invalid(RfmError::Degree { .. }))
            }),
            ("count = [10, 10]", "count = [3, 10]", |e| {
                matches!(e, SpecError::Invalid(RfmError::Count { .. }))
            }),
            ("ambient = 1573.0", "ambient = -5.0", |e| {
                matches!(e, SpecError::Invalid(RfmError::Ambient { piece: 0, .. }))
            }),
            (
                "film = 100.0\n[[boundary]]\nmodel = \"inner",
                "film = -1.0\n[[boundary]]\nmodel = \"inner",
                |e| matches!(e, SpecError::Invalid(RfmError::Film { piece: 0, .. })),
            ),
            ("model = \"outer.json\"", "model = \"\"", |e| {
                matches!(e, SpecError::EmptyModel { piece: 0 })
            }),
            (
                "conductivity = 7.0",
                "conductivity = 7.0\nbounds = [1.0, 0.0, 0.0, 1.0]",
                |e| matches!(e, SpecError::Bounds { .. }),
            ),
            ("conductivity = 7.0", "conductivity = 7.0\ndepth = 9", |e| {
                matches!(e, SpecError::Invalid(RfmError::Depth { .. }))
            }),
            (
                "conductivity = 7.0",
                "conductivity = 7.0\nsystem = { rp = { p = 3 } }",
                |e| matches!(e, SpecError::Invalid(RfmError::System)),
            ),
            (
                "conductivity = 7.0",
                "conductivity = 7.0\nunknown = 1",
                |e| matches!(e, SpecError::Toml(_)),
            ),
            ("count = [10, 10]", "count = [10]", |e| {
                matches!(e, SpecError::Toml(_))
            }),
        ];
        for (from, to, is) in cases {
            assert!(RING.contains(from), "{from}");
            let text = RING.replacen(from, to, 1);
            let err = HeatSpec::from_toml(&text).unwrap_err();
            assert!(is(&err), "{to}: {err:?}");
        }
        let insulated = RING.replace("film = 100.0", "film = 0.0");
        assert!(matches!(
            HeatSpec::from_toml(&insulated),
            Err(SpecError::Invalid(RfmError::Insulated))
        ));
    }

    fn spec() -> impl Strategy<Value = HeatSpec> {
        let boundary = ("[a-z]{1,8}\\.(json|vm)", 1.0f64..2000.0, 0.0f64..500.0).prop_map(
            |(model, ambient, film)| BoundarySpec {
                model,
                ambient,
                film,
            },
        );
        (
            0.01f64..1000.0,
            2usize..=5,
            0usize..20,
            0usize..20,
            proptest::collection::vec(boundary, 1..5),
            0u32..=MAX_DEPTH,
            proptest::option::of((-10.0f64..0.0, -10.0f64..0.0, 0.1f64..10.0, 0.1f64..10.0)),
        )
            .prop_map(|(conductivity, degree, ex, ey, mut boundary, depth, b)| {
                boundary[0].film += 1.0;
                HeatSpec {
                    conductivity,
                    basis: BasisSpec {
                        degree,
                        count: [degree + 1 + ex, degree + 1 + ey],
                    },
                    boundary,
                    system: RSystem::default(),
                    depth,
                    bounds: b.map(|(a, b, c, d)| [a, b, c, d]),
                }
            })
    }

    proptest! {
        /// Any text: an error or a spec, never a panic.
        #[test]
        fn arbitrary_text_never_panics(text in "\\PC{0,200}") {
            let _ = HeatSpec::from_toml(&text);
        }

        /// Mutated valid specs: an error or a checked spec, never a panic.
        #[test]
        fn mutated_specs_never_panic(cut in 0usize..RING.len(), insert in "[ -~\\n]{0,12}") {
            let mut text = RING.to_owned();
            let at = (0..=cut).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
            text.insert_str(at, &insert);
            if let Ok(spec) = HeatSpec::from_toml(&text) {
                prop_assert!(spec.settings().is_ok());
            }
        }

        /// Valid specs write and read back unchanged.
        #[test]
        fn valid_specs_round_trip(s in spec()) {
            let text = s.to_toml();
            let back = HeatSpec::from_toml(&text).unwrap();
            prop_assert_eq!(back, s);
        }
    }
}
