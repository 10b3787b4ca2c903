//! Runs the real `sculpt-tools volume` applications (streamlines, critical,
//! isosurface, morph) on files written here, and their bad input: one clear line and
//! a non-zero exit.

mod common;

use sculpt_core::formats::MeshFormat;
use sculpt_core::tolerance::{CRITICAL_POSITION_EPS, STREAMLINE_CLOSURE_EPS, TEST_WELD_EPS};

use common::{Files, assert_one_line_error};

/// The words of a command line (the test paths hold no spaces).
fn words(line: &str) -> Vec<&str> {
    line.split(' ').collect()
}

/// Runs a space-separated command line, which must succeed; its stdout.
fn ok(line: &str) -> String {
    common::ok(&words(line))
}

/// Runs a space-separated command line, which must fail with one line naming `needle`.
fn fails(line: &str, needle: &str) {
    assert_one_line_error(&words(line), needle);
}

/// A volume file over `[-1, 1]^3` of degree `p` with `p + 1` control points per
/// direction (one Bezier cell, control points at the Greville abscissae `-1 .. 1`),
/// attributes `x, y, z` and `names`, the extra values per point from `extra(i, j, l)`.
fn bezier_box(p: usize, names: &[&str], extra: impl Fn([usize; 3]) -> Vec<f64>) -> String {
    let knots: Vec<f64> = [vec![0.0; p + 1], vec![1.0; p + 1]].concat();
    let g = |i: usize| -1.0 + 2.0 * i as f64 / p as f64;
    let mut net = Vec::new();
    for i in 0..=p {
        let mut plane = Vec::new();
        for j in 0..=p {
            let mut row = Vec::new();
            for l in 0..=p {
                let mut v = vec![g(i), g(j), g(l)];
                v.extend(extra([i, j, l]));
                row.push(v);
            }
            plane.push(row);
        }
        net.push(plane);
    }
    let mut attrs = vec!["x", "y", "z"];
    attrs.extend(names);
    serde_json::json!({
        "format": "wandsculpt-volume", "version": 1,
        "degrees": [p, p, p],
        "knots": [knots, knots, knots],
        "attributes": attrs,
        "control_points": net,
    })
    .to_string()
}

#[test]
fn streamlines_trace_a_closed_orbit_and_refuse_a_seed_outside() {
    let files = Files::new();
    // A rigid rotation about the z axis, linear: exact with degree 1.
    let vol = files.put(
        "rot.json",
        &bezier_box(1, &["vx", "vy", "vz"], |[i, j, _]| {
            let (x, y) = (-1.0 + 2.0 * i as f64, -1.0 + 2.0 * j as f64);
            vec![-y, x, 0.0]
        }),
    );
    let seeds = files.put("seeds.csv", "x,y,z\n0.5,0,0.1\n0,0.25,-0.3\n");
    let out = files.path("lines.csv").display().to_string();
    let cmd = format!("volume streamlines {vol} --velocity vx,vy,vz --out {out}");
    let two_pi = 2.0 * std::f64::consts::PI;
    ok(&format!("{cmd} --seeds {seeds} --time {two_pi}"));
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("line,x,y,z"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    for (id, seed) in [(0.0, [0.5, 0.0, 0.1]), (1.0, [0.0, 0.25, -0.3])] {
        let line: Vec<&Vec<f64>> = rows.iter().filter(|r| r[0] == id).collect();
        assert!(line.len() > 10, "line {id}: {} points", line.len());
        for r in [line[0], line[line.len() - 1]] {
            for d in 0..3 {
                assert!(
                    (r[1 + d] - seed[d]).abs() <= STREAMLINE_CLOSURE_EPS,
                    "{r:?}"
                );
            }
        }
    }
    let outside = files.put("out.csv", "0.5,0,0\n1.5,0,0\n");
    fails(
        &format!("{cmd} --seeds {outside} --time 1"),
        "seed 1: point (1.5, 0, 0) is outside the volume",
    );
    let two = format!("volume streamlines {vol} --velocity vx,vy --out {out}");
    fails(
        &format!("{two} --seeds {seeds} --time 1"),
        "--velocity needs three attribute names",
    );
    let unknown = format!("volume streamlines {vol} --velocity vx,vy,w --out {out}");
    fails(
        &format!("{unknown} --seeds {seeds} --time 1"),
        "no attribute \"w\"",
    );
}

#[test]
fn critical_prints_the_zeros_of_a_quadratic_field_classified() {
    let files = Files::new();
    // V = (x^2 - 1/4, -y, -z): the Bezier coefficients of x^2 on [-1, 1] are 1, -1, 1.
    let vol = files.put(
        "q.json",
        &bezier_box(2, &["vx", "vy", "vz"], |[i, j, l]| {
            let sq = [1.0, -1.0, 1.0][i];
            vec![sq - 0.25, -(j as f64 - 1.0), -(l as f64 - 1.0)]
        }),
    );
    let out = ok(&format!("volume critical {vol} --velocity vx,vy,vz"));
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    let mut cps: Vec<(f64, f64, f64, String)> = doc["critical_points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            assert_eq!(c["eigenvalues"].as_array().unwrap().len(), 3);
            (
                c["x"].as_f64().unwrap(),
                c["y"].as_f64().unwrap(),
                c["z"].as_f64().unwrap(),
                c["kind"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    cps.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(cps.len(), 2, "{out}");
    for (c, (x, kind)) in cps.iter().zip([(-0.5, "node"), (0.5, "saddle")]) {
        assert!((c.0 - x).abs() <= CRITICAL_POSITION_EPS, "{c:?}");
        assert!(c.1.abs() <= CRITICAL_POSITION_EPS && c.2.abs() <= CRITICAL_POSITION_EPS);
        assert_eq!(c.3, kind);
    }
    // A volume without geometry cannot be analysed.
    let flat = files.put(
        "flat.json",
        r#"{"format": "wandsculpt-volume", "version": 1, "degrees": [1],
            "knots": [[0,0,1,1]], "attributes": ["vx","vy","vz"],
            "control_points": [[1,2,3],[4,5,6]]}"#,
    );
    fails(
        &format!("volume critical {flat} --velocity vx,vy,vz"),
        "needs a volume with 3 parameter directions and attributes x, y, z",
    );
}

#[test]
fn isosurface_of_a_fitted_distance_field_is_a_closed_sphere() {
    let files = Files::new();
    // The paper's Fig. 4 pipeline: scattered samples of a distance, fitted (sec. 3.1),
    // then meshed at a level (sec. 5.3).
    let mut csv = String::from("u,v,w,x,y,z,d\n");
    let n = 14;
    for i in 0..n {
        for j in 0..n {
            for l in 0..n {
                let u = [i, j, l].map(|a| a as f64 / (n - 1) as f64);
                let p = u.map(|a| 2.0 * a - 1.0);
                let d = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                csv.push_str(&format!(
                    "{},{},{},{},{},{},{d}\n",
                    u[0], u[1], u[2], p[0], p[1], p[2]
                ));
            }
        }
    }
    let data = files.put("samples.csv", &csv);
    let vol = files.path("sphere.json").display().to_string();
    ok(&format!(
        "volume fit {data} --params 3 --degrees 3,3,3 --counts 10,10,10 --out {vol}"
    ));
    let res = 24;
    let cell = 2.0 / res as f64;
    let iso = format!("volume isosurface {vol} --attribute d");
    for ext in ["stl", "obj"] {
        let mesh_path = files.path(&format!("s.{ext}")).display().to_string();
        ok(&format!("{iso} --level 0.6 --res {res} --out {mesh_path}"));
        let format = MeshFormat::from_extension(&mesh_path).unwrap();
        let mesh = format.read(&std::fs::read(&mesh_path).unwrap()).unwrap();
        let mesh = sculpt_core::mesh::weld(&mesh.vertices, &mesh.triangles, TEST_WELD_EPS);
        let report = mesh.edge_report();
        assert!(report.is_watertight(), "{ext}: {report:?}");
        assert!(mesh.triangles.len() > 300);
        for v in &mesh.vertices {
            let r = v.position.map(f64::from);
            let d = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            assert!((d - 0.6).abs() <= cell / 2.0, "{ext}: vertex at radius {d}");
        }
    }
    let none = files.path("none.stl").display().to_string();
    fails(
        &format!("{iso} --level 5 --res 8 --out {none}"),
        "does not reach the level 5",
    );
    let ply = files.path("x.ply").display().to_string();
    fails(
        &format!("{iso} --level 0.5 --out {ply}"),
        "must end in .stl, .obj or .glb",
    );
}

/// Writes an RGBA PNG of `w x h` pixels coloured by `f(x, y)`.
fn png(path: &str, w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(f(x, y)));
    img.save(path).unwrap();
    img.into_raw()
}

#[test]
fn morph_writes_frames_from_a_to_b_and_refuses_images_of_different_sizes() {
    let files = Files::new();
    let path = |name: &str| files.path(name).display().to_string();
    let (a_path, b_path, dir) = (path("a.png"), path("b.png"), path("frames"));
    let a = png(&a_path, 12, 8, |x, y| {
        [(x * 20) as u8, (y * 30) as u8, 7, 255]
    });
    let b = png(&b_path, 12, 8, |x, y| {
        [(y * 25) as u8, 200, (x * 9) as u8, 128]
    });
    let lines = files.put(
        "lines.json",
        r#"{"format": "wandsculpt-morph-lines", "version": 1,
            "lines": [{"source": [[2, 2], [9, 3]], "target": [[3, 1], [8, 6]]}]}"#,
    );
    let morph = format!("volume morph {a_path} {b_path} --out {dir}");
    ok(&format!("{morph} --frames 4 --lines {lines}"));
    let frame = |i: usize| {
        image::open(format!("{dir}/frame_{i:04}.png"))
            .unwrap()
            .into_rgba8()
            .into_raw()
    };
    assert!(frame(0) == a, "frame 0 is not A");
    assert!(frame(3) == b, "the last frame is not B");
    let mid = frame(1);
    assert!(mid != a && mid != b);
    let small = path("small.png");
    png(&small, 11, 8, |_, _| [0, 0, 0, 255]);
    fails(
        &format!("volume morph {a_path} {small} --frames 3 --out {dir}"),
        "the images differ in size: 12x8 and 11x8",
    );
    let bad = files.put(
        "bad.json",
        r#"{"format": "wandsculpt-morph-lines", "version": 1,
            "lines": [{"source": [[0, 0], [0, 0]], "target": [[1, 1], [2, 2]]}]}"#,
    );
    fails(
        &format!("{morph} --frames 3 --lines {bad}"),
        "line 0, source",
    );
    fails(&format!("{morph} --frames 1"), "--frames 1");
}

/// The commands docs/volumes.md shows, on the example files it shows
/// (docs/examples/volume/, written by `tools/examples/volume_pictures.rs`).
#[test]
fn the_documented_commands_run_on_the_documented_files() {
    let files = Files::new();
    let ex = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/examples/volume");
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/volumes.md"))
        .unwrap();
    let out = |name: &str| files.path(name).display().to_string();
    let lines = out("lines.csv");
    ok(&format!(
        "volume streamlines {ex}/flow.json --velocity vx,vy,vz --seeds {ex}/seeds.csv --time 20 --out {lines}"
    ));
    let seeds = std::fs::read_to_string(format!("{ex}/seeds.csv")).unwrap();
    let text = std::fs::read_to_string(&lines).unwrap();
    let last_line = text.lines().last().unwrap().split(',').next().unwrap();
    assert_eq!(
        last_line.parse::<usize>().unwrap(),
        seeds.lines().count() - 2
    );
    // The flow rises at a constant rate: it has no critical point.
    let cps = ok(&format!(
        "volume critical {ex}/flow.json --velocity vx,vy,vz"
    ));
    assert_eq!(cps.trim(), r#"{"critical_points":[]}"#);
    let stl = out("blobs.stl");
    ok(&format!(
        "volume isosurface {ex}/sphere.json --attribute d --level 0.45 --res 40 --out {stl}"
    ));
    let mesh = MeshFormat::Stl.read(&std::fs::read(&stl).unwrap()).unwrap();
    let mesh = sculpt_core::mesh::weld(&mesh.vertices, &mesh.triangles, TEST_WELD_EPS);
    assert!(mesh.edge_report().is_watertight());
    let frames = out("frames");
    ok(&format!(
        "volume morph {ex}/a.png {ex}/b.png --frames 5 --lines {ex}/lines.json --out {frames}"
    ));
    let a = image::open(format!("{ex}/a.png")).unwrap().into_rgba8();
    let first = image::open(format!("{frames}/frame_0000.png"))
        .unwrap()
        .into_rgba8();
    assert!(a == first);
    // The docs show these commands on these files.
    for needle in [
        "volume streamlines docs/examples/volume/flow.json",
        "volume isosurface docs/examples/volume/sphere.json --attribute d --level 0.45",
        "volume morph docs/examples/volume/a.png docs/examples/volume/b.png",
    ] {
        assert!(doc.contains(needle), "docs/volumes.md lacks '{needle}'");
    }
}
