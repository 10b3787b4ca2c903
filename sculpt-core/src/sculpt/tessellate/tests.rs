use super::*;
use crate::assert_near;
use crate::mesh::PatchMesh;
use crate::sculpt::jordan::Location;
use crate::sculpt::stroke::{Mode, Stroke};
use crate::sculpt::stroke::{Profile, StrokeInput, Tool};
use crate::sculpt::surface::TargetSurface;
use crate::sculpt::surface::test_surfaces::{plane, sphere, wavy};
use crate::tolerance::{
    EXPORT_WELD_EPS, F32_EPS, GROOVE_TOL, MESH_DEPTH_TOL, MESH_HIT_EPS, TEST_WELD_EPS,
};
use glam::{DVec2, DVec3};

fn tool(mode: Mode, profile: Profile) -> Tool {
    Tool {
        profile,
        width: 0.1,
        depth: 0.02,
        mode,
        taper: 0.05,
    }
}

fn stroke(s: &TargetSurface, a: DVec3, b: DVec3, t: Tool) -> Stroke {
    let samples = (0..40)
        .map(|i| {
            let f = i as f64 / 39.0;
            (f, a.lerp(b, f))
        })
        .collect();
    Stroke::build(s, &StrokeInput { samples, tool: t }, 0.2).unwrap()
}

/// Depth below the plane z = 0 of the first hit of a ray coming down at (x, y).
fn depth_at(mesh: &PatchMesh, x: f64, y: f64) -> f64 {
    let t = mesh
        .first_hit([x, y, 1.0], [0.0, 0.0, -1.0])
        .expect("a hit");
    t - 1.0
}

#[test]
fn carved_groove_on_a_plane_has_tool_depth_and_no_cracks() {
    let s = plane(1.0);
    let a = stroke(
        &s,
        DVec3::new(0.2, 0.5, 0.0),
        DVec3::new(0.8, 0.5, 0.0),
        tool(Mode::Carve, Profile::V),
    );
    for detail in [Detail::Interactive, Detail::Final] {
        let mut tess = TargetTessellation::new(&s, 0, detail);
        let mut mesh = PatchMesh::new();
        tess.update(&s, &[(1, &a)], None, &mut mesh);
        // Groove bottom at the tool depth, half depth half-way to the rim, flat outside.
        assert_near!(depth_at(&mesh, 0.5, 0.5), 0.02, F32_EPS);
        assert_near!(depth_at(&mesh, 0.43, 0.5 + 0.025), 0.01, MESH_DEPTH_TOL);
        assert_near!(depth_at(&mesh, 0.5, 0.6), 0.0, F32_EPS);
        assert_near!(depth_at(&mesh, 0.1, 0.1), 0.0, F32_EPS);
        // Crack-free: the only open edges are the outer border of the square.
        let w = mesh.welded(EXPORT_WELD_EPS);
        let r = w.edge_report();
        assert_eq!(r.non_manifold, 0);
        assert_eq!(r.misoriented, 0);
        let border: usize = w
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .filter(|&(a, b)| {
                let (p, q) = (
                    w.vertices[a as usize].position,
                    w.vertices[b as usize].position,
                );
                let on = |x: f32| x.abs() < EXPORT_WELD_EPS || (x - 1.0).abs() < EXPORT_WELD_EPS;
                (on(p[0]) && p[0] == q[0]) || (on(p[1]) && p[1] == q[1])
            })
            .count();
        assert_eq!(
            r.boundary, border,
            "{detail:?}: open edges inside the square"
        );
    }
}

#[test]
fn crossing_grooves_take_the_deeper_and_emboss_rises() {
    let s = plane(1.0);
    let a = stroke(
        &s,
        DVec3::new(0.2, 0.5, 0.0),
        DVec3::new(0.8, 0.5, 0.0),
        tool(Mode::Carve, Profile::V),
    );
    let mut deep = tool(Mode::Carve, Profile::U);
    deep.depth = 0.03;
    let b = stroke(
        &s,
        DVec3::new(0.5, 0.2, 0.0),
        DVec3::new(0.5, 0.8, 0.0),
        deep,
    );
    let c = stroke(
        &s,
        DVec3::new(0.2, 0.2, 0.0),
        DVec3::new(0.4, 0.3, 0.0),
        tool(Mode::Emboss, Profile::U),
    );
    let mut tess = TargetTessellation::new(&s, 0, Detail::Final);
    let mut mesh = PatchMesh::new();
    tess.update(&s, &[(1, &a), (2, &b), (3, &c)], None, &mut mesh);
    assert_near!(depth_at(&mesh, 0.5, 0.5), 0.03, F32_EPS);
    // On a's axis, 0.03 from b's axis: b (U, r/w = 0.6) is 0.03 * 0.8 = 0.024 deep,
    // a's V bottom is 0.02: the deeper wins. (The U profile is sampled at a few
    // fractions of its half-width: its chord error is a few percent of the depth.)
    assert_near!(depth_at(&mesh, 0.53, 0.5), 0.024, MESH_HIT_EPS);
    assert_near!(depth_at(&mesh, 0.3, 0.25), -0.02, GROOVE_TOL);
    assert_eq!(mesh.welded(EXPORT_WELD_EPS).edge_report().non_manifold, 0);
}

#[test]
fn only_changed_patches_are_rewritten() {
    let s = wavy(0.02);
    let a = stroke(
        &s,
        DVec3::new(0.2, 0.2, 0.0),
        DVec3::new(0.3, 0.2, 0.0),
        tool(Mode::Carve, Profile::V),
    );
    let b = stroke(
        &s,
        DVec3::new(0.7, 0.7, 0.0),
        DVec3::new(0.8, 0.7, 0.0),
        tool(Mode::Carve, Profile::V),
    );
    let mut tess = TargetTessellation::new(&s, 0, Detail::Interactive);
    let mut mesh = PatchMesh::new();
    let first = tess.update(&s, &[(1, &a)], None, &mut mesh);
    assert_eq!(
        first.patches_written,
        (tess.map().n() * tess.map().n()) as usize
    );
    let second = tess.update(&s, &[(1, &a), (2, &b)], Some(b.bounds), &mut mesh);
    assert!(second.patches_written > 0 && second.patches_written < first.patches_written / 2);
    // The incremental mesh equals a fresh one.
    let mut fresh = PatchMesh::new();
    TargetTessellation::new(&s, 0, Detail::Interactive).update(
        &s,
        &[(1, &a), (2, &b)],
        None,
        &mut fresh,
    );
    for ((ka, pa), (kb, pb)) in mesh.patches().zip(fresh.patches()) {
        assert_eq!(ka, kb);
        assert!(pa == pb, "patch {ka}: {pa:?}\n{pb:?}");
    }
    assert_eq!(mesh, fresh);
}

#[test]
fn carved_sphere_is_watertight() {
    let s = sphere(1.0);
    let t = Tool {
        profile: Profile::V,
        width: 0.3,
        depth: 0.05,
        mode: Mode::Carve,
        taper: 0.1,
    };
    let a = stroke(
        &s,
        DVec3::new(-1.0, -0.3, 0.3),
        DVec3::new(-0.2, -1.0, -0.2),
        t.clone(),
    );
    let b = stroke(
        &s,
        DVec3::new(-0.6, -1.0, 0.3),
        DVec3::new(-1.0, 0.1, -0.3),
        t.clone(),
    );
    // Across the seam (u = 0 = 1 at -x): the groove wraps, still watertight.
    let c = stroke(
        &s,
        DVec3::new(-0.9, 0.45, 0.1),
        DVec3::new(-0.9, -0.4, -0.1),
        t,
    );
    assert_eq!(
        (c.bounds.min.x, c.bounds.max.x),
        (0.0, 1.0),
        "{:?}",
        c.bounds
    );
    let mut tess = TargetTessellation::new(&s, 0, Detail::Final);
    let mut mesh = PatchMesh::new();
    tess.update(&s, &[(1, &a), (2, &b), (3, &c)], None, &mut mesh);
    let r = mesh.welded(EXPORT_WELD_EPS).edge_report();
    assert!(r.is_watertight(), "{r:?}");
    let (v, _) = mesh.merged();
    assert!(
        v.iter()
            .all(|v| v.position.iter().chain(&v.normal).all(|x| x.is_finite()))
    );
}

/// The uv distance from `uv` to the nearest segment of `outline`.
fn outline_distance(outline: &[[DVec2; 2]], uv: DVec2) -> f64 {
    outline
        .iter()
        .map(|s| super::super::jordan::point_segment_distance(uv, s[0], s[1]))
        .fold(f64::INFINITY, f64::min)
}

/// Triangles of a welded mesh as uv triangles (on `plane(1.0)` the position is the uv).
fn uv_triangles(mesh: &PatchMesh) -> (Vec<[DVec2; 3]>, Vec<[u32; 3]>) {
    let w = mesh.welded(EXPORT_WELD_EPS);
    let uv = |i: u32| {
        let p = w.vertices[i as usize].position;
        DVec2::new(f64::from(p[0]), f64::from(p[1]))
    };
    (
        w.triangles.iter().map(|t| t.map(uv)).collect(),
        w.triangles.clone(),
    )
}

fn longest_edge(t: &[DVec2; 3]) -> f64 {
    (0..3)
        .map(|k| t[k].distance(t[(k + 1) % 3]))
        .fold(0.0, f64::max)
}

/// Regression for issue 20 (sawtooth rims: long thin fans ran from a groove's fine
/// rim to the coarse root grid). The criterion, at both details, for a V and a U
/// groove and a curved stroke on a plane:
/// - every triangle with a vertex on the rim (the footprint outline) has all its
///   edges at most `RIM_REACH` times the rim spacing `h` (the larger of the longest
///   outline segment and the side of a leaf at the depth cap), shorter than a root
///   cell's side;
/// - every triangle's size (longest edge) is at most `GRADE (h + d)`, `d` its
///   distance from the rim: sizes grow with the distance from the rim, one quadtree
///   level at a time (the balanced tree), not in a jump from the rim to a root cell
///   (a fan with a vertex on the rim and a root cell's side fails both checks).
#[test]
fn mesh_is_graded_from_the_rim_to_the_root_grid() {
    const RIM_REACH: f64 = 2.0;
    const GRADE: f64 = 2.5;
    let s = plane(1.0);
    let curved = {
        let samples = (0..60)
            .map(|i| {
                let f = i as f64 / 59.0;
                let a = f * 2.5;
                (f, DVec3::new(0.5 + 0.3 * a.cos(), 0.5 + 0.3 * a.sin(), 0.0))
            })
            .collect();
        Stroke::build(
            &s,
            &StrokeInput {
                samples,
                tool: tool(Mode::Carve, Profile::V),
            },
            0.2,
        )
        .unwrap()
    };
    let straight_u = stroke(
        &s,
        DVec3::new(0.15, 0.3, 0.0),
        DVec3::new(0.85, 0.45, 0.0),
        tool(Mode::Carve, Profile::U),
    );
    let mut checked = 0;
    for st in [&curved, &straight_u] {
        for detail in [Detail::Interactive, Detail::Final] {
            let mut tess = TargetTessellation::new(&s, 0, detail);
            let mut mesh = PatchMesh::new();
            tess.update(&s, &[(1, st)], None, &mut mesh);
            let outline = tess.hidden().segments().to_vec();
            let n = f64::from(tess.map().n());
            let leaf = 1.0 / (n * f64::from(1u32 << detail.cap()));
            let rim_spacing = outline
                .iter()
                .map(|s| s[0].distance(s[1]))
                .fold(0.0, f64::max);
            let h = rim_spacing.max(leaf);
            // A fan to the root grid would fail the test.
            assert!(1.0 / n > RIM_REACH * h, "{detail:?}: the test cannot fail");
            let (tris, _) = uv_triangles(&mesh);
            let on_rim = |p: DVec2| outline_distance(&outline, p) <= F32_EPS;
            for t in &tris {
                if t.iter().any(|&p| on_rim(p)) {
                    checked += 1;
                    assert!(
                        longest_edge(t) <= RIM_REACH * h,
                        "{detail:?}: a triangle at the rim spans {} (rim spacing {h}): {t:?}",
                        longest_edge(t)
                    );
                }
            }
            // Sizes grow with the distance from the rim, not in jumps.
            let mut worst: f64 = 0.0;
            for t in &tris {
                let d = t
                    .iter()
                    .map(|&p| outline_distance(&outline, p))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(longest_edge(t) / (h + d));
            }
            assert!(
                worst <= GRADE,
                "{detail:?}: a triangle {worst} x (h + its distance)"
            );
            assert!(
                worst <= GRADE,
                "{detail:?}: neighbouring triangles differ {worst}x"
            );
        }
    }
    assert!(checked > 100, "only {checked} rim triangles");
}

/// Issue 20: normals come from the exact geometry, split at sharp edges. On a plane,
/// a straight V groove's walls are planes: away from the tapered ends every corner
/// of a wall triangle carries exactly its face's normal (no averaging across the
/// crease or the rim), the flat target carries +z, and each bottom vertex is written
/// twice, once per wall.
#[test]
fn v_groove_normals_are_exact_and_split_at_the_crease_and_rims() {
    let s = plane(1.0);
    let a = stroke(
        &s,
        DVec3::new(0.2, 0.5, 0.0),
        DVec3::new(0.8, 0.5, 0.0),
        tool(Mode::Carve, Profile::V),
    );
    for detail in [Detail::Interactive, Detail::Final] {
        let mut tess = TargetTessellation::new(&s, 0, detail);
        let mut mesh = PatchMesh::new();
        tess.update(&s, &[(1, &a)], None, &mut mesh);
        let (mut walls, mut flat, mut bottom) = (0, 0, Vec::new());
        for (_, patch) in mesh.patches() {
            for t in &patch.triangles {
                let v = t.map(|i| patch.vertices[i as usize]);
                let p = v.map(|v| DVec3::from_array(v.position.map(f64::from)));
                let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                let middle = p.iter().all(|q| q.x > 0.3 && q.x < 0.7);
                let sunk = p.iter().any(|q| q.z < -f64::from(TEST_WELD_EPS));
                for c in &v {
                    let n = DVec3::from_array(c.normal.map(f64::from));
                    if !sunk && p.iter().all(|q| (q.y - 0.5).abs() > 0.06) {
                        assert!(n.distance(DVec3::Z) < F32_EPS, "{detail:?}: flat {n}");
                        flat += 1;
                    }
                    if sunk && middle {
                        assert!(
                            n.distance(face) < MESH_DEPTH_TOL,
                            "{detail:?}: {n} on face {face} at {p:?}"
                        );
                        // The wall's slope: depth over half-width.
                        assert_near!(n.y.abs() / n.z, 0.02 / 0.05, MESH_DEPTH_TOL);
                        walls += 1;
                    }
                    if middle && (f64::from(c.position[2]) + 0.02).abs() < F32_EPS {
                        bottom.push(c.position.map(f32::to_bits));
                    }
                }
            }
        }
        assert!(walls > 50 && flat > 50, "{detail:?}: {walls} {flat}");
        // Each bottom vertex appears with two normals (as two written vertices).
        let mut verts: Vec<([u32; 3], [u32; 3])> = Vec::new();
        for (_, patch) in mesh.patches() {
            for v in &patch.vertices {
                if bottom.contains(&v.position.map(f32::to_bits)) {
                    verts.push((v.position.map(f32::to_bits), v.normal.map(f32::to_bits)));
                }
            }
        }
        verts.sort_unstable();
        verts.dedup();
        let mut positions: Vec<[u32; 3]> = verts.iter().map(|v| v.0).collect();
        positions.dedup();
        assert!(positions.len() > 4, "{detail:?}: {}", positions.len());
        assert_eq!(
            verts.len(),
            2 * positions.len(),
            "{detail:?}: crease not split {verts:?}"
        );
    }
}

/// Issue 20: groove walls are triangulated as strips along the stroke. On a plane,
/// a straight groove's profile sample lines are lines of constant distance from the
/// centreline; every triangle inside the groove has its corners on those lines
/// (leaf corners inside the strip are left out; the root grid's corners, which every
/// cell keeps, are the exception), spans one profile interval across the stroke and
/// at most one sample step along it. The quadtree's leaf corners, which the groove
/// kept before, sat between the lines and failed this.
#[test]
fn groove_walls_are_strips_along_the_stroke() {
    let s = plane(1.0);
    let mut checked = 0;
    for profile in [Profile::V, Profile::U] {
        let a = stroke(
            &s,
            DVec3::new(0.2, 0.5, 0.0),
            DVec3::new(0.8, 0.5, 0.0),
            tool(Mode::Carve, profile.clone()),
        );
        let step = a
            .centre_uv
            .windows(2)
            .map(|w| w[0].distance(w[1]))
            .fold(0.0, f64::max);
        let hw = a.half_width[a.half_width.len() / 2];
        for detail in [Detail::Interactive, Detail::Final] {
            let mut levels = vec![0.0];
            levels.extend_from_slice(detail.profile_lines(profile.is_curved()));
            levels.push(1.0);
            let level_of = |y: f64| {
                let f = (y - 0.5).abs() / hw;
                levels.iter().position(|&l| (l - f).abs() <= F32_EPS / hw)
            };
            let mut tess = TargetTessellation::new(&s, 0, detail);
            let mut mesh = PatchMesh::new();
            tess.update(&s, &[(1, &a)], None, &mut mesh);
            let n = f64::from(tess.map().n());
            let on_grid = |x: f64| ((x * n).round() - x * n).abs() <= F32_EPS * n;
            let (tris, _) = uv_triangles(&mesh);
            for t in &tris {
                let centre = (t[0] + t[1] + t[2]) / 3.0;
                let inside =
                    (centre.y - 0.5).abs() < hw && t.iter().all(|p| p.x > 0.3 && p.x < 0.7);
                if !inside || t.iter().any(|p| on_grid(p.x) && on_grid(p.y)) {
                    continue;
                }
                let lv: Vec<usize> = t
                    .iter()
                    .map(|p| {
                        level_of(p.y).unwrap_or_else(|| {
                            panic!("{profile:?} {detail:?}: corner {p} off the profile lines")
                        })
                    })
                    .collect();
                let (lo, hi) = (lv.iter().min().unwrap(), lv.iter().max().unwrap());
                assert!(
                    hi - lo <= 1,
                    "{profile:?} {detail:?}: {t:?} spans {lo}..{hi}"
                );
                let (x0, x1) = t
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                        (a.min(p.x), b.max(p.x))
                    });
                assert!(
                    x1 - x0 <= step + F32_EPS,
                    "{profile:?} {detail:?}: {t:?} along"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 200, "only {checked} groove triangles");
}

/// Regression (issue 30 §4, the demo's ridge over a groove): where an embossed ridge
/// crosses an earlier carved groove, the combined height steps on the ridge's outline
/// (the ridge's height is zero there, the groove's is not). That outline was no mesh
/// edge, so triangles straddled it, each pulled up by its corners inside the ridge: the
/// groove's end was a staircase. Now the ridge's outline inside the groove is a chain
/// of constraint edges ([`patch::step_segments`]) whose vertices keep the groove's
/// height: every triangle outside the ridge and inside the groove has the groove's
/// height at all its corners, at both details, and the mesh stays crack-free.
#[test]
fn a_ridge_over_a_groove_steps_along_its_outline() {
    let s = plane(1.0);
    let groove = stroke(
        &s,
        DVec3::new(0.2, 0.5, 0.0),
        DVec3::new(0.8, 0.5, 0.0),
        tool(Mode::Carve, Profile::V),
    );
    let ridge = stroke(
        &s,
        DVec3::new(0.3, 0.2, 0.0),
        DVec3::new(0.7, 0.8, 0.0),
        tool(Mode::Emboss, Profile::V),
    );
    let strokes = [(1, &groove), (2, &ridge)];
    assert!(!patch::step_segments(&strokes).is_empty());
    for detail in [Detail::Interactive, Detail::Final] {
        let mut tess = TargetTessellation::new(&s, 0, detail);
        let mut mesh = PatchMesh::new();
        tess.update(&s, &strokes, None, &mut mesh);
        let (verts, tris) = mesh.merged();
        let mut checked = 0;
        let mut straddling = Vec::new();
        for t in &tris {
            let vs = t.map(|i| verts[i as usize]);
            let uv = vs.map(|v| DVec2::new(f64::from(v.uv[0]), f64::from(v.uv[1])));
            let centroid = (uv[0] + uv[1] + uv[2]) / 3.0;
            if ridge.footprint.locate(centroid) != Location::Outside
                || groove.footprint.locate(centroid) != Location::Inside
            {
                continue;
            }
            checked += 1;
            for (v, uv) in vs.iter().zip(uv) {
                // On the plane z = 0 the displacement is z; the groove's alone here.
                let want = height(&[(1, &groove)], uv, uv.extend(0.0));
                let got = f64::from(v.position[2]);
                if (got - want).abs() > MESH_DEPTH_TOL {
                    straddling.push((uv, got, want));
                }
            }
        }
        assert!(
            checked > 10,
            "{detail:?}: {checked} triangles in the groove"
        );
        assert!(
            straddling.is_empty(),
            "{detail:?}: {} corners of triangles outside the ridge off the groove's \
             height, first {:?}",
            straddling.len(),
            straddling.first()
        );
        let r = mesh.welded(EXPORT_WELD_EPS).edge_report();
        assert_eq!((r.non_manifold, r.misoriented), (0, 0), "{detail:?}");
    }
}
