//! Our IGES export, read by an independent CAD kernel: OpenCASCADE (OCCT 7.6), through
//! the small checker in `tools/occt-iges-check/` (built here with g++, once per run).
//!
//! Every paper scene is exported with [`Document::iges_surfaces`] and [`iges::write`];
//! OCCT must transfer every entity into valid faces, with as many faces and holes as we
//! wrote, the areas we compute ourselves, footprints classified OUT and the rest IN, and
//! the same surface points as our kernel.
//!
//! Skipped with a note when OCCT (`libocct-data-exchange-dev`) or g++ is missing on a
//! developer machine; with `CI` set (where `.ci/run` installs it) that is a failure.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use glam::{DVec2, DVec3};
use sculpt_core::formats::iges::{self, Face, IgesSurface, NurbsPatch};
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::jordan::Location;
use sculpt_core::sculpt::view::DocumentView;
use serde_json::Value;
use tests::tolerance::{
    OCCT_AREA_ABS as AREA_ABS, OCCT_AREA_REL as AREA_REL, OCCT_POINT_REL as POINT_REL,
    OCCT_STROKE_AREA_REL as STROKE_AREA_REL,
};

const CHECKER_SOURCE: &str = "tools/occt-iges-check/iges_check.cpp";
const OCCT_HEADER: &str = "/usr/include/opencascade/IGESControl_Reader.hxx";
/// OCCT libraries the checker links (all in `libocct-data-exchange-dev` and its deps).
const OCCT_LIBS: [&str; 9] = [
    "-lTKIGES",
    "-lTKXSBase",
    "-lTKBRep",
    "-lTKTopAlgo",
    "-lTKGeomAlgo",
    "-lTKG3d",
    "-lTKG2d",
    "-lTKMath",
    "-lTKernel",
];
/// The longest the checker may take on one file before the test calls it hung.
const CHECKER_TIMEOUT: Duration = Duration::from_secs(120);

/// The checker binary, built once into the target dir; `None` (after the note or the
/// CI failure) when OCCT or g++ is missing.
fn checker() -> Option<&'static Path> {
    static CHECKER: OnceLock<Option<PathBuf>> = OnceLock::new();
    CHECKER
        .get_or_init(|| {
            let missing = |what: &str| {
                let ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
                assert!(
                    !ci,
                    "{what} is missing in CI: install it with \
                     `apt-get install g++ libocct-data-exchange-dev` (.ci/run does)"
                );
                eprintln!(
                    "skipped: {what} is missing (apt-get install g++ libocct-data-exchange-dev)"
                );
                None
            };
            if !Path::new(OCCT_HEADER).exists() {
                return missing("OpenCASCADE (libocct-data-exchange-dev)");
            }
            if Command::new("g++").arg("--version").output().is_err() {
                return missing("g++");
            }
            let source = tests::workspace_root().join(CHECKER_SOURCE);
            let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("occt-iges-check");
            std::fs::create_dir_all(&dir).unwrap();
            let exe = dir.join("iges_check");
            let fresh = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
            if fresh(&exe).is_some() && fresh(&exe) >= fresh(&source) {
                return Some(exe);
            }
            // Built under a private name, then renamed: a concurrent run never sees half a file.
            let partial = dir.join(format!("iges_check.{}", std::process::id()));
            let out = Command::new("g++")
                .args(["-O1", "-std=c++17", "-w", "-I/usr/include/opencascade"])
                .arg(&source)
                .arg("-o")
                .arg(&partial)
                .args(OCCT_LIBS)
                .output()
                .expect("running g++");
            assert!(
                out.status.success(),
                "g++ could not build the OCCT checker:\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            std::fs::rename(&partial, &exe).unwrap();
            Some(exe)
        })
        .as_deref()
}

/// One query asked of every face: a point of the normalised parameter square.
#[derive(Debug, Clone, Copy)]
struct UvQuery(DVec2);

/// What OCCT reported for a file.
#[derive(Debug)]
struct Report {
    roots: Vec<Value>,
    faces: Vec<Value>,
    checks: Vec<Value>,
    file: Value,
}

impl Report {
    /// The faces of root `root` (1-based, in transfer order).
    fn faces_of(&self, root: u64) -> Vec<&Value> {
        self.faces.iter().filter(|f| f["root"] == root).collect()
    }
}

/// Runs the checker on IGES bytes with the given queries; panics with OCCT's message if
/// it cannot read the file or hangs.
fn occt(exe: &Path, name: &str, bytes: &[u8], queries: &[UvQuery]) -> Report {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("occt-iges-check");
    let igs = dir.join(format!("{name}.igs"));
    let qpath = dir.join(format!("{name}.queries"));
    std::fs::write(&igs, bytes).unwrap();
    let qtext: String = queries
        .iter()
        .map(|q| format!("uv {:.17} {:.17}\n", q.0.x, q.0.y))
        .collect();
    std::fs::write(&qpath, qtext).unwrap();
    let mut child = Command::new(exe)
        .arg(&igs)
        .arg("--queries")
        .arg(&qpath)
        .args(["--area-eps", "1e-8"]) // not a tolerance: OCCT's integration target, passed to it
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(stdout).unwrap());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > CHECKER_TIMEOUT {
            child.kill().unwrap();
            panic!("{name}: the OCCT checker hung (> {CHECKER_TIMEOUT:?})");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let text = reader.join().unwrap();
    let stderr = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
    assert!(
        status.success(),
        "{name}: OCCT could not read {} ({status}): {stderr}",
        igs.display()
    );
    let mut report = Report {
        roots: Vec::new(),
        faces: Vec::new(),
        checks: Vec::new(),
        file: Value::Null,
    };
    for line in text.lines() {
        let v: Value = serde_json::from_str(line)
            .unwrap_or_else(|e| panic!("{name}: checker line is not JSON ({e}): {line}"));
        match v["kind"].as_str() {
            Some("root") => report.roots.push(v),
            Some("face") => report.faces.push(v),
            Some("check") => report.checks.push(v),
            Some("file") => report.file = v,
            _ => panic!("{name}: unknown checker line {line}"),
        }
    }
    report
}

fn scene(name: &str) -> Document {
    let path = tests::workspace_root()
        .join("tests/data/scenes")
        .join(format!("{name}.json"));
    Document::from_json(&std::fs::read(&path).unwrap()).unwrap()
}

const SCENES: [&str; 7] = [
    "curved-patch-carved",
    "curved-patch-embossed",
    "sphere-overlaps",
    "mask-face",
    "saddle",
    "wavy",
    "hooked-tapered-end",
];

// ---- our own side: the expected topology, areas, classifications and points ----

/// Gauss-Legendre nodes and weights on [0, 1], 8 points (exact for degree 15).
fn gauss8() -> [(f64, f64); 8] {
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let mut out = [(0.0, 0.0); 8];
    for k in 0..4 {
        out[2 * k] = (0.5 - 0.5 * X[k], 0.5 * W[k]);
        out[2 * k + 1] = (0.5 + 0.5 * X[k], 0.5 * W[k]);
    }
    out
}

/// Gauss pieces per knot span in our area integration. Raising it to 4 or 16 changes
/// no area of the exports by more than 1e-14 relative (checked): ours is converged.
const SUBSPANS: usize = 1;

/// A surface of the export as our kernel evaluates it, with its knots in normalised
/// parameters (where the integrand is only piecewise smooth).
struct Ours {
    surface: NurbsSurface,
    breaks_u: Vec<f64>,
    breaks_v: Vec<f64>,
}

impl Ours {
    fn new(p: &NurbsPatch) -> Self {
        let surface = NurbsSurface::new(
            p.degree_u,
            p.degree_v,
            p.knots_u.clone(),
            p.knots_v.clone(),
            p.control_points.clone(),
            p.weights.clone(),
        )
        .unwrap();
        // Knots, each span further split in SUBSPANS (the area element is only as
        // smooth as sqrt allows where a span is nearly degenerate).
        let breaks = |k: &[f64], (a, b): (f64, f64)| {
            let mut v: Vec<f64> = k
                .iter()
                .map(|x| (x - a) / (b - a))
                .filter(|x| (0.0..=1.0).contains(x))
                .collect();
            v.dedup();
            let mut fine = vec![0.0];
            for w in v.windows(2) {
                fine.extend(
                    (1..=SUBSPANS).map(|i| w[0] + (w[1] - w[0]) * i as f64 / SUBSPANS as f64),
                );
            }
            fine
        };
        let breaks_u = breaks(surface.knots_u().knots(), surface.domain_u());
        let breaks_v = breaks(surface.knots_v().knots(), surface.domain_v());
        Ours {
            surface,
            breaks_u,
            breaks_v,
        }
    }

    /// S at a normalised parameter.
    fn point(&self, uv: DVec2) -> DVec3 {
        use sculpt_core::sculpt::surface::ParamSurface;
        self.surface.eval(uv).p
    }

    /// The area element |S_u x S_v| over the normalised square.
    fn jacobian(&self, uv: DVec2) -> f64 {
        use sculpt_core::sculpt::surface::ParamSurface;
        let e = self.surface.eval(uv);
        e.du.cross(e.dv).length()
    }

    /// F(u, v) = integral of the area element from u = 0 to u, at fixed v.
    fn area_primitive(&self, u: f64, v: f64) -> f64 {
        let mut sum = 0.0;
        for w in self.breaks_u.windows(2) {
            let (a, b) = (w[0], w[1].min(u));
            if b <= a {
                break;
            }
            for (x, wt) in gauss8() {
                sum += wt * (b - a) * self.jacobian(DVec2::new(a + x * (b - a), v));
            }
        }
        sum
    }

    /// The area (m^2) of the part of the surface over a face of the normalised square,
    /// by Green's theorem: the integral of F dv around the face's loops (outer
    /// counter-clockwise, holes clockwise, whichever way they are given), each edge split where it crosses a knot line
    /// and integrated by 8-point Gauss-Legendre.
    fn area(&self, face: &Face) -> f64 {
        let mut area = 0.0;
        for (n, lp) in std::iter::once(&face.outer).chain(&face.holes).enumerate() {
            let mut sum = 0.0;
            for k in 0..lp.len() {
                let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
                if a.y == b.y {
                    continue;
                }
                let mut ts = vec![0.0, 1.0];
                for (brk, (x0, x1)) in [(&self.breaks_u, (a.x, b.x)), (&self.breaks_v, (a.y, b.y))]
                {
                    for &k in brk {
                        let t = (k - x0) / (x1 - x0);
                        if t > 0.0 && t < 1.0 {
                            ts.push(t);
                        }
                    }
                }
                ts.sort_by(f64::total_cmp);
                for w in ts.windows(2) {
                    for (x, wt) in gauss8() {
                        let t = w[0] + x * (w[1] - w[0]);
                        let p = a.lerp(b, t);
                        sum += wt * (w[1] - w[0]) * (b.y - a.y) * self.area_primitive(p.x, p.y);
                    }
                }
            }
            // Whatever the loop's orientation: the outer loop adds, holes subtract.
            area += if n == 0 { sum.abs() } else { -sum.abs() };
        }
        area
    }
}

/// The whole normalised square as a face.
fn whole() -> Face {
    Face {
        outer: vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ],
        holes: Vec::new(),
    }
}

/// Crossing-number test of `p` against all loops of a face (even-odd).
fn inside(face: &Face, p: DVec2) -> bool {
    let mut odd = false;
    for lp in std::iter::once(&face.outer).chain(&face.holes) {
        for k in 0..lp.len() {
            let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
            if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x) {
                odd = !odd;
            }
        }
    }
    odd
}

/// The distance from `p` to the nearest loop edge of any of `faces`.
fn distance_to_loops(faces: &[Face], p: DVec2) -> f64 {
    let mut d = f64::INFINITY;
    for f in faces {
        for lp in std::iter::once(&f.outer).chain(&f.holes) {
            for k in 0..lp.len() {
                let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
                let ab = b - a;
                let t = ((p - a).dot(ab)
                    / ab.length_squared().max(sculpt_core::tolerance::DIVISOR_MIN))
                .clamp(0.0, 1.0);
                d = d.min(p.distance(a + ab * t));
            }
        }
    }
    d
}

/// Query points closer than this (normalised parameters) to a trimming loop are not
/// asked: "well inside" and "well outside" only.
const MARGIN_UV: f64 = 0.004;

/// What one export looked like in OCCT, for the test's summary line.
#[derive(Debug, Default)]
struct Seen {
    faces: usize,
    holes: usize,
    in_checked: usize,
    out_checked: usize,
    points_checked: usize,
    worst_area_rel: f64,
    worst_point_rel: f64,
}

/// Exports `surfaces`, reads them with OCCT, and asserts everything this file promises.
/// `hidden` are points (normalised) that must be hidden on every face of surface
/// `hidden.0` (inside a stroke's footprint).
fn check_export(
    exe: &Path,
    name: &str,
    surfaces: &[IgesSurface],
    hidden: &[(usize, DVec2)],
) -> Seen {
    let bytes = iges::write(surfaces).expect("finite surfaces");
    // The expected roots, in file order: each face of a trimmed surface is one entity
    // 144, an untrimmed surface one entity 128.
    let mut expected: Vec<(usize, Face)> = Vec::new();
    for (k, s) in surfaces.iter().enumerate() {
        match &s.faces {
            Some(faces) => expected.extend(faces.iter().map(|f| (k, f.clone()))),
            None => expected.push((k, whole())),
        }
    }
    // Queries: a grid over the square and the hidden points.
    let mut queries: Vec<UvQuery> = (0..11)
        .flat_map(|i| {
            (0..11)
                .map(move |j| UvQuery(DVec2::new((i as f64 + 0.5) / 11.0, (j as f64 + 0.5) / 11.0)))
        })
        .collect();
    queries.extend(hidden.iter().map(|&(_, p)| UvQuery(p)));
    let report = occt(exe, name, &bytes, &queries);

    let fails: Vec<&Value> = report
        .checks
        .iter()
        .filter(|c| c["severity"] == "fail")
        .collect();
    assert!(
        fails.is_empty(),
        "{name}: OCCT reports failures: {fails:#?}"
    );
    for w in report.checks.iter().filter(|c| c["severity"] == "warning") {
        eprintln!("{name}: OCCT warning: {w}");
    }
    assert_eq!(
        report.roots.len(),
        expected.len(),
        "{name}: OCCT found {} root entities, we wrote {}: {:#?}",
        report.roots.len(),
        expected.len(),
        report.roots
    );
    let ours: Vec<Ours> = surfaces.iter().map(|s| Ours::new(&s.patch)).collect();
    let mut seen = Seen::default();
    for (r, (root, (k, face))) in report.roots.iter().zip(&expected).enumerate() {
        let s = &surfaces[*k];
        let kind = if s.faces.is_some() { 144 } else { 128 };
        let what = format!("{name}: root {} ({} of surface {:?})", r + 1, kind, s.name);
        assert_eq!(root["type"], kind, "{what}: {root}");
        assert_eq!(
            root["transfer_failed"], false,
            "{what}: transfer failed: {root}"
        );
        let faces = report.faces_of(r as u64 + 1);
        assert_eq!(faces.len(), 1, "{what}: {} faces in OCCT", faces.len());
        let f = faces[0];
        assert_eq!(
            f["valid"], true,
            "{what}: BRepCheck_Analyzer finds the face invalid: {f}"
        );
        assert_eq!(
            f["holes"].as_u64(),
            Some(face.holes.len() as u64),
            "{what}: holes"
        );
        seen.faces += 1;
        seen.holes += face.holes.len();

        // Area: OCCT against Green's theorem over the loops we wrote.
        let ours_area = ours[*k].area(face);
        let occt_area = f["area"].as_f64().unwrap_or(f64::NAN);
        let rel = (occt_area - ours_area).abs() / ours_area;
        // OCCT's adaptive integration says how far it got (relative); on some cubic
        // stroke surfaces it stalls near 1e-6 whatever is asked.
        let occt_error = f["area_error"].as_f64().unwrap_or(0.0).max(0.0);
        let area_rel = if s.name.starts_with("stroke") {
            STROKE_AREA_REL
        } else {
            AREA_REL
        };
        sculpt_core::assert_near!(
            occt_area,
            ours_area,
            (area_rel + 2.0 * occt_error) * ours_area + AREA_ABS,
            "{what}: OCCT area {occt_area} m^2 (its error estimate {occt_error:e}), ours {ours_area} m^2"
        );
        seen.worst_area_rel = seen.worst_area_rel.max(rel);

        // Surface points and classification.
        let size = {
            let (lo, hi) = ours[*k].surface.control_bounds();
            (hi - lo).length()
        };
        let all_faces: Vec<Face> = match &s.faces {
            Some(fs) => fs.clone(),
            None => vec![whole()],
        };
        let qs = f["queries"].as_array().unwrap();
        assert_eq!(qs.len(), queries.len(), "{what}: answers");
        for (q, a) in queries.iter().zip(qs) {
            let p = a["p"]
                .as_array()
                .map(|p| {
                    DVec3::new(
                        p[0].as_f64().unwrap(),
                        p[1].as_f64().unwrap(),
                        p[2].as_f64().unwrap(),
                    )
                })
                .unwrap_or_else(|| panic!("{what}: no surface point at {q:?}: {a}"));
            let d = p.distance(ours[*k].point(q.0)) / size;
            sculpt_core::assert_near!(
                d,
                0.0,
                POINT_REL,
                "{what}: OCCT's S{:?} = {p} differs from ours {}",
                q.0,
                ours[*k].point(q.0)
            );
            seen.worst_point_rel = seen.worst_point_rel.max(d);
            seen.points_checked += 1;
            if distance_to_loops(&all_faces, q.0) < MARGIN_UV {
                continue;
            }
            let want = if inside(face, q.0) { "IN" } else { "OUT" };
            assert_eq!(a["state"], want, "{what}: OCCT classifies {:?}", q.0);
            if want == "IN" {
                seen.in_checked += 1;
            } else {
                seen.out_checked += 1;
            }
        }
        // Points inside a footprint are hidden on every face of their target.
        for (hq, (_, uv)) in qs[queries.len() - hidden.len()..]
            .iter()
            .zip(hidden)
            .filter(|(_, (h, _))| h == k)
        {
            assert_eq!(
                hq["state"], "OUT",
                "{what}: footprint point {uv:?} must be trimmed away"
            );
        }
    }
    let per_surface = surfaces
        .iter()
        .map(|s| s.faces.as_ref().map_or(1, Vec::len))
        .sum::<usize>();
    assert_eq!(
        report.file["faces"].as_u64(),
        Some(per_surface as u64),
        "{name}: face count"
    );
    seen
}

/// Points well inside each stroke's footprint (and away from every trimming loop) on
/// the target, which in every scene is the first surface of the export.
fn footprint_points(doc: &Document, surfaces: &[IgesSurface]) -> Vec<(usize, DVec2)> {
    assert_eq!(doc.targets().len(), 1, "scenes have one target");
    let faces = surfaces[0].faces.clone().expect("the target is trimmed");
    let mut out = Vec::new();
    for rec in doc.strokes() {
        let [stroke] = doc.stroke(rec.id).unwrap().pieces.as_slice() else {
            panic!("stroke {} falls into pieces", rec.id);
        };
        let n = stroke.centre_uv.len();
        for k in 1..8 {
            let p = stroke.centre_uv[k * (n - 1) / 8];
            if stroke.footprint.locate(p) == Location::Inside
                && distance_to_loops(&faces, p) > MARGIN_UV
            {
                assert!(
                    !faces.iter().any(|f| inside(f, p)),
                    "our export shows {p:?}, inside stroke {}'s footprint",
                    rec.id
                );
                out.push((0, p));
            }
        }
    }
    out
}

#[test]
fn paper_scenes_read_by_opencascade_match_our_geometry() {
    let Some(exe) = checker() else { return };
    for name in SCENES {
        let doc = scene(name);
        let surfaces = DocumentView::new().iges_surfaces(&doc);
        let hidden = footprint_points(&doc, &surfaces);
        assert!(
            hidden.len() >= doc.strokes().len(),
            "{name}: footprint points {}",
            hidden.len()
        );
        let seen = check_export(exe, name, &surfaces, &hidden);
        eprintln!("{name}: {seen:?}");
    }
}

/// A closed rational torus (R 0.3 m, r 0.1 m): whole (entity 128), and carved by a
/// stroke around its outer equator across the u = 0 seam (entity 144 on a closed
/// surface).
#[test]
fn torus_read_by_opencascade_matches_our_geometry() {
    use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
    let Some(exe) = checker() else { return };
    let torus = NurbsSurface::torus(DVec3::ZERO, 0.3, 0.1).unwrap();
    let mut doc = Document::new();
    let target = doc.add_target("torus", torus);
    let whole_torus = DocumentView::new().iges_surfaces(&doc);
    assert!(
        whole_torus[0].patch.weights.is_some(),
        "the torus is rational"
    );
    let seen = check_export(exe, "torus-whole", &whole_torus, &[]);
    eprintln!("torus-whole: {seen:?}");

    let tool = Tool {
        profile: Profile::V,
        width: 0.03,
        depth: 0.006,
        mode: Mode::Carve,
        taper: 0.02,
    };
    let samples = (0..=90)
        .map(|k| {
            let a = -0.4 + 1.2 * k as f64 / 90.0;
            (
                k as f64 / 90.0,
                DVec3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.101),
            )
        })
        .collect();
    doc.apply_stroke(target, StrokeInput { samples, tool })
        .unwrap();
    let surfaces = DocumentView::new().iges_surfaces(&doc);
    let hidden = footprint_points(&doc, &surfaces);
    assert!(!hidden.is_empty());
    let seen = check_export(exe, "torus-carved", &surfaces, &hidden);
    eprintln!("torus-carved: {seen:?}");
}

/// Faces as a caller might hand them to the writer, on a rational patch over a
/// non-normalised knot domain: an explicit closing point, a repeated point, loops in
/// the wrong orientation, an outer loop that touches itself.
#[test]
fn writer_edge_cases_read_by_opencascade() {
    let Some(exe) = checker() else { return };
    let p = |x: f64, y: f64| DVec2::new(x, y);
    let square = |c: DVec2, h: f64| vec![c + p(-h, -h), c + p(h, -h), c + p(h, h), c + p(-h, h)];
    let patch = NurbsPatch {
        degree_u: 2,
        degree_v: 1,
        knots_u: vec![5.0, 5.0, 5.0, 7.0, 7.0, 7.0],
        knots_v: vec![-1.0, -1.0, 2.0, 2.0],
        control_points: vec![
            vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)],
            vec![DVec3::new(0.5, 0.0, 0.3), DVec3::new(0.5, 1.0, 0.3)],
            vec![DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.1)],
        ],
        weights: Some(vec![vec![1.0, 1.0], vec![0.9, 0.8], vec![1.0, 1.0]]),
    };
    let mut closed = square(p(0.5, 0.5), 0.5);
    closed.push(closed[0]);
    let mut repeated = square(p(0.3, 0.3), 0.1);
    repeated.insert(2, repeated[1]);
    let faces = [
        Face {
            outer: closed,
            holes: vec![],
        },
        Face {
            outer: square(p(0.5, 0.5), 0.5),
            holes: vec![repeated.into_iter().rev().collect()],
        },
        Face {
            outer: square(p(0.5, 0.5), 0.5).into_iter().rev().collect(),
            holes: vec![square(p(0.5, 0.5), 0.2)],
        },
        Face {
            outer: vec![
                p(0.0, 0.0),
                p(1.0, 0.0),
                p(1.0, 1.0),
                p(0.5, 0.5),
                p(0.0, 1.0),
            ],
            holes: vec![],
        },
    ];
    let surfaces: Vec<IgesSurface> = faces
        .iter()
        .enumerate()
        .map(|(k, f)| IgesSurface {
            name: format!("case{k}"),
            patch: patch.clone(),
            faces: Some(vec![f.clone()]),
        })
        .chain([IgesSurface {
            name: "whole".into(),
            patch: patch.clone(),
            faces: None,
        }])
        .collect();
    let seen = check_export(exe, "writer-edge-cases", &surfaces, &[]);
    eprintln!("writer edge cases: {seen:?}");
    assert_eq!(seen.faces, 5);
}

/// The checker itself: a file OCCT cannot read is an error (exit 2, a message), not an
/// empty report; so is a truncated export.
#[test]
fn checker_rejects_files_opencascade_cannot_read() {
    let Some(exe) = checker() else { return };
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("occt-iges-check");
    std::fs::create_dir_all(&dir).unwrap();
    let doc = scene("saddle");
    let bytes = iges::write(&DocumentView::new().iges_surfaces(&doc)).expect("finite surfaces");
    for (name, content) in [
        ("not-iges", b"this is not an IGES file\n".to_vec()),
        ("truncated", bytes[..400].to_vec()),
    ] {
        let path = dir.join(format!("{name}.igs"));
        std::fs::write(&path, content).unwrap();
        let out = Command::new(exe)
            .arg(&path)
            .args(["--timeout", "60"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{name}: {out:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("iges_check:"), "{name}: {stderr}");
    }
}
