//! The live stroke preview: the tool footprint swept along the stroke so far, drawn
//! while the wand button is held (the stroke is applied to the document only on
//! release).
//!
//! The ribbon is the tool width wide, across the path in the plane facing the viewer,
//! and lifted towards the viewer by half the tool depth for emboss or sunk by it for
//! carve, so it reads as "material will go here".
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::interaction::{StrokeEdit, StrokeSample, Tool, DEFAULT_TARGET};
//! use sculpt_core::mesh::PatchMesh;
//! let samples = (0..4)
//!     .map(|i| StrokeSample { t: i as f64, position: DVec3::new(0.01 * i as f64, 1.2, 0.0) })
//!     .collect();
//! let stroke = StrokeEdit::new(DEFAULT_TARGET, Tool::default(), samples);
//! let mut mesh = PatchMesh::new();
//! vr_app::preview::write_stroke_ribbon(&stroke, DVec3::Z, 7, &mut mesh);
//! assert_eq!(mesh.triangle_count(), 6);
//! ```

use glam::DVec3;
use sculpt_core::interaction::{StrokeEdit, StrokeMode};
use sculpt_core::mesh::{MeshSink, MeshVertex, PatchKey};

/// Writes a stroke's footprint ribbon as patch `key`. `facing` is the direction the
/// target faces (towards the viewer). Fewer than two finite samples, or a bad width,
/// remove the patch instead.
pub fn write_stroke_ribbon(
    stroke: &StrokeEdit,
    facing: DVec3,
    key: PatchKey,
    sink: &mut dyn MeshSink,
) {
    let pts: Vec<DVec3> = stroke
        .samples
        .iter()
        .map(|s| s.position)
        .filter(|p| p.is_finite())
        .collect();
    let facing = if facing.is_finite() && facing.length_squared() > 0.0 {
        facing.normalize()
    } else {
        DVec3::Z
    };
    if pts.len() < 2 || !(stroke.tool.width.is_finite() && stroke.tool.width > 0.0) {
        sink.remove_patch(key);
        return;
    }
    let half = 0.5 * stroke.tool.width;
    let lift = match stroke.mode {
        StrokeMode::Carve => -0.5 * stroke.tool.depth,
        StrokeMode::Emboss => 0.5 * stroke.tool.depth,
    };
    sink.begin_patch(key);
    let mut across_prev = DVec3::X;
    for (i, p) in pts.iter().enumerate() {
        let tangent = pts[(i + 1).min(pts.len() - 1)] - pts[i.saturating_sub(1)];
        let across = tangent.cross(facing);
        let across = if across.length_squared() > crate::tolerance::ZERO_LEN2_EPS {
            across.normalize()
        } else {
            across_prev
        };
        across_prev = across;
        let c = *p + facing * lift;
        for side in [-1.0, 1.0] {
            sink.push_vertex(MeshVertex {
                position: (c + across * side * half).as_vec3().to_array(),
                normal: facing.as_vec3().to_array(),
                uv: [i as f32 / (pts.len() - 1) as f32, (side as f32 + 1.0) * 0.5],
            });
        }
    }
    for i in 0..pts.len() as u32 - 1 {
        let a = i * 2;
        sink.push_triangle(a, a + 2, a + 1);
        sink.push_triangle(a + 1, a + 2, a + 3);
    }
    sink.end_patch();
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::interaction::{DEFAULT_TARGET, StrokeSample, Tool};
    use sculpt_core::mesh::PatchMesh;
    use sculpt_core::tolerance::F32_EPS;

    fn stroke(points: &[DVec3], mode: StrokeMode) -> StrokeEdit {
        StrokeEdit::new(
            DEFAULT_TARGET,
            Tool {
                mode,
                ..Tool::default()
            },
            points
                .iter()
                .enumerate()
                .map(|(i, p)| StrokeSample {
                    t: i as f64,
                    position: *p,
                })
                .collect(),
        )
    }

    #[test]
    fn ribbon_is_tool_wide_and_sunk_for_carve_lifted_for_emboss() {
        let pts = [DVec3::ZERO, DVec3::X * 0.1, DVec3::X * 0.2];
        for (mode, sign) in [(StrokeMode::Carve, -1.0), (StrokeMode::Emboss, 1.0)] {
            let s = stroke(&pts, mode);
            let mut m = PatchMesh::new();
            write_stroke_ribbon(&s, DVec3::Z, 3, &mut m);
            let (v, t) = m.merged();
            assert_eq!((v.len(), t.len()), (6, 4));
            let width = DVec3::from(v[0].position.map(f64::from))
                .distance(DVec3::from(v[1].position.map(f64::from)));
            assert_near!(width, s.tool.width, F32_EPS);
            assert_near!(
                f64::from(v[2].position[2]),
                sign * 0.5 * s.tool.depth,
                F32_EPS
            );
        }
    }

    #[test]
    fn degenerate_strokes_remove_the_patch() {
        let mut m = PatchMesh::new();
        write_stroke_ribbon(
            &stroke(&[DVec3::ZERO, DVec3::X * 0.1], StrokeMode::Carve),
            DVec3::Z,
            1,
            &mut m,
        );
        assert_eq!(m.triangle_count(), 2);
        write_stroke_ribbon(
            &stroke(&[DVec3::ZERO, DVec3::NAN], StrokeMode::Carve),
            DVec3::NAN,
            1,
            &mut m,
        );
        assert_eq!(m.triangle_count(), 0);
    }
}
