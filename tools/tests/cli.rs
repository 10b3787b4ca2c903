//! Runs the real `sculpt-tools` binary: eval and project, stdin and `--out`, and bad
//! input that must give a one-line error naming the file and line, never a panic.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

use glam::{DVec2, DVec3};
use sculpt_core::assert_near;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::tolerance::{EXACT_EPS, ULP_EPS};

const SURFACE: &str = r#"{"degree_u": 2, "degree_v": 2,
 "knots_u": [0,0,0,0.5,1,1,1], "knots_v": [0,0,0,1,1,1],
 "control_points": [
   [[0,0,0],[0,0.5,0.2],[0,1,0]],
   [[0.3,0,0.1],[0.3,0.5,0.4],[0.3,1,0.1]],
   [[0.7,0,0.1],[0.7,0.5,0.3],[0.7,1,0.1]],
   [[1,0,0],[1,0.5,0.2],[1,1,0]]],
 "weights": [[1,1,1],[1,2,1],[1,1,1],[1,0.5,1]]}"#;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sculpt-tools"))
}

fn run(args: &[&str], stdin: Option<&str>) -> Output {
    let mut child = bin()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn sculpt-tools");
    if let Some(text) = stdin {
        // A run that fails early (a bad surface file) may exit before reading its
        // input: the broken pipe is then expected, not a test failure (regression:
        // this test failed intermittently with EPIPE under load).
        let written = child.stdin.take().unwrap().write_all(text.as_bytes());
        if let Err(e) = written {
            assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe, "{e}");
        }
    } else {
        drop(child.stdin.take());
    }
    child.wait_with_output().unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

fn rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect()
}

/// A failed run: exit code 1, exactly one line on stderr, no panic, and the line
/// contains `needle`.
fn assert_one_line_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(needle), "expected '{needle}' in: {err}");
}

#[test]
fn eval_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let s = write(dir.path(), "s.json", SURFACE);
    let uv = write(
        dir.path(),
        "uv.csv",
        "u,v\n0,0\n0.25,0.5\n\n# comment\n1,1\n0.7, 0.1\n",
    );
    let out = run(&["eval", "--surface", &s, "--uv", &uv], None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let surface = NurbsSurface::from_json(SURFACE).unwrap();
    let got = rows(&String::from_utf8(out.stdout).unwrap());
    let uvs = [(0.0, 0.0), (0.25, 0.5), (1.0, 1.0), (0.7, 0.1)];
    assert_eq!(got.len(), uvs.len());
    for (row, (u, v)) in got.iter().zip(uvs) {
        assert_near!(row.clone(), surface.point(u, v).to_array().to_vec(), 0.0);
    }
}

#[test]
fn project_reads_stdin_and_writes_out() {
    let dir = tempfile::tempdir().unwrap();
    let s = write(dir.path(), "s.json", SURFACE);
    let out_path = dir.path().join("proj.csv");
    let points = "x,y,z\n0.5,0.5,1\n2,0.5,0\n-1,-1,-1\n0.3,0.5,0.3\n";
    let out = run(
        &[
            "project",
            "--surface",
            &s,
            "--points",
            "-",
            "--out",
            out_path.to_str().unwrap(),
        ],
        Some(points),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stdout.is_empty());
    let got = rows(&std::fs::read_to_string(&out_path).unwrap());
    let surface = NurbsSurface::from_json(SURFACE).unwrap();
    let inv = surface.inverter();
    let queries = [
        DVec3::new(0.5, 0.5, 1.0),
        DVec3::new(2.0, 0.5, 0.0),
        DVec3::splat(-1.0),
        DVec3::new(0.3, 0.5, 0.3),
    ];
    assert_eq!(got.len(), queries.len());
    for (row, q) in got.iter().zip(queries) {
        assert_eq!(row.len(), 6);
        let want = inv.closest_point(q);
        assert_near!(
            row[..2].to_vec(),
            vec![want.uv_in_knots.x, want.uv_in_knots.y],
            0.0
        );
        let point = DVec3::new(row[2], row[3], row[4]);
        assert_near!(
            point.to_array(),
            surface.point_uv(DVec2::new(row[0], row[1])).to_array(),
            EXACT_EPS
        );
        assert_near!(row[5], point.distance(q), ULP_EPS);
    }
    // The query beyond the u = 1 edge lands on that edge; the far corner on (0, 0).
    assert_near!(got[1][0], 1.0, 0.0);
    assert_near!(got[2][..2].to_vec(), vec![0.0, 0.0], 0.0);
}

#[test]
fn malformed_csv_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let s = write(dir.path(), "s.json", SURFACE);
    let cases = [
        (
            "bad_fields.csv",
            "0.1,0.2,0.3\n0.5,0.5\n1,2,3,4\n",
            "bad_fields.csv:2: expected 3 comma-separated numbers",
        ),
        (
            "bad_number.csv",
            "0.1,0.2,0.3\n0.1,zero,0.3\n",
            "bad_number.csv:2: 'zero' is not a number",
        ),
        (
            "nan.csv",
            "\n\n0.1,NaN,0.3\n",
            "nan.csv:3: 'NaN' is not a finite number",
        ),
        ("inf.csv", "inf,0,0\n", "inf.csv:1:"),
    ];
    for (name, text, needle) in cases {
        let p = write(dir.path(), name, text);
        let out = run(&["project", "--surface", &s, "--points", &p], None);
        assert_one_line_error(&out, needle);
    }
    let out = run(
        &["eval", "--surface", &s, "--uv", "-"],
        Some("0.5,0.5\n0.5;0.5\n"),
    );
    assert_one_line_error(&out, "<stdin>:2:");
}

#[test]
fn invalid_surfaces_name_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let uv = write(dir.path(), "uv.csv", "0.5,0.5\n");
    let cases = [
        ("trunc.json", &SURFACE[..60], "trunc.json:"),
        (
            "knots.json",
            &SURFACE.replace("[0,0,0,0.5,1,1,1]", "[0,0,0,1,0.5,1,1]"),
            "knots.json:",
        ),
        (
            "weights.json",
            &SURFACE.replace("[1,0.5,1]]", "[1,-0.5,1]]"),
            "weights",
        ),
        (
            "rows.json",
            &SURFACE.replace("[[0,0,0],[0,0.5,0.2],[0,1,0]],", ""),
            "control",
        ),
        ("nan.json", &SURFACE.replace("0.4", "NaN"), "nan.json:5:"),
    ];
    for (name, text, needle) in cases {
        let p = write(dir.path(), name, text);
        let out = run(&["eval", "--surface", &p, "--uv", &uv], None);
        assert_one_line_error(&out, needle);
    }
    let out = run(
        &["eval", "--surface", "/nonexistent/s.json", "--uv", &uv],
        None,
    );
    assert_one_line_error(&out, "/nonexistent/s.json: cannot read");
    let out = run(&["eval", "--surface", "-", "--uv", "-"], Some(SURFACE));
    assert_one_line_error(&out, "stdin");
}

/// Regression (issue 15 item 7): a surface that is valid JSON but invalid NURBS was
/// reported at `S.json:0:0`; it names the entry that is wrong instead.
#[test]
fn semantic_surface_errors_name_the_entry_not_line_0_column_0() {
    let dir = tempfile::tempdir().unwrap();
    let uv = write(dir.path(), "uv.csv", "0.5,0.5\n");
    let cases = [
        (
            "weights.json",
            SURFACE.replace("[1,0.5,1]]", "[1,-0.5,1]]"),
            "weights.json: invalid surface: invalid weights: control point [3][1]: weight -0.5 is not finite and positive",
        ),
        (
            "knots.json",
            SURFACE.replace("[0,0,0,0.5,1,1,1]", "[0,0,0,1,0.5,1,1]"),
            "knots.json: invalid surface: invalid knot vector: knots_u: knots decrease at index 4: 1 > 0.5",
        ),
    ];
    for (name, text, needle) in cases {
        let p = write(dir.path(), name, &text);
        let out = run(&["eval", "--surface", &p, "--uv", &uv], None);
        assert_one_line_error(&out, needle);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains(":0:0"), "{err}");
    }
}

#[test]
fn usage_errors_exit_non_zero() {
    let out = run(&["project", "--surface", "x.json"], None);
    assert!(!out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    let out = run(&["--help"], None);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("eval") && help.contains("project"));
}

/// `mesh --part` writes the sculpted target (default), the stroke surfaces, or both;
/// each file read back by the crate's own reader matches the library's tessellation.
#[test]
fn mesh_part_selects_target_strokes_or_all() {
    use sculpt_core::formats::MeshFormat;
    use sculpt_core::mesh::PatchMesh;
    use sculpt_core::sculpt::document::Document;
    use sculpt_core::sculpt::tessellate::Detail;
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/scenes/sphere-overlaps.json"
    );
    let doc = Document::from_json(&std::fs::read(scene).unwrap()).unwrap();
    let target = doc.mesh(Detail::Final).triangle_count();
    let mut strokes = PatchMesh::new();
    let stroke_tris = sculpt_core::sculpt::view::DocumentView::new().stroke_surfaces_mesh(
        &doc,
        Detail::Final,
        &mut strokes,
    );
    assert!(stroke_tris > 0);
    let dir = tempfile::tempdir().unwrap();
    let mut counts = Vec::new();
    for part in [None, Some("target"), Some("strokes"), Some("all")] {
        let out = dir
            .path()
            .join(format!("{}.obj", part.unwrap_or("default")));
        let out = out.to_str().unwrap();
        let mut args = vec!["mesh", "--scene", scene, "--out", out];
        if let Some(p) = part {
            args.extend(["--part", p]);
        }
        let run = run(&args, None);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let back = MeshFormat::Obj.read(&std::fs::read(out).unwrap()).unwrap();
        counts.push(back.triangles.len());
    }
    // Welding may drop a few collapsed slivers at tapered ends: compare loosely there.
    let near = |got: usize, want: usize| got <= want && got * 100 >= want * 99;
    assert!(near(counts[0], target), "default {} vs {target}", counts[0]);
    assert_eq!(counts[0], counts[1], "the default is the target");
    assert!(
        near(counts[2], stroke_tris),
        "strokes {} vs {stroke_tris}",
        counts[2]
    );
    assert!(near(counts[3], target + stroke_tris), "all {}", counts[3]);
    let bad = run(
        &[
            "mesh", "--scene", scene, "--out", "x.obj", "--part", "wings",
        ],
        None,
    );
    assert_eq!(bad.status.code(), Some(2), "a usage error");
}
