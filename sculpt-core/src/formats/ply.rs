//! Stanford PLY, ASCII (`format ascii 1.0`): one `vertex` element with `x y z` (float),
//! `nx ny nz` (float) and, when given, `red green blue` (uchar, the colours of
//! [`crate::paint`] scaled to `0..=255`), and one `face` element of `vertex_indices`
//! (`list uchar int`, triangles). The header is the one MeshLab, Blender, Open3D and
//! trimesh read (Turk, *The PLY polygon file format*, 1994).
//!
//! ```
//! use sculpt_core::formats::ply;
//! use sculpt_core::mesh::{MeshVertex, WeldedMesh};
//! let v = |x: f32, y: f32| MeshVertex { position: [x, y, 0.0], normal: [0.0, 0.0, 1.0], uv: [x, y] };
//! let mesh = WeldedMesh { vertices: vec![v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)], triangles: vec![[0, 1, 2]] };
//! let text = String::from_utf8(ply::write(&mesh, Some(&[[1.0, 0.0, 0.0]; 3]))?).unwrap();
//! assert!(text.contains("property uchar red") && text.contains("\n3 0 1 2\n"));
//! # Ok::<(), sculpt_core::Error>(())
//! ```

use std::fmt::Write;

use super::{VertexColours, check_colours, check_mesh};
use crate::Result;
use crate::error::{FileFormat, WrittenValue};
use crate::mesh::WeldedMesh;

/// A colour component in `[0, 1]` (clamped) as a PLY `uchar`.
fn byte(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Writes the mesh as ASCII PLY, with vertex colours when given; a vertex with a NaN or
/// infinite position or normal, or colours that are not one finite colour per vertex,
/// is an error and nothing is written.
pub fn write(mesh: &WeldedMesh, colours: Option<&VertexColours>) -> Result<Vec<u8>> {
    check_mesh(
        FileFormat::Ply,
        mesh,
        &[WrittenValue::Position, WrittenValue::Normal],
    )?;
    if let Some(c) = colours {
        check_colours(FileFormat::Ply, mesh, c)?;
    }
    let mut s = String::with_capacity(256 + mesh.vertices.len() * 80 + mesh.triangles.len() * 24);
    s.push_str("ply\nformat ascii 1.0\ncomment Wandsculpt sculpted mesh\n");
    let _ = writeln!(s, "element vertex {}", mesh.vertices.len());
    for p in ["x", "y", "z", "nx", "ny", "nz"] {
        let _ = writeln!(s, "property float {p}");
    }
    if colours.is_some() {
        for p in ["red", "green", "blue"] {
            let _ = writeln!(s, "property uchar {p}");
        }
    }
    let _ = writeln!(s, "element face {}", mesh.triangles.len());
    s.push_str("property list uchar int vertex_indices\nend_header\n");
    for (i, v) in mesh.vertices.iter().enumerate() {
        let [x, y, z] = v.position;
        let [a, b, c] = v.normal;
        let _ = write!(s, "{x} {y} {z} {a} {b} {c}");
        if let Some(colours) = colours {
            let [r, g, b] = colours[i].map(byte);
            let _ = write!(s, " {r} {g} {b}");
        }
        s.push('\n');
    }
    for [a, b, c] in &mesh.triangles {
        let _ = writeln!(s, "3 {a} {b} {c}");
    }
    Ok(s.into_bytes())
}
