//! The chisel: its profile, carve or emboss mode, and the tool's parameters with their
//! caps.

use super::reject;
use crate::error::{Result, StrokeRejection, ToolParam, ToolRangeError};
use crate::tolerance::PROFILE_EDGE;
use serde::{Deserialize, Serialize};

/// Cross-section of the chisel: the one profile type, used by the interaction (its
/// current tool, commands, the journal) and by the sculpting layer (strokes, the
/// document).
///
/// Written as `"v"`, `"u"` or `{"custom": [[x, f], ...]}` in every format (journal,
/// document, scene, TOML configuration); the kebab-case and lowercase spellings the
/// interaction and the sculpting layer once wrote separately are the same words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// Straight walls meeting at a sharp bottom.
    V,
    /// A round (elliptical) bottom.
    U,
    /// A custom half-profile: `(x, f)` pairs with `x` from 0 (centre) to 1 (rim),
    /// increasing, and `f` the depth fraction (interpolated linearly, 0 at the rim).
    Custom(Vec<[f64; 2]>),
}

impl Profile {
    /// The depth fraction at `x = r / half_width` in `[0, 1]`; 0 outside.
    pub fn shape(&self, x: f64) -> f64 {
        if !(0.0..1.0).contains(&x) {
            return 0.0;
        }
        match self {
            Profile::V => 1.0 - x,
            Profile::U => (1.0 - x * x).sqrt(),
            Profile::Custom(pts) => {
                let mut prev = [0.0, pts.first().map_or(1.0, |p| p[1])];
                for &p in pts.iter().chain(std::iter::once(&[1.0, 0.0])) {
                    if x <= p[0] {
                        let span = p[0] - prev[0];
                        let t = if span > 0.0 {
                            (x - prev[0]) / span
                        } else {
                            1.0
                        };
                        return (prev[1] + (p[1] - prev[1]) * t).clamp(0.0, 1.0);
                    }
                    prev = p;
                }
                0.0
            }
        }
    }

    /// The slope `d shape / dx` at `x` in `[0, 1]` (clamped), for normals. A U profile is
    /// vertical at its rim: its slope is taken at [`PROFILE_EDGE`] short of the rim.
    pub fn slope(&self, x: f64) -> f64 {
        let x = if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.0
        };
        match self {
            Profile::V => -1.0,
            Profile::U => {
                let x = x.min(1.0 - PROFILE_EDGE);
                -x / (1.0 - x * x).sqrt()
            }
            Profile::Custom(pts) => {
                let mut prev = [0.0, pts.first().map_or(1.0, |p| p[1])];
                for &p in pts.iter().chain(std::iter::once(&[1.0, 0.0])) {
                    if x <= p[0] {
                        let span = p[0] - prev[0];
                        return if span > 0.0 {
                            (p[1] - prev[1]) / span
                        } else {
                            0.0
                        };
                    }
                    prev = p;
                }
                0.0
            }
        }
    }

    /// True when the profile is curved between centre and rim (needs extra sample lines).
    pub fn is_curved(&self) -> bool {
        !matches!(self, Profile::V)
    }

    /// The profile a profile button switches to: V to U, U (or a custom profile) to V.
    pub fn toggled(&self) -> Self {
        match self {
            Profile::V => Profile::U,
            Profile::U | Profile::Custom(_) => Profile::V,
        }
    }

    fn validate(&self) -> Result<()> {
        if let Profile::Custom(pts) = self {
            if pts.is_empty() || pts.len() > 256 {
                return Err(reject(StrokeRejection::ProfilePointCount {
                    count: pts.len(),
                    max: 256,
                }));
            }
            let mut last = -1.0;
            for (index, p) in pts.iter().enumerate() {
                if !(p[0].is_finite() && p[1].is_finite()) || p[0] <= last || p[0] > 1.0 {
                    return Err(reject(StrokeRejection::ProfileX { index }));
                }
                if !(0.0..=1.0).contains(&p[1]) {
                    return Err(reject(StrokeRejection::ProfileDepth { index }));
                }
                last = p[0];
            }
        }
        Ok(())
    }
}

/// Carve into the surface or emboss onto it: the one carve/emboss type (the
/// interaction re-exports it as `StrokeMode`, next to its
/// [`InteractionMode`](crate::interaction::InteractionMode), which adds sketching).
///
/// Written as `"carve"` or `"emboss"` in every format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Remove material: the groove goes in against the normal.
    Carve,
    /// Add material: the ridge stands out along the normal.
    Emboss,
}

/// The chisel and what it does: the one tool type, the interaction's current tool
/// (its [`Interaction::tool`](crate::interaction::Interaction::tool)) and every
/// stroke's tool in the document.
///
/// **Defaults** ([`Tool::default`]): a V profile, 2 cm wide, 5 mm deep, carving, with
/// ends tapered over [`DEFAULT_TAPER`] (1 cm). **Caps** ([`Tool::validate`]): width
/// and depth in `(0, MAX_TOOL_SIZE]`, the taper in `[0, MAX_TOOL_SIZE]`
/// ([`MAX_TOOL_SIZE`] is 10 m), and a custom profile of 1 to 256 increasing points.
///
/// Serialized with its mode (`{"profile", "width", "depth", "mode", "taper"}`, the
/// document's and scene files' stroke tools); a stored stroke without `taper` has
/// blunt ends (0), as files written before tapers existed meant. The journal writes a
/// stroke's mode beside its tool instead (see
/// [`StrokeEdit`](crate::interaction::StrokeEdit)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    /// Cross-section.
    pub profile: Profile,
    /// Full width at the rims, metres.
    pub width: f64,
    /// Depth (carve) or height (emboss) at the centreline, metres.
    pub depth: f64,
    /// Carve or emboss.
    pub mode: Mode,
    /// Length over which each end tapers to nothing, metres (0: blunt round ends).
    #[serde(default)]
    pub taper: f64,
}

/// The largest tool width, depth and taper (metres) anywhere: the interaction's tool,
/// a stroke built from the wand, and every stroke of a document or scene file read
/// back, so that no mesh or file written from them holds a non-finite number.
pub const MAX_TOOL_SIZE: f64 = 10.0;

/// The default end taper (metres): [`Tool::default`]'s, and the taper of a journalled
/// stroke or a configured tool that does not give one.
pub const DEFAULT_TAPER: f64 = 0.01;

impl Default for Tool {
    fn default() -> Self {
        Self {
            profile: Profile::V,
            width: 0.02,
            depth: 0.005,
            mode: Mode::Carve,
            taper: DEFAULT_TAPER,
        }
    }
}

impl Tool {
    /// Checks the parameters: width and depth in `(0, MAX_TOOL_SIZE]`, the taper in
    /// `[0, MAX_TOOL_SIZE]`, and the profile; the error says which one is wrong.
    pub fn validate(&self) -> Result<()> {
        let size = |param: ToolParam, v: f64| {
            let zero_ok = param == ToolParam::Taper;
            let low_ok = if zero_ok { v >= 0.0 } else { v > 0.0 };
            if v.is_finite() && low_ok && v <= MAX_TOOL_SIZE {
                Ok(())
            } else {
                Err(reject(StrokeRejection::Tool(ToolRangeError {
                    param,
                    value: v,
                    max: MAX_TOOL_SIZE,
                })))
            }
        };
        size(ToolParam::Width, self.width)?;
        size(ToolParam::Depth, self.depth)?;
        size(ToolParam::Taper, self.taper)?;
        self.profile.validate()
    }
}
