//! Binary STL: an 80-byte header, a triangle count, and 50 bytes per triangle (facet
//! normal, three corners, attribute word), little-endian `f32`.

use super::check_mesh;
use crate::Result;
use crate::error::{Error, FileFormat, FormatError, WrittenValue};
use crate::mesh::{MeshVertex, WeldedMesh};

/// The header's size: 80 bytes of text and the triangle count.
const HEADER_BYTES: usize = 84;

fn err(reason: FormatError) -> Error {
    super::err(FileFormat::Stl, reason)
}

/// Writes binary STL with facet normals computed from the corners (zero where a
/// triangle has no area). A vertex position that is NaN or infinite is an error
/// ([`FormatError::NonFinite`]) and nothing is written.
pub fn write(mesh: &WeldedMesh) -> Result<Vec<u8>> {
    check_mesh(FileFormat::Stl, mesh, &[WrittenValue::Position])?;
    let mut out = Vec::with_capacity(84 + 50 * mesh.triangles.len());
    let mut header = [b' '; 80];
    let title = b"Wandsculpt sculpted mesh (binary STL)";
    header[..title.len()].copy_from_slice(title);
    out.extend_from_slice(&header);
    out.extend_from_slice(&(mesh.triangles.len() as u32).to_le_bytes());
    for t in &mesh.triangles {
        let p = t.map(|i| glam::Vec3::from_array(mesh.vertices[i as usize].position));
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for v in std::iter::once(n).chain(p) {
            for c in v.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.extend_from_slice(&0u16.to_le_bytes());
    }
    Ok(out)
}

/// Reads binary STL (one vertex per corner; weld afterwards if needed).
pub fn read(bytes: &[u8]) -> Result<WeldedMesh> {
    if bytes.len() < HEADER_BYTES {
        return Err(err(FormatError::Truncated {
            bytes: bytes.len(),
            header: HEADER_BYTES,
        }));
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
    let want = n.checked_mul(50).and_then(|b| b.checked_add(HEADER_BYTES));
    if want != Some(bytes.len()) {
        return Err(err(FormatError::TriangleCount {
            triangles: n,
            bytes: bytes.len(),
        }));
    }
    let f = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let mut mesh = WeldedMesh::default();
    for k in 0..n {
        let base = HEADER_BYTES + 50 * k;
        let normal = [f(base), f(base + 4), f(base + 8)];
        let mut ids = [0u32; 3];
        for (c, id) in ids.iter_mut().enumerate() {
            let o = base + 12 + 12 * c;
            let position = [f(o), f(o + 4), f(o + 8)];
            if position.iter().any(|x| !x.is_finite()) {
                return Err(err(FormatError::NonFiniteCorner { triangle: k }));
            }
            mesh.vertices.push(MeshVertex {
                position,
                normal,
                uv: [0.0; 2],
            });
            *id = (mesh.vertices.len() - 1) as u32;
        }
        mesh.triangles.push(ids);
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn truncated_file_is_rejected() {
        let mut bytes = vec![0u8; 84 + 50];
        bytes[80] = 2;
        assert!(
            read(&bytes)
                .unwrap_err()
                .to_string()
                .contains("2 triangles")
        );
        assert_eq!(
            read(&bytes).unwrap_err(),
            err(FormatError::TriangleCount {
                triangles: 2,
                bytes: 134
            })
        );
        assert_eq!(
            read(&bytes[..10]).unwrap_err(),
            err(FormatError::Truncated {
                bytes: 10,
                header: HEADER_BYTES
            })
        );
    }

    /// Regression (issue 15): a mesh with a NaN or infinite vertex was written as STL
    /// with non-finite corners that readers reject.
    #[test]
    fn nan_vertex_is_refused_not_written() {
        let v = |x: f32| MeshVertex {
            position: [x, 0.0, x],
            normal: [0.0, 0.0, 1.0],
            uv: [f32::NAN; 2], // STL writes no texture coordinates
        };
        let mut mesh = WeldedMesh {
            vertices: vec![v(0.0), v(1.0), v(0.5)],
            triangles: vec![[0, 1, 2]],
        };
        mesh.vertices[1].position[1] = f32::NEG_INFINITY;
        assert_eq!(
            write(&mesh).unwrap_err(),
            Error::Format {
                format: FileFormat::Stl,
                reason: FormatError::NonFinite {
                    what: WrittenValue::Position,
                    index: 1
                }
            }
        );
        mesh.vertices[1].position[1] = 1.0;
        assert_eq!(read(&write(&mesh).unwrap()).unwrap().triangles.len(), 1);
    }

    proptest! {
        #[test]
        fn never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = read(&bytes);
        }
    }
}
