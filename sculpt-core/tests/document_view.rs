//! The model apart from its views (issue 32): a [`Document`] holds targets, strokes and
//! history; a [`DocumentView`] holds what is drawn from it and syncs from `&Document`
//! by the revisions the document records. These tests prove the split: views of one
//! document agree whenever they sync, a view that followed every edit equals a fresh
//! one, drawing needs only a shared reference, and a view started over for another
//! document leaves nothing of the old one in its sinks.

use glam::DVec3;
use sculpt_core::editor::{default_document, default_surface_point};
use sculpt_core::interaction::DEFAULT_TARGET;
use sculpt_core::lattice::{Lattice, LatticeSpec};
use sculpt_core::mesh::PatchMesh;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool as StrokeTool};
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;

const DETAILS: [Detail; 2] = [Detail::Interactive, Detail::Final];

/// A stroke along the default sheet's row `y` (its own parameters), its samples on
/// the sheet.
fn across_sheet(y: f64) -> StrokeInput {
    let on_sheet = |s: f64| default_surface_point(-0.3 + 0.6 * s, y);
    StrokeInput {
        samples: (0..=30)
            .map(|i| {
                let s = f64::from(i) / 30.0;
                (0.3 * s, on_sheet(s))
            })
            .collect(),
        tool: StrokeTool::default(),
    }
}

/// Bends every target of `doc` as one step: the cage's control points near its top
/// front middle moved up and forward. True when the document took it.
fn bend(doc: &mut Document) -> bool {
    let ids = doc.target_ids();
    let surfaces: Vec<_> = doc.targets().iter().map(|t| &t.surface).collect();
    let mut lattice = Lattice::around(LatticeSpec::default(), &surfaces).unwrap();
    let (lo, hi) = lattice.bounds();
    let grabbed = lattice
        .group(DVec3::new(0.5 * (lo.x + hi.x), hi.y, hi.z), 0.3)
        .unwrap();
    lattice
        .displace(&grabbed, DVec3::new(0.0, 0.05, 0.1))
        .unwrap();
    doc.apply_deform(&ids, &lattice).is_ok()
}

/// A flat unit square at `x0..x0 + 1` (two of them side by side share a side: a
/// patch network).
fn square(x0: f64) -> NurbsSurface {
    NurbsSurface::new(
        1,
        1,
        vec![0.0, 0.0, 1.0, 1.0],
        vec![0.0, 0.0, 1.0, 1.0],
        vec![
            vec![DVec3::new(x0, 0.0, 0.0), DVec3::new(x0, 1.0, 0.0)],
            vec![
                DVec3::new(x0 + 1.0, 0.0, 0.0),
                DVec3::new(x0 + 1.0, 1.0, 0.0),
            ],
        ],
        None,
    )
    .unwrap()
}

/// A straight stroke from `a` to `b` on the squares (1 cm deep V).
fn line(a: DVec3, b: DVec3) -> StrokeInput {
    StrokeInput {
        samples: (0..=40)
            .map(|i| {
                let s = f64::from(i) / 40.0;
                (s, a.lerp(b, s))
            })
            .collect(),
        tool: StrokeTool {
            profile: Profile::V,
            width: 0.05,
            depth: 0.01,
            mode: Mode::Carve,
            taper: 0.02,
        },
    }
}

/// What a view that never drew `doc` writes at each detail, into empty sinks.
fn fresh(doc: &Document) -> [PatchMesh; 2] {
    let mut view = DocumentView::new();
    DETAILS.map(|d| {
        let mut sink = PatchMesh::new();
        view.tessellate(doc, d, &mut sink);
        sink
    })
}

/// The leaves of `target`'s UV map at `detail` in `view` (level, rectangle, class), in
/// a fixed order: the map's own node order depends on how it was refined and pruned.
fn leaves(view: &DocumentView, target: u64, detail: Detail) -> Vec<String> {
    let mut out: Vec<String> = view
        .uv_map(target, detail)
        .map(|m| {
            m.leaves()
                .map(|(_, n)| format!("{} {:?} {:?}", n.level, n.rect, n.class))
                .collect()
        })
        .unwrap_or_default();
    out.sort();
    out
}

/// Brings `view`'s sinks up to date with `doc` at both details.
fn sync(view: &mut DocumentView, doc: &Document, sinks: &mut [PatchMesh; 2]) {
    for (d, sink) in DETAILS.into_iter().zip(sinks.iter_mut()) {
        view.tessellate(doc, d, sink);
    }
}

/// One step of a session: true when it changed the document.
type Step = dyn Fn(&mut Document) -> bool;

/// A view that follows every step of a session (strokes, undo, redo, a lattice bend,
/// targets added and undone) has, after each step, the sinks and UV maps of a view
/// made fresh from the document at that step; a second view that syncs only every
/// other step agrees with both whenever it syncs.
#[test]
fn a_view_synced_after_every_edit_equals_a_fresh_view() {
    let mut doc = default_document();
    let (mut every, mut sinks) = (DocumentView::new(), [PatchMesh::new(), PatchMesh::new()]);
    let (mut sometimes, mut sinks2) = (DocumentView::new(), [PatchMesh::new(), PatchMesh::new()]);
    sync(&mut every, &doc, &mut sinks);
    let steps: Vec<Box<Step>> = vec![
        Box::new(|d| d.apply_stroke(DEFAULT_TARGET, across_sheet(1.2)).is_ok()),
        Box::new(|d| d.apply_stroke(DEFAULT_TARGET, across_sheet(1.3)).is_ok()),
        Box::new(Document::undo),
        Box::new(Document::redo),
        Box::new(bend),
        Box::new(|d| d.apply_stroke(DEFAULT_TARGET, across_sheet(1.25)).is_ok()),
        Box::new(Document::undo),
        Box::new(Document::undo),
        Box::new(|d| {
            d.add_target("second", square(3.0));
            true
        }),
        Box::new(Document::undo),
        Box::new(Document::redo),
    ];
    let mut revisions = vec![doc.revision()];
    for (k, step) in steps.iter().enumerate() {
        assert!(step(&mut doc), "step {k} applies");
        revisions.push(doc.revision());
        sync(&mut every, &doc, &mut sinks);
        let want = fresh(&doc);
        assert!(
            sinks == want,
            "step {k}: the synced view's sinks are a fresh view's"
        );
        let mut maps = DocumentView::new();
        sync(&mut maps, &doc, &mut [PatchMesh::new(), PatchMesh::new()]);
        for t in doc.targets() {
            for d in DETAILS {
                let (ours, theirs) = (leaves(&every, t.id, d), leaves(&maps, t.id, d));
                assert!(
                    !ours.is_empty() && ours == theirs,
                    "step {k}: the UV maps' leaves"
                );
            }
        }
        if k % 2 == 1 {
            sync(&mut sometimes, &doc, &mut sinks2);
            assert!(sinks2 == sinks, "step {k}: two views of one document agree");
        }
    }
    revisions
        .windows(2)
        .for_each(|w| assert!(w[1] > w[0], "every step raises the revision"));
    // Undone and redone strokes leave no stroke surface behind, and a deformation's
    // rebuilt pieces get new ones: the synced view's are a fresh view's.
    let mut fresh_view = DocumentView::new();
    for t in doc.targets() {
        let ours: Vec<_> = every.stroke_surfaces(&doc, t.id);
        let theirs: Vec<_> = fresh_view.stroke_surfaces(&doc, t.id);
        assert_eq!(ours.len(), theirs.len());
        for ((ka, a), (kb, b)) in ours.iter().zip(&theirs) {
            assert_eq!(ka, kb);
            assert!(a.surface() == b.surface(), "stroke surface {ka}");
            assert_eq!(a.trim().area(), b.trim().area(), "trim of {ka}");
        }
    }
}

/// Drawing reads the document through a shared reference only: two views draw one
/// `&Document` on two threads at once and write the same meshes as the model's own
/// fresh mesh, and the preview of one view never reaches the other or the model.
#[test]
fn drawing_needs_only_a_shared_document() {
    let mut doc = Document::new();
    let a = doc.add_target("left", square(0.0));
    doc.add_target("right", square(1.0));
    assert!(
        !doc.network().is_empty(),
        "the squares form a patch network"
    );
    doc.apply_stroke(
        a,
        line(DVec3::new(0.2, 0.3, 0.0), DVec3::new(0.7, 0.3, 0.0)),
    )
    .unwrap();
    let doc: &Document = &doc;
    let before = doc.to_json();
    let (mut left, mut right) = (DocumentView::new(), DocumentView::new());
    let preview = line(DVec3::new(0.4, 0.8, 0.0), DVec3::new(1.6, 0.8, 0.0));
    left.set_preview(doc, a, &preview).unwrap();
    let (with_preview, plain) = std::thread::scope(|s| {
        let one = s.spawn(|| {
            let mut sink = PatchMesh::new();
            left.tessellate(doc, Detail::Interactive, &mut sink);
            sink
        });
        let two = s.spawn(|| {
            let mut sink = PatchMesh::new();
            right.tessellate(doc, Detail::Interactive, &mut sink);
            sink
        });
        (one.join().unwrap(), two.join().unwrap())
    });
    assert!(
        plain == doc.mesh(Detail::Interactive),
        "a view draws the model's mesh"
    );
    assert!(
        with_preview != plain,
        "the preview is carved into its own view only"
    );
    assert!(right.preview().is_none());
    assert_eq!(doc.to_json(), before);
    // Cleared, the preview's view writes the model's mesh again.
    let mut sink = with_preview;
    left.clear_preview();
    left.tessellate(doc, Detail::Interactive, &mut sink);
    assert!(sink == plain);
}

/// Regression (issue 32): a cluster node replaced its document and the view went on
/// with the old one's tessellation state. Started over, a view takes every patch of
/// the old document out of its sinks and writes the new one whole.
#[test]
fn a_view_started_over_holds_nothing_of_the_old_document() {
    let mut old = Document::new();
    old.add_target("left", square(0.0));
    old.add_target("right", square(1.0));
    old.add_target("far", square(5.0));
    let mut new = default_document();
    new.apply_stroke(DEFAULT_TARGET, across_sheet(1.2)).unwrap();
    let mut view = DocumentView::new();
    let mut sinks = [PatchMesh::new(), PatchMesh::new()];
    sync(&mut view, &old, &mut sinks);
    view.start_over();
    sync(&mut view, &new, &mut sinks);
    assert!(sinks == fresh(&new));
}
