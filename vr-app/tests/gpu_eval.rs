//! The GPU path of implicit tapes (`vr_app::gpu_eval`, `wandsculpt --gpu-eval`) against
//! the CPU's f32 tape (`sculpt_core::implicit::Tape`), on lavapipe.
//!
//! The adapter is the one `WANDSCULPT_ADAPTER` names, lavapipe (`llvmpipe`) otherwise.
//! Without it a test says so and passes on a developer machine; in CI (a non-empty `CI`,
//! where scripts/test installs `mesa-vulkan-drivers`) a missing adapter is a failure.
//!
//! The CPU reference is independent of the code under test: the tape's own f32
//! evaluation (`Tape::eval_point`, `Tape::eval_grid`, themselves checked against f64
//! tree walks in sculpt-core), and a walk of the instructions here that also gives the
//! largest intermediate magnitude, which scales the tolerance of whole tapes.

use std::path::{Path, PathBuf};
use std::process::Command;

use sculpt_core::implicit::tape::{Grid, Instr, Tape};
use sculpt_core::implicit::{Binary, Model, Unary};
use vr_app::gpu_eval::wgsl::MAX_GPU_TAPE;
use vr_app::gpu_eval::{GpuEvalError, GpuTape, Wait, pruned};
use vr_app::render::Gpu;
use vr_app::tolerance::{
    GPU_EVAL_ARC_REL, GPU_EVAL_EXACT_ULPS, GPU_EVAL_MODEL_REL, GPU_EVAL_TRANSCENDENTAL_REL,
    GPU_EVAL_ULPS,
};

/// The adapter named by `WANDSCULPT_ADAPTER`, else lavapipe; `None` (the test skips)
/// only outside CI.
fn gpu() -> Option<Gpu> {
    let name = std::env::var(vr_app::render::gpu::ADAPTER_ENV)
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "llvmpipe".into());
    match Gpu::headless_named(Some(&name)) {
        Ok(gpu) => Some(gpu),
        Err(e) => {
            assert!(
                std::env::var_os("CI").is_none_or(|v| v.is_empty()),
                "the GPU evaluation tests need an adapter in CI ({name}): {e}"
            );
            eprintln!("skipped: no adapter {name:?}: {e}");
            None
        }
    }
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/implicit")
        .join(name)
}

/// A seeded generator, so failures reproduce.
struct Rng(fastrand::Rng);

impl Rng {
    fn seeded(seed: u64) -> Self {
        Self(fastrand::Rng::with_seed(seed))
    }
    fn index(&mut self, n: usize) -> usize {
        self.0.usize(..n)
    }
    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.0.f32()
    }
    /// `|v|` uniform in `[lo, hi)`, either sign.
    fn signed(&mut self, lo: f32, hi: f32) -> f32 {
        let v = self.range(lo, hi);
        if self.0.bool() { v } else { -v }
    }
}

/// The value and the largest intermediate magnitude of `tape` at `p`, walking its
/// instructions with the ops' own f32 semantics.
fn walk(tape: &Tape, p: [f32; 3]) -> (f32, f64) {
    let mut slots: Vec<f32> = Vec::with_capacity(tape.len());
    let mut scale = 0.0f64;
    for ins in tape.instrs() {
        let v = match *ins {
            Instr::Var(v) => p[v.index()],
            Instr::Const(c) => c,
            Instr::Unary(op, a) => op.apply(slots[a as usize]),
            Instr::Binary(op, a, b) => op.apply(slots[a as usize], slots[b as usize]),
        };
        if v.is_finite() {
            scale = scale.max(f64::from(v.abs()));
        }
        slots.push(v);
    }
    (*slots.last().unwrap(), scale)
}

/// How closely one op's GPU value must agree with the CPU's.
#[derive(Debug, Clone, Copy)]
enum Bound {
    /// This many ulps of the CPU value.
    Ulps(f64),
    /// This many ulps of the larger argument.
    ArgUlps(f64),
    /// This fraction of max(|value|, 1).
    Rel(f64),
}

fn unary_bound(op: Unary) -> Bound {
    match op {
        Unary::Recip | Unary::Sqrt => Bound::Ulps(GPU_EVAL_ULPS),
        Unary::Sin | Unary::Cos | Unary::Tan | Unary::Exp | Unary::Ln => {
            Bound::Rel(GPU_EVAL_TRANSCENDENTAL_REL)
        }
        Unary::Asin | Unary::Acos | Unary::Atan => Bound::Rel(GPU_EVAL_ARC_REL),
        _ => Bound::Ulps(GPU_EVAL_EXACT_ULPS),
    }
}

fn binary_bound(op: Binary) -> Bound {
    match op {
        Binary::Div => Bound::Ulps(GPU_EVAL_ULPS),
        Binary::Mod => Bound::ArgUlps(GPU_EVAL_ULPS),
        Binary::Atan2 => Bound::Rel(GPU_EVAL_ARC_REL),
        _ => Bound::Ulps(GPU_EVAL_EXACT_ULPS),
    }
}

/// Where each unary op is tested: its domain (WGSL leaves values outside it open).
fn unary_domain(op: Unary, rng: &mut Rng) -> f32 {
    match op {
        Unary::Sqrt => rng.range(0.0, 4.0),
        Unary::Ln => rng.range(0.001, 8.0),
        Unary::Asin | Unary::Acos => rng.range(-1.0, 1.0),
        Unary::Tan => rng.range(-1.2, 1.2),
        Unary::Recip => rng.signed(0.1, 4.0),
        Unary::Exp => rng.range(-10.0, 10.0),
        Unary::Sin | Unary::Cos => rng.range(-std::f32::consts::PI, std::f32::consts::PI),
        _ => rng.range(-4.0, 4.0),
    }
}

fn binary_domain(op: Binary, rng: &mut Rng) -> [f32; 2] {
    match op {
        Binary::Div => [rng.range(-4.0, 4.0), rng.signed(0.1, 4.0)],
        Binary::Mod => [rng.range(-4.0, 4.0), rng.signed(0.25, 2.0)],
        _ => [rng.range(-4.0, 4.0), rng.range(-4.0, 4.0)],
    }
}

/// The points of a one-op test: random ones in the domain, plus the special values
/// the op decides on (zeros, halves for `round`, equal arguments for `compare`).
fn op_points(rng: &mut Rng, sample: impl Fn(&mut Rng) -> [f32; 2]) -> Vec<[f32; 3]> {
    let mut pts: Vec<[f32; 3]> = (0..2000)
        .map(|_| {
            let [x, y] = sample(rng);
            [x, y, 0.0]
        })
        .collect();
    for x in [0.0f32, -0.0, 0.5, -0.5, 1.5, -2.5, 3.0] {
        for y in [0.0f32, 0.5, x, 1.0] {
            pts.push([x, y, 0.0]);
        }
    }
    pts
}

/// Checks the GPU's values of `model` at `pts` against the CPU tape's within `bound`;
/// returns the largest difference seen (in the bound's units).
fn check_op(gpu: &Gpu, what: &str, vm: &str, pts: &[[f32; 3]], bound: Bound) -> f64 {
    let tape = Model::from_vm(vm).unwrap().tape_negative_inside();
    let compiled = GpuTape::compile(gpu, &tape).unwrap();
    let (got, _) = compiled.eval_points(gpu, pts).unwrap();
    let mut worst = 0.0f64;
    for (p, g) in pts.iter().zip(&got) {
        let want = tape.eval_point(*p);
        if !want.is_finite() {
            // Outside the ops' domains (only at the special points): WGSL leaves
            // infinities and NaN open, so only their agreement in kind is asked.
            assert!(
                !g.is_finite(),
                "{what} at {p:?}: GPU {g}, CPU {want} (not finite)"
            );
            continue;
        }
        let (w, g) = (f64::from(want), f64::from(*g));
        let ulp = |v: f64| f64::from(f32::EPSILON) * v.abs().max(f64::from(f32::MIN_POSITIVE));
        let (err, allowed) = match bound {
            Bound::Ulps(n) => ((g - w).abs() / ulp(w), n),
            Bound::ArgUlps(n) => (
                (g - w).abs() / ulp(f64::from(p[0].abs().max(p[1].abs()))),
                n,
            ),
            Bound::Rel(r) => ((g - w).abs() / w.abs().max(1.0), r),
        };
        assert!(
            err <= allowed,
            "{what} at {p:?}: GPU {g}, CPU {w}: {err} > {allowed} ({bound:?})"
        );
        worst = worst.max(err);
    }
    worst
}

#[test]
fn every_op_agrees_with_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let mut rng = Rng::seeded(34);
    let mut report = Vec::new();
    for op in Unary::ALL {
        let pts = op_points(&mut rng, |r| [unary_domain(op, r), 0.0]);
        let vm = format!("x var-x\nr {} x\n", op.name());
        let worst = check_op(&gpu, op.name(), &vm, &pts, unary_bound(op));
        report.push(format!("{} {worst:e}", op.name()));
    }
    for op in Binary::ALL {
        let pts = op_points(&mut rng, |r| binary_domain(op, r));
        let vm = format!("x var-x\ny var-y\nr {} x y\n", op.name());
        let worst = check_op(&gpu, op.name(), &vm, &pts, binary_bound(op));
        report.push(format!("{} {worst:e}", op.name()));
    }
    eprintln!("largest differences: {}", report.join(", "));
}

/// A random program over the ops the shipped models use, finished by an `atan` that
/// keeps magnitudes bounded (as sculpt-core's tape tests build them).
fn random_program(rng: &mut Rng) -> String {
    let ops = [
        "add", "sub", "mul", "min", "max", "neg", "abs", "square", "and", "or", "sqrt", "div",
    ];
    let mut text = String::from("v0 var-x\nv1 var-y\nv2 var-z\n");
    let count = 3 + rng.index(30);
    for n in 3..count + 3 {
        let (a, b) = (rng.index(n), rng.index(n));
        let k = rng.index(ops.len() + 1);
        let line = match ops.get(k).copied() {
            None => format!("v{n} const {}", rng.range(-2.0, 2.0)),
            // sqrt of a square, and division by 1 + a square: inside their domains.
            Some("sqrt") => format!("t{n} square v{a}\nv{n} sqrt t{n}"),
            Some("div") => {
                format!("t{n} square v{b}\nu{n} const 1\nw{n} add t{n} u{n}\nv{n} div v{a} w{n}")
            }
            Some(op @ ("neg" | "abs" | "square")) => format!("v{n} {op} v{a}"),
            Some(op) => format!("v{n} {op} v{a} v{b}"),
        };
        text.push_str(&line);
        text.push('\n');
    }
    text.push_str(&format!("out atan v{}\n", count + 2));
    text
}

/// Checks `values` (the GPU's, at `points`) against the CPU walk to
/// [`GPU_EVAL_MODEL_REL`] of the largest intermediate (plus one).
fn check_tape(what: &str, tape: &Tape, points: &[[f32; 3]], values: &[f32]) -> f64 {
    let mut worst = 0.0f64;
    for (p, g) in points.iter().zip(values) {
        let (want, scale) = walk(tape, *p);
        if want.is_nan() {
            assert!(g.is_nan(), "{what} at {p:?}: GPU {g}, CPU NaN");
            continue;
        }
        let err = (f64::from(*g) - f64::from(want)).abs() / (1.0 + scale);
        assert!(
            err <= GPU_EVAL_MODEL_REL,
            "{what} at {p:?}: GPU {g}, CPU {want}, scale {scale}"
        );
        worst = worst.max(err);
    }
    worst
}

#[test]
fn random_programs_agree_at_random_points() {
    let Some(gpu) = gpu() else { return };
    let mut rng = Rng::seeded(2007);
    let mut worst = 0.0f64;
    for _ in 0..40 {
        let text = random_program(&mut rng);
        let tape = Model::from_vm(&text).unwrap().tape_negative_inside();
        let pts: Vec<[f32; 3]> = (0..500)
            .map(|_| [0; 3].map(|_| rng.range(-2.0, 2.0)))
            .collect();
        let compiled = GpuTape::compile(&gpu, &tape).unwrap();
        let (got, timing) = compiled.eval_points(&gpu, &pts).unwrap();
        assert_eq!(timing.chunks, 1);
        worst = worst.max(check_tape(&text, &tape, &pts, &got));
        // The walk here is the tape's own evaluation.
        for p in &pts[..10] {
            assert_eq!(walk(&tape, *p).0.to_bits(), tape.eval_point(*p).to_bits());
        }
    }
    eprintln!("largest difference / (1 + scale): {worst:e}");
}

/// The grid of one shipped model: 2D models on the unit square, 3D ones on a cube.
fn model_grid(name: &str) -> Grid {
    if name == "table4.json" {
        Grid::new([256, 128, 1], [0.0, 0.0, -0.5], [1.0, 1.0, 0.5]).unwrap()
    } else {
        Grid::new([40, 33, 29], [-1.2; 3], [1.2; 3]).unwrap()
    }
}

fn grid_points(grid: &Grid) -> Vec<[f32; 3]> {
    let mut pts = Vec::with_capacity(grid.len());
    for k in 0..grid.n[2] {
        for j in 0..grid.n[1] {
            for i in 0..grid.n[0] {
                pts.push([
                    grid.centre(0, i) as f32,
                    grid.centre(1, j) as f32,
                    grid.centre(2, k) as f32,
                ]);
            }
        }
    }
    pts
}

#[test]
fn shipped_models_agree_on_grids() {
    let Some(gpu) = gpu() else { return };
    for name in [
        "table4.json",
        "sphere.vm",
        "two-spheres.vm",
        "torus.json",
        "bracket.json",
    ] {
        let text = std::fs::read_to_string(data(name)).unwrap();
        let tape = Model::from_text(&text).unwrap().tape_negative_inside();
        let grid = model_grid(name);
        let compiled = GpuTape::compile(&gpu, &tape).unwrap();
        let (got, _) = compiled.eval_grid(&gpu, &grid).unwrap();
        let cpu = tape.eval_grid(&grid);
        assert_eq!(got.len(), cpu.len());
        let pts = grid_points(&grid);
        let worst = check_tape(name, &tape, &pts, &got);
        // Inside and outside agree wherever the CPU value is clear of zero.
        let flips = got
            .iter()
            .zip(&cpu)
            .filter(|(g, c)| c.abs() > 1e-4 && g.signum() != c.signum()) // not a tolerance: a sign test's margin, far above the measured differences
            .count();
        assert_eq!(flips, 0, "{name}: inside/outside differ");
        let inside = cpu.iter().filter(|v| **v < 0.0).count();
        assert!(
            inside > 0 && inside < cpu.len(),
            "{name}: the grid misses the surface"
        );
        eprintln!(
            "{name}: {} values, largest difference / (1 + scale) {worst:e}",
            got.len()
        );
    }
}

#[test]
fn chunked_grids_equal_one_dispatch() {
    let Some(gpu) = gpu() else { return };
    let text = std::fs::read_to_string(data("bracket.json")).unwrap();
    let tape = Model::from_text(&text).unwrap().tape_negative_inside();
    let grid = Grid::new([37, 21, 13], [-1.2; 3], [1.2; 3]).unwrap();
    let whole = GpuTape::compile(&gpu, &tape).unwrap();
    assert!(whole.chunk_limit() >= grid.len());
    let (one, t1) = whole.eval_grid(&gpu, &grid).unwrap();
    let mut chunked = GpuTape::compile(&gpu, &tape).unwrap();
    chunked.limit_chunks(1000);
    assert_eq!(chunked.chunk_limit(), 960);
    let (many, tn) = chunked.eval_grid(&gpu, &grid).unwrap();
    assert_eq!((t1.chunks, tn.chunks), (1, grid.len().div_ceil(960)));
    assert_eq!(
        one.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        many.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // Points in chunks too.
    let pts = grid_points(&grid);
    let (at_points, tp) = chunked.eval_points(&gpu, &pts).unwrap();
    assert_eq!(tp.chunks, grid.len().div_ceil(960));
    assert_eq!(
        one.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        at_points.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
}

/// Both ways of waiting for the readback, and a reused destination, give the same
/// values bit for bit; every value is written (the destination starts as NaN).
#[test]
fn readback_waits_and_reused_destinations_agree() {
    let Some(gpu) = gpu() else { return };
    let text = std::fs::read_to_string(data("bracket.json")).unwrap();
    let tape = Model::from_text(&text).unwrap().tape_negative_inside();
    let grid = Grid::new([37, 21, 13], [-1.2; 3], [1.2; 3]).unwrap();
    let mut compiled = GpuTape::compile(&gpu, &tape).unwrap();
    let bits = |v: &[f32]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let mut runs = Vec::new();
    for wait in [Wait::Block, Wait::Spin] {
        compiled.set_wait(wait);
        assert_eq!(compiled.wait(), wait);
        // Chunks of 960 cells, so the copy out of the mapped buffer runs in pieces.
        compiled.limit_chunks(1000);
        let job = compiled.grid_job(&gpu, &grid);
        assert_eq!(job.len(), grid.len());
        let mut dst = vec![f32::NAN; job.len()];
        for _ in 0..2 {
            let timing = job.run_into(&gpu, &mut dst).unwrap();
            assert!(timing.copy <= timing.gpu, "{timing:?}");
            runs.push(bits(&dst));
        }
    }
    for run in &runs {
        assert_eq!(run, &runs[0]);
    }
    let worst = check_tape(
        "bracket via run_into",
        &tape,
        &grid_points(&grid),
        &runs[0]
            .iter()
            .map(|&b| f32::from_bits(b))
            .collect::<Vec<_>>(),
    );
    eprintln!("waits agree, worst {worst:e}");
}

/// A union (`min`) of 27 spheres of radius 0.4 on a 3 x 3 x 3 lattice, as `.vm`.
fn sphere_lattice() -> String {
    let mut text = String::from("x var-x\ny var-y\nz var-z\nr const 0.4\n");
    for c in 0..27 {
        let centre = [c % 3, (c / 3) % 3, c / 9].map(|k| k as f32 - 1.0);
        for (a, v) in ["x", "y", "z"].iter().enumerate() {
            text.push_str(&format!(
                "c{c}{v} const {}\nd{c}{v} sub {v} c{c}{v}\n",
                centre[a]
            ));
            text.push_str(&format!("q{c}{v} square d{c}{v}\n"));
        }
        text.push_str(&format!(
            "s{c}a add q{c}x q{c}y\ns{c}b add s{c}a q{c}z\nl{c} sqrt s{c}b\ne{c} sub l{c} r\n"
        ));
        let prev = if c == 0 {
            "e0".to_string()
        } else {
            format!("u{}", c - 1)
        };
        text.push_str(&format!("u{c} min {prev} e{c}\n"));
    }
    text
}

/// Tapes pruned per tile on the CPU and sent to the GPU give the CPU's values to f32
/// rounding, on 3D and 2D grids whose faces cut tiles; pruning really happens.
#[test]
fn pruned_tiles_agree_with_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let tape = Model::from_vm(&sphere_lattice())
        .unwrap()
        .tape_negative_inside();
    for (n, tile) in [([45, 38, 29], 16), ([300, 170, 1], 64)] {
        let grid = Grid::new(n, [-1.6; 3], [1.6; 3]).unwrap();
        let (got, timing, report) =
            pruned::eval_grid_pruned(&gpu, &tape, &grid, tile, Wait::for_adapter(&gpu)).unwrap();
        let cpu = tape.eval_grid(&grid);
        assert_eq!(got.len(), cpu.len());
        let worst = check_tape("sphere lattice (pruned)", &tape, &grid_points(&grid), &got);
        let tiles = [0, 1, 2].map(|a| n[a].div_ceil(if n[a] == 1 { 1 } else { tile }));
        assert_eq!(report.tiles, tiles.iter().product::<usize>());
        assert!(
            report.tapes > 1 && report.tapes <= report.tiles,
            "{report:?}"
        );
        assert!(report.mean_len < 0.9 * report.full_len as f64, "{report:?}");
        assert!(timing.chunks >= report.tapes);
        eprintln!("pruned {n:?} tile {tile}: {report:?}, worst {worst:e}");
    }
}

/// A `.vm` chain of `len` clauses: x + 1 + 1 + ... (no two clauses merge).
fn long_model(len: usize) -> String {
    let mut text = String::from("v0 var-x\nc0 const 1\n");
    for i in 1..len {
        text.push_str(&format!("v{i} add v{} c0\n", i - 1));
    }
    text
}

#[test]
fn tapes_past_the_limit_are_refused() {
    let Some(gpu) = gpu() else { return };
    let tape = Model::from_vm(&long_model(MAX_GPU_TAPE + 10))
        .unwrap()
        .tape_negative_inside();
    assert!(tape.len() > MAX_GPU_TAPE);
    match GpuTape::compile(&gpu, &tape) {
        Err(GpuEvalError::TapeTooLong { len, max }) => {
            assert_eq!((len, max), (tape.len(), MAX_GPU_TAPE));
        }
        other => panic!("expected TapeTooLong, got {other:?}"),
    }
}

/// Runs `wandsculpt --gpu-eval` on `model`; returns its JSON report, stderr and values.
fn run_cli(model: &Path, grid: &str, bounds: &str) -> (serde_json::Value, String, Vec<f32>) {
    run_cli_with(model, grid, bounds, &[])
}

/// [`run_cli`] with more arguments.
fn run_cli_with(
    model: &Path,
    grid: &str,
    bounds: &str,
    extra: &[&str],
) -> (serde_json::Value, String, Vec<f32>) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v.f32");
    let adapter = std::env::var(vr_app::render::gpu::ADAPTER_ENV)
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "llvmpipe".into());
    let o = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--gpu-eval")
        .arg(model)
        .args(["--grid", grid, "--bounds", bounds, "--repeat", "3", "--out"])
        .arg(&out)
        .args(extra)
        .env(vr_app::render::gpu::ADAPTER_ENV, adapter)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "wandsculpt failed: {stderr}");
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bytes = std::fs::read(&out).unwrap();
    let values = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    (report, stderr, values)
}

#[test]
fn the_cli_writes_the_cpu_paths_file() {
    let Some(_gpu) = gpu() else { return };
    let model = data("table4.json");
    let (report, _, values) = run_cli(&model, "256x128", "0,1");
    assert_eq!(report["path"], "gpu", "{report}");
    assert!(report["adapter"].as_str().is_some_and(|s| !s.is_empty()));
    assert_eq!(report["cells"], 256 * 128);
    assert_eq!(report["gpu_ms_runs"].as_array().map(Vec::len), Some(3));
    let gpu_ms = report["gpu_ms"].as_f64().unwrap();
    let total_ms = report["total_ms"].as_f64().unwrap();
    assert!(gpu_ms > 0.0 && gpu_ms < total_ms, "{report}");
    // The library's CPU path, as `sculpt-tools implicit eval --grid 256x128 --bounds
    // 0,1` computes it (a 2D grid is the layer z = 0).
    let text = std::fs::read_to_string(&model).unwrap();
    let tape = Model::from_text(&text).unwrap().tape_negative_inside();
    let grid = Grid::new([256, 128, 1], [0.0, 0.0, -0.5], [1.0, 1.0, 0.5]).unwrap();
    assert_eq!(values.len(), grid.len());
    check_tape(
        "table4.json via the CLI",
        &tape,
        &grid_points(&grid),
        &values,
    );
}

/// `--gpu-prune` sends each tile its pruned tape and writes the same file as the
/// whole tape (to the models' bound); `--gpu-wait` is reported as chosen.
#[test]
fn the_cli_prunes_per_tile_on_request() {
    let Some(_gpu) = gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("spheres.vm");
    std::fs::write(&model, sphere_lattice()).unwrap();
    let (report, _, values) = run_cli_with(
        &model,
        "40x36x30",
        "-1.6,1.6",
        &["--gpu-prune", "16", "--gpu-wait", "spin"],
    );
    assert_eq!(report["path"], "gpu", "{report}");
    assert_eq!(report["wait"], "spin", "{report}");
    assert_eq!(report["prune"]["tile"], 16, "{report}");
    assert_eq!(report["prune"]["tiles"], 3 * 3 * 2, "{report}");
    assert!(report["prune"]["tapes"].as_u64().unwrap() > 1, "{report}");
    assert_eq!(report["copy_ms_runs"].as_array().map(Vec::len), Some(3));
    let tape = Model::from_vm(&sphere_lattice())
        .unwrap()
        .tape_negative_inside();
    let grid = Grid::new([40, 36, 30], [-1.6; 3], [1.6; 3]).unwrap();
    assert_eq!(values.len(), grid.len());
    check_tape(
        "spheres via --gpu-prune",
        &tape,
        &grid_points(&grid),
        &values,
    );
    let (whole, _, _) = run_cli_with(&model, "40x36x30", "-1.6,1.6", &["--gpu-wait", "block"]);
    assert_eq!(whole["wait"], "block", "{whole}");
    assert!(whole.get("prune").is_none(), "{whole}");
}

#[test]
fn the_cli_falls_back_to_the_cpu_for_long_tapes() {
    let Some(_gpu) = gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("long.vm");
    std::fs::write(&model, long_model(MAX_GPU_TAPE + 10)).unwrap();
    let (report, stderr, values) = run_cli(&model, "8x4x2", "-1,1");
    assert_eq!(report["path"], "cpu", "{report}");
    assert!(report["fallback"].as_str().unwrap().contains("GPU limit"));
    assert!(stderr.contains("evaluating on the CPU"), "{stderr}");
    let tape = Model::from_vm(&long_model(MAX_GPU_TAPE + 10))
        .unwrap()
        .tape_negative_inside();
    let grid = Grid::new([8, 4, 2], [-1.0; 3], [1.0; 3]).unwrap();
    assert_eq!(values, tape.eval_grid(&grid));
}

#[test]
fn the_cli_refuses_bad_models_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("bad.vm");
    std::fs::write(&model, "x var-x\ny frobnicate x\n").unwrap();
    let out = dir.path().join("v.f32");
    let o = Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--gpu-eval")
        .arg(&model)
        .args(["--grid", "4x4", "--bounds", "0,1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("unknown op `frobnicate`"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(!out.exists());
}
