//! Lattice deformation through the document: one undoable edit, strokes carried in UV,
//! the saved document consistent, exports of the deformed surfaces, and the
//! interaction's lattice mode.

use glam::{DQuat, DVec3};
use sculpt_core::assert_near;
use sculpt_core::editor::{self, Applied, default_document, default_surface_point};
use sculpt_core::formats::{MeshFormat, iges};
use sculpt_core::interaction::{
    Command, DEFAULT_TARGET, Edit, Interaction, InteractionConfig, InteractionMode, Output,
    StrokeEdit, StrokeSample, Tool, WandEvent, WandSample,
};
use sculpt_core::lattice::{DeformEdit, Lattice, LatticeSpec};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::surface::{ParamSurface, TargetSurface};
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;
use sculpt_core::tolerance::{EXPORT_WELD_EPS, POINT_EPS};

/// How close a carried stroke's centreline stays to its old `(u, v)`: point inversion
/// of the carried samples plus resampling; a thousandth of the square.
const UV_FOLLOW: f64 = 0.001;

fn carve(y: f64) -> Edit {
    Edit::Stroke(StrokeEdit::new(
        DEFAULT_TARGET,
        Tool::default(),
        (0..=30)
            .map(|i| StrokeSample {
                t: i as f64 * 0.01,
                position: default_surface_point(-0.3 + 0.02 * i as f64, y),
            })
            .collect(),
    ))
}

/// The cage's top front middle, where the test bend grabs.
fn top_front(doc: &Document) -> DVec3 {
    let surfaces: Vec<_> = doc.targets().iter().map(|t| &t.surface).collect();
    let l = Lattice::around(LatticeSpec::default(), &surfaces).unwrap();
    let (lo, hi) = l.bounds();
    DVec3::new(0.5 * (lo.x + hi.x), hi.y, hi.z)
}

fn bend(doc: &Document, radius: f64) -> Edit {
    Edit::Deform(DeformEdit {
        targets: doc.target_ids(),
        lattice: LatticeSpec::default(),
        grab: top_front(doc),
        radius,
        displacement: DVec3::new(0.0, 0.05, 0.1),
    })
}

fn centre_uv(doc: &Document) -> Vec<glam::DVec2> {
    let id = doc.strokes()[0].id;
    doc.stroke(id).unwrap().pieces[0].centre_uv.clone()
}

#[test]
fn a_deformation_bends_the_target_and_the_groove_follows_in_uv() {
    let mut doc = default_document();
    assert!(matches!(
        editor::apply(&mut doc, &carve(1.3)),
        Applied::Stroke { .. }
    ));
    let before_surface = doc.targets()[0].surface.clone();
    let before_input = doc.strokes()[0].input.clone();
    let before_uv = centre_uv(&doc);
    let edit = bend(&doc, 0.3);
    let Applied::Deform {
        targets, points, ..
    } = editor::apply(&mut doc, &edit)
    else {
        panic!("the bend applies");
    };
    assert_eq!(targets, vec![DEFAULT_TARGET]);
    assert!(points >= 2, "{points}");
    let after = doc.targets()[0].surface.clone();
    assert_ne!(after, before_surface);
    // The top edge came forward.
    assert!(after.point(0.5, 1.0).z > before_surface.point(0.5, 1.0).z + 0.01);
    // The groove runs through the same (u, v) on the bent surface ...
    let after_uv = centre_uv(&doc);
    let (a, b) = (after_uv[0], *after_uv.last().unwrap());
    assert_near!(a, before_uv[0], UV_FOLLOW);
    assert_near!(b, *before_uv.last().unwrap(), UV_FOLLOW);
    // ... and its centreline lies on it.
    let target = TargetSurface::new(&after);
    let piece = &doc.stroke(doc.strokes()[0].id).unwrap().pieces[0];
    for (uv, p) in piece.centre_uv.iter().zip(&piece.centre) {
        assert_near!(*p, target.eval(*uv).p, POINT_EPS);
    }
    // One undo puts surface and stroke back exactly; redo brings the bend again.
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
    assert_eq!(doc.targets()[0].surface, before_surface);
    assert_eq!(doc.strokes()[0].input, before_input);
    assert_eq!(centre_uv(&doc), before_uv);
    assert_eq!(editor::apply(&mut doc, &Edit::Redo), Applied::Redone);
    assert_eq!(doc.targets()[0].surface, after);
    assert_eq!(centre_uv(&doc), after_uv);
    // Undo twice: the bend, then the stroke.
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
    assert!(doc.strokes().is_empty());
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Unchanged);
}

/// The saved document holds the bent surfaces and the carried samples; read back it
/// rebuilds the same strokes, and saves the same bytes.
#[test]
fn a_deformed_document_saves_and_loads_to_the_same_bytes() {
    let mut doc = default_document();
    editor::apply(&mut doc, &carve(1.25));
    let edit = bend(&doc, 0.3);
    assert!(matches!(
        editor::apply(&mut doc, &edit),
        Applied::Deform { .. }
    ));
    let bytes = doc.to_json();
    let back = Document::from_json(&bytes).unwrap();
    assert_eq!(back.to_json(), bytes);
    assert_eq!(centre_uv(&back), centre_uv(&doc));
    assert_eq!(
        back.mesh(Detail::Interactive),
        doc.mesh(Detail::Interactive)
    );
}

#[test]
fn refused_deformations_leave_the_document_alone() {
    let mut doc = default_document();
    let before = doc.to_json();
    // Nothing of the cage within 1 mm of a point in the middle of a cell.
    let Edit::Deform(mut off) = bend(&doc, 0.001) else {
        unreachable!()
    };
    off.grab -= DVec3::new(0.1, 0.1, 0.0);
    let Applied::Rejected(e) = editor::apply(&mut doc, &Edit::Deform(off.clone())) else {
        panic!("nothing grabbed");
    };
    assert!(e.to_string().contains("no lattice control point"), "{e}");
    off.targets = vec![99];
    off.radius = 10.0;
    let Applied::Rejected(e) = editor::apply(&mut doc, &Edit::Deform(off)) else {
        panic!("no target 99");
    };
    assert!(e.to_string().contains("target 99"), "{e}");
    assert_eq!(doc.to_json(), before);
    assert!(!doc.can_undo());
}

/// IGES and GLB export what the document holds: the bent surface, read back.
#[test]
fn iges_and_glb_exports_read_back_the_deformed_surface() {
    let mut doc = default_document();
    let original = doc.targets()[0].surface.clone();
    let edit = bend(&doc, 0.3);
    assert!(matches!(
        editor::apply(&mut doc, &edit),
        Applied::Deform { .. }
    ));
    let bent = doc.targets()[0].surface.clone();
    let model =
        iges::read(&iges::write(&DocumentView::new().iges_surfaces(&doc)).unwrap()).unwrap();
    assert_eq!(model.surfaces.len(), 1);
    let read = &model.surfaces[0].control_points;
    let (want, old) = (bent.control_points(), original.control_points());
    let mut moved = 0.0f64;
    for i in 0..want.len() {
        for j in 0..want[i].len() {
            assert_near!(read[i][j], want[i][j], POINT_EPS);
            moved = moved.max(read[i][j].distance(old[i][j]));
        }
    }
    assert!(moved > 0.01, "the IGES holds the bent net ({moved} m)");
    let welded = doc.mesh(Detail::Final).welded(EXPORT_WELD_EPS);
    let glb = MeshFormat::Glb
        .read(&MeshFormat::Glb.write(&welded).unwrap())
        .unwrap();
    let target = TargetSurface::new(&bent);
    let mut glb_top = f64::NEG_INFINITY;
    for v in &glb.vertices {
        let p = DVec3::from_array(v.position.map(f64::from));
        // Every vertex lies on the bent surface (within the final detail's chord
        // tolerance, f32 positions).
        let on = target.closest_point(p);
        assert!(
            target.eval(on.uv_in_square).p.distance(p) < Detail::Final.tolerance(bent.size()),
            "{p}"
        );
        glb_top = glb_top.max(p.z);
    }
    // The mesh comes as far forward as the bent surface does, which is further than
    // the original did.
    let front = |s: &sculpt_core::nurbs::NurbsSurface| {
        (0..=100)
            .flat_map(|a| (0..=100).map(move |b| (a as f64 / 100.0, b as f64 / 100.0)))
            .map(|(u, v)| s.point(u, v).z)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert_near!(glb_top, front(&bent), Detail::Final.tolerance(bent.size()));
    assert!(front(&bent) > front(&original) + 0.01);
}

fn tracked(t: f64, p: DVec3, buttons: u32) -> WandEvent {
    WandEvent::sample(t, WandSample::tracked(p, DQuat::IDENTITY, buttons))
}

/// Lattice mode: a drag emits one deformation from where it grabbed by how far it
/// went; a click (shorter than a stroke) emits none; the radius command is checked.
#[test]
fn a_lattice_drag_is_one_deform_edit() {
    let mut m = Interaction::new(
        InteractionConfig::default(),
        InteractionMode::CARVE,
        Tool::default(),
    );
    let mut out = Vec::new();
    m.handle(
        &WandEvent::command(
            0.0,
            Command::SetMode {
                mode: InteractionMode::Lattice,
            },
        ),
        &mut out,
    )
    .unwrap();
    assert_eq!(m.mode(), InteractionMode::Lattice);
    assert!(
        m.handle(
            &WandEvent::command(0.0, Command::SetLatticeRadius { radius: -1.0 }),
            &mut out
        )
        .is_err()
    );
    m.handle(
        &WandEvent::command(0.0, Command::SetLatticeRadius { radius: 0.2 }),
        &mut out,
    )
    .unwrap();
    let grab = DVec3::new(0.1, 1.2, 0.0);
    m.handle(&tracked(0.1, grab, 0), &mut out).unwrap();
    m.handle(&tracked(0.2, grab, 1), &mut out).unwrap();
    for k in 1..=10 {
        let p = grab + DVec3::new(0.0, 0.0, 0.01 * k as f64);
        m.handle(&tracked(0.2 + 0.01 * k as f64, p, 1), &mut out)
            .unwrap();
        assert_near!(m.live_lattice().unwrap().1, p - grab, 0.0);
    }
    m.handle(&tracked(0.4, grab + DVec3::new(0.0, 0.0, 0.1), 0), &mut out)
        .unwrap();
    let edits: Vec<&Edit> = out
        .iter()
        .filter_map(|o| match o {
            Output::Edit(e) => Some(e),
            _ => None,
        })
        .collect();
    let [Edit::Deform(d)] = edits.as_slice() else {
        panic!("one deform: {edits:?}");
    };
    assert_eq!(d.targets, vec![DEFAULT_TARGET]);
    assert_near!(d.grab, grab, 0.0);
    assert_near!(d.displacement, DVec3::new(0.0, 0.0, 0.1), POINT_EPS);
    assert_near!(d.radius, 0.2, 0.0);
    // A click moves nothing.
    out.clear();
    m.handle(&tracked(0.5, grab, 1), &mut out).unwrap();
    m.handle(&tracked(0.6, grab, 0), &mut out).unwrap();
    assert!(!out.iter().any(|o| matches!(o, Output::Edit(_))));
}
