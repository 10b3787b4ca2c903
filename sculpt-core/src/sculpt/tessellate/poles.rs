//! Poles: sides of the square that map to one point (a sphere's), evaluated once and
//! triangulated without fins.

use super::StrokeRef;
use crate::sculpt::stroke::Mode;
use crate::sculpt::surface::{ParamSurface, SurfaceExtent, normal_from};
use crate::tolerance::{MESH_SNAP_EPS, POLE_RING_PARAM, POLE_SIDE_REL};
use glam::{DVec2, DVec3};

/// The sides of the square (0 u-min, 1 u-max, 2 v-min, 3 v-max) whose points all
/// coincide (within [`POLE_SIDE_REL`] of the target's size): the poles of a sphere.
pub(super) fn pole_sides(surface: &dyn ParamSurface, extent: &SurfaceExtent) -> [bool; 4] {
    let tol = POLE_SIDE_REL * extent.diagonal();
    let side = |k: usize| {
        let at = |t: f64| {
            surface
                .eval(match k {
                    0 => DVec2::new(0.0, t),
                    1 => DVec2::new(1.0, t),
                    2 => DVec2::new(t, 0.0),
                    _ => DVec2::new(t, 1.0),
                })
                .p
        };
        let first = at(0.0);
        first.is_finite() && (1..=8).all(|i| at(f64::from(i) / 8.0).distance(first) <= tol)
    };
    [side(0), side(1), side(2), side(3)]
}

/// The one parameter a pole on side `side` is evaluated at: the side's midpoint.
pub(super) fn pole_uv(side: usize) -> DVec2 {
    match side {
        0 => DVec2::new(0.0, 0.5),
        1 => DVec2::new(1.0, 0.5),
        2 => DVec2::new(0.5, 0.0),
        _ => DVec2::new(0.5, 1.0),
    }
}

/// Flips the fins that a pole leaves in a cell's triangulation.
///
/// A pole (a side of the square that is one point) collapses every triangle with a
/// vertex on it and its two other vertices on one meridian (the same `u` for a pole at
/// `v = 0` or `1`, the same `v` for one at `u = 0` or `1`) onto that meridian: a fin of
/// no area. Where two cells share the meridian as a side, each made such a fin over the
/// same three points, so the edge from the lower side vertex to the pole was used by
/// four triangles (non-manifold at a sphere's pole at final detail). Each fin is
/// flipped with its neighbour across one of its two pole edges (one that is no
/// constraint and whose quadrilateral is convex in `uv`), so that both new triangles
/// span two meridians. The cell's outline is unchanged, so it stays crack-free against
/// its neighbours.
pub(super) fn unfold_pole_fins(
    uvs: &[DVec2],
    poles: [bool; 4],
    is_constraint: impl Fn(u32, u32) -> bool,
    tris: &mut [[u32; 3]],
) {
    let uv = |i: u32| uvs[i as usize];
    let on_pole = |i: u32| pole_of(poles, uv(i));
    let ccw = |a: u32, b: u32, c: u32| (uv(b) - uv(a)).perp_dot(uv(c) - uv(a)) > 0.0;
    let third = |t: [u32; 3], a: u32, b: u32| t.into_iter().find(|&i| i != a && i != b);
    for f in 0..tris.len() {
        let t = tris[f];
        let Some(k) = (0..3).find(|&k| on_pole(t[k]).is_some()) else {
            continue;
        };
        // The fin in counter-clockwise order (q, x, y), q on the pole.
        let (q, x, y) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let Some(side) = on_pole(q) else { continue };
        let meridian = |i: u32| if side >= 2 { uv(i).x } else { uv(i).y };
        let same_meridian = |a: u32, b: u32| (meridian(a) - meridian(b)).abs() <= MESH_SNAP_EPS;
        if on_pole(x).is_some() || on_pole(y).is_some() || !same_meridian(x, y) {
            continue;
        }
        for a in [x, y] {
            if is_constraint(a, q) {
                continue;
            }
            let neighbour =
                (0..tris.len()).find(|&g| g != f && tris[g].contains(&a) && tris[g].contains(&q));
            let Some(g) = neighbour else { continue };
            let Some(w) = third(tris[g], a, q) else {
                continue;
            };
            if on_pole(w).is_some() || same_meridian(w, x) {
                continue;
            }
            // Flip the diagonal a-q of the quadrilateral to the other one.
            let new = if a == x {
                [[x, y, w], [y, q, w]]
            } else {
                [[q, x, w], [x, y, w]]
            };
            if new.iter().all(|&[i, j, k]| ccw(i, j, k)) {
                tris[f] = new[0];
                tris[g] = new[1];
                break;
            }
        }
    }
}

/// The pole side `uv` lies on, if any (within [`MESH_SNAP_EPS`]: a cell side summed from
/// the grid may stop one rounding short of the square's side).
pub(super) fn pole_of(poles: [bool; 4], uv: DVec2) -> Option<usize> {
    let near = |a: f64, b: f64| (a - b).abs() <= MESH_SNAP_EPS;
    let on = [
        near(uv.x, 0.0),
        near(uv.x, 1.0),
        near(uv.y, 0.0),
        near(uv.y, 1.0),
    ];
    (0..4).find(|&k| poles[k] && on[k])
}

/// [`height`] at a pole `p`: each stroke's depth from the 3D point alone (the pole is
/// in a footprint wherever it lies within the stroke's half-width), since the footprint
/// in the square meets the pole's side along part of it only.
/// The point, normal and displacement of the pole on side `side`.
pub(super) fn pole_point(
    surface: &dyn ParamSurface,
    strokes: &[StrokeRef<'_>],
    side: usize,
) -> (DVec3, DVec3, f64) {
    let uv = pole_uv(side);
    let p = surface.eval(uv).p;
    // The normal: the mean of the normals on a small ring round the pole (at the pole
    // itself one derivative vanishes and the cross product is rounding noise).
    let ring: DVec3 = (0..8)
        .map(|k| {
            let t = f64::from(k) / 8.0;
            let (a, b) = (POLE_RING_PARAM, 1.0 - POLE_RING_PARAM);
            let q = match side {
                0 => DVec2::new(a, t),
                1 => DVec2::new(b, t),
                2 => DVec2::new(t, a),
                _ => DVec2::new(t, b),
            };
            normal_from(surface, q, &surface.eval(q))
        })
        .sum();
    let n = ring
        .try_normalize()
        .unwrap_or_else(|| normal_from(surface, uv, &surface.eval(uv)));
    (p, n, pole_height(strokes, p))
}

pub(crate) fn pole_height(strokes: &[StrokeRef<'_>], p: DVec3) -> f64 {
    let mut h: f64 = 0.0;
    for (_, s) in strokes {
        let d = s.depth_at_point(p);
        if d > 0.0 {
            h = match s.tool.mode {
                Mode::Carve => h.min(-d),
                Mode::Emboss => h.max(d),
            };
        }
    }
    h
}
