//! Runs the real `sculpt-tools rfm heat` on the shipped specs (tests/data/rfm): the
//! ring's probes against the exact solution derived here, the three output files read
//! back (CSV parsed, PNG decoded, JSON parsed), bad input that must fail with one line;
//! and `implicit eval` of a material document.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{ok, tools as run};
use sculpt_core::assert_near;
use sculpt_core::tolerance::{IMPLICIT_F32_REL, RFM_RING_PROBE_K};

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/rfm")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

fn fails(out: &Output, needle: &str) {
    assert!(!out.status.success(), "should fail");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    assert!(err.contains(needle), "{needle:?} not in {err}");
}

/// The ring of ring.toml: radii 0.5 and 1, lambda 7, alpha 100 on both, air at 1073 K
/// inside and 1573 K outside. `T = C + D ln r`; the film conditions
/// `-lambda D / b = alpha (C + D ln b - 1573)` (outer, normal +r) and
/// `lambda D / a = alpha (C + D ln a - 1073)` (inner, normal -r) solved for C and D.
fn ring_exact(r: f64) -> f64 {
    let (a, b, lambda, alpha) = (0.5f64, 1.0f64, 7.0, 100.0);
    // Subtracting the two conditions gives D, then C from the outer one.
    let d = alpha * (1573.0 - 1073.0) / (alpha * (b.ln() - a.ln()) + lambda / b + lambda / a);
    let c = 1573.0 - d * b.ln() - lambda * d / (alpha * b);
    c + d * r.ln()
}

fn read_probes(path: &Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("x,y,T"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|f| f.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

#[test]
fn ring_writes_probes_picture_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("ring");
    ok(&[
        "rfm",
        "heat",
        &data("ring.toml"),
        "--probes",
        &data("ring-probes.csv"),
        "--out",
        out.to_str().unwrap(),
    ]);
    let probes = read_probes(&out.join("probes.csv"));
    assert_eq!(probes.len(), 20);
    for [x, y, t] in &probes {
        let r = x.hypot(*y);
        assert_near!(*t, ring_exact(r), RFM_RING_PROBE_K);
    }

    let png = image::load_from_memory(&std::fs::read(out.join("temperature.png")).unwrap())
        .unwrap()
        .to_rgb8();
    assert!(
        png.width() > 400 && png.height() > 400,
        "{:?}",
        png.dimensions()
    );
    let colours: std::collections::HashSet<[u8; 3]> = png.pixels().map(|p| p.0).collect();
    assert!(colours.len() > 100, "{} colours", colours.len());
    // The centre of the field (the hole) is white, a pixel in the ring is not.
    let (fx0, fy0, fw) = (16u32, 28u32, 400u32);
    let field = |x: f64, y: f64, lo: f64, hi: f64| {
        let px = fx0 + ((x - lo) / (hi - lo) * f64::from(fw)) as u32;
        let py = fy0 + ((hi - y) / (hi - lo) * f64::from(fw)) as u32;
        png.get_pixel(px, py).0
    };

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["basis"]["degree"], 3);
    assert_eq!(report["basis"]["count"], serde_json::json!([10, 10]));
    assert_eq!(report["counts"]["unknowns"], 200);
    assert!(report["solve_seconds"].as_f64().unwrap() > 0.0);
    let b = report["basis"]["bounds"].as_array().unwrap();
    let (lo, hi) = (b[0].as_f64().unwrap(), b[2].as_f64().unwrap());
    assert_eq!(field(0.0, 0.0, lo, hi), [255, 255, 255]);
    assert_ne!(field(0.75, 0.0, lo, hi), [255, 255, 255]);
    let (tmin, tmax) = (
        report["min_T"].as_f64().unwrap(),
        report["max_T"].as_f64().unwrap(),
    );
    assert!(
        tmin >= ring_exact(0.5) - RFM_RING_PROBE_K && tmax <= ring_exact(1.0) + RFM_RING_PROBE_K
    );
    assert_eq!(report["probes"].as_array().unwrap().len(), 20);
    let bounds = report["boundaries"].as_array().unwrap();
    assert_near!(
        bounds[0]["mean_T"].as_f64().unwrap(),
        ring_exact(1.0),
        RFM_RING_PROBE_K
    );
    assert_near!(
        bounds[1]["mean_T"].as_f64().unwrap(),
        ring_exact(0.5),
        RFM_RING_PROBE_K
    );
}

#[test]
fn bad_input_fails_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("s.toml");
    let probes = dir.path().join("p.csv");
    std::fs::write(&probes, "x,y\n0,0\n").unwrap();
    let outdir = dir.path().join("out");
    let go = || {
        run(&[
            "rfm",
            "heat",
            spec.to_str().unwrap(),
            "--probes",
            probes.to_str().unwrap(),
            "--out",
            outdir.to_str().unwrap(),
        ])
    };
    let disc = |name: &str, cx: f64| {
        std::fs::write(
            dir.path().join(name),
            format!(r#"{{"solid": {{"circle": {{"center": [{cx}, 0], "radius": 0.5}}}}}}"#),
        )
        .unwrap();
    };
    disc("a.json", -2.0);
    disc("b.json", 2.0);
    let two = |a: &str, b: &str| {
        format!(
            "conductivity = 1.0\n[basis]\ncount = [6, 6]\n\
             [[boundary]]\nmodel = \"{a}\"\nambient = 300.0\nfilm = 10.0\n\
             [[boundary]]\nmodel = \"{b}\"\nambient = 300.0\nfilm = 10.0\n"
        )
    };
    std::fs::write(&spec, two("a.json", "b.json")).unwrap();
    fails(&go(), "no interior");
    std::fs::write(&spec, two("a.json", "missing.json")).unwrap();
    fails(&go(), "missing.json");
    std::fs::write(&spec, "conductivity = [").unwrap();
    fails(&go(), "invalid heat spec");
    std::fs::write(
        &spec,
        two("a.json", "a.json").replace("count = [6, 6]", "degree = 1\ncount = [6, 6]"),
    )
    .unwrap();
    fails(&go(), "degree");
    assert!(!outdir.join("report.json").exists());
}

/// A material document evaluates like a shape: the ring's boundary values exactly on
/// the circles (eq. 9) and the point's value at the point (eq. 2).
#[test]
fn implicit_eval_of_a_material_field() {
    let dir = tempfile::tempdir().unwrap();
    let pts = dir.path().join("p.csv");
    std::fs::write(&pts, "x,y\n0.5,0\n0,-1\n0.75,0\n0,0.75\n").unwrap();
    let text = ok(&[
        "implicit",
        "eval",
        &data("ring-material.json"),
        "--points",
        pts.to_str().unwrap(),
    ]);
    let v: Vec<f64> = text.lines().map(|l| l.parse().unwrap()).collect();
    assert_near!(v[0], 1073.0, 1073.0 * IMPLICIT_F32_REL);
    assert_near!(v[1], 1573.0, 1573.0 * IMPLICIT_F32_REL);
    assert_near!(v[2], 1200.0, 1200.0 * IMPLICIT_F32_REL);
    assert!(v[3] > 1073.0 && v[3] < 1573.0, "{}", v[3]);
}
