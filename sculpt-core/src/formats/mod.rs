//! File formats as bytes in and bytes out: OBJ, binary STL and glTF 2.0 binary for
//! sculpted meshes, IGES 5.3 for the NURBS surfaces. Every writer has a reader, used by
//! the tests to check what was written.
//!
//! ```
//! use sculpt_core::formats::{obj, stl};
//! use sculpt_core::mesh::{MeshVertex, WeldedMesh};
//! let v = |x: f32, y: f32| MeshVertex { position: [x, y, 0.0], normal: [0.0, 0.0, 1.0], uv: [x, y] };
//! let mesh = WeldedMesh { vertices: vec![v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)], triangles: vec![[0, 1, 2]] };
//! let back = obj::read(&obj::write(&mesh)).unwrap();
//! assert_eq!(back.triangles, mesh.triangles);
//! assert_eq!(stl::read(&stl::write(&mesh)).unwrap().triangles.len(), 1);
//! ```

pub mod glb;
pub mod iges;
pub mod obj;
pub mod stl;

use crate::error::Error;

fn err(format: &'static str, reason: impl Into<String>) -> Error {
    Error::Format {
        format,
        reason: reason.into(),
    }
}

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

    /// Writes a mesh in this format.
    pub fn write(self, mesh: &crate::mesh::WeldedMesh) -> Vec<u8> {
        match self {
            Self::Obj => obj::write(mesh),
            Self::Stl => stl::write(mesh),
            Self::Glb => glb::write(mesh),
        }
    }

    /// Reads a mesh in this format.
    pub fn read(self, bytes: &[u8]) -> crate::Result<crate::mesh::WeldedMesh> {
        match self {
            Self::Obj => obj::read(bytes),
            Self::Stl => stl::read(bytes),
            Self::Glb => glb::read(bytes),
        }
    }
}
