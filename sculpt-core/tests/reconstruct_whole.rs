//! Issue 30, item 2: a reconstructed closed scan meshes into one watertight,
//! consistently oriented surface (Euler characteristic `2 - 2g`) at both details, with
//! (almost) no area facing against the surface it was scanned from.
//!
//! The checks read the mesh with their own half-edge count: vertices are merged only
//! where their positions are the same bits (no distance tolerance), every undirected
//! edge must be used by exactly two triangles running it in opposite directions, and
//! the bodies are the connected components of the triangles.

use std::collections::HashMap;

use glam::DVec3;
use sculpt_core::mesh::PatchMesh;
use sculpt_core::reconstruct::network::{NetworkSettings, to_document};
use sculpt_core::reconstruct::pipeline::reconstruct;
use sculpt_core::reconstruct::read::PointCloud;
use sculpt_core::reconstruct::sample::{sphere, torus};
use sculpt_core::reconstruct::segment::SegmentSettings;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;
use sculpt_core::tolerance::FOLD_AREA_FRACTION;

/// What the half-edge count found.
#[derive(Debug, Default, PartialEq, Eq)]
struct Surface {
    vertices: usize,
    edges: usize,
    faces: usize,
    bodies: usize,
    /// Edges used by one triangle.
    open: usize,
    /// Edges used by three or more.
    non_manifold: usize,
    /// Edges whose two triangles run it the same way.
    misoriented: usize,
    /// Triangles with two corners at one vertex.
    degenerate: usize,
    /// Vertices whose triangles form two or more fans meeting only there (a pinch:
    /// every edge can still have two triangles; the kitten at K = 80 had one).
    pinched: usize,
}

impl Surface {
    fn euler(&self) -> i64 {
        self.vertices as i64 - self.edges as i64 + self.faces as i64
    }

    fn is_closed_manifold(&self) -> bool {
        self.open == 0
            && self.non_manifold == 0
            && self.misoriented == 0
            && self.degenerate == 0
            && self.pinched == 0
    }
}

fn find(parent: &mut [usize], x: usize) -> usize {
    let mut r = x;
    while parent[r] != r {
        r = parent[r];
    }
    let mut y = x;
    while parent[y] != r {
        let next = parent[y];
        parent[y] = r;
        y = next;
    }
    r
}

/// Triangles as position triples, from every patch of the mesh.
fn triangles(mesh: &PatchMesh) -> Vec<[[f32; 3]; 3]> {
    mesh.patches()
        .flat_map(|(_, p)| {
            p.triangles
                .iter()
                .map(|t| t.map(|i| p.vertices[i as usize].position))
        })
        .collect()
}

fn count(tris: &[[[f32; 3]; 3]]) -> Surface {
    // The distinct positions, sorted; a corner's vertex is its position's rank.
    let mut ids: Vec<[u32; 3]> = tris.iter().flatten().map(|p| p.map(f32::to_bits)).collect();
    ids.sort_unstable();
    ids.dedup();
    let rank = |p: &[f32; 3]| ids.binary_search(&p.map(f32::to_bits)).unwrap();
    let faces: Vec<[usize; 3]> = tris.iter().map(|t| t.each_ref().map(rank)).collect();
    let mut s = Surface {
        vertices: ids.len(),
        faces: faces.len(),
        ..Surface::default()
    };
    let mut directed: HashMap<(usize, usize), usize> = HashMap::new();
    let mut parent: Vec<usize> = (0..ids.len()).collect();
    for f in &faces {
        if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
            s.degenerate += 1;
        }
        for k in 0..3 {
            *directed.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
            let (a, b) = (find(&mut parent, f[k]), find(&mut parent, f[(k + 1) % 3]));
            parent[a] = b;
        }
    }
    let mut undirected: HashMap<(usize, usize), (usize, usize)> = HashMap::new();
    for (&(a, b), &n) in &directed {
        let e = undirected.entry((a.min(b), a.max(b))).or_default();
        if a < b {
            e.0 += n;
        } else {
            e.1 += n;
        }
    }
    s.edges = undirected.len();
    for &(fwd, back) in undirected.values() {
        match fwd + back {
            1 => s.open += 1,
            2 if fwd != 1 => s.misoriented += 1,
            2 => {}
            _ => s.non_manifold += 1,
        }
    }
    // The fans round each vertex: its triangles, joined where they share an edge at it.
    let mut at: HashMap<usize, Vec<[usize; 2]>> = HashMap::new();
    for f in &faces {
        for k in 0..3 {
            at.entry(f[k])
                .or_default()
                .push([f[(k + 1) % 3], f[(k + 2) % 3]]);
        }
    }
    for link in at.values() {
        let mut fan: Vec<usize> = (0..link.len()).collect();
        for a in 0..link.len() {
            for b in a + 1..link.len() {
                if link[a].iter().any(|v| link[b].contains(v)) {
                    let (ra, rb) = (find(&mut fan, a), find(&mut fan, b));
                    fan[ra] = rb;
                }
            }
        }
        let fans: std::collections::HashSet<usize> =
            (0..link.len()).map(|i| find(&mut fan, i)).collect();
        s.pinched += usize::from(fans.len() > 1);
    }
    let used: std::collections::HashSet<usize> = faces.iter().flatten().copied().collect();
    let roots: std::collections::HashSet<usize> =
        used.iter().map(|&v| find(&mut parent, v)).collect();
    s.bodies = roots.len();
    s
}

/// The fraction of the mesh's area whose triangles face against `reference` (the
/// outward unit normal of the scanned surface at a point).
fn facing_against(tris: &[[[f32; 3]; 3]], reference: impl Fn(DVec3) -> DVec3) -> f64 {
    let (mut against, mut total) = (0.0, 0.0);
    for t in tris {
        let [a, b, c] = t.map(|p| DVec3::from(p.map(f64::from)));
        let n = (b - a).cross(c - a);
        let area = 0.5 * n.length();
        total += area;
        if n.dot(reference((a + b + c) / 3.0)) < 0.0 {
            against += area;
        }
    }
    against / total
}

/// The document `reconstruct --out` writes for `points` at K patches, read back.
fn scan_document(points: Vec<DVec3>, patches: usize) -> Document {
    let cloud = PointCloud {
        points,
        normals: None,
    };
    let settings = NetworkSettings {
        levels: 3,
        control: 6,
        ..NetworkSettings::new()
    };
    let r = reconstruct(&cloud, &SegmentSettings::new(patches), &settings, |_| {}).unwrap();
    let quads = r.network.quads.len();
    let doc = Document::from_json(&to_document(&r.network).unwrap().to_json()).unwrap();
    assert_eq!(doc.targets().len(), quads);
    // Every side of every patch is found shared with exactly one other patch.
    assert_eq!(doc.network().sides.len() * 2, quads * 4);
    doc
}

/// Meshes `doc` at both details, incrementally (`Document::tessellate`, as the live
/// view does) and afresh (`Document::mesh`), and checks each is one closed,
/// consistently oriented body of Euler characteristic `euler` with at most
/// `FOLD_AREA_FRACTION` of its area facing against `reference`.
fn check_whole(doc: Document, euler: i64, reference: impl Fn(DVec3) -> DVec3) {
    let mut view = DocumentView::new();
    for detail in [Detail::Interactive, Detail::Final] {
        let mut live = PatchMesh::new();
        view.tessellate(&doc, detail, &mut live);
        for mesh in [live, doc.mesh(detail)] {
            let tris = triangles(&mesh);
            let s = count(&tris);
            eprintln!("{detail:?}: {s:?}, Euler {}", s.euler());
            assert!(s.is_closed_manifold(), "{detail:?}: {s:?}");
            assert_eq!(s.bodies, 1, "{detail:?}");
            assert_eq!(s.euler(), euler, "{detail:?}: {s:?}");
            let folded = facing_against(&tris, &reference);
            eprintln!("{detail:?}: area facing against the surface {folded}");
            assert!(folded <= FOLD_AREA_FRACTION, "{detail:?}: {folded}");
        }
    }
}

/// Regression (issue 30): the kitten at K = 80 meshed with Euler characteristic 1, one
/// vertex joining two sheets where a patch wrapped its tail (the polygonal model
/// pinched there), and 0.26 % of its area faced against the data. The pinched patches
/// are split now (`reconstruct::pinch`): one closed surface of genus 1 (the kitten's
/// tail is a handle), no pinch, at most 0.1 % of the area folded, measured against the
/// normal of the nearest data point.
#[test]
fn the_kitten_is_one_closed_surface_of_genus_one_without_folds() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/scans/kitten.xyz");
    if !path.is_file() {
        assert!(
            std::env::var("CI").map_or(true, |v| v.is_empty()),
            "{} is missing: CI must run scripts/fetch-scans",
            path.display()
        );
        eprintln!(
            "{} not fetched (run scripts/fetch-scans); skipped",
            path.display()
        );
        return;
    }
    use sculpt_core::reconstruct::read::{PointFormat, read_points};
    let cloud = read_points(&std::fs::read(&path).unwrap(), PointFormat::Xyz).unwrap();
    let (points, normals) = (cloud.points.clone(), cloud.normals.clone().unwrap());
    let r = reconstruct(
        &cloud,
        &SegmentSettings::new(80),
        &NetworkSettings::new(),
        |_| {},
    )
    .unwrap();
    let doc = Document::from_json(&to_document(&r.network).unwrap().to_json()).unwrap();
    let tree: rstar::RTree<rstar::primitives::GeomWithData<[f64; 3], usize>> =
        rstar::RTree::bulk_load(
            points
                .iter()
                .enumerate()
                .map(|(i, p)| rstar::primitives::GeomWithData::new(p.to_array(), i))
                .collect(),
        );
    check_whole(doc, 0, |c| {
        normals[tree.nearest_neighbor(&c.to_array()).unwrap().data]
    });
}

#[test]
fn a_reconstructed_sphere_is_one_closed_surface_of_euler_characteristic_two() {
    let doc = scan_document(sphere(3000, 0.15, 11), 20);
    check_whole(doc, 2, |p| p.normalize());
}

#[test]
fn a_reconstructed_torus_is_one_closed_surface_of_euler_characteristic_zero() {
    let (major, minor) = (0.2, 0.08);
    let doc = scan_document(torus(4000, major, minor, 7), 30);
    check_whole(doc, 0, |p| {
        let core = DVec3::new(p.x, p.y, 0.0).normalize() * major;
        (p - core).normalize()
    });
}

/// Without the conforming tessellation (each patch meshed on its own grid) the same
/// torus is not closed: this is what the test above would have caught.
#[test]
fn patches_meshed_apart_leave_open_edges() {
    let doc = scan_document(torus(4000, 0.2, 0.08, 7), 30);
    let mut mesh = PatchMesh::new();
    for (k, t) in doc.targets().iter().enumerate() {
        let mut view = sculpt_core::sculpt::tessellate::TargetTessellation::new(
            &t.surface,
            k as u32,
            Detail::Final,
        );
        view.update_strokes(&t.surface, &[], &mut mesh);
    }
    let s = count(&triangles(&mesh));
    eprintln!("apart: {s:?}");
    assert!(s.open > 0, "{s:?}");
}

/// The live view of a network through a stroke and its undo: the carved patch is
/// meshed by its own tessellation (its root patches, with its groove) and its
/// neighbours stay network patches, the surface watertight; undone, the sink holds the
/// same watertight surface as before the stroke.
#[test]
fn a_stroke_and_its_undo_keep_the_live_view_in_step() {
    let mut view = DocumentView::new();
    use sculpt_core::editor::{self, Applied};
    use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample};
    use sculpt_core::sculpt::document::conform_key;
    use sculpt_core::sculpt::stroke::Tool;

    let mut doc = scan_document(torus(4000, 0.2, 0.08, 7), 30);
    let mut live = PatchMesh::new();
    view.tessellate(&doc, Detail::Interactive, &mut live);
    let before = triangles(&live);
    assert!(count(&before).is_closed_manifold());
    let keys = |m: &PatchMesh| m.patches().map(|(k, _)| k).collect::<Vec<_>>();
    assert!(keys(&live).contains(&conform_key(0)));
    let surface = doc.targets()[0].surface.clone();
    let samples = (0..=10)
        .map(|k| StrokeSample {
            t: 0.01 * f64::from(k),
            position: surface.point(0.3 + 0.04 * f64::from(k), 0.5),
        })
        .collect();
    let tool = Tool {
        width: 0.01,
        ..Tool::default()
    };
    let edit = Edit::Stroke(StrokeEdit::new(doc.targets()[0].id, tool, samples));
    assert!(matches!(
        editor::apply(&mut doc, &edit),
        Applied::Stroke { .. }
    ));
    view.tessellate(&doc, Detail::Interactive, &mut live);
    // Issue 30, watertight after strokes: the carved patch's shared sides are the
    // network's, so the live view stays one closed surface.
    let after = count(&triangles(&live));
    assert!(after.is_closed_manifold(), "{after:?}");
    assert_eq!((after.bodies, after.euler()), (1, 0), "{after:?}");
    let carved = keys(&live);
    assert!(!carved.contains(&conform_key(0)));
    // Target 0's own root patches, and every other target still one network patch.
    assert!(carved.iter().any(|&k| k >> 32 == 0));
    for k in 1..doc.targets().len() {
        assert!(carved.contains(&conform_key(k)), "{k}");
    }
    assert_eq!(live, doc.mesh(Detail::Interactive));
    assert!(doc.undo());
    view.tessellate(&doc, Detail::Interactive, &mut live);
    let mut again = triangles(&live);
    let mut first = before;
    let order = |a: &[[f32; 3]; 3], b: &[[f32; 3]; 3]| {
        a.map(|p| p.map(f32::to_bits))
            .cmp(&b.map(|p| p.map(f32::to_bits)))
    };
    again.sort_by(order);
    first.sort_by(order);
    assert_eq!(again, first);
}

/// A straight stroke of `samples + 1` samples on target `k` of `doc` from `(u0, v0)` to
/// `(u1, v1)` of its surface, applied through the editor.
fn carve(
    doc: &mut sculpt_core::sculpt::document::Document,
    k: usize,
    from: (f64, f64),
    to: (f64, f64),
) {
    use sculpt_core::editor::{self, Applied};
    use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample};
    use sculpt_core::sculpt::stroke::Tool;
    let surface = doc.targets()[k].surface.clone();
    let samples = (0..=20)
        .map(|i| {
            let f = f64::from(i) / 20.0;
            StrokeSample {
                t: 0.01 * f64::from(i),
                position: surface.point(from.0 + (to.0 - from.0) * f, from.1 + (to.1 - from.1) * f),
            }
        })
        .collect();
    let tool = Tool {
        width: 0.01,
        ..Tool::default()
    };
    let edit = Edit::Stroke(StrokeEdit::new(doc.targets()[k].id, tool, samples));
    assert!(matches!(editor::apply(doc, &edit), Applied::Stroke { .. }));
}

/// The deepest vertex of `mesh` below the torus `(major, minor)` (distance inside the
/// tube), to see that a groove was carved.
fn deepest_below_torus(mesh: &PatchMesh, major: f64, minor: f64) -> f64 {
    triangles(mesh)
        .iter()
        .flatten()
        .map(|p| {
            let p = DVec3::from(p.map(f64::from));
            let core = DVec3::new(p.x, p.y, 0.0).normalize() * major;
            minor - p.distance(core)
        })
        .fold(0.0, f64::max)
}

/// Issue 30, watertight after strokes: a torus network with strokes on two patches
/// (one in the middle of its patch, one running up to a shared side) is one closed,
/// oriented surface of Euler characteristic 0 at both details, live and afresh, with
/// its grooves carved.
#[test]
fn a_carved_network_stays_one_closed_surface() {
    let mut view = DocumentView::new();
    let (major, minor) = (0.2, 0.08);
    let mut doc = scan_document(torus(4000, major, minor, 7), 30);
    let mut live = [PatchMesh::new(), PatchMesh::new()];
    for (mesh, detail) in live.iter_mut().zip([Detail::Interactive, Detail::Final]) {
        view.tessellate(&doc, detail, mesh);
    }
    carve(&mut doc, 0, (0.32, 0.47), (0.71, 0.52));
    carve(&mut doc, 5, (0.47, 0.43), (0.52, 1.0));
    for (mesh, detail) in live.iter_mut().zip([Detail::Interactive, Detail::Final]) {
        view.tessellate(&doc, detail, mesh);
        let s = count(&triangles(mesh));
        eprintln!(
            "{detail:?} after strokes (live): {s:?}, Euler {}",
            s.euler()
        );
        assert!(s.is_closed_manifold(), "{detail:?}: {s:?}");
        assert_eq!((s.bodies, s.euler()), (1, 0), "{detail:?}: {s:?}");
        assert_eq!(*mesh, doc.mesh(detail), "{detail:?}");
        let depth = deepest_below_torus(mesh, major, minor);
        assert!(depth > 0.003, "{detail:?}: deepest {depth}");
    }
    // Afresh (new sinks), with the fold check.
    view.forget_sinks();
    check_whole(doc, 0, |p| {
        let core = DVec3::new(p.x, p.y, 0.0).normalize() * major;
        (p - core).normalize()
    });
}

/// How much deeper `after` lies than `before` along the torus's inward normal at `p`
/// (a point of the network near the torus): where a ray from outside, aimed at `p`,
/// first meets each mesh.
fn carved_depth(before: &PatchMesh, after: &PatchMesh, p: DVec3, major: f64) -> f64 {
    let core = DVec3::new(p.x, p.y, 0.0).normalize() * major;
    let n = (p - core).normalize();
    let origin = p + n * 0.02;
    let hit = |m: &PatchMesh| {
        m.first_hit(origin.to_array(), (-n).to_array())
            .expect("the ray meets the mesh")
    };
    hit(after) - hit(before)
}

/// Issue 30, strokes across patch boundaries: a stroke drawn from the middle of one
/// patch of a torus network to the middle of its neighbour is projected onto the
/// network and carved as one groove in two pieces, one on each patch, meeting on the
/// shared side; at final detail the network stays one closed surface, and the groove's
/// depth measured on the mesh along its bottom is the tool's on both sides of the side
/// and on it: no notch where the patches meet (a piece tapered at the side, as a
/// stroke ending there is, would go to zero depth).
#[test]
fn a_stroke_across_a_patch_boundary_carves_one_continuous_groove() {
    use sculpt_core::editor::{self, Applied};
    use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample};
    use sculpt_core::sculpt::stroke::Tool;

    let (major, minor) = (0.2, 0.08);
    let mut doc = scan_document(torus(4000, major, minor, 7), 30);
    let network = doc.network();
    let [(a, ka), (b, kb)] = network.sides[0];
    let side_uv = |k: usize, t: f64| match k {
        0 => (0.0, t),
        1 => (1.0, t),
        2 => (t, 0.0),
        _ => (t, 1.0),
    };
    let (sa, sb) = (
        doc.targets()[a].surface.clone(),
        doc.targets()[b].surface.clone(),
    );
    let lerp =
        |p: (f64, f64), q: (f64, f64), f: f64| (p.0 + (q.0 - p.0) * f, p.1 + (q.1 - p.1) * f);
    let on_a = side_uv(ka, 0.5);
    // The side's middle, whichever way `b` runs it.
    let on_b = side_uv(kb, 0.5);
    // Along the surfaces: the middle of `a` to the side's middle, then on to the middle
    // of `b`.
    let mut path: Vec<DVec3> = (0..=20)
        .map(|i| {
            let (u, v) = lerp((0.5, 0.5), on_a, f64::from(i) / 20.0);
            sa.point(u, v)
        })
        .collect();
    path.extend((1..=20).map(|i| {
        let (u, v) = lerp(on_b, (0.5, 0.5), f64::from(i) / 20.0);
        sb.point(u, v)
    }));
    let samples = path
        .iter()
        .enumerate()
        .map(|(i, &position)| StrokeSample {
            t: 0.01 * i as f64,
            position,
        })
        .collect();
    let tool = Tool {
        width: 0.01,
        ..Tool::default()
    };
    let (depth, tool_width) = (tool.depth, tool.width);
    let edit = Edit::Stroke(StrokeEdit::new(doc.targets()[a].id, tool, samples));
    let before = doc.mesh(Detail::Final);
    let Applied::Stroke { id, .. } = editor::apply(&mut doc, &edit) else {
        panic!("the stroke was not carved");
    };
    // One stroke, a piece on each patch, each in its own UV map.
    let on: Vec<usize> = (0..doc.targets().len())
        .filter(|&k| !doc.strokes_on(doc.targets()[k].id).is_empty())
        .collect();
    assert_eq!(on, {
        let mut v = vec![a, b];
        v.sort();
        v
    });
    assert_eq!(doc.strokes().len(), 1);
    assert!(doc.stroke(id).expect("built").pieces.len() >= 2);
    let mut live = PatchMesh::new();
    DocumentView::new().tessellate(&doc, Detail::Final, &mut live);
    let s = count(&triangles(&live));
    eprintln!("across: {s:?}, Euler {}", s.euler());
    assert!(s.is_closed_manifold(), "{s:?}");
    assert_eq!((s.bodies, s.euler()), (1, 0), "{s:?}");
    assert_eq!(live, doc.mesh(Detail::Final));
    // The depth carved along the groove's bottom near the side, from the mesh (the
    // difference of the meshes before and after the stroke, by rays at the
    // centreline): the last centreline points of `a`'s piece, which ends on the side,
    // then the first of `b`'s, which starts there; about a centimetre each way.
    let piece = |k: usize| doc.strokes_on(doc.targets()[k].id)[0].1.clone();
    let (pa, pb) = (piece(a), piece(b));
    let joint = pa.centre.last().unwrap().distance(pb.centre[0]);
    assert!(
        joint <= 0.1 * tool_width,
        "the pieces meet at the side: {joint}"
    );
    let bottom: Vec<DVec3> = pa.centre[pa.centre.len() - 5..]
        .iter()
        .chain(&pb.centre[1..5])
        .copied()
        .collect();
    let depths: Vec<f64> = bottom
        .iter()
        .map(|&c| carved_depth(&before, &live, c, major))
        .collect();
    eprintln!("groove depth along its bottom across the side: {depths:?} (tool {depth})");
    for d in &depths {
        assert!((d - depth).abs() <= 0.1 * depth, "{depths:?}");
    }
    let jump = depths
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(jump <= 0.05 * depth, "{depths:?}");
}
