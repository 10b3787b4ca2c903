//! Windowed mode: desktop with the emulated wand, the built-in demo, and projector
//! outputs (`dual`: one fullscreen window per projector on the chosen monitors).
//!
//! Keys: `1` sketch, `2` carve, `3` emboss, `V`/`U` profile, `[`/`]` width,
//! `-`/`=` depth, `Ctrl+Z` undo, `Ctrl+Y` redo, `Tab` next target, `Ctrl+S` save,
//! `W` wireframe, `E` swap eyes, `Esc` quit. Mouse: move to aim the wand, scroll
//! to move the wand plane nearer or farther, left button to carve/emboss/sketch.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use sculpt_core::interaction::{Command, InteractionMode, Profile, WandEvent, WandSample};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Fullscreen, Window, WindowId};

use crate::app::AppState;
use crate::desktop_wand::EmulatedWand;
use crate::error::{VrError, VrResult};
use crate::output::OutputMode;
use crate::render::{FrameInput, Gpu, OutputContent, OutputTarget, Renderer};

/// Where wand input comes from in windowed mode.
pub enum WindowInput {
    /// The mouse drives the emulated wand.
    Desktop,
    /// Scripted events, played in real time (the demo).
    Scripted(Vec<WandEvent>),
    /// Live events from a tracker, polled each frame.
    Live(Box<dyn FnMut(f64) -> Vec<crate::input::Input>>),
}

impl std::fmt::Debug for WindowInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            WindowInput::Desktop => "Desktop",
            WindowInput::Scripted(_) => "Scripted",
            WindowInput::Live(_) => "Live",
        })
    }
}

struct Output {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    content: OutputContent,
}

struct Running {
    gpu: Gpu,
    renderer: Renderer,
    outputs: Vec<Output>,
}

struct WindowApp {
    app: AppState,
    input: WindowInput,
    scripted: VecDeque<WandEvent>,
    running: Option<Running>,
    error: Option<VrError>,
    start: Instant,
    last_frame: Instant,
    cursor: (f64, f64),
    buttons: u32,
    ctrl: bool,
    wand: EmulatedWand,
    last_t: f64,
    /// Frames still to draw before exiting (`--frames`), if limited.
    frames_left: Option<u64>,
}

/// Opens the windows and runs until they close (or, with `frames`, until that many
/// frames were drawn).
pub fn run_windowed(app: AppState, input: WindowInput, frames: Option<u64>) -> VrResult<()> {
    let event_loop = EventLoop::new().map_err(|e| {
        VrError::Gpu(format!(
            "no display available ({e}). On a machine without a display run \
             `wandsculpt --headless` (add --demo for the built-in session)"
        ))
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let scripted = match &input {
        WindowInput::Scripted(ev) => ev.iter().cloned().collect(),
        _ => VecDeque::new(),
    };
    let mut wa = WindowApp {
        app,
        input,
        scripted,
        running: None,
        error: None,
        start: Instant::now(),
        last_frame: Instant::now(),
        cursor: (0.0, 0.0),
        buttons: 0,
        ctrl: false,
        wand: EmulatedWand::default(),
        last_t: 0.0,
        frames_left: frames,
    };
    event_loop
        .run_app(&mut wa)
        .map_err(|e| VrError::Gpu(format!("window event loop: {e}")))?;
    // Never lose work on a clean exit.
    wa.app.session.autosave()?;
    match wa.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl WindowApp {
    fn create(&mut self, event_loop: &ActiveEventLoop) -> VrResult<Running> {
        let d = &self.app.config.display;
        let monitors: Vec<_> = event_loop.available_monitors().collect();
        let contents: Vec<OutputContent> = match d.mode {
            OutputMode::Dual => vec![OutputContent::LeftEye, OutputContent::RightEye],
            OutputMode::SideBySide => vec![OutputContent::SideBySide],
            OutputMode::Anaglyph => vec![OutputContent::Anaglyph],
            OutputMode::Mono => vec![OutputContent::Mono],
        };
        let mut windows = Vec::new();
        for (i, content) in contents.iter().enumerate() {
            let mut attrs = Window::default_attributes()
                .with_title(format!("wandsculpt ({content:?})"))
                .with_inner_size(PhysicalSize::new(d.width, d.height));
            if d.fullscreen {
                let monitor = d.monitors.get(i).and_then(|&m| monitors.get(m).cloned());
                if d.monitors.get(i).is_some() && monitor.is_none() {
                    tracing::warn!(
                        index = d.monitors[i],
                        available = monitors.len(),
                        "configured monitor not found; using the current one"
                    );
                }
                attrs = attrs.with_fullscreen(Some(Fullscreen::Borderless(monitor)));
            }
            let w = event_loop
                .create_window(attrs)
                .map_err(|e| VrError::Gpu(format!("cannot open a window: {e}")))?;
            windows.push((Arc::new(w), *content));
        }
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let mut surfaces = Vec::new();
        for (w, _) in &windows {
            surfaces.push(
                instance
                    .create_surface(w.clone())
                    .map_err(|e| VrError::Gpu(format!("cannot create a window surface: {e}")))?,
            );
        }
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surfaces.first(),
            ..Default::default()
        }))
        .map_err(|e| VrError::NoAdapter(e.to_string()))?;
        let gpu = Gpu::from_adapter(instance, adapter)?;
        tracing::info!(adapter = %gpu.describe(), "rendering");
        let caps = surfaces[0].get_capabilities(&gpu.adapter);
        // The shaders write display values directly: prefer a non-sRGB format.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| VrError::Gpu("the window surface supports no format".into()))?;
        let mut outputs = Vec::new();
        for ((window, content), surface) in windows.into_iter().zip(surfaces) {
            let size = window.inner_size();
            let mut config = surface
                .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
                .ok_or_else(|| {
                    VrError::Gpu("the window surface is not supported by the adapter".into())
                })?;
            config.format = format;
            config.present_mode = wgpu::PresentMode::AutoVsync;
            surface.configure(&gpu.device, &config);
            outputs.push(Output {
                window,
                surface,
                config,
                content,
            });
        }
        let mut renderer = Renderer::new(&gpu, format);
        renderer.wireframe = d.wireframe;
        renderer.swap_eyes = d.swap_eyes;
        Ok(Running {
            gpu,
            renderer,
            outputs,
        })
    }

    fn command(&mut self, c: Command) {
        // Live input runs on the tracker's clock; the others on this window's.
        let t = match self.input {
            WindowInput::Live(_) => self.app.session.time(),
            _ => self.last_t,
        };
        let ev = WandEvent::command(t, c);
        if let Err(e) = self.app.session.handle(&ev) {
            tracing::error!("{e}");
        }
    }

    fn key(&mut self, key: &Key, event_loop: &ActiveEventLoop) {
        let tool = self.app.session.interaction.tool().clone();
        match key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::Tab) => self.command(Command::SelectNextTarget),
            Key::Character(s) => match (s.to_lowercase().as_str(), self.ctrl) {
                ("z", true) => self.command(Command::Undo),
                ("y", true) => self.command(Command::Redo),
                ("s", true) => self.command(Command::Save),
                ("1", _) => self.command(Command::SetMode {
                    mode: InteractionMode::Sketch,
                }),
                ("2", _) => self.command(Command::SetMode {
                    mode: InteractionMode::CARVE,
                }),
                ("3", _) => self.command(Command::SetMode {
                    mode: InteractionMode::EMBOSS,
                }),
                ("v", _) => self.command(Command::SetProfile {
                    profile: Profile::V,
                }),
                ("u", _) => self.command(Command::SetProfile {
                    profile: Profile::U,
                }),
                ("[", _) => self.command(Command::SetWidth {
                    width: (tool.width / 1.25).max(0.002),
                }),
                ("]", _) => self.command(Command::SetWidth {
                    width: (tool.width * 1.25).min(0.2),
                }),
                ("-", _) => self.command(Command::SetDepth {
                    depth: (tool.depth / 1.25).max(0.0005),
                }),
                ("=", _) | ("+", _) => self.command(Command::SetDepth {
                    depth: (tool.depth * 1.25).min(0.1),
                }),
                ("w", _) => {
                    if let Some(r) = &mut self.running {
                        r.renderer.wireframe = !r.renderer.wireframe;
                    }
                }
                ("e", _) => {
                    if let Some(r) = &mut self.running {
                        r.renderer.swap_eyes = !r.renderer.swap_eyes;
                    }
                }
                _ => {}
            },
            _ => {}
        }
    }

    fn feed_input(&mut self, t: f64) {
        self.last_t = t;
        match &mut self.input {
            WindowInput::Desktop => {
                let size = self
                    .running
                    .as_ref()
                    .and_then(|r| r.outputs.first())
                    .map(|o| (o.config.width, o.config.height))
                    .unwrap_or((1, 1));
                let eye = self.app.head.position;
                let sample = match self.wand.tip(&self.app.screen, eye, self.cursor, size) {
                    Some(p) => WandSample::tracked(p, glam::DQuat::IDENTITY, self.buttons),
                    None => WandSample::lost(self.buttons),
                };
                if let Err(e) = self.app.session.handle(&WandEvent::sample(t, sample)) {
                    tracing::error!("{e}");
                }
            }
            WindowInput::Scripted(_) => {
                while self.scripted.front().is_some_and(|e| e.t <= t) {
                    if let Some(ev) = self.scripted.pop_front()
                        && let Err(e) = self.app.session.handle(&ev)
                    {
                        tracing::error!("{e}");
                    }
                }
            }
            WindowInput::Live(poll) => {
                for input in poll(t) {
                    match input {
                        crate::input::Input::Wand(ev) => {
                            if let Err(e) = self.app.session.handle(&ev) {
                                tracing::error!("{e}");
                            }
                        }
                        crate::input::Input::Head(h) => self.app.set_head(h),
                        crate::input::Input::Tracking(s) => self.app.tracking = s,
                        crate::input::Input::Tick(t) => {
                            if let Err(e) = self.app.session.tick(t) {
                                tracing::error!("{e}");
                            }
                        }
                    }
                }
                // Live time is the tracker's (the frame stage's clock), not this one.
                return;
            }
        }
        if let Err(e) = self.app.session.tick(t) {
            tracing::error!("{e}");
        }
    }

    fn redraw(&mut self) {
        let now = Instant::now();
        let t = now.duration_since(self.start).as_secs_f64();
        self.app
            .note_frame_time(now.duration_since(self.last_frame).as_secs_f64());
        self.last_frame = now;
        self.feed_input(t);
        let Some(run) = &mut self.running else { return };
        let app = &mut self.app;
        run.renderer.sync_with(|sinks| app.sync_meshes(sinks));
        let Ok(views) = self.app.views() else { return };
        let lines = self.app.overlay_lines();
        let hud = if self.app.config.display.hud {
            self.app.hud_lines()
        } else {
            Vec::new()
        };
        let mut frames = Vec::new();
        for o in &run.outputs {
            match o.surface.get_current_texture() {
                wgpu::CurrentSurfaceTexture::Success(tex)
                | wgpu::CurrentSurfaceTexture::Suboptimal(tex) => {
                    frames.push(Some(tex));
                }
                wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                    o.surface.configure(&run.gpu.device, &o.config);
                    frames.push(None);
                }
                _ => frames.push(None),
            }
        }
        let views_tex: Vec<Option<wgpu::TextureView>> = frames
            .iter()
            .map(|f| {
                f.as_ref()
                    .map(|f| f.texture.create_view(&Default::default()))
            })
            .collect();
        let targets: Vec<OutputTarget<'_>> = run
            .outputs
            .iter()
            .zip(&views_tex)
            .filter_map(|(o, v)| {
                v.as_ref().map(|view| OutputTarget {
                    view,
                    size: (o.config.width, o.config.height),
                    content: o.content,
                })
            })
            .collect();
        let stats = run.renderer.render(
            &FrameInput {
                views: &views,
                lines: &lines,
                hud: &hud,
            },
            &targets,
        );
        tracing::debug!(cpu_us = stats.cpu.as_micros() as u64, "frame");
        for f in frames.into_iter().flatten() {
            run.gpu.queue.present(f);
        }
    }
}

impl ApplicationHandler for WindowApp {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.create(event_loop) {
            Ok(r) => self.running = Some(r),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(run) = &mut self.running
                    && let Some(o) = run.outputs.iter_mut().find(|o| o.window.id() == id)
                {
                    o.config.width = size.width.max(1);
                    o.config.height = size.height.max(1);
                    o.surface.configure(&run.gpu.device, &o.config);
                }
            }
            WindowEvent::CursorMoved { position, .. } => self.cursor = (position.x, position.y),
            WindowEvent::MouseInput { state, button, .. } => {
                let bit = match button {
                    MouseButton::Left => 1 << self.app.config.interaction.buttons.action,
                    _ => 0,
                };
                match state {
                    ElementState::Pressed => self.buttons |= bit,
                    ElementState::Released => self.buttons &= !bit,
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.wand.scroll(lines);
            }
            WindowEvent::ModifiersChanged(m) => self.ctrl = m.state().control_key(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(&event.logical_key, event_loop);
            }
            WindowEvent::RedrawRequested => {
                let first = self
                    .running
                    .as_ref()
                    .and_then(|r| r.outputs.first())
                    .map(|o| o.window.id());
                if first == Some(id) {
                    self.redraw();
                    if let Some(n) = &mut self.frames_left {
                        *n = n.saturating_sub(1);
                        if *n == 0 {
                            tracing::info!("drew the requested frames; exiting");
                            event_loop.exit();
                        }
                    }
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(run) = &self.running
            && let Some(o) = run.outputs.first()
        {
            o.window.request_redraw();
        }
    }
}
