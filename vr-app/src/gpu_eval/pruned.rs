//! Interval pruning per tile before the GPU (Keeter, *Massively Parallel Rendering of
//! Complex Closed-Form Implicit Surfaces*, 2020, sec. 3; the CPU side is
//! [`Tape::simplify`]).
//!
//! The grid is cut into tiles ([`GPU_PRUNE_TILE_2D`] or [`GPU_PRUNE_TILE_3D`] cells
//! on a side by default). On the CPU each tile's tape is simplified over the box of
//! its cell centres: where interval arithmetic proves one side of a `min`, `max`,
//! `and` or `or` always wins in the tile, the other side is dropped. Tiles whose
//! pruned tapes are the same share one compiled shader; each shader is dispatched
//! once over all its tiles (the `tiles_main` entry point of [`wgsl::shader`]), and
//! the values are scattered back to grid order.
//!
//! The shader stays generated straight-line code (the [`wgsl`] module docs say why),
//! so each distinct pruned tape costs a compile; the report gives the count and the
//! time apart from the GPU time. Every value is the value of a tape equal to the
//! full one at that cell's centre (the bounds are sound for f32 evaluation), so the
//! values equal the CPU's to f32 rounding, as the unpruned path's do.
//!
//! [`wgsl::shader`]: super::wgsl::shader
//! [`wgsl`]: super::wgsl

use std::collections::HashMap;
use std::time::{Duration, Instant};

use sculpt_core::implicit::interval::Interval;
use sculpt_core::implicit::tape::{Grid, Tape};
use wgpu::util::DeviceExt;

use super::{Chunk, EvalTiming, GpuEvalError, GpuTape, Wait, run_chunk};
use crate::render::Gpu;

/// Default tile edge (cells) on grids one cell deep.
pub const GPU_PRUNE_TILE_2D: usize = 128;
/// Default tile edge (cells) on 3D grids.
pub const GPU_PRUNE_TILE_3D: usize = 32;

/// The largest cell index per axis the tile table holds (its entries travel as the
/// bits of f32 values, which must not be NaN patterns).
const MAX_AXIS: usize = 1 << 30;

/// What pruning did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PruneReport {
    /// Tiles.
    pub tiles: usize,
    /// Distinct pruned tapes (one shader each).
    pub tapes: usize,
    /// Instructions of the full tape.
    pub full_len: usize,
    /// Instructions of the longest pruned tape.
    pub longest: usize,
    /// Mean instructions per tile after pruning.
    pub mean_len: f64,
    /// CPU time of the interval passes and grouping.
    pub prune: Duration,
    /// Time to generate and compile the shaders.
    pub compile: Duration,
}

/// The tile edge per axis for `grid` and an edge `tile` (one cell deep in z on
/// grids one cell deep).
fn tile_dims(grid: &Grid, tile: usize) -> [usize; 3] {
    let t = tile.max(1);
    [t, t, if grid.n[2] == 1 { 1 } else { t }]
}

/// A pruned tape and the first cell of each tile it serves.
type TileGroup = (Tape, Vec<[usize; 3]>);

/// The tiles of `grid` grouped by their pruned tape: each distinct tape with the
/// first cell of each of its tiles.
fn group_tiles(
    tape: &Tape,
    grid: &Grid,
    td: [usize; 3],
    centres: &[Vec<f32>; 3],
) -> (Vec<TileGroup>, PruneReport) {
    let mut groups: Vec<TileGroup> = Vec::new();
    let mut by_tape: HashMap<String, usize> = HashMap::new();
    let mut report = PruneReport {
        full_len: tape.len(),
        ..Default::default()
    };
    let mut total_len = 0usize;
    for k in (0..grid.n[2]).step_by(td[2]) {
        for j in (0..grid.n[1]).step_by(td[1]) {
            for i in (0..grid.n[0]).step_by(td[0]) {
                let origin = [i, j, k];
                let region = [0, 1, 2].map(|a| {
                    let last = (origin[a] + td[a]).min(grid.n[a]) - 1;
                    Interval::new(centres[a][origin[a]], centres[a][last])
                });
                let (_, small) = tape.simplify(region);
                report.tiles += 1;
                total_len += small.len();
                report.longest = report.longest.max(small.len());
                let key = format!("{:?}", small.instrs());
                let g = *by_tape.entry(key).or_insert_with(|| {
                    groups.push((small, Vec::new()));
                    groups.len() - 1
                });
                groups[g].1.push(origin);
            }
        }
    }
    report.tapes = groups.len();
    report.mean_len = total_len as f64 / report.tiles.max(1) as f64;
    (groups, report)
}

/// Values at the cell centres of `grid`, x fastest (as [`Tape::eval_grid`]), with
/// the tape pruned per tile of `tile` cells on a side (module docs); readbacks wait
/// as `wait` says.
///
/// # Errors
/// As [`GpuTape::compile`] for a pruned tape (so [`GpuEvalError::TapeTooLong`] when
/// one is longer than the GPU path compiles: use the CPU path), and the readback
/// errors of [`GpuTape::eval_grid`].
pub fn eval_grid_pruned(
    gpu: &Gpu,
    tape: &Tape,
    grid: &Grid,
    tile: usize,
    wait: Wait,
) -> Result<(Vec<f32>, EvalTiming, PruneReport), GpuEvalError> {
    if grid.n.iter().any(|&k| k >= MAX_AXIS) {
        // The tile table cannot hold such indices: one tape for the whole grid.
        let mut compiled = GpuTape::compile(gpu, tape)?;
        compiled.set_wait(wait);
        let (values, timing) = compiled.eval_grid(gpu, grid)?;
        let report = PruneReport {
            tiles: 1,
            tapes: 1,
            full_len: tape.len(),
            longest: tape.len(),
            mean_len: tape.len() as f64,
            compile: compiled.compile,
            ..Default::default()
        };
        return Ok((values, timing, report));
    }
    let start = Instant::now();
    let td = tile_dims(grid, tile);
    let centres: [Vec<f32>; 3] =
        [0, 1, 2].map(|a| (0..grid.n[a]).map(|i| grid.centre(a, i) as f32).collect());
    let (groups, mut report) = group_tiles(tape, grid, td, &centres);
    report.prune = start.elapsed();
    let per_tile = td[0] * td[1] * td[2];
    let mut values = vec![0.0f32; grid.len()];
    let mut timing = EvalTiming::default();
    for (small, origins) in &groups {
        let compiled = GpuTape::compile(gpu, small)?;
        report.compile += compiled.compile;
        // Cell centres, then the tile table (first cell indices as u32 bits).
        let mut words: Vec<u32> = centres.iter().flatten().map(|c| c.to_bits()).collect();
        words.extend(origins.iter().flatten().map(|&o| o as u32));
        let coords = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("implicit tiles"),
                contents: bytemuck::cast_slice(&words),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let len = origins.len() * per_tile;
        let (out, readback) = GpuTape::output_buffers(gpu, len.min(compiled.chunk_limit as usize));
        let mut tiled = vec![f32::NAN; len];
        for (first, count) in compiled.chunk_ranges(len) {
            let (mut params, groups) = compiled.params(first, count);
            params.n = grid.n.map(|k| k as u32);
            params.y_at = grid.n[0] as u32;
            params.z_at = (grid.n[0] + grid.n[1]) as u32;
            params.tile = td[0] as u32;
            params.tile_z = td[2] as u32;
            let params = compiled.params_buffer(gpu, params);
            let chunk = Chunk {
                bind_group: compiled.bind_group(gpu, &params, &coords, &out),
                first,
                count,
                groups,
            };
            timing.add(run_chunk(
                gpu,
                &compiled.tiles_pipeline,
                &chunk,
                &out,
                &readback,
                &mut tiled[first..first + count],
                wait,
            )?);
        }
        scatter(&tiled, origins, td, grid, &mut values);
    }
    Ok((values, timing, report))
}

/// Writes the values of tiles (tile after tile, x fastest within a tile) to their
/// cells of `values` (grid order), dropping the cells past the grid's faces.
fn scatter(tiled: &[f32], origins: &[[usize; 3]], td: [usize; 3], grid: &Grid, values: &mut [f32]) {
    let per_tile = td[0] * td[1] * td[2];
    for (origin, tile) in origins.iter().zip(tiled.chunks(per_tile)) {
        for (l, &v) in tile.iter().enumerate() {
            let local = [l % td[0], (l / td[0]) % td[1], l / (td[0] * td[1])];
            let cell = [0, 1, 2].map(|a| origin[a] + local[a]);
            if (0..3).all(|a| cell[a] < grid.n[a]) {
                values[cell[0] + grid.n[0] * (cell[1] + grid.n[1] * cell[2])] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::implicit::Model;

    /// min(|x| - 0.5, |y| - 0.5) style: two boxes far apart, so tiles near one drop
    /// the other.
    fn two_slabs() -> Tape {
        Model::from_vm(
            "x var-x\ny var-y\na const 0.6\nb const 0.3\nxa sub x a\nxb add x a\n\
             s1 abs xa\ns2 abs xb\nd1 sub s1 b\nd2 sub s2 b\nm min d1 d2\n",
        )
        .unwrap()
        .tape_negative_inside()
    }

    #[test]
    fn tiles_cover_the_grid_once_and_group_by_tape() {
        let grid = Grid::new([300, 70, 1], [-1.0, -1.0, -0.5], [1.0, 1.0, 0.5]).unwrap();
        let tape = two_slabs();
        let td = tile_dims(&grid, 64);
        assert_eq!(td, [64, 64, 1]);
        let centres: [Vec<f32>; 3] =
            [0, 1, 2].map(|a| (0..grid.n[a]).map(|i| grid.centre(a, i) as f32).collect());
        let (groups, report) = group_tiles(&tape, &grid, td, &centres);
        // 5 x 2 tiles; the left ones keep d2's side only, the right ones d1's, the
        // middle one both.
        assert_eq!(report.tiles, 10);
        assert_eq!(report.tapes, 3, "{groups:?}");
        assert_eq!(report.longest, tape.len());
        assert!(report.mean_len < tape.len() as f64);
        // Scattering tile-ordered cell numbers gives every cell its own number once.
        let mut values = vec![-1.0f32; grid.len()];
        for (_, origins) in &groups {
            let tiled: Vec<f32> = origins
                .iter()
                .flat_map(|o| {
                    (0..td[0] * td[1]).map(move |l| {
                        let (i, j) = (o[0] + l % td[0], o[1] + l / td[0]);
                        (i + grid.n[0] * j) as f32
                    })
                })
                .collect();
            scatter(&tiled, origins, td, &grid, &mut values);
        }
        for (idx, v) in values.iter().enumerate() {
            assert_eq!(*v, idx as f32);
        }
    }
}
