//! Binary STL: an 80-byte header, a triangle count, and 50 bytes per triangle (facet
//! normal, three corners, attribute word), little-endian `f32`.

use super::err;
use crate::Result;
use crate::mesh::{MeshVertex, WeldedMesh};

/// Writes binary STL with facet normals computed from the corners.
pub fn write(mesh: &WeldedMesh) -> Vec<u8> {
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
    out
}

/// Reads binary STL (one vertex per corner; weld afterwards if needed).
pub fn read(bytes: &[u8]) -> Result<WeldedMesh> {
    if bytes.len() < 84 {
        return Err(err(
            "STL",
            format!("{} bytes is shorter than the 84-byte header", bytes.len()),
        ));
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
    let want = n.checked_mul(50).and_then(|b| b.checked_add(84));
    if want != Some(bytes.len()) {
        return Err(err(
            "STL",
            format!(
                "header says {n} triangles but the file has {} bytes",
                bytes.len()
            ),
        ));
    }
    let f = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let mut mesh = WeldedMesh::default();
    for k in 0..n {
        let base = 84 + 50 * k;
        let normal = [f(base), f(base + 4), f(base + 8)];
        let mut ids = [0u32; 3];
        for (c, id) in ids.iter_mut().enumerate() {
            let o = base + 12 + 12 * c;
            let position = [f(o), f(o + 4), f(o + 8)];
            if position.iter().any(|x| !x.is_finite()) {
                return Err(err("STL", format!("triangle {k} has a non-finite corner")));
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
    }

    proptest! {
        #[test]
        fn never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = read(&bytes);
        }
    }
}
