//! The recorded solid carve (`tests/data/sessions/carve-solid.poselog`, made by
//! `make-sessions`; issue 35 item 3) through the `replay` binary: the header's plate
//! joins the base, the session selects it and cuts two slots through it. Outputs are
//! byte-identical, the metrics meet expectations (`--check`), and the solid's mesh,
//! exported as OBJ, STL and GLB and read back, is watertight and manifold after each
//! stroke, its Euler characteristic dropping by 2 per slot (a hole each).

mod common;

use std::path::PathBuf;

use sculpt_core::formats::MeshFormat;
use sculpt_core::mesh::WeldedMesh;
use sculpt_core::sculpt::document::Document;
use sculpt_core::solid::{SolidTarget, euler_characteristic};

fn session() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions/carve-solid.poselog")
}

/// Closed, edge-manifold and consistently oriented (the mesh module's edge count, not
/// the solid mesher's), with its Euler characteristic.
fn watertight_euler(mesh: &WeldedMesh, what: &str) -> i64 {
    let r = mesh.edge_report();
    assert!(r.is_watertight(), "{what}: {r:?}");
    euler_characteristic(mesh)
}

/// `mesh` with vertices at bit-identical positions merged (STL stores a triangle soup).
fn exact_weld(mesh: &WeldedMesh) -> WeldedMesh {
    let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut out = WeldedMesh::default();
    let map: Vec<u32> = mesh
        .vertices
        .iter()
        .map(|v| {
            *index
                .entry(v.position.map(f32::to_bits))
                .or_insert_with(|| {
                    out.vertices.push(*v);
                    (out.vertices.len() - 1) as u32
                })
        })
        .collect();
    out.triangles = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| map[v as usize]))
        .collect();
    out
}

#[test]
fn the_solid_session_replays_byte_identically_and_cuts_through() {
    let tmp = tempfile::tempdir().unwrap();
    let a = common::replay_twice_identically(
        &session(),
        tmp.path(),
        r#"{"gestures": {"strokes_applied": 2, "strokes_rejected": 0, "too_short": 0},
            "operations": 2, "targets": 1, "strokes": 0,
            "solids": {"targets": 1, "strokes": 2, "euler": [-2]}}"#,
    );
    // The saved document holds the plate and its two strokes; the exported mesh holds
    // the sheet's triangles and the plate's.
    let doc = Document::from_json(&std::fs::read(a.join("scene.json")).unwrap()).unwrap();
    let plate = &doc.solids()[0];
    assert_eq!(plate.solid.cuts().len(), 2);
    let carved = plate.solid.mesh();
    let stl = MeshFormat::Stl
        .read(&std::fs::read(a.join("scene.stl")).unwrap())
        .unwrap();
    assert!(stl.triangles.len() > carved.triangles.len());
    // After each stroke: rebuild the plate with the strokes so far and export it.
    let mut solid = SolidTarget::new(plate.solid.text(), plate.solid.cells()).unwrap();
    for k in 0..=2 {
        if k > 0 {
            let cut = &plate.solid.cuts()[k - 1];
            solid.cut(cut.id, &cut.input).unwrap();
        }
        let mesh = solid.mesh();
        for format in [MeshFormat::Obj, MeshFormat::Stl, MeshFormat::Glb] {
            let back = exact_weld(&format.read(&format.write(&mesh).unwrap()).unwrap());
            let what = format!("after {k} strokes, {format:?}");
            assert_eq!(back.triangles.len(), mesh.triangles.len(), "{what}");
            assert_eq!(
                watertight_euler(&back, &what),
                2 - 2 * k as i64,
                "{what}: one hole per slot"
            );
        }
    }
    assert_eq!(
        solid.mesh().triangles,
        carved.triangles,
        "rebuilt as replayed"
    );
    // The operator log marks the selection of the plate (id 2) and both strokes.
    let log = std::fs::read_to_string(a.join("operator.log")).unwrap();
    assert!(log.contains("select-target 2"));
    assert_eq!(log.matches("stroke_end").count(), 2);
}
