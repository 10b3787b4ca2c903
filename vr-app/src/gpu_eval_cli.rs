//! `wandsculpt --gpu-eval MODEL --grid NxM[xK] --bounds LO,HI --out V.f32`: an implicit
//! model evaluated on the GPU at grid cell centres, with no window (docs/implicit.md).
//!
//! The file is the one `sculpt-tools implicit eval --grid` writes: little-endian f32 at
//! the cell centres `LO + (i + 0.5) (HI - LO) / N`, x fastest, negative inside; a 2D
//! grid is the layer z = 0. The JSON report on stdout names the adapter and gives the
//! GPU time from submit to the values read back. A tape longer than the GPU path
//! compiles is evaluated on the CPU instead, which the report and stderr say.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use sculpt_core::implicit::Model;
use sculpt_core::implicit::tape::{Grid, Tape};
use serde_json::{Value, json};
use vr_app::gpu_eval::{EvalTiming, GpuEvalError, GpuTape, Wait, pruned};
use vr_app::render::Gpu;

/// The arguments of `--gpu-eval`.
pub struct GpuEvalArgs<'a> {
    /// The model file.
    pub model: &'a Path,
    /// `NxM` or `NxMxK`.
    pub grid: &'a str,
    /// `LO,HI`.
    pub bounds: &'a str,
    /// The f32 file written.
    pub out: &'a Path,
    /// Evaluations (timed each).
    pub repeat: usize,
    /// How to wait for the readback (`None`: [`Wait::for_adapter`]).
    pub wait: Option<Wait>,
    /// Prune the tape per tile of this many cells on a side first.
    pub prune: Option<usize>,
}

/// The grid of `--grid` and `--bounds`: a 2D grid (`NxM`) is one layer centred on
/// z = 0, as `sculpt-tools implicit eval` samples it.
fn grid_of(spec: &str, bounds: &str) -> Result<Grid> {
    let counts: Vec<&str> = spec.split(['x', 'X']).collect();
    if !(2..=3).contains(&counts.len()) {
        bail!("--grid {spec:?}: expected NxM or NxMxK");
    }
    let mut n = [1usize; 3];
    for (slot, text) in n.iter_mut().zip(&counts) {
        *slot = match text.trim().parse::<usize>() {
            Ok(k) if k > 0 => k,
            _ => bail!("--grid {spec:?}: {text:?} is not a positive count"),
        };
    }
    let ends: Vec<f64> = bounds
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--bounds {bounds:?}: expected two numbers LO,HI"))?;
    let &[lo, hi] = ends.as_slice() else {
        bail!("--bounds {bounds:?}: expected two numbers LO,HI");
    };
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        bail!("--bounds {bounds:?}: expected finite LO < HI");
    }
    let (zlo, zhi) = if counts.len() == 2 {
        (-0.5, 0.5)
    } else {
        (lo, hi)
    };
    Ok(Grid::new(n, [lo, lo, zlo], [hi, hi, zhi])?)
}

/// The timing fields of the report: every run's GPU time (submit to values read
/// back) and copy time (out of the mapped buffer), the first, median and minimum.
fn report_runs(report: &mut Value, runs: &[EvalTiming]) {
    let gpu: Vec<f64> = runs.iter().map(|t| ms(t.gpu)).collect();
    let copy: Vec<f64> = runs.iter().map(|t| ms(t.copy)).collect();
    report["path"] = json!("gpu");
    report["chunks"] = json!(runs.last().map_or(0, |t| t.chunks));
    report["gpu_ms"] = json!(gpu[0]);
    report["gpu_ms_median"] = json!(median(&gpu));
    report["gpu_ms_min"] = json!(gpu.iter().copied().fold(f64::INFINITY, f64::min));
    report["gpu_ms_runs"] = json!(gpu);
    report["copy_ms_median"] = json!(median(&copy));
    report["copy_ms_runs"] = json!(copy);
}

/// The whole tape on every cell, `repeat` times into one destination (allocated and
/// written once before the first run, so no run pays for its pages).
fn eval_whole(
    gpu: &Gpu,
    tape: &Tape,
    grid: &Grid,
    wait: Wait,
    repeat: usize,
    report: &mut Value,
) -> Result<Vec<f32>, GpuEvalError> {
    let mut compiled = GpuTape::compile(gpu, tape)?;
    compiled.set_wait(wait);
    let job = compiled.grid_job(gpu, grid);
    let mut values = vec![f32::NAN; job.len()];
    let runs = (0..repeat.max(1))
        .map(|_| job.run_into(gpu, &mut values))
        .collect::<Result<Vec<_>, _>>()?;
    report["compile_ms"] = json!(ms(compiled.compile));
    report["shader_bytes"] = json!(compiled.shader_bytes);
    report_runs(report, &runs);
    Ok(values)
}

/// The tape pruned per tile of `tile` cells, `repeat` times (pruning and compiling
/// each time, reported apart from the GPU time).
fn eval_pruned(
    gpu: &Gpu,
    tape: &Tape,
    grid: &Grid,
    wait: Wait,
    tile: usize,
    repeat: usize,
    report: &mut Value,
) -> Result<Vec<f32>, GpuEvalError> {
    let mut runs = Vec::new();
    let mut values = Vec::new();
    let mut prune = pruned::PruneReport::default();
    for _ in 0..repeat.max(1) {
        let (v, timing, r) = pruned::eval_grid_pruned(gpu, tape, grid, tile, wait)?;
        runs.push(timing);
        values = v;
        prune = r;
    }
    report["compile_ms"] = json!(ms(prune.compile));
    report["prune"] = json!({
        "tile": tile,
        "tiles": prune.tiles,
        "tapes": prune.tapes,
        "full_len": prune.full_len,
        "longest": prune.longest,
        "mean_len": prune.mean_len,
        "prune_ms": ms(prune.prune),
    });
    report_runs(report, &runs);
    Ok(values)
}

/// Milliseconds.
fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The median of `xs` by the workspace's one percentile rule
/// ([`sculpt_core::percentile`]: a measured run, the upper middle of an even count);
/// 0 when empty.
fn median(xs: &[f64]) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    sculpt_core::percentile::median(&v).unwrap_or(0.0)
}

/// Runs `--gpu-eval`; returns the JSON report.
pub fn run(args: &GpuEvalArgs<'_>) -> Result<Value> {
    let start = Instant::now();
    let text = std::fs::read_to_string(args.model)
        .with_context(|| format!("cannot read {}", args.model.display()))?;
    let model = Model::from_text(&text)
        .with_context(|| format!("{}: invalid model", args.model.display()))?;
    let grid = grid_of(args.grid, args.bounds)?;
    let tape = model.tape_negative_inside();
    let gpu = Gpu::headless()?;
    let info = gpu.adapter.get_info();
    let mut report = json!({
        "model": args.model.display().to_string(),
        "grid": grid.n,
        "cells": grid.len(),
        "tape_len": tape.len(),
        "adapter": info.name,
        "backend": format!("{:?}", info.backend),
        "device_type": format!("{:?}", info.device_type),
        "driver": info.driver_info,
    });
    let wait = args.wait.unwrap_or_else(|| Wait::for_adapter(&gpu));
    report["wait"] = json!(format!("{wait:?}").to_lowercase());
    let evaluated = match args.prune {
        None => eval_whole(&gpu, &tape, &grid, wait, args.repeat, &mut report),
        Some(tile) => eval_pruned(&gpu, &tape, &grid, wait, tile, args.repeat, &mut report),
    };
    let values = match evaluated {
        Ok(values) => values,
        Err(e @ GpuEvalError::TapeTooLong { .. }) => {
            eprintln!("wandsculpt: {e}; evaluating on the CPU instead");
            let cpu = Instant::now();
            let values = tape.eval_grid(&grid);
            report["path"] = json!("cpu");
            report["fallback"] = json!(e.to_string());
            report["cpu_ms"] = json!(ms(cpu.elapsed()));
            values
        }
        Err(e) => return Err(e.into()),
    };
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    fsio::write_atomic(args.out, &bytes)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    report["out"] = json!(args.out.display().to_string());
    report["total_ms"] = json!(ms(start.elapsed()));
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_parse_as_the_cpu_tool_reads_them() {
        let g = grid_of("4x2", "0,1").unwrap();
        assert_eq!(g.n, [4, 2, 1]);
        assert_eq!(g.centre(2, 0), 0.0);
        assert_eq!(g.centre(0, 0), 0.125);
        let g = grid_of("2x3x4", "-1,1").unwrap();
        assert_eq!(g.n, [2, 3, 4]);
        assert_eq!(g.lo, [-1.0; 3]);
        for (grid, bounds) in [
            ("4", "0,1"),
            ("4x0", "0,1"),
            ("4xa", "0,1"),
            ("1x2x3x4", "0,1"),
            ("4x4", "1,0"),
            ("4x4", "0"),
            ("4x4", "0,nan"),
            ("4x4", "0,1,2"),
        ] {
            assert!(grid_of(grid, bounds).is_err(), "{grid} {bounds}");
        }
    }

    #[test]
    fn medians() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        // One percentile rule (issue 32): the upper middle of an even count, a run that
        // was measured, where this report alone used to average the two middles (2.5).
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 3.0);
    }
}
