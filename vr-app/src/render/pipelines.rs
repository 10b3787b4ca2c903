//! Building the renderer: bind-group layouts and the render pipelines of each pass.

use super::*;

fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// How a pipeline uses the depth buffer.
#[derive(Clone, Copy, PartialEq)]
enum DepthUse {
    /// No depth attachment (composition, HUD).
    None,
    /// Test `LessEqual` and write (surfaces).
    Write,
    /// Test `LessEqual`, no write (overlays in front).
    Front,
    /// Test `Greater`, no write (overlays behind a surface).
    Behind,
}

struct PipelineSpec<'a> {
    label: &'a str,
    layout: &'a wgpu::PipelineLayout,
    vs: &'a str,
    fs: &'a str,
    buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    topology: wgpu::PrimitiveTopology,
    /// `None`: an eye pass (colour and geometry images, multisampled).
    format: Option<wgpu::TextureFormat>,
    depth: DepthUse,
    blend: bool,
    /// In an eye pass: write all of the geometry image (surfaces), or only its class
    /// channel (overlays).
    geometry: bool,
}

impl Renderer {
    /// A renderer on `gpu` whose outputs have `output_format` (the window surface's
    /// format, or `Rgba8Unorm` offscreen), multisampled as far as the adapter allows,
    /// in the default material.
    pub fn new(gpu: &Gpu, output_format: wgpu::TextureFormat) -> Self {
        Self::with_samples(gpu, output_format, WANTED_SAMPLES)
    }

    /// The same with at most `samples` samples per pixel (1 turns multisampling off).
    pub fn with_samples(gpu: &Gpu, output_format: wgpu::TextureFormat, samples: u32) -> Self {
        let samples = supported_samples(&gpu.adapter, samples);
        let device = gpu.device.clone();
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("wandsculpt shaders"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders.wgsl").into()),
        });
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let camera_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera"),
            entries: &[uniform_entry(0, vf)],
        });
        let material_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &[uniform_entry(0, vf)],
        });
        let compose_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("compose"),
            entries: &[
                texture_entry(0),
                texture_entry(1),
                uniform_entry(2, wgpu::ShaderStages::FRAGMENT),
                texture_entry(3),
                texture_entry(4),
            ],
        });
        let hud_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hud"),
            entries: &[uniform_entry(0, vf)],
        });
        let layout = |label: &str, bgls: &[Option<&wgpu::BindGroupLayout>]| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: bgls,
                immediate_size: 0,
            })
        };
        let scene_layout = layout("scene", &[Some(&camera_bgl), Some(&material_bgl)]);
        let paint = super::paint_texture::PaintTextures::new(&device, &gpu.queue);
        let mesh_layout = layout(
            "mesh",
            &[Some(&camera_bgl), Some(&material_bgl), Some(paint.layout())],
        );
        let line_layout = layout("lines", &[Some(&camera_bgl)]);
        let compose_layout = layout("compose", &[Some(&compose_bgl)]);
        let hud_layout = layout("hud", &[Some(&hud_bgl)]);
        let line_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<LineVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4],
        })];
        let hud_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<HudVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x4],
        })];
        let make = |s: PipelineSpec<'_>| {
            let blend = s.blend.then_some(wgpu::BlendState::ALPHA_BLENDING);
            let targets: Vec<Option<wgpu::ColorTargetState>> = match s.format {
                Some(format) => vec![Some(wgpu::ColorTargetState {
                    format,
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                None => vec![
                    Some(wgpu::ColorTargetState {
                        format: EYE_FORMAT,
                        blend,
                        write_mask: wgpu::ColorWrites::ALL,
                    }),
                    Some(wgpu::ColorTargetState {
                        format: GEOM_FORMAT,
                        blend: None,
                        write_mask: if s.geometry {
                            wgpu::ColorWrites::ALL
                        } else if s.blend {
                            // Faded overlays behind a surface leave it alone.
                            wgpu::ColorWrites::empty()
                        } else {
                            wgpu::ColorWrites::ALPHA
                        },
                    }),
                ],
            };
            let eye_pass = s.format.is_none();
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(s.label),
                layout: Some(s.layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(s.vs),
                    compilation_options: Default::default(),
                    buffers: s.buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: s.topology,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: (s.depth != DepthUse::None).then(|| wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(s.depth == DepthUse::Write),
                    depth_compare: Some(if s.depth == DepthUse::Behind {
                        wgpu::CompareFunction::Greater
                    } else {
                        wgpu::CompareFunction::LessEqual
                    }),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState {
                    count: if eye_pass { samples } else { 1 },
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(s.fs),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let tri = wgpu::PrimitiveTopology::TriangleList;
        let lines = wgpu::PrimitiveTopology::LineList;
        let mesh_pipeline = make(PipelineSpec {
            label: "mesh",
            layout: &mesh_layout,
            vs: "vs_mesh",
            fs: "fs_mesh",
            buffers: &[Some(GpuVertex::LAYOUT)],
            topology: tri,
            format: None,
            depth: DepthUse::Write,
            blend: false,
            geometry: true,
        });
        let wire_pipeline = make(PipelineSpec {
            label: "wireframe",
            layout: &scene_layout,
            vs: "vs_wire",
            fs: "fs_wire",
            buffers: &[Some(GpuVertex::LAYOUT)],
            topology: lines,
            format: None,
            depth: DepthUse::Write,
            blend: false,
            geometry: false,
        });
        let line_pipeline = make(PipelineSpec {
            label: "overlay lines",
            layout: &line_layout,
            vs: "vs_line",
            fs: "fs_line",
            buffers: &line_buffers,
            topology: lines,
            format: None,
            depth: DepthUse::Front,
            blend: false,
            geometry: false,
        });
        let line_hidden_pipeline = make(PipelineSpec {
            label: "overlay lines behind surfaces",
            layout: &line_layout,
            vs: "vs_line",
            fs: "fs_line_hidden",
            buffers: &line_buffers,
            topology: lines,
            format: None,
            depth: DepthUse::Behind,
            blend: true,
            geometry: false,
        });
        let compose_pipeline = make(PipelineSpec {
            label: "compose",
            layout: &compose_layout,
            vs: "vs_full",
            fs: "fs_compose",
            buffers: &[],
            topology: tri,
            format: Some(output_format),
            depth: DepthUse::None,
            blend: false,
            geometry: false,
        });
        let hud_pipeline = make(PipelineSpec {
            label: "hud",
            layout: &hud_layout,
            vs: "vs_hud",
            fs: "fs_hud",
            buffers: &hud_buffers,
            topology: tri,
            format: Some(output_format),
            depth: DepthUse::None,
            blend: true,
            geometry: false,
        });
        let ubuf = |label: &str, size: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let bind = |label: &str, bgl: &wgpu::BindGroupLayout, buf: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: bgl,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buf.as_entire_binding(),
                }],
            })
        };
        let camera_ubufs = [
            ubuf("camera 0", std::mem::size_of::<CameraUniform>()),
            ubuf("camera 1", std::mem::size_of::<CameraUniform>()),
        ];
        let camera_bgs = [
            bind("camera 0", &camera_bgl, &camera_ubufs[0]),
            bind("camera 1", &camera_bgl, &camera_ubufs[1]),
        ];
        let material_ubufs: Vec<wgpu::Buffer> = SurfaceClass::ALL
            .iter()
            .map(|_| ubuf("material", std::mem::size_of::<MaterialUniform>()))
            .collect();
        let material_bgs = material_ubufs
            .iter()
            .map(|b| bind("material", &material_bgl, b))
            .collect();
        let slots = (0..MAX_OUTPUTS)
            .map(|_| {
                let hud_ubuf = ubuf("hud", 16);
                OutputSlot {
                    compose_ubuf: ubuf("compose", std::mem::size_of::<ComposeUniform>()),
                    hud_bg: bind("hud", &hud_bgl, &hud_ubuf),
                    hud_ubuf,
                    hud_vbuf: None,
                }
            })
            .collect();
        let mut renderer = Self {
            targets: GpuMeshStore::new(&device),
            interactive: GpuMeshStore::new(&device),
            shown: Detail::Final,
            preview: GpuMeshStore::new(&device),
            wireframe: false,
            swap_eyes: false,
            background: [0.2, 0.22, 0.26],
            effects: true,
            classes: SurfaceClasses::default(),
            material: Material::default(),
            samples,
            output_srgb: output_format.is_srgb(),
            device,
            queue: gpu.queue.clone(),
            mesh_pipeline,
            wire_pipeline,
            line_pipeline,
            line_hidden_pipeline,
            compose_pipeline,
            hud_pipeline,
            compose_bgl,
            camera_ubufs,
            camera_bgs,
            material_ubufs,
            material_bgs,
            line_vbuf: None,
            paint,
            eyes: None,
            slots,
            last: FrameStats::default(),
        };
        renderer.set_material(Material::default());
        renderer
    }
}
