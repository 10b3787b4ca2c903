//! The paper's example scenes (tests/data/scenes), checked by ray casting against the
//! final-detail mesh.
//!
//! Tessellation tolerances: along the centrelines (groove bottoms and ridge crests are
//! constrained mesh edges) the mesh is within [`tol`]: 0.1 % of the target's size and at
//! most 10 % of the shallowest tool depth. On the target away from the strokes it is
//! within the stated `Detail::Final.tolerance(size)` (0.1 % of the size), the chord
//! error the grid is planned for.

mod common;
use common::height_along_normal;
use glam::DVec2;
use sculpt_core::assert_near;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::jordan::Location;
use sculpt_core::sculpt::stroke::Mode;
use sculpt_core::sculpt::surface::ParamSurface;
use sculpt_core::sculpt::tessellate::{Detail, height};
use sculpt_core::tolerance::{CENTRELINE_TOL_REL, EXPORT_WELD_EPS, POINT_EPS, TEST_WELD_EPS};

fn load(name: &str) -> Document {
    let path = format!("{}/../tests/data/scenes/{name}", env!("CARGO_MANIFEST_DIR"));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    Document::from_json(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn tol(doc: &Document) -> f64 {
    let size = doc.targets()[0].surface.size();
    let depth = doc
        .strokes()
        .iter()
        .map(|s| s.input.tool.depth)
        .fold(f64::INFINITY, f64::min);
    (CENTRELINE_TOL_REL * size).min(0.1 * depth)
}

struct Checked {
    centre: usize,
    overlaps: usize,
    outside: usize,
}

fn check_scene(name: &str, closed: bool) -> Checked {
    let doc = load(name);
    let target = &doc.targets()[0];
    let surface = &target.surface;
    let strokes = doc.strokes_on(target.id);
    assert_eq!(
        strokes.len(),
        doc.strokes().len(),
        "{name}: every stroke applies"
    );
    let mesh = doc.mesh(Detail::Final);
    let tol = tol(&doc);
    let lift = 0.05 * surface.size();
    let (verts, _) = mesh.merged();
    assert!(
        verts.iter().all(|v| v
            .position
            .iter()
            .chain(&v.normal)
            .chain(&v.uv)
            .all(|x| x.is_finite())),
        "{name}: NaN in the mesh"
    );
    let report = mesh.welded(EXPORT_WELD_EPS).edge_report();
    assert_eq!(report.non_manifold, 0, "{name}: {report:?}");
    assert_eq!(report.misoriented, 0, "{name}: {report:?}");
    if closed {
        assert!(report.is_watertight(), "{name}: {report:?}");
    }
    let mut c = Checked {
        centre: 0,
        overlaps: 0,
        outside: 0,
    };
    // Along every centreline (away from the tapered ends): the first hit is the
    // combined displacement; where only this stroke acts, exactly the tool depth.
    for (id, s) in &strokes {
        let n = s.centre_uv.len();
        for i in (n / 4..3 * n / 4).step_by(2) {
            let uv = s.centre_uv[i];
            let p = surface.eval(uv).p;
            let expect = height(&strokes, uv, p);
            let others: Vec<_> = strokes
                .iter()
                .filter(|(o, st)| o != id && st.depth_at(uv, p) > 0.0)
                .collect();
            let sign = if s.tool.mode == Mode::Carve {
                -1.0
            } else {
                1.0
            };
            if others.is_empty() {
                assert_near!(
                    expect,
                    sign * s.depth[i],
                    POINT_EPS,
                    "{name}: stroke {id} centre"
                );
                assert_near!(
                    s.depth[i],
                    s.tool.depth,
                    POINT_EPS,
                    "{name}: untapered middle"
                );
            } else {
                c.overlaps += 1;
                // Same mode in an overlap: the deeper (or higher) of the two wins.
                let all_same = others.iter().all(|(_, o)| o.tool.mode == s.tool.mode);
                if all_same {
                    let deepest = others
                        .iter()
                        .map(|(_, o)| o.depth_at(uv, p))
                        .fold(s.depth_at(uv, p), f64::max);
                    assert_near!(expect, sign * deepest, POINT_EPS, "{name}: overlap");
                }
            }
            let got = height_along_normal(&mesh, surface, uv, lift);
            assert_near!(got, expect, tol, "{name}: stroke {id} sample {i} at {uv}");
            c.centre += 1;
        }
    }
    // Outside every footprint, well away from the rims: the first hit is the target.
    let hidden = doc_hidden(&doc);
    for j in 1..20 {
        for i in 1..20 {
            let uv = DVec2::new(i as f64 / 20.0, j as f64 / 20.0);
            let p = surface.eval(uv).p;
            let clear = strokes.iter().all(|(_, s)| {
                s.centre
                    .iter()
                    .zip(&s.half_width)
                    .all(|(q, hw)| q.distance(p) > 2.0 * hw.max(s.tool.width * 0.5))
            });
            if clear && hidden.locate(uv) == Location::Outside {
                assert_near!(
                    height_along_normal(&mesh, surface, uv, lift),
                    0.0,
                    Detail::Final.tolerance(surface.size()),
                    "{name}: outside at {uv}"
                );
                c.outside += 1;
            }
        }
    }
    c
}

fn doc_hidden(doc: &Document) -> sculpt_core::sculpt::jordan::Region {
    let strokes = doc.strokes_on(doc.targets()[0].id);
    let regions: Vec<_> = strokes.iter().map(|s| &s.1.footprint).collect();
    sculpt_core::sculpt::stroke::union(&regions)
}

#[test]
fn curved_patch_with_three_carved_strokes() {
    let c = check_scene("curved-patch-carved.json", false);
    assert!(c.centre >= 30 && c.outside > 100, "{}", c.centre);
    assert_eq!(c.overlaps, 0);
}

#[test]
fn curved_patch_with_three_embossed_strokes() {
    let c = check_scene("curved-patch-embossed.json", false);
    assert!(c.centre >= 30 && c.outside > 100);
}

#[test]
fn sphere_with_strokes_crossing_three_times_is_watertight() {
    let doc = load("sphere-overlaps.json");
    let strokes = doc.strokes_on(doc.targets()[0].id);
    // The two footprints overlap in three separate places.
    let (a, b) = (strokes[0].1, strokes[1].1);
    let mut runs = 0;
    let mut inside = false;
    for &uv in &a.centre_uv {
        let now = b.footprint.locate(uv) != Location::Outside;
        if now && !inside {
            runs += 1;
        }
        inside = now;
    }
    assert_eq!(runs, 3, "crossings");
    let c = check_scene("sphere-overlaps.json", true);
    assert!(c.overlaps >= 3 && c.outside > 50);
}

#[test]
fn mask_face_with_wrinkles_eyebrow_and_crossing_cuts() {
    let c = check_scene("mask-face.json", false);
    assert!(c.overlaps >= 2, "the crossing cuts overlap");
}

#[test]
fn saddle_with_groove_and_ridge() {
    check_scene("saddle.json", false);
}

#[test]
fn wavy_surface_with_crossing_grooves() {
    let c = check_scene("wavy.json", false);
    assert!(c.overlaps >= 1);
}

/// True when the open segments `a-b` and `c-d` cross at a single interior point.
fn segments_cross(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let o = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    o(c, d, a) * o(c, d, b) < 0.0 && o(a, b, c) * o(a, b, d) < 0.0
}

/// Regression (spade's CDT panicked at `cdt.rs:978`, in `add_constraint_and_split`,
/// when the real Open Brush sketch was replayed). Cause: a stroke whose path hooks back
/// at its tapered end folds its strip over itself, so the footprint outline gets a tiny
/// hole and a Z-fold and the centreline leaves its own footprint, crossing outline
/// edges at shallow angles. spade's incremental splitting put the split vertex off
/// both lines and then failed its own assertion. The tessellator now splits crossing
/// constraints itself before loading the triangulation.
#[test]
fn centreline_crossing_its_outline_at_a_hooked_tapered_end_tessellates() {
    let doc = load("hooked-tapered-end.json");
    let stroke = doc.strokes_on(doc.targets()[0].id)[0].1;
    // The cause is present: the centreline crosses outline edges.
    let crossings = stroke
        .centre_uv
        .windows(2)
        .flat_map(|w| {
            stroke
                .footprint
                .segments()
                .iter()
                .filter(move |s| segments_cross(w[0], w[1], s[0], s[1]))
        })
        .count();
    assert!(crossings > 0, "the centreline stays inside its footprint");
    assert!(
        stroke.footprint.contours().len() >= 2,
        "the fold leaves a hole"
    );
    for detail in [Detail::Interactive, Detail::Final] {
        let mesh = doc.mesh(detail);
        let (verts, tris) = mesh.merged();
        assert!(tris.len() > 100, "{detail:?}");
        assert!(
            verts
                .iter()
                .all(|v| v.position.iter().chain(&v.normal).all(|x| x.is_finite()))
        );
        assert_eq!(
            mesh.welded(TEST_WELD_EPS).edge_report().non_manifold,
            0,
            "{detail:?}"
        );
    }
    // The groove is still there: half-way along, the bottom lies at the tool depth.
    let mesh = doc.mesh(Detail::Final);
    let surface = &doc.targets()[0].surface;
    let mid = stroke.centre_uv[stroke.centre_uv.len() / 2];
    let depth = stroke.depth[stroke.centre_uv.len() / 2];
    assert_near!(
        height_along_normal(&mesh, surface, mid, 0.02),
        -depth,
        tol(&doc)
    );
}

/// The bare target's mesh lies within the stated tolerance of the surface at both
/// details, measured by ray casting along the normal on a fine grid of parameters
/// (including the mask face's tight spots, which the grid plan refines).
/// Regression: the final mesh of the replay sessions' sheet was 1.26 mm off the
/// surface, above the 0.1 % the grid was chosen for (the curvature estimate ignored
/// the twist across cell diagonals).
#[test]
fn bare_targets_lie_within_the_stated_tolerance() {
    for name in [
        "mask-face.json",
        "sphere-overlaps.json",
        "wavy.json",
        "saddle.json",
        "hooked-tapered-end.json",
    ] {
        // The scene's target alone: a loaded document's content cannot be undone.
        let scene = load(name);
        let mut doc = Document::new();
        let target = &scene.targets()[0];
        doc.add_target(&target.name, target.surface.clone());
        let surface = &doc.targets()[0].surface;
        let size = surface.size();
        for detail in [Detail::Interactive, Detail::Final] {
            let mesh = doc.mesh(detail);
            let tol = detail.tolerance(size);
            let mut worst: f64 = 0.0;
            let k = 47;
            for j in 1..k {
                for i in 1..k {
                    let uv = DVec2::new(i as f64 / k as f64, j as f64 / k as f64);
                    worst = worst.max(height_along_normal(&mesh, surface, uv, 0.05 * size).abs());
                }
            }
            assert!(worst <= tol, "{name} {detail:?}: {worst} > {tol}");
        }
    }
}
