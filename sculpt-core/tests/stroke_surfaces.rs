//! Stroke surfaces: each stroke's own NURBS surface and UV map, trimmed where
//! other strokes remove it (paper 4.3), checked against the stroke data and against the
//! document's rendered final mesh on the paper scenes (tests/data/scenes) and on three
//! mutually overlapping strokes.
//!
//! Tolerances: the fit is within [`StrokeSurface::fit_tolerance`] (7.5 % of the tool
//! depth plus 0.1 % of its width). A visible stroke-surface point lies on the rendered
//! surface (the height field the tessellator samples) within that, and on the final
//! mesh within that plus the mesh's own error across the profile, [`mesh_tol`]: 10 % of
//! the tool depth for a curved (U) profile, whose mesh is a few chords across, and the
//! scene tests' centreline tolerance (0.1 % of the target's size) otherwise. Points
//! closer than twice the fit tolerance to the trim outline (by the visibility margin)
//! are not judged.

mod common;
use common::height_along_normal;
use glam::{DVec2, DVec3};
use sculpt_core::assert_near;
use sculpt_core::formats::iges;
use sculpt_core::mesh::{MeshSink, PatchMesh};
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::{Document, StrokeId, stroke_patch_key};
use sculpt_core::sculpt::jordan::NodeClass;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
use sculpt_core::sculpt::stroke_surface::{StrokeSurface, map_cap, visibility_margin};
use sculpt_core::sculpt::surface::{ParamSurface, extent, normal_at, wrap_uv};
use sculpt_core::sculpt::tessellate::{Detail, height};
use sculpt_core::sculpt::view::DocumentView;
use sculpt_core::tolerance::{CENTRELINE_TOL_REL, EXACT_EPS, POINT_EPS, ULP_EPS};

const SCENES: [&str; 7] = [
    "curved-patch-carved.json",
    "curved-patch-embossed.json",
    "sphere-overlaps.json",
    "mask-face.json",
    "saddle.json",
    "wavy.json",
    "hooked-tapered-end.json",
];

fn load(name: &str) -> Document {
    let path = format!("{}/../tests/data/scenes/{name}", env!("CARGO_MANIFEST_DIR"));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    Document::from_json(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn closed(s: &dyn ParamSurface) -> [bool; 2] {
    let e = extent(s);
    [e.closed_u, e.closed_v]
}

/// The rendered mesh's own error across a groove's profile (see the module docs).
fn mesh_tol(doc: &Document, profile: &Profile, depth: f64) -> f64 {
    let size = doc.targets()[0].surface.size();
    match profile {
        Profile::V => CENTRELINE_TOL_REL * size,
        _ => 0.1 * depth + CENTRELINE_TOL_REL * size,
    }
}

/// Every stroke of every paper scene gets a stroke surface within the stated fit
/// tolerance: rims on the target, the centre at the tapered tool depth (against the
/// stroke's data and `Stroke::depth_at`), cubic along the stroke, degree 1 across a V.
#[test]
fn stroke_surfaces_fit_the_grooves_of_the_paper_scenes() {
    let mut view = DocumentView::new();
    for name in SCENES {
        let doc = load(name);
        let target = &doc.targets()[0];
        let surface = &target.surface;
        for (id, stroke) in doc.strokes_on(target.id) {
            let ss = view
                .stroke_surface(&doc, id)
                .unwrap_or_else(|| panic!("{name}: stroke {id} has a surface"));
            let tol = ss.fit_tolerance();
            if name != "hooked-tapered-end.json" {
                assert!(
                    ss.fit_error() <= tol,
                    "{name}: stroke {id} fit {} > {tol}",
                    ss.fit_error()
                );
            }
            let nurbs = ss.surface();
            assert_eq!(nurbs.degree_u(), 3, "{name}: cubic along the stroke");
            let across = match stroke.tool.profile {
                Profile::V => 1,
                _ => 3,
            };
            assert_eq!(nurbs.degree_v(), across, "{name}: degree across");
            let sign = match stroke.tool.mode {
                Mode::Carve => -1.0,
                Mode::Emboss => 1.0,
            };
            let centre_col = ss
                .column_fractions()
                .iter()
                .position(|&f| f == 0.0)
                .expect("a centre column");
            let t_centre = ss.column_params()[centre_col];
            if stroke.tool.profile == Profile::V {
                // The crease is a knot of the degree-1 direction.
                assert!(nurbs.knots_v().knots().contains(&t_centre), "{name}");
            }
            for (k, (&s, &x)) in ss.row_params().iter().zip(ss.row_positions()).enumerate() {
                if x.fract() != 0.0 {
                    continue; // a row inserted between samples
                }
                let i = x as usize;
                for (t, rim) in [(0.0, &stroke.rims_uv[0]), (1.0, &stroke.rims_uv[1])] {
                    let on_target = surface.eval(wrap_uv(rim[i])).p;
                    assert_near!(
                        ss.point(DVec2::new(s, t)).to_array(),
                        on_target.to_array(),
                        POINT_EPS,
                        "{name}: stroke {id} rim at row {k}"
                    );
                }
                let c = wrap_uv(stroke.centre_uv[i]);
                let base = surface.eval(c).p;
                let n = normal_at(surface, c);
                let bottom = ss.point(DVec2::new(s, t_centre));
                assert_near!(
                    (bottom - base).dot(n),
                    sign * stroke.depth_at(stroke.centre_uv[i], base),
                    POINT_EPS,
                    "{name}: stroke {id} centre at row {k}"
                );
                // At least the section's tapered depth (a neighbouring section may reach
                // deeper), and the tool depth along the untapered middle.
                assert!(stroke.depth_at(stroke.centre_uv[i], base) >= stroke.depth[i] - POINT_EPS);
                if stroke.depth[i] == stroke.tool.depth && name != "hooked-tapered-end.json" {
                    assert_near!(
                        (bottom - base).dot(n),
                        sign * stroke.tool.depth,
                        tol,
                        "{name}: stroke {id} tool depth at row {k}"
                    );
                }
            }
            // Tapered ends go to zero depth.
            let last = ss.row_params().len() - 1;
            for k in [0, last] {
                let i = ss.row_positions()[k] as usize;
                assert!(stroke.depth[i] <= 0.05 * stroke.tool.depth, "{name}: taper");
            }
        }
    }
}

struct Tally {
    visible: usize,
    trimmed: usize,
    on_mesh: usize,
}

/// Samples every stroke surface of `doc` and checks the trimming against the rendered
/// surface: its height field ([`height`], which the tessellator samples) within the fit
/// tolerance everywhere, and the final mesh itself (ray cast) within the fit plus the
/// mesh tolerance wherever the mesh is within its own tolerance of the height field
/// (the mesh is coarser than the fit on the rim walls of tapered U ends).
fn check_trims(name: &str, doc: &Document) -> Tally {
    let mut view = DocumentView::new();
    let target = &doc.targets()[0];
    let surface = &target.surface;
    let closed = closed(surface);
    let strokes = doc.strokes_on(target.id);
    let mesh = doc.mesh(Detail::Final);
    let lift = 0.2 * surface.size();
    let mut tally = Tally {
        visible: 0,
        trimmed: 0,
        on_mesh: 0,
    };
    for (own, &(id, stroke)) in strokes.iter().enumerate() {
        let ss = view.stroke_surface(doc, id).expect("a stroke surface");
        let fit = ss.fit_tolerance();
        let tol = mesh_tol(doc, &stroke.tool.profile, stroke.tool.depth);
        let same_mode = strokes.iter().all(|(_, o)| o.tool.mode == stroke.tool.mode);
        let rows = ss.row_params();
        let cols = ss.column_params();
        let step = (rows.len() / 24).max(1);
        for k in (0..rows.len() - 1).step_by(step) {
            for j in 1..8 {
                let st = DVec2::new(
                    0.5 * (rows[k] + rows[k + 1]),
                    cols[0] + (cols[cols.len() - 1] - cols[0]) * j as f64 / 8.0,
                );
                let uv = ss.target_foot(target.target_surface(), st);
                let margin = visibility_margin(surface, &strokes, own, uv, closed);
                if margin.abs() <= 2.0 * fit {
                    continue; // too close to the trim outline to judge
                }
                let w = wrap_uv(uv);
                let base = surface.eval(w).p;
                let n = normal_at(surface, w);
                let h_surface = (ss.point(st) - base).dot(n);
                let h_final = height(&strokes, w, base);
                let h_mesh = height_along_normal(&mesh, surface, w, lift);
                let mesh_ok = (h_mesh - h_final).abs() <= tol;
                let visible = ss.is_visible(st);
                assert_eq!(
                    visible,
                    margin > 0.0,
                    "{name}: stroke {id} at {st}: trim region and margin {margin} disagree"
                );
                if visible {
                    assert_near!(
                        h_surface,
                        h_final,
                        fit,
                        "{name}: stroke {id} visible at {st} off the rendered surface"
                    );
                    if mesh_ok {
                        assert_near!(
                            h_surface,
                            h_mesh,
                            fit + tol,
                            "{name}: stroke {id} visible at {st} off the mesh"
                        );
                        tally.on_mesh += 1;
                    }
                    tally.visible += 1;
                } else {
                    // Not on the final surface; with strokes of one mode, strictly inside
                    // another stroke's removed volume (carve: above the final surface, in
                    // the other groove) or added volume (emboss: below it).
                    assert!(
                        (h_surface - h_final).abs() > fit,
                        "{name}: stroke {id} trimmed at {st} but on the final surface"
                    );
                    if same_mode {
                        let inside = match stroke.tool.mode {
                            Mode::Carve => {
                                h_surface > h_final + fit && (!mesh_ok || h_surface > h_mesh)
                            }
                            Mode::Emboss => {
                                h_surface < h_final - fit && (!mesh_ok || h_surface < h_mesh)
                            }
                        };
                        assert!(
                            inside,
                            "{name}: stroke {id} trimmed at {st}: {h_surface} vs final {h_final}, mesh {h_mesh}"
                        );
                    }
                    tally.trimmed += 1;
                }
            }
        }
    }
    // The mesh is within its tolerance of the height field almost everywhere.
    assert!(
        tally.on_mesh as f64 >= 0.8 * tally.visible as f64,
        "{name}: {} of {} visible points checked on the mesh",
        tally.on_mesh,
        tally.visible
    );
    tally
}

#[test]
fn overlapping_stroke_surfaces_agree_with_the_rendered_mesh() {
    for name in [
        "sphere-overlaps.json",
        "mask-face.json",
        "wavy.json",
        "saddle.json",
        "curved-patch-carved.json",
    ] {
        let doc = load(name);
        let t = check_trims(name, &doc);
        assert!(t.visible > 50, "{name}: {} visible points", t.visible);
        if name == "sphere-overlaps.json" || name == "mask-face.json" || name == "wavy.json" {
            assert!(t.trimmed > 0, "{name}: overlaps are trimmed");
        }
    }
}

/// A gently curved bicubic patch, 1 m across.
fn patch() -> NurbsSurface {
    let n = 6;
    let mut knots = vec![0.0; 4];
    knots.extend((1..n - 3).map(|i| i as f64 / (n - 3) as f64));
    knots.extend([1.0; 4]);
    let cps = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                    DVec3::new(
                        x,
                        y,
                        0.08 * (x - 0.5) * (x - 0.5) - 0.05 * (y - 0.5).powi(2),
                    )
                })
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, knots.clone(), knots, cps, None).expect("patch")
}

fn line_on(surface: &NurbsSurface, a: DVec2, b: DVec2, tool: Tool) -> StrokeInput {
    let samples = (0..=80)
        .map(|k| {
            let f = k as f64 / 80.0;
            let uv = a.lerp(b, f);
            (f, ParamSurface::eval(surface, uv).p)
        })
        .collect();
    StrokeInput { samples, tool }
}

fn carve(depth: f64, profile: Profile) -> Tool {
    Tool {
        profile,
        width: 0.06,
        depth,
        mode: Mode::Carve,
        taper: 0.06,
    }
}

/// Three carved strokes crossing pairwise (a triangle), of different depths, all three
/// overlapping near the centre; then the same as emboss.
fn three_strokes(mode: Mode) -> (Document, Vec<StrokeId>) {
    let mut doc = Document::new();
    let surface = patch();
    let t = doc.add_target("patch", surface.clone());
    let c = DVec2::splat(0.5);
    let mut ids = Vec::new();
    for (k, (depth, profile)) in [
        (0.010, Profile::V),
        (0.016, Profile::U),
        (0.013, Profile::V),
    ]
    .into_iter()
    .enumerate()
    {
        let a = std::f64::consts::TAU * k as f64 / 3.0 + 0.3;
        let dir = DVec2::new(a.cos(), a.sin()) * 0.3;
        let off = DVec2::new(-a.sin(), a.cos()) * 0.02;
        let mut tool = carve(depth, profile);
        tool.mode = mode;
        let input = line_on(&surface, c - dir + off, c + dir + off, tool);
        ids.push(doc.apply_stroke(t, input).expect("stroke applies"));
    }
    (doc, ids)
}

#[test]
fn three_mutually_overlapping_strokes_trim_each_other() {
    let mut view = DocumentView::new();
    for mode in [Mode::Carve, Mode::Emboss] {
        let (doc, ids) = three_strokes(mode);
        let name = format!("three strokes {mode:?}");
        for &id in &ids {
            let ss = view.stroke_surface(&doc, id).expect("surface");
            assert!(!ss.trim().is_empty(), "{name}: stroke {id} is trimmed");
            assert!(
                ss.fit_error() <= ss.fit_tolerance(),
                "{name}: stroke {id} fit {} > {}",
                ss.fit_error(),
                ss.fit_tolerance()
            );
            // The UV map classifies against the trim region, boundary nodes at the cap.
            for detail in [Detail::Interactive, Detail::Final] {
                let map = ss.map(detail);
                assert!(map.leaves().any(|(_, n)| n.class == NodeClass::Interior));
                for (_, n) in map.leaves() {
                    if n.class == NodeClass::Boundary {
                        assert_eq!(n.level, map_cap(detail), "{name}");
                    }
                }
            }
        }
        let t = check_trims(&name, &doc);
        assert!(
            t.visible > 100 && t.trimmed > 10,
            "{name}: {} / {}",
            t.visible,
            t.trimmed
        );
    }
}

#[test]
fn undo_and_redo_keep_stroke_surfaces_right() {
    let (mut doc, ids) = three_strokes(Mode::Carve);
    // One view follows `doc` through undo and redo; `two` gets its own.
    let mut view = DocumentView::new();
    let area = |view: &mut DocumentView, doc: &Document, id| {
        view.stroke_surface(doc, id).map(|s| s.trim().area())
    };
    let before: Vec<_> = ids.iter().map(|&id| area(&mut view, &doc, id)).collect();
    assert!(doc.undo());
    assert_eq!(
        area(&mut view, &doc, ids[2]),
        None,
        "an undone stroke has no surface"
    );
    let fewer: Vec<_> = ids[..2]
        .iter()
        .map(|&id| area(&mut view, &doc, id))
        .collect();
    // Without the third stroke the first two are trimmed less (or the same).
    for (a, b) in fewer.iter().zip(&before) {
        assert!(a.unwrap() <= b.unwrap() + EXACT_EPS);
    }
    assert!(fewer[0].unwrap() < before[0].unwrap());
    // A fresh document with two strokes agrees with the undone one.
    let (full, _) = three_strokes(Mode::Carve);
    let mut two = full.clone();
    two.undo();
    for (k, &id) in ids[..2].iter().enumerate() {
        assert_near!(
            area(&mut DocumentView::new(), &two, id).unwrap(),
            fewer[k].unwrap(),
            ULP_EPS
        );
    }
    assert!(doc.redo());
    let after: Vec<_> = ids.iter().map(|&id| area(&mut view, &doc, id)).collect();
    for (a, b) in after.iter().zip(&before) {
        assert_near!(a.unwrap(), b.unwrap(), ULP_EPS);
    }
}

#[test]
fn iges_export_carries_each_stroke_surface_trimmed_by_its_visible_faces() {
    let doc = load("sphere-overlaps.json");
    let surfaces = DocumentView::new().iges_surfaces(&doc);
    // The target and one surface per stroke.
    assert_eq!(surfaces.len(), 1 + doc.strokes().len());
    let model = iges::read(&iges::write(&surfaces).expect("finite")).expect("reads back");
    assert_eq!(model.surfaces.len(), surfaces.len());
    for (k, s) in surfaces.iter().enumerate() {
        assert_eq!(model.surfaces[k].degree_u, s.patch.degree_u);
        assert_eq!(model.surfaces[k].degree_v, s.patch.degree_v);
        let flat = |net: &[Vec<DVec3>]| -> Vec<f64> {
            net.iter().flatten().flat_map(|p| p.to_array()).collect()
        };
        assert_near!(
            flat(&model.surfaces[k].control_points),
            flat(&s.patch.control_points),
            EXACT_EPS
        );
    }
    // The strokes cross: both stroke surfaces are trimmed (entity 144).
    let trimmed_strokes = model.trimmed.iter().filter(|(base, _)| *base > 0).count();
    assert!(trimmed_strokes >= 2, "{:?}", model.trimmed);
    // A lone stroke's surface is a plain entity 128, cubic along the stroke.
    let doc = load("curved-patch-carved.json");
    let model = iges::read(&iges::write(&DocumentView::new().iges_surfaces(&doc)).expect("finite"))
        .expect("reads back");
    assert_eq!(model.surfaces.len(), 4);
    assert!(model.trimmed.iter().all(|(base, _)| *base == 0));
    assert!(
        model.surfaces[1..]
            .iter()
            .all(|s| s.degree_u == 3 && s.degree_v == 1)
    );
}

#[test]
fn stroke_surface_meshes_are_finite_face_out_and_skip_the_trimmed_part() {
    let mut view = DocumentView::new();
    let doc = load("sphere-overlaps.json");
    let target = &doc.targets()[0];
    for &(id, stroke) in &doc.strokes_on(target.id) {
        let ss = view.stroke_surface(&doc, id).expect("surface");
        for detail in [Detail::Interactive, Detail::Final] {
            let mut mesh = PatchMesh::new();
            let n = view.stroke_surface_mesh(&doc, id, detail, &mut mesh);
            assert!(n > 100, "stroke {id}: {n} triangles");
            let (verts, tris) = mesh.merged();
            assert_eq!(tris.len(), n);
            assert_eq!(
                mesh.patches().next().map(|p| p.0),
                Some(stroke_patch_key(id))
            );
            let (mut along, mut wound, mut total) = (0.0, 0.0, 0.0);
            for t in &tris {
                let [a, b, c] = t.map(|i| verts[i as usize]);
                let p =
                    |v: sculpt_core::mesh::MeshVertex| DVec3::from_array(v.position.map(f64::from));
                assert!(
                    [a, b, c]
                        .iter()
                        .all(|v| v.position.iter().all(|x| x.is_finite()))
                );
                let st = DVec2::new(
                    f64::from(a.uv[0] + b.uv[0] + c.uv[0]) / 3.0,
                    f64::from(a.uv[1] + b.uv[1] + c.uv[1]) / 3.0,
                );
                assert!(
                    ss.is_visible(st),
                    "stroke {id}: a triangle in the trimmed part"
                );
                // Faces out of the material: along the target normal.
                let face = (p(b) - p(a)).cross(p(c) - p(a));
                let uv = wrap_uv(ss.target_uv(st));
                let area = face.length();
                total += area;
                if face.dot(normal_at(&target.surface, uv)) > 0.0 {
                    along += area;
                }
                let normals = [a, b, c]
                    .iter()
                    .map(|v| DVec3::from_array(v.normal.map(f64::from)))
                    .sum::<DVec3>();
                if face.dot(normals) > 0.0 {
                    wound += area;
                }
            }
            // Wound consistently with the normals, which face out of the material (the
            // steep rim walls of a U profile are nearly perpendicular to the target's
            // normal, so a few of them tip either way).
            // (Shares of the area: slivers at tapered ends have no reliable direction.)
            assert!(
                wound >= 0.99 * total,
                "stroke {id}: {wound} of {total} wound"
            );
            let share = if stroke.tool.profile == Profile::V {
                0.99
            } else {
                0.9
            };
            assert!(
                along > share * total,
                "stroke {id}: {along} of {total} face out"
            );
        }
    }
    // All of them at once, each under its own key, next to nothing else.
    let mut all = PatchMesh::new();
    let n = view.stroke_surfaces_mesh(&doc, Detail::Final, &mut all);
    assert_eq!(all.patches().count(), 2);
    assert_eq!(all.triangle_count(), n);
}

/// A sink that counts what it is given (to check nothing is written for no surface).
#[derive(Default)]
struct Count(usize);

impl MeshSink for Count {
    fn begin_patch(&mut self, _: u64) {
        self.0 += 1;
    }
    fn push_vertex(&mut self, _: sculpt_core::mesh::MeshVertex) -> u32 {
        0
    }
    fn push_triangle(&mut self, _: u32, _: u32, _: u32) {}
    fn end_patch(&mut self) {}
    fn remove_patch(&mut self, _: u64) {}
}

#[test]
fn degenerate_strokes_get_a_defined_result() {
    let mut view = DocumentView::new();
    // Very short, tapered away, and over the pole of the sphere: either rejected as a
    // stroke (as today) or given a finite surface, never a panic or NaN.
    let sphere = load("sphere-overlaps.json");
    let sphere_surface = sphere.targets()[0].surface.clone();
    let plane = patch();
    let tapered = Tool {
        taper: 5.0,
        ..carve(0.01, Profile::U)
    };
    let custom = carve(0.01, Profile::Custom(vec![[0.0, 1.0], [0.5, 0.8]]));
    let cases: Vec<(&NurbsSurface, [f64; 4], Tool)> = vec![
        (&plane, [0.5, 0.5, 0.5001, 0.5], carve(0.01, Profile::V)),
        (&plane, [0.3, 0.5, 0.31, 0.5], tapered),
        (
            &sphere_surface,
            [0.1, 0.0, 0.1, 0.15],
            carve(0.01, Profile::V),
        ),
        (&sphere_surface, [0.0, 0.02, 0.5, 0.02], custom),
    ];
    let cases = cases.into_iter().map(|(s, [a, b, c, d], tool)| {
        (
            s.clone(),
            line_on(s, DVec2::new(a, b), DVec2::new(c, d), tool),
        )
    });
    for (k, (surface, input)) in cases.enumerate() {
        let mut doc = Document::new();
        let t = doc.add_target("t", surface);
        let Ok(id) = doc.apply_stroke(t, input) else {
            continue; // rejected with a reason, as before
        };
        match view.stroke_surface(&doc, id) {
            Some(ss) => {
                assert!(ss.fit_error().is_finite(), "case {k}");
                let mut mesh = PatchMesh::new();
                view.stroke_surface_mesh(&doc, id, Detail::Final, &mut mesh);
                let (verts, _) = mesh.merged();
                assert!(
                    verts
                        .iter()
                        .all(|v| v.position.iter().chain(&v.normal).all(|x| x.is_finite())),
                    "case {k}"
                );
            }
            None => {
                let mut sink = Count::default();
                assert_eq!(
                    view.stroke_surface_mesh(&doc, id, Detail::Final, &mut sink),
                    0
                );
                assert_eq!(sink.0, 0, "case {k}: nothing written without a surface");
            }
        }
        let _ = DocumentView::new().iges_surfaces(&doc);
    }
    // Built directly from a stroke with its width zeroed: no surface, a typed error.
    let doc = load("curved-patch-carved.json");
    let target = &doc.targets()[0];
    let (_, stroke) = doc.strokes_on(target.id)[0];
    let mut flat = stroke.clone();
    flat.half_width.iter_mut().for_each(|w| *w = 0.0);
    assert!(StrokeSurface::build(target.target_surface(), &flat).is_err());
}
