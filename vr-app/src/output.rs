//! How the two eyes reach the display ([`OutputMode`]): a configuration choice that
//! the renderer, the window and headless runs all read.

use serde::{Deserialize, Serialize};

use crate::error::{VrError, VrResult};

/// How the two eyes reach the display.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OutputMode {
    /// One output per projector: left eye on one, right eye on the other.
    #[default]
    Dual,
    /// One wide output, left eye on the left half.
    SideBySide,
    /// Red-cyan anaglyph on one output.
    Anaglyph,
    /// One eye (the head centre), no stereo.
    Mono,
}

impl std::str::FromStr for OutputMode {
    type Err = VrError;
    fn from_str(s: &str) -> VrResult<Self> {
        match s {
            "dual" => Ok(Self::Dual),
            "side-by-side" | "sbs" => Ok(Self::SideBySide),
            "anaglyph" => Ok(Self::Anaglyph),
            "mono" => Ok(Self::Mono),
            other => Err(VrError::Config(crate::ConfigError::OutputMode(
                other.to_string(),
            ))),
        }
    }
}
