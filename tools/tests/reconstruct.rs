//! `sculpt-tools reconstruct` end to end: the seeded torus, the real scans fetched by
//! `scripts/fetch-scans` (kitten.xyz, oni.pwn), and bad inputs.
//!
//! The real scans are read from `target/scans`; when they are missing the tests fail if
//! `CI` is set (CI must have run `scripts/fetch-scans`) and say so otherwise.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use sculpt_core::editor::{self, Applied};
use sculpt_core::formats::{iges, obj};
use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample};
use sculpt_core::reconstruct::read::{PointFormat, read_points};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::stroke::Tool;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sculpt-tools"))
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("spawn sculpt-tools")
}

fn report(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("report JSON on stdout")
}

fn num(v: &serde_json::Value, key: &str) -> usize {
    v[key].as_u64().unwrap_or_else(|| panic!("{key} in {v}")) as usize
}

/// A real scan from the cache, or `None` (outside CI) when it was not fetched.
fn scan(name: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../target/scans")
        .join(name);
    if p.is_file() {
        return Some(p);
    }
    let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty());
    assert!(
        !ci,
        "{} is missing: CI must run scripts/fetch-scans first",
        p.display()
    );
    eprintln!(
        "{} not fetched (run scripts/fetch-scans); skipped",
        p.display()
    );
    None
}

/// Checks shared by every closed object: each patch is one piece, surrounded by at
/// least three others, and the adjacency is a graph on a surface of the object's genus:
/// with faces of three or more sides, `E <= 3 (V - chi)` (`chi = 0` for genus 1), and
/// `E >= 2 V` for faces of at most four sides.
fn check_closed_genus_one(r: &serde_json::Value) {
    // The patches after the pinched ones were split (the model's vertices).
    let k = num(r, "patches_after_split");
    assert!(k >= num(r, "patches"), "{r}");
    assert_eq!(num(r, "patches_in_pieces"), 0, "{r}");
    assert!(num(r, "patch_degree_min") >= 3, "{r}");
    let e = num(r, "adjacent_pairs");
    assert!(e <= 3 * k && e >= 2 * k, "{r}");
    // The polygonal model is closed with V - E + F = 0, and every quad edge is shared
    // by exactly two quads.
    assert_eq!(r["euler_characteristic"], 0, "{r}");
    assert_eq!(num(r, "open_model_edges"), 0, "{r}");
    assert_eq!(num(r, "open_quad_edges"), 0, "{r}");
    assert!(num(r, "quads") >= 3 * num(r, "model_faces"), "{r}");
    // One NURBS patch per quad, every side shared by two patches.
    assert_eq!(num(r, "nurbs_patches"), num(r, "quads"), "{r}");
    assert_eq!(num(r, "shared_sides"), 2 * num(r, "quads"), "{r}");
}

fn fig(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

/// E_avg bound of the small torus (4,000 points, K = 30, 8x8 bicubic patches): the
/// issue's 0.03 % of the bounding-box diagonal.
const TORUS_E_AVG: f64 = 3e-4; // not a tolerance: an acceptance bound on a measured figure
/// Worst G1 angle of the small torus, degrees (near the corners where five or more
/// quads meet; the mean over sides is under 2 degrees).
const TORUS_G1_DEGREES: f64 = 15.0;
/// E_avg bound of the real scans: the 0.1 % of the bounding-box diagonal.
const SCAN_E_AVG: f64 = 1e-3; // not a tolerance: an acceptance bound on a measured figure
/// E_max bound of oni at K = 30 (measured 2.0 % of the diagonal; 12.9 % fitted to the
/// grids only).
const ONI_E_MAX: f64 = 3e-2; // not a tolerance: an acceptance bound on a measured figure
/// Mean over oni's shared sides of each side's worst G1 angle at K = 30, degrees
/// (measured 11; 34 fitted to the grids only).
const ONI_G1_MEAN_DEGREES: f64 = 15.0;
/// E_max bound of the kitten at K = 80 (measured 0.37 % of the diagonal; 1.10 % fitted
/// to the grids only).
const KITTEN_E_MAX: f64 = 0.6e-2; // not a tolerance: an acceptance bound on a measured figure

/// The document `reconstruct --out` wrote holds one target per patch, and carves: one
/// stroke across its first target through the editor, the path the app and replay use.
fn carve_one_stroke(doc: &Path, patches: usize) {
    let mut document = Document::from_json(&std::fs::read(doc).unwrap()).unwrap();
    assert_eq!(document.targets().len(), patches);
    let surface = document.targets()[0].surface.clone();
    let samples = (0..=20)
        .map(|k| StrokeSample {
            t: 0.01 * f64::from(k),
            position: surface.point(0.2 + 0.03 * f64::from(k), 0.5),
        })
        .collect();
    let tool = Tool {
        width: 0.01,
        ..Tool::default()
    };
    let edit = Edit::Stroke(StrokeEdit::new(document.targets()[0].id, tool, samples));
    assert!(matches!(
        editor::apply(&mut document, &edit),
        Applied::Stroke { .. }
    ));
    assert_eq!(document.strokes().len(), 1);
}

#[test]
fn torus_patches_cover_a_genus_one_surface() {
    let dir = tempfile::tempdir().unwrap();
    let layout = dir.path().join("layout.ply");
    let (doc, igs, obj) = (
        dir.path().join("scan.json"),
        dir.path().join("scan.igs"),
        dir.path().join("scan.obj"),
    );
    let out = run(&[
        "reconstruct",
        "torus:4000:7",
        "--patches",
        "30",
        "--degree",
        "3",
        "--control",
        "8",
        "--layout",
        layout.to_str().unwrap(),
        "--out",
        doc.to_str().unwrap(),
        "--igs",
        igs.to_str().unwrap(),
        "--obj",
        obj.to_str().unwrap(),
    ]);
    let r = report(&out);
    assert_eq!(num(&r, "points"), 4000);
    assert_eq!(r["normals"], "estimated");
    check_closed_genus_one(&r);
    assert!(fig(&r, "e_avg") <= TORUS_E_AVG, "{r}");
    assert!(fig(&r, "e_avg") <= fig(&r, "e_max"), "{r}");
    assert!(fig(&r, "g1_max_degrees") < TORUS_G1_DEGREES, "{r}");
    // The layout reads back through the point reader, with its normals.
    let back = read_points(&std::fs::read(&layout).unwrap(), PointFormat::Ply).unwrap();
    assert_eq!(back.points.len(), 4000);
    assert_eq!(back.normals.map(|n| n.len()), Some(4000));
    let patches = num(&r, "nurbs_patches");
    carve_one_stroke(&doc, patches);
    // IGES: one type 128 surface per patch; OBJ: a mesh with triangles.
    let model = iges::read(&std::fs::read(&igs).unwrap()).unwrap();
    assert_eq!(model.surfaces.len(), patches);
    let mesh = obj::read(&std::fs::read(&obj).unwrap()).unwrap();
    assert!(mesh.triangles.len() >= 2 * patches);
}

#[test]
fn kitten_scan_patches() {
    let Some(path) = scan("kitten.xyz") else {
        return;
    };
    // K = 80 (at K = 50 the model closes with Euler characteristic 1: docs/reconstruct.md).
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("kitten.json");
    let r = report(&run(&[
        "reconstruct",
        path.to_str().unwrap(),
        "--patches",
        "80",
        "--out",
        doc.to_str().unwrap(),
    ]));
    assert_eq!(num(&r, "points"), 5210);
    assert_eq!(r["normals"], "file");
    check_closed_genus_one(&r);
    assert!(fig(&r, "e_avg") <= SCAN_E_AVG, "{r}");
    assert!(fig(&r, "e_max") <= KITTEN_E_MAX, "{r}");
    // Regression (0.26 % before the patches the model pinched were split, issue 30):
    // the kitten's area facing against its data normals.
    assert!(
        fig(&r, "folded_area") <= sculpt_core::tolerance::FOLD_AREA_FRACTION,
        "{r}"
    );
    carve_one_stroke(&doc, num(&r, "nurbs_patches"));
}

#[test]
fn oni_scan_patches() {
    let Some(path) = scan("oni.pwn") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let report_path = dir.path().join("r.json");
    let doc = dir.path().join("oni.json");
    let out = run(&[
        "reconstruct",
        path.to_str().unwrap(),
        "--patches",
        "30",
        "--report",
        report_path.to_str().unwrap(),
        "--out",
        doc.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report_path).unwrap()).unwrap();
    assert_eq!(num(&r, "points"), 1435);
    assert_eq!(r["normals"], "file");
    // An open mask: every patch one piece and touching another.
    assert_eq!(num(&r, "patches_in_pieces"), 0);
    assert!(num(&r, "patch_degree_min") >= 1);
    // The 0.1 % (measured 0.091 % with the refit to the data; 0.93 % before
    // it, when the patches were fitted to their grids only).
    assert!(fig(&r, "e_avg") <= SCAN_E_AVG, "{r}");
    assert!(fig(&r, "e_max") <= ONI_E_MAX, "{r}");
    assert!(fig(&r, "g1_mean_degrees") <= ONI_G1_MEAN_DEGREES, "{r}");
    carve_one_stroke(&doc, num(&r, "nurbs_patches"));
}

/// One line on stderr, exit code 1, containing `needle`.
fn fails_with(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains(needle), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_inputs_give_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let nan = dir.path().join("nan.xyz");
    std::fs::write(&nan, "0 0 0\n1 1 1\nnan 0 0\n").unwrap();
    fails_with(
        &run(&["reconstruct", nan.to_str().unwrap(), "--patches", "2"]),
        "line 3",
    );
    let few = dir.path().join("few.xyz");
    std::fs::write(&few, "0 0 0\n0 0 0\n1 1 1\n").unwrap();
    fails_with(
        &run(&["reconstruct", few.to_str().unwrap(), "--patches", "3"]),
        "only 2 distinct points",
    );
    fails_with(
        &run(&["reconstruct", "points.stl", "--patches", "3"]),
        "unknown point format",
    );
}

/// Points as `.xyz` text, one `x y z` line each.
fn xyz_text<'a>(points: impl IntoIterator<Item = &'a glam::DVec3>) -> String {
    points
        .into_iter()
        .map(|p| format!("{} {} {}\n", p.x, p.y, p.z))
        .collect()
}

/// Writes `text` to `file` and runs `reconstruct` on it with `patches` patches.
fn reconstruct_xyz(file: &Path, text: &str, patches: usize) -> Output {
    std::fs::write(file, text).unwrap();
    run(&[
        "reconstruct",
        file.to_str().unwrap(),
        "--patches",
        &patches.to_string(),
    ])
}

#[test]
fn duplicates_and_outliers_are_accepted() {
    // The torus twice over plus far outliers: still clusters, every patch one piece
    // (an outlier alone is its own piece of the neighbour graph, so it joins a patch).
    let dir = tempfile::tempdir().unwrap();
    let pts = sculpt_core::reconstruct::sample::torus(1000, 0.2, 0.08, 5);
    let text = xyz_text(pts.iter().chain(&pts)) + "5 5 5\n-5 0 0\n";
    let r = report(&reconstruct_xyz(&dir.path().join("dup.xyz"), &text, 12));
    assert_eq!(num(&r, "points"), 2002);
    assert_eq!(num(&r, "patches_in_pieces"), 0);
}

/// E_avg bound of the torus with a hole in its data (measured below 0.01 %): the
/// network bridges the hole and still fits the points around it.
const HOLED_TORUS_E_AVG: f64 = 3e-4; // not a tolerance: an acceptance bound on a measured figure

#[test]
fn a_hole_in_the_data_is_bridged_and_the_rest_still_fits() {
    // The torus with every point within 0.05 of one surface point removed: a disc-shaped
    // hole, as a scanner's shadow leaves. The patches still close over it (no open
    // edge) and every remaining point stays near the network.
    let dir = tempfile::tempdir().unwrap();
    let pts = sculpt_core::reconstruct::sample::torus(4000, 0.2, 0.08, 7);
    let centre = glam::DVec3::new(0.28, 0.0, 0.0);
    let kept: Vec<_> = pts.iter().filter(|p| p.distance(centre) > 0.05).collect();
    assert!(kept.len() < pts.len() - 50, "the hole removes points");
    let r = report(&reconstruct_xyz(
        &dir.path().join("holed.xyz"),
        &xyz_text(kept.iter().copied()),
        30,
    ));
    assert_eq!(num(&r, "points"), kept.len());
    check_closed_genus_one(&r);
    eprintln!(
        "holed torus: e_avg {} e_max {}",
        fig(&r, "e_avg"),
        fig(&r, "e_max")
    );
    assert!(fig(&r, "e_avg") <= HOLED_TORUS_E_AVG, "{r}");
}

#[test]
fn a_thin_plate_gives_patches_or_one_clear_line() {
    // Both faces of a 1 x 1 x 0.004 plate, nearer each other than the sampling step:
    // neighbours mix the two faces. Either the patches come out whole or the
    // command says in one line why not; it never panics.
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::new();
    let n = 40;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
            text += &format!("{x} {y} 0\n{x} {y} 0.004\n");
        }
    }
    let out = reconstruct_xyz(&dir.path().join("plate.xyz"), &text, 8);
    if out.status.success() {
        let r = report(&out);
        assert_eq!(num(&r, "points"), 2 * n * n);
        assert_eq!(num(&r, "patches_in_pieces"), 0, "{r}");
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// Positions of the triangles of a binary STL, read here (80-byte header, count, 50
/// bytes a triangle), independently of the crate's readers.
fn stl_triangles(bytes: &[u8]) -> Vec<[[u32; 3]; 3]> {
    let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 84 + 50 * n);
    (0..n)
        .map(|k| {
            let at = |o: usize| {
                let b = &bytes[84 + 50 * k + o..84 + 50 * k + o + 4];
                f32::from_le_bytes(b.try_into().unwrap()).to_bits()
            };
            std::array::from_fn(|v| std::array::from_fn(|c| at(12 + 12 * v + 4 * c)))
        })
        .collect()
}

/// Positions of the triangles of an OBJ's `v` and `f` lines, read here.
fn obj_triangles(text: &str) -> Vec<[[u32; 3]; 3]> {
    let mut v: Vec<[u32; 3]> = Vec::new();
    let mut out = Vec::new();
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => v.push(std::array::from_fn(|_| {
                w.next().unwrap().parse::<f32>().unwrap().to_bits()
            })),
            Some("f") => {
                let idx: Vec<usize> = w
                    .map(|t| t.split('/').next().unwrap().parse::<usize>().unwrap() - 1)
                    .collect();
                assert_eq!(idx.len(), 3, "{line}");
                out.push([v[idx[0]], v[idx[1]], v[idx[2]]]);
            }
            _ => {}
        }
    }
    out
}

/// Half-edge count of triangles given by their corner positions (vertices are the
/// same where the bits are): (V - E + F, bodies, directed edges not matched by exactly
/// one edge the other way).
fn closed_surface(tris: &[[[u32; 3]; 3]]) -> (i64, usize, usize) {
    use std::collections::HashMap;
    let mut ids: HashMap<[u32; 3], usize> = HashMap::new();
    let faces: Vec<[usize; 3]> = tris
        .iter()
        .map(|t| {
            t.map(|p| {
                let n = ids.len();
                *ids.entry(p).or_insert(n)
            })
        })
        .collect();
    let mut parent: Vec<usize> = (0..ids.len()).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            x = parent[x];
        }
        x
    }
    let mut directed: HashMap<(usize, usize), usize> = HashMap::new();
    for f in &faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *directed.entry((a, b)).or_default() += 1;
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra] = rb;
        }
    }
    let bad = directed
        .iter()
        .filter(|&(&(a, b), &n)| a == b || n != 1 || directed.get(&(b, a)) != Some(&1))
        .count();
    let edges = directed.len() / 2;
    let mut roots: Vec<usize> = (0..ids.len()).map(|v| root(&mut parent, v)).collect();
    roots.sort_unstable();
    roots.dedup();
    (
        ids.len() as i64 - edges as i64 + faces.len() as i64,
        roots.len(),
        bad,
    )
}

/// Issue 30 item 2: `reconstruct --out` then `mesh` gives one closed, consistently
/// oriented surface of the torus's genus (Euler characteristic 0) at both details,
/// checked on the written files by the half-edge count above, and `mesh` says so.
#[test]
fn a_reconstructed_torus_meshes_into_one_watertight_surface() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("scan.json");
    let out = run(&[
        "reconstruct",
        "torus:4000:7",
        "--patches",
        "30",
        "--control",
        "6",
        "--out",
        doc.to_str().unwrap(),
    ]);
    // No folds: the network's area facing against the data normals (measured 0).
    let folded = fig(&report(&out), "folded_area");
    assert!(
        folded <= sculpt_core::tolerance::FOLD_AREA_FRACTION,
        "{folded}"
    );
    for (depth, file) in [("final", "scan.stl"), ("interactive", "scan.obj")] {
        let path = dir.path().join(file);
        let out = run(&[
            "mesh",
            "--scene",
            doc.to_str().unwrap(),
            "--depth",
            depth,
            "--out",
            path.to_str().unwrap(),
        ]);
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{said} {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            said.contains("open edges 0, watertight true, bodies 1, Euler characteristic 0"),
            "{said}"
        );
        let bytes = std::fs::read(&path).unwrap();
        let tris = if file.ends_with(".stl") {
            stl_triangles(&bytes)
        } else {
            obj_triangles(std::str::from_utf8(&bytes).unwrap())
        };
        assert_eq!(closed_surface(&tris), (0, 1, 0), "{depth}");
    }
}
