//! The depth layer (`XR_KHR_composition_layer_depth`): each eye's depth, drawn with
//! the eye's own projection into a depth image the runtime owns, and the numbers that
//! tell the compositor what the values mean ([`DepthLayer`]). A runtime uses it to
//! reproject the picture to the head's latest pose and to merge layers by depth.
//!
//! The renderer keeps view depth in its geometry image, a colour image; so the depth
//! layer has its own depth-only pass ([`DepthPass`]) that draws the same meshes (the
//! document at the detail shown and the live stroke preview) with the same
//! `clip_from_display` matrices. Its values are the projection's: depth range [0, 1],
//! `near` at 0 and `far` at 1 (no reversed or infinite depth).
//!
//! ```
//! use vr_app::xr::depth::DepthLayer;
//! let layer = DepthLayer::new(0.05, 100.0).unwrap();
//! assert_eq!((layer.min_depth, layer.max_depth), (0.0, 1.0));
//! // The compositor reads a stored value back as a distance along the view axis.
//! let z = layer.distance(layer.depth(0.5));
//! assert!((z - 0.5).abs() < sculpt_core::tolerance::ROUNDING_EPS);
//! ```

use bytemuck::{Pod, Zeroable};

use crate::error::{VrError, VrResult, XrError};
use crate::render::{GpuVertex, Renderer};
use crate::scene::Views;

/// What the depth swapchain's values mean (`XrCompositionLayerDepthInfoKHR` less the
/// image): `min_depth` is the value at `near_z` metres along the view axis,
/// `max_depth` the value at `far_z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthLayer {
    /// The smallest value (at `near_z`).
    pub min_depth: f64,
    /// The largest value (at `far_z`).
    pub max_depth: f64,
    /// The near plane's distance (metres, > 0).
    pub near_z: f64,
    /// The far plane's distance (metres).
    pub far_z: f64,
}

impl DepthLayer {
    /// The layer for the eye cameras' projection with clip planes `near` and `far`
    /// ([`crate::xr::projection_from_fov`]: depth range [0, 1], near at 0).
    pub fn new(near: f64, far: f64) -> VrResult<Self> {
        if !(near > 0.0 && far > near && far.is_finite()) {
            return Err(VrError::Xr(XrError::ClipPlanes));
        }
        Ok(Self {
            min_depth: 0.0,
            max_depth: 1.0,
            near_z: near,
            far_z: far,
        })
    }

    /// The stored value for a surface `z` metres along the view axis (what the
    /// projection writes; `min_depth` at `near_z`, `max_depth` at `far_z`).
    pub fn depth(&self, z: f64) -> f64 {
        let (n, f) = (self.near_z, self.far_z);
        let unit = f * (z - n) / (z * (f - n));
        self.min_depth + unit * (self.max_depth - self.min_depth)
    }

    /// The distance along the view axis (metres) of stored value `d`: the inverse of
    /// [`Self::depth`], as a compositor reads the layer.
    pub fn distance(&self, d: f64) -> f64 {
        let (n, f) = (self.near_z, self.far_z);
        let unit = (d - self.min_depth) / (self.max_depth - self.min_depth);
        n * f / (f - unit * (f - n))
    }
}

/// Depth formats (`VkFormat`) a depth swapchain may use, with their wgpu twins, best
/// first.
pub const DEPTH_SWAPCHAIN_FORMATS: [(i64, wgpu::TextureFormat); 2] = [
    // VK_FORMAT_D32_SFLOAT
    (126, wgpu::TextureFormat::Depth32Float),
    // VK_FORMAT_D16_UNORM
    (124, wgpu::TextureFormat::Depth16Unorm),
];

/// The depth swapchain format among those the runtime offers: the first of
/// [`DEPTH_SWAPCHAIN_FORMATS`] that is offered.
pub fn depth_swapchain_format(offered: &[i64]) -> Option<(i64, wgpu::TextureFormat)> {
    DEPTH_SWAPCHAIN_FORMATS
        .iter()
        .copied()
        .find(|(vk, _)| offered.contains(vk))
}

const SHADER: &str = "
struct Camera { clip_from_display: mat4x4<f32> };
@group(0) @binding(0) var<uniform> cam: Camera;
@vertex
fn vs_depth(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return cam.clip_from_display * vec4<f32>(position, 1.0);
}
";

#[derive(Debug, Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct CameraUniform {
    clip_from_display: [[f32; 4]; 4],
}

/// The depth-only pass of the depth layer: draws the renderer's meshes for both eyes
/// into two depth images of one format.
#[derive(Debug)]
pub struct DepthPass {
    pipeline: wgpu::RenderPipeline,
    uniforms: [wgpu::Buffer; 2],
    groups: [wgpu::BindGroup; 2],
}

impl DepthPass {
    /// The pass for depth images of `format` (a depth format).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("xr depth layer"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("xr depth camera"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("xr depth layer"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        // Positions only: the mesh vertices' first attribute, at their stride.
        let buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: GpuVertex::LAYOUT.array_stride,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3],
        })];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("xr depth layer"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_depth"),
                compilation_options: Default::default(),
                buffers: &buffers,
            },
            fragment: None,
            // As the renderer's mesh pipeline: both faces, less-or-equal test.
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::LessEqual),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let uniforms = [0, 1].map(|_| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("xr depth camera"),
                size: std::mem::size_of::<CameraUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let groups = [0, 1].map(|i| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("xr depth camera"),
                layout: &layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniforms[i].as_entire_binding(),
                }],
            })
        });
        Self {
            pipeline,
            uniforms,
            groups,
        }
    }

    /// Draws what `renderer` drew last (its document store and live preview, flushed
    /// by its `render`) into `targets` (left, right) with the eye cameras of
    /// `cameras`, and submits. Each image is cleared to the far value first.
    pub fn draw(
        &self,
        queue: &wgpu::Queue,
        renderer: &Renderer,
        cameras: &Views,
        targets: [&wgpu::TextureView; 2],
    ) {
        for (eye, cam) in [&cameras.left, &cameras.right].into_iter().enumerate() {
            let u = CameraUniform {
                clip_from_display: cam.clip_from_display().as_mat4().to_cols_array_2d(),
            };
            queue.write_buffer(&self.uniforms[eye], 0, bytemuck::bytes_of(&u));
        }
        let mut encoder =
            renderer
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("xr depth layer"),
                });
        for (eye, target) in targets.into_iter().enumerate() {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("xr depth layer"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: target,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.groups[eye], &[]);
            for store in [renderer.document_store(), &renderer.preview] {
                for p in store.batches() {
                    pass.set_vertex_buffer(0, p.vertices.slice(..));
                    pass.set_index_buffer(p.triangles.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..p.triangle_index_count, 0, 0..1);
                }
            }
        }
        queue.submit([encoder.finish()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xr::{XrFov, projection_from_fov};
    use glam::DVec4;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::{CONVERSION_REL, ROUNDING_EPS};

    /// The layer's numbers describe the projection the eyes are drawn with: a point on
    /// the near plane stores `min_depth`, one on the far plane `max_depth`, and every
    /// stored value reads back as its distance.
    #[test]
    fn the_layer_matches_the_eye_projection() {
        let fov = XrFov {
            angle_left: -0.9,
            angle_right: 0.7,
            angle_up: 0.8,
            angle_down: -0.75,
        };
        let (near, far) = (0.05, 100.0);
        let clip_from_view = projection_from_fov(&fov, near, far).unwrap();
        let layer = DepthLayer::new(near, far).unwrap();
        let stored = |z: f64| {
            let c = clip_from_view * DVec4::new(0.1 * z, -0.05 * z, -z, 1.0);
            c.z / c.w
        };
        assert_near!(stored(near), layer.min_depth, ROUNDING_EPS);
        assert_near!(stored(far), layer.max_depth, ROUNDING_EPS);
        for z in [0.07, 0.3, 0.45, 1.0, 2.5, 40.0] {
            assert_near!(layer.depth(z), stored(z), ROUNDING_EPS);
            // Far from the eye the inverse is ill-conditioned: relative agreement.
            assert_near!(layer.distance(stored(z)) / z, 1.0, CONVERSION_REL);
        }
        // Clip planes that cannot make a layer are refused.
        for (n, f) in [
            (0.0, 1.0),
            (1.0, 0.5),
            (0.1, f64::INFINITY),
            (f64::NAN, 1.0),
        ] {
            assert!(DepthLayer::new(n, f).is_err(), "{n} {f}");
        }
    }

    /// Reads a `Depth32Float` image back, row by row from the top.
    fn read_depth(gpu: &crate::render::Gpu, texture: &wgpu::Texture) -> Vec<f32> {
        let (w, h) = (texture.width(), texture.height());
        let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth read-back"),
            size: u64::from(row * h),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                aspect: wgpu::TextureAspect::DepthOnly,
                ..texture.as_image_copy()
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            texture.size(),
        );
        gpu.queue.submit([encoder.finish()]);
        let slice = buffer.slice(..);
        slice.map_async(wgpu::MapMode::Read, |r| r.unwrap());
        gpu.device
            .poll(wgpu::PollType::wait_indefinitely())
            .unwrap();
        let data = slice.get_mapped_range().unwrap();
        (0..h)
            .flat_map(|y| {
                let start = (y * row) as usize;
                bytemuck::cast_slice::<u8, f32>(&data[start..start + (w * 4) as usize]).to_vec()
            })
            .collect()
    }

    /// On lavapipe: the depth pass stores, for each eye, the depth of the surfaces the
    /// renderer drew there, and through the layer's near and far a compositor reads
    /// back the renderer's own view depth (its geometry image, within the chord error
    /// its smooth-surface lift adds); where the renderer drew nothing the far value
    /// stays.
    #[test]
    fn the_depth_pass_stores_what_the_renderer_drew() {
        use crate::app::AppState;
        use crate::render::{FrameInput, Gpu, OutputContent, OutputTarget};
        use crate::xr::actions::{self, ReferenceSpace};
        use crate::xr::{XrPose, xr_views};
        use glam::{DQuat, DVec3};
        use sculpt_core::sculpt::tessellate::Detail;

        let gpu = Gpu::headless().unwrap_or_else(|e| panic!("a GPU (lavapipe): {e}"));
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = crate::config::Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let (lo, hi) = app.document_bounds().unwrap();
        let stage = actions::display_from_stage(ReferenceSpace::Stage, (lo + hi) * 0.5);
        let eye = |x: f64| XrPose {
            position: DVec3::new(x, actions::STANDING_EYE_HEIGHT_M, 0.0),
            orientation: DQuat::IDENTITY,
        };
        let fov = XrFov {
            angle_left: -0.8,
            angle_right: 0.8,
            angle_up: 0.8,
            angle_down: -0.8,
        };
        let (near, far) = (0.05, 100.0);
        let cameras =
            xr_views(&[(eye(-0.032), fov), (eye(0.032), fov)], &stage, near, far).unwrap();
        let size = (96, 64);
        let texture = |format, label| {
            gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: size.0,
                    height: size.1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let format = wgpu::TextureFormat::Rgba8UnormSrgb;
        let colour = [0, 1].map(|_| texture(format, "eye"));
        let depth = [0, 1].map(|_| texture(wgpu::TextureFormat::Depth32Float, "eye depth"));
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (colour_views, depth_views) = (colour.each_ref().map(view), depth.each_ref().map(view));
        // One sample per pixel: the renderer's depth at the pixel centres, as the pass.
        let mut renderer = Renderer::with_samples(&gpu, format, 1);
        renderer.sync_with(|sinks| app.sync_meshes(sinks));
        let outputs = [OutputContent::LeftEye, OutputContent::RightEye];
        renderer.render(
            &FrameInput {
                views: &cameras,
                lines: &[],
                hud: &[],
            },
            &[
                OutputTarget {
                    view: &colour_views[0],
                    size,
                    content: outputs[0],
                },
                OutputTarget {
                    view: &colour_views[1],
                    size,
                    content: outputs[1],
                },
            ],
        );
        let pass = DepthPass::new(&gpu.device, wgpu::TextureFormat::Depth32Float);
        pass.draw(
            &gpu.queue,
            &renderer,
            &cameras,
            [&depth_views[0], &depth_views[1]],
        );
        let layer = DepthLayer::new(near, far).unwrap();
        // The geometry image keeps view depth as a pair of half floats (about 20
        // significant bits), the depth image a 32-bit float whose steps near 1 stand
        // for z^2 (f - n) / (n f) metres each: both agree to a few units of rounding.
        // The geometry image's depth is the smooth surface's (the flat triangles'
        // point lifted by Phong tessellation for the cavity term, `shaders.wgsl`), the
        // depth pass draws the flat triangles: they differ by at most the chord error,
        // which the tessellation keeps within its stated tolerance.
        let chord = app
            .session
            .doc
            .targets()
            .iter()
            .map(|t| Detail::Final.tolerance(t.surface.size()))
            .fold(0.0, f64::max);
        let tolerance = |z: f64| {
            chord
                + ROUNDING_UNITS
                    * f64::from(f32::EPSILON)
                    * (z + z * z * (far - near) / (near * far))
        };
        for (eye, texture) in depth.iter().enumerate() {
            let stored = read_depth(&gpu, texture);
            let drawn = renderer.read_view_depth(eye).unwrap().unwrap();
            let mut covered = 0;
            for (i, (&d, &z)) in stored.iter().zip(&drawn.depth).enumerate() {
                if z.is_finite() {
                    covered += 1;
                    let z = f64::from(z);
                    assert_near!(layer.distance(f64::from(d)), z, tolerance(z));
                } else {
                    assert_eq!(d, 1.0, "eye {eye} pixel {i}: nothing drawn, far value");
                }
            }
            assert!(
                covered > stored.len() / 4,
                "eye {eye}: the sheet covers {covered} of {} pixels",
                stored.len()
            );
        }
    }

    /// Units of `f32::EPSILON` the two depth records may differ by.
    const ROUNDING_UNITS: f64 = 16.0;

    #[test]
    fn depth_swapchain_format_prefers_32_bit_float() {
        assert_eq!(
            depth_swapchain_format(&[124, 129, 126]),
            Some((126, wgpu::TextureFormat::Depth32Float))
        );
        assert_eq!(
            depth_swapchain_format(&[129, 124]),
            Some((124, wgpu::TextureFormat::Depth16Unorm))
        );
        assert_eq!(depth_swapchain_format(&[43, 129]), None, "no usable depth");
    }
}
