//! The vertex of overlay lines (wand cursor, footprints, cages, the UV map), a leaf
//! the scene and the overlays share.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// One vertex of an overlay line (wand cursor, footprint), display frame.
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct LineVertex {
    /// Position, display frame metres.
    pub position: [f32; 3],
    /// Linear RGBA colour.
    pub color: [f32; 4],
}

impl LineVertex {
    /// A vertex from a display-frame point.
    pub fn new(p: DVec3, color: [f32; 4]) -> Self {
        Self {
            position: p.as_vec3().to_array(),
            color,
        }
    }
}
