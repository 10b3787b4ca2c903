//! File formats as bytes in and bytes out: OBJ, binary STL and glTF 2.0 binary for
//! sculpted meshes, IGES 5.3 for the NURBS surfaces. Every writer has a reader, used by
//! the tests to check what was written.
//!
//! ```
//! use sculpt_core::formats::{obj, stl};
//! use sculpt_core::mesh::{MeshVertex, WeldedMesh};
//! let v = |x: f32, y: f32| MeshVertex { position: [x, y, 0.0], normal: [0.0, 0.0, 1.0], uv: [x, y] };
//! let mesh = WeldedMesh { vertices: vec![v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)], triangles: vec![[0, 1, 2]] };
//! let back = obj::read(&obj::write(&mesh)?)?;
//! assert_eq!(back.triangles, mesh.triangles);
//! assert_eq!(stl::read(&stl::write(&mesh)?)?.triangles.len(), 1);
//! # Ok::<(), sculpt_core::Error>(())
//! ```
//!
//! Errors are [`Error::Format`] with a typed [`FormatError`]: readers name the line,
//! entry or byte and quote at most a short prefix of bad input
//! ([`crate::error::MAX_QUOTED_CHARS`]); writers refuse a mesh or surface holding a
//! NaN or infinite number ([`FormatError::NonFinite`]) instead of writing it.

pub mod glb;
pub mod iges;
pub mod obj;
pub mod ply;
pub mod stl;

use crate::error::{Error, FileFormat, FormatError, WrittenValue};
use crate::mesh::WeldedMesh;

fn err(format: FileFormat, reason: FormatError) -> Error {
    Error::Format { format, reason }
}

/// Checks that every number a mesh writer writes (the vertex attributes in `written`)
/// is finite, so that no writer emits `NaN` or `inf`; the error names the first bad
/// vertex.
fn check_mesh(
    format: FileFormat,
    mesh: &WeldedMesh,
    written: &[WrittenValue],
) -> crate::Result<()> {
    for (index, v) in mesh.vertices.iter().enumerate() {
        for &what in written {
            let finite = match what {
                WrittenValue::Position => v.position.iter().all(|x| x.is_finite()),
                WrittenValue::Normal => v.normal.iter().all(|x| x.is_finite()),
                WrittenValue::TexCoord => v.uv.iter().all(|x| x.is_finite()),
                _ => true,
            };
            if !finite {
                return Err(err(format, FormatError::NonFinite { what, index }));
            }
        }
    }
    Ok(())
}

/// Vertex colours, linear RGB in `[0, 1]`, one per vertex of a mesh (what
/// [`crate::paint`] gives a painted mesh).
pub type VertexColours = [[f32; 3]];

/// Checks that `colours` has one finite colour per vertex of `mesh`.
fn check_colours(
    format: FileFormat,
    mesh: &WeldedMesh,
    colours: &VertexColours,
) -> crate::Result<()> {
    if colours.len() != mesh.vertices.len() {
        return Err(err(
            format,
            FormatError::ColourCount {
                got: colours.len(),
                need: mesh.vertices.len(),
            },
        ));
    }
    if let Some(index) = colours
        .iter()
        .position(|c| !c.iter().all(|x| x.is_finite()))
    {
        return Err(err(
            format,
            FormatError::NonFinite {
                what: WrittenValue::Colour,
                index,
            },
        ));
    }
    Ok(())
}

/// Every vertex attribute: what OBJ and glTF write.
const ALL_ATTRIBUTES: &[WrittenValue] = &[
    WrittenValue::Position,
    WrittenValue::Normal,
    WrittenValue::TexCoord,
];

/// The mesh formats, chosen from a file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ (text).
    Obj,
    /// Binary STL.
    Stl,
    /// glTF 2.0 binary.
    Glb,
}

impl MeshFormat {
    /// The format for a file name's extension (`obj`, `stl`, `glb`, any case).
    pub fn from_extension(name: &str) -> Option<Self> {
        let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(Self::Obj),
            "stl" => Some(Self::Stl),
            "glb" => Some(Self::Glb),
            _ => None,
        }
    }

    /// Writes a mesh in this format; a vertex with a NaN or infinite number is an
    /// error ([`FormatError::NonFinite`]).
    pub fn write(self, mesh: &WeldedMesh) -> crate::Result<Vec<u8>> {
        match self {
            Self::Obj => obj::write(mesh),
            Self::Stl => stl::write(mesh),
            Self::Glb => glb::write(mesh),
        }
    }

    /// Writes a mesh in this format with vertex colours where the format has them
    /// (OBJ `v x y z r g b`, glTF `COLOR_0`; STL has none and ignores them).
    pub fn write_coloured(
        self,
        mesh: &WeldedMesh,
        colours: Option<&VertexColours>,
    ) -> crate::Result<Vec<u8>> {
        match self {
            Self::Obj => obj::write_coloured(mesh, colours),
            Self::Stl => stl::write(mesh),
            Self::Glb => glb::write_coloured(mesh, colours),
        }
    }

    /// Reads a mesh in this format.
    pub fn read(self, bytes: &[u8]) -> crate::Result<WeldedMesh> {
        match self {
            Self::Obj => obj::read(bytes),
            Self::Stl => stl::read(bytes),
            Self::Glb => glb::read(bytes),
        }
    }
}
