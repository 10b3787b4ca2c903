//! Runs the real `sculpt-tools volume` commands on files written here: eval (with
//! derivatives), fit, analyze --integrate and grid, and bad input that must give one
//! clear line and a non-zero exit.

mod common;

use sculpt_core::assert_near;
use sculpt_core::tolerance::{FIT_EPS, VOLUME_EVAL_REL, VOLUME_EXACT_REL};
use sculpt_core::volume::{StructuredGrid, Volume};

/// The rational quarter cylindrical shell of docs/formats/volume.md: radii 1 to 2.5,
/// height 3, density `0.7 + 1.3 z`.
const SHELL: &str = r#"{"format": "wandsculpt-volume", "version": 1,
 "degrees": [2, 1, 1],
 "knots": [[0,0,0,1,1,1], [0,0,1,1], [0,0,1,1]],
 "attributes": ["x", "y", "z", "rho"],
 "control_points": [[[[1,0,0,0.7], [1,0,3,4.6]], [[2.5,0,0,0.7], [2.5,0,3,4.6]]],
                    [[[1,1,0,0.7], [1,1,3,4.6]], [[2.5,2.5,0,0.7], [2.5,2.5,3,4.6]]],
                    [[[0,1,0,0.7], [0,1,3,4.6]], [[0,2.5,0,0.7], [0,2.5,3,4.6]]]],
 "weights": [[[1,1],[1,1]], [[0.7071067811865476,0.7071067811865476],[0.7071067811865476,0.7071067811865476]], [[1,1],[1,1]]]}"#;

use common::{Files, assert_one_line_error};

/// The numbers of CSV output, row by row.
fn csv_numbers(text: &str) -> Vec<Vec<f64>> {
    let parse = |l: &str| -> Vec<f64> { l.split(',').flat_map(str::parse).collect() };
    text.lines().map(parse).collect()
}

#[test]
fn the_documented_example_is_the_analytic_shell() {
    // docs/formats/volume.md shows the same file; read it from there.
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/formats/volume.md"
    ))
    .unwrap();
    let start = doc.find("```json\n").unwrap() + 8;
    let end = start + doc[start..].find("```").unwrap();
    let from_doc = Volume::from_json(&doc[start..end]).unwrap();
    assert_eq!(from_doc, Volume::from_json(SHELL).unwrap());
}

#[test]
fn eval_prints_values_and_first_derivatives_per_row() {
    let files = Files::new();
    let vol_path = files.put("v.json", SHELL);
    let params = files.put("p.csv", "u,v,w\n0,0,0\n0.3,0.5,0.25\n1,1,1\n");
    let vol = Volume::from_json(SHELL).unwrap();
    let out = common::ok(&["volume", "eval", &vol_path, "--params", &params]);
    let got = csv_numbers(&out);
    assert_eq!(got.len(), 3);
    assert_near!(got[1].clone(), vol.point(&[0.3, 0.5, 0.25]).unwrap(), 0.0);
    let out = common::ok(&[
        "volume",
        "eval",
        &vol_path,
        "--params",
        &params,
        "--derivatives",
        "1",
    ]);
    let got = csv_numbers(&out);
    assert_eq!(got[1].len(), 4 * 4);
    let d = vol.derivatives(&[0.3, 0.5, 0.25], 1).unwrap();
    assert_near!(got[1][..4].to_vec(), d.value().to_vec(), VOLUME_EVAL_REL);
    for dir_ in 0..3 {
        assert_near!(
            got[1][4 * (1 + dir_)..4 * (2 + dir_)].to_vec(),
            d.d1(dir_).to_vec(),
            VOLUME_EVAL_REL
        );
    }
    // d rho / dw = 1.3 * 3 everywhere: density linear in height.
    assert_near!(got[2][4 * 3 + 3], 3.9, VOLUME_EVAL_REL * 10.0);
}

#[test]
fn analyze_integrates_the_analytic_volume_and_mass() {
    let files = Files::new();
    let vol_path = files.put("v.json", SHELL);
    let out = common::ok(&[
        "volume",
        "analyze",
        &vol_path,
        "--integrate",
        "--gauss",
        "16",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let quarter = std::f64::consts::FRAC_PI_4 * (2.5f64 * 2.5 - 1.0);
    let volume = quarter * 3.0;
    let mass = quarter * (0.7 * 3.0 + 1.3 * 9.0 / 2.0);
    assert_near!(
        v["volume"].as_f64().unwrap() / volume,
        1.0,
        VOLUME_EXACT_REL
    );
    assert_near!(
        v["integrals"]["rho"].as_f64().unwrap() / mass,
        1.0,
        VOLUME_EXACT_REL
    );
}

#[test]
fn fit_writes_a_volume_that_reproduces_its_samples() {
    let files = Files::new();
    // A function bilinear in the parameters, sampled on a 7 x 6 grid: a degree (1, 1)
    // fit with 3 x 3 control points reproduces it.
    let mut csv = String::from("s,t,temp,p\n");
    for i in 0..7 {
        for j in 0..6 {
            let (s, t) = (i as f64 / 6.0 * 2.0, j as f64 / 5.0);
            csv.push_str(&format!("{s},{t},{},{}\n", 1.0 + s * t, s - 2.0 * t));
        }
    }
    let data = files.put("d.csv", &csv);
    let out = files.path("fit.json");
    common::ok(&[
        "volume",
        "fit",
        &data,
        "--params",
        "2",
        "--degrees",
        "1,1",
        "--counts",
        "3,3",
        "--out",
        out.to_str().unwrap(),
    ]);
    let vol = Volume::from_json(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(vol.attributes(), ["temp", "p"]);
    assert_eq!(vol.counts(), [3, 3]);
    let got = vol.point(&[1.3, 0.45]).unwrap();
    assert_near!(got, vec![1.0 + 1.3 * 0.45, 1.3 - 0.9], FIT_EPS);
    // Fewer samples than one span needs.
    let few = files.put("few.csv", "a,b,c,f\n0,0,0,1\n1,1,1,2\n");
    assert_one_line_error(
        &[
            "volume",
            "fit",
            &few,
            "--params",
            "3",
            "--degrees",
            "2,2,2",
            "--counts",
            "4,4,4",
            "--out",
            out.to_str().unwrap(),
        ],
        "fewer than one knot span needs",
    );
    let nan = files.put("nan.csv", "a,f\n0,1\n0.5,NaN\n1,2\n");
    assert_one_line_error(
        &[
            "volume",
            "fit",
            &nan,
            "--params",
            "1",
            "--degrees",
            "1",
            "--counts",
            "2",
            "--out",
            out.to_str().unwrap(),
        ],
        "nan.csv:3: 'NaN' is not a finite number",
    );
}

#[test]
fn grid_writes_a_vtk_structured_grid_first_index_fastest() {
    let files = Files::new();
    let vol_path = files.put("v.json", SHELL);
    let vol = Volume::from_json(SHELL).unwrap();
    for binary in [false, true] {
        let out = files.path("g.vtk");
        let mut args = vec![
            "volume",
            "grid",
            &vol_path,
            "--res",
            "5,3,4",
            "--out",
            out.to_str().unwrap(),
        ];
        if binary {
            args.push("--binary");
        }
        common::ok(&args);
        let g = StructuredGrid::from_vtk(&std::fs::read(&out).unwrap()).unwrap();
        assert_eq!(g.dims, [5, 3, 4]);
        assert_eq!(g.arrays.len(), 1);
        assert_eq!(g.arrays[0].name, "rho");
        // Point (i, j, k) = (3, 1, 2) sits at index i + 5 (j + 3 k).
        let idx = 3 + 5 * (1 + 3 * 2);
        let want = vol.point(&[0.75, 0.5, 2.0 / 3.0]).unwrap();
        assert_near!(g.points[idx].to_vec(), want[..3].to_vec(), VOLUME_EVAL_REL);
        assert_near!(g.arrays[0].values[idx], want[3], VOLUME_EVAL_REL);
    }
}

/// `grid --f32`: raw little-endian f32, every attribute per point, the first index
/// fastest (the layout `wandsculpt --gpu-volume-eval` writes), each value the f64
/// evaluation at the uniform parameter rounded once.
#[test]
fn grid_f32_writes_every_attribute_first_index_fastest() {
    let files = Files::new();
    let vol_path = files.put("v.json", SHELL);
    let vol = Volume::from_json(SHELL).unwrap();
    let out = files.path("g.f32");
    common::ok(&[
        "volume",
        "grid",
        &vol_path,
        "--res",
        "5,3,4",
        "--f32",
        "--out",
        out.to_str().unwrap(),
    ]);
    let bytes = std::fs::read(&out).unwrap();
    let values: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert_eq!(values.len(), 5 * 3 * 4 * 4);
    for (i, j, l) in [(0, 0, 0), (3, 1, 2), (4, 2, 3), (1, 2, 0)] {
        let at = (i + 5 * (j + 3 * l)) * 4;
        let u = [i as f64 / 4.0, j as f64 / 2.0, l as f64 / 3.0];
        let want: Vec<f32> = vol.point(&u).unwrap().iter().map(|&v| v as f32).collect();
        assert_eq!(values[at..at + 4].to_vec(), want, "({i}, {j}, {l})");
    }
}

#[test]
fn bad_input_gets_one_clear_line() {
    let files = Files::new();
    let params = files.put("p.csv", "0.5,0.5,0.5\n");
    let bad = |name: &str, from: &str, to: &str| files.put(name, &SHELL.replacen(from, to, 1));
    let decreasing = bad(
        "dec.json",
        "[0,0,1,1], [0,0,1,1]]",
        "[0,0,1,0.5,1], [0,0,1,1]]",
    );
    assert_one_line_error(
        &["volume", "eval", &decreasing, "--params", &params],
        "knots of direction 1",
    );
    let count = bad("count.json", "[[0,0,0,1,1,1]", "[[0,0,0,0.5,1,1,1]");
    assert_one_line_error(
        &["volume", "eval", &count, "--params", &params],
        "the knots of direction 0 need 4",
    );
    let weight = bad("w.json", "[[[1,1],[1,1]], [[0.7", "[[[1,1],[1,-1]], [[0.7");
    assert_one_line_error(
        &["volume", "eval", &weight, "--params", &params],
        "weight [0][1][1] = -1",
    );
    let vol_path = files.put("v.json", SHELL);
    let nan = files.put("nan.csv", "0.5,nan,0.5\n");
    assert_one_line_error(
        &["volume", "eval", &vol_path, "--params", &nan],
        "nan.csv:1: 'nan' is not a finite number",
    );
    let short = files.put("short.csv", "0.5,0.5\n");
    assert_one_line_error(
        &["volume", "eval", &vol_path, "--params", &short],
        "expected 3 comma-separated parameters",
    );
    let not_json = files.put("x.json", "{\"format\": ");
    assert_one_line_error(
        &["volume", "analyze", &not_json, "--integrate"],
        "x.json:1:",
    );
    assert_one_line_error(
        &[
            "volume",
            "grid",
            &vol_path,
            "--res",
            "5,1,3",
            "--out",
            "/dev/null",
        ],
        "at least 2",
    );
}
