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

#[test]
fn mesh_writes_a_closed_stl_for_each_shipped_3d_model() {
    for (model, method) in ["sphere.vm", "two-spheres.vm", "bracket.json", "torus.json"]
        .into_iter()
        .flat_map(|m| [(m, "mt"), (m, "dc")])
    {
        let (_d, out) = tmp("m.stl");
        let text = ok(&run(&[
            "implicit",
            "mesh",
            &data(model),
            "--res",
            "24",
            "--bounds",
            "-1.2,1.2",
            "--method",
            method,
            "--out",
            out.to_str().unwrap(),
        ]));
        assert!(text.contains("\"triangles\""), "{text}");
        assert_eq!(text.contains("\"fans\""), method == "dc", "{text}");
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
