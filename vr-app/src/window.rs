//! Windowed mode: desktop with the emulated wand, the built-in demo, and projector
//! outputs (`dual`: one fullscreen window per projector on the chosen monitors).
//!
//! The desktop keys and mouse ([`KEYS`], [`MOUSE`]) are one table, which also gives
//! the on-screen help (`F1`, `H` or `?`) and `wandsculpt --help` ([`key_help`]). In
//! desktop mode the right button orbits the view, the middle button (or Shift with the
//! right) pans it and Ctrl with the wheel zooms ([`DesktopView`](crate::desktop_view::DesktopView)).
//! The wand tip follows the surface under the pointer ([`crate::desktop_wand`]); the
//! plain wheel sets how high it hovers above it (or how deep it presses), and, when
//! sketching, moves the wand plane. A left press on a target other than the selected
//! one selects it first (a select command, as `Tab` gives).

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use sculpt_core::interaction::{Command, InteractionMode, Profile, WandEvent};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, TouchPhase, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::ModifiersState;
use winit::keyboard::{Key, NamedKey};
use winit::window::{Fullscreen, Window, WindowId};

use crate::app::AppState;
use crate::cluster::node::{NodeLoop, NodeReport};
use crate::error::{AdapterError, GpuError, VrError, VrResult};
use crate::feeder::Feeder;
use crate::headless::HeadlessOptions;
use crate::input::Input;
use crate::output::OutputMode;
use crate::render::{FrameInput, Gpu, OutputContent, OutputTarget, Renderer};
use crate::session::MouseOperator;

/// What a desktop key does.
#[derive(Debug, Clone, PartialEq)]
pub enum KeyAction {
    /// Switch to a mode.
    Mode(InteractionMode),
    /// Switch the groove profile.
    Profile(Profile),
    /// Tool width down by a factor 1.25.
    Narrower,
    /// Tool width up by a factor 1.25.
    Wider,
    /// Tool depth down by a factor 1.25.
    Shallower,
    /// Tool depth up by a factor 1.25.
    Deeper,
    /// Undo the last edit.
    Undo,
    /// Redo.
    Redo,
    /// Save the document.
    Save,
    /// Select the next target.
    NextTarget,
    /// Lattice mode: show or hide the cage.
    Cage,
    /// Show the first painted scalar as a heat map, or the painted colour again.
    HeatMap,
    /// Lattice mode: grab radius down by a factor 1.5.
    SmallerGroup,
    /// Lattice mode: grab radius up by a factor 1.5.
    LargerGroup,
    /// Toggle the wireframe.
    Wireframe,
    /// Toggle the UV quadtree overlay.
    Quadtree,
    /// Swap the eyes.
    SwapEyes,
    /// Next material (clay, stone, wood).
    Material,
    /// Back to the start view (frames the whole document).
    ResetView,
    /// Toggle the key help.
    Help,
    /// Study mode: start the next trial, or end the one being recorded.
    Trial,
    /// Quit (saving).
    Quit,
}

/// One desktop key: its name as `--help` shows it, the logical key (a character,
/// lower case, or a named key's winit name), whether Ctrl is held, and the action.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyBinding {
    /// As shown to people.
    pub label: &'static str,
    /// The logical key: a character (lower case) or a named key (`Tab`, `Escape`,
    /// `F1`, `Home`).
    pub key: &'static str,
    /// Ctrl held.
    pub ctrl: bool,
    /// What it does.
    pub action: KeyAction,
    /// What it does, for people.
    pub help: &'static str,
}

const fn bind(
    label: &'static str,
    key: &'static str,
    ctrl: bool,
    action: KeyAction,
    help: &'static str,
) -> KeyBinding {
    KeyBinding {
        label,
        key,
        ctrl,
        action,
        help,
    }
}

/// Every desktop key.
pub const KEYS: &[KeyBinding] = &[
    bind(
        "1",
        "1",
        false,
        KeyAction::Mode(InteractionMode::Sketch),
        "sketch mode",
    ),
    bind(
        "2",
        "2",
        false,
        KeyAction::Mode(InteractionMode::CARVE),
        "carve mode",
    ),
    bind(
        "3",
        "3",
        false,
        KeyAction::Mode(InteractionMode::EMBOSS),
        "emboss mode",
    ),
    bind(
        "4",
        "4",
        false,
        KeyAction::Mode(InteractionMode::Lattice),
        "lattice mode: drag a cage point to bend the targets",
    ),
    bind(
        "5",
        "5",
        false,
        KeyAction::Mode(InteractionMode::Paint),
        "paint mode: sweep over a target to paint it",
    ),
    bind(
        "T",
        "t",
        false,
        KeyAction::HeatMap,
        "heat map of the painted scalar (e.g. density) / painted colour",
    ),
    bind(
        "L",
        "l",
        false,
        KeyAction::Cage,
        "lattice cage shown / hidden",
    ),
    bind(
        ",",
        ",",
        false,
        KeyAction::SmallerGroup,
        "smaller lattice grab radius",
    ),
    bind(
        ".",
        ".",
        false,
        KeyAction::LargerGroup,
        "larger lattice grab radius",
    ),
    bind("V", "v", false, KeyAction::Profile(Profile::V), "V profile"),
    bind("U", "u", false, KeyAction::Profile(Profile::U), "U profile"),
    bind("[", "[", false, KeyAction::Narrower, "narrower tool"),
    bind("]", "]", false, KeyAction::Wider, "wider tool"),
    bind("-", "-", false, KeyAction::Shallower, "shallower tool"),
    bind("=", "=", false, KeyAction::Deeper, "deeper tool"),
    bind("+", "+", false, KeyAction::Deeper, "deeper tool"),
    bind("Ctrl+Z", "z", true, KeyAction::Undo, "undo"),
    bind("Ctrl+Y", "y", true, KeyAction::Redo, "redo"),
    bind("Ctrl+S", "s", true, KeyAction::Save, "save"),
    bind(
        "Tab",
        "Tab",
        false,
        KeyAction::NextTarget,
        "next target: the sheets, then the solids (--solid MODEL); the HUD names its kind",
    ),
    bind("W", "w", false, KeyAction::Wireframe, "wireframe on/off"),
    bind(
        "G",
        "g",
        false,
        KeyAction::Quadtree,
        "UV quadtree overlay on/off",
    ),
    bind("E", "e", false, KeyAction::SwapEyes, "swap eyes"),
    bind(
        "M",
        "m",
        false,
        KeyAction::Material,
        "next material (clay, stone, wood)",
    ),
    bind(
        "R",
        "r",
        false,
        KeyAction::ResetView,
        "reset the view (frame the document)",
    ),
    bind(
        "Home",
        "Home",
        false,
        KeyAction::ResetView,
        "reset the view",
    ),
    bind("F1", "F1", false, KeyAction::Help, "key help on/off"),
    bind("H", "h", false, KeyAction::Help, "key help on/off"),
    bind("?", "?", false, KeyAction::Help, "key help on/off"),
    bind(
        "Enter",
        "Enter",
        false,
        KeyAction::Trial,
        "study mode: start / end the trial",
    ),
    bind("Esc", "Escape", false, KeyAction::Quit, "quit (saves)"),
];

/// The mouse in desktop mode: (what, what it does).
pub const MOUSE: &[(&str, &str)] = &[
    (
        "move",
        "aim the wand: its tip follows the surface under the pointer",
    ),
    (
        "left button",
        "carve, emboss or sketch (a press selects the target under it); lattice: drag a cage point",
    ),
    (
        "wheel",
        "hover above / press into the surface (sketch: wand plane)",
    ),
    ("right drag", "orbit the view"),
    ("middle drag, Shift+right drag", "pan the view"),
    ("Ctrl+wheel", "zoom the view"),
];

/// The operator of a mouse button press (a `key` event, [`MouseOperator`]): the right
/// and middle buttons. The left button is the wand's action button, logged by the state
/// machine; the others do nothing and are no operator, as an unbound key is not.
pub fn mouse_button_operator(button: MouseButton, shift: bool) -> Option<MouseOperator> {
    match button {
        MouseButton::Right => Some(MouseOperator::Right { shift }),
        MouseButton::Middle => Some(MouseOperator::Middle),
        _ => None,
    }
}

/// The operator of a wheel event: each notch of a wheel (a line delta) is one, a
/// touchpad's smooth scroll (pixel deltas) one per gesture, at its start.
pub fn wheel_operator(
    delta: &MouseScrollDelta,
    phase: TouchPhase,
    ctrl: bool,
) -> Option<MouseOperator> {
    match (delta, phase) {
        (MouseScrollDelta::LineDelta(..), _) | (_, TouchPhase::Started) => {
            Some(MouseOperator::Wheel { ctrl })
        }
        _ => None,
    }
}

/// The action of `key` (a character or a named key, as in [`KeyBinding::key`]) with
/// Ctrl held or not.
pub fn key_action(key: &str, ctrl: bool) -> Option<KeyAction> {
    key_binding(key, ctrl).map(|b| b.action.clone())
}

/// The binding of `key` with Ctrl held or not (see [`key_action`]).
pub fn key_binding(key: &str, ctrl: bool) -> Option<&'static KeyBinding> {
    let key = if key.chars().count() == 1 {
        key.to_lowercase()
    } else {
        key.to_string()
    };
    KEYS.iter().find(|b| b.key == key && b.ctrl == ctrl)
}

/// Whether a key press is an operator of the task, logged as a `key` event (K):
/// every key but quitting and the study's trial key (the protocol's start and end
/// signal, not part of the task).
pub fn key_is_operator(action: &KeyAction) -> bool {
    !matches!(action, KeyAction::Quit | KeyAction::Trial)
}

/// The help lines: every key and mouse action, one per line (shown on screen and in
/// `wandsculpt --help`). Keys with the same action share a line.
pub fn key_help() -> Vec<String> {
    let mut lines: Vec<(String, KeyAction, &str)> = Vec::new();
    for b in KEYS {
        match lines.iter_mut().find(|(_, action, _)| *action == b.action) {
            Some((label, ..)) => {
                label.push(' ');
                label.push_str(b.label);
            }
            None => lines.push((b.label.to_string(), b.action.clone(), b.help)),
        }
    }
    let width = lines
        .iter()
        .map(|(l, ..)| l.len())
        .chain(MOUSE.iter().map(|(m, _)| m.len()))
        .max()
        .unwrap_or(0);
    lines
        .iter()
        .map(|(l, _, h)| format!("{l:width$}  {h}"))
        .chain(MOUSE.iter().map(|(m, h)| format!("{m:width$}  {h}")))
        .collect()
}

/// What a mouse drag does to the view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drag {
    Orbit,
    Pan,
}

/// Where wand input comes from in windowed mode.
pub enum WindowInput {
    /// The mouse drives the emulated wand.
    Desktop,
    /// Scripted events, played in real time (the demo).
    Scripted(Vec<WandEvent>),
    /// Live raw inputs from a tracker, polled each frame and fed through the
    /// window's [`Feeder`].
    Live(Box<dyn FnMut(f64) -> Vec<Input>>),
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

struct WindowApp<'n> {
    app: AppState,
    input: WindowInput,
    /// A cluster render node: its feed and the stream drive the app (not `input`),
    /// and its frames present through the swap lock.
    node: Option<&'n mut NodeLoop>,
    scripted: VecDeque<WandEvent>,
    /// Raw inputs to wand events and edits, as every driver does it.
    feeder: Feeder,
    running: Option<Running>,
    error: Option<VrError>,
    start: Instant,
    last_frame: Instant,
    cursor: (f64, f64),
    buttons: u32,
    modifiers: ModifiersState,
    drag: Option<Drag>,
    help: bool,
    last_t: f64,
    /// Frames still to draw before exiting (`--frames`), if limited.
    frames_left: Option<u64>,
    /// The session is over (a cluster node's): exit after this frame.
    over: bool,
}

/// Opens the windows and runs until they close (or, with `frames`, until that many
/// frames were drawn).
pub fn run_windowed(app: AppState, input: WindowInput, frames: Option<u64>) -> VrResult<()> {
    let mut wa = WindowApp::new(app, input, None, frames)?;
    let result = wa.run();
    // A trial still being recorded ends with the session.
    if let Some(study) = &mut wa.app.study
        && let Err(e) = study.finish(&mut wa.app.session, None)
    {
        tracing::error!("{e}");
    }
    // Never lose work on a clean exit.
    wa.app.session.autosave()?;
    result?;
    // Sculpting went on after a failed operator-log write; the run still lost data.
    match wa.app.session.oplog_failure() {
        None => Ok(()),
        Some(reason) => Err(VrError::OperatorLogLost {
            path: wa
                .app
                .session
                .dir()
                .join(crate::session::OPLOG_FILE)
                .display()
                .to_string(),
            reason: reason.to_string(),
        }),
    }
}

/// A cluster render node in a window (its screen's projector or monitor): each frame
/// runs the node's turn ([`NodeLoop::step`]), draws, then waits at the frame barrier
/// ([`NodeLoop::swap_lock`]) and only then presents, so the nodes of a CAVE show frame
/// N together. Runs until the session is over for the node (or its window closes),
/// then writes the document and the screen's pictures as a headless node does.
pub fn run_windowed_node(
    app: AppState,
    mut node: NodeLoop,
    pictures: &HeadlessOptions,
) -> VrResult<NodeReport> {
    let mut wa = WindowApp::new(app, WindowInput::Desktop, Some(&mut node), None)?;
    wa.run()?;
    let WindowApp {
        mut app, running, ..
    } = wa;
    let gpu = match running {
        Some(run) => run.gpu,
        None => Gpu::headless()?,
    };
    let mut report = node.finish(&mut app, &gpu, pictures)?;
    report.windowed = true;
    Ok(report)
}

impl<'n> WindowApp<'n> {
    fn new(
        app: AppState,
        input: WindowInput,
        node: Option<&'n mut NodeLoop>,
        frames: Option<u64>,
    ) -> VrResult<Self> {
        let scripted = match &input {
            WindowInput::Scripted(ev) => ev.iter().cloned().collect(),
            _ => VecDeque::new(),
        };
        let feeder = Feeder::for_config(&app.config)?;
        Ok(Self {
            app,
            input,
            node,
            scripted,
            feeder,
            running: None,
            error: None,
            start: Instant::now(),
            last_frame: Instant::now(),
            cursor: (0.0, 0.0),
            buttons: 0,
            modifiers: ModifiersState::empty(),
            drag: None,
            help: false,
            last_t: 0.0,
            frames_left: frames,
            over: false,
        })
    }

    /// Feeds one raw input to the session through the feeder; an error is logged.
    fn feed(&mut self, input: &Input) {
        if let Err(e) = self.feeder.feed(input, &mut self.app) {
            tracing::error!("{e}");
        }
    }

    /// Runs the event loop until the windows close; the first error ends it.
    fn run(&mut self) -> VrResult<()> {
        let event_loop = EventLoop::new().map_err(|e| VrError::Gpu(GpuError::NoDisplay(e)))?;
        event_loop.set_control_flow(ControlFlow::Poll);
        event_loop
            .run_app(self)
            .map_err(|e| VrError::Gpu(GpuError::EventLoop(e)))?;
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

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
                .map_err(|e| VrError::Gpu(GpuError::Window(e)))?;
            windows.push((Arc::new(w), *content));
        }
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let mut surfaces = Vec::new();
        for (w, _) in &windows {
            surfaces.push(
                instance
                    .create_surface(w.clone())
                    .map_err(|e| VrError::Gpu(GpuError::Surface(e)))?,
            );
        }
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surfaces.first(),
            ..Default::default()
        }))
        .map_err(|e| VrError::NoAdapter(AdapterError::Request(e)))?;
        let gpu = Gpu::from_adapter(instance, adapter)?;
        tracing::info!(adapter = %gpu.describe(), "rendering");
        let caps = surfaces[0].get_capabilities(&gpu.adapter);
        // The composition writes linear light: an sRGB surface encodes it (the
        // renderer encodes by hand for any other format).
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or(VrError::Gpu(GpuError::NoSurfaceFormat))?;
        let mut outputs = Vec::new();
        for ((window, content), surface) in windows.into_iter().zip(surfaces) {
            let size = window.inner_size();
            let mut config = surface
                .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
                .ok_or(VrError::Gpu(GpuError::SurfaceUnsupported))?;
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
        let mut renderer = Renderer::with_samples(&gpu, format, self.app.config.render.msaa);
        renderer.wireframe = d.wireframe;
        renderer.swap_eyes = d.swap_eyes;
        renderer.set_material(self.app.config.render.material);
        tracing::info!(
            samples = renderer.sample_count(),
            material = renderer.material().name(),
            "renderer"
        );
        Ok(Running {
            gpu,
            renderer,
            outputs,
        })
    }

    /// The time of a command: live input runs on the tracker's clock; the others on
    /// this window's.
    fn command_time(&self) -> f64 {
        match self.input {
            _ if self.node.is_some() => self.app.session.time(),
            WindowInput::Live(_) => self.app.session.time(),
            _ => self.last_t,
        }
    }

    fn command(&mut self, c: Command) {
        let ev = WandEvent::command(self.command_time(), c);
        let done = match &mut self.node {
            // A cluster node's edits go through the stream.
            Some(node) => node.command(&mut self.app, &ev),
            None => self.feeder.feed(&Input::Wand(ev), &mut self.app).map(drop),
        };
        if let Err(e) = done {
            tracing::error!("{e}");
        }
    }

    fn key(&mut self, key: &Key, event_loop: &ActiveEventLoop) {
        let name = match key {
            Key::Named(NamedKey::Escape) => "Escape",
            Key::Named(NamedKey::Tab) => "Tab",
            Key::Named(NamedKey::F1) => "F1",
            Key::Named(NamedKey::Home) => "Home",
            Key::Named(NamedKey::Enter) => "Enter",
            Key::Character(s) => s.as_str(),
            _ => return,
        };
        let Some(binding) = key_binding(name, self.modifiers.control_key()) else {
            return;
        };
        let action = binding.action.clone();
        let t = self.command_time();
        if key_is_operator(&action) {
            // Every key of the task is an operator (K), logged before its command.
            self.feed(&Input::Key {
                t,
                key: binding.label.to_owned(),
            });
        }
        let tool = self.app.session.interaction.tool().clone();
        match action {
            KeyAction::Quit => event_loop.exit(),
            KeyAction::Trial => {
                if let Some(study) = &mut self.app.study
                    && let Err(e) = study.toggle(&mut self.app.session, t)
                {
                    tracing::error!("{e}");
                }
            }
            KeyAction::NextTarget => self.command(Command::SelectNextTarget),
            KeyAction::Undo => self.command(Command::Undo),
            KeyAction::Redo => self.command(Command::Redo),
            KeyAction::Save => self.command(Command::Save),
            KeyAction::Mode(mode) => self.command(Command::SetMode { mode }),
            KeyAction::Profile(profile) => self.command(Command::SetProfile { profile }),
            KeyAction::Narrower => self.command(Command::SetWidth {
                width: (tool.width / 1.25).max(0.002),
            }),
            KeyAction::Wider => self.command(Command::SetWidth {
                width: (tool.width * 1.25).min(0.2),
            }),
            KeyAction::Shallower => self.command(Command::SetDepth {
                depth: (tool.depth / 1.25).max(0.0005),
            }),
            KeyAction::Deeper => self.command(Command::SetDepth {
                depth: (tool.depth * 1.25).min(0.1),
            }),
            KeyAction::Cage => self.app.cage = !self.app.cage,
            KeyAction::HeatMap => self.app.toggle_heat_map(),
            KeyAction::SmallerGroup | KeyAction::LargerGroup => {
                let r = self.app.session.interaction.lattice_radius();
                let radius = if action == KeyAction::LargerGroup {
                    (r * 1.5).min(1.0)
                } else {
                    (r / 1.5).max(0.005)
                };
                self.command(Command::SetLatticeRadius { radius });
            }
            KeyAction::Wireframe => {
                if let Some(r) = &mut self.running {
                    r.renderer.wireframe = !r.renderer.wireframe;
                }
            }
            KeyAction::Quadtree => {
                self.app.config.display.quadtree = !self.app.config.display.quadtree;
            }
            KeyAction::SwapEyes => {
                if let Some(r) = &mut self.running {
                    r.renderer.swap_eyes = !r.renderer.swap_eyes;
                }
            }
            KeyAction::Material => {
                if let Some(r) = &mut self.running {
                    let next = r.renderer.material().next();
                    r.renderer.set_material(next);
                }
            }
            KeyAction::ResetView => self.app.reset_view(),
            KeyAction::Help => self.help = !self.help,
        }
    }

    fn window_size(&self) -> (u32, u32) {
        self.running
            .as_ref()
            .and_then(|r| r.outputs.first())
            .map(|o| (o.config.width, o.config.height))
            .unwrap_or((1, 1))
    }

    fn cursor_moved(&mut self, to: (f64, f64)) {
        let (dx, dy) = (to.0 - self.cursor.0, to.1 - self.cursor.1);
        self.cursor = to;
        let size = self.window_size();
        match (self.drag, &mut self.app.view) {
            (Some(Drag::Orbit), Some(view)) => view.orbit(dx, dy),
            (Some(Drag::Pan), Some(view)) => view.pan(dx, dy, size),
            _ => {}
        }
    }

    /// Desktop input: the wand sample of the pointer at `t` (window seconds).
    fn sample_pointer(&mut self, t: f64) {
        self.last_t = t;
        let size = self.window_size();
        let sample = self.app.desktop_sample(self.cursor, size, self.buttons);
        self.feed(&Input::Wand(WandEvent::sample(t, sample)));
    }

    /// Desktop input: a wand sample now, for a press or release of the wand's button,
    /// so that a stroke starts and ends where the button went down and up however
    /// slowly frames are drawn (between frames the pointer is sampled once a frame).
    fn sample_pointer_now(&mut self) {
        if self.node.is_none() && matches!(self.input, WindowInput::Desktop) {
            let t = self.start.elapsed().as_secs_f64().max(self.last_t);
            self.sample_pointer(t);
        }
    }

    fn feed_input(&mut self, t: f64) {
        self.last_t = t;
        if let Some(node) = &mut self.node {
            match node.step(&mut self.app) {
                Ok(over) => self.over |= over,
                Err(e) => {
                    self.error = Some(e);
                    self.over = true;
                }
            }
            return;
        }
        match &mut self.input {
            WindowInput::Desktop => self.sample_pointer(t),
            WindowInput::Scripted(_) => {
                while self.scripted.front().is_some_and(|e| e.t <= t) {
                    if let Some(ev) = self.scripted.pop_front() {
                        self.feed(&Input::Wand(ev));
                    }
                }
            }
            WindowInput::Live(poll) => {
                let inputs = poll(t);
                for input in &inputs {
                    self.feed(input);
                }
                // Live time is the tracker's (the frame stage's clock), not this one.
                return;
            }
        }
        self.feed(&Input::Tick(t));
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
        run.renderer.classes = self.app.surface_classes();
        let mut hud = if self.app.config.display.hud {
            let mut h = self.app.hud_lines();
            h.push(format!("{}  F1 keys", run.renderer.material().name()));
            h
        } else {
            Vec::new()
        };
        if self.help {
            hud.push(String::new());
            hud.extend(key_help());
        }
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
        // Software swap lock: a cluster node presents once every live node is ready.
        if let Some(node) = &mut self.node
            && let Err(e) = node.swap_lock()
        {
            self.error = Some(e);
            self.over = true;
        }
        for f in frames.into_iter().flatten() {
            run.gpu.queue.present(f);
        }
    }
}

impl ApplicationHandler for WindowApp<'_> {
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
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor_moved((position.x, position.y));
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let bit = match button {
                    MouseButton::Left => 1 << self.app.config.interaction.buttons.action,
                    _ => 0,
                };
                let drag = match button {
                    MouseButton::Right if self.modifiers.shift_key() => Some(Drag::Pan),
                    MouseButton::Right => Some(Drag::Orbit),
                    MouseButton::Middle => Some(Drag::Pan),
                    _ => None,
                };
                match state {
                    ElementState::Pressed => {
                        // Every button of the task is an operator (K), as the keys are.
                        if let Some(op) = mouse_button_operator(button, self.modifiers.shift_key())
                        {
                            let t = self.command_time();
                            self.app.session.mouse(t, op);
                        }
                        // The wand's button: aim now; on another target than the
                        // selected one, select it first; then press (desktop input).
                        let desktop =
                            self.node.is_none() && matches!(self.input, WindowInput::Desktop);
                        if bit != 0 && desktop {
                            self.sample_pointer_now();
                            if let Some(index) = self.app.pointer_target_to_select() {
                                self.command(Command::SelectTarget { index });
                            }
                        }
                        self.buttons |= bit;
                        if bit != 0 {
                            self.sample_pointer_now();
                        }
                        if drag.is_some() {
                            self.drag = drag;
                        }
                    }
                    ElementState::Released => {
                        self.buttons &= !bit;
                        if bit != 0 {
                            self.sample_pointer_now();
                        }
                        if drag.is_some() {
                            self.drag = None;
                        }
                    }
                }
            }
            WindowEvent::MouseWheel { delta, phase, .. } => {
                if let Some(op) = wheel_operator(&delta, phase, self.modifiers.control_key()) {
                    let t = self.command_time();
                    self.app.session.mouse(t, op);
                }
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                let follow = self.app.pointer_follows_surface();
                match &mut self.app.view {
                    Some(view) if self.modifiers.control_key() => view.zoom(lines),
                    _ => self.app.pointer.scroll(lines, follow),
                }
            }
            WindowEvent::ModifiersChanged(m) => self.modifiers = m.state(),
            // winit makes up a press (`is_synthetic`) for each key already held when the
            // window gains focus; that is no keystroke of the sculptor's. Regression: under
            // Xvfb the first key typed after focusing was logged twice.
            WindowEvent::KeyboardInput {
                event,
                is_synthetic: false,
                ..
            } if event.state == ElementState::Pressed => {
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
                    if self.over {
                        event_loop.exit();
                    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_maps_to_its_action_and_only_with_the_right_modifier() {
        for b in KEYS {
            assert_eq!(key_action(b.key, b.ctrl), Some(b.action.clone()), "{b:?}");
            if b.ctrl {
                assert_eq!(key_action(b.key, false), None, "{} needs Ctrl", b.label);
            }
        }
        // Letters work in either case; unknown keys do nothing.
        assert_eq!(key_action("M", false), Some(KeyAction::Material));
        assert_eq!(key_action("Z", true), Some(KeyAction::Undo));
        assert_eq!(key_action("g", false), Some(KeyAction::Quadtree));
        assert_eq!(key_action("q", false), None);
        assert_eq!(key_action("", false), None);
    }

    /// Issue 19: every button of the task is an operator; the left one is the wand's
    /// (logged by the state machine), a wheel notch is one, a smooth scroll one per
    /// gesture.
    #[test]
    fn mouse_buttons_and_the_wheel_are_operators_but_the_wands_button() {
        assert_eq!(mouse_button_operator(MouseButton::Left, false), None);
        assert_eq!(
            mouse_button_operator(MouseButton::Right, true),
            Some(MouseOperator::Right { shift: true })
        );
        assert_eq!(
            mouse_button_operator(MouseButton::Middle, false),
            Some(MouseOperator::Middle)
        );
        assert_eq!(mouse_button_operator(MouseButton::Back, false), None);
        let notch = MouseScrollDelta::LineDelta(0.0, 1.0);
        assert_eq!(
            wheel_operator(&notch, TouchPhase::Moved, true),
            Some(MouseOperator::Wheel { ctrl: true })
        );
        let pixels = MouseScrollDelta::PixelDelta(winit::dpi::PhysicalPosition::new(0.0, 3.0));
        assert_eq!(
            wheel_operator(&pixels, TouchPhase::Started, false),
            Some(MouseOperator::Wheel { ctrl: false })
        );
        assert_eq!(wheel_operator(&pixels, TouchPhase::Moved, false), None);
        assert_eq!(wheel_operator(&pixels, TouchPhase::Ended, false), None);
    }

    #[test]
    fn the_help_lists_every_key_and_mouse_action_once() {
        let help = key_help();
        let text = help.join("\n");
        for b in KEYS {
            let lines = help
                .iter()
                .filter(|l| l.split_whitespace().any(|w| w == b.label))
                .count();
            assert!(lines >= 1, "{} missing from\n{text}", b.label);
        }
        for (what, does) in MOUSE {
            assert!(text.contains(what) && text.contains(does), "{what}");
        }
        // Keys sharing an action share a line.
        let reset = help.iter().filter(|l| l.contains("reset the view")).count();
        assert_eq!(reset, 1, "{text}");
    }
}
