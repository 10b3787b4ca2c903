//! The document API: undo/redo back to the start, incremental tessellation equal to a
//! fresh one, JSON round trips, clear errors for bad files, and bad strokes that never
//! panic, never put NaN in a mesh and never corrupt the document (proptest).

use glam::DVec3;
use proptest::prelude::*;
use sculpt_core::Error;
use sculpt_core::error::{DocumentError, StrokeRejection, ToolParam, ToolRangeError};
use sculpt_core::formats::{MeshFormat, iges};
use sculpt_core::mesh::PatchMesh;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;
use sculpt_core::tolerance::{MESH_HIT_EPS, POINT_WELD_EPS, TEST_WELD_EPS};

fn plane() -> NurbsSurface {
    NurbsSurface::new(
        1,
        1,
        vec![0.0, 0.0, 1.0, 1.0],
        vec![0.0, 0.0, 1.0, 1.0],
        vec![
            vec![DVec3::ZERO, DVec3::Y],
            vec![DVec3::X, DVec3::new(1.0, 1.0, 0.0)],
        ],
        None,
    )
    .unwrap()
}

fn tool(mode: Mode) -> Tool {
    Tool {
        profile: Profile::V,
        width: 0.06,
        depth: 0.01,
        mode,
        taper: 0.03,
    }
}

fn line(a: DVec3, b: DVec3) -> Vec<(f64, DVec3)> {
    (0..60)
        .map(|i| {
            let t = i as f64 / 59.0;
            (t, a.lerp(b, t))
        })
        .collect()
}

/// Applies a straight stroke from `a` to `b`.
fn stroke(doc: &mut Document, t: u64, a: DVec3, b: DVec3, mode: Mode) -> sculpt_core::Result<u64> {
    doc.apply_stroke(
        t,
        StrokeInput {
            samples: line(a, b),
            tool: tool(mode),
        },
    )
}

fn mesh_of(doc: &Document, detail: Detail) -> PatchMesh {
    doc.mesh(detail)
}

#[test]
fn undo_redo_back_to_the_start_and_incremental_equals_fresh() {
    let mut view = DocumentView::new();
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    let mut live = PatchMesh::new();
    view.tessellate(&doc, Detail::Interactive, &mut live);
    let empty = mesh_of(&doc, Detail::Interactive);
    let a = doc
        .apply_stroke(
            t,
            StrokeInput {
                samples: line(DVec3::new(0.2, 0.3, 0.0), DVec3::new(0.8, 0.3, 0.0)),
                tool: tool(Mode::Carve),
            },
        )
        .unwrap();
    view.tessellate(&doc, Detail::Interactive, &mut live);
    let one = mesh_of(&doc, Detail::Interactive);
    assert_eq!(live, one, "incremental after one stroke");
    let b = doc
        .apply_stroke(
            t,
            StrokeInput {
                samples: line(DVec3::new(0.5, 0.1, 0.0), DVec3::new(0.5, 0.9, 0.0)),
                tool: tool(Mode::Emboss),
            },
        )
        .unwrap();
    assert!(b > a);
    view.tessellate(&doc, Detail::Interactive, &mut live);
    let two = mesh_of(&doc, Detail::Interactive);
    assert_eq!(live, two);
    assert!(doc.undo());
    view.tessellate(&doc, Detail::Interactive, &mut live);
    assert_eq!(live, one, "undo restores the mesh");
    assert!(doc.undo());
    view.tessellate(&doc, Detail::Interactive, &mut live);
    assert_eq!(live, empty);
    assert!(doc.undo(), "undo the target too");
    view.tessellate(&doc, Detail::Interactive, &mut live);
    assert_eq!(
        live.triangle_count(),
        0,
        "target's patches removed from the sink"
    );
    assert!(!doc.undo());
    assert!(doc.redo() && doc.redo() && doc.redo());
    assert!(!doc.redo());
    view.tessellate(&doc, Detail::Interactive, &mut live);
    assert_eq!(live, two, "redo restores everything");
    // A new stroke clears the redo stack.
    doc.undo();
    stroke(
        &mut doc,
        t,
        DVec3::new(0.2, 0.7, 0.0),
        DVec3::new(0.8, 0.7, 0.0),
        Mode::Carve,
    )
    .unwrap();
    assert!(!doc.can_redo());
}

/// Applying, undoing and redoing a short stroke rewrites only the root cells it touches
/// (and their neighbours), not the whole target.
#[test]
fn edits_rewrite_only_the_cells_of_the_affected_stroke() {
    let mut view = DocumentView::new();
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    let mut live = PatchMesh::new();
    let all = view
        .tessellate(&doc, Detail::Interactive, &mut live)
        .patches_written;
    assert_eq!(all, doc.patch_count(Detail::Interactive));
    assert!(all >= 64);
    stroke(
        &mut doc,
        t,
        DVec3::new(0.3, 0.3, 0.0),
        DVec3::new(0.4, 0.3, 0.0),
        Mode::Carve,
    )
    .unwrap();
    let apply = view
        .tessellate(&doc, Detail::Interactive, &mut live)
        .patches_written;
    assert!(doc.undo());
    let undo = view
        .tessellate(&doc, Detail::Interactive, &mut live)
        .patches_written;
    assert!(doc.redo());
    let redo = view
        .tessellate(&doc, Detail::Interactive, &mut live)
        .patches_written;
    for (what, n) in [("apply", apply), ("undo", undo), ("redo", redo)] {
        assert!(
            n > 0 && n <= all / 4,
            "{what}: {n} of {all} patches rewritten"
        );
    }
    assert_eq!(live, doc.mesh(Detail::Interactive));
}

/// Regression (issue 16): a windowed cluster node drew its document into the window's
/// renderer, then wrote its pictures through a new one, which got only the patches
/// changed since (none): `forget_sinks` makes the next tessellation write them all.
#[test]
fn after_forget_sinks_a_new_sink_gets_every_patch() {
    let mut view = DocumentView::new();
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    let mut first = PatchMesh::new();
    view.tessellate(&doc, Detail::Final, &mut first);
    stroke(
        &mut doc,
        t,
        DVec3::new(0.3, 0.3, 0.0),
        DVec3::new(0.4, 0.3, 0.0),
        Mode::Carve,
    )
    .unwrap();
    view.tessellate(&doc, Detail::Final, &mut first);
    let mut second = PatchMesh::new();
    let stale = view
        .tessellate(&doc, Detail::Final, &mut second)
        .patches_written;
    assert_eq!(stale, 0, "without forgetting, nothing changed since");
    view.forget_sinks();
    let mut third = PatchMesh::new();
    let all = view
        .tessellate(&doc, Detail::Final, &mut third)
        .patches_written;
    assert_eq!(all, doc.patch_count(Detail::Final));
    assert_eq!(third, first);
    assert_eq!(third, doc.mesh(Detail::Final));
}

#[test]
fn a_preview_carves_only_the_interactive_mesh_and_leaves_no_trace() {
    let mut view = DocumentView::new();
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    let (mut live, mut fin) = (PatchMesh::new(), PatchMesh::new());
    view.tessellate(&doc, Detail::Interactive, &mut live);
    view.tessellate(&doc, Detail::Final, &mut fin);
    let (live_before, fin_before) = (live.clone(), fin.clone());
    let input = StrokeInput {
        samples: line(DVec3::new(0.3, 0.5, 0.0), DVec3::new(0.7, 0.5, 0.0)),
        tool: tool(Mode::Carve),
    };
    // A growing stroke, previewed as it is drawn.
    for n in [10, 30, 60] {
        let partial = StrokeInput {
            samples: input.samples[..n].to_vec(),
            tool: input.tool.clone(),
        };
        view.set_preview(&doc, t, &partial).unwrap();
        let written = view
            .tessellate(&doc, Detail::Interactive, &mut live)
            .patches_written;
        assert!(
            written > 0 && written <= doc.patch_count(Detail::Interactive) / 4,
            "{n} samples: {written} patches rewritten"
        );
    }
    let hit = |m: &PatchMesh| m.first_hit([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]).unwrap();
    sculpt_core::assert_near!(hit(&live), 1.0 + 0.01, MESH_HIT_EPS);
    assert_eq!(
        view.tessellate(&doc, Detail::Final, &mut fin)
            .patches_written,
        0
    );
    assert_eq!(fin, fin_before, "the final detail never shows a preview");
    assert!(doc.strokes().is_empty() && !doc.can_redo());
    assert_eq!(doc.to_json(), {
        let mut plain = Document::new();
        plain.add_target("plane", plane());
        plain.to_json()
    });
    // The preview looks exactly like the stroke once applied.
    let previewed = live.clone();
    view.clear_preview();
    doc.apply_stroke(t, input.clone()).unwrap();
    view.tessellate(&doc, Detail::Interactive, &mut live);
    assert_eq!(live, previewed);
    assert!(doc.undo());
    view.tessellate(&doc, Detail::Interactive, &mut live);
    assert_eq!(live, live_before, "clearing the preview restores the mesh");
    // A rejected preview says why and leaves none behind.
    let off = StrokeInput {
        samples: line(DVec3::new(0.3, 0.5, 5.0), DVec3::new(0.7, 0.5, 5.0)),
        tool: tool(Mode::Carve),
    };
    assert!(matches!(
        view.set_preview(&doc, t, &off),
        Err(Error::StrokeRejected(StrokeRejection::OffSurface))
    ));
    assert!(view.preview().is_none());
    assert!(view.set_preview(&doc, t + 100, &input).is_err());
}

/// Issue 20 ("shards while carving"): the live preview is meshed by the same graded
/// mesher as the result, and no triangle it shapes reaches past the stroke's
/// footprint by more than the stated interactive tolerance. On a plane every
/// triangle that is carved (a corner below the plane) or shaded as a wall (a corner
/// normal off +z) must have its corners and edge midpoints inside the footprint or
/// within `Detail::Interactive.tolerance(size)` of its outline (parameters are metres
/// on this unit plane). A fan from the rim to the root grid, or a rim normal carried
/// over the flat target, fails it.
#[test]
fn no_preview_triangle_lies_outside_the_footprint_plus_the_tolerance() {
    let mut view = DocumentView::new();
    use glam::DVec2;
    use sculpt_core::sculpt::jordan::{Location, point_segment_distance};
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    let mut live = PatchMesh::new();
    view.tessellate(&doc, Detail::Interactive, &mut live);
    let tol = Detail::Interactive.tolerance(2f64.sqrt());
    // A bent stroke across several root cells, previewed as it grows.
    let samples: Vec<(f64, DVec3)> = (0..80)
        .map(|i| {
            let s = i as f64 / 79.0;
            let (x, y) = (0.2 + 0.6 * s, 0.5 + 0.15 * (3.0 * s).sin());
            (s, DVec3::new(x, y, 0.0))
        })
        .collect();
    let mut checked = 0;
    for n in [12, 40, 80] {
        let partial = StrokeInput {
            samples: samples[..n].to_vec(),
            tool: tool(Mode::Carve),
        };
        view.set_preview(&doc, t, &partial).unwrap();
        view.tessellate(&doc, Detail::Interactive, &mut live);
        let (_, pieces) = view.preview().unwrap();
        let [stroke] = pieces.pieces.as_slice() else {
            panic!("the preview falls into pieces");
        };
        let outline = stroke.footprint.segments();
        let within = |p: DVec2| {
            stroke.footprint.locate(p) != Location::Outside
                || outline
                    .iter()
                    .any(|s| point_segment_distance(p, s[0], s[1]) <= tol)
        };
        for (_, patch) in live.patches() {
            for tri in &patch.triangles {
                let v = tri.map(|i| patch.vertices[i as usize]);
                let shaped = v.iter().any(|c| {
                    -c.position[2] > TEST_WELD_EPS
                        || DVec3::from_array(c.normal.map(f64::from)).distance(DVec3::Z)
                            > f64::from(TEST_WELD_EPS)
                });
                if !shaped {
                    continue;
                }
                checked += 1;
                let uv = v.map(|c| DVec2::from_array(c.uv.map(f64::from)));
                for k in 0..3 {
                    let mid = (uv[k] + uv[(k + 1) % 3]) * 0.5;
                    assert!(
                        within(uv[k]) && within(mid),
                        "{n} samples: a preview triangle reaches outside the footprint \
                         + {tol} m: {uv:?}"
                    );
                }
            }
        }
    }
    assert!(checked > 300, "only {checked} shaped triangles checked");
}

#[test]
fn json_round_trip_and_bad_files() {
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    stroke(
        &mut doc,
        t,
        DVec3::new(0.2, 0.3, 0.0),
        DVec3::new(0.8, 0.3, 0.0),
        Mode::Carve,
    )
    .unwrap();
    let bytes = doc.to_json();
    let back = Document::from_json(&bytes).unwrap();
    assert_eq!(back.strokes(), doc.strokes());
    assert_eq!(back.targets(), doc.targets());
    assert_eq!(back.mesh(Detail::Final), doc.mesh(Detail::Final));
    let text = String::from_utf8(bytes).unwrap();
    let expect_err = |t: &str, needle: &str| {
        let e = Document::from_json(t.as_bytes()).unwrap_err();
        assert!(matches!(e, Error::Document(_)), "{e:?}");
        assert!(
            e.to_string().contains(needle),
            "{e} should mention {needle}"
        );
    };
    expect_err(
        &text.replace("\"version\": 1", "\"version\": 2"),
        "unsupported version",
    );
    assert!(matches!(
        Document::from_json(text.replace("\"version\": 1", "\"version\": 2").as_bytes()),
        Err(Error::Document(DocumentError::Version {
            found: Some(2),
            supported: 1
        }))
    ));
    assert!(matches!(
        Document::from_json(text.replace("\"target\": 1", "\"target\": 7").as_bytes()),
        Err(Error::Document(DocumentError::Stroke { ref error, .. }))
            if matches!(**error, Error::NotFound { kind: "target", id: 7 })
    ));
    expect_err(
        &text.replace("wandsculpt-document", "something-else"),
        "format",
    );
    expect_err(
        &text.replace("\"target\": 1", "\"target\": 7"),
        "no such target 7",
    );
    expect_err(&text.replace("\"width\"", "\"widht\""), "unknown field");
    expect_err(&text.replace("\"depth\": 0.01", "\"depth\": -1.0"), "depth");
    expect_err(&text[..text.len() / 2], "not a JSON object");
    expect_err("[]", "not a JSON object");
}

#[test]
fn exports_read_back() {
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    stroke(
        &mut doc,
        t,
        DVec3::new(0.2, 0.3, 0.0),
        DVec3::new(0.8, 0.3, 0.0),
        Mode::Carve,
    )
    .unwrap();
    let welded = doc.mesh(Detail::Final).welded(TEST_WELD_EPS);
    for f in [MeshFormat::Obj, MeshFormat::Stl, MeshFormat::Glb] {
        let back = f.read(&f.write(&welded).unwrap()).unwrap();
        assert_eq!(back.triangles.len(), welded.triangles.len(), "{f:?}");
        // Same geometry: welding the read-back mesh gives the same topology.
        let (v, tr) = (back.vertices, back.triangles);
        let rewelded = sculpt_core::mesh::weld(&v, &tr, TEST_WELD_EPS);
        assert_eq!(rewelded.vertices.len(), welded.vertices.len(), "{f:?}");
    }
    let model =
        iges::read(&iges::write(&DocumentView::new().iges_surfaces(&doc)).unwrap()).unwrap();
    // The target (trimmed by one hole) and one stroke surface.
    assert_eq!(model.surfaces.len(), 2);
    assert_eq!(model.trimmed, vec![(0, 2)]);
}

fn arb_point() -> impl Strategy<Value = DVec3> {
    prop_oneof![
        8 => (-0.5..1.5f64, -0.5..1.5f64, -0.2..0.2f64).prop_map(|(x, y, z)| DVec3::new(x, y, z)),
        1 => Just(DVec3::new(f64::NAN, 0.5, 0.0)),
        1 => Just(DVec3::new(0.5, 0.5, 50.0)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    #[test]
    fn bad_strokes_never_corrupt_the_document(
        pts in proptest::collection::vec(arb_point(), 0..40),
        width in prop_oneof![Just(-1.0), Just(0.0), Just(f64::NAN), Just(10.0), 0.005..0.3f64],
        depth in prop_oneof![Just(0.0), Just(f64::INFINITY), 0.001..0.05f64],
        taper in prop_oneof![Just(0.0), Just(-0.1), 0.0..0.2f64],
        emboss in any::<bool>(),
        u in any::<bool>(),
    ) {
        let mut view = DocumentView::new();
        let mut doc = Document::new();
        let t = doc.add_target("plane", plane());
        doc.apply_stroke(t, StrokeInput { samples: line(DVec3::new(0.2, 0.5, 0.0), DVec3::new(0.8, 0.5, 0.0)), tool: tool(Mode::Carve) }).unwrap();
        let before_json = doc.to_json();
        let mut live = PatchMesh::new();
        view.tessellate(&doc, Detail::Interactive, &mut live);
        let samples = pts.iter().enumerate().map(|(i, p)| (i as f64, *p)).collect();
        let tool = Tool {
            profile: if u { Profile::U } else { Profile::V },
            width, depth, taper,
            mode: if emboss { Mode::Emboss } else { Mode::Carve },
        };
        match doc.apply_stroke(t, StrokeInput { samples, tool }) {
            Ok(_) => prop_assert_eq!(doc.strokes().len(), 2),
            Err(e) => {
                prop_assert!(matches!(e, Error::StrokeRejected(_)), "{e:?}");
                prop_assert_eq!(doc.to_json(), before_json);
            }
        }
        view.tessellate(&doc, Detail::Interactive, &mut live);
        let (verts, tris) = live.merged();
        prop_assert!(verts.iter().all(|v| v.position.iter().chain(&v.normal).all(|x| x.is_finite())));
        prop_assert!(tris.iter().all(|t| t.iter().all(|&i| (i as usize) < verts.len())));
        prop_assert_eq!(live, doc.mesh(Detail::Interactive));
    }
}

/// A wand path that wanders, reverses, loops back over itself and runs off the edge:
/// a random walk of up to 12 legs, each a straight run of a few samples, some of them
/// turning back by up to 180 degrees.
fn arb_wild_path() -> impl Strategy<Value = Vec<(f64, DVec3)>> {
    (
        (-0.2..1.2f64, -0.2..1.2f64),
        proptest::collection::vec((-3.2..3.2f64, 0.002..0.3f64, 2usize..12), 1..12),
        -0.01..0.01f64,
    )
        .prop_map(|((x, y), legs, z)| {
            let mut p = DVec3::new(x, y, z);
            let mut heading = 0.0f64;
            let mut out = vec![(0.0, p)];
            for (turn, length, n) in legs {
                heading += turn;
                let step = DVec3::new(heading.cos(), heading.sin(), 0.0) * (length / n as f64);
                for _ in 0..n {
                    p += step;
                    out.push((out.len() as f64 / 90.0, p));
                }
            }
            out
        })
}

fn arb_tool() -> impl Strategy<Value = Tool> {
    (
        0.005..0.2f64,
        0.001..0.05f64,
        prop_oneof![Just(0.0), 0.0..0.1f64],
        any::<bool>(),
        0..3u8,
    )
        .prop_map(|(width, depth, taper, emboss, profile)| Tool {
            profile: match profile {
                0 => Profile::V,
                1 => Profile::U,
                _ => Profile::Custom(vec![[0.0, 1.0], [0.4, 0.9], [0.8, 0.2]]),
            },
            width,
            depth,
            mode: if emboss { Mode::Emboss } else { Mode::Carve },
            taper,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
    /// Self-intersecting, reversing and off-edge strokes, alone or crossing each
    /// other, never panic the tessellator and never put NaN in a mesh, at either
    /// detail, incrementally or fresh.
    #[test]
    fn wild_strokes_never_panic_or_give_nan(
        strokes in proptest::collection::vec((arb_wild_path(), arb_tool()), 1..4),
    ) {
        let mut view = DocumentView::new();
        let mut doc = Document::new();
        let t = doc.add_target("plane", plane());
        let mut live = [PatchMesh::new(), PatchMesh::new()];
        for (samples, tool) in strokes {
            if let Err(e) = doc.apply_stroke(t, StrokeInput { samples, tool }) {
                prop_assert!(matches!(e, Error::StrokeRejected(_)), "{e:?}");
            }
            for (detail, sink) in [Detail::Interactive, Detail::Final].into_iter().zip(&mut live) {
                view.tessellate(&doc, detail, sink);
            }
        }
        for (detail, sink) in [Detail::Interactive, Detail::Final].into_iter().zip(&live) {
            let (verts, tris) = sink.merged();
            prop_assert!(!tris.is_empty());
            prop_assert!(verts.iter().all(|v| v.position.iter().chain(&v.normal).chain(&v.uv).all(|x| x.is_finite())));
            prop_assert!(tris.iter().all(|t| t.iter().all(|&i| (i as usize) < verts.len())));
            prop_assert_eq!(sink, &doc.mesh(detail));
        }
    }
}

/// Regression (issue 15, item 2): a scene file's stroke depth, width and taper had no
/// upper bound, so `sculpt-tools mesh` and `replay --scene` wrote OBJ files with `inf`
/// vertices for a depth of 1e200. The reader now applies the interaction's limits
/// (`MAX_TOOL_SIZE`, 10 m) and names the field; a depth at the limit still reads.
#[test]
fn a_scene_with_an_absurd_tool_size_is_refused_by_name() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/scenes/curved-patch-carved.json"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let good: serde_json::Value = serde_json::from_str(&text).unwrap();
    for (field, value) in [("depth", 1e200), ("width", 1e200), ("taper", 11.0)] {
        let mut bad = good.clone();
        bad["strokes"][0]["tool"][field] = serde_json::json!(value);
        let err = Document::from_json(&serde_json::to_vec(&bad).unwrap())
            .expect_err("an absurd tool size must be refused");
        assert!(err.to_string().contains(field), "{field}: {err}");
    }
    let mut at_limit = good.clone();
    at_limit["strokes"][0]["tool"]["taper"] =
        serde_json::json!(sculpt_core::sculpt::stroke::MAX_TOOL_SIZE);
    let doc = Document::from_json(&serde_json::to_vec(&at_limit).unwrap()).unwrap();
    let obj = MeshFormat::Obj
        .write(&doc.mesh(Detail::Final).welded(POINT_WELD_EPS))
        .unwrap();
    let obj = String::from_utf8(obj).unwrap();
    assert!(!obj.contains("inf") && !obj.contains("NaN"));
}

/// Each reason a stroke is refused is a variant the caller can match on, with the
/// numbers that decided it.
#[test]
fn stroke_rejections_are_typed() {
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    let at = DVec3::new(0.5, 0.5, 0.0);
    let point = StrokeInput {
        samples: vec![(0.0, at), (1.0, at)],
        tool: tool(Mode::Carve),
    };
    let e = doc.apply_stroke(t, point).unwrap_err();
    assert!(
        matches!(
            e,
            Error::StrokeRejected(StrokeRejection::TooShort { length_m, min_m })
                if length_m == 0.0 && min_m > 0.0
        ),
        "{e:?}"
    );
    assert_eq!(e.to_string(), "stroke rejected: the stroke has zero length");
    let mut wide = tool(Mode::Carve);
    wide.width = -1.0;
    let e = doc
        .apply_stroke(
            t,
            StrokeInput {
                samples: line(DVec3::new(0.2, 0.5, 0.0), DVec3::new(0.8, 0.5, 0.0)),
                tool: wide,
            },
        )
        .unwrap_err();
    assert!(
        matches!(
            e,
            Error::StrokeRejected(StrokeRejection::Tool(ToolRangeError {
                param: ToolParam::Width,
                value: -1.0,
                ..
            }))
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "stroke rejected: tool width must be in (0, 10] m, got -1"
    );
    let nan = StrokeInput {
        samples: vec![(0.0, at), (f64::NAN, at)],
        tool: tool(Mode::Carve),
    };
    assert!(matches!(
        doc.apply_stroke(t, nan),
        Err(Error::StrokeRejected(StrokeRejection::SampleNotFinite {
            index: 1
        }))
    ));
    assert!(doc.strokes().is_empty());
}

/// Regression (issue 15 §2): no writer may emit a non-finite number. The document and
/// surface JSON writers write only what a [`Document`] holds, and a NaN or infinite
/// control point, weight, knot, sample or tool size never gets in: each is refused
/// where it would enter, and the document's JSON stays as it was.
#[test]
fn a_nan_never_enters_a_document_so_its_json_writer_never_writes_one() {
    let mut doc = Document::new();
    let t = doc.add_target("plane", plane());
    stroke(
        &mut doc,
        t,
        DVec3::new(0.2, 0.3, 0.0),
        DVec3::new(0.8, 0.3, 0.0),
        Mode::Carve,
    )
    .unwrap();
    let before = doc.to_json();
    let knots = || vec![0.0, 0.0, 1.0, 1.0];
    let net = |p: DVec3| vec![vec![DVec3::ZERO, DVec3::Y], vec![DVec3::X, p]];
    assert!(matches!(
        NurbsSurface::new(1, 1, knots(), knots(), net(DVec3::NAN), None),
        Err(Error::InvalidControlNet(_))
    ));
    let weights = Some(vec![vec![1.0, 1.0], vec![1.0, f64::INFINITY]]);
    assert!(matches!(
        NurbsSurface::new(1, 1, knots(), knots(), net(DVec3::ONE), weights),
        Err(Error::InvalidWeights(_))
    ));
    assert!(matches!(
        NurbsSurface::new(
            1,
            1,
            vec![0.0, 0.0, f64::NAN, 1.0],
            knots(),
            net(DVec3::ONE),
            None
        ),
        Err(Error::InvalidKnots { .. })
    ));
    let mut samples = line(DVec3::new(0.2, 0.6, 0.0), DVec3::new(0.8, 0.6, 0.0));
    samples[7].1.y = f64::NAN;
    let tool = tool(Mode::Carve);
    assert_eq!(
        doc.apply_stroke(
            t,
            StrokeInput {
                samples,
                tool: tool.clone()
            }
        ),
        Err(Error::StrokeRejected(StrokeRejection::SampleNotFinite {
            index: 7
        }))
    );
    let samples = line(DVec3::new(0.2, 0.6, 0.0), DVec3::new(0.8, 0.6, 0.0));
    let nan_depth = Tool {
        depth: f64::NAN,
        ..tool
    };
    assert!(matches!(
        doc.apply_stroke(
            t,
            StrokeInput {
                samples,
                tool: nan_depth
            }
        ),
        Err(Error::StrokeRejected(StrokeRejection::Tool(_)))
    ));
    assert_eq!(doc.to_json(), before);
    let text = String::from_utf8(before).unwrap();
    assert!(!text.contains("null") && !text.contains("NaN") && !text.contains("inf"));
}

/// Regression (issue 15 §7): errors quoted bad input whole, so a megabyte-long
/// `"format"` value, or a long string where a number belongs (serde quotes it), gave a
/// megabyte-long message. Both are cut to a short prefix.
#[test]
fn a_huge_string_in_a_document_gives_a_short_error_because_quotes_are_cut() {
    let huge = "z".repeat(1 << 20);
    let wrong_format =
        format!(r#"{{"format": "{huge}", "version": 1, "targets": [], "strokes": []}}"#);
    let e = Document::from_json(wrong_format.as_bytes()).unwrap_err();
    match &e {
        Error::Document(DocumentError::Format {
            found: Some(found), ..
        }) => assert!(found.is_cut()),
        other => panic!("{other:?}"),
    }
    let wrong_type = format!(
        r#"{{"format": "wandsculpt-document", "version": 1, "targets": [{{"id": "{huge}"}}], "strokes": []}}"#
    );
    let e2 = Document::from_json(wrong_type.as_bytes()).unwrap_err();
    assert!(
        matches!(e2, Error::Document(DocumentError::Schema(_))),
        "{e2:?}"
    );
    for e in [e, e2] {
        let shown = sculpt_core::error::Chain(&e).to_string();
        assert!(shown.len() < 300, "{} bytes", shown.len());
    }
}
