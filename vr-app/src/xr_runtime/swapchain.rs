//! The eye and depth swapchains: acquiring images, drawing the eyes into them and
//! reading one back.

use super::*;

/// Acquires the next image of `sc` and waits until it may be drawn into; returns its
/// index and how long the wait blocked.
pub(super) fn acquire(sc: &mut EyeSwapchain) -> VrResult<(usize, Duration)> {
    let index = sc
        .handle
        .acquire_image()
        .map_err(runtime("xrAcquireSwapchainImage"))? as usize;
    let start = Instant::now();
    sc.handle
        .wait_image(xr::Duration::INFINITE)
        .map_err(runtime("xrWaitSwapchainImage"))?;
    Ok((index, start.elapsed()))
}

/// The depth layer's swapchains (one per eye) and the pass that draws them.
pub(super) struct DepthSwapchains {
    pub(super) format: i64,
    pub(super) eyes: [EyeSwapchain; 2],
    pub(super) pass: DepthPass,
}

/// One eye's swapchain with its images as wgpu textures.
pub(super) struct EyeSwapchain {
    pub(super) handle: xr::Swapchain<xr::Vulkan>,
    pub(super) textures: Vec<wgpu::Texture>,
    pub(super) views: Vec<wgpu::TextureView>,
}

pub(super) fn eye_swapchain(
    session: &xr::Session<xr::Vulkan>,
    device: &wgpu::Device,
    (vk_format, format): (i64, wgpu::TextureFormat),
    (width, height): (u32, u32),
    role: ImageRole,
) -> VrResult<EyeSwapchain> {
    let handle = session
        .create_swapchain(&xr::SwapchainCreateInfo {
            create_flags: xr::SwapchainCreateFlags::EMPTY,
            usage_flags: role.swapchain_usage(),
            format: vk_format as u32,
            sample_count: 1,
            width,
            height,
            face_count: 1,
            array_size: 1,
            mip_count: 1,
        })
        .map_err(runtime("creating a swapchain"))?;
    let images = handle
        .enumerate_images()
        .map_err(runtime("swapchain images"))?;
    let textures = images
        .into_iter()
        .map(|image| {
            wrap_image(
                device,
                vk::Image::from_raw(image),
                format,
                (width, height),
                role,
            )
        })
        .collect::<VrResult<Vec<_>>>()?;
    let views = textures
        .iter()
        .map(|t| t.create_view(&wgpu::TextureViewDescriptor::default()))
        .collect();
    Ok(EyeSwapchain {
        handle,
        textures,
        views,
    })
}

/// What a swapchain image is drawn as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ImageRole {
    /// A colour attachment (an eye's picture).
    Colour,
    /// A depth attachment (the depth layer).
    Depth,
}

impl ImageRole {
    /// The HAL uses the image allows and the state OpenXR hands it out in (the
    /// colour, or depth-stencil, attachment layout), as wgpu names them.
    fn uses(self) -> (wgpu::TextureUses, wgpu::TextureUses) {
        match self {
            ImageRole::Colour => (
                wgpu::TextureUses::COLOR_TARGET
                    | wgpu::TextureUses::COPY_SRC
                    | wgpu::TextureUses::RESOURCE,
                wgpu::TextureUses::COLOR_TARGET,
            ),
            ImageRole::Depth => (
                wgpu::TextureUses::DEPTH_STENCIL_READ
                    | wgpu::TextureUses::DEPTH_STENCIL_WRITE
                    | wgpu::TextureUses::COPY_SRC,
                wgpu::TextureUses::DEPTH_STENCIL_WRITE,
            ),
        }
    }

    fn usage(self) -> wgpu::TextureUsages {
        match self {
            ImageRole::Colour => {
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::TEXTURE_BINDING
            }
            ImageRole::Depth => {
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC
            }
        }
    }

    /// The swapchain usage to ask the runtime for.
    fn swapchain_usage(self) -> xr::SwapchainUsageFlags {
        match self {
            ImageRole::Colour => {
                xr::SwapchainUsageFlags::COLOR_ATTACHMENT
                    | xr::SwapchainUsageFlags::SAMPLED
                    | xr::SwapchainUsageFlags::TRANSFER_SRC
            }
            ImageRole::Depth => {
                xr::SwapchainUsageFlags::DEPTH_STENCIL_ATTACHMENT
                    | xr::SwapchainUsageFlags::TRANSFER_SRC
            }
        }
    }
}

/// A Vulkan image owned elsewhere (a swapchain image) as a wgpu texture on `device`,
/// which must be the Vulkan device the image was created on. wgpu never destroys it,
/// and takes it to be in the colour (or depth-stencil) attachment layout, as OpenXR
/// hands out Vulkan swapchain images.
pub(super) fn wrap_image(
    device: &wgpu::Device,
    image: vk::Image,
    format: wgpu::TextureFormat,
    (width, height): (u32, u32),
    role: ImageRole,
) -> VrResult<wgpu::Texture> {
    let (hal_uses, handed_out_as) = role.uses();
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    };
    // SAFETY: the caller passes the device the image lives on.
    let hal_device = unsafe { device.as_hal::<hal::api::Vulkan>() }
        .ok_or_else(|| hal_err("wrapping an image")("the device is not Vulkan".into()))?;
    let hal_desc = hal::TextureDescriptor {
        label: Some("xr swapchain image"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: hal_uses,
        memory_flags: hal::MemoryFlags::empty(),
        view_formats: Vec::new(),
    };
    // SAFETY: `image` was created with this size, format and usage, and is owned by
    // someone else (the runtime's swapchain): the empty drop callback tells wgpu-hal
    // not to destroy it, and the owner outlives the texture (dropped first).
    let hal_texture = unsafe {
        hal_device.texture_from_raw(
            image,
            &hal_desc,
            Some(Box::new(|| {})),
            hal::vulkan::TextureMemory::External,
        )
    };
    drop(hal_device);
    // SAFETY: as above; the image is in the layout `handed_out_as` names (the colour
    // attachment layout is wgpu's COLOR_TARGET state, the depth-stencil attachment
    // layout its DEPTH_STENCIL_WRITE).
    let texture = unsafe {
        device.create_texture_from_hal::<hal::api::Vulkan>(
            hal_texture,
            &wgpu::TextureDescriptor {
                label: Some("xr swapchain image"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: role.usage(),
                view_formats: &[],
            },
            handed_out_as,
        )
    };
    Ok(texture)
}

/// Draws both eyes of `app`'s scene into `targets` (left, right), `size` pixels each,
/// with the project's renderer: meshes brought up to date, the wand cursor, no HUD.
pub(super) fn render_eyes(
    renderer: &mut Renderer,
    app: &mut AppState,
    cameras: &Views,
    targets: [&wgpu::TextureView; 2],
    size: (u32, u32),
) -> FrameStats {
    renderer.sync_with(|sinks| app.sync_meshes(sinks));
    renderer.classes = app.surface_classes();
    let lines = app.overlay_lines();
    renderer.render(
        &FrameInput {
            views: cameras,
            lines: &lines,
            hud: &[],
        },
        &[
            OutputTarget {
                view: targets[0],
                size,
                content: OutputContent::LeftEye,
            },
            OutputTarget {
                view: targets[1],
                size,
                content: OutputContent::RightEye,
            },
        ],
    )
}

/// Copies a swapchain texture back to the CPU as RGBA, then returns it to the colour
/// attachment layout the runtime expects at release.
pub(super) fn read_back(gpu: &Gpu, texture: &wgpu::Texture) -> VrResult<image::RgbaImage> {
    let (width, height) = (texture.width(), texture.height());
    let row = (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("xr capture"),
        size: u64::from(row) * u64::from(height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(height),
            },
        },
        texture.size(),
    );
    // An empty pass that loads and stores: back to the colour attachment layout.
    let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
    drop(encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("xr capture: back to colour attachment"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            },
        })],
        ..Default::default()
    }));
    gpu.queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| hal_err("reading the swapchain image")(Box::new(e)))?;
    rx.recv()
        .map_err(|e| hal_err("reading the swapchain image")(Box::new(e)))?
        .map_err(|e| hal_err("reading the swapchain image")(Box::new(e)))?;
    let bgra = matches!(
        texture.format(),
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let data = slice
        .get_mapped_range()
        .map_err(|e| hal_err("reading the swapchain image")(Box::new(e)))?;
    let mut img = image::RgbaImage::new(width, height);
    for y in 0..height {
        let start = (y * row) as usize;
        let line = &data[start..start + (width * 4) as usize];
        for (x, px) in line.chunks_exact(4).enumerate() {
            let rgba = if bgra {
                [px[2], px[1], px[0], px[3]]
            } else {
                [px[0], px[1], px[2], px[3]]
            };
            img.put_pixel(x as u32, y, image::Rgba(rgba));
        }
    }
    Ok(img)
}
