//! Solid targets carved through (`sculpt_core::solid`, issue 35 item 3): the meshes are
//! closed, manifold and outward after every stroke (checked by a half-edge walk written
//! here, independent of the mesher), a groove deeper than the wall opens a hole (the
//! Euler characteristic drops by 2), local re-meshing equals meshing the whole grid,
//! and a stroke on a solid is one step of the document: undo, redo, save and load.

use std::collections::HashMap;

use glam::DVec3;
use sculpt_core::editor::{self, Applied};
use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample};
use sculpt_core::mesh::WeldedMesh;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
use sculpt_core::solid::{SolidError, SolidTarget, euler_characteristic};

/// A 0.6 m x 0.6 m plate 2 cm thick, its top face at z = 0.01.
const PLATE: &str =
    r#"{"version": 1, "solid": {"box": {"min": [-0.3, -0.3, -0.01], "max": [0.3, 0.3, 0.01]}}}"#;
/// A sphere of radius 0.25 at the origin, as a `.vm` model (negative inside).
const SPHERE_VM: &str = "x var-x\ny var-y\nz var-z\nxx square x\nyy square y\nzz square z\ns add xx yy\nt add s zz\nr sqrt t\nc const 0.25\nout sub r c\n";

fn tool(profile: Profile, depth: f64, mode: Mode) -> Tool {
    Tool {
        profile,
        width: 0.06,
        depth,
        mode,
        taper: 0.0,
    }
}

/// Samples along x at height `z`, from `x0` to `x1`.
fn line(x0: f64, x1: f64, y: f64, z: f64) -> Vec<(f64, DVec3)> {
    (0..=20)
        .map(|i| {
            let s = i as f64 / 20.0;
            (s, DVec3::new(x0 + (x1 - x0) * s, y, z))
        })
        .collect()
}

/// The half-edge walk: every directed edge has exactly one opposite (closed,
/// edge-manifold, consistently oriented), every vertex's triangles form one fan
/// (vertex-manifold), no triangle is degenerate in index; returns the enclosed volume
/// (positive when wound outward).
fn check_closed_manifold(mesh: &WeldedMesh) -> f64 {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        assert!(
            tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2],
            "degenerate triangle {t}"
        );
        for k in 0..3 {
            let e = (tri[k], tri[(k + 1) % 3]);
            assert!(
                directed.insert(e, t).is_none(),
                "directed edge {e:?} used twice (non-manifold or flipped)"
            );
        }
    }
    for &(a, b) in directed.keys() {
        assert!(
            directed.contains_key(&(b, a)),
            "edge ({a}, {b}) has no opposite: a crack"
        );
    }
    // Vertex-manifold: following next-around-vertex from one triangle visits all of its triangles.
    let mut around: HashMap<u32, Vec<usize>> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for &v in tri {
            around.entry(v).or_default().push(t);
        }
    }
    for (&v, tris) in &around {
        let start = tris[0];
        let mut t = start;
        let mut seen = 0;
        loop {
            let tri = mesh.triangles[t];
            let k = tri.iter().position(|&x| x == v).unwrap();
            // The edge leaving v in this triangle; its opposite's triangle is the next one.
            let out = (v, tri[(k + 1) % 3]);
            t = directed[&(out.1, out.0)];
            seen += 1;
            if t == start || seen > tris.len() {
                break;
            }
        }
        assert_eq!(
            seen,
            tris.len(),
            "vertex {v} is not manifold: its triangles form more than one fan"
        );
    }
    let p = |v: u32| DVec3::from(mesh.vertices[v as usize].position.map(f64::from));
    mesh.triangles
        .iter()
        .map(|t| p(t[0]).dot(p(t[1]).cross(p(t[2]))) / 6.0)
        .sum()
}

#[test]
fn a_plate_meshes_closed_with_its_volume() {
    let solid = SolidTarget::new(PLATE, 64).unwrap();
    let mesh = solid.mesh();
    let volume = check_closed_manifold(&mesh);
    assert_eq!(euler_characteristic(&mesh), 2);
    // 0.6 x 0.6 x 0.02 = 0.0072 m^3, within the cells' error on the thin side.
    assert!((volume - 0.0072).abs() < 0.0072 * 0.25, "volume {volume}");
}

/// A V groove 5 cm deep through a 2 cm wall opens a hole: genus 0 -> 1.
#[test]
fn a_groove_deeper_than_the_wall_cuts_through() {
    let mut solid = SolidTarget::new(PLATE, 64).unwrap();
    let before = check_closed_manifold(&solid.mesh());
    let input = StrokeInput {
        samples: line(-0.1, 0.1, 0.0, 0.012),
        tool: tool(Profile::V, 0.05, Mode::Carve),
    };
    let r = solid.cut(2, &input).unwrap();
    assert!(
        r.blocks > 0 && r.blocks < solid.block_meshes().1.len(),
        "{r:?}"
    );
    let mesh = solid.mesh();
    let after = check_closed_manifold(&mesh);
    assert_eq!(euler_characteristic(&mesh), 0, "a hole: one handle");
    assert!(after < before, "{after} < {before}");
    // The field is negative (outside) on the line through the plate under the stroke.
    assert!(solid.eval(DVec3::new(0.0, 0.0, 0.0)) <= 0.0);
    assert!(solid.eval(DVec3::new(0.0, 0.2, 0.0)) > 0.0);
}

/// A shallow groove (U, 5 mm in a 2 cm wall) removes material but opens nothing.
#[test]
fn a_shallow_groove_keeps_the_plate_whole() {
    let mut solid = SolidTarget::new(PLATE, 64).unwrap();
    let before = check_closed_manifold(&solid.mesh());
    let input = StrokeInput {
        samples: line(-0.2, 0.2, 0.05, 0.01),
        tool: tool(Profile::U, 0.005, Mode::Carve),
    };
    solid.cut(2, &input).unwrap();
    let mesh = solid.mesh();
    let after = check_closed_manifold(&mesh);
    assert_eq!(euler_characteristic(&mesh), 2);
    assert!(after < before);
    assert!(
        solid.eval(DVec3::new(0.0, 0.05, 0.0)) > 0.0,
        "the groove stops above the middle"
    );
}

/// An emboss adds a ridge: more volume, still one closed sphere.
#[test]
fn an_emboss_adds_material() {
    let mut solid = SolidTarget::new(SPHERE_VM, 48).unwrap();
    let before = check_closed_manifold(&solid.mesh());
    let input = StrokeInput {
        samples: (0..=20)
            .map(|i| {
                let a = -0.6 + 1.2 * i as f64 / 20.0;
                (i as f64, DVec3::new(0.25 * a.sin(), 0.0, 0.25 * a.cos()))
            })
            .collect(),
        tool: tool(Profile::U, 0.02, Mode::Emboss),
    };
    solid.cut(9, &input).unwrap();
    let mesh = solid.mesh();
    let after = check_closed_manifold(&mesh);
    assert_eq!(euler_characteristic(&mesh), 2);
    assert!(after > before, "{after} > {before}");
    assert!(
        solid.eval(DVec3::new(0.0, 0.0, 0.26)) > 0.0,
        "the ridge stands above the sphere"
    );
}

/// Re-meshing only the blocks a stroke reaches gives the same mesh as re-meshing all.
#[test]
fn local_remeshing_equals_whole_remeshing() {
    let mut solid = SolidTarget::new(PLATE, 64).unwrap();
    for (k, y) in [-0.1, 0.0, 0.1].into_iter().enumerate() {
        let input = StrokeInput {
            samples: line(-0.25, 0.2, y, 0.01),
            tool: tool(Profile::V, 0.015, Mode::Carve),
        };
        solid.cut(k as u64 + 2, &input).unwrap();
    }
    let local = solid.mesh();
    let mut whole = solid.clone();
    whole.remesh_all();
    let again = whole.mesh();
    assert_eq!(local.vertices.len(), again.vertices.len());
    assert_eq!(local.triangles, again.triangles);
    check_closed_manifold(&local);
}

#[test]
fn a_stroke_off_the_surface_is_refused() {
    let mut solid = SolidTarget::new(PLATE, 64).unwrap();
    let input = StrokeInput {
        samples: line(-0.1, 0.1, 0.0, 0.5),
        tool: tool(Profile::V, 0.01, Mode::Carve),
    };
    assert!(matches!(
        solid.cut(2, &input),
        Err(SolidError::OffSurface { index: 0, .. })
    ));
    assert!(solid.cuts().is_empty());
    assert!(matches!(
        SolidTarget::new("out const 1\n", 32),
        Err(SolidError::Empty { .. })
    ));
    assert!(matches!(
        SolidTarget::new("nonsense", 32),
        Err(SolidError::Model(_))
    ));
    assert!(matches!(
        SolidTarget::new(PLATE, 4),
        Err(SolidError::Cells { .. })
    ));
}

/// Through the editor: the stroke edit that names a solid carves it, as one step.
#[test]
fn a_stroke_on_a_solid_is_one_undoable_step_and_is_saved() {
    let mut doc = Document::new();
    let id = doc.add_solid("plate", PLATE, 48).unwrap();
    doc.seal_history();
    let original = doc.solid_mesh(id).unwrap();
    let samples = line(-0.1, 0.1, 0.0, 0.01)
        .into_iter()
        .map(|(t, position)| StrokeSample { t, position })
        .collect();
    let edit = Edit::Stroke(StrokeEdit::new(
        id,
        tool(Profile::V, 0.05, Mode::Carve),
        samples,
    ));
    let Applied::Stroke { target, .. } = editor::apply(&mut doc, &edit) else {
        panic!("not applied")
    };
    assert_eq!(target, id);
    let carved = doc.solid_mesh(id).unwrap();
    assert_eq!(euler_characteristic(&carved), 0);
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
    assert_eq!(doc.solid_mesh(id).unwrap().triangles, original.triangles);
    assert_eq!(
        editor::apply(&mut doc, &Edit::Undo),
        Applied::Unchanged,
        "the base stays"
    );
    assert_eq!(editor::apply(&mut doc, &Edit::Redo), Applied::Redone);
    assert_eq!(doc.solid_mesh(id).unwrap().triangles, carved.triangles);
    let loaded = Document::from_json(&doc.to_json()).unwrap();
    assert_eq!(loaded.solids(), doc.solids());
    assert_eq!(loaded.solid_mesh(id).unwrap().triangles, carved.triangles);
    assert_eq!(loaded.to_json(), doc.to_json());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

    /// The document reader's `solids` section: any model text, any cell count and any
    /// samples give a document or a clear error, never a panic.
    #[test]
    fn document_solids_section_never_panics(
        model in "\\PC{0,40}",
        cells in 0usize..40,
        sample in proptest::array::uniform4(-1.0f64..1.0),
        cut in 0usize..200,
    ) {
        let good = serde_json::json!({
            "format": "wandsculpt-document", "version": 1, "targets": [], "strokes": [],
            "solids": [{"id": 1, "name": "p", "model": PLATE, "cells": 16, "strokes": [
                {"id": 2, "tool": {"profile": "v", "width": 0.06, "depth": 0.05, "mode": "carve"},
                 "samples": [[0.0, -0.1, 0.0, 0.01], sample]}]}]
        });
        let _ = Document::from_json(good.to_string().as_bytes());
        let mut bad = good.clone();
        bad["solids"][0]["model"] = serde_json::Value::String(model);
        bad["solids"][0]["cells"] = serde_json::json!(cells);
        let _ = Document::from_json(bad.to_string().as_bytes());
        let text = good.to_string();
        let cut = cut.min(text.len());
        let _ = Document::from_json(&text.as_bytes()[..cut]);
    }
}

/// The desktop pointer's ray hit on a solid (`SolidTarget::cast`, through
/// `sculpt::ray::cast_document`): on the plate's top face from above, with the outward
/// normal; through the slot a groove cut, it meets nothing (the hole is open); a ray
/// that misses the plate misses.
#[test]
fn a_ray_meets_the_plate_and_passes_through_its_slot() {
    use sculpt_core::sculpt::ray::{Ray, cast_document};
    let mut doc = Document::new();
    let id = doc.add_solid("plate", PLATE, 64).unwrap();
    let down = |x: f64, y: f64| Ray::new(DVec3::new(x, y, 0.5), DVec3::NEG_Z).unwrap();
    let hit = cast_document(&doc, &down(0.1, 0.05)).expect("the top face");
    assert_eq!(hit.target, id);
    // The field is exact, not the mesh: the top face at z = 0.01.
    sculpt_core::assert_near!(hit.hit.point.z, 0.01, sculpt_core::tolerance::RAY_HIT_TOL);
    sculpt_core::assert_near!(hit.hit.t, 0.49, sculpt_core::tolerance::RAY_HIT_TOL);
    assert!(hit.hit.normal.z > 0.99, "{:?}", hit.hit.normal);
    assert!(
        cast_document(&doc, &down(0.4, 0.0)).is_none(),
        "beside the plate"
    );
    let input = StrokeInput {
        samples: line(-0.1, 0.1, 0.0, 0.01),
        tool: tool(Profile::V, 0.05, Mode::Carve),
    };
    doc.apply_solid_stroke(id, input).unwrap();
    assert!(
        cast_document(&doc, &down(0.0, 0.0)).is_none(),
        "through the slot"
    );
    assert!(
        cast_document(&doc, &down(0.0, 0.1)).is_some(),
        "beside the slot"
    );
}

/// A hollow sphere (radius 0.25, 2 cm wall) as the bench carves it.
const SHELL: &str = r#"{"version": 1, "solid": {"and": {"system": "min_max", "solids": [
  {"sphere": {"center": [0, 0, 0], "radius": 0.25}},
  {"not": {"solid": {"sphere": {"center": [0, 0, 0], "radius": 0.23}}}}]}}}"#;

/// Samples on the sphere of radius 0.25 over the arc of polar angle `a0..a1` at azimuth
/// `phi`.
fn arc(a0: f64, a1: f64, phi: f64) -> Vec<(f64, DVec3)> {
    (0..=30)
        .map(|i| {
            let a = a0 + (a1 - a0) * i as f64 / 30.0;
            let p = DVec3::new(a.sin() * phi.cos(), a.sin() * phi.sin(), a.cos()) * 0.25;
            (i as f64, p)
        })
        .collect()
}

/// Equal values (NaN equal to NaN; the sign of a zero does not count).
fn same_values(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
}

/// The solid's meshes and kept values against the plain evaluation of every corner
/// against every segment (`remesh_reference`, `reference_values`); returns how many
/// blocks kept values were compared.
fn check_against_reference(solid: &SolidTarget, what: &str) -> usize {
    let mut plain = solid.clone();
    plain.remesh_reference();
    let (_, fast) = solid.block_meshes();
    let (_, slow) = plain.block_meshes();
    for (b, (f, s)) in fast.iter().zip(slow).enumerate() {
        assert!(
            f == s,
            "{what}: block {b}'s mesh differs from the plain one"
        );
    }
    let mut compared = 0;
    for b in 0..fast.len() {
        if let Some(kept) = solid.block_values(b) {
            let plain = solid.reference_values(b).expect("not decided");
            assert!(same_values(kept, &plain), "{what}: block {b}'s values");
            compared += 1;
        }
    }
    check_closed_manifold(&solid.mesh());
    compared
}

/// The fast stroke path (kept corner values, the tool bounded per sub-box and corner,
/// only changed blocks re-meshed) gives the same values and the same mesh as evaluating
/// every corner against every segment, after every stroke, undo and redo: carves of
/// both profiles crossing each other and cutting through the wall, a tapered one, an
/// emboss over a carve, on the hollow sphere; and the mesh stays closed and manifold.
/// Regression guard for the distance bound of `SweptTool::apply` (a bound too tight
/// skips corners the tool changes, and the values differ here).
#[test]
fn the_fast_stroke_path_equals_the_plain_evaluation() {
    let mut solid = SolidTarget::new(SHELL, 64).unwrap();
    let strokes = [
        (arc(-0.5, 0.5, 0.0), tool(Profile::V, 0.03, Mode::Carve)),
        (arc(-0.4, 0.6, 1.2), tool(Profile::U, 0.01, Mode::Carve)),
        (
            arc(0.1, 0.7, 0.4),
            Tool {
                taper: 0.05,
                ..tool(Profile::V, 0.04, Mode::Carve)
            },
        ),
        (arc(-0.3, 0.3, 2.0), tool(Profile::U, 0.015, Mode::Emboss)),
        (arc(-0.2, 0.2, 0.1), tool(Profile::V, 0.05, Mode::Carve)),
    ];
    let mut compared = 0;
    for (k, (samples, tool)) in strokes.into_iter().enumerate() {
        let r = solid
            .cut(k as u64 + 2, &StrokeInput { samples, tool })
            .unwrap();
        assert!(r.blocks > 0 && r.blocks <= r.reached, "{r:?}");
        compared += check_against_reference(&solid, &format!("stroke {k}"));
    }
    assert!(compared > 0, "no kept values were compared");
    let last = solid.uncut().unwrap();
    check_against_reference(&solid, "undone");
    solid.recut(last);
    check_against_reference(&solid, "redone");
    // The grooves through the wall open holes: fewer than a sphere's 2.
    assert!(euler_characteristic(&solid.mesh()) < 2);
}

/// The live groove (`SolidTarget::preview`, through `DocumentView::set_preview` as the
/// display server shows it): while a stroke grows sample by sample on a solid that
/// already has a stroke, the preview's blocks are the meshes the applied stroke gives
/// them, every other block's mesh is unchanged by the stroke, and the solid and the
/// document stay as they were; a stroke off the surface is refused and clears it.
#[test]
fn a_preview_shows_what_the_stroke_will_make() {
    use sculpt_core::sculpt::view::DocumentView;
    let mut doc = Document::new();
    let id = doc.add_solid("shell", SHELL, 48).unwrap();
    doc.apply_solid_stroke(
        id,
        StrokeInput {
            samples: arc(-0.5, 0.5, 0.0),
            tool: tool(Profile::V, 0.03, Mode::Carve),
        },
    )
    .unwrap();
    let json = doc.to_json();
    let mut view = DocumentView::new();
    let samples = arc(-0.3, 0.6, 0.8);
    for n in [3, 12, samples.len()] {
        let input = StrokeInput {
            samples: samples[..n].to_vec(),
            tool: tool(Profile::U, 0.02, Mode::Carve),
        };
        view.set_preview(&doc, id, &input).unwrap();
        let (target, preview) = view.solid_preview().expect("a solid preview");
        assert_eq!(target, id);
        let solid = &doc.solid(id).unwrap().solid;
        let mut applied = solid.clone();
        applied.cut(99, &input).unwrap();
        let (_, after) = applied.block_meshes();
        let (_, before) = solid.block_meshes();
        let shown: Vec<usize> = preview.blocks().map(|(b, _, _)| b).collect();
        assert!(!shown.is_empty(), "{n} samples: no block previewed");
        for (b, mesh, _) in preview.blocks() {
            assert!(
                *mesh == after[b],
                "{n} samples: block {b} differs from the stroke applied"
            );
        }
        for b in (0..before.len()).filter(|b| !shown.contains(b)) {
            assert!(
                before[b] == after[b],
                "{n} samples: block {b} changed but not previewed"
            );
        }
    }
    assert_eq!(doc.to_json(), json, "the document is unchanged");
    let off = StrokeInput {
        samples: line(-0.1, 0.1, 0.0, 0.6),
        tool: tool(Profile::V, 0.01, Mode::Carve),
    };
    assert!(view.set_preview(&doc, id, &off).is_err());
    assert!(view.solid_preview().is_none());
}
