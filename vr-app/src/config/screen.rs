//! `[screen]`: the screen rectangle's three corners (also a cluster node's own screen,
//! `[[cluster.node]] screen`).

use serde::{Deserialize, Serialize};

use crate::error::VrResult;
use crate::projection::Screen;

/// The screen rectangle, display frame metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScreenConfig {
    /// Lower-left corner.
    pub lower_left: [f64; 3],
    /// Lower-right corner.
    pub lower_right: [f64; 3],
    /// Upper-left corner.
    pub upper_left: [f64; 3],
}

impl Default for ScreenConfig {
    fn default() -> Self {
        // A 27" monitor (0.6 m x 0.34 m) whose bottom edge is at y = 1.0 m.
        Self {
            lower_left: [-0.3, 1.0, 0.0],
            lower_right: [0.3, 1.0, 0.0],
            upper_left: [-0.3, 1.34, 0.0],
        }
    }
}

impl ScreenConfig {
    /// The validated screen.
    pub fn screen(&self) -> VrResult<Screen> {
        Screen::new(
            self.lower_left.into(),
            self.lower_right.into(),
            self.upper_left.into(),
        )
    }
}
