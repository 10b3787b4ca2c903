//! Wavefront OBJ: `v`, `vt`, `vn` and `f a/a/a b/b/b c/c/c` lines.
//!
//! The reader accepts the common subset: positions, optional texture coordinates and
//! normals, faces with `a`, `a/b`, `a//c` or `a/b/c` references (negative indices count
//! back), polygons fanned into triangles. Other statements are ignored. Errors name the
//! line.

use super::err;
use crate::Result;
use crate::mesh::{MeshVertex, WeldedMesh};
use std::fmt::Write;

/// Writes the mesh as OBJ text.
pub fn write(mesh: &WeldedMesh) -> Vec<u8> {
    let mut s = String::with_capacity(mesh.vertices.len() * 100 + mesh.triangles.len() * 40);
    s.push_str("# Wandsculpt sculpted mesh\no sculpture\n");
    for v in &mesh.vertices {
        let [x, y, z] = v.position;
        let _ = writeln!(s, "v {x} {y} {z}");
    }
    for v in &mesh.vertices {
        let [u, w] = v.uv;
        let _ = writeln!(s, "vt {u} {w}");
    }
    for v in &mesh.vertices {
        let [x, y, z] = v.normal;
        let _ = writeln!(s, "vn {x} {y} {z}");
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        let _ = writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
    }
    s.into_bytes()
}

/// Reads OBJ text. Vertices are de-indexed per distinct `v/vt/vn` triple.
pub fn read(bytes: &[u8]) -> Result<WeldedMesh> {
    let text = std::str::from_utf8(bytes).map_err(|e| err("OBJ", format!("not UTF-8: {e}")))?;
    let (mut pos, mut tex, mut nrm) = (Vec::new(), Vec::new(), Vec::new());
    let mut faces: Vec<(usize, Vec<[Option<usize>; 3]>)> = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let ln = ln + 1;
        let mut it = line.split_whitespace();
        let Some(tag) = it.next() else { continue };
        let nums = |it: std::str::SplitWhitespace<'_>, n: usize| -> Result<Vec<f32>> {
            let v: Vec<f32> = it
                .take(n)
                .map(|t| t.parse::<f32>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|e| err("OBJ", format!("line {ln}: {e}")))?;
            if v.len() < n || v.iter().any(|x| !x.is_finite()) {
                return Err(err(
                    "OBJ",
                    format!("line {ln}: expected {n} finite numbers"),
                ));
            }
            Ok(v)
        };
        match tag {
            "v" => pos.push(nums(it, 3)?),
            "vt" => tex.push(nums(it, 2)?),
            "vn" => nrm.push(nums(it, 3)?),
            "f" => {
                let mut refs = Vec::new();
                for t in it {
                    let mut r = [None; 3];
                    let counts = [pos.len(), tex.len(), nrm.len()];
                    for (k, part) in t.split('/').enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        let i: i64 = part.parse().map_err(|e| {
                            err("OBJ", format!("line {ln}: bad index {part:?}: {e}"))
                        })?;
                        let idx = if i > 0 { i - 1 } else { counts[k] as i64 + i };
                        if idx < 0 || idx >= counts[k] as i64 {
                            return Err(err("OBJ", format!("line {ln}: index {i} out of range")));
                        }
                        r[k] = Some(idx as usize);
                    }
                    if r[0].is_none() {
                        return Err(err("OBJ", format!("line {ln}: face without a position")));
                    }
                    refs.push(r);
                }
                if refs.len() < 3 {
                    return Err(err("OBJ", format!("line {ln}: a face needs 3 vertices")));
                }
                faces.push((ln, refs));
            }
            _ => {}
        }
    }
    let mut mesh = WeldedMesh::default();
    let mut seen = std::collections::HashMap::new();
    for (_, refs) in faces {
        let ids: Vec<u32> = refs
            .iter()
            .map(|r| {
                *seen.entry(*r).or_insert_with(|| {
                    let p = &pos[r[0].unwrap_or(0)];
                    mesh.vertices.push(MeshVertex {
                        position: [p[0], p[1], p[2]],
                        uv: r[1].map_or([0.0; 2], |i| [tex[i][0], tex[i][1]]),
                        normal: r[2].map_or([0.0; 3], |i| [nrm[i][0], nrm[i][1], nrm[i][2]]),
                    });
                    (mesh.vertices.len() - 1) as u32
                })
            })
            .collect();
        for k in 1..ids.len() - 1 {
            mesh.triangles.push([ids[0], ids[k], ids[k + 1]]);
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn reads_polygons_and_negative_indices() {
        let m = read(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn bad_files_name_the_line() {
        let e = read(b"v 0 0 0\nf 1 2 3\n").unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        let e = read(b"v 0 nan 0\n").unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
    }

    proptest! {
        #[test]
        fn never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = read(&bytes);
        }

        #[test]
        fn never_panics_on_obj_like_text(lines in proptest::collection::vec("(v|vt|vn|f) [-0-9/ .e]{0,20}", 0..20)) {
            let _ = read(lines.join("\n").as_bytes());
        }
    }
}
