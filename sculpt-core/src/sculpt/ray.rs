//! Ray casting against target surfaces: where a pointer's ray (the desktop mouse seen
//! from the eye) first meets the document's targets.
//!
//! # Method
//!
//! **Sphere tracing** (Hart, *Sphere tracing: a geometric method for the antialiased
//! ray tracing of implicit surfaces*, The Visual Computer 12, 1996) with the target's
//! certified closest point ([`TargetSurface::closest_point_from`], P&T section 6.1
//! inside the branch and bound of [`crate::nurbs::invert`]) as the distance bound: at
//! `q = o + t d` the open ball of radius `dist = |S(uv*) - q|` about `q` holds no point
//! of the surface, so `t` may advance by `dist` without passing a hit. The march starts
//! where the ray enters the box of the control net (the surface lies in it, convex hull
//! property, P&T section 4.4) and ends where it leaves it: a ray that misses the box
//! costs no projection at all.
//!
//! Close to the surface the march slows down (linearly, by `1 - sin a` per step for a
//! ray at angle `a` to the surface), so once `dist` is below [`RAY_POLISH_REL`] times
//! the target's size the hit is **polished** by Newton's method on
//! `F(u, v, t) = S(u, v) - (o + t d) = 0`, Jacobian `[S_u  S_v  -d]`, from the foot
//! `uv*` and `t`. The polished hit is kept only when it lies no nearer than the empty
//! ball allows (`t' >= t + dist`) and within [`RAY_POLISH_WINDOW`] ball radii beyond
//! it; otherwise the march goes on (a grazing ray), ending at a foot within
//! [`POINT_EPS`].
//!
//! **What is certain.** Every step is bounded by a certified closest point, so no hit
//! nearer than the answer is passed over, except within the polish window (below
//! `RAY_POLISH_WINDOW * RAY_POLISH_REL`, about 64 micrometres on a 1 m target) and where
//! a projection was left unproven (its [`TargetProjection::certificate`], counted in
//! [`RayHit::certified`]). A ray that runs along the surface, closer than the polish
//! distance and not meeting it, is given up after [`MAX_TRACE_STEPS`] steps and counts
//! as a miss.
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::editor::{default_document, default_surface_point};
//! use sculpt_core::sculpt::ray::{Ray, cast_document};
//! use sculpt_core::tolerance::POINT_EPS;
//! let doc = default_document();
//! // From 1 m in front of the default sheet, straight at one of its points.
//! let on = default_surface_point(0.1, 1.2);
//! let ray = Ray::new(on + DVec3::Z, -DVec3::Z).unwrap();
//! let hit = cast_document(&doc, &ray).unwrap();
//! assert!(hit.hit.point.distance(on) < 10.0 * POINT_EPS);
//! assert_eq!(hit.target, doc.targets()[0].id);
//! ```

use glam::{DMat3, DVec2, DVec3};

use crate::sculpt::document::{Document, TargetId};
use crate::sculpt::surface::{ParamSurface, TargetProjection, TargetSurface, normal_at, wrap_uv};
use crate::tolerance::{POINT_EPS, RAY_POLISH_REL, SINGULAR_REL};

/// Sphere-tracing steps per target before a ray that keeps running along the surface
/// is given up (a miss).
pub const MAX_TRACE_STEPS: u32 = 512;
/// Newton iterations of one polish.
pub const MAX_POLISH_ITERS: u32 = 24;
/// A polished hit is kept within this many empty-ball radii beyond the march's point
/// (a ray at more than about 0.9 degrees to the surface); a farther one is a grazing
/// ray, marched on instead.
pub const RAY_POLISH_WINDOW: f64 = 64.0;

/// A ray `origin + t dir`, `t >= 0`, with a unit direction (display frame, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Where it starts.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: DVec3,
}

impl Ray {
    /// The ray from `origin` along `dir` (normalised); `None` when either is not finite
    /// or `dir` has no direction.
    pub fn new(origin: DVec3, dir: DVec3) -> Option<Self> {
        let dir = dir.try_normalize()?;
        origin.is_finite().then_some(Self { origin, dir })
    }

    /// The ray from `origin` through `through`; `None` when they coincide.
    pub fn through(origin: DVec3, through: DVec3) -> Option<Self> {
        Self::new(origin, through - origin)
    }

    /// The point at `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }

    /// Where the ray is inside the box `lo..hi` (slab test), as `(t_in, t_out)` with
    /// `t_in >= 0`; `None` when it misses the box or the box is behind it.
    pub fn box_span(&self, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
        let (mut t_in, mut t_out) = (0.0f64, f64::INFINITY);
        for k in 0..3 {
            let (o, d) = (self.origin[k], self.dir[k]);
            if d == 0.0 {
                if o < lo[k] || o > hi[k] {
                    return None;
                }
                continue;
            }
            let (a, b) = ((lo[k] - o) / d, (hi[k] - o) / d);
            t_in = t_in.max(a.min(b));
            t_out = t_out.min(a.max(b));
        }
        (t_in <= t_out).then_some((t_in, t_out))
    }
}

/// Where a ray meets a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance along the ray (metres).
    pub t: f64,
    /// The surface point `S(uv)` (display frame).
    pub point: DVec3,
    /// The parameter in the normalised square.
    pub uv: DVec2,
    /// The unit normal `S_u x S_v / |S_u x S_v|` there (it may face away from the ray:
    /// a target seen from behind).
    pub normal: DVec3,
    /// Every projection of the march was proven global (see the module docs).
    pub certified: bool,
    /// Sphere-tracing steps taken.
    pub steps: u32,
}

/// The first hit of `ray` on `target` at `t` in `[t_min, t_max]` (see the module
/// docs); `None` when it misses, or runs along the surface longer than
/// [`MAX_TRACE_STEPS`].
pub fn cast(target: &TargetSurface, ray: &Ray) -> Option<RayHit> {
    let (lo, hi) = target.surface().control_bounds();
    let size = (hi - lo).length();
    if !size.is_finite() {
        return None;
    }
    let pad = DVec3::splat(POINT_EPS);
    let (t_in, t_out) = ray.box_span(lo - pad, hi + pad)?;
    let polish_below = RAY_POLISH_REL * size;
    let closed = [
        target.surface().is_closed_u(),
        target.surface().is_closed_v(),
    ];
    let mut t = t_in;
    let mut seed: Option<DVec2> = None;
    let mut certified = true;
    for step in 0..MAX_TRACE_STEPS {
        if t > t_out {
            return None;
        }
        let q = ray.at(t);
        let pr: TargetProjection = match seed {
            Some(uv) => target.closest_point_from(q, uv),
            None => target.closest_point(q),
        };
        if !(pr.distance.is_finite() && pr.uv_in_square.is_finite()) {
            return None;
        }
        certified &= pr.certificate.is_certified();
        let dist = pr.distance;
        let hit = |t: f64, uv: DVec2, point: DVec3| RayHit {
            t,
            point,
            uv,
            normal: normal_at(target, uv),
            certified,
            steps: step + 1,
        };
        if dist <= POINT_EPS {
            return Some(hit(t, pr.uv_in_square, pr.point));
        }
        if dist <= polish_below
            && let Some((uv, tp, point)) = polish(target, ray, pr.uv_in_square, t, closed)
            && tp >= t + dist - POINT_EPS
            && tp <= t + RAY_POLISH_WINDOW * dist
        {
            return Some(hit(tp, uv, point));
        }
        seed = Some(pr.uv_in_square);
        t += dist;
    }
    None
}

/// Newton's method on `S(u, v) = o + t d` from `(uv, t)` (see the module docs): the
/// hit `(uv, t, S(uv))` when the residual falls to [`POINT_EPS`] with `uv` in the
/// square (wrapped in `closed` directions); `None` when the Jacobian is singular (the
/// ray tangent to the surface) or the iteration does not converge.
fn polish(
    target: &TargetSurface,
    ray: &Ray,
    mut uv: DVec2,
    mut t: f64,
    closed: [bool; 2],
) -> Option<(DVec2, f64, DVec3)> {
    for _ in 0..MAX_POLISH_ITERS {
        let sp = target.eval(uv);
        let r = sp.p - ray.at(t);
        if r.length() <= POINT_EPS {
            return Some((uv, t, sp.p));
        }
        let j = DMat3::from_cols(sp.du, sp.dv, -ray.dir);
        let scale = sp.du.length() * sp.dv.length();
        let det = j.determinant().abs();
        if det.is_nan() || det <= SINGULAR_REL * scale {
            return None;
        }
        let step = j.inverse() * -r;
        if !step.is_finite() {
            return None;
        }
        uv += DVec2::new(step.x, step.y);
        t += step.z;
        for k in 0..2 {
            uv[k] = if closed[k] {
                wrap_uv(uv)[k]
            } else {
                uv[k].clamp(0.0, 1.0)
            };
        }
    }
    None
}

/// A hit on one of a document's targets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DocumentHit {
    /// The target hit.
    pub target: TargetId,
    /// Where.
    pub hit: RayHit,
}

/// The first hit of `ray` over all of `doc`'s targets: each target whose control box
/// the ray enters before the best hit so far is cast ([`cast`]), nearest box first;
/// then each solid target ([`crate::solid::SolidTarget::cast`]).
pub fn cast_document(doc: &Document, ray: &Ray) -> Option<DocumentHit> {
    let mut order: Vec<(f64, usize)> = doc
        .targets()
        .iter()
        .enumerate()
        .filter_map(|(i, rec)| {
            let (lo, hi) = rec.surface.control_bounds();
            let pad = DVec3::splat(POINT_EPS);
            ray.box_span(lo - pad, hi + pad).map(|(t_in, _)| (t_in, i))
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best: Option<DocumentHit> = None;
    for (t_in, i) in order {
        if best.is_some_and(|b| b.hit.t < t_in) {
            break;
        }
        let rec = &doc.targets()[i];
        if let Some(hit) = cast(rec.target_surface(), ray)
            && best.is_none_or(|b| hit.t < b.hit.t)
        {
            best = Some(DocumentHit {
                target: rec.id,
                hit,
            });
        }
    }
    // The solid targets (issue 35): marched on their fields (no parameter: uv is 0).
    for s in doc.solids() {
        if let Some((t, point, normal)) = s.solid.cast(ray.origin, ray.dir)
            && best.is_none_or(|b| t < b.hit.t)
        {
            best = Some(DocumentHit {
                target: s.id,
                hit: RayHit {
                    t,
                    point,
                    uv: DVec2::ZERO,
                    normal,
                    certified: false,
                    steps: 0,
                },
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::editor::{DEFAULT_SURFACE_CENTER, default_document, default_surface_point};
    use crate::mesh::PatchMesh;
    use crate::sculpt::surface::test_surfaces::{plane, sphere, wavy};
    use crate::tolerance::{COSINE_EPS, RAY_HIT_TOL, RAY_MESH_TOL};
    use proptest::prelude::*;

    /// The default sheet's first hit by the quadratic its height field gives:
    /// `z(t) = c.z - (2 u(t)^2 + v(t)^2) / 4`, `u = x - c.x`, `v = (y - c.y) / 0.6`,
    /// over `|u| <= 0.5`, `|v| <= 0.5` (an independent reference: no NURBS, no
    /// projection).
    fn sheet_hit(ray: &Ray) -> Option<f64> {
        let c = DEFAULT_SURFACE_CENTER;
        let (o, d) = (ray.origin, ray.dir);
        let (u0, du) = (o.x - c.x, d.x);
        let (v0, dv) = ((o.y - c.y) / 0.6, d.y / 0.6);
        // g(t) = z(t) - height(t) = a t^2 + b t + e
        let a = 0.25 * (2.0 * du * du + dv * dv);
        let b = d.z + 0.5 * (2.0 * u0 * du + v0 * dv);
        let e = o.z - c.z + 0.25 * (2.0 * u0 * u0 + v0 * v0);
        let mut roots = Vec::new();
        if a.abs() < f64::EPSILON {
            if b != 0.0 {
                roots.push(-e / b);
            }
        } else {
            let disc = b * b - 4.0 * a * e;
            if disc >= 0.0 {
                let s = disc.sqrt();
                roots.push((-b - s) / (2.0 * a));
                roots.push((-b + s) / (2.0 * a));
            }
        }
        roots.sort_by(f64::total_cmp);
        roots.into_iter().find(|&t| {
            let p = ray.at(t);
            t >= 0.0 && (p.x - c.x).abs() <= 0.5 && ((p.y - c.y) / 0.6).abs() <= 0.5
        })
    }

    #[test]
    fn a_ray_at_the_plane_hits_where_the_plane_equation_says() {
        let t = plane(2.0);
        let ray = Ray::new(DVec3::new(0.3, 0.4, 1.5), DVec3::new(0.2, 0.1, -1.0)).unwrap();
        let hit = cast(&t, &ray).unwrap();
        let expected = 1.5 / -ray.dir.z;
        assert_near!(hit.t, expected, RAY_HIT_TOL);
        assert_near!(hit.point.z, 0.0, RAY_HIT_TOL);
        assert_near!(
            hit.uv.to_array(),
            (hit.point.truncate() / 2.0).to_array(),
            RAY_HIT_TOL
        );
        assert_near!(hit.normal.z.abs(), 1.0, COSINE_EPS);
        assert!(hit.certified);
        // Beyond the plane's edge, pointing away, parallel above it: misses.
        assert!(cast(&t, &Ray::new(DVec3::new(3.0, 0.4, 1.0), -DVec3::Z).unwrap()).is_none());
        assert!(cast(&t, &Ray::new(DVec3::new(0.3, 0.4, 1.0), DVec3::Z).unwrap()).is_none());
        assert!(cast(&t, &Ray::new(DVec3::new(-1.0, 0.4, 0.1), DVec3::X).unwrap()).is_none());
    }

    #[test]
    fn a_ray_through_the_sphere_hits_its_near_side_first() {
        let s = sphere(1.0);
        for dir in [
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(-1.0, -0.3, 0.2),
            // Towards the seam (-x) and a pole.
            DVec3::new(1.0, 0.001, 0.0),
            DVec3::new(0.0, 0.0, -1.0),
        ] {
            let origin = -dir.normalize() * 3.0 + DVec3::new(0.0, 0.1, 0.05);
            let ray = Ray::new(origin, dir).unwrap();
            // |o + t d|^2 = 1: the smaller root.
            let b = ray.origin.dot(ray.dir);
            let c = ray.origin.length_squared() - 1.0;
            let expected = -b - (b * b - c).sqrt();
            let hit = cast(&s, &ray).unwrap();
            assert_near!(hit.t, expected, RAY_HIT_TOL);
            assert_near!(hit.point.length(), 1.0, RAY_HIT_TOL);
            // The near side faces the ray.
            assert!(hit.normal.dot(ray.dir).abs() > COSINE_EPS);
        }
        // A ray starting inside meets the far side; one that passes by misses.
        let inside = Ray::new(DVec3::ZERO, DVec3::new(0.3, 0.2, 0.1)).unwrap();
        assert_near!(cast(&s, &inside).unwrap().t, 1.0, RAY_HIT_TOL);
        let by = Ray::new(DVec3::new(-3.0, 1.01, 0.0), DVec3::X).unwrap();
        assert!(cast(&s, &by).is_none());
    }

    #[test]
    fn bad_rays_are_refused() {
        assert!(Ray::new(DVec3::NAN, DVec3::X).is_none());
        assert!(Ray::new(DVec3::ZERO, DVec3::ZERO).is_none());
        assert!(Ray::new(DVec3::ZERO, DVec3::new(f64::INFINITY, 0.0, 0.0)).is_none());
        assert!(Ray::through(DVec3::ONE, DVec3::ONE).is_none());
    }

    /// A fine triangle grid of `target`'s points (the reference for the first hit of
    /// a ray: Moller-Trumbore over every triangle, [`PatchMesh::first_hit`]).
    fn grid_mesh(target: &TargetSurface, n: u32) -> PatchMesh {
        use crate::mesh::{MeshSink, MeshVertex};
        let mut mesh = PatchMesh::new();
        mesh.begin_patch(0);
        for i in 0..=n {
            for j in 0..=n {
                let uv = DVec2::new(f64::from(i), f64::from(j)) / f64::from(n);
                mesh.push_vertex(MeshVertex {
                    position: target.eval(uv).p.as_vec3().to_array(),
                    ..Default::default()
                });
            }
        }
        for i in 0..n {
            for j in 0..n {
                let at = |a: u32, b: u32| a * (n + 1) + b;
                mesh.push_triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1));
                mesh.push_triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1));
            }
        }
        mesh.end_patch();
        mesh
    }

    #[test]
    fn the_first_of_several_crossings_of_a_wavy_sheet_is_found() {
        // Rays at about 4.6 degrees to a sheet of 4 waves each way pass through several
        // crests; the answer is the first, as a fine mesh of the sheet says.
        let w = wavy(0.05);
        let mesh = grid_mesh(&w, 512);
        let mut crossings = 0;
        for k in 0..8 {
            let y = 0.1 + 0.1 * f64::from(k);
            let ray = Ray::new(DVec3::new(-0.2, y, 0.08), DVec3::new(1.0, 0.05, -0.08)).unwrap();
            let hit = cast(&w, &ray).unwrap();
            assert_near!(hit.point.distance(ray.at(hit.t)), 0.0, RAY_HIT_TOL);
            assert_near!(w.closest_point(hit.point).distance, 0.0, RAY_HIT_TOL);
            let reference = mesh
                .first_hit(ray.origin.to_array(), ray.dir.to_array())
                .unwrap();
            assert_near!(hit.t, reference, RAY_MESH_TOL);
            // The ray goes on through the sheet and meets it again farther on (so the
            // first hit is a choice).
            let beyond = ray.at(hit.t + 10.0 * RAY_MESH_TOL);
            let again = mesh.first_hit(beyond.to_array(), ray.dir.to_array());
            crossings += usize::from(again.is_some());
            if let Some(t) = again {
                let far = cast(&w, &Ray::new(beyond, ray.dir).unwrap()).unwrap();
                assert_near!(far.t, t, RAY_MESH_TOL);
            }
        }
        assert!(
            crossings >= 3,
            "only {crossings} rays cross the waves again"
        );
    }

    #[test]
    fn the_document_cast_picks_the_nearest_target() {
        let mut doc = default_document();
        // A second sheet 5 cm in front of the default one, over its left half.
        let front = crate::nurbs::NurbsSurface::plane(
            DVec3::new(-0.5, 0.9, 0.05),
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::new(0.0, 0.5, 0.0),
        )
        .unwrap();
        let front_id = doc.add_target("front", front);
        let default_id = doc.targets()[0].id;
        let left = Ray::new(DVec3::new(-0.2, 1.1, 1.0), -DVec3::Z).unwrap();
        let hit = cast_document(&doc, &left).unwrap();
        assert_eq!(hit.target, front_id);
        assert_near!(hit.hit.point.z, 0.05, RAY_HIT_TOL);
        let right = Ray::new(DVec3::new(0.2, 1.1, 1.0), -DVec3::Z).unwrap();
        let hit = cast_document(&doc, &right).unwrap();
        assert_eq!(hit.target, default_id);
        assert_near!(
            hit.hit.point.z,
            default_surface_point(0.2, 1.1).z,
            RAY_HIT_TOL
        );
        // Past everything: none.
        let miss = Ray::new(DVec3::new(2.0, 1.1, 1.0), -DVec3::Z).unwrap();
        assert!(cast_document(&doc, &miss).is_none());
        assert!(cast_document(&Document::new(), &right).is_none());
    }

    proptest! {
        /// Rays from an eye in front of the default sheet towards random points around
        /// it hit where the sheet's own quadratic says, or miss where it has no root.
        #[test]
        fn rays_at_the_default_sheet_agree_with_its_quadratic(
            ex in -0.4f64..0.4, ey in 0.9f64..1.4, ez in 0.3f64..1.5,
            tx in -0.7f64..0.7, ty in 0.7f64..1.65, tz in -0.4f64..-0.05,
        ) {
            let ray = Ray::through(DVec3::new(ex, ey, ez), DVec3::new(tx, ty, tz)).unwrap();
            let doc = default_document();
            let expected = sheet_hit(&ray);
            let got = cast_document(&doc, &ray);
            match (expected, got) {
                (Some(t), Some(h)) => {
                    assert_near!(h.hit.t, t, RAY_HIT_TOL);
                    assert!(h.hit.certified);
                }
                (None, None) => {}
                (e, g) => prop_assert!(false, "expected {e:?}, got {g:?}"),
            }
        }
    }
}
