//! Implicit tapes evaluated on the GPU (issue 34, docs/implicit.md "GPU evaluation").
//!
//! A [`sculpt_core::implicit::Tape`] is compiled to a WGSL compute shader of straight-line
//! code ([`wgsl::shader`], one `let` per instruction; the module docs there say why
//! generated code rather than an interpreter), dispatched over grid cells or points,
//! and read back. Cell centres are computed on the CPU with [`Grid::centre`] and
//! uploaded, so the GPU sees the very f32 coordinates the CPU path
//! ([`Tape::eval_grid`]) does; values agree with the CPU's to f32 rounding (the bound
//! is in `sculpt_core::tolerance`, section "GPU evaluation of implicit tapes").
//!
//! Large jobs are cut into chunks that respect the device's limits: a chunk's output
//! fits `max_storage_buffer_binding_size` and `max_buffer_size`, and its workgroups fit
//! `max_compute_workgroups_per_dimension` (in two dimensions when one is not enough).
//! Tapes longer than [`wgsl::MAX_GPU_TAPE`] are refused with
//! [`GpuEvalError::TapeTooLong`], so the caller can use the CPU path.

pub mod pruned;
pub mod wgsl;

use std::time::{Duration, Instant};

use sculpt_core::implicit::tape::{Grid, Tape};
use thiserror::Error;
use wgpu::util::DeviceExt;

use crate::render::Gpu;
use wgsl::{MAX_GPU_TAPE, Params, WORKGROUP_SIZE};

/// What can go wrong evaluating on the GPU.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GpuEvalError {
    /// The tape is longer than the GPU path compiles ([`MAX_GPU_TAPE`]).
    #[error("the tape has {len} instructions, more than the GPU limit of {max}")]
    TapeTooLong {
        /// Instructions in the tape.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// The generated shader or its pipeline was refused by the device.
    #[error("the generated shader was refused: {0}")]
    Shader(#[source] wgpu::Error),
    /// Waiting for the GPU failed.
    #[error("waiting for the GPU: {0}")]
    Poll(#[source] wgpu::PollError),
    /// Mapping the readback buffer failed.
    #[error("readback: {0}")]
    Map(#[source] wgpu::BufferAsyncError),
    /// The mapping callback was dropped before it ran.
    #[error("readback: the mapping callback never ran")]
    MapLost,
    /// The mapped range could not be viewed.
    #[error("readback: {0}")]
    MapRange(#[source] wgpu::MapRangeError),
}

/// A tape compiled for one device: its shader and its pipelines (one per entry point).
#[derive(Debug)]
pub struct GpuTape {
    grid_pipeline: wgpu::ComputePipeline,
    points_pipeline: wgpu::ComputePipeline,
    tiles_pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    chunk_limit: u64,
    max_groups: u32,
    /// Wall time of WGSL generation, shader and pipeline creation.
    pub compile: Duration,
    /// Bytes of WGSL generated.
    pub shader_bytes: usize,
    /// How readbacks wait for the GPU.
    wait: Wait,
}

/// The timing of one evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EvalTiming {
    /// Sum over chunks of the time from `submit` until the chunk's values were copied
    /// out of the mapped readback buffer.
    pub gpu: Duration,
    /// Of `gpu`, the time spent copying the values out of the mapped buffer.
    pub copy: Duration,
    /// Chunks dispatched.
    pub chunks: usize,
}

/// A grid job with its buffers made, so it can run repeatedly (for timing) without
/// allocating.
#[derive(Debug)]
pub struct GridJob<'t> {
    tape: &'t GpuTape,
    chunks: Vec<Chunk>,
    out: wgpu::Buffer,
    readback: wgpu::Buffer,
    len: usize,
}

/// One chunk: its bind group (parameters) and extent.
#[derive(Debug)]
struct Chunk {
    bind_group: wgpu::BindGroup,
    first: usize,
    count: usize,
    groups: (u32, u32),
}

/// Workgroups for `count` invocations: `(x, y)` with `x <= max` and `row` invocations
/// per row of the dispatch.
fn dispatch_shape(count: usize, max: u32) -> ((u32, u32), u32) {
    let groups = count.div_ceil(WORKGROUP_SIZE as usize) as u64;
    let max = u64::from(max);
    let (gx, gy) = if groups <= max {
        (groups, 1)
    } else {
        (max, groups.div_ceil(max))
    };
    ((gx as u32, gy as u32), gx as u32 * WORKGROUP_SIZE)
}

impl GpuTape {
    /// Compiles `tape` for `gpu`'s device.
    ///
    /// # Errors
    /// [`GpuEvalError::TapeTooLong`] above [`MAX_GPU_TAPE`] instructions (use the CPU
    /// path), [`GpuEvalError::Shader`] when the device refuses the shader.
    pub fn compile(gpu: &Gpu, tape: &Tape) -> Result<Self, GpuEvalError> {
        if tape.len() > MAX_GPU_TAPE {
            return Err(GpuEvalError::TapeTooLong {
                len: tape.len(),
                max: MAX_GPU_TAPE,
            });
        }
        let start = Instant::now();
        let device = &gpu.device;
        let source = wgsl::shader(tape);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("implicit tape"),
            source: wgpu::ShaderSource::Wgsl(source.as_str().into()),
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("implicit tape"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage(1, true),
                storage(2, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("implicit tape"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let grid_pipeline = pipeline("grid_main");
        let points_pipeline = pipeline("points_main");
        let tiles_pipeline = pipeline("tiles_main");
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuEvalError::Shader(e));
        }
        let limits = device.limits();
        // A chunk's output must fit one storage binding and one buffer; invocation
        // indices are u32.
        let by_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            / 4;
        let max_groups = limits.max_compute_workgroups_per_dimension.max(1);
        let by_dispatch = u64::from(max_groups).pow(2) * u64::from(WORKGROUP_SIZE);
        let chunk_limit = by_binding.min(by_dispatch).min(u64::from(u32::MAX));
        Ok(Self {
            grid_pipeline,
            points_pipeline,
            tiles_pipeline,
            layout,
            chunk_limit: (chunk_limit / u64::from(WORKGROUP_SIZE) * u64::from(WORKGROUP_SIZE))
                .max(u64::from(WORKGROUP_SIZE)),
            max_groups,
            compile: start.elapsed(),
            shader_bytes: source.len(),
            wait: Wait::for_adapter(gpu),
        })
    }

    /// How readbacks wait for the GPU ([`Wait::for_adapter`] unless set).
    pub fn wait(&self) -> Wait {
        self.wait
    }

    /// Sets how readbacks wait for the GPU.
    pub fn set_wait(&mut self, wait: Wait) {
        self.wait = wait;
    }

    /// The most cells or points one dispatch handles (from the device's limits).
    pub fn chunk_limit(&self) -> usize {
        self.chunk_limit as usize
    }

    /// Lowers the chunk size to `cells` (at least one workgroup), to test chunking on
    /// small jobs.
    pub fn limit_chunks(&mut self, cells: usize) {
        let w = WORKGROUP_SIZE as usize;
        self.chunk_limit = self.chunk_limit.min((cells.max(w) / w * w) as u64);
    }

    /// Cuts `len` items into chunks of at most [`chunk_limit`](Self::chunk_limit).
    fn chunk_ranges(&self, len: usize) -> impl Iterator<Item = (usize, usize)> {
        let step = self.chunk_limit as usize;
        (0..len)
            .step_by(step)
            .map(move |first| (first, step.min(len - first)))
    }

    fn params_buffer(&self, gpu: &Gpu, params: Params) -> wgpu::Buffer {
        gpu.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("implicit params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            })
    }

    fn bind_group(
        &self,
        gpu: &Gpu,
        params: &wgpu::Buffer,
        coords: &wgpu::Buffer,
        out: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("implicit tape"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: coords.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: out.as_entire_binding(),
                },
            ],
        })
    }

    /// The output and readback buffers for chunks of up to `cells` values.
    fn output_buffers(gpu: &Gpu, cells: usize) -> (wgpu::Buffer, wgpu::Buffer) {
        let size = (cells.max(1) * 4) as u64;
        let make = |label, usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        (
            make(
                "implicit values",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            ),
            make(
                "implicit readback",
                wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            ),
        )
    }

    fn params(&self, first: usize, count: usize) -> (Params, (u32, u32)) {
        let (groups, row) = dispatch_shape(count, self.max_groups);
        let params = Params {
            n: [1; 3],
            first: first as u32,
            count: count as u32,
            y_at: 0,
            z_at: 0,
            row,
            inf_bits: f32::INFINITY.to_bits(),
            nan_bits: f32::NAN.to_bits(),
            tile: 0,
            tile_z: 0,
        };
        (params, groups)
    }

    /// Prepares the evaluation of `grid`'s cell centres (x fastest, then y, then z):
    /// uploads the centres and makes the buffers of every chunk.
    pub fn grid_job(&self, gpu: &Gpu, grid: &Grid) -> GridJob<'_> {
        let mut coords: Vec<f32> = Vec::with_capacity(grid.n.iter().sum());
        for axis in 0..3 {
            coords.extend((0..grid.n[axis]).map(|i| grid.centre(axis, i) as f32));
        }
        let coords = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("implicit cell centres"),
                contents: bytemuck::cast_slice(&coords),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let len = grid.len();
        let (out, readback) = Self::output_buffers(gpu, len.min(self.chunk_limit as usize));
        let chunks = self
            .chunk_ranges(len)
            .map(|(first, count)| {
                let (mut params, groups) = self.params(first, count);
                params.n = grid.n.map(|k| k as u32);
                params.y_at = grid.n[0] as u32;
                params.z_at = (grid.n[0] + grid.n[1]) as u32;
                let params = self.params_buffer(gpu, params);
                Chunk {
                    bind_group: self.bind_group(gpu, &params, &coords, &out),
                    first,
                    count,
                    groups,
                }
            })
            .collect();
        GridJob {
            tape: self,
            chunks,
            out,
            readback,
            len,
        }
    }

    /// Values at the cell centres of `grid`, x fastest (as [`Tape::eval_grid`]).
    pub fn eval_grid(
        &self,
        gpu: &Gpu,
        grid: &Grid,
    ) -> Result<(Vec<f32>, EvalTiming), GpuEvalError> {
        self.grid_job(gpu, grid).run(gpu)
    }

    /// Values at `points`, one per point.
    pub fn eval_points(
        &self,
        gpu: &Gpu,
        points: &[[f32; 3]],
    ) -> Result<(Vec<f32>, EvalTiming), GpuEvalError> {
        let mut values = vec![f32::NAN; points.len()];
        let (out, readback) =
            Self::output_buffers(gpu, points.len().min(self.chunk_limit as usize));
        let mut timing = EvalTiming::default();
        for (first, count) in self.chunk_ranges(points.len()) {
            let flat: Vec<f32> = points[first..first + count]
                .iter()
                .flatten()
                .copied()
                .collect();
            let coords = gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("implicit points"),
                    contents: bytemuck::cast_slice(&flat),
                    usage: wgpu::BufferUsages::STORAGE,
                });
            let (params, groups) = self.params(first, count);
            let params = self.params_buffer(gpu, params);
            let chunk = Chunk {
                bind_group: self.bind_group(gpu, &params, &coords, &out),
                first,
                count,
                groups,
            };
            timing.add(run_chunk(
                gpu,
                &self.points_pipeline,
                &chunk,
                &out,
                &readback,
                &mut values[first..first + count],
                self.wait,
            )?);
        }
        Ok((values, timing))
    }
}

impl GridJob<'_> {
    /// Runs every chunk and reads the values back.
    pub fn run(&self, gpu: &Gpu) -> Result<(Vec<f32>, EvalTiming), GpuEvalError> {
        let mut values = vec![f32::NAN; self.len];
        let timing = self.run_into(gpu, &mut values)?;
        Ok((values, timing))
    }

    /// Cells in the job.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the job has no cells (never: a grid has at least one).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Runs every chunk and reads the values back into `values` (of length
    /// [`len`](Self::len)), so repeated runs reuse one destination whose pages are
    /// already in memory.
    ///
    /// # Panics
    /// When `values.len()` is not [`len`](Self::len): a caller's bug.
    pub fn run_into(&self, gpu: &Gpu, values: &mut [f32]) -> Result<EvalTiming, GpuEvalError> {
        assert_eq!(values.len(), self.len, "destination of the wrong length");
        let mut timing = EvalTiming::default();
        for chunk in &self.chunks {
            timing.add(run_chunk(
                gpu,
                &self.tape.grid_pipeline,
                chunk,
                &self.out,
                &self.readback,
                &mut values[chunk.first..chunk.first + chunk.count],
                self.tape.wait,
            )?);
        }
        Ok(timing)
    }
}

impl EvalTiming {
    /// Adds one chunk's readback.
    fn add(&mut self, t: ReadbackTime) {
        self.gpu += t.total;
        self.copy += t.copy;
        self.chunks += 1;
    }
}

/// Dispatches one chunk, copies its values to the readback buffer, submits, waits for
/// the mapping and copies the values into `dst`; returns the time from the submit to
/// the values in `dst`.
fn run_chunk(
    gpu: &Gpu,
    pipeline: &wgpu::ComputePipeline,
    chunk: &Chunk,
    out: &wgpu::Buffer,
    readback: &wgpu::Buffer,
    dst: &mut [f32],
    wait: Wait,
) -> Result<ReadbackTime, GpuEvalError> {
    let dispatch = Dispatch {
        label: "implicit tape",
        pipeline,
        bind_group: &chunk.bind_group,
        groups: chunk.groups,
    };
    Ok(dispatch.read_back(gpu, out, readback, dst, wait)?)
}

/// One compute dispatch whose output buffer holds f32 values (the implicit tapes and
/// the volumes, `crate::gpu_volume`, share it).
pub(crate) struct Dispatch<'a> {
    /// The compute pass's label.
    pub label: &'static str,
    /// The pipeline.
    pub pipeline: &'a wgpu::ComputePipeline,
    /// Its bind group 0.
    pub bind_group: &'a wgpu::BindGroup,
    /// Workgroups in x and y.
    pub groups: (u32, u32),
}

/// Why values could not be read back; each GPU path turns it into its own error.
#[derive(Debug)]
pub(crate) enum ReadbackFailure {
    /// Waiting for the GPU failed.
    Poll(wgpu::PollError),
    /// Mapping the readback buffer failed.
    Map(wgpu::BufferAsyncError),
    /// The mapping callback was dropped without an answer.
    MapLost,
    /// The mapped range could not be read.
    MapRange(wgpu::MapRangeError),
}

impl From<ReadbackFailure> for GpuEvalError {
    fn from(f: ReadbackFailure) -> Self {
        match f {
            ReadbackFailure::Poll(e) => Self::Poll(e),
            ReadbackFailure::Map(e) => Self::Map(e),
            ReadbackFailure::MapLost => Self::MapLost,
            ReadbackFailure::MapRange(e) => Self::MapRange(e),
        }
    }
}

/// How the CPU waits for a readback to be mapped.
///
/// The driver's fence wait puts the thread to sleep until the GPU is done, and the
/// wake-up costs from tens of microseconds to milliseconds (scheduler and driver); a
/// non-blocking poll in a loop sees the mapping as soon as it is ready, at the price
/// of one busy core while the GPU works. On a software adapter (lavapipe) the GPU *is*
/// the CPU's cores, so there a spinning thread would take time from the work it waits
/// for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wait {
    /// Block in the driver's wait (`PollType::wait_indefinitely`).
    Block,
    /// Poll without blocking until the mapping is ready, yielding between polls.
    Spin,
}

impl Wait {
    /// The default for `gpu`'s adapter: [`Wait::Block`] on a software (CPU) adapter,
    /// [`Wait::Spin`] on a real GPU.
    pub fn for_adapter(gpu: &Gpu) -> Self {
        if gpu.adapter.get_info().device_type == wgpu::DeviceType::Cpu {
            Self::Block
        } else {
            Self::Spin
        }
    }
}

/// Values per piece of the copy out of the mapped readback buffer (256 KiB): large
/// enough that a thread's start is small against its copy, small enough that an 8 MB
/// readback spreads over every core.
const COPY_PIECE: usize = 1 << 16;

/// The time of one readback.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct ReadbackTime {
    /// From the submit until the values are in the destination.
    pub total: Duration,
    /// Of which copying out of the mapped buffer.
    pub copy: Duration,
}

impl Dispatch<'_> {
    /// Runs the dispatch, copies the first `dst.len()` values of `out` to `readback`,
    /// submits, waits for the mapping (as `wait` says) and copies the values into
    /// `dst`, in pieces on the rayon pool; returns the time from the submit to the
    /// values in `dst`.
    pub(crate) fn read_back(
        &self,
        gpu: &Gpu,
        out: &wgpu::Buffer,
        readback: &wgpu::Buffer,
        dst: &mut [f32],
        wait: Wait,
    ) -> Result<ReadbackTime, ReadbackFailure> {
        use rayon::prelude::*;
        let bytes = (dst.len() * 4) as u64;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(self.label),
                timestamp_writes: None,
            });
            pass.set_pipeline(self.pipeline);
            pass.set_bind_group(0, self.bind_group, &[]);
            pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
        }
        encoder.copy_buffer_to_buffer(out, 0, readback, 0, bytes);
        let commands = encoder.finish();
        let start = Instant::now();
        gpu.queue.submit([commands]);
        let slice = readback.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            // The receiver outlives the polls below; a send failure cannot happen.
            let _ = tx.send(r);
        });
        let mapped = match wait {
            Wait::Block => {
                gpu.device
                    .poll(wgpu::PollType::wait_indefinitely())
                    .map_err(ReadbackFailure::Poll)?;
                rx.recv().map_err(|_| ReadbackFailure::MapLost)?
            }
            Wait::Spin => loop {
                gpu.device
                    .poll(wgpu::PollType::Poll)
                    .map_err(ReadbackFailure::Poll)?;
                match rx.try_recv() {
                    Ok(r) => break r,
                    Err(std::sync::mpsc::TryRecvError::Empty) => std::thread::yield_now(),
                    Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                        return Err(ReadbackFailure::MapLost);
                    }
                }
            },
        };
        mapped.map_err(ReadbackFailure::Map)?;
        let copy_start = Instant::now();
        {
            let data = slice
                .get_mapped_range()
                .map_err(ReadbackFailure::MapRange)?;
            let src: &[f32] = bytemuck::cast_slice(&data);
            dst.par_chunks_mut(COPY_PIECE)
                .zip(src.par_chunks(COPY_PIECE))
                .for_each(|(d, s)| d.copy_from_slice(s));
        }
        readback.unmap();
        let end = Instant::now();
        Ok(ReadbackTime {
            total: end - start,
            copy: end - copy_start,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatches_fit_the_workgroup_limit() {
        assert_eq!(dispatch_shape(1, 65535), ((1, 1), 64));
        assert_eq!(dispatch_shape(64, 65535), ((1, 1), 64));
        assert_eq!(dispatch_shape(65, 65535), ((2, 1), 128));
        // 2048 x 1024 cells: 32768 workgroups in one row.
        assert_eq!(dispatch_shape(2048 * 1024, 65535), ((32768, 1), 32768 * 64));
        // Past the limit: rows of `max` workgroups, enough rows for every invocation.
        let ((gx, gy), row) = dispatch_shape(10 * 64 + 1, 4);
        assert_eq!((gx, gy, row), (4, 3, 256));
        assert!(u64::from(gx) * u64::from(gy) * 64 > 10 * 64);
    }
}
