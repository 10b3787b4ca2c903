//! Wavefront OBJ: `v`, `vt`, `vn` and `f a/a/a b/b/b c/c/c` lines.
//!
//! The reader accepts the common subset: positions, optional texture coordinates and
//! normals, faces with `a`, `a/b`, `a//c` or `a/b/c` references (negative indices count
//! back), polygons fanned into triangles. Other statements are ignored. Errors name the
//! line.

use super::{ALL_ATTRIBUTES, check_mesh};
use crate::Result;
use crate::error::{Error, Excerpt, FileFormat, FormatError};
use crate::mesh::{MeshVertex, WeldedMesh};
use std::fmt::Write;

fn err(reason: FormatError) -> Error {
    super::err(FileFormat::Obj, reason)
}

/// Writes the mesh as OBJ text; a vertex with a NaN or infinite number is an error
/// ([`FormatError::NonFinite`]) and nothing is written.
pub fn write(mesh: &WeldedMesh) -> Result<Vec<u8>> {
    write_coloured(mesh, None)
}

/// Writes the mesh as OBJ text like [`write`](fn@write), with vertex colours when
/// given: `v x y z r g b`, the common extension (read by MeshLab, Blender, trimesh),
/// colours in `[0, 1]` clamped. The colours must be one per vertex
/// ([`FormatError::ColourCount`]) and finite.
pub fn write_coloured(
    mesh: &WeldedMesh,
    colours: Option<&super::VertexColours>,
) -> Result<Vec<u8>> {
    check_mesh(FileFormat::Obj, mesh, ALL_ATTRIBUTES)?;
    if let Some(c) = colours {
        super::check_colours(FileFormat::Obj, mesh, c)?;
    }
    let mut s = String::with_capacity(mesh.vertices.len() * 100 + mesh.triangles.len() * 40);
    s.push_str("# Wandsculpt sculpted mesh\no sculpture\n");
    for (i, v) in mesh.vertices.iter().enumerate() {
        let [x, y, z] = v.position;
        match colours {
            Some(c) => {
                let [r, g, b] = c[i].map(|x| x.clamp(0.0, 1.0));
                let _ = writeln!(s, "v {x} {y} {z} {r} {g} {b}");
            }
            None => {
                let _ = writeln!(s, "v {x} {y} {z}");
            }
        }
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
    Ok(s.into_bytes())
}

/// Reads OBJ text. Vertices are de-indexed per distinct `v/vt/vn` triple.
pub fn read(bytes: &[u8]) -> Result<WeldedMesh> {
    let text = std::str::from_utf8(bytes).map_err(|error| err(FormatError::NotText { error }))?;
    let (mut pos, mut tex, mut nrm) = (Vec::new(), Vec::new(), Vec::new());
    let mut faces: Vec<(usize, Vec<[Option<usize>; 3]>)> = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let ln = ln + 1;
        let mut it = line.split_whitespace();
        let Some(tag) = it.next() else { continue };
        let nums = |it: std::str::SplitWhitespace<'_>, n: usize| -> Result<Vec<f32>> {
            let v: Vec<f32> = it
                .take(n)
                .map(|t| {
                    t.parse::<f32>().map_err(|error| {
                        err(FormatError::Number {
                            line: ln,
                            token: Excerpt::new(t),
                            error,
                        })
                    })
                })
                .collect::<Result<_>>()?;
            let finite = v.iter().filter(|x| x.is_finite()).count();
            if v.len() < n || finite < n {
                return Err(err(FormatError::NumberCount {
                    line: ln,
                    expected: n,
                    found: v.len(),
                    finite,
                }));
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
                        let i: i64 = part.parse().map_err(|error| {
                            err(FormatError::Index {
                                line: ln,
                                token: Excerpt::new(part),
                                error,
                            })
                        })?;
                        let idx = if i > 0 { i - 1 } else { counts[k] as i64 + i };
                        if idx < 0 || idx >= counts[k] as i64 {
                            return Err(err(FormatError::IndexOutOfRange {
                                line: ln,
                                index: i,
                                count: counts[k],
                            }));
                        }
                        r[k] = Some(idx as usize);
                    }
                    if r[0].is_none() {
                        return Err(err(FormatError::FaceWithoutPosition { line: ln }));
                    }
                    refs.push(r);
                }
                if refs.len() < 3 {
                    return Err(err(FormatError::FaceTooSmall {
                        line: ln,
                        found: refs.len(),
                    }));
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

    fn reason(e: Error) -> FormatError {
        match e {
            Error::Format {
                format: FileFormat::Obj,
                reason,
            } => reason,
            other => panic!("not an OBJ format error: {other:?}"),
        }
    }

    #[test]
    fn errors_are_typed_with_line_token_and_cause() {
        match reason(read(b"v 0 0 0\nv 1 x2 0\n").unwrap_err()) {
            FormatError::Number { line, token, error } => {
                assert_eq!(line, 2);
                assert_eq!(token.prefix, "x2");
                assert_eq!(error, "x2".parse::<f32>().unwrap_err());
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            reason(read(b"v 0 0 0\nf 1 2 3\n").unwrap_err()),
            FormatError::IndexOutOfRange {
                line: 2,
                index: 2,
                count: 1
            }
        );
        assert_eq!(
            reason(read(b"v 0 inf\n").unwrap_err()),
            FormatError::NumberCount {
                line: 1,
                expected: 3,
                found: 2,
                finite: 1
            }
        );
        assert!(matches!(
            reason(read(b"v 0 0 0\nf 1/q 1 1\n").unwrap_err()),
            FormatError::Index { line: 2, .. }
        ));
        assert!(matches!(
            reason(read(b"\xff").unwrap_err()),
            FormatError::NotText { .. }
        ));
    }

    /// Regression (issue 15): a 200 MB CSV line gave a 200 MB error message, because
    /// errors quoted the bad input whole. A 50 MB single-line OBJ now gives a short one.
    #[test]
    fn huge_single_line_gives_a_short_error_because_quotes_are_cut() {
        const MB50: usize = 50 << 20;
        let mut number = b"v 0 0 ".to_vec();
        number.resize(MB50, b'x');
        let mut index = b"v 0 0 0\nf 1/".to_vec();
        index.resize(MB50, b'7');
        index.extend_from_slice(b"q 1 1");
        for bytes in [number, index] {
            let e = read(&bytes).unwrap_err();
            let message = crate::error::Chain(&e).to_string();
            assert!(message.len() < 200, "{} bytes: {message}", message.len());
            assert!(message.contains("..."), "{message}");
        }
    }

    /// Regression (issue 15): a mesh with a NaN vertex (a scene with a huge stroke
    /// depth) was written as OBJ with `NaN` / `inf` text.
    #[test]
    fn nan_vertex_is_refused_not_written_as_nan() {
        let v = |x: f32| MeshVertex {
            position: [x, 0.0, 0.0],
            normal: [0.0, 0.0, 1.0],
            uv: [0.0; 2],
        };
        let mut mesh = WeldedMesh {
            vertices: vec![v(0.0), v(1.0), v(f32::NAN)],
            triangles: vec![[0, 1, 2]],
        };
        assert_eq!(
            reason(write(&mesh).unwrap_err()),
            FormatError::NonFinite {
                what: crate::error::WrittenValue::Position,
                index: 2
            }
        );
        mesh.vertices[2].position[0] = 0.5;
        mesh.vertices[1].normal[2] = f32::INFINITY;
        assert_eq!(
            reason(write(&mesh).unwrap_err()),
            FormatError::NonFinite {
                what: crate::error::WrittenValue::Normal,
                index: 1
            }
        );
        mesh.vertices[1].normal[2] = 1.0;
        let text = String::from_utf8(write(&mesh).unwrap()).unwrap();
        assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
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
