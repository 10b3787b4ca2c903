//! The UV quadtree overlay, like the paper's figures: the leaves of each target's UV
//! vector map drawn on the sculpted surface, coloured by class: exterior leaves (the
//! target is drawn there) blue, boundary leaves (cut along a stroke's outline) amber,
//! interior leaves (hidden, the stroke surface fills them) red.
//!
//! The map is the one sculpting uses, asked of the session's document view
//! ([`DocumentView::uv_map`]): the target's tessellation view at the detail drawn, with
//! the grid planned for the detail's chord tolerance of the surface's extent, wrapped
//! on closed sides, and updated with the target's stroke footprints. So draw it after
//! the meshes were synchronised at that detail; a target not yet tessellated there
//! (or drawn as one patch of a conforming network) shows no leaves. Shown with
//! `display.quadtree = true` in the config, `--quadtree`, or the `G` key.

use glam::{DVec2, DVec3};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::jordan::NodeClass;
use sculpt_core::sculpt::surface::{ParamSurface, extent, normal_from};
use sculpt_core::sculpt::tessellate::{Detail, height};
use sculpt_core::sculpt::view::DocumentView;

use crate::scene::LineVertex;

/// Colour (linear RGBA) of exterior leaves.
pub const EXTERIOR_COLOR: [f32; 4] = [0.15, 0.35, 0.9, 1.0];
/// Colour of boundary leaves.
pub const BOUNDARY_COLOR: [f32; 4] = [1.0, 0.55, 0.0, 1.0];
/// Colour of interior (hidden) leaves.
pub const INTERIOR_COLOR: [f32; 4] = [0.9, 0.05, 0.05, 1.0];

/// Lines are lifted off the sculpted surface by this many tessellation tolerances, so
/// that the mesh (within one tolerance of the surface) does not hide them.
const LIFT_TOLERANCES: f64 = 2.0;

/// The colour of a leaf of class `class`.
pub fn class_color(class: NodeClass) -> [f32; 4] {
    match class {
        NodeClass::Exterior => EXTERIOR_COLOR,
        NodeClass::Boundary => BOUNDARY_COLOR,
        NodeClass::Interior => INTERIOR_COLOR,
    }
}

/// The lift of the lines off the surface: [`LIFT_TOLERANCES`] of the tessellation's
/// chord tolerance at `detail` (of the surface's extent, as the grid is planned).
fn lift(surface: &dyn ParamSurface, detail: Detail) -> f64 {
    LIFT_TOLERANCES * detail.tolerance(extent(surface).diagonal())
}

/// The leaves of every target's UV map at `detail` in `view` ([`DocumentView::uv_map`]:
/// the map sculpting and the renderer's mesh use), as line segments (vertex pairs) on
/// the sculpted surfaces of `doc`, appended to `out`. Returns the number of leaves
/// drawn.
pub fn quadtree_lines(
    doc: &Document,
    view: &DocumentView,
    detail: Detail,
    out: &mut Vec<LineVertex>,
) -> usize {
    let mut leaves = 0;
    for target in doc.targets() {
        let Some(map) = view.uv_map(target.id, detail) else {
            continue;
        };
        let surface = target.target_surface();
        let strokes = doc.strokes_on(target.id);
        let lift = lift(surface, detail);
        let at = |uv: DVec2| -> DVec3 {
            let sp = surface.eval(uv);
            let n = normal_from(surface, uv, &sp);
            sp.p + n * (height(&strokes, uv, sp.p) + lift)
        };
        for (_, node) in map.leaves() {
            leaves += 1;
            let color = class_color(node.class);
            let (lo, hi) = (node.rect.min, node.rect.max);
            let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
            // Coarse leaves bend with the surface: their sides in a few pieces.
            let pieces = (4u32 >> node.level.min(2)).max(1);
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                for s in 0..pieces {
                    let t0 = f64::from(s) / f64::from(pieces);
                    let t1 = f64::from(s + 1) / f64::from(pieces);
                    out.push(LineVertex::new(at(a.lerp(b, t0)), color));
                    out.push(LineVertex::new(at(a.lerp(b, t1)), color));
                }
            }
        }
    }
    leaves
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::F32_EPS;

    fn scene(name: &str) -> Document {
        let path = format!("{}/../tests/data/scenes/{name}", env!("CARGO_MANIFEST_DIR"));
        Document::from_json(&std::fs::read(path).unwrap()).unwrap()
    }

    /// `doc` and its view tessellated at `detail`, as the renderer's sync does before
    /// the overlay.
    fn tessellated(doc: Document, detail: Detail) -> (Document, DocumentView) {
        let mut view = DocumentView::new();
        view.tessellate(&doc, detail, &mut sculpt_core::mesh::PatchMesh::default());
        (doc, view)
    }

    /// Regression (issue 32): the overlay rebuilt the UV map on its own, sized by the
    /// control net's diagonal instead of the surface's extent and without wrapping the
    /// closed sides, so it could show another quadtree than the one sculpting used.
    /// It draws the document's own map now: every leaf of it, nothing before the
    /// document was tessellated at that detail.
    #[test]
    fn regression_the_overlay_draws_the_map_sculpting_uses() {
        let doc = scene("sphere-overlaps.json");
        let mut lines = Vec::new();
        assert_eq!(
            quadtree_lines(&doc, &DocumentView::new(), Detail::Final, &mut lines),
            0
        );
        let (doc, view) = tessellated(doc, Detail::Final);
        let leaves: usize = doc
            .targets()
            .iter()
            .map(|t| view.uv_map(t.id, Detail::Final).unwrap().leaves().count())
            .sum();
        assert!(leaves > 0);
        assert_eq!(
            quadtree_lines(&doc, &view, Detail::Final, &mut lines),
            leaves
        );
        assert!(
            view.uv_map(doc.targets()[0].id, Detail::Interactive)
                .is_none()
        );
    }

    #[test]
    fn leaves_of_every_class_are_drawn_in_their_colours_on_the_surface() {
        let (doc, view) = tessellated(scene("curved-patch-carved.json"), Detail::Final);
        let mut lines = Vec::new();
        let leaves = quadtree_lines(&doc, &view, Detail::Final, &mut lines);
        assert!(leaves > 100, "{leaves}");
        assert_eq!(lines.len() % 2, 0);
        for color in [EXTERIOR_COLOR, BOUNDARY_COLOR, INTERIOR_COLOR] {
            let n = lines.iter().filter(|v| v.color == color).count();
            assert!(n > 0, "no leaf in {color:?}");
        }
        // Every vertex lies the lift above the sculpted surface; interior leaves lie
        // mostly in the grooves (below the target), exterior ones never.
        let target = &doc.targets()[0];
        let surface = target.target_surface();
        let strokes = doc.strokes_on(target.id);
        let lift = lift(surface, Detail::Final);
        let offset = |v: &LineVertex| {
            let p = DVec3::from_array(v.position.map(f64::from));
            let pr = surface.closest_point(p);
            let n = normal_from(surface, pr.uv_in_square, &surface.eval(pr.uv_in_square));
            let above = (p - pr.point).dot(n);
            assert_near!(
                above,
                height(&strokes, pr.uv_in_square, pr.point) + lift,
                F32_EPS
            );
            above
        };
        let interior: Vec<_> = lines.iter().filter(|v| v.color == INTERIOR_COLOR).collect();
        let sunk = interior.iter().filter(|v| offset(v) < 0.0).count();
        assert!(2 * sunk > interior.len(), "{sunk} of {}", interior.len());
        for v in lines.iter().filter(|v| v.color == EXTERIOR_COLOR) {
            assert_near!(offset(v), lift, F32_EPS);
        }
    }

    #[test]
    fn a_bare_target_has_only_exterior_leaves() {
        let scene = scene("saddle.json");
        let mut doc = Document::new();
        let t = &scene.targets()[0];
        doc.add_target(&t.name, t.surface.clone());
        let (doc, view) = tessellated(doc, Detail::Interactive);
        let mut lines = Vec::new();
        assert!(quadtree_lines(&doc, &view, Detail::Interactive, &mut lines) > 0);
        assert!(lines.iter().all(|v| v.color == EXTERIOR_COLOR));
    }
}
