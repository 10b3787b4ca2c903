//! A stroke over valleys is carved in pieces, and no part whose closest points run
//! continuously is lost; the pieces are one operation.
//!
//! **Regression** (issue 30, item 1): `Stroke::build` split the projected centreline
//! at basin jumps (where the true closest point jumps from one slope of a valley to the
//! other) and then kept only the longest run; the rest of the stroke was dropped
//! without a word. On a finely waved sheet (bicubic, 64 x 64 control points, 14 waves
//! across) with strokes hovering 25 to 45 mm above it, a third to a half of the
//! samples whose true closest points ran continuously got no groove. Now every run is
//! a piece of the one stroke ([`StrokePieces`]).
//!
//! The truth here is independent of the inverter: true closest points by brute force
//! (`brute::closest_point`: a dense parameter grid refined locally), and basin jumps
//! found from them on a finer subdivision of the stroke than the one the stroke uses.

use std::sync::OnceLock;

use glam::{DVec2, DVec3};
use sculpt_core::editor::{self, Applied};
use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample};
use sculpt_core::mesh::PatchMesh;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::oplog::EventKind;
use sculpt_core::sculpt::document::{Document, TargetId};
use sculpt_core::sculpt::stroke::{StrokeInput, StrokePieces, Tool};
use sculpt_core::sculpt::tessellate::{Detail, StrokeRef, TargetTessellation, height};
use sculpt_core::sculpt::view::DocumentView;
use sculpt_core::tolerance::BASIN_JUMP_RATIO;

mod brute;

/// Waves across the sheet.
const WAVES: f64 = 14.0;
/// Wave amplitude, metres.
const AMPLITUDE: f64 = 0.01;
/// Control points per direction.
const CONTROL: usize = 64;
/// Wand samples per stroke.
const SAMPLES: usize = 60;
/// Brute-force queries per interval between two wand samples (the jumps are found on
/// this finer subdivision).
const SUBDIVISION: usize = 4;

/// A 1 m square sheet, `z = AMPLITUDE sin(2 pi (WAVES x + y / 2))` (waves across x,
/// turning slowly with y): the bicubic interpolant of a 64 x 64 grid (P&T A9.4), so 64
/// x 64 control points.
fn waved_sheet() -> NurbsSurface {
    let n = CONTROL - 1;
    let grid: Vec<Vec<DVec3>> = (0..=n)
        .map(|i| {
            (0..=n)
                .map(|j| {
                    let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                    let z = AMPLITUDE * (std::f64::consts::TAU * (WAVES * x + 0.5 * y)).sin();
                    DVec3::new(x, y, z)
                })
                .collect()
        })
        .collect();
    NurbsSurface::interpolate_grid(&grid, 3, 3)
        .expect("valid grid")
        .0
}

/// Three strokes of [`SAMPLES`] samples over the waves, hovering 25 to 45 mm above the
/// sheet's mean plane: along x, diagonally, and a shorter one climbing.
fn strokes() -> Vec<Vec<(f64, DVec3)>> {
    let path = |f: &dyn Fn(f64) -> DVec3| -> Vec<(f64, DVec3)> {
        (0..SAMPLES)
            .map(|k| {
                let t = k as f64 / (SAMPLES - 1) as f64;
                (t, f(t))
            })
            .collect()
    };
    let tau = std::f64::consts::TAU;
    vec![
        path(&|t| DVec3::new(0.1 + 0.8 * t, 0.5, 0.035 + 0.01 * (tau * 1.5 * t).sin())),
        path(&|t| DVec3::new(0.15 + 0.7 * t, 0.2 + 0.6 * t, 0.025 + 0.02 * t)),
        path(&|t| DVec3::new(0.3 + 0.35 * t, 0.3 + 0.05 * t, 0.045 - 0.02 * t)),
    ]
}

/// The truth about one stroke, from brute force.
struct Truth {
    /// The wand samples.
    samples: Vec<DVec3>,
    /// Each sample's true closest point: parameter (in the unit square) and point.
    feet: Vec<(DVec2, DVec3)>,
    /// True when the sample's closest point runs continuously: no basin jump in the
    /// intervals to its neighbours.
    continuous: Vec<bool>,
    /// Basin jumps along the whole stroke.
    jumps: usize,
}

/// The brute-force closest point of `p` on `s`: parameter in the unit square, point.
fn true_foot(s: &NurbsSurface, p: DVec3) -> (DVec2, DVec3) {
    let (_, uv) = brute::closest_point(s, p, (560, 32));
    let (u0, u1) = s.domain_u();
    let (v0, v1) = s.domain_v();
    let unit = DVec2::new((uv.x - u0) / (u1 - u0), (uv.y - v0) / (v1 - v0));
    (unit, s.point_uv(uv))
}

fn truth_of(s: &NurbsSurface, samples: &[(f64, DVec3)]) -> Truth {
    let samples: Vec<DVec3> = samples.iter().map(|x| x.1).collect();
    let feet: Vec<(DVec2, DVec3)> = samples.iter().map(|&p| true_foot(s, p)).collect();
    // A jump in an interval: two consecutive queries of its subdivision whose feet are
    // more than BASIN_JUMP_RATIO times farther apart than the queries.
    let jumps_in: Vec<usize> = samples
        .windows(2)
        .enumerate()
        .map(|(i, w)| {
            let mut last = (w[0], feet[i].1);
            let mut count = 0;
            for k in 1..=SUBDIVISION {
                let q = w[0].lerp(w[1], k as f64 / SUBDIVISION as f64);
                let foot = if k == SUBDIVISION {
                    feet[i + 1].1
                } else {
                    true_foot(s, q).1
                };
                if foot.distance(last.1) > BASIN_JUMP_RATIO * q.distance(last.0) {
                    count += 1;
                }
                last = (q, foot);
            }
            count
        })
        .collect();
    let continuous = (0..samples.len())
        .map(|i| {
            let before = i == 0 || jumps_in[i - 1] == 0;
            let after = i + 1 == samples.len() || jumps_in[i] == 0;
            before && after
        })
        .collect();
    Truth {
        samples,
        feet,
        continuous,
        jumps: jumps_in.iter().sum(),
    }
}

/// The sheet and the truth of every stroke, computed once for all tests.
fn fixture() -> &'static (NurbsSurface, Vec<Truth>) {
    static FIXTURE: OnceLock<(NurbsSurface, Vec<Truth>)> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let sheet = waved_sheet();
        let truths = strokes().iter().map(|s| truth_of(&sheet, s)).collect();
        (sheet, truths)
    })
}

/// A document holding the sheet, and its target.
fn document(sheet: &NurbsSurface) -> (Document, TargetId) {
    let mut doc = Document::new();
    let target = doc.add_target("waves", sheet.clone());
    doc.seal_history();
    (doc, target)
}

/// The tools the strokes are drawn with: the default (ends tapered over 1 cm) and the
/// same with blunt, round ends.
fn tools() -> [Tool; 2] {
    [
        Tool::default(),
        Tool {
            taper: 0.0,
            ..Tool::default()
        },
    ]
}

/// The continuous samples whose true closest point gets no groove from `strokes`
/// (the combined displacement there is not below the surface). With tapered ends the
/// groove comes to nothing at the stroke's first and last sample, by design: those
/// two are left out for a tapered tool.
fn uncarved(truth: &Truth, strokes: &[StrokeRef<'_>], tool: &Tool) -> Vec<usize> {
    let n = truth.samples.len();
    (0..n)
        .filter(|&i| truth.continuous[i])
        .filter(|&i| tool.taper == 0.0 || (i != 0 && i + 1 != n))
        .filter(|&i| {
            let (uv, p) = truth.feet[i];
            height(strokes, uv, p) >= 0.0
        })
        .collect()
}

#[test]
fn every_continuous_run_of_a_stroke_over_valleys_is_carved() {
    let (sheet, truths) = fixture();
    for (k, (samples, truth)) in strokes().into_iter().zip(truths).enumerate() {
        for tool in tools() {
            check_carved(sheet, k, samples.clone(), truth, tool);
        }
    }
}

/// Applies stroke `k` to the sheet with `tool` and checks it against its truth.
fn check_carved(
    sheet: &NurbsSurface,
    k: usize,
    samples: Vec<(f64, DVec3)>,
    truth: &Truth,
    tool: Tool,
) {
    let (mut doc, target) = document(sheet);
    let id = doc
        .apply_stroke(
            target,
            StrokeInput {
                samples,
                tool: tool.clone(),
            },
        )
        .expect("the stroke is applied");
    let built = doc.stroke(id).expect("built");
    let continuous = truth.continuous.iter().filter(|&&c| c).count();
    let strokes = doc.strokes_on(target);
    let missed = uncarved(truth, &strokes, &tool);
    println!(
        "stroke {k}, taper {}: {} true basin jumps, {} pieces ({} dropped), \
         {continuous} of {} samples continuous, {} of them uncarved",
        tool.taper,
        truth.jumps,
        built.pieces.len(),
        built.dropped,
        truth.samples.len(),
        missed.len()
    );
    assert!(
        truth.jumps >= 2,
        "stroke {k}: the truth has no jumps to test"
    );
    assert!(missed.is_empty(), "stroke {k}: samples {missed:?} uncarved");
    // One piece per run between true jumps: the stroke splits where the truth jumps,
    // and nowhere else.
    assert_eq!(
        built.pieces.len() + built.dropped,
        truth.jumps + 1,
        "stroke {k}"
    );
    // The pieces are what the tessellator carves, one entry each.
    assert_eq!(strokes.len(), built.pieces.len());
}

/// The cause of the regression: with only the longest piece carved (what
/// `Stroke::build` kept), continuous samples go uncarved on every stroke.
#[test]
fn regression_a_stroke_over_valleys_kept_only_its_longest_run() {
    let (sheet, truths) = fixture();
    let target = sheet_target(sheet);
    for (k, (samples, truth)) in strokes().into_iter().zip(truths).enumerate() {
        let input = StrokeInput {
            samples,
            tool: Tool::default(),
        };
        let snap = sculpt_core::sculpt::document::snap_distance(&input.tool, sheet.size());
        let built = StrokePieces::build(&target, &input, snap).expect("built");
        let all: Vec<StrokeRef<'_>> = (0u64..).zip(&built.pieces).collect();
        let longest = built
            .pieces
            .iter()
            .max_by_key(|p| p.centre.len())
            .expect("a piece");
        let old = uncarved(truth, &[(0, longest)], &input.tool);
        println!(
            "stroke {k}: the longest piece alone leaves {} continuous samples uncarved",
            old.len()
        );
        assert!(
            !old.is_empty(),
            "stroke {k}: the longest piece covers it all"
        );
        assert!(uncarved(truth, &all, &input.tool).is_empty(), "stroke {k}");
    }
}

fn sheet_target(sheet: &NurbsSurface) -> sculpt_core::sculpt::surface::TargetSurface {
    sculpt_core::sculpt::surface::TargetSurface::new(sheet)
}

/// The stroke goes through the editor as one edit: its result counts the pieces, the
/// operator log gets one marker for it, one undo removes every piece and one redo
/// brings them all back; the document file reads back to the same pieces.
#[test]
fn a_stroke_in_pieces_is_one_operation() {
    let (sheet, _) = fixture();
    let (mut doc, target) = document(sheet);
    let untouched = doc.mesh(Detail::Interactive);
    let samples = strokes().swap_remove(0);
    let edit = Edit::Stroke(StrokeEdit::new(
        target,
        Tool::default(),
        samples
            .iter()
            .map(|&(t, position)| StrokeSample { t, position })
            .collect(),
    ));
    let applied = editor::apply(&mut doc, &edit);
    let Applied::Stroke {
        id,
        pieces,
        dropped,
        ..
    } = applied
    else {
        panic!("{applied:?}");
    };
    assert!(pieces >= 3, "{pieces} pieces");
    assert_eq!(doc.stroke(id).map(|b| b.pieces.len()), Some(pieces));
    assert_eq!(doc.stroke(id).map(|b| b.dropped), Some(dropped));
    assert_eq!(doc.strokes().len(), 1, "one stroke record");
    assert_eq!(doc.piece_keys(id).map(<[u64]>::len), Some(pieces));
    assert_eq!(doc.piece_keys(id).map(|k| k[0]), Some(id));
    let Some(EventKind::Marker { label }) = editor::oplog_applied(&applied) else {
        panic!("no marker for a stroke in pieces");
    };
    assert_eq!(
        label,
        format!("stroke {id}: {pieces} pieces, {dropped} dropped")
    );
    let carved = doc.mesh(Detail::Interactive);
    assert_ne!(carved, untouched);
    // Every piece changes the mesh: each is carved. (The same tessellation of all
    // pieces is the document's mesh, so the comparison is like for like.)
    let mesh_of = |strokes: &[StrokeRef<'_>]| {
        let mut mesh = PatchMesh::new();
        let mut view = TargetTessellation::new(sheet, 0, Detail::Interactive);
        view.update_strokes(sheet, strokes, &mut mesh);
        mesh
    };
    assert_eq!(mesh_of(&doc.strokes_on(target)), carved);
    for &key in doc.piece_keys(id).unwrap() {
        let without: Vec<StrokeRef<'_>> = doc
            .strokes_on(target)
            .into_iter()
            .filter(|(k, _)| *k != key)
            .collect();
        assert_eq!(without.len(), pieces - 1);
        assert_ne!(mesh_of(&without), carved, "piece {key} carves nothing");
    }
    // Each piece has its own stroke surface, named after the stroke in the export.
    let names: Vec<String> = DocumentView::new()
        .iges_surfaces(&doc)
        .into_iter()
        .map(|s| s.name)
        .collect();
    let own = |n: &String| {
        *n == format!("stroke{id}") || (2..=pieces).any(|k| *n == format!("stroke{id}-{k}"))
    };
    assert!(names.iter().skip(1).all(own), "{names:?}");
    assert!(names.len() > 2, "{names:?}");
    // One undo removes all the pieces, one redo restores them all.
    assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
    assert!(doc.strokes().is_empty() && doc.strokes_on(target).is_empty());
    assert_eq!(doc.mesh(Detail::Interactive), untouched);
    assert!(!doc.can_undo());
    assert_eq!(editor::apply(&mut doc, &Edit::Redo), Applied::Redone);
    assert_eq!(doc.strokes_on(target).len(), pieces);
    assert_eq!(doc.mesh(Detail::Interactive), carved);
    // The file holds the one stroke; read back, it is carved in the same pieces.
    let again = Document::from_json(&doc.to_json()).expect("reads back");
    assert_eq!(again.strokes().len(), 1);
    assert_eq!(again.stroke(id).map(|b| b.pieces.len()), Some(pieces));
    assert_eq!(again.mesh(Detail::Interactive), carved);
}

/// A stroke that must be one piece ([`Stroke::build`](sculpt_core::sculpt::stroke::Stroke::build))
/// is refused with the number of pieces when it falls into several, never clipped.
#[test]
fn a_single_piece_build_refuses_a_stroke_in_pieces() {
    let (sheet, _) = fixture();
    let target = sheet_target(sheet);
    let input = StrokeInput {
        samples: strokes().swap_remove(0),
        tool: Tool::default(),
    };
    let snap = sculpt_core::sculpt::document::snap_distance(&input.tool, sheet.size());
    let err = sculpt_core::sculpt::stroke::Stroke::build(&target, &input, snap).unwrap_err();
    assert!(
        matches!(
            err,
            sculpt_core::Error::StrokeRejected(sculpt_core::error::StrokeRejection::Pieces {
                pieces
            }) if pieces >= 3
        ),
        "{err}"
    );
}
