//! Painted attributes through the document: one undoable edit per stroke, the
//! interaction's paint mode, the journal record, and the coloured exports (PLY, OBJ
//! `v x y z r g b`, GLB `COLOR_0`) each read back by a minimal reader written here,
//! independent of the writers.

use glam::{DQuat, DVec3};
use sculpt_core::assert_near;
use sculpt_core::editor::{
    self, Applied, DEFAULT_SURFACE_CENTER, default_document, default_surface_point,
};
use sculpt_core::formats::{glb, obj, ply};
use sculpt_core::interaction::{
    Command, DEFAULT_TARGET, Edit, Interaction, InteractionMode, Output, WandEvent, WandSample,
};
use sculpt_core::mesh::WeldedMesh;
use sculpt_core::oplog::EventKind;
use sculpt_core::paint::{Brush, COLOUR, PaintEdit};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::tolerance::{EXPORT_WELD_EPS, PAINT_VALUE_TOL};

const GREY: [f32; 3] = [0.6, 0.6, 0.6];
const RED: [f64; 3] = [0.9, 0.1, 0.1];
/// The brush radius: a broad brush, as the final mesh of the smooth sheet is coarse
/// (vertices some 5 cm apart).
const BRUSH: f64 = 0.08;

/// A paint stroke of `value` 5 mm above the default sheet along x at height `y`.
fn paint(attribute: &str, value: &[f64], y: f64) -> Edit {
    let c = DEFAULT_SURFACE_CENTER;
    Edit::Paint(PaintEdit {
        target: DEFAULT_TARGET,
        attribute: attribute.into(),
        value: value.to_vec(),
        radius: BRUSH,
        samples: (0..=30)
            .map(|i| default_surface_point(c.x - 0.3 + 0.02 * i as f64, y) + DVec3::Z * 0.005)
            .collect(),
    })
}

fn painted_document() -> Document {
    let mut doc = default_document();
    let applied = editor::apply(&mut doc, &paint(COLOUR, &RED, DEFAULT_SURFACE_CENTER.y));
    assert!(matches!(applied, Applied::Paint { .. }), "{applied:?}");
    doc
}

fn mesh(doc: &Document) -> WeldedMesh {
    doc.mesh(Detail::Final).welded(EXPORT_WELD_EPS)
}

/// Is vertex `p` on the painted stripe (well inside the brush), or well away from it?
fn on_stripe(p: [f32; 3]) -> Option<bool> {
    let c = DEFAULT_SURFACE_CENTER;
    let dy = (f64::from(p[1]) - c.y).abs();
    let inside_x = (f64::from(p[0]) - c.x).abs() < 0.25;
    if dy < 0.5 * BRUSH && inside_x {
        Some(true)
    } else if dy > 0.2 || (f64::from(p[0]) - c.x).abs() > 0.5 {
        Some(false)
    } else {
        None
    }
}

/// Checks colours read back from a file against the stripe: red on it, grey away.
fn check_stripe(positions: &[[f32; 3]], colours: &[[f32; 3]]) {
    assert_eq!(positions.len(), colours.len());
    let (mut on, mut off) = (0, 0);
    for (p, c) in positions.iter().zip(colours) {
        match on_stripe(*p) {
            Some(true) => {
                on += 1;
                let c64: Vec<f64> = c.iter().map(|&x| f64::from(x)).collect();
                assert_near!(c64, RED.to_vec(), 2.0 * PAINT_VALUE_TOL);
            }
            Some(false) => {
                off += 1;
                let c64: Vec<f64> = c.iter().map(|&x| f64::from(x)).collect();
                let g: Vec<f64> = GREY.iter().map(|&x| f64::from(x)).collect();
                assert_near!(c64, g, PAINT_VALUE_TOL);
            }
            None => {}
        }
    }
    assert!(
        on > 3 && off > 3,
        "{on} vertices on the stripe, {off} off it"
    );
}

#[test]
fn a_paint_stroke_is_one_undoable_step() {
    let mut doc = painted_document();
    let field = doc.attribute_field(DEFAULT_TARGET, COLOUR).unwrap().clone();
    assert!(field.sample_count() > 30);
    assert_eq!(
        doc.attribute_names(DEFAULT_TARGET),
        vec![COLOUR.to_string()]
    );
    assert!(doc.can_undo());
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
    assert!(doc.attribute_field(DEFAULT_TARGET, COLOUR).is_none());
    assert!(!doc.can_undo(), "the paint was the only step");
    assert_eq!(editor::apply(&mut doc, &Edit::Redo), Applied::Redone);
    assert_eq!(doc.attribute_field(DEFAULT_TARGET, COLOUR), Some(&field));
    // A second stroke, then undo: the first stroke's field is back.
    let second = paint(COLOUR, &[0.0, 0.0, 1.0], DEFAULT_SURFACE_CENTER.y);
    assert!(matches!(
        editor::apply(&mut doc, &second),
        Applied::Paint { .. }
    ));
    assert_ne!(doc.attribute_field(DEFAULT_TARGET, COLOUR), Some(&field));
    editor::apply(&mut doc, &Edit::Undo);
    assert_eq!(doc.attribute_field(DEFAULT_TARGET, COLOUR), Some(&field));
}

#[test]
fn the_operator_log_names_a_paint_stroke() {
    let mut doc = default_document();
    let applied = editor::apply(&mut doc, &paint(COLOUR, &RED, DEFAULT_SURFACE_CENTER.y));
    let Some(EventKind::Marker { label }) = editor::oplog_applied(&applied) else {
        panic!("no marker for {applied:?}");
    };
    assert!(
        label.starts_with("paint ") && label.contains("colour"),
        "{label}"
    );
}

#[test]
fn a_brush_that_reaches_no_target_is_refused_and_changes_nothing() {
    let mut doc = default_document();
    let Edit::Paint(mut far) = paint(COLOUR, &RED, DEFAULT_SURFACE_CENTER.y) else {
        unreachable!()
    };
    for p in &mut far.samples {
        *p += DVec3::Z * 0.5;
    }
    let applied = editor::apply(&mut doc, &Edit::Paint(far));
    assert!(matches!(applied, Applied::Rejected(_)), "{applied:?}");
    assert!(doc.paints().is_empty() && !doc.can_undo());
}

#[test]
fn the_journal_record_round_trips() {
    let edit = paint("density", &[250.0], 1.2);
    let text = serde_json::to_string(&edit).unwrap();
    assert!(text.starts_with(r#"{"edit":"paint","target":"#), "{text}");
    let back: Edit = serde_json::from_str(&text).unwrap();
    assert_eq!(back, edit);
    // Replayed on a fresh document, it gives the same field.
    let (mut a, mut b) = (default_document(), default_document());
    editor::apply(&mut a, &edit);
    editor::apply(&mut b, &back);
    assert_eq!(
        a.attribute_field(DEFAULT_TARGET, "density"),
        b.attribute_field(DEFAULT_TARGET, "density")
    );
}

#[test]
fn a_named_scalar_is_shown_as_a_heat_map() {
    let mut doc = painted_document();
    let c = DEFAULT_SURFACE_CENTER;
    for (value, dy) in [(100.0, -0.2), (500.0, 0.2)] {
        let applied = editor::apply(&mut doc, &paint("density", &[value], c.y + dy));
        assert!(matches!(applied, Applied::Paint { .. }), "{applied:?}");
    }
    assert_eq!(
        doc.attribute_names(DEFAULT_TARGET),
        vec![COLOUR.to_string(), "density".to_string()]
    );
    let m = mesh(&doc);
    assert!(doc.heat_colours(&m, "hardness", GREY).is_none());
    let heat = doc.heat_colours(&m, "density", GREY).unwrap();
    let (mut low, mut high) = (0, 0);
    for (v, h) in m.vertices.iter().zip(&heat) {
        let dy = f64::from(v.position[1]) - c.y;
        if (f64::from(v.position[0]) - c.x).abs() > 0.25 {
            continue;
        }
        if (dy + 0.2).abs() < 0.5 * BRUSH {
            // The least painted value: blue.
            assert!(h[2] > 0.8 && h[0] < 0.2, "{h:?} at {:?}", v.position);
            low += 1;
        } else if (dy - 0.2).abs() < 0.5 * BRUSH {
            // The greatest: red.
            assert!(h[0] > 0.8 && h[2] < 0.2, "{h:?} at {:?}", v.position);
            high += 1;
        }
    }
    assert!(low > 3 && high > 3, "{low} low, {high} high");
}

fn tracked(t: f64, p: DVec3, buttons: u32) -> WandEvent {
    WandEvent::sample(t, WandSample::tracked(p, DQuat::IDENTITY, buttons))
}

/// Paint mode: the paint button (7) turns it on, a sweep with the action button is
/// one paint edit with the brush, the button turns it off again; a bad brush is refused.
#[test]
fn a_sweep_in_paint_mode_is_one_paint_edit() {
    let mut m = Interaction::default();
    let mut out = Vec::new();
    let p0 = default_surface_point(0.0, 1.17) + DVec3::Z * 0.005;
    m.handle(&tracked(0.0, p0, 0), &mut out).unwrap();
    m.handle(&tracked(0.05, p0, 1 << 7), &mut out).unwrap();
    m.handle(&tracked(0.1, p0, 0), &mut out).unwrap();
    assert_eq!(m.mode(), InteractionMode::Paint);
    assert_eq!(m.mode().name(), "paint");
    let bad = Brush {
        value: vec![2.0, 0.0, 0.0],
        ..Brush::default()
    };
    assert!(
        m.handle(
            &WandEvent::command(0.1, Command::SetBrush { brush: bad }),
            &mut out
        )
        .is_err()
    );
    let density = Brush {
        attribute: "density".into(),
        value: vec![3.5],
        radius: 0.02,
    };
    m.handle(
        &WandEvent::command(
            0.1,
            Command::SetBrush {
                brush: density.clone(),
            },
        ),
        &mut out,
    )
    .unwrap();
    for k in 0..=10 {
        let p = p0 + DVec3::X * 0.01 * k as f64;
        m.handle(&tracked(0.2 + 0.01 * k as f64, p, 1), &mut out)
            .unwrap();
        // Nothing is previewed as a carve while painting.
        assert!(m.live_stroke().is_none());
    }
    m.handle(&tracked(0.4, p0 + DVec3::X * 0.1, 0), &mut out)
        .unwrap();
    let edits: Vec<&Edit> = out
        .iter()
        .filter_map(|o| match o {
            Output::Edit(e) => Some(e),
            _ => None,
        })
        .collect();
    let [Edit::Paint(p)] = edits.as_slice() else {
        panic!("one paint edit: {edits:?}");
    };
    assert_eq!(p.attribute, "density");
    assert_eq!(p.value, vec![3.5]);
    // The sample the button went down at, then the sweep's eleven.
    assert_eq!(p.samples.len(), 12);
    assert_eq!(p.target, DEFAULT_TARGET);
    // The paint button again: back to carving.
    m.handle(&tracked(0.5, p0, 1 << 7), &mut out).unwrap();
    assert_eq!(m.mode(), InteractionMode::CARVE);
}

// ---- Independent readers: the least of each format, written from its spec. ----

/// An ASCII PLY's vertex positions and colours (`red green blue` as uchar).
fn read_ply(bytes: &[u8]) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, usize) {
    let text = std::str::from_utf8(bytes).unwrap();
    let (header, body) = text.split_once("end_header\n").unwrap();
    let mut lines = header.lines();
    assert_eq!(lines.next(), Some("ply"));
    assert_eq!(lines.next(), Some("format ascii 1.0"));
    let (mut nv, mut nf, mut props) = (0, 0, Vec::new());
    let mut element = "";
    for l in lines {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.as_slice() {
            ["element", "vertex", n] => (element, nv) = ("vertex", n.parse().unwrap()),
            ["element", "face", n] => (element, nf) = ("face", n.parse().unwrap()),
            ["property", _, name] if element == "vertex" => props.push(name.to_string()),
            _ => {}
        }
    }
    let col = |name: &str| props.iter().position(|p| p == name).unwrap();
    let (x, r) = (col("x"), col("red"));
    let mut rows = body.lines();
    let (mut pos, mut colours) = (Vec::new(), Vec::new());
    for _ in 0..nv {
        let v: Vec<f32> = rows
            .next()
            .unwrap()
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(v.len(), props.len());
        pos.push([v[x], v[x + 1], v[x + 2]]);
        colours.push([v[r] / 255.0, v[r + 1] / 255.0, v[r + 2] / 255.0]);
    }
    let faces = rows.filter(|l| l.starts_with("3 ")).count();
    assert_eq!(faces, nf);
    (pos, colours, nf)
}

/// An OBJ's `v x y z r g b` lines.
fn read_obj_colours(bytes: &[u8]) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let text = std::str::from_utf8(bytes).unwrap();
    let (mut pos, mut colours) = (Vec::new(), Vec::new());
    for l in text.lines().filter(|l| l.starts_with("v ")) {
        let v: Vec<f32> = l[2..]
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(v.len(), 6, "{l}");
        pos.push([v[0], v[1], v[2]]);
        colours.push([v[3], v[4], v[5]]);
    }
    (pos, colours)
}

/// A GLB's float `VEC3` accessor named by the first primitive's attribute `name`.
fn read_glb_vec3(bytes: &[u8], name: &str) -> Vec<[f32; 3]> {
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[0..4], b"glTF");
    let json_len = u32_at(12);
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[20 + json_len + 8..];
    let a = &json["accessors"][json["meshes"][0]["primitives"][0]["attributes"][name]
        .as_u64()
        .unwrap() as usize];
    assert_eq!(a["componentType"], 5126);
    assert_eq!(a["type"], "VEC3");
    let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap() as usize;
    (0..a["count"].as_u64().unwrap() as usize)
        .map(|i| {
            [0, 1, 2].map(|c| {
                let o = start + 12 * i + 4 * c;
                f32::from_le_bytes(bin[o..o + 4].try_into().unwrap())
            })
        })
        .collect()
}

#[test]
fn exports_carry_the_painted_colours() {
    let doc = painted_document();
    let m = mesh(&doc);
    let colours = doc.vertex_colours(&m, GREY).unwrap();
    assert!(default_document().vertex_colours(&m, GREY).is_none());

    let (pos, back, faces) = read_ply(&ply::write(&m, Some(&colours)).unwrap());
    assert_eq!(pos.len(), m.vertices.len());
    assert_eq!(faces, m.triangles.len());
    check_stripe(&pos, &back);

    let (pos, back) = read_obj_colours(&obj::write_coloured(&m, Some(&colours)).unwrap());
    check_stripe(&pos, &back);
    // The crate's own OBJ reader still reads the coloured file's geometry.
    assert_eq!(
        obj::read(&obj::write_coloured(&m, Some(&colours)).unwrap())
            .unwrap()
            .triangles
            .len(),
        m.triangles.len()
    );

    let bytes = glb::write_coloured(&m, Some(&colours)).unwrap();
    check_stripe(
        &read_glb_vec3(&bytes, "POSITION"),
        &read_glb_vec3(&bytes, "COLOR_0"),
    );
    assert_eq!(glb::read(&bytes).unwrap().vertices.len(), m.vertices.len());

    // One colour short: refused, nothing written.
    assert!(ply::write(&m, Some(&colours[1..])).is_err());
    assert!(glb::write_coloured(&m, Some(&colours[1..])).is_err());
}

#[test]
fn the_document_file_keeps_the_paint() {
    let mut doc = painted_document();
    let density = paint("density", &[250.0], DEFAULT_SURFACE_CENTER.y + 0.2);
    assert!(matches!(
        editor::apply(&mut doc, &density),
        Applied::Paint { .. }
    ));
    let json = doc.to_json();
    let loaded = Document::from_json(&json).unwrap();
    for attribute in [COLOUR, "density"] {
        assert_eq!(
            loaded.attribute_field(DEFAULT_TARGET, attribute),
            doc.attribute_field(DEFAULT_TARGET, attribute),
            "{attribute}"
        );
    }
    assert_eq!(loaded.paints().len(), 2);
    assert_eq!(loaded.to_json(), json, "saved again, the same file");
    let m = mesh(&doc);
    assert_eq!(
        loaded.vertex_colours(&m, GREY),
        doc.vertex_colours(&m, GREY)
    );
    // What was loaded is the base: it is not undone.
    let mut base = loaded;
    assert!(!base.undo());
}

#[test]
fn a_document_file_from_before_paint_loads_unpainted() {
    // Written before paint existed: no `paints` section.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/scenes/curved-patch-carved.json"
    );
    let bytes = std::fs::read(path).unwrap();
    assert!(!String::from_utf8_lossy(&bytes).contains("\"paints\""));
    let doc = Document::from_json(&bytes).unwrap();
    assert!(doc.paints().is_empty());
    // An unpainted document is written without the section, as before.
    assert!(!String::from_utf8_lossy(&doc.to_json()).contains("\"paints\""));
}

#[test]
fn a_paint_stroke_the_document_refuses_is_the_files_error() {
    let mut file: serde_json::Value =
        serde_json::from_slice(&painted_document().to_json()).unwrap();
    // The brush 2 m above the sheet reaches nothing.
    file["paints"][0]["samples"] = serde_json::json!([[0.0, 1.17, 2.0]]);
    let e = Document::from_json(file.to_string().as_bytes()).unwrap_err();
    assert!(e.to_string().contains("paint stroke 0"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]

    /// The document reader's `paints` section: any attribute name, values, radius and
    /// samples, and any cut of a painted file, give a document or a clear error, never
    /// a panic.
    #[test]
    fn document_paints_section_never_panics(
        attribute in "\\PC{0,12}",
        value in proptest::collection::vec(-2.0f64..2.0, 0..5),
        radius in -0.5f64..1.5,
        samples in proptest::collection::vec(proptest::array::uniform3(-1.0f64..1.0), 0..4),
        target in 0u64..4,
        cut in 0usize..400,
    ) {
        let good = serde_json::json!({
            "format": "wandsculpt-document", "version": 1,
            "targets": [{"id": 1, "name": "sheet", "surface": editor::default_surface()}],
            "strokes": [],
            "paints": [{"target": 1, "attribute": "colour", "value": [0.5, 0.5, 0.5],
                        "radius": 0.03, "samples": [[0.0, 5.0, 0.0]]}]
        });
        let mut bad = good.clone();
        bad["paints"][0] = serde_json::json!({"target": target, "attribute": attribute,
            "value": value, "radius": radius, "samples": samples});
        let _ = Document::from_json(bad.to_string().as_bytes());
        let text = good.to_string();
        let cut = cut.min(text.len());
        let _ = Document::from_json(&text.as_bytes()[..cut]);
    }
}
