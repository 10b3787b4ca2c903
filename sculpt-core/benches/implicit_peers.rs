//! Side by side with Fidget (Keeter; crate `fidget` 0.5, its x86-64/aarch64 JIT), in
//! one run, on two of Fidget's own models:
//!
//! - dense evaluation: every cell-centre value of `prospero.vm` (2D, ~7,900 clauses)
//!   and of `bear.vm` (3D, ~660 clauses; its z = 0 section) on 2048^2 grids on
//!   [-1, 1]^2, and of `bear.vm` on a 512^3 grid on [-1, 1]^3 (the issue's "512^3
//!   (3D) or 2048^2 (2D)"; the 512^3 run is left out of the default for its length:
//!   `WANDSCULPT_PEERS_3D=1` adds it, `WANDSCULPT_PEERS_ONLY=dense3d` runs it alone,
//!   three timed rounds of each side, alternating). Ours is [`Tape::eval_grid`]
//!   (tiles pruned by interval arithmetic, evaluated in blocks). Fidget has no dense-grid call (its renderers fill pruned
//!   tiles with inside/outside flags, not values), so its side is its own render
//!   loop written with its public API: the same slabs on the same rayon pool, its
//!   JIT's tile sizes (128, 16 in 2D; 64, 16, 8 in 3D), an interval evaluation and
//!   `simplify` per tile, and its JIT float-slice evaluator on the leaf tiles;
//! - meshing `bear.vm` at 256^3 on [-1, 1]^3: ours with sharp features
//!   ([`dual_contour`]), the same with octree simplification
//!   ([`dual_contour_simplified`], default settings) and plain marching tetrahedra
//!   ([`contour`]), Fidget's manifold
//!   dual contouring (`Octree::build` at depth 8, then `walk_dual`).
//!
//! Before timing, the two dense results are compared (largest difference printed).
//! The meshes are timed once each (with their triangle counts), and by criterion as
//! well with `WANDSCULPT_PEERS_MESH_CRITERION=1`; `WANDSCULPT_PEERS_ONLY=mesh` or
//! `dense` runs one half.
//!
//! Fidget's models are never copied into this repository: point
//! `WANDSCULPT_FIDGET_MODELS` at a folder holding `prospero.vm` and `bear.vm`
//! (`scripts/fetch-fidget-models` fetches them); without it the bench says so and
//! times nothing.
//!
//! `WANDSCULPT_FIDGET_MODELS=target/fidget-models cargo bench -p sculpt-core
//!  --features fidget-bench --bench implicit_peers`

use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use fidget::context::Context;
use fidget::jit::JitShape;
use fidget::mesh::{Octree, Settings};
use fidget::render::ThreadPool;
use fidget::types::Interval;
use rayon::prelude::*;
use sculpt_core::implicit::Model;
use sculpt_core::implicit::contour::contour;
use sculpt_core::implicit::dual::{dual_contour, dual_contour_simplified};
use sculpt_core::implicit::octree::OctreeSimplify;
use sculpt_core::implicit::tape::{GRID_TILES_2D, GRID_TILES_3D, Grid, Tape, for_each_tile};
use std::hint::black_box;
use std::time::Instant;

/// The folder of Fidget's models, or why the bench skips.
fn models_dir() -> Result<PathBuf, String> {
    let dir = std::env::var_os("WANDSCULPT_FIDGET_MODELS").ok_or(
        "WANDSCULPT_FIDGET_MODELS is not set (scripts/fetch-fidget-models fetches the models)",
    )?;
    let dir = PathBuf::from(dir);
    for m in ["prospero.vm", "bear.vm"] {
        if !dir.join(m).is_file() {
            return Err(format!("{} has no {m}", dir.display()));
        }
    }
    Ok(dir)
}

/// One model read by both: our tape (negative inside, as the file) and Fidget's
/// JIT shape.
struct Pair {
    tape: Tape,
    jit: JitShape,
}

fn load(path: &std::path::Path) -> Pair {
    let text = std::fs::read_to_string(path).expect("model is readable");
    let tape = Model::from_vm(&text)
        .expect("our reader")
        .tape_negative_inside();
    let (ctx, root) = Context::from_text(text.as_bytes()).expect("Fidget's reader");
    let jit = JitShape::new(&ctx, root).expect("Fidget's JIT");
    Pair { tape, jit }
}

/// Per-thread state of Fidget's dense evaluation.
struct FidgetScratch {
    interval: fidget::shape::ShapeTracingEval<
        <fidget::jit::JitFunction as fidget::eval::Function>::IntervalEval,
    >,
    slice: fidget::shape::ShapeBulkEval<
        <fidget::jit::JitFunction as fidget::eval::Function>::FloatSliceEval,
    >,
    workspace: <fidget::jit::JitFunction as fidget::eval::Function>::Workspace,
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    index: Vec<usize>,
}

impl Default for FidgetScratch {
    fn default() -> Self {
        Self {
            interval: JitShape::new_interval_eval(),
            slice: JitShape::new_float_slice_eval(),
            workspace: Default::default(),
            xs: Vec::new(),
            ys: Vec::new(),
            zs: Vec::new(),
            index: Vec::new(),
        }
    }
}

type Boxed = [std::ops::Range<usize>; 3];

/// Where tiles write: cell centres per axis and the slab's index offset.
struct Target<'a> {
    coords: &'a [Vec<f32>; 3],
    stride: [usize; 3],
    base: usize,
}

/// The JIT interval tape of a shape.
type IntervalTape = fidget::shape::ShapeTape<
    <<fidget::jit::JitFunction as fidget::eval::Function>::IntervalEval as fidget::eval::TracingEvaluator>::Tape,
>;

/// Fidget's render loop for one tile: interval (on the parent's tape, compiled once
/// for all its children), simplify, recurse; bulk JIT at the leaves.
#[allow(clippy::too_many_arguments)]
fn fidget_tile(
    shape: &JitShape,
    itape: &IntervalTape,
    bx: Boxed,
    tiles: &[usize],
    t: &Target<'_>,
    out: &mut [f32],
    s: &mut FidgetScratch,
) {
    let c = t.coords;
    let iv = |a: usize| Interval::new(c[a][bx[a].start], c[a][bx[a].end - 1]);
    let (_, trace) = s
        .interval
        .eval(itape, iv(0), iv(1), iv(2))
        .expect("interval");
    let sub = match trace {
        Some(trace) => shape
            .simplify(trace, Default::default(), &mut s.workspace)
            .expect("simplify"),
        None => shape.clone(),
    };
    if let Some((&size, rest)) = tiles.split_first() {
        let sub_itape = sub.interval_tape(Default::default());
        for_each_tile(&bx, size, |b| {
            fidget_tile(&sub, &sub_itape, b, rest, t, out, s)
        });
        return;
    }
    s.xs.clear();
    s.ys.clear();
    s.zs.clear();
    s.index.clear();
    for k in bx[2].clone() {
        for j in bx[1].clone() {
            for i in bx[0].clone() {
                s.xs.push(c[0][i]);
                s.ys.push(c[1][j]);
                s.zs.push(c[2][k]);
                s.index.push(i + j * t.stride[1] + k * t.stride[2] - t.base);
            }
        }
    }
    let ftape = sub.float_slice_tape(Default::default());
    let vals = s.slice.eval(&ftape, &s.xs, &s.ys, &s.zs).expect("bulk");
    for (&i, &v) in s.index.iter().zip(vals) {
        out[i] = v;
    }
}

/// Every cell-centre value of `grid`, x fastest, by Fidget (module docs).
fn fidget_dense(shape: &JitShape, grid: &Grid) -> Vec<f32> {
    let n = grid.n;
    let tiles: &[usize] = if n[2] == 1 {
        &GRID_TILES_2D
    } else {
        &GRID_TILES_3D
    };
    let coords: [Vec<f32>; 3] =
        [0, 1, 2].map(|a| (0..n[a]).map(|i| grid.centre(a, i) as f32).collect());
    let stride = [1, n[0], n[0] * n[1]];
    let axis = if n[2] > 1 { 2 } else { 1 };
    let top = tiles[0];
    let mut out = vec![0.0f32; grid.len()];
    let itape = shape.interval_tape(Default::default());
    out.par_chunks_mut(top * stride[axis])
        .enumerate()
        .for_each_init(FidgetScratch::default, |s, (slab, chunk)| {
            let mut bx = [0..n[0], 0..n[1], 0..n[2]];
            bx[axis] = slab * top..((slab + 1) * top).min(n[axis]);
            let t = Target {
                coords: &coords,
                stride,
                base: bx[axis].start * stride[axis],
            };
            for_each_tile(&bx, top, |b| {
                fidget_tile(shape, &itape, b, &tiles[1..], &t, chunk, s)
            });
        });
    out
}

fn fidget_mesh(shape: &JitShape, depth: u8) -> fidget::mesh::Mesh {
    let bound = shape.clone().try_into().expect("no extra variables");
    let settings = Settings {
        depth,
        threads: Some(&ThreadPool::Global),
        ..Default::default()
    };
    Octree::build(&bound, &settings)
        .expect("not cancelled")
        .walk_dual()
}

/// The largest difference of two dense results and how many cells differ in sign.
fn compare(ours: &[f32], theirs: &[f32]) -> (f32, usize) {
    let worst = ours
        .iter()
        .zip(theirs)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    let signs = ours
        .iter()
        .zip(theirs)
        .filter(|(a, b)| (**a < 0.0) != (**b < 0.0))
        .count();
    (worst, signs)
}

/// The bear at 512^3 on [-1, 1]^3, dense: each side timed alone, alternating, three
/// rounds (a criterion run of 134 M values a sample is too long for a shared
/// machine); the first round's results are compared cell by cell.
fn dense_3d_timed(bear: &Pair) {
    let grid = Grid::new([512; 3], [-1.0; 3], [1.0; 3]).expect("grid");
    let (mut ours_s, mut theirs_s) = (Vec::new(), Vec::new());
    for round in 0..3 {
        let t = Instant::now();
        let ours = bear.tape.eval_grid(&grid);
        ours_s.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let theirs = fidget_dense(&bear.jit, &grid);
        theirs_s.push(t.elapsed().as_secs_f64());
        eprintln!(
            "implicit_peers: dense bear 512^3, round {round}: ours {:.3} s, Fidget JIT {:.3} s",
            ours_s[round], theirs_s[round]
        );
        if round == 0 {
            let (worst, signs) = compare(&ours, &theirs);
            eprintln!(
                "implicit_peers: bear_512x512x512: largest |ours - Fidget| {worst:e}, \
                 {signs} of {} cells differ in sign",
                ours.len()
            );
        }
    }
    eprintln!(
        "implicit_peers: dense bear 512^3, three rounds: ours {ours_s:.3?} s, \
         Fidget JIT {theirs_s:.3?} s"
    );
}

fn peers(c: &mut Criterion) {
    let dir = match models_dir() {
        Ok(d) => d,
        Err(why) => {
            eprintln!("implicit_peers: skipped, {why}");
            return;
        }
    };
    let prospero = load(&dir.join("prospero.vm"));
    let bear = load(&dir.join("bear.vm"));
    let mut group = c.benchmark_group("implicit_peers");
    group.sample_size(10);
    let mut cases = vec![
        ("prospero_2048x2048", &prospero, [2048, 2048, 1]),
        ("bear_z0_2048x2048", &bear, [2048, 2048, 1]),
    ];
    // `WANDSCULPT_PEERS_ONLY=mesh`, `dense` or `dense3d` runs one part.
    let only = std::env::var("WANDSCULPT_PEERS_ONLY").ok();
    if matches!(only.as_deref(), Some("mesh" | "dense3d")) {
        cases.clear();
    }
    if std::env::var_os("WANDSCULPT_PEERS_3D").is_some_and(|v| v == "1")
        || only.as_deref() == Some("dense3d")
    {
        dense_3d_timed(&bear);
    }
    for (name, pair, n) in cases {
        let lo = [-1.0, -1.0, if n[2] == 1 { -0.5 } else { -1.0 }];
        let hi = [1.0, 1.0, if n[2] == 1 { 0.5 } else { 1.0 }];
        // A 2D model on one layer at z = 0.
        let grid = Grid::new(n, lo, hi).expect("grid");
        let (ours, theirs) = (pair.tape.eval_grid(&grid), fidget_dense(&pair.jit, &grid));
        let (worst, signs) = compare(&ours, &theirs);
        eprintln!(
            "implicit_peers: {name}: tape {} clauses, largest |ours - Fidget| {worst:e}, \
             {signs} of {} cells differ in sign",
            pair.tape.len(),
            ours.len()
        );
        group.bench_function(format!("dense_{name}/ours"), |b| {
            b.iter(|| black_box(pair.tape.eval_grid(black_box(&grid))))
        });
        group.bench_function(format!("dense_{name}/fidget_jit"), |b| {
            b.iter(|| black_box(fidget_dense(&pair.jit, black_box(&grid))))
        });
    }
    if matches!(only.as_deref(), Some("dense" | "dense3d")) {
        group.finish();
        return;
    }
    // Meshing at 256^3: one timed run of each (criterion's samples of the slowest
    // take longer than a shared machine allows), then criterion's samples when
    // `WANDSCULPT_PEERS_MESH_CRITERION=1`.
    let ([lo, hi], n) = ([[-1.0; 3], [1.0; 3]], [256; 3]);
    let t = Instant::now();
    let (ours, report) = dual_contour(&bear.tape, n, lo, hi).expect("mesh");
    let ours_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let settings = OctreeSimplify::default();
    let (simple, simple_report) =
        dual_contour_simplified(&bear.tape, n, lo, hi, &settings).expect("mesh");
    let simple_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mt = contour(&bear.tape, n, lo, hi).expect("mesh");
    let mt_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let theirs = fidget_mesh(&bear.jit, 8);
    let theirs_s = t.elapsed().as_secs_f64();
    eprintln!(
        "implicit_peers: mesh bear 256^3, one run each: ours dual contouring {ours_s:.3} s \
         ({} triangles; {report:?}), ours octree-simplified {simple_s:.3} s ({} triangles; \
         {simple_report:?}; edges {:?}), ours marching tetrahedra {mt_s:.3} s ({} triangles), \
         Fidget octree {theirs_s:.3} s ({} triangles)",
        ours.triangles.len(),
        simple.triangles.len(),
        simple.edge_report(),
        mt.triangles.len(),
        theirs.triangles.len()
    );
    if std::env::var_os("WANDSCULPT_PEERS_MESH_CRITERION").is_some_and(|v| v == "1") {
        group.bench_function("mesh_bear_256/ours_dual_contour", |b| {
            b.iter(|| black_box(dual_contour(&bear.tape, n, lo, hi).expect("mesh")))
        });
        group.bench_function("mesh_bear_256/ours_octree_simplified", |b| {
            b.iter(|| {
                black_box(dual_contour_simplified(&bear.tape, n, lo, hi, &settings).expect("mesh"))
            })
        });
        group.bench_function("mesh_bear_256/ours_marching_tetrahedra", |b| {
            b.iter(|| black_box(contour(&bear.tape, n, lo, hi).expect("mesh")))
        });
        group.bench_function("mesh_bear_256/fidget_jit_manifold_dc", |b| {
            b.iter(|| black_box(fidget_mesh(&bear.jit, 8)))
        });
    }
    group.finish();
}

criterion_group!(benches, peers);
criterion_main!(benches);
