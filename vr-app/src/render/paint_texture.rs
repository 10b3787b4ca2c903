//! The paint on the GPU: the document store's [`Tint`] (the painted colour, or a
//! scalar's heat map, from the targets' attribute volumes: [`crate::paint_view`])
//! sampled into a 3D texture over the tint's box, which `fs_mesh` reads per fragment
//! at the fragment's display position, trilinearly filtered.
//!
//! Each texel holds the tint at its centre premultiplied, `(r a, g a, b a, a)`, so the
//! filter blends the painted result, not colour and coverage apart (a colour
//! filtered towards unpainted texels would darken the paint's edge). The fragment's
//! albedo is then `albedo (1 - a) + rgb_premultiplied`, before lighting: the paint is
//! multiplied into the lit shading as the material's albedo is. Outside the box, or
//! with no tint, `a = 0` and the material shows.
//!
//! Per fragment rather than per vertex: the final tessellation of a smooth target
//! has triangles a tenth of a metre long away from its grooves, and colours
//! interpolated over them smeared the paint across them (a halo 10 cm wide around a
//! painted band, in the first version of `replay/tests/paint_render.rs`).
//!
//! The texture has [`PAINT_TEXELS_MAX`] texels along the box's longest side (8.6 mm
//! on the default sheet's box, against the attribute volume's 5.5 cm control
//! spacing) and proportionally fewer, at least 2, along the others. It is built once
//! per tint (a paint stroke, an undo, the heat-map key), on every core.

use bytemuck::{Pod, Zeroable};
use sculpt_core::mesh::Tint;
use wgpu::util::DeviceExt;

/// Texels of a paint texture along its box's longest side.
pub const PAINT_TEXELS_MAX: u32 = 128;

/// The box of the paint texture, as `fs_mesh` reads it.
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct PaintBoxUniform {
    /// The box's least corner; `w` is 1 with a tint, 0 without.
    lo: [f32; 4],
    /// One over the box's size per axis.
    inv_size: [f32; 4],
}

/// The texel counts of the paint texture over the box `lo..hi`.
pub fn texel_counts(lo: [f32; 3], hi: [f32; 3]) -> [u32; 3] {
    let size = [0, 1, 2].map(|d| f64::from(hi[d] - lo[d]).max(0.0));
    let longest = size.iter().copied().fold(0.0, f64::max);
    size.map(|s| {
        if longest > 0.0 {
            ((f64::from(PAINT_TEXELS_MAX) * s / longest).ceil() as u32).clamp(2, PAINT_TEXELS_MAX)
        } else {
            2
        }
    })
}

/// The texels of `tint` (rows along x, then y, then z slices), each the tint at its
/// centre premultiplied by its coverage, in 8 bits; evaluated on every core.
pub fn texels(tint: &Tint) -> ([u32; 3], Vec<[u8; 4]>) {
    let n = texel_counts(tint.lo, tint.hi);
    let slice = (n[0] * n[1]) as usize;
    let mut out = vec![[0u8; 4]; slice * n[2] as usize];
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
    let per = (n[2] as usize).div_ceil(threads).max(1);
    std::thread::scope(|scope| {
        for (chunk, slices) in out.chunks_mut(per * slice).enumerate() {
            scope.spawn(move || {
                for (k, texel) in slices.iter_mut().enumerate() {
                    let z = chunk * per + k / slice;
                    let (y, x) = ((k % slice) / n[0] as usize, k % n[0] as usize);
                    let idx = [x, y, z];
                    let p = [0, 1, 2].map(|d| {
                        let s = (idx[d] as f32 + 0.5) / n[d] as f32;
                        tint.lo[d] + s * (tint.hi[d] - tint.lo[d])
                    });
                    let t = (tint.at)(p);
                    let a = if t[3].is_finite() {
                        t[3].clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                    let c = |v: f32| if v.is_finite() { byte(v * a) } else { 0 };
                    *texel = [c(t[0]), c(t[1]), c(t[2]), byte(a)];
                }
            });
        }
    });
    (n, out)
}

/// The paint textures' bind group layout, sampler, the group without paint and the
/// group of the last tint drawn.
#[derive(Debug)]
pub(crate) struct PaintTextures {
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    empty: wgpu::BindGroup,
    current: Option<(Tint, wgpu::BindGroup)>,
}

impl PaintTextures {
    /// The layout (group 2 of the mesh pipeline) and the group without paint.
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("paint"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: fragment,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D3,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: fragment,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: fragment,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("paint"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let off = PaintBoxUniform {
            lo: [0.0; 4],
            inv_size: [0.0; 4],
        };
        let empty = Self::group(
            (device, queue),
            &layout,
            &sampler,
            [1, 1, 1],
            &[[0; 4]],
            off,
        );
        Self {
            layout,
            sampler,
            empty,
            current: None,
        }
    }

    /// The layout of the paint group.
    pub(crate) fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// Makes `tint` the one [`Self::bind_group`] returns, building its texture unless
    /// it is the current one.
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        tint: Option<&Tint>,
    ) {
        let Some(tint) = tint else {
            self.current = None;
            return;
        };
        if self.current.as_ref().is_some_and(|(t, _)| t.same(tint)) {
            return;
        }
        let (n, data) = texels(tint);
        let size = [0, 1, 2].map(|d| tint.hi[d] - tint.lo[d]);
        let inv = size.map(|s| if s > 0.0 { 1.0 / s } else { 0.0 });
        let uniform = PaintBoxUniform {
            lo: [tint.lo[0], tint.lo[1], tint.lo[2], 1.0],
            inv_size: [inv[0], inv[1], inv[2], 0.0],
        };
        let group = Self::group(
            (device, queue),
            &self.layout,
            &self.sampler,
            n,
            &data,
            uniform,
        );
        self.current = Some((tint.clone(), group));
    }

    /// The group of the prepared tint, or the one without paint.
    pub(crate) fn bind_group(&self, painted: bool) -> &wgpu::BindGroup {
        match (&self.current, painted) {
            (Some((_, g)), true) => g,
            _ => &self.empty,
        }
    }

    fn group(
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        layout: &wgpu::BindGroupLayout,
        sampler: &wgpu::Sampler,
        n: [u32; 3],
        texels: &[[u8; 4]],
        uniform: PaintBoxUniform,
    ) -> wgpu::BindGroup {
        let texture = device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("paint"),
                size: wgpu::Extent3d {
                    width: n[0],
                    height: n[1],
                    depth_or_array_layers: n[2],
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::Rgba8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(texels),
        );
        let box_uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("paint box"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let view = texture.create_view(&Default::default());
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("paint"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: box_uniform.as_entire_binding(),
                },
            ],
        })
    }
}
