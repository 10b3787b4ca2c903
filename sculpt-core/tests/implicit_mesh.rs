//! Meshes of implicit solids are closed, 2-manifold and consistently oriented, with
//! the Euler characteristic of their topology, and lie within half a cell of the
//! surface. Checked by an independent half-edge walk written here, not the crate's
//! own edge report.

use std::collections::{HashMap, HashSet};

use sculpt_core::assert_near;
use sculpt_core::implicit::Model;
use sculpt_core::implicit::contour::contour;
use sculpt_core::mesh::WeldedMesh;

/// What the half-edge walk found.
#[derive(Debug)]
struct Topology {
    vertices: usize,
    edges: usize,
    faces: usize,
    /// Connected components (by shared edges).
    components: usize,
}

/// Builds half-edges and checks: every directed edge appears once, its twin once
/// (closed, edge-manifold, consistently oriented); the faces around each vertex form
/// one cycle (vertex-manifold); no triangle repeats a vertex.
fn half_edge_check(mesh: &WeldedMesh) -> Topology {
    let mut next: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "degenerate triangle {t:?}"
        );
        for e in 0..3 {
            let (a, b, c) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
            assert!(
                next.insert((a, b), c).is_none(),
                "directed edge {a}->{b} used twice"
            );
        }
    }
    for &(a, b) in next.keys() {
        assert!(
            next.contains_key(&(b, a)),
            "edge {a}->{b} has no twin: a hole or a flipped triangle"
        );
    }
    // Vertex-manifold: walking a -> b, then around a by twins, visits every outgoing
    // half-edge of a in one cycle.
    let mut outgoing: HashMap<u32, Vec<u32>> = HashMap::new();
    for &(a, b) in next.keys() {
        outgoing.entry(a).or_default().push(b);
    }
    for (&a, outs) in &outgoing {
        let start = outs[0];
        let mut b = start;
        let mut seen = 0;
        loop {
            // The triangle (a, b, c): the next outgoing edge around a is a -> c.
            let c = next[&(a, b)];
            seen += 1;
            b = c;
            if b == start || seen > outs.len() {
                break;
            }
        }
        assert_eq!(
            seen,
            outs.len(),
            "vertex {a}: its faces form more than one fan"
        );
    }
    let used: HashSet<u32> = mesh.triangles.iter().flatten().copied().collect();
    // Components by union-find over edges.
    let mut parent: HashMap<u32, u32> = used.iter().map(|&v| (v, v)).collect();
    fn find(p: &mut HashMap<u32, u32>, v: u32) -> u32 {
        let mut r = v;
        while p[&r] != r {
            r = p[&r];
        }
        p.insert(v, r);
        r
    }
    for &(a, b) in next.keys() {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        parent.insert(ra, rb);
    }
    let roots: HashSet<u32> = used.iter().map(|&v| find(&mut parent, v)).collect();
    Topology {
        vertices: used.len(),
        edges: next.len() / 2,
        faces: mesh.triangles.len(),
        components: roots.len(),
    }
}

fn euler(t: &Topology) -> i64 {
    t.vertices as i64 - t.edges as i64 + t.faces as i64
}

/// Signed volume by the divergence theorem (positive for outward orientation).
fn volume(mesh: &WeldedMesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.vertices[i as usize].position.map(f64::from));
            let c = [
                p[1][1] * p[2][2] - p[1][2] * p[2][1],
                p[1][2] * p[2][0] - p[1][0] * p[2][2],
                p[1][0] * p[2][1] - p[1][1] * p[2][0],
            ];
            (p[0][0] * c[0] + p[0][1] * c[1] + p[0][2] * c[2]) / 6.0
        })
        .sum()
}

/// Closed, manifold, oriented, one component, Euler characteristic `chi`.
fn assert_closed(mesh: &WeldedMesh, chi: i64) {
    let t = half_edge_check(mesh);
    assert_eq!((euler(&t), t.components), (chi, 1), "{t:?}");
}

fn mesh_of(json: &str, res: usize, lo: f64, hi: f64) -> (Model, WeldedMesh) {
    let model = Model::from_solid_json(json).unwrap();
    let mesh = contour(&model.tape_negative_inside(), [res; 3], [lo; 3], [hi; 3]).unwrap();
    (model, mesh)
}

/// A sphere meshed by `make` is closed, with Euler characteristic 2, its vertices
/// within half a cell of the surface and its volume within 5 %.
fn check_sphere(make: fn(&str, usize, f64, f64) -> (Model, WeldedMesh)) {
    let (_, mesh) = make(
        r#"{"solid": {"sphere": {"center": [0.1, 0.0, -0.05], "radius": 0.8}}}"#,
        24,
        -1.0,
        1.0,
    );
    assert_closed(&mesh, 2);
    let half_cell = 0.5 * 2.0 / 24.0;
    for v in &mesh.vertices {
        let p = v.position.map(f64::from);
        let d = ((p[0] - 0.1).powi(2) + p[1].powi(2) + (p[2] + 0.05).powi(2)).sqrt() - 0.8;
        assert!(d.abs() <= half_cell, "vertex {p:?} is {d} from the sphere");
    }
    let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.8f64.powi(3);
    assert_near!(volume(&mesh), exact, 0.05 * exact);
}

#[test]
fn sphere_is_a_closed_sphere_near_the_surface() {
    check_sphere(mesh_of);
}

/// A tilted torus meshed by `make` is closed, with Euler characteristic 0, its
/// vertices within half a cell of the surface and a positive volume.
fn check_torus(make: fn(&str, usize, f64, f64) -> (Model, WeldedMesh)) {
    let (_, mesh) = make(
        r#"{"solid": {"torus": {"center": [0, 0, 0], "axis": [0.2, 0.1, 1], "major": 0.6, "minor": 0.25}}}"#,
        32,
        -1.0,
        1.0,
    );
    assert_closed(&mesh, 0);
    let half_cell = 0.5 * 2.0 / 32.0;
    let n = {
        let a = [0.2f64, 0.1, 1.0];
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|c| c / l)
    };
    for v in &mesh.vertices {
        let p = v.position.map(f64::from);
        let t = p[0] * n[0] + p[1] * n[1] + p[2] * n[2];
        let rho = ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - t * t)
            .max(0.0)
            .sqrt();
        let d = ((rho - 0.6).powi(2) + t * t).sqrt() - 0.25;
        assert!(d.abs() <= half_cell, "vertex {p:?} is {d} from the torus");
    }
    assert!(
        volume(&mesh) > 0.0,
        "outward orientation gives a positive volume"
    );
}

/// A CSG part: a box with a cylindrical hole through it and a spherical bite out of a
/// corner (genus 1), R_0 conjunctions throughout.
#[test]
fn torus_has_euler_characteristic_zero() {
    check_torus(mesh_of);
}

#[test]
fn csg_part_with_a_hole_is_a_closed_torus_topologically() {
    let json = r#"{"solid": {"and": {"solids": [
        {"box": {"min": [-0.7, -0.5, -0.3], "max": [0.7, 0.5, 0.3]}},
        {"not": {"solid": {"cylinder": {"base": [0, 0, -1], "axis": [0, 0, 1], "radius": 0.25, "height": 2}}}},
        {"not": {"solid": {"sphere": {"center": [0.7, 0.5, 0.3], "radius": 0.3}}}}
    ]}}}"#;
    let (model, mesh) = mesh_of(json, 40, -1.0, 1.0);
    assert_closed(&mesh, 0);
    // The function is distance-like (|grad| near 1) away from the edges; its value
    // at each vertex is within half a cell of 0.
    let tape = model.tape_positive_inside();
    let half_cell = 0.5 * 2.0 / 40.0;
    for v in &mesh.vertices {
        let w = f64::from(tape.eval_point(v.position));
        assert!(w.abs() <= half_cell, "omega {w} at vertex {:?}", v.position);
    }
    assert!(volume(&mesh) > 0.0);
}

/// A solid that leaves the sampling box is closed off at the box's faces.
#[test]
fn solids_cut_by_the_box_are_closed() {
    let (_, mesh) = mesh_of(
        r#"{"solid": {"sphere": {"center": [0, 0, 0], "radius": 1.5}}}"#,
        10,
        -1.0,
        1.0,
    );
    assert_closed(&mesh, 2);
    // Nearly the whole box: the outer layer of corners is outside.
    assert_near!(volume(&mesh), 8.0, 0.7 * 8.0);
}

/// A Fidget-style `.vm` model (negative inside) meshes the same as the equivalent
/// solid document; the STL round trip keeps it closed.
#[test]
fn vm_model_meshes_and_survives_stl() {
    let text = "x var-x\ny var-y\nz var-z\nxx square x\nyy square y\nzz square z\n\
                s add xx yy\ns2 add s zz\nr sqrt s2\nc const 0.7\nd sub r c\n";
    let model = Model::from_vm(text).unwrap();
    let mesh = contour(&model.tape_negative_inside(), [16; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let t = half_edge_check(&mesh);
    assert_eq!(euler(&t), 2);
    let bytes = sculpt_core::formats::stl::write(&mesh).unwrap();
    let back = sculpt_core::formats::stl::read(&bytes).unwrap();
    let welded = sculpt_core::mesh::weld(
        &back.vertices,
        &back.triangles,
        sculpt_core::tolerance::POINT_WELD_EPS,
    );
    let t2 = half_edge_check(&welded);
    assert_eq!(
        (t2.vertices, t2.faces, euler(&t2)),
        (t.vertices, t.faces, 2)
    );
}

// Dual contouring (`implicit::dual`): the same checks, and sharp edges.

use sculpt_core::implicit::dual::dual_contour;
use sculpt_core::tolerance::DUAL_EDGE_CELL_FRAC;

fn dual_of(json: &str, res: usize, lo: f64, hi: f64) -> (Model, WeldedMesh) {
    let model = Model::from_solid_json(json).unwrap();
    let (mesh, report) =
        dual_contour(&model.tape_negative_inside(), [res; 3], [lo; 3], [hi; 3]).unwrap();
    assert!(report.fans > 0, "{report:?}");
    eprintln!("{report:?}");
    (model, mesh)
}

#[test]
fn dual_sphere_and_torus_are_closed_near_the_surface() {
    check_sphere(dual_of);
    check_torus(dual_of);
}

/// The distance from `q` to the triangle `p` (Ericson, *Real-Time Collision
/// Detection*, 5.1.5, by regions).
fn point_triangle(q: [f64; 3], p: [[f64; 3]; 3]) -> f64 {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let at = |a: [f64; 3], d: [f64; 3], t: f64| [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]];
    let (ab, ac, ap) = (sub(p[1], p[0]), sub(p[2], p[0]), sub(q, p[0]));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    let closest = if d1 <= 0.0 && d2 <= 0.0 {
        p[0]
    } else {
        let bp = sub(q, p[1]);
        let (d3, d4) = (dot(ab, bp), dot(ac, bp));
        let cp = sub(q, p[2]);
        let (d5, d6) = (dot(ab, cp), dot(ac, cp));
        let (va, vb, vc) = (d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2);
        if d3 >= 0.0 && d4 <= d3 {
            p[1]
        } else if d6 >= 0.0 && d5 <= d6 {
            p[2]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            at(p[0], ab, d1 / (d1 - d3))
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            at(p[0], ac, d2 / (d2 - d6))
        } else if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
            at(p[1], sub(p[2], p[1]), (d4 - d3) / ((d4 - d3) + (d5 - d6)))
        } else {
            let den = 1.0 / (va + vb + vc);
            let (v, w) = (vb * den, vc * den);
            [0, 1, 2].map(|c| p[0][c] + ab[c] * v + ac[c] * w)
        }
    };
    dot(sub(q, closest), sub(q, closest)).sqrt()
}

/// Along the box's edges (away from its corners): the largest distance from a point on
/// an edge to the mesh, and the largest over those points of the distance to the edge
/// of the mesh vertex within a cell of the point that lies closest to the edge.
fn edge_error(mesh: &WeldedMesh, lo: [f64; 3], hi: [f64; 3], cell: f64) -> (f64, f64) {
    let tris: Vec<[[f64; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| mesh.vertices[i as usize].position.map(f64::from)))
        .collect();
    let mut worst = 0.0f64;
    let mut worst_vertex = 0.0f64;
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for (cu, cv) in [
            (lo[u], lo[v]),
            (lo[u], hi[v]),
            (hi[u], lo[v]),
            (hi[u], hi[v]),
        ] {
            for s in 1..20 {
                let t = 0.1 + 0.8 * s as f64 / 20.0;
                let mut q = [0.0; 3];
                q[axis] = lo[axis] + t * (hi[axis] - lo[axis]);
                q[u] = cu;
                q[v] = cv;
                let d = tris
                    .iter()
                    .map(|p| point_triangle(q, *p))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d);
                let near_edge = mesh
                    .vertices
                    .iter()
                    .map(|v| v.position.map(f64::from))
                    .filter(|p| (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>() <= cell * cell)
                    .map(|p| ((p[u] - cu).powi(2) + (p[v] - cv).powi(2)).sqrt())
                    .fold(f64::INFINITY, f64::min);
                worst_vertex = worst_vertex.max(near_edge);
            }
        }
    }
    (worst, worst_vertex)
}

/// The box (edges off the grid planes) minus a cylinder: its corners and its document.
fn box_minus_cylinder() -> ([f64; 3], [f64; 3], String) {
    let (lo, hi) = ([-0.713, -0.471, -0.289], [0.687, 0.517, 0.313]);
    let json = format!(
        r#"{{"solid": {{"and": {{"solids": [
        {{"box": {{"min": {lo:?}, "max": {hi:?}}}}},
        {{"not": {{"solid": {{"cylinder": {{"base": [0, 0, -1], "axis": [0, 0, 1], "radius": 0.25, "height": 2}}}}}}}}
    ]}}}}}}"#
    );
    (lo, hi, json)
}

/// A CSG part with sharp edges: a box (edges off the grid planes) minus a cylinder,
/// genus 1. Dual contouring puts its vertices on the box's edges, where marching
/// tetrahedra cut them within a cell.
#[test]
fn dual_box_minus_cylinder_is_closed_with_sharp_edges() {
    let (lo, hi, json) = box_minus_cylinder();
    let res = 40;
    let cell = 2.0 / res as f64;
    let (model, mesh) = dual_of(&json, res, -1.0, 1.0);
    assert_closed(&mesh, 0);
    assert!(volume(&mesh) > 0.0);
    let tape = model.tape_positive_inside();
    for v in &mesh.vertices {
        let w = f64::from(tape.eval_point(v.position));
        assert!(
            w.abs() <= 0.5 * cell,
            "omega {w} at vertex {:?}",
            v.position
        );
    }
    let (dc_surface, dc_vertex) = edge_error(&mesh, lo, hi, cell);
    let (_, mt) = mesh_of(&json, res, -1.0, 1.0);
    let (mt_surface, mt_vertex) = edge_error(&mt, lo, hi, cell);
    eprintln!(
        "box edges (cell {cell}): nearest vertex off the edge: dual contouring {dc_vertex:e}, \
         marching tetrahedra {mt_vertex:e}; edge points from the mesh: {dc_surface:e}, {mt_surface:e}"
    );
    assert!(
        dc_vertex <= DUAL_EDGE_CELL_FRAC * cell,
        "dual contouring: vertices {dc_vertex} off the edges"
    );
    assert!(
        mt_vertex > DUAL_EDGE_CELL_FRAC * cell,
        "marching tetrahedra already on the edges: {mt_vertex}"
    );
    assert!(
        dc_surface <= DUAL_EDGE_CELL_FRAC * cell,
        "dual contouring: the edges lie {dc_surface} from the mesh"
    );
    assert!(
        dc_surface < mt_surface,
        "dual contouring cuts the edges more: {dc_surface} vs {mt_surface}"
    );
}

/// Two small spheres around the corners x and y of one cell (corners that share no
/// edge of the cell's tetrahedra): that cell holds two sheets. Plain dual contouring
/// gives it one vertex and pinches the spheres together; here each sheet is its own
/// patch with its own vertex, and the spheres stay apart.
#[test]
fn dual_keeps_two_sheets_in_one_cell_apart() {
    let (res, r) = (10, 0.12);
    let cell = 2.0 / res as f64;
    let centres = [[0.21, 0.005, 0.003], [0.004, 0.19, 0.007]];
    let json = format!(
        r#"{{"solid": {{"or": {{"solids": [
        {{"sphere": {{"center": {:?}, "radius": {r}}}}},
        {{"sphere": {{"center": {:?}, "radius": {r}}}}}
    ]}}}}}}"#,
        centres[0], centres[1]
    );
    let model = Model::from_solid_json(&json).unwrap();
    let (mesh, report) =
        dual_contour(&model.tape_negative_inside(), [res; 3], [-1.0; 3], [1.0; 3]).unwrap();
    assert!(
        report.split_cells > 0,
        "no cell holds two sheets: {report:?}"
    );
    let t = half_edge_check(&mesh);
    assert_eq!((t.components, euler(&t)), (2, 4), "{t:?} {report:?}");
    // Every vertex lies within half a cell of one of the spheres.
    for v in &mesh.vertices {
        let p = v.position.map(f64::from);
        let d = centres
            .map(|c| {
                ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() - r
            })
            .into_iter()
            .fold(f64::INFINITY, |m, d| if d.abs() < m.abs() { d } else { m });
        assert!(
            d.abs() <= 0.5 * cell,
            "vertex {p:?} is {d} from the spheres"
        );
    }
}

// The sparse mesher (`contour_cells`: blocks classified by interval arithmetic,
// corners evaluated only where the surface may be, on each block's pruned tape)
// against the dense reference (`contour_cells_dense`: every corner on the full tape).

use sculpt_core::implicit::contour::{contour_cells, contour_cells_dense, contour_stats};

/// The triangles of `mesh` as their corners' position and normal bits, each triangle
/// rotated to start at its smallest corner (winding kept), sorted.
fn triangle_set(mesh: &WeldedMesh) -> Vec<[[u32; 6]; 3]> {
    let key = |i: u32| {
        let v = &mesh.vertices[i as usize];
        let (p, n) = (v.position, v.normal);
        [p[0], p[1], p[2], n[0], n[1], n[2]].map(f32::to_bits)
    };
    let mut out: Vec<[[u32; 6]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            let k = t.map(key);
            let r = (0..3).min_by_key(|&r| k[r]).expect("three corners");
            [k[r], k[(r + 1) % 3], k[(r + 2) % 3]]
        })
        .collect();
    out.sort_unstable();
    out
}

/// The sparse mesh equals the dense one triangle for triangle (positions and normals
/// bit for bit), with blocks skipped: a `min`/`max` CSG part (grid ending mid-block),
/// Fidget-layout spheres joined by `min`, and a solid leaving the box (blocks inside
/// on the outer layer must still be evaluated, or the box's faces would be open).
#[test]
fn sparse_mesher_equals_the_dense_reference_and_skips_blocks() {
    let part = r#"{"solid": {"and": {"system": "min_max", "solids": [
        {"box": {"min": [-0.7, -0.5, -0.3], "max": [0.7, 0.5, 0.3]}},
        {"not": {"solid": {"cylinder": {"base": [0, 0, -1], "axis": [0, 0, 1], "radius": 0.25, "height": 2}}}},
        {"not": {"solid": {"sphere": {"center": [0.7, 0.5, 0.3], "radius": 0.3}}}}
    ]}}}"#;
    let cut = r#"{"solid": {"or": {"system": "min_max", "solids": [
        {"sphere": {"center": [0, 0, 0], "radius": 1.5}},
        {"sphere": {"center": [3, 0, 0], "radius": 0.5}}]}}}"#;
    let spheres = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/implicit/two-spheres.vm"
    ))
    .unwrap();
    let cases = [
        (Model::from_solid_json(part).unwrap(), 70, 0, 2),
        (Model::from_vm(&spheres).unwrap(), 67, 2, 2),
        // 98 of its 125 blocks touch the outer layer, inside the solid.
        (Model::from_solid_json(cut).unwrap(), 37, 2, 1),
    ];
    for (model, res, chi, skip_ratio) in cases {
        let tape = model.tape_negative_inside();
        let (n, lo, hi) = ([res; 3], [-1.0; 3], [1.0; 3]);
        let (sparse, extra) = contour_cells(&tape, n, lo, hi).unwrap();
        let (dense, _) = contour_cells_dense(&tape, n, lo, hi).unwrap();
        assert_eq!(extra.cells.len(), sparse.triangles.len());
        assert_eq!(extra.edges.len(), sparse.vertices.len());
        assert!(!sparse.triangles.is_empty());
        assert_eq!(triangle_set(&sparse), triangle_set(&dense), "res {res}");
        let t = half_edge_check(&sparse);
        assert_eq!(euler(&t), chi, "{t:?}");
        let stats = contour_stats(&tape, n, lo, hi).unwrap();
        eprintln!("{stats:?}");
        assert!(
            stats.evaluated_blocks * skip_ratio < stats.blocks,
            "interval classification skips most blocks: {stats:?}"
        );
    }
}

/// The corner bounds of R-functions (`MonotoneR`) decide blocks the formulas' interval
/// arithmetic cannot: on the shipped CSG bracket (R_0 conjunctions throughout) the
/// sparse mesher evaluates fewer blocks with them, and the mesh is still the dense
/// reference's.
#[test]
fn r_function_corner_bounds_let_the_mesher_skip_blocks() {
    let json = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/implicit/bracket.json"
    ))
    .unwrap();
    let tape = Model::from_solid_json(&json)
        .unwrap()
        .tape_negative_inside();
    assert!(tape.r_bounds() > 0);
    let (n, lo, hi) = ([48; 3], [-1.2; 3], [1.2; 3]);
    let with = contour_stats(&tape, n, lo, hi).unwrap();
    let without = contour_stats(&tape.without_r_bounds(), n, lo, hi).unwrap();
    eprintln!("bracket 48^3: corner bounds {with:?}, formulas only {without:?}");
    assert!(
        with.evaluated_blocks < without.evaluated_blocks,
        "{with:?} vs {without:?}"
    );
    let (sparse, _) = contour_cells(&tape, n, lo, hi).unwrap();
    let (dense, _) = contour_cells_dense(&tape, n, lo, hi).unwrap();
    assert_eq!(triangle_set(&sparse), triangle_set(&dense));
}

// Octree simplification (`implicit::octree`): the same topology and distance checks,
// fewer triangles, sharp edges kept.

use sculpt_core::implicit::dual::dual_contour_simplified;
use sculpt_core::implicit::octree::OctreeSimplify;

fn octree_of(json: &str, res: usize, lo: f64, hi: f64) -> (Model, WeldedMesh) {
    let model = Model::from_solid_json(json).unwrap();
    let (mesh, report) = dual_contour_simplified(
        &model.tape_negative_inside(),
        [res; 3],
        [lo; 3],
        [hi; 3],
        &OctreeSimplify::default(),
    )
    .unwrap();
    eprintln!("{report:?}");
    assert!(report.node_fans > 0, "no node collapsed: {report:?}");
    (model, mesh)
}

/// Points spread over every triangle (corners, edge midpoints, and a barycentric
/// grid of 15 inner points).
fn triangle_samples(mesh: &WeldedMesh) -> Vec<[f64; 3]> {
    const STEPS: usize = 6;
    let mut out = Vec::new();
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.vertices[i as usize].position.map(f64::from));
        for i in 0..=STEPS {
            for j in 0..=STEPS - i {
                let (a, b) = (i as f64 / STEPS as f64, j as f64 / STEPS as f64);
                let c = 1.0 - a - b;
                out.push([0, 1, 2].map(|k| a * p[0][k] + b * p[1][k] + c * p[2][k]));
            }
        }
    }
    out
}

/// The simplified sphere and torus pass the uniform meshes' checks (closed, Euler
/// characteristic, vertices within half a cell, volume), every point of every
/// triangle lies within half a cell of the exact surface, and they have fewer
/// triangles than the uniform dual-contouring meshes.
#[test]
fn octree_sphere_and_torus_are_closed_near_the_surface_and_smaller() {
    check_sphere(octree_of);
    check_torus(octree_of);
    let sphere = r#"{"solid": {"sphere": {"center": [0.1, 0.0, -0.05], "radius": 0.8}}}"#;
    let (_, simple) = octree_of(sphere, 24, -1.0, 1.0);
    let (_, uniform) = dual_of(sphere, 24, -1.0, 1.0);
    let half_cell = 0.5 * 2.0 / 24.0;
    for p in triangle_samples(&simple) {
        let d = ((p[0] - 0.1).powi(2) + p[1].powi(2) + (p[2] + 0.05).powi(2)).sqrt() - 0.8;
        assert!(
            d.abs() <= half_cell,
            "mesh point {p:?} is {d} from the sphere"
        );
    }
    eprintln!(
        "sphere 24^3: {} triangles simplified, {} uniform",
        simple.triangles.len(),
        uniform.triangles.len()
    );
    assert!(simple.triangles.len() < uniform.triangles.len());
}

/// The CSG part (R_0 conjunctions) simplified: closed, genus 1, the function within
/// half a cell of 0 at every point of every triangle.
#[test]
fn octree_csg_part_is_closed_near_the_surface() {
    let json = r#"{"solid": {"and": {"solids": [
        {"box": {"min": [-0.7, -0.5, -0.3], "max": [0.7, 0.5, 0.3]}},
        {"not": {"solid": {"cylinder": {"base": [0, 0, -1], "axis": [0, 0, 1], "radius": 0.25, "height": 2}}}},
        {"not": {"solid": {"sphere": {"center": [0.7, 0.5, 0.3], "radius": 0.3}}}}
    ]}}}"#;
    let (model, mesh) = octree_of(json, 40, -1.0, 1.0);
    assert_closed(&mesh, 0);
    assert!(volume(&mesh) > 0.0);
    let tape = model.tape_positive_inside();
    let half_cell = 0.5 * 2.0 / 40.0;
    for p in triangle_samples(&mesh) {
        let w = f64::from(tape.eval_point(p.map(|c| c as f32)));
        assert!(w.abs() <= half_cell, "omega {w} at mesh point {p:?}");
    }
}

/// A flat-sided box minus a cylinder: the simplified mesh is closed with genus 1,
/// has well under half the uniform mesh's triangles (its faces collapse into
/// octree nodes), and still passes through the box's edges as the uniform one does.
#[test]
fn octree_box_has_fewer_triangles_and_keeps_its_edges() {
    let (lo, hi, json) = box_minus_cylinder();
    let res = 40;
    let cell = 2.0 / res as f64;
    let (model, simple) = octree_of(&json, res, -1.0, 1.0);
    let (_, uniform) = dual_of(&json, res, -1.0, 1.0);
    assert_closed(&simple, 0);
    eprintln!(
        "box minus cylinder {res}^3: {} triangles simplified, {} uniform",
        simple.triangles.len(),
        uniform.triangles.len()
    );
    assert!(
        2 * simple.triangles.len() < uniform.triangles.len(),
        "{} vs {}",
        simple.triangles.len(),
        uniform.triangles.len()
    );
    let tape = model.tape_positive_inside();
    for p in triangle_samples(&simple) {
        let w = f64::from(tape.eval_point(p.map(|c| c as f32)));
        assert!(w.abs() <= 0.5 * cell, "omega {w} at mesh point {p:?}");
    }
    let (surface, vertex) = edge_error(&simple, lo, hi, cell);
    eprintln!("box edges simplified: vertex {vertex:e}, surface {surface:e}");
    assert!(
        surface <= DUAL_EDGE_CELL_FRAC * cell,
        "the edges lie {surface} from the simplified mesh"
    );
}

/// The mesh of `json` by each mesher at `res` on [-1, 1]^3: marching tetrahedra, dual
/// contouring, and dual contouring with the default octree simplification.
fn three_meshes(json: &str, res: usize) -> [WeldedMesh; 3] {
    [
        mesh_of(json, res, -1.0, 1.0).1,
        dual_of(json, res, -1.0, 1.0).1,
        octree_of(json, res, -1.0, 1.0).1,
    ]
}

/// The default mesher of `sculpt-tools implicit mesh` (octree simplification) has the
/// fewest triangles of the three on the sphere, the tilted torus and the CSG part
/// (box, hole and bite), each closed and manifold with its genus (the checks above
/// hold the distances and the sharp edges).
#[test]
fn octree_has_the_fewest_triangles_on_sphere_torus_and_csg_part() {
    let cases = [
        (
            r#"{"solid": {"sphere": {"center": [0.1, 0.0, -0.05], "radius": 0.8}}}"#,
            24,
            2,
        ),
        (
            r#"{"solid": {"torus": {"center": [0, 0, 0], "axis": [0.2, 0.1, 1], "major": 0.6, "minor": 0.25}}}"#,
            32,
            0,
        ),
        (
            r#"{"solid": {"and": {"solids": [
        {"box": {"min": [-0.7, -0.5, -0.3], "max": [0.7, 0.5, 0.3]}},
        {"not": {"solid": {"cylinder": {"base": [0, 0, -1], "axis": [0, 0, 1], "radius": 0.25, "height": 2}}}},
        {"not": {"solid": {"sphere": {"center": [0.7, 0.5, 0.3], "radius": 0.3}}}}
    ]}}}"#,
            40,
            0,
        ),
    ];
    for (json, res, chi) in cases {
        let [mt, dc, octree] = three_meshes(json, res);
        for m in [&mt, &dc, &octree] {
            assert_closed(m, chi);
        }
        let counts = [&mt, &dc, &octree].map(|m| m.triangles.len());
        eprintln!(
            "{res}^3 triangles: mt {}, dc {}, octree {}",
            counts[0], counts[1], counts[2]
        );
        assert!(counts[2] < counts[0] && counts[2] < counts[1], "{counts:?}");
    }
}

/// Octree nodes grow past the mesher's 8^3 blocks where the QEF error allows: a box
/// (faces off the grid planes) at 48^3 collapses nodes of 16 cells on its faces, has
/// fewer triangles than with nodes capped at 8 cells, and stays closed with its
/// edges kept and every triangle within half a cell of the surface.
#[test]
fn octree_nodes_grow_past_eight_cells_on_flat_faces() {
    let (lo, hi) = ([-0.83, -0.79, -0.81], [0.87, 0.81, 0.77]);
    let json = format!(r#"{{"solid": {{"box": {{"min": {lo:?}, "max": {hi:?}}}}}}}"#);
    let res = 48;
    let cell = 2.0 / res as f64;
    let model = Model::from_solid_json(&json).unwrap();
    let tape = model.tape_negative_inside();
    let mesh_with = |settings: &OctreeSimplify| {
        dual_contour_simplified(&tape, [res; 3], [-1.0; 3], [1.0; 3], settings).unwrap()
    };
    let (deep, report) = mesh_with(&OctreeSimplify::default());
    let capped = OctreeSimplify {
        levels: 3,
        ..OctreeSimplify::default()
    };
    let (shallow, shallow_report) = mesh_with(&capped);
    eprintln!("deep {report:?}\nshallow {shallow_report:?}");
    assert!(report.widest_node > 8, "{report:?}");
    assert_eq!(shallow_report.widest_node, 8, "{shallow_report:?}");
    assert!(
        deep.triangles.len() < shallow.triangles.len(),
        "{} vs {}",
        deep.triangles.len(),
        shallow.triangles.len()
    );
    assert_closed(&deep, 2);
    let inside = model.tape_positive_inside();
    for p in triangle_samples(&deep) {
        let w = f64::from(inside.eval_point(p.map(|c| c as f32)));
        assert!(w.abs() <= 0.5 * cell, "omega {w} at mesh point {p:?}");
    }
    let (surface, _) = edge_error(&deep, lo, hi, cell);
    assert!(
        surface <= DUAL_EDGE_CELL_FRAC * cell,
        "the edges lie {surface} from the mesh"
    );
}
