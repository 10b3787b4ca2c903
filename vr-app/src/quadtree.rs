//! The UV quadtree overlay, like the paper's figures: the leaves of each target's UV
//! vector map drawn on the sculpted surface, coloured by class: exterior leaves (the
//! target is drawn there) blue, boundary leaves (cut along a stroke's outline) amber,
//! interior leaves (hidden, the stroke surface fills them) red.
//!
//! The map is the one sculpting builds: the root grid planned for the detail's chord
//! tolerance ([`GridPlan`]), updated with the union of the target's stroke footprints
//! down to the detail's depth cap. Shown with `display.quadtree = true` in the config,
//! `--quadtree`, or the `G` key.

use glam::{DVec2, DVec3};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::jordan::NodeClass;
use sculpt_core::sculpt::stroke::union;
use sculpt_core::sculpt::surface::{ParamSurface, normal_from};
use sculpt_core::sculpt::tessellate::{Detail, GridPlan, MAX_GRID, height};
use sculpt_core::sculpt::uvmap::UvMap;

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

/// The leaves of every target's UV map at `detail`, as line segments (vertex pairs)
/// on the sculpted surfaces, appended to `out`. Returns the number of leaves drawn.
pub fn quadtree_lines(doc: &Document, detail: Detail, out: &mut Vec<LineVertex>) -> usize {
    let mut leaves = 0;
    for target in doc.targets() {
        let surface = target.target_surface();
        let tol = detail.tolerance(target.surface.size());
        let plan = GridPlan::new(surface, tol);
        let mut map = UvMap::new(plan.n.clamp(1, MAX_GRID));
        map.set_min_levels(&plan.min_levels);
        let strokes = doc.strokes_on(target.id);
        let footprints: Vec<_> = strokes.iter().map(|(_, s)| &s.footprint).collect();
        map.update(&union(&footprints), None, detail.cap());
        let lift = LIFT_TOLERANCES * tol;
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

    #[test]
    fn leaves_of_every_class_are_drawn_in_their_colours_on_the_surface() {
        let doc = scene("curved-patch-carved.json");
        let mut lines = Vec::new();
        let leaves = quadtree_lines(&doc, Detail::Final, &mut lines);
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
        let lift = LIFT_TOLERANCES * Detail::Final.tolerance(target.surface.size());
        let offset = |v: &LineVertex| {
            let p = DVec3::from_array(v.position.map(f64::from));
            let pr = surface.closest_point(p);
            let n = normal_from(surface, pr.uv, &surface.eval(pr.uv));
            let above = (p - pr.point).dot(n);
            assert_near!(above, height(&strokes, pr.uv, pr.point) + lift, F32_EPS);
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
        let mut lines = Vec::new();
        assert!(quadtree_lines(&doc, Detail::Interactive, &mut lines) > 0);
        assert!(lines.iter().all(|v| v.color == EXTERIOR_COLOR));
    }
}
