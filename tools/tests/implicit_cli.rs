//! Runs the real `sculpt-tools implicit` on the shipped models: values at points and
//! on grids against formulas written here, meshes read back and checked closed, and
//! bad input that must give one line and a non-zero exit.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use sculpt_core::assert_near;
use sculpt_core::tolerance::{IMPLICIT_F32_REL, TEST_WELD_EPS};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sculpt-tools"))
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("spawn sculpt-tools")
}

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/implicit")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

fn tmp(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    (dir, p)
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).unwrap()
}

fn read_f32(path: &Path) -> Vec<f32> {
    std::fs::read(path)
        .unwrap()
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

/// Shin, Kim and Sheen 2007, Fig. 12, negated to negative-inside.
fn fig12(x: f64, y: f64) -> f64 {
    let w0 = (0.16 - (x - 0.5).powi(2) - (y - 0.5).powi(2)) / 0.8;
    let w1 = -(0.01 - (x - 0.7).powi(2) - (y - 0.5).powi(2)) / 0.2;
    -(w0 + w1 - (w0 * w0 + w1 * w1).sqrt())
}

#[test]
fn eval_points_of_a_vm_sphere() {
    let (_d, csv) = tmp("p.csv");
    std::fs::write(&csv, "x,y,z\n0,0,0\n3,4,0\n0.5,0.5,0.5\n2,0\n").unwrap();
    let text = ok(&run(&[
        "implicit",
        "eval",
        &data("sphere.vm"),
        "--points",
        csv.to_str().unwrap(),
    ]));
    let got: Vec<f64> = text.lines().map(|l| l.parse().unwrap()).collect();
    let want = [-1.0, 4.0, 0.75f64.sqrt() - 1.0, 1.0];
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert_near!(*g, w, IMPLICIT_F32_REL);
    }
}

#[test]
fn eval_grid_2d_is_the_paper_benchmark_at_cell_centres() {
    let (_d, out) = tmp("v.f32");
    ok(&run(&[
        "implicit",
        "eval",
        &data("table4.json"),
        "--grid",
        "64x32",
        "--bounds",
        "0,1",
        "--out",
        out.to_str().unwrap(),
    ]));
    let v = read_f32(&out);
    assert_eq!(v.len(), 64 * 32);
    for (idx, got) in v.iter().enumerate() {
        let (i, j) = (idx % 64, idx / 64);
        let (x, y) = ((i as f64 + 0.5) / 64.0, (j as f64 + 0.5) / 32.0);
        assert_near!(
            f64::from(*got),
            fig12(x, y),
            IMPLICIT_F32_REL,
            "cell ({i}, {j})"
        );
    }
}

#[test]
fn eval_grid_3d_runs_x_fastest() {
    let (_d, out) = tmp("v.f32");
    ok(&run(&[
        "implicit",
        "eval",
        &data("sphere.vm"),
        "--grid",
        "5x4x3",
        "--bounds",
        "-1.5,1.5",
        "--out",
        out.to_str().unwrap(),
    ]));
    let v = read_f32(&out);
    assert_eq!(v.len(), 60);
    let c = |i: usize, n: usize| -1.5 + (i as f64 + 0.5) * 3.0 / n as f64;
    for (idx, got) in v.iter().enumerate() {
        let (x, y, z) = (c(idx % 5, 5), c((idx / 5) % 4, 4), c(idx / 20, 3));
        let want = (x * x + y * y + z * z).sqrt() - 1.0;
        assert_near!(f64::from(*got), want, IMPLICIT_F32_REL);
    }
}

/// Every method, and the default (no `--method`: octree simplification, whose report
/// names its node fans), writes a watertight mesh of every shipped 3D model.
#[test]
fn mesh_writes_a_closed_stl_for_each_shipped_3d_model() {
    for (model, chosen) in ["sphere.vm", "two-spheres.vm", "bracket.json", "torus.json"]
        .into_iter()
        .flat_map(|m| {
            [
                (m, None),
                (m, Some("mt")),
                (m, Some("dc")),
                (m, Some("octree")),
            ]
        })
    {
        let (_d, out) = tmp("m.stl");
        let path = data(model);
        let mut args = vec![
            "implicit",
            "mesh",
            &path,
            "--res",
            "24",
            "--bounds",
            "-1.2,1.2",
            "--out",
            out.to_str().unwrap(),
        ];
        if let Some(m) = chosen {
            args.extend(["--method", m]);
        }
        let text = ok(&run(&args));
        let method = chosen.unwrap_or("octree");
        assert!(text.contains("\"triangles\""), "{text}");
        assert_eq!(text.contains("\"fans\""), method != "mt", "{text}");
        assert_eq!(text.contains("\"node_fans\""), method == "octree", "{text}");
        let mesh = sculpt_core::formats::stl::read(&std::fs::read(&out).unwrap()).unwrap();
        let welded = sculpt_core::mesh::weld(&mesh.vertices, &mesh.triangles, TEST_WELD_EPS);
        let report = welded.edge_report();
        assert!(report.is_watertight(), "{model} ({method}): {report:?}");
        assert!(!welded.triangles.is_empty());
    }
}

/// Bad input: one line on stderr naming the problem, exit code 1, no panic.
#[test]
fn bad_input_gives_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_string_lossy().into_owned()
    };
    let pts = file("p.csv", "0,0,0\n");
    let cases = [
        (file("a.vm", "a var-x\nb frob a\n"), "unknown op `frob`"),
        (
            file("b.vm", "b add a a\na var-x\n"),
            "used before it is defined",
        ),
        (file("c.vm", "a var-x\nb mul a b\n"), "cycle"),
        (file("d.vm", "a const NaN\n"), "NaN"),
        (
            file(
                "e.json",
                r#"{"solid": {"sphere": {"center": [0,0,0], "radius": 0}}}"#,
            ),
            "radius",
        ),
        (file("f.json", r#"{"solid": {"sphere": "#), "solid document"),
    ];
    for (model, needle) in cases {
        let out = run(&["implicit", "eval", &model, "--points", &pts]);
        assert_eq!(out.status.code(), Some(1), "{model}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{model}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let sphere = data("sphere.vm");
    let out_path = dir.path().join("v.f32").to_string_lossy().into_owned();
    let stl_path = dir.path().join("m.stl").to_string_lossy().into_owned();
    for args in [
        vec![
            "implicit", "eval", &sphere, "--grid", "0x4", "--bounds", "0,1", "--out", &out_path,
        ],
        vec![
            "implicit", "eval", &sphere, "--grid", "4x4", "--bounds", "1,0", "--out", &out_path,
        ],
        vec![
            "implicit",
            "eval",
            &sphere,
            "--grid",
            "100000x100000x100000",
            "--bounds",
            "0,1",
            "--out",
            &out_path,
        ],
        vec![
            "implicit", "mesh", &sphere, "--res", "8", "--bounds", "0,1", "--out", "m.xyz",
        ],
        vec![
            "implicit", "mesh", &sphere, "--res", "8", "--bounds", "5,6", "--out", &stl_path,
        ],
    ] {
        let out = run(&args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
}

/// The paper's Fig. 8 kind of heterogeneous object (sec. 2.3.2; the figure itself is
/// lost from the text): a disc with two holes whose material takes 1.0 on the left
/// hole, 0.5 on the right one and 0.0 on the rim, by transfinite interpolation (eq. 9
/// with mu = 1). Values on a grid against eq. 9 written here with the circles'
/// distance-like functions `(r^2 - |p - c|^2) / (2 r)`, the boundary values on the
/// boundaries, and the picture: coloured inside the object, white in the holes and
/// outside.
#[test]
fn fig8_heterogeneous_object() {
    let (_d, out) = tmp("v.f32");
    let png = out.with_extension("png");
    let (n, lo, hi) = (128usize, -1.1f64, 1.1f64);
    ok(&run(&[
        "implicit",
        "eval",
        &data("fig8-material.json"),
        "--grid",
        &format!("{n}x{n}"),
        "--bounds",
        &format!("{lo},{hi}"),
        "--out",
        out.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
    ]));
    let circles = [
        ([0.0, 0.0], 1.0, 0.0),
        ([-0.45, 0.0], 0.25, 1.0),
        ([0.45, 0.0], 0.25, 0.5),
    ];
    let omega = |p: [f64; 2], (c, r, _): ([f64; 2], f64, f64)| {
        (r * r - (p[0] - c[0]).powi(2) - (p[1] - c[1]).powi(2)) / (2.0 * r)
    };
    let eq9 = |p: [f64; 2]| {
        let w: Vec<f64> = circles.iter().map(|&c| 1.0 / omega(p, c).abs()).collect();
        let total: f64 = w.iter().sum();
        circles.iter().zip(&w).map(|(c, w)| c.2 * w).sum::<f64>() / total
    };
    let v = read_f32(&out);
    assert_eq!(v.len(), n * n);
    let h = (hi - lo) / n as f64;
    let mut checked = 0;
    for (idx, got) in v.iter().enumerate() {
        let p = [
            lo + (idx % n) as f64 * h + h / 2.0,
            lo + (idx / n) as f64 * h + h / 2.0,
        ];
        let min_omega = circles
            .iter()
            .map(|&c| omega(p, c).abs())
            .fold(f64::MAX, f64::min);
        if min_omega < 0.02 {
            continue; // next to a boundary the f32 weights are dominated by one term
        }
        assert_near!(f64::from(*got), eq9(p), IMPLICIT_F32_REL, "cell at {p:?}");
        checked += 1;
    }
    assert!(checked > n * n / 2);
    // On each boundary: its value.
    let (_d2, csv) = tmp("p.csv");
    std::fs::write(&csv, "x,y\n0,1\n-0.7,0\n0.45,0.25\n0,-1\n").unwrap();
    let text = ok(&run(&[
        "implicit",
        "eval",
        &data("fig8-material.json"),
        "--points",
        csv.to_str().unwrap(),
    ]));
    let got: Vec<f64> = text.lines().map(|l| l.parse().unwrap()).collect();
    for (g, want) in got.iter().zip([0.0, 1.0, 0.5, 0.0]) {
        assert_near!(*g, want, IMPLICIT_F32_REL);
    }
    // The picture: a field of n x n pixels after the 16-pixel margin and 28-pixel title.
    let img = image::open(&png).unwrap().to_rgb8();
    assert!(img.width() > n as u32 && img.height() > n as u32);
    let pixel = |p: [f64; 2]| {
        let c = ((p[0] - lo) / h) as u32;
        let r = ((hi - p[1]) / h) as u32;
        *img.get_pixel(16 + c, 28 + r)
    };
    let white = image::Rgb([255u8, 255, 255]);
    for inside in [[0.0, 0.6], [-0.75, 0.3], [0.0, -0.2]] {
        assert_ne!(pixel(inside), white, "{inside:?} is in the object");
    }
    for outside in [[-0.45, 0.0], [0.45, 0.05], [1.05, 1.05]] {
        assert_eq!(pixel(outside), white, "{outside:?} is not in the object");
    }
    // Near the left hole (value 1) the colour is the hot end, near the rim the cold.
    let (hot, cold) = (pixel([-0.45, 0.27]), pixel([0.0, 0.97]));
    assert!(hot[0] > hot[2] && cold[2] > cold[0], "{hot:?} {cold:?}");
}
