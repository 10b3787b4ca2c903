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

mod frame;
pub mod gpu;
pub mod hud;
pub(crate) mod limits;
pub mod material;
pub mod mesh_store;
pub mod paint_texture;
mod pipelines;
mod readback;

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
pub use readback::ViewDepth;

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
/// detail, as `DocumentView::tessellate` wants; [`Renderer::shown`] picks which is drawn)
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
    paint: paint_texture::PaintTextures,
    eyes: Option<EyeTargets>,
    slots: Vec<OutputSlot>,
    last: FrameStats,
}

impl Renderer {
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
}

#[cfg(test)]
mod tests {
    use super::readback::f16_to_f32;

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
