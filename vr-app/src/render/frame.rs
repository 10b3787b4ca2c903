//! One frame: the eye passes, the overlays and the composition into each output.

use super::*;

impl Renderer {
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
    pub(super) fn render_outputs(
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
        // The document's paint, sampled into its texture when it changed.
        let tint = self.document_store().tint().cloned();
        self.paint.prepare(&self.device, &self.queue, tint.as_ref());
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
                // The paint is the document's; the stroke preview has none.
                let painted = std::ptr::eq(store, self.document_store());
                pass.set_bind_group(2, self.paint.bind_group(painted), &[]);
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
}
