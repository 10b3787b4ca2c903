//! Reading frames back: offscreen rendering, colour images and the view depth.

use super::*;

impl Renderer {
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
pub(super) fn f16_to_f32(bits: u16) -> f32 {
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
