//! glTF 2.0 binary (`.glb`): one mesh with `POSITION`, `NORMAL`, `TEXCOORD_0` and
//! `u32` indices in a single buffer.
//!
//! The reader reads what the writer writes and what most exporters produce for a
//! triangle mesh: the first primitive's float `VEC3` positions and normals, float `VEC2`
//! texture coordinates and `u8`/`u16`/`u32` indices, from the GLB's binary chunk. It
//! bounds-checks every access, so a damaged file gives an error, never a panic.

use super::{ALL_ATTRIBUTES, check_mesh};
use crate::Result;
use crate::error::{Error, FileFormat, FormatError, GltfPart};
use crate::mesh::{MeshVertex, WeldedMesh};
use serde_json::{Value, json};

const MAGIC: u32 = 0x4654_6C67; // "glTF"
const CHUNK_JSON: u32 = 0x4E4F_534A; // "JSON"
const CHUNK_BIN: u32 = 0x004E_4942; // "BIN\0"

fn err(reason: FormatError) -> Error {
    super::err(FileFormat::Gltf, reason)
}

/// Writes a `.glb`; a vertex with a NaN or infinite number is an error
/// ([`FormatError::NonFinite`]) and nothing is written (glTF's JSON has no
/// spelling for them, and the accessor bounds would be wrong).
pub fn write(mesh: &WeldedMesh) -> Result<Vec<u8>> {
    write_coloured(mesh, None)
}

/// Writes a `.glb` like [`write`](fn@write), with vertex colours when given: a
/// `COLOR_0` attribute (float `VEC3`, linear RGB in `[0, 1]` clamped, glTF 2.0
/// sec. 3.7.2.1), after the other attributes in the buffer. The colours must be one
/// per vertex ([`FormatError::ColourCount`]) and finite.
pub fn write_coloured(
    mesh: &WeldedMesh,
    colours: Option<&super::VertexColours>,
) -> Result<Vec<u8>> {
    check_mesh(FileFormat::Gltf, mesh, ALL_ATTRIBUTES)?;
    if let Some(c) = colours {
        super::check_colours(FileFormat::Gltf, mesh, c)?;
    }
    let nv = mesh.vertices.len();
    let mut bin: Vec<u8> = Vec::with_capacity(nv * 32 + mesh.triangles.len() * 12);
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for v in &mesh.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(v.position[k]);
            hi[k] = hi[k].max(v.position[k]);
        }
        bin.extend(v.position.iter().flat_map(|x| x.to_le_bytes()));
    }
    if nv == 0 {
        (lo, hi) = ([0.0; 3], [0.0; 3]);
    }
    let normals_at = bin.len();
    for v in &mesh.vertices {
        bin.extend(v.normal.iter().flat_map(|x| x.to_le_bytes()));
    }
    let uvs_at = bin.len();
    for v in &mesh.vertices {
        bin.extend(v.uv.iter().flat_map(|x| x.to_le_bytes()));
    }
    let idx_at = bin.len();
    for t in &mesh.triangles {
        bin.extend(t.iter().flat_map(|x| x.to_le_bytes()));
    }
    let idx_len = bin.len() - idx_at;
    let colours_at = bin.len();
    for c in colours.unwrap_or(&[]) {
        bin.extend(c.iter().flat_map(|x| x.clamp(0.0, 1.0).to_le_bytes()));
    }
    let colours_len = bin.len() - colours_at;
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": "Wandsculpt sculpt-core"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "sculpture"}],
        "meshes": [{"name": "sculpture", "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
            "indices": 3, "mode": 4
        }]}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": normals_at, "target": 34962},
            {"buffer": 0, "byteOffset": normals_at, "byteLength": uvs_at - normals_at, "target": 34962},
            {"buffer": 0, "byteOffset": uvs_at, "byteLength": idx_at - uvs_at, "target": 34962},
            {"buffer": 0, "byteOffset": idx_at, "byteLength": idx_len, "target": 34963}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": nv, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": mesh.triangles.len() * 3, "type": "SCALAR"}
        ]
    });
    if colours.is_some() {
        doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(4);
        if let Some(views) = doc["bufferViews"].as_array_mut() {
            views.push(json!({"buffer": 0, "byteOffset": colours_at, "byteLength": colours_len, "target": 34962}));
        }
        if let Some(accessors) = doc["accessors"].as_array_mut() {
            accessors
                .push(json!({"bufferView": 4, "componentType": 5126, "count": nv, "type": "VEC3"}));
        }
    }
    let mut json_bytes = serde_json::to_vec(&doc).unwrap_or_default();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    for w in [MAGIC, 2, total as u32, json_bytes.len() as u32, CHUNK_JSON] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
    out.extend_from_slice(&bin);
    Ok(out)
}

fn u32_at(b: &[u8], o: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(o..o + 4)?.try_into().ok()?))
}

/// Reads a `.glb` written by [`write`](fn@write) or a compatible exporter.
pub fn read(bytes: &[u8]) -> Result<WeldedMesh> {
    let missing = |part: GltfPart| err(FormatError::Missing(part));
    if u32_at(bytes, 0) != Some(MAGIC) {
        return Err(err(FormatError::BadMagic));
    }
    if u32_at(bytes, 4) != Some(2) {
        return Err(err(FormatError::GltfVersion {
            found: u32_at(bytes, 4),
        }));
    }
    if u32_at(bytes, 8).map(|l| l as usize) != Some(bytes.len()) {
        return Err(err(FormatError::Length {
            header: u32_at(bytes, 8),
            bytes: bytes.len(),
        }));
    }
    let (mut json, mut bin): (Option<&[u8]>, Option<&[u8]>) = (None, None);
    let mut at = 12usize;
    while at < bytes.len() {
        let chunk = || err(FormatError::Chunk { at });
        let len = u32_at(bytes, at).ok_or_else(chunk)? as usize;
        let kind = u32_at(bytes, at + 4).ok_or_else(chunk)?;
        let body = bytes.get(at + 8..at + 8 + len).ok_or_else(chunk)?;
        match kind {
            CHUNK_JSON if json.is_none() => json = Some(body),
            CHUNK_BIN if bin.is_none() => bin = Some(body),
            _ => {}
        }
        at += 8 + len;
    }
    let doc: Value = serde_json::from_slice(json.ok_or_else(|| missing(GltfPart::JsonChunk))?)
        .map_err(|x| err(FormatError::GltfJson(x.into())))?;
    let bin = bin.unwrap_or(&[]);
    let prim = &doc["meshes"][0]["primitives"][0];
    let accessor = |idx: &Value, comps: usize| -> Result<Vec<f32>> {
        let accessor = idx.as_u64().ok_or_else(|| missing(GltfPart::Accessor))? as usize;
        let a = &doc["accessors"][accessor];
        let count = a["count"]
            .as_u64()
            .ok_or_else(|| missing(GltfPart::AccessorCount))? as usize;
        let ctype = a["componentType"].as_u64().unwrap_or(0);
        let view = &doc["bufferViews"][a["bufferView"]
            .as_u64()
            .ok_or_else(|| missing(GltfPart::AccessorView))?
            as usize];
        let past = || {
            err(FormatError::AccessorRange {
                accessor,
                bytes: bin.len(),
            })
        };
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let size = match ctype {
            5126 | 5125 => 4,
            5123 => 2,
            5121 => 1,
            _ => {
                return Err(err(FormatError::ComponentType {
                    accessor,
                    component_type: ctype,
                }));
            }
        };
        let stride = view["byteStride"]
            .as_u64()
            .map_or(size * comps, |s| s as usize);
        let n = count.checked_mul(comps).ok_or_else(past)?;
        if n > bin.len() {
            return Err(past());
        }
        let mut out = Vec::with_capacity(n);
        for i in 0..count {
            for c in 0..comps {
                let o = start + i * stride + c * size;
                let raw = bin.get(o..o + size).ok_or_else(past)?;
                out.push(match ctype {
                    5126 => f32::from_le_bytes(raw.try_into().unwrap_or_default()),
                    5125 => u32::from_le_bytes(raw.try_into().unwrap_or_default()) as f32,
                    5123 => f32::from(u16::from_le_bytes(raw.try_into().unwrap_or_default())),
                    _ => f32::from(raw[0]),
                });
            }
        }
        Ok(out)
    };
    let pos = accessor(&prim["attributes"]["POSITION"], 3)?;
    let nv = pos.len() / 3;
    let nrm = match prim["attributes"].get("NORMAL") {
        Some(i) => accessor(i, 3)?,
        None => vec![0.0; nv * 3],
    };
    let uvs = match prim["attributes"].get("TEXCOORD_0") {
        Some(i) => accessor(i, 2)?,
        None => vec![0.0; nv * 2],
    };
    if nrm.len() != nv * 3 || uvs.len() != nv * 2 {
        return Err(err(FormatError::AttributeCounts {
            positions: nv,
            normals: nrm.len() / 3,
            uvs: uvs.len() / 2,
        }));
    }
    let mut mesh = WeldedMesh::default();
    for i in 0..nv {
        mesh.vertices.push(MeshVertex {
            position: [pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]],
            normal: [nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]],
            uv: [uvs[2 * i], uvs[2 * i + 1]],
        });
    }
    // Indices: read as exact integers (f32 above is exact only below 2^24).
    let indices = prim["indices"]
        .as_u64()
        .ok_or_else(|| missing(GltfPart::Indices))? as usize;
    let ia = &doc["accessors"][indices];
    let count = ia["count"].as_u64().unwrap_or(0) as usize;
    let view = &doc["bufferViews"][ia["bufferView"].as_u64().unwrap_or(u64::MAX) as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + ia["byteOffset"].as_u64().unwrap_or(0) as usize;
    let size = match ia["componentType"].as_u64() {
        Some(5125) => 4,
        Some(5123) => 2,
        Some(5121) => 1,
        _ => {
            return Err(err(FormatError::ComponentType {
                accessor: indices,
                component_type: ia["componentType"].as_u64().unwrap_or(0),
            }));
        }
    };
    if !count.is_multiple_of(3) || count.saturating_mul(size) > bin.len() {
        return Err(err(FormatError::IndexCount { count }));
    }
    let mut idx = Vec::with_capacity(count);
    for i in 0..count {
        let raw = bin
            .get(start + i * size..start + (i + 1) * size)
            .ok_or_else(|| {
                err(FormatError::AccessorRange {
                    accessor: indices,
                    bytes: bin.len(),
                })
            })?;
        let v = match size {
            4 => u32::from_le_bytes(raw.try_into().unwrap_or_default()),
            2 => u32::from(u16::from_le_bytes(raw.try_into().unwrap_or_default())),
            _ => u32::from(raw[0]),
        };
        if v as usize >= nv {
            return Err(err(FormatError::VertexIndex {
                index: v,
                vertices: nv,
            }));
        }
        idx.push(v);
    }
    mesh.triangles = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn tri() -> WeldedMesh {
        let v = |x: f32, y: f32| MeshVertex {
            position: [x, y, 0.5],
            normal: [0.0, 0.0, 1.0],
            uv: [x, y],
        };
        WeldedMesh {
            vertices: vec![v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)],
            triangles: vec![[0, 1, 2]],
        }
    }

    #[test]
    fn round_trip_and_alignment() {
        let bytes = write(&tri()).unwrap();
        assert_eq!(bytes.len() % 4, 0);
        assert_eq!(read(&bytes).unwrap(), tri());
    }

    /// Regression (issue 15): a NaN vertex was written into the binary chunk and the
    /// accessor bounds (`min` / `max`, JSON `null`).
    #[test]
    fn nan_vertex_is_refused_not_written() {
        for (k, what) in [
            crate::error::WrittenValue::Position,
            crate::error::WrittenValue::Normal,
            crate::error::WrittenValue::TexCoord,
        ]
        .into_iter()
        .enumerate()
        {
            let mut mesh = tri();
            let v = &mut mesh.vertices[k];
            match k {
                0 => v.position[1] = f32::NAN,
                1 => v.normal[0] = f32::INFINITY,
                _ => v.uv[1] = f32::NAN,
            }
            assert_eq!(
                write(&mesh).unwrap_err(),
                err(FormatError::NonFinite { what, index: k })
            );
        }
    }

    #[test]
    fn errors_are_typed() {
        let mut bytes = write(&tri()).unwrap();
        assert_eq!(read(&bytes[..3]).unwrap_err(), err(FormatError::BadMagic));
        bytes[4] = 1;
        assert_eq!(
            read(&bytes).unwrap_err(),
            err(FormatError::GltfVersion { found: Some(1) })
        );
    }

    proptest! {
        #[test]
        fn damaged_files_never_panic(cut in 0usize..400, flip in 0usize..400, val in any::<u8>()) {
            let mut bytes = write(&tri()).unwrap();
            if flip < bytes.len() { bytes[flip] = val; }
            bytes.truncate(cut.max(1));
            let _ = read(&bytes);
        }
    }
}
