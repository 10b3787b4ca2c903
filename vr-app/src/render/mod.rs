//! The wgpu renderer: shaded meshes, optional wireframe, wand cursor lines and a HUD,
//! drawn for each eye and composed into the outputs of the chosen [`OutputMode`].
//!
//! **Picture.** Each eye is drawn multisampled (4x where the adapter supports it for
//! every attachment, else 1: [`Renderer::sample_count`]) into an sRGB colour image, so
//! lighting is computed in linear light and encoded once. The lighting is fixed to the
//! viewer: a key light from the upper left, a weak rim light and a sky/ground
//! hemisphere fill; the surface takes one of the [`Material`]s. A second image holds
//! each pixel's view depth and surface class; the composition pass darkens cavities
//! (grooves) by unsharp masking that depth (Luft, Colditz and Deussen 2006), draws a
//! dark silhouette outline where a surface lies in front of a deeper one or of the
//! background, an amber one around the selected target when there are several
//! ([`SurfaceClasses`]), and encodes sRGB by hand for non-sRGB outputs (the
//! `Rgba8Unorm` offscreen images that become PNGs). The wand cursor is drawn twice: in
//! front of the surfaces as it is, and behind them faded, so it never disappears.
//!
//! Geometry arrives only through [`MeshSink`](sculpt_core::mesh::MeshSink): the
//! [`GpuMeshStore`]s (the document at each detail, and the live preview) pack patches
//! into batches of neighbouring patches, so an edit re-uploads only the batches it
//! changed and a frame draws one call per batch. The same code renders to windows and
//! offscreen; [`Renderer::render_offscreen`] returns both eyes and the composite as
//! images for PNG output (it runs on lavapipe, Mesa's CPU Vulkan driver).
//!
//! ```no_run
//! use vr_app::projection::{fixed_head, Screen, StereoRig};
//! use vr_app::render::{FrameInput, Gpu, OutputMode, Renderer, Views};
//! use glam::DVec3;
//! let gpu = Gpu::headless()?;
//! let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
//! let screen = Screen::new(DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(-1.0, 1.5, 0.0))?;
//! let views = Views::new(&StereoRig::default(), &screen, &fixed_head(&screen, 2.0))?;
//! let frame = renderer.render_offscreen(&FrameInput { views: &views, lines: &[], hud: &[] }, OutputMode::Anaglyph, 640, 360)?;
//! frame.composite.save("frame.png").unwrap();
//! # Ok::<(), vr_app::VrError>(())
//! ```

pub mod gpu;
pub mod hud;
pub(crate) mod limits;
pub mod material;
pub mod mesh_store;

use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};

pub use gpu::Gpu;
pub use limits::{MAX_OFFSCREEN_PIXELS, MAX_OFFSCREEN_SIDE};
pub use mesh_store::{GpuMeshStore, GpuVertex, UploadStats};
use sculpt_core::sculpt::tessellate::Detail;

pub use crate::output::OutputMode;
pub use crate::scene::{
    FrameInput, LineVertex, MeshSinks, MeshSync, SurfaceClasses, Views, cursor_lines,
};

use crate::error::{GpuError, VrError, VrResult};
use hud::HudVertex;
pub use material::{Material, SurfaceClass};
use material::{MaterialUniform, srgb_to_linear};

/// What one output shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputContent {
    /// The left eye only (one projector of a dual setup).
    LeftEye,
    /// The right eye only.
    RightEye,
    /// Both eyes side by side.
    SideBySide,
    /// Red-cyan anaglyph.
    Anaglyph,
    /// The head-centre view.
    Mono,
}

/// One render target: a texture view of a window surface or an offscreen texture.
#[derive(Debug, Clone, Copy)]
pub struct OutputTarget<'a> {
    /// Where to draw.
    pub view: &'a wgpu::TextureView,
    /// Its size in pixels.
    pub size: (u32, u32),
    /// What to show.
    pub content: OutputContent,
}

/// The outputs of an offscreen frame.
#[derive(Debug, Clone)]
pub struct OffscreenFrame {
    /// The left eye's image as a projector would show it, without the HUD (in mono,
    /// the composite: the head-centre view).
    pub left: image::RgbaImage,
    /// The right eye's image (in mono, the composite).
    pub right: image::RgbaImage,
    /// What the display shows: the mode's composition; for `dual`, the two projector
    /// outputs side by side.
    pub composite: image::RgbaImage,
}

/// Timing of one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameStats {
    /// CPU time for uniform and buffer updates plus command encoding and submission,
    /// both eyes. (On lavapipe, submission runs part of the software rasteriser.)
    pub cpu: Duration,
    /// The same up to the end of encoding, without the submission.
    pub encode: Duration,
    /// Triangles drawn per eye.
    pub triangles: u64,
}

#[derive(Debug, Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct CameraUniform {
    clip_from_display: [[f32; 4]; 4],
    view_from_display: [[f32; 4]; 4],
    eye: [f32; 4],
}

#[derive(Debug, Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct ComposeUniform {
    mode: u32,
    half_width: u32,
    width: u32,
    height: u32,
    encode_srgb: u32,
    effects: u32,
    focal_px: f32,
    pad: f32,
}

/// Checks an offscreen image size against [`MAX_OFFSCREEN_SIDE`] and
/// [`MAX_OFFSCREEN_PIXELS`] ([`GpuError::OffscreenSize`] otherwise), before anything is
/// allocated.
pub fn check_offscreen_size(width: u32, height: u32) -> VrResult<()> {
    let side = 1..=MAX_OFFSCREEN_SIDE;
    if !side.contains(&width)
        || !side.contains(&height)
        || u64::from(width) * u64::from(height) > MAX_OFFSCREEN_PIXELS
    {
        return Err(VrError::Gpu(GpuError::OffscreenSize { width, height }));
    }
    Ok(())
}

/// The eye images' colour format: sRGB, so the shaders write linear light.
pub const EYE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// The geometry image (view depth as a half-float pair, coverage, surface class).
const GEOM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The offscreen output format (read back into PNGs, which are sRGB-encoded).
const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Most outputs one frame may have (two projectors, or an offscreen composition and
/// both eyes).
const MAX_OUTPUTS: usize = 4;
/// The multisample count asked for.
pub const WANTED_SAMPLES: u32 = 4;

/// The largest sample count up to `want` (4, 2 or 1) that `adapter` supports for
/// every eye attachment, with resolve for the colour images.
pub fn supported_samples(adapter: &wgpu::Adapter, want: u32) -> u32 {
    [4, 2]
        .into_iter()
        .filter(|&n| n <= want)
        .find(|&n| {
            [EYE_FORMAT, GEOM_FORMAT, DEPTH_FORMAT].iter().all(|&f| {
                let flags = adapter.get_texture_format_features(f).flags;
                flags.sample_count_supported(n)
                    && (f == DEPTH_FORMAT
                        || flags.contains(wgpu::TextureFormatFeatureFlags::MULTISAMPLE_RESOLVE))
            })
        })
        .unwrap_or(1)
}

#[derive(Debug)]
struct EyeTargets {
    size: (u32, u32),
    /// Resolved (single-sample) colour, read by the composition.
    color_views: [wgpu::TextureView; 2],
    /// Multisampled colour and geometry (absent at one sample: drawn directly).
    msaa_color_views: Option<[wgpu::TextureView; 2]>,
    msaa_geom_views: Option<[wgpu::TextureView; 2]>,
    geom_views: [wgpu::TextureView; 2],
    /// The resolved geometry images, kept for [`Renderer::read_view_depth`].
    geom: [wgpu::Texture; 2],
    depth_views: [wgpu::TextureView; 2],
    compose_bg: wgpu::BindGroup,
}

#[derive(Debug)]
struct OutputSlot {
    compose_ubuf: wgpu::Buffer,
    hud_ubuf: wgpu::Buffer,
    hud_bg: wgpu::BindGroup,
    hud_vbuf: Option<(wgpu::Buffer, u64)>,
}

/// The renderer. Owns the pipelines, the per-eye offscreen targets and the mesh
/// stores: the sculpted document at final and at interactive detail (one store per
/// detail, as `Document::tessellate` wants; [`Renderer::shown`] picks which is drawn)
/// and the live stroke preview.
#[derive(Debug)]
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// The sculpted targets (trimmed, with their stroke surfaces) at final detail.
    pub targets: GpuMeshStore,
    /// The same at interactive detail, drawn while a stroke is live.
    pub interactive: GpuMeshStore,
    /// Which of the two document stores is drawn.
    pub shown: Detail,
    /// The live stroke preview.
    pub preview: GpuMeshStore,
    /// Draw the wireframe over the meshes.
    pub wireframe: bool,
    /// Swap the eyes (for a projector pair wired the other way round).
    pub swap_eyes: bool,
    /// Background colour (sRGB-encoded display values).
    pub background: [f64; 3],
    /// Cavity shading and silhouette outlines (on by default).
    pub effects: bool,
    /// How targets are told apart.
    pub classes: SurfaceClasses,
    material: Material,
    samples: u32,
    output_srgb: bool,
    mesh_pipeline: wgpu::RenderPipeline,
    wire_pipeline: wgpu::RenderPipeline,
    line_pipeline: wgpu::RenderPipeline,
    line_hidden_pipeline: wgpu::RenderPipeline,
    compose_pipeline: wgpu::RenderPipeline,
    hud_pipeline: wgpu::RenderPipeline,
    compose_bgl: wgpu::BindGroupLayout,
    camera_ubufs: [wgpu::Buffer; 2],
    camera_bgs: [wgpu::BindGroup; 2],
    material_ubufs: Vec<wgpu::Buffer>,
    material_bgs: Vec<wgpu::BindGroup>,
    line_vbuf: Option<(wgpu::Buffer, u64)>,
    eyes: Option<EyeTargets>,
    slots: Vec<OutputSlot>,
    last: FrameStats,
}

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
            layout: &scene_layout,
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
            eyes: None,
            slots,
            last: FrameStats::default(),
        };
        renderer.set_material(Material::default());
        renderer
    }

    /// Samples per pixel of the eye images (4 where the adapter allows, else 1).
    pub fn sample_count(&self) -> u32 {
        self.samples
    }

    /// The surface material.
    pub fn material(&self) -> Material {
        self.material
    }

    /// Sets the surface material.
    pub fn set_material(&mut self, material: Material) {
        self.material = material;
        for (class, buf) in SurfaceClass::ALL.iter().zip(&self.material_ubufs) {
            self.queue
                .write_buffer(buf, 0, bytemuck::bytes_of(&material.uniform(*class)));
        }
    }

    /// The document store that is drawn ([`Renderer::shown`]).
    pub fn document_store(&self) -> &GpuMeshStore {
        match self.shown {
            Detail::Final => &self.targets,
            Detail::Interactive => &self.interactive,
        }
    }

    /// The sinks a scene's meshes are written into (see
    /// [`SceneState::sync_meshes`](crate::scene::SceneState::sync_meshes)).
    pub fn sinks(&mut self) -> MeshSinks<'_> {
        MeshSinks {
            final_detail: &mut self.targets,
            interactive: &mut self.interactive,
            preview: &mut self.preview,
        }
    }

    /// Brings the mesh stores up to date through `update`, which writes into the
    /// [`sinks`](Self::sinks) (e.g. `|s| app.sync_meshes(s)`), and draws the detail it
    /// reports.
    pub fn sync_with(&mut self, update: impl FnOnce(MeshSinks<'_>) -> MeshSync) -> MeshSync {
        let sync = update(self.sinks());
        self.shown = sync.shown;
        sync
    }

    /// Empties the mesh stores (the next scene is written from scratch).
    pub fn clear_meshes(&mut self) {
        for store in [&mut self.targets, &mut self.interactive, &mut self.preview] {
            store.clear();
        }
        self.shown = Detail::Final;
    }

    /// The device this renderer draws with.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// Timing of the last frame.
    pub fn last_frame(&self) -> FrameStats {
        self.last
    }

    fn ensure_eyes(&mut self, size: (u32, u32)) {
        if self.eyes.as_ref().is_some_and(|e| e.size == size) {
            return;
        }
        let tex = |label: &str, format, usage, sample_count| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: size.0,
                    height: size.1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let resolved = attach | wgpu::TextureUsages::TEXTURE_BINDING;
        let n = self.samples;
        let color = [0, 1].map(|_| tex("eye", EYE_FORMAT, resolved, 1));
        // Copied back by `read_view_depth`.
        let readable = resolved | wgpu::TextureUsages::COPY_SRC;
        let geom = [0, 1].map(|_| tex("eye geometry", GEOM_FORMAT, readable, 1));
        let depth = [0, 1].map(|_| tex("eye depth", DEPTH_FORMAT, attach, n));
        let (msaa_color_views, msaa_geom_views) = if n > 1 {
            (
                Some([0, 1].map(|_| view(&tex("eye msaa", EYE_FORMAT, attach, n)))),
                Some([0, 1].map(|_| view(&tex("eye geometry msaa", GEOM_FORMAT, attach, n)))),
            )
        } else {
            (None, None)
        };
        let color_views = [0, 1].map(|i| view(&color[i]));
        let geom_views = [0, 1].map(|i| view(&geom[i]));
        let depth_views = [0, 1].map(|i| view(&depth[i]));
        let compose_bg = Self::compose_bind_group(
            &self.device,
            &self.compose_bgl,
            [&color_views[0], &color_views[1]],
            [&geom_views[0], &geom_views[1]],
            &self.slots[0].compose_ubuf,
        );
        // Other output slots have their own compose uniforms; their bind groups are cheap
        // and are built per frame in `compose_group`.
        self.eyes = Some(EyeTargets {
            size,
            color_views,
            msaa_color_views,
            msaa_geom_views,
            geom_views,
            geom,
            depth_views,
            compose_bg,
        });
    }

    fn compose_bind_group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        color: [&wgpu::TextureView; 2],
        geom: [&wgpu::TextureView; 2],
        ubuf: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let tv = |binding, v| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(v),
        };
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("compose"),
            layout,
            entries: &[
                tv(0, color[0]),
                tv(1, color[1]),
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: ubuf.as_entire_binding(),
                },
                tv(3, geom[0]),
                tv(4, geom[1]),
            ],
        })
    }

    /// The compose bind group of output `slot`; `second_first` puts eye 1 in the
    /// first texture binding (a right-eye-only output).
    fn compose_group(&self, slot: usize, second_first: bool) -> Option<wgpu::BindGroup> {
        let eyes = self.eyes.as_ref()?;
        let (a, b) = if second_first { (1, 0) } else { (0, 1) };
        Some(Self::compose_bind_group(
            &self.device,
            &self.compose_bgl,
            [&eyes.color_views[a], &eyes.color_views[b]],
            [&eyes.geom_views[a], &eyes.geom_views[b]],
            &self.slots[slot].compose_ubuf,
        ))
    }

    /// An offscreen output texture (`Rgba8Unorm`) that can be rendered to and copied.
    pub fn output_texture(&self, width: u32, height: u32) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen output"),
            size: wgpu::Extent3d {
                width: width.max(1),
                height: height.max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OFFSCREEN_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    }

    fn write_buffer_growing(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        slot: &mut Option<(wgpu::Buffer, u64)>,
        bytes: &[u8],
    ) {
        if bytes.is_empty() {
            return;
        }
        let need = bytes.len() as u64;
        if slot.as_ref().is_none_or(|(_, cap)| *cap < need) {
            let cap = need.next_power_of_two().max(1024);
            *slot = Some((
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("dynamic vertices"),
                    size: cap,
                    usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                cap,
            ));
        }
        if let Some((buf, _)) = slot {
            queue.write_buffer(buf, 0, bytes);
        }
    }

    /// Renders one frame into `outputs` (at most four) and submits it. The eye images
    /// are sized for the first output (half its width for side by side).
    pub fn render(&mut self, input: &FrameInput<'_>, outputs: &[OutputTarget<'_>]) -> FrameStats {
        self.render_outputs(input, outputs, outputs.len())
    }

    /// [`Self::render`] with the HUD on the first `hud_outputs` outputs only.
    fn render_outputs(
        &mut self,
        input: &FrameInput<'_>,
        outputs: &[OutputTarget<'_>],
        hud_outputs: usize,
    ) -> FrameStats {
        let start = Instant::now();
        for store in [&mut self.targets, &mut self.interactive, &mut self.preview] {
            store.flush();
        }
        let outputs = &outputs[..outputs.len().min(MAX_OUTPUTS)];
        let Some(first) = outputs.first() else {
            return FrameStats::default();
        };
        let eye_size = match first.content {
            OutputContent::SideBySide => ((first.size.0 / 2).max(1), first.size.1.max(1)),
            _ => (first.size.0.max(1), first.size.1.max(1)),
        };
        self.ensure_eyes(eye_size);
        let mono = outputs.iter().all(|o| o.content == OutputContent::Mono);
        let (a, b) = if self.swap_eyes {
            (input.views.right, input.views.left)
        } else {
            (input.views.left, input.views.right)
        };
        let cams = if mono {
            [input.views.center, input.views.center]
        } else {
            [a, b]
        };
        for (i, cam) in cams.iter().enumerate() {
            let u = CameraUniform {
                clip_from_display: cam.clip_from_display().as_mat4().to_cols_array_2d(),
                view_from_display: cam.view_from_display.as_mat4().to_cols_array_2d(),
                eye: cam.eye.as_vec3().extend(1.0).to_array(),
            };
            self.queue
                .write_buffer(&self.camera_ubufs[i], 0, bytemuck::bytes_of(&u));
        }
        Self::write_buffer_growing(
            &self.device,
            &self.queue,
            &mut self.line_vbuf,
            bytemuck::cast_slice(input.lines),
        );
        let line_count = (input.lines.len() / 2 * 2) as u32;

        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        let eye_count = if mono { 1 } else { 2 };
        let eyes = self.eyes.as_ref().expect("eye targets were just created");
        let bg = self.background.map(srgb_to_linear);
        // Pixels per metre at one metre of view depth, for the cavity radius.
        let focal_px = (cams[0].clip_from_view.y_axis.y * f64::from(eye_size.1) * 0.5) as f32;
        for eye in 0..eye_count {
            // Multisampled images resolve into the single-sample ones.
            let (color_view, color_resolve) = match &eyes.msaa_color_views {
                Some(m) => (&m[eye], Some(&eyes.color_views[eye])),
                None => (&eyes.color_views[eye], None),
            };
            let (geom_view, geom_resolve) = match &eyes.msaa_geom_views {
                Some(m) => (&m[eye], Some(&eyes.geom_views[eye])),
                None => (&eyes.geom_views[eye], None),
            };
            let store = if color_resolve.is_some() {
                wgpu::StoreOp::Discard
            } else {
                wgpu::StoreOp::Store
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("eye"),
                color_attachments: &[
                    Some(wgpu::RenderPassColorAttachment {
                        view: color_view,
                        depth_slice: None,
                        resolve_target: color_resolve,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color {
                                r: bg[0],
                                g: bg[1],
                                b: bg[2],
                                a: 1.0,
                            }),
                            store,
                        },
                    }),
                    Some(wgpu::RenderPassColorAttachment {
                        view: geom_view,
                        depth_slice: None,
                        resolve_target: geom_resolve,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store,
                        },
                    }),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &eyes.depth_views[eye],
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.camera_bgs[eye], &[]);
            let preview_class = |_: u64| SurfaceClass::Preview;
            let document_class = |b: u64| self.classes.of_batch(b);
            let stores: [(&GpuMeshStore, &dyn Fn(u64) -> SurfaceClass); 2] = [
                (self.document_store(), &document_class),
                (&self.preview, &preview_class),
            ];
            for (store, class_of) in stores {
                pass.set_pipeline(&self.mesh_pipeline);
                let mut bound = None;
                for (batch, p) in store.keyed_batches() {
                    let class = class_of(batch);
                    if bound != Some(class) {
                        pass.set_bind_group(1, &self.material_bgs[class.index()], &[]);
                        bound = Some(class);
                    }
                    pass.set_vertex_buffer(0, p.vertices.slice(..));
                    pass.set_index_buffer(p.triangles.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..p.triangle_index_count, 0, 0..1);
                }
                if self.wireframe {
                    pass.set_pipeline(&self.wire_pipeline);
                    pass.set_bind_group(1, &self.material_bgs[0], &[]);
                    for p in store.batches() {
                        pass.set_vertex_buffer(0, p.vertices.slice(..));
                        pass.set_index_buffer(p.edges.slice(..), wgpu::IndexFormat::Uint32);
                        pass.draw_indexed(0..p.edge_index_count, 0, 0..1);
                    }
                }
            }
            if let (Some((buf, _)), true) = (&self.line_vbuf, line_count > 0) {
                // The cursor behind a surface, faded, then in front as it is.
                pass.set_vertex_buffer(0, buf.slice(..));
                pass.set_pipeline(&self.line_hidden_pipeline);
                pass.draw(0..line_count, 0..1);
                pass.set_pipeline(&self.line_pipeline);
                pass.draw(0..line_count, 0..1);
            }
        }

        for (slot_index, out) in outputs.iter().enumerate() {
            let (w, h) = (out.size.0.max(1), out.size.1.max(1));
            let (mode, second_eye) = match out.content {
                OutputContent::LeftEye | OutputContent::Mono => (0, false),
                OutputContent::RightEye => (0, true),
                OutputContent::SideBySide => (1, false),
                OutputContent::Anaglyph => (2, false),
            };
            let cu = ComposeUniform {
                mode,
                half_width: eye_size.0,
                width: w,
                height: h,
                encode_srgb: u32::from(!self.output_srgb),
                effects: u32::from(self.effects),
                focal_px,
                pad: 0.0,
            };
            let mut hud_vertices = Vec::new();
            if slot_index < hud_outputs {
                hud::hud_panel(input.hud, 0.0, h, &mut hud_vertices);
                if out.content == OutputContent::SideBySide {
                    hud::hud_panel(input.hud, eye_size.0 as f32, h, &mut hud_vertices);
                }
            }
            let slot = &mut self.slots[slot_index];
            self.queue
                .write_buffer(&slot.compose_ubuf, 0, bytemuck::bytes_of(&cu));
            self.queue.write_buffer(
                &slot.hud_ubuf,
                0,
                bytemuck::cast_slice(&[
                    w as f32,
                    h as f32,
                    if self.output_srgb { 0.0 } else { 1.0 },
                    0.0,
                ]),
            );
            Self::write_buffer_growing(
                &self.device,
                &self.queue,
                &mut slot.hud_vbuf,
                bytemuck::cast_slice(&hud_vertices),
            );
            // A right-eye-only output reads eye 1 as its "first" image.
            let group = if !second_eye && slot_index == 0 {
                self.eyes.as_ref().map(|e| e.compose_bg.clone())
            } else {
                self.compose_group(slot_index, second_eye)
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("compose"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: out.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let Some(group) = &group {
                pass.set_pipeline(&self.compose_pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.draw(0..3, 0..1);
            }
            let slot = &self.slots[slot_index];
            if let (Some((buf, _)), false) = (&slot.hud_vbuf, hud_vertices.is_empty()) {
                pass.set_pipeline(&self.hud_pipeline);
                pass.set_bind_group(0, &slot.hud_bg, &[]);
                pass.set_vertex_buffer(0, buf.slice(..));
                pass.draw(0..hud_vertices.len() as u32, 0..1);
            }
        }
        let command_buffer = encoder.finish();
        let encode = start.elapsed();
        self.queue.submit([command_buffer]);
        let stats = FrameStats {
            cpu: start.elapsed(),
            encode,
            triangles: self.document_store().triangle_count() + self.preview.triangle_count(),
        };
        tracing::trace!(
            cpu_us = stats.cpu.as_micros() as u64,
            encode_us = stats.encode.as_micros() as u64,
            triangles = stats.triangles,
            "frame"
        );
        self.last = stats;
        stats
    }

    /// Renders a frame offscreen at `width` x `height` (the size of one output) and
    /// reads back both eyes and the composite.
    pub fn render_offscreen(
        &mut self,
        input: &FrameInput<'_>,
        mode: OutputMode,
        width: u32,
        height: u32,
    ) -> VrResult<OffscreenFrame> {
        check_offscreen_size(width, height)?;
        let contents: &[OutputContent] = match mode {
            OutputMode::Dual => &[OutputContent::LeftEye, OutputContent::RightEye],
            OutputMode::SideBySide => &[OutputContent::SideBySide],
            OutputMode::Anaglyph => &[OutputContent::Anaglyph],
            OutputMode::Mono => &[OutputContent::Mono],
        };
        // Both eyes alone (no HUD) besides the mode's outputs, except in mono.
        let eye_size = match mode {
            OutputMode::SideBySide => ((width / 2).max(1), height),
            _ => (width, height),
        };
        let eyes: &[OutputContent] = match mode {
            OutputMode::Mono => &[],
            _ => &[OutputContent::LeftEye, OutputContent::RightEye],
        };
        let sized: Vec<(OutputContent, (u32, u32))> = contents
            .iter()
            .map(|&c| (c, (width, height)))
            .chain(eyes.iter().map(|&c| (c, eye_size)))
            .collect();
        let textures: Vec<wgpu::Texture> = sized
            .iter()
            .map(|&(_, (w, h))| self.output_texture(w, h))
            .collect();
        let views: Vec<wgpu::TextureView> = textures
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let targets: Vec<OutputTarget<'_>> = views
            .iter()
            .zip(&sized)
            .map(|(view, &(content, size))| OutputTarget {
                view,
                size,
                content,
            })
            .collect();
        self.render_outputs(input, &targets, contents.len());
        let mut outs = Vec::new();
        for t in &textures {
            outs.push(self.read_texture(t)?);
        }
        let mut eye_images = outs.split_off(contents.len());
        let composite = if outs.len() == 2 {
            let mut wide = image::RgbaImage::new(width * 2, height);
            image::imageops::replace(&mut wide, &outs[0], 0, 0);
            image::imageops::replace(&mut wide, &outs[1], i64::from(width), 0);
            wide
        } else {
            outs.swap_remove(0)
        };
        let (left, right) = match (eye_images.pop(), eye_images.pop()) {
            (Some(right), Some(left)) => (left, right),
            _ => (composite.clone(), composite.clone()),
        };
        Ok(OffscreenFrame {
            left,
            right,
            composite,
        })
    }

    /// The view depth and coverage of eye image `eye` (0: the left eye, or the centre
    /// in mono; 1: the right eye; as drawn, after [`Self::swap_eyes`]) of the last
    /// frame, read back from the GPU: the depth buffer's surfaces as the composition
    /// sees them. `None` before the first frame or for an eye the frame did not draw
    /// (eye 1 of a mono frame holds an older picture).
    pub fn read_view_depth(&self, eye: usize) -> VrResult<Option<ViewDepth>> {
        let Some(texture) = self.eyes.as_ref().and_then(|e| e.geom.get(eye)) else {
            return Ok(None);
        };
        let (width, height) = (texture.width(), texture.height());
        let bytes = self.read_texture_bytes(texture, 8)?;
        let half = |i: usize| f16_to_f32(u16::from_le_bytes([bytes[i], bytes[i + 1]]));
        let n = (width * height) as usize;
        let (mut depth, mut coverage) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for px in 0..n {
            let (hi, lo, cov) = (half(px * 8), half(px * 8 + 2), half(px * 8 + 4));
            coverage.push(cov);
            // Resolve averaged the pair over the covered samples.
            depth.push(if cov > 0.0 {
                (hi + lo) / cov
            } else {
                f32::INFINITY
            });
        }
        Ok(Some(ViewDepth {
            width,
            height,
            depth,
            coverage,
        }))
    }

    /// Copies an `Rgba8Unorm` texture back to the CPU.
    fn read_texture(&self, texture: &wgpu::Texture) -> VrResult<image::RgbaImage> {
        let (w, h) = (texture.width(), texture.height());
        let pixels = self.read_texture_bytes(texture, 4)?;
        image::RgbaImage::from_raw(w, h, pixels).ok_or(VrError::Gpu(GpuError::ReadbackSize))
    }

    /// Copies a texture of `bytes_per_pixel` back to the CPU, rows packed.
    fn read_texture_bytes(
        &self,
        texture: &wgpu::Texture,
        bytes_per_pixel: u32,
    ) -> VrResult<Vec<u8>> {
        let (w, h) = (texture.width(), texture.height());
        let row = w * bytes_per_pixel;
        let padded =
            row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: u64::from(padded) * u64::from(h),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(h),
                },
            },
            texture.size(),
        );
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            // The receiver outlives the poll below; a send failure cannot happen.
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| VrError::Gpu(GpuError::Poll(e)))?;
        rx.recv()
            .map_err(|_| VrError::Gpu(GpuError::MapLost))?
            .map_err(|e| VrError::Gpu(GpuError::Map(e)))?;
        let data = buffer
            .slice(..)
            .get_mapped_range()
            .map_err(|e| VrError::Gpu(GpuError::MapRange(e)))?;
        let mut pixels = Vec::with_capacity((row * h) as usize);
        for y in 0..h as usize {
            let start = y * padded as usize;
            pixels.extend_from_slice(&data[start..start + row as usize]);
        }
        drop(data);
        buffer.unmap();
        Ok(pixels)
    }
}

/// The view depth of one eye image as the GPU drew it ([`Renderer::read_view_depth`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ViewDepth {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Per pixel, row by row from the top: the distance (metres) along the eye's view
    /// direction of the nearest surface, averaged over the covered samples; infinite
    /// where no surface covers the pixel.
    pub depth: Vec<f32>,
    /// Per pixel: the fraction of its samples a surface covers (0 to 1).
    pub coverage: Vec<f32>,
}

impl ViewDepth {
    /// The depth at pixel `(x, y)` where a surface covers at least half of it.
    pub fn at(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y * self.width + x) as usize;
        (self.coverage[i] >= 0.5).then_some(self.depth[i])
    }
}

/// An IEEE 754 half-precision float's bits as `f32`.
fn f16_to_f32(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((bits >> 10) & 0x1f);
    let frac = f32::from(bits & 0x3ff);
    sign * match exp {
        0 => frac * 2f32.powi(-24),
        31 if frac == 0.0 => f32::INFINITY,
        31 => f32::NAN,
        _ => (1.0 + frac / 1024.0) * 2f32.powi(exp - 15),
    }
}

#[cfg(test)]
mod tests {
    use super::f16_to_f32;

    #[test]
    fn half_floats_decode() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
        assert_eq!(f16_to_f32(0x0000), 0.0);
    }
}
