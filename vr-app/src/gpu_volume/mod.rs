//! Volumetric NURBS evaluated on the GPU (issue 33; `wandsculpt --gpu-volume-eval`).
//!
//! A [`sculpt_core::volume::Volume`] is uploaded once ([`GpuVolume::new`]): its knots
//! and homogeneous control net as f32. [`GpuVolume::eval_grid`] then evaluates every
//! attribute at the points of a uniform parameter grid in a WGSL compute shader
//! (`volume.wgsl`, fixed, not generated: one invocation per grid point computes the
//! knot span (P&T A2.1) and basis functions (A2.2) of each direction and the
//! homogeneous sum over the local control points, A4.3 extended to `n` directions).
//! The grid parameters are computed on the CPU in f64 ([`Volume::grid_params`]) and
//! rounded once, so the GPU evaluates at the very f32 parameters the CPU reference
//! rounds to. The output has the layout of `sculpt-tools volume grid --f32`
//! ([`Volume::eval_grid_f32`]): `k` values per point, the first index fastest. It
//! agrees with it to f32 rounding (the bound is
//! [`crate::tolerance::VOLUME_GPU_REL`]).
//!
//! Large grids are cut into chunks whose output fits one storage binding and whose
//! workgroups fit the device's dispatch limits (in two dimensions when one is not
//! enough). A net larger than one storage binding is refused
//! ([`GpuVolumeError::NetTooLarge`]); the caller can use the CPU path.

use std::time::{Duration, Instant};

use sculpt_core::volume::{Volume, VolumeError};
use thiserror::Error;
use wgpu::util::DeviceExt;

use crate::gpu_eval::{Dispatch, ReadbackFailure, Wait};
use crate::render::Gpu;

/// The shader source.
pub const SHADER: &str = include_str!("volume.wgsl");
/// Invocations per workgroup (one grid point each), as the shader declares.
pub const WORKGROUP_SIZE: u32 = 64;

/// What can go wrong evaluating a volume on the GPU.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GpuVolumeError {
    /// The grid does not suit the volume (a count per direction, each at least 1).
    #[error("grid: {0}")]
    Grid(#[source] VolumeError),
    /// A grid direction with no points.
    #[error("grid direction {direction} has no points")]
    EmptyDirection {
        /// The direction.
        direction: usize,
    },
    /// The grid has more points than one u32 index reaches.
    #[error("the grid has {points} points, more than the GPU path indexes ({max})")]
    GridTooLarge {
        /// Points asked for.
        points: u128,
        /// The limit.
        max: u64,
    },
    /// The control net does not fit one storage binding of this device.
    #[error("the control net takes {bytes} bytes, more than one storage binding holds ({max})")]
    NetTooLarge {
        /// Bytes of the f32 net.
        bytes: u64,
        /// The device's limit.
        max: u64,
    },
    /// A value of the volume is not representable in f32 (beyond its range).
    #[error("a control value or knot ({value}) overflows f32")]
    NotF32 {
        /// The value.
        value: f64,
    },
    /// The shader or its pipeline was refused by the device.
    #[error("the volume shader was refused: {0}")]
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

/// The uniform parameters, as laid out in the shader's `Params` struct.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n: u32,
    k: u32,
    count: u32,
    first: u32,
    row: u32,
    pad: [u32; 3],
    res: [u32; 4],
    degree: [u32; 4],
    ncp: [u32; 4],
    knot_at: [u32; 4],
    param_at: [u32; 4],
    stride: [u32; 4],
}

/// A volume uploaded to one device, with its pipeline.
#[derive(Debug)]
pub struct GpuVolume {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    net: wgpu::Buffer,
    /// The knots of every direction, f32, concatenated.
    knots: Vec<f32>,
    base: Params,
    directions: usize,
    components: usize,
    max_binding: u64,
    max_groups: u32,
    /// How readbacks wait for the GPU ([`Wait::for_adapter`], chosen once).
    wait: Wait,
    /// Wall time of the upload, shader and pipeline creation.
    pub setup: Duration,
}

/// The timing of one grid evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GridTiming {
    /// Sum over chunks of the time from `submit` until the chunk's values were copied
    /// out of the mapped readback buffer.
    pub gpu: Duration,
    /// Chunks dispatched.
    pub chunks: usize,
}

impl From<ReadbackFailure> for GpuVolumeError {
    fn from(f: ReadbackFailure) -> Self {
        match f {
            ReadbackFailure::Poll(e) => Self::Poll(e),
            ReadbackFailure::Map(e) => Self::Map(e),
            ReadbackFailure::MapLost => Self::MapLost,
            ReadbackFailure::MapRange(e) => Self::MapRange(e),
        }
    }
}

fn to_f32(v: f64) -> Result<f32, GpuVolumeError> {
    let x = v as f32;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(GpuVolumeError::NotF32 { value: v })
    }
}

/// Workgroups `(x, y)` for `count` invocations with at most `max` along x, and the
/// invocations per row.
fn workgroups(count: u32, max: u32) -> ((u32, u32), u32) {
    let groups = count.div_ceil(WORKGROUP_SIZE).max(1);
    let x = groups.min(max.max(1));
    ((x, groups.div_ceil(x)), x * WORKGROUP_SIZE)
}

impl GpuVolume {
    /// Uploads `vol` to `gpu`'s device and builds the pipeline.
    ///
    /// # Errors
    /// [`GpuVolumeError::NetTooLarge`] when the net exceeds one storage binding,
    /// [`GpuVolumeError::NotF32`] for values beyond f32, [`GpuVolumeError::Shader`]
    /// when the device refuses the shader.
    pub fn new(gpu: &Gpu, vol: &Volume) -> Result<Self, GpuVolumeError> {
        let start = Instant::now();
        let device = &gpu.device;
        let limits = device.limits();
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let net: Vec<f32> = vol
            .homogeneous()
            .iter()
            .map(|&v| to_f32(v))
            .collect::<Result<_, _>>()?;
        let bytes = (net.len() * 4) as u64;
        if bytes > max_binding {
            return Err(GpuVolumeError::NetTooLarge {
                bytes,
                max: max_binding,
            });
        }
        let n = vol.directions();
        let mut knots = Vec::new();
        let mut base = Params {
            n: n as u32,
            k: vol.components() as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let mut stride = 1usize;
        for d in (0..n).rev() {
            base.stride[d] = stride as u32;
            stride *= vol.counts()[d];
        }
        for d in 0..n {
            let kv = vol.knots(d);
            base.knot_at[d] = knots.len() as u32;
            base.degree[d] = kv.degree() as u32;
            base.ncp[d] = kv.count() as u32;
            for &t in kv.knots() {
                knots.push(to_f32(t)?);
            }
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("volume grid"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let storage = |read_only| wgpu::BufferBindingType::Storage { read_only };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volume grid"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Uniform),
                entry(1, storage(true)),
                entry(2, storage(true)),
                entry(3, storage(false)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("volume grid"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("volume grid"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("grid_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuVolumeError::Shader(e));
        }
        let net = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("volume net"),
            contents: bytemuck::cast_slice(&net),
            usage: wgpu::BufferUsages::STORAGE,
        });
        Ok(Self {
            pipeline,
            layout,
            net,
            knots,
            base,
            directions: n,
            components: vol.components(),
            max_binding,
            max_groups: limits.max_compute_workgroups_per_dimension.max(1),
            wait: Wait::for_adapter(gpu),
            setup: start.elapsed(),
        })
    }

    /// The most grid points one dispatch handles: its output fits one storage
    /// binding and its workgroups the dispatch limits.
    pub fn chunk_limit(&self) -> usize {
        let by_binding = self.max_binding / (4 * self.components as u64);
        let by_dispatch = u64::from(self.max_groups).pow(2) * u64::from(WORKGROUP_SIZE);
        let limit = by_binding.min(by_dispatch).min(u64::from(u32::MAX));
        (limit / u64::from(WORKGROUP_SIZE) * u64::from(WORKGROUP_SIZE)).max(1) as usize
    }

    /// The attribute values at the uniform grid of `res` points per direction
    /// ([`Volume::grid_params`] of `vol`, the volume this was made from): `k` values
    /// per point, the first index fastest. `chunk` lowers the points per dispatch
    /// (at least one workgroup), to test chunking on small grids.
    ///
    /// # Errors
    /// A bad grid ([`GpuVolumeError::Grid`], [`GpuVolumeError::EmptyDirection`],
    /// [`GpuVolumeError::GridTooLarge`]) or a failure of the device.
    pub fn eval_grid(
        &self,
        gpu: &Gpu,
        vol: &Volume,
        res: &[usize],
        chunk: Option<usize>,
    ) -> Result<(Vec<f32>, GridTiming), GpuVolumeError> {
        let params = vol.grid_params(res).map_err(GpuVolumeError::Grid)?;
        if let Some(direction) = res.iter().position(|&r| r == 0) {
            return Err(GpuVolumeError::EmptyDirection { direction });
        }
        let points: u128 = res.iter().map(|&r| r as u128).product();
        let values = points * self.components as u128;
        if values > u128::from(u32::MAX) {
            return Err(GpuVolumeError::GridTooLarge {
                points,
                max: u64::from(u32::MAX) / self.components as u64,
            });
        }
        let total = points as usize;
        let mut coords = self.knots.clone();
        let mut base = self.base;
        for (d, p) in params.iter().enumerate().take(self.directions) {
            base.res[d] = res[d] as u32;
            base.param_at[d] = coords.len() as u32;
            for &u in p {
                coords.push(u as f32);
            }
        }
        let device = &gpu.device;
        let coords = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("volume knots and grid parameters"),
            contents: bytemuck::cast_slice(&coords),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let step = chunk
            .map_or(usize::MAX, |c| c.max(WORKGROUP_SIZE as usize))
            .min(self.chunk_limit());
        let k = self.components;
        let size = (step.min(total).max(1) * k * 4) as u64;
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let out = buffer(
            "volume values",
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let readback = buffer(
            "volume readback",
            wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        );
        // Written once here (NaN) so the timed copies do not fault its pages in.
        let mut values = vec![f32::NAN; total * k];
        let mut timing = GridTiming::default();
        for first in (0..total).step_by(step) {
            let count = step.min(total - first);
            let (groups, row) = workgroups(count as u32, self.max_groups);
            let uniform = Params {
                count: count as u32,
                first: first as u32,
                row,
                ..base
            };
            let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("volume params"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("volume grid"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: coords.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: self.net.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: out.as_entire_binding(),
                    },
                ],
            });
            let dst = &mut values[first * k..(first + count) * k];
            timing.gpu += self.dispatch(gpu, &bind_group, groups, &out, &readback, dst)?;
            timing.chunks += 1;
        }
        Ok((values, timing))
    }

    /// Runs one chunk and copies its values into `dst`; returns the time from the
    /// submit to the values in `dst`.
    fn dispatch(
        &self,
        gpu: &Gpu,
        bind_group: &wgpu::BindGroup,
        groups: (u32, u32),
        out: &wgpu::Buffer,
        readback: &wgpu::Buffer,
        dst: &mut [f32],
    ) -> Result<Duration, GpuVolumeError> {
        let dispatch = Dispatch {
            label: "volume grid",
            pipeline: &self.pipeline,
            bind_group,
            groups,
        };
        Ok(dispatch
            .read_back(gpu, out, readback, dst, self.wait)?
            .total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn workgroups_cover_every_point_within_the_limit() {
        assert_eq!(workgroups(1, 65535), ((1, 1), 64));
        assert_eq!(workgroups(65, 65535), ((2, 1), 128));
        let ((x, y), row) = workgroups(10 * 64 + 1, 4);
        assert_eq!((x, y, row), (4, 3, 256));
        assert!(u64::from(x) * u64::from(y) * 64 > 10 * 64);
    }

    #[test]
    fn params_match_the_shader_layout() {
        // 8 scalars, then six vec4<u32> (16-byte aligned): 32 + 96 bytes.
        assert_eq!(std::mem::size_of::<Params>(), 128);
    }
}
