//! OpenXR runtime glue (feature `openxr`): `wandsculpt --xr`.
//!
//! * [`probe`] loads the OpenXR loader, creates an instance and asks for a
//!   head-mounted display; with no loader or runtime it fails with one line naming
//!   what is missing (the loader library, the manifest `XR_RUNTIME_JSON` names, or any
//!   active runtime).
//! * [`run_xr`] runs a headset session on Vulkan: the instance with
//!   `XR_KHR_vulkan_enable2`; the Vulkan instance and device created *through* the
//!   runtime (`xrCreateVulkanInstanceKHR` / `xrCreateVulkanDeviceKHR`) on the physical
//!   device it chooses, then adopted by wgpu through its Vulkan HAL
//!   (`wgpu::hal::vulkan::Instance::from_raw`, `Adapter::device_from_raw`,
//!   `Instance::create_adapter_from_hal`, `Adapter::create_device_from_hal`); one
//!   swapchain per eye whose images wgpu wraps (`create_texture_from_hal`), so the
//!   project's renderer draws straight into them; the frame loop
//!   (`xrWaitFrame` / `xrBeginFrame` / `xrEndFrame`) submitting one projection layer
//!   of two views, driven by the pure lifecycle [`crate::xr::state`]; the controllers
//!   through the action set of [`crate::xr::actions`] as tracker frames into the same
//!   [`FrameStage`](tracking::stage::FrameStage), edit loop, journal and operator log as a tracked wand, written to
//!   a pose log (`xr.poselog`, with `xr-replay.toml` for `replay --config`); a haptic
//!   pulse when a stroke is applied or refused;
//! * the depth layer (`XR_KHR_composition_layer_depth`) when the runtime offers it:
//!   a depth swapchain per eye drawn by [`DepthPass`] and chained to its projection
//!   view with the near and far of the eyes' projection ([`DepthLayer`]);
//! * the CPU time of each rendered frame by phase ([`FrameTimer`]), its median and
//!   99th percentile in the report.
//!
//! This module needs unsafe code: the HAL interop hands raw Vulkan handles between
//! the OpenXR runtime, ash and wgpu. Each `unsafe` block says what it relies on.
#![allow(unsafe_code)]

use std::path::PathBuf;
use std::time::{Duration, Instant};

use ash::vk::{self, Handle};
use glam::{DQuat, DVec3};
use openxr as xr;
use serde::Serialize;
use wgpu::hal;

use crate::app::AppState;
use crate::error::{VrError, VrResult, XrError};
use crate::input::TrackingState;
use crate::render::{FrameInput, FrameStats, Gpu, OutputContent, OutputTarget, Renderer};
use crate::scene::Views;
use crate::xr::actions::{self, ControllerState, PoseSource, ReferenceSpace, WandAction};
use crate::xr::depth::{DepthLayer, DepthPass, depth_swapchain_format};
use crate::xr::state::{ExitReason, Lifecycle, LifecycleEvent, SessionAction, SessionState};
use crate::xr::timing::{FramePhases, FrameTimer, XrFrameTiming};
use crate::xr::wand::XrWand;
use crate::xr::{XrFov, XrPose, swapchain_format, xr_views};

mod swapchain;
mod vulkan;

use swapchain::*;
use vulkan::*;

/// What the runtime reported.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct XrRuntimeInfo {
    /// Runtime name and version.
    pub runtime: String,
    /// The head-mounted display's system name.
    pub system: String,
    /// Whether the runtime offers Vulkan interop (`XR_KHR_vulkan_enable2`).
    pub vulkan: bool,
    /// Whether the runtime offers depth layers (`XR_KHR_composition_layer_depth`).
    pub depth: bool,
}

/// The environment variable naming the runtime's manifest.
pub const RUNTIME_ENV: &str = "XR_RUNTIME_JSON";

/// The view configuration: two views, one per eye.
const VIEW_TYPE: xr::ViewConfigurationType = xr::ViewConfigurationType::PRIMARY_STEREO;

/// Maps a failed runtime call at step `what` to [`XrError::Runtime`].
fn runtime(what: &'static str) -> impl Fn(xr::sys::Result) -> VrError {
    move |cause| VrError::Xr(XrError::Runtime { what, cause })
}

/// What is missing when the loader finds no runtime: the manifest `XR_RUNTIME_JSON`
/// names, or (with the variable unset) an active runtime.
pub fn missing_runtime(runtime_json: Option<&std::ffi::OsStr>) -> String {
    match runtime_json.filter(|p| !p.is_empty()) {
        Some(p) if !std::path::Path::new(p).exists() => format!(
            "{RUNTIME_ENV} names {}, which does not exist",
            std::path::Path::new(p).display()
        ),
        Some(p) => format!(
            "the runtime {RUNTIME_ENV} names ({}) did not load",
            std::path::Path::new(p).display()
        ),
        None => format!(
            "no active runtime (set {RUNTIME_ENV} to a runtime's manifest, e.g. Monado's \
             openxr_monado.json)"
        ),
    }
}

fn no_runtime(cause: xr::sys::Result) -> VrError {
    let hint = missing_runtime(std::env::var_os(RUNTIME_ENV).as_deref());
    VrError::Xr(XrError::NoRuntime { hint, cause })
}

fn load_entry() -> VrResult<xr::Entry> {
    // SAFETY: `Entry::load` dlopens the system OpenXR loader (libopenxr_loader.so.1),
    // which the OpenXR specification defines; it is kept loaded as long as the entry.
    unsafe { xr::Entry::load(&()) }.map_err(|cause| VrError::Xr(XrError::Loader { cause }))
}

fn app_info() -> xr::ApplicationInfo<'static> {
    xr::ApplicationInfo {
        application_name: "wandsculpt",
        application_version: 1,
        engine_name: "wandsculpt",
        engine_version: 1,
        api_version: xr::Version::new(1, 0, 0),
    }
}

/// Loads the OpenXR loader, creates an instance and finds a head-mounted display.
pub fn probe() -> VrResult<XrRuntimeInfo> {
    let entry = load_entry()?;
    let available = entry.enumerate_extensions().map_err(no_runtime)?;
    let instance = entry
        .create_instance(&app_info(), &xr::ExtensionSet::default(), &[], &())
        .map_err(no_runtime)?;
    let props = instance
        .properties()
        .map_err(runtime("runtime properties"))?;
    let system = instance
        .system(xr::FormFactor::HEAD_MOUNTED_DISPLAY)
        .map_err(runtime("no head-mounted display is connected"))?;
    let sys_props = instance
        .system_properties(system)
        .map_err(runtime("system properties"))?;
    Ok(XrRuntimeInfo {
        runtime: format!("{} {}", props.runtime_name, props.runtime_version),
        system: sys_props.system_name,
        vulkan: available.khr_vulkan_enable2,
        depth: available.khr_composition_layer_depth,
    })
}

/// Options of a headset session.
#[derive(Debug, Clone, PartialEq)]
pub struct XrOptions {
    /// Stop after rendering this many frames (asks the runtime to end the session).
    pub frames: Option<u64>,
    /// Which controller pose drives the wand.
    pub pose: PoseSource,
    /// Near and far clip planes (metres).
    pub near_far: (f64, f64),
    /// Read the last rendered left-eye swapchain image back into `xr-left.png`.
    pub capture: bool,
    /// Submit each eye's depth (`XR_KHR_composition_layer_depth`) when the runtime
    /// offers it.
    pub depth_layer: bool,
}

impl Default for XrOptions {
    fn default() -> Self {
        Self {
            frames: None,
            pose: PoseSource::Grip,
            near_far: (0.05, 100.0),
            capture: false,
            depth_layer: true,
        }
    }
}

/// What a headset session did.
#[derive(Debug, Clone, Serialize)]
pub struct XrReport {
    /// The runtime, system and extensions.
    pub runtime: XrRuntimeInfo,
    /// The wgpu adapter on the runtime's physical device.
    pub adapter: String,
    /// `stage` or `local`.
    pub reference_space: String,
    /// Swapchain image size per eye (pixels).
    pub eye_size: (u32, u32),
    /// The swapchain format (`VkFormat`).
    pub format: i64,
    /// The depth swapchains' format (`VkFormat`) when the depth layer is submitted.
    pub depth_format: Option<i64>,
    /// Frames waited for (`xrWaitFrame`).
    pub frames_waited: u64,
    /// Frames rendered and submitted with the projection layer.
    pub frames_rendered: u64,
    /// Controller frames fed to the frame stage (and written to the pose log).
    pub controller_frames: u64,
    /// Haptic pulses sent.
    pub haptic_pulses: u64,
    /// Operations in the journal at the end.
    pub operations: u64,
    /// Strokes in the document at the end.
    pub strokes: usize,
    /// Median CPU time per rendered frame, both eyes (from `xrBeginFrame` to
    /// `xrEndFrame`, without waiting for the swapchain image), microseconds
    /// (`timing.cpu.median_us`).
    pub frame_cpu_median_us: f64,
    /// Per-phase CPU time of the rendered frames: median, p99, max.
    pub timing: XrFrameTiming,
    /// Why the session ended: `requested` or `lost`.
    pub exit: String,
    /// The pose log written.
    pub pose_log: PathBuf,
    /// The captured left-eye image, if asked for.
    pub capture: Option<PathBuf>,
}

/// The action set and its actions.
struct Actions {
    set: xr::ActionSet,
    grip: xr::Action<xr::Posef>,
    aim: xr::Action<xr::Posef>,
    draw: xr::Action<f32>,
    mode: xr::Action<bool>,
    profile: xr::Action<bool>,
    undo: xr::Action<bool>,
    redo: xr::Action<bool>,
    next_target: xr::Action<bool>,
    lattice: xr::Action<bool>,
    paint: xr::Action<bool>,
    stick: xr::Action<xr::Vector2f>,
    haptic: xr::Action<xr::Haptic>,
}

impl Actions {
    fn new(instance: &xr::Instance) -> VrResult<Self> {
        let set = instance
            .create_action_set(actions::ACTION_SET, actions::ACTION_SET_LOCALIZED, 0)
            .map_err(runtime("creating the action set"))?;
        let err = runtime("creating an action");
        macro_rules! action {
            ($ty:ty, $a:expr) => {
                set.create_action::<$ty>($a.name(), $a.localized(), &[])
                    .map_err(&err)?
            };
        }
        Ok(Self {
            grip: action!(xr::Posef, WandAction::GripPose),
            aim: action!(xr::Posef, WandAction::AimPose),
            draw: action!(f32, WandAction::Draw),
            mode: action!(bool, WandAction::Mode),
            profile: action!(bool, WandAction::Profile),
            undo: action!(bool, WandAction::Undo),
            redo: action!(bool, WandAction::Redo),
            next_target: action!(bool, WandAction::NextTarget),
            lattice: action!(bool, WandAction::Lattice),
            paint: action!(bool, WandAction::Paint),
            stick: action!(xr::Vector2f, WandAction::Thumbstick),
            haptic: action!(xr::Haptic, WandAction::Haptic),
            set,
        })
    }

    /// Suggests the bindings of every profile in [`actions::PROFILES`]; a profile the
    /// runtime refuses is logged and skipped. Returns how many were accepted.
    fn suggest(&self, instance: &xr::Instance) -> VrResult<usize> {
        let mut accepted = 0;
        for p in &actions::PROFILES {
            let mut bindings = Vec::with_capacity(p.bindings.len());
            for &(action, path) in p.bindings {
                let path = instance
                    .string_to_path(path)
                    .map_err(runtime("a binding path"))?;
                bindings.push(match action {
                    WandAction::GripPose => xr::Binding::new(&self.grip, path),
                    WandAction::AimPose => xr::Binding::new(&self.aim, path),
                    WandAction::Draw => xr::Binding::new(&self.draw, path),
                    WandAction::Mode => xr::Binding::new(&self.mode, path),
                    WandAction::Profile => xr::Binding::new(&self.profile, path),
                    WandAction::Undo => xr::Binding::new(&self.undo, path),
                    WandAction::Redo => xr::Binding::new(&self.redo, path),
                    WandAction::NextTarget => xr::Binding::new(&self.next_target, path),
                    WandAction::Lattice => xr::Binding::new(&self.lattice, path),
                    WandAction::Paint => xr::Binding::new(&self.paint, path),
                    WandAction::Thumbstick => xr::Binding::new(&self.stick, path),
                    WandAction::Haptic => xr::Binding::new(&self.haptic, path),
                });
            }
            let profile = instance
                .string_to_path(p.profile)
                .map_err(runtime("an interaction profile path"))?;
            match instance.suggest_interaction_profile_bindings(profile, &bindings) {
                Ok(()) => accepted += 1,
                Err(e) => tracing::warn!(profile = p.profile, "bindings refused: {e}"),
            }
        }
        Ok(accepted)
    }
}

fn pose(p: &xr::Posef) -> XrPose {
    XrPose {
        position: DVec3::new(
            f64::from(p.position.x),
            f64::from(p.position.y),
            f64::from(p.position.z),
        ),
        orientation: DQuat::from_xyzw(
            f64::from(p.orientation.x),
            f64::from(p.orientation.y),
            f64::from(p.orientation.z),
            f64::from(p.orientation.w),
        ),
    }
}

fn fov(f: &xr::Fovf) -> XrFov {
    XrFov {
        angle_left: f64::from(f.angle_left),
        angle_right: f64::from(f.angle_right),
        angle_up: f64::from(f.angle_up),
        angle_down: f64::from(f.angle_down),
    }
}

fn session_state(s: xr::SessionState) -> SessionState {
    match s {
        xr::SessionState::IDLE => SessionState::Idle,
        xr::SessionState::READY => SessionState::Ready,
        xr::SessionState::SYNCHRONIZED => SessionState::Synchronized,
        xr::SessionState::VISIBLE => SessionState::Visible,
        xr::SessionState::FOCUSED => SessionState::Focused,
        xr::SessionState::STOPPING => SessionState::Stopping,
        xr::SessionState::LOSS_PENDING => SessionState::LossPending,
        xr::SessionState::EXITING => SessionState::Exiting,
        _ => SessionState::Unknown,
    }
}

/// A located pose, if the runtime reports both position and orientation valid.
fn located(space: &xr::Space, base: &xr::Space, time: xr::Time) -> Option<XrPose> {
    let loc = space.locate(base, time).ok()?;
    let valid = xr::SpaceLocationFlags::POSITION_VALID | xr::SpaceLocationFlags::ORIENTATION_VALID;
    loc.location_flags.contains(valid).then(|| pose(&loc.pose))
}

/// The controller's state from the actions (after `xrSyncActions`), poses located
/// in `base` at `time`.
fn controller_state(
    acts: &Actions,
    session: &xr::Session<xr::Vulkan>,
    grip_space: &xr::Space,
    aim_space: &xr::Space,
    base: &xr::Space,
    time: xr::Time,
) -> ControllerState {
    let button = |a: &xr::Action<bool>| {
        a.state(session, xr::Path::NULL)
            .is_ok_and(|s| s.is_active && s.current_state)
    };
    let thumbstick = acts
        .stick
        .state(session, xr::Path::NULL)
        .ok()
        .filter(|s| s.is_active)
        .map_or([0.0; 2], |s| {
            [f64::from(s.current_state.x), f64::from(s.current_state.y)]
        });
    let trigger = acts
        .draw
        .state(session, xr::Path::NULL)
        .ok()
        .filter(|s| s.is_active)
        .map_or(0.0, |s| f64::from(s.current_state));
    ControllerState {
        grip: located(grip_space, base, time),
        aim: located(aim_space, base, time),
        trigger,
        mode: button(&acts.mode),
        profile: button(&acts.profile),
        undo: button(&acts.undo),
        redo: button(&acts.redo),
        next_target: button(&acts.next_target),
        lattice: button(&acts.lattice),
        paint: button(&acts.paint),
        thumbstick,
    }
}

/// Runs a headset session on `app` until the runtime ends it or `opts.frames` frames
/// were rendered (see the module docs).
pub fn run_xr(app: &mut AppState, opts: &XrOptions) -> VrResult<XrReport> {
    let entry = load_entry()?;
    let available = entry.enumerate_extensions().map_err(no_runtime)?;
    let mut wanted = xr::ExtensionSet::default();
    wanted.khr_vulkan_enable2 = available.khr_vulkan_enable2;
    wanted.khr_composition_layer_depth = available.khr_composition_layer_depth && opts.depth_layer;
    let instance = entry
        .create_instance(&app_info(), &wanted, &[], &())
        .map_err(no_runtime)?;
    let props = instance
        .properties()
        .map_err(runtime("runtime properties"))?;
    let runtime_name = format!("{} {}", props.runtime_name, props.runtime_version);
    if !available.khr_vulkan_enable2 {
        return Err(VrError::Xr(XrError::NoVulkanEnable2 {
            runtime: runtime_name,
        }));
    }
    let system = instance
        .system(xr::FormFactor::HEAD_MOUNTED_DISPLAY)
        .map_err(runtime("no head-mounted display is connected"))?;
    let sys_props = instance
        .system_properties(system)
        .map_err(runtime("system properties"))?;
    let info = XrRuntimeInfo {
        runtime: runtime_name,
        system: sys_props.system_name.clone(),
        vulkan: true,
        depth: available.khr_composition_layer_depth,
    };
    let blend = *instance
        .enumerate_environment_blend_modes(system, VIEW_TYPE)
        .map_err(runtime("environment blend modes"))?
        .first()
        .ok_or(VrError::Xr(XrError::Runtime {
            what: "no environment blend mode",
            cause: xr::sys::Result::ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED,
        }))?;

    // Declared before the session: dropped after it (OpenXR first, then Vulkan).
    let vulkan = create_vulkan(&instance, system)?;
    let gpu = &vulkan.gpu;
    tracing::info!(adapter = %gpu.describe(), runtime = %info.runtime, system = %info.system, "OpenXR session on Vulkan");

    // SAFETY: the handles are the instance, physical device and device the runtime
    // created (and chose) above, alive for as long as `vulkan`, which outlives the
    // session; queue 0 of `queue_family` is the queue wgpu submits to.
    let (session, mut waiter, mut stream) = unsafe {
        instance.create_session::<xr::Vulkan>(
            system,
            &xr::vulkan::SessionCreateInfo {
                instance: vulkan.raw_instance.as_raw() as _,
                physical_device: vulkan.physical_device.as_raw() as _,
                device: vulkan.raw_device.as_raw() as _,
                queue_family_index: vulkan.queue_family,
                queue_index: 0,
            },
        )
    }
    .map_err(runtime("creating the session"))?;

    let acts = Actions::new(&instance)?;
    let profiles = acts.suggest(&instance)?;
    tracing::info!(profiles, "suggested controller bindings");
    session
        .attach_action_sets(&[&acts.set])
        .map_err(runtime("attaching the action set"))?;
    let grip_space = acts
        .grip
        .create_space(&session, xr::Path::NULL, xr::Posef::IDENTITY)
        .map_err(runtime("the grip space"))?;
    let aim_space = acts
        .aim
        .create_space(&session, xr::Path::NULL, xr::Posef::IDENTITY)
        .map_err(runtime("the aim space"))?;
    let spaces = session
        .enumerate_reference_spaces()
        .map_err(runtime("reference spaces"))?;
    let (space_type, space_kind) = if spaces.contains(&xr::ReferenceSpaceType::STAGE) {
        (xr::ReferenceSpaceType::STAGE, ReferenceSpace::Stage)
    } else {
        (xr::ReferenceSpaceType::LOCAL, ReferenceSpace::Local)
    };
    let space = session
        .create_reference_space(space_type, xr::Posef::IDENTITY)
        .map_err(runtime("the reference space"))?;
    let centre = app.document_bounds().map_or(
        sculpt_core::editor::default_surface_point(0.0, 1.17),
        |(lo, hi)| (lo + hi) * 0.5,
    );
    let display_from_stage = actions::display_from_stage(space_kind, centre);

    let config_views = instance
        .enumerate_view_configuration_views(system, VIEW_TYPE)
        .map_err(runtime("view configuration"))?;
    let eye_size = config_views.first().map_or((0, 0), |v| {
        (
            v.recommended_image_rect_width,
            v.recommended_image_rect_height,
        )
    });
    let formats: Vec<i64> = session
        .enumerate_swapchain_formats()
        .map_err(runtime("swapchain formats"))?
        .into_iter()
        .map(i64::from)
        .collect();
    let format = swapchain_format(&formats)
        .ok_or_else(|| VrError::Xr(XrError::SwapchainFormat(formats.clone())))?;
    let mut eyes = [
        eye_swapchain(&session, &gpu.device, format, eye_size, ImageRole::Colour)?,
        eye_swapchain(&session, &gpu.device, format, eye_size, ImageRole::Colour)?,
    ];
    // The depth layer: a depth swapchain per eye, drawn by the depth pass.
    let layer = DepthLayer::new(opts.near_far.0, opts.near_far.1)?;
    let depth_format = depth_swapchain_format(&formats);
    if wanted.khr_composition_layer_depth && depth_format.is_none() {
        tracing::warn!(
            ?formats,
            "no depth swapchain format this renderer can draw: no depth layer"
        );
    }
    let mut depth = match depth_format.filter(|_| wanted.khr_composition_layer_depth) {
        Some(f) => Some(DepthSwapchains {
            format: f.0,
            eyes: [
                eye_swapchain(&session, &gpu.device, f, eye_size, ImageRole::Depth)?,
                eye_swapchain(&session, &gpu.device, f, eye_size, ImageRole::Depth)?,
            ],
            pass: DepthPass::new(&gpu.device, f.1),
        }),
        None => None,
    };
    let mut renderer = Renderer::with_samples(gpu, format.1, app.config.render.msaa);
    renderer.wireframe = app.config.display.wireframe;
    renderer.set_material(app.config.render.material);

    // The controllers as a tracked wand: pose log, replay config, frame stage.
    let dir = app.session.dir().to_path_buf();
    let mut wand = XrWand::create(
        &dir,
        &format!("{} / {}", info.runtime, info.system),
        &display_from_stage,
        app.config.interaction.buttons,
        opts.pose,
    )?;
    app.view = None;
    app.tracking = TrackingState::Lost;

    let mut lifecycle = Lifecycle::default();
    let mut events = xr::EventDataBuffer::new();
    let mut first_time: Option<i64> = None;
    let mut report = XrReport {
        runtime: info,
        adapter: gpu.describe(),
        reference_space: format!("{space_kind:?}").to_lowercase(),
        eye_size,
        format: format.0,
        depth_format: depth.as_ref().map(|d| d.format),
        frames_waited: 0,
        frames_rendered: 0,
        controller_frames: 0,
        haptic_pulses: 0,
        operations: 0,
        strokes: 0,
        frame_cpu_median_us: 0.0,
        timing: XrFrameTiming::default(),
        exit: String::new(),
        pose_log: wand.log_path().to_path_buf(),
        capture: None,
    };
    let mut timer = FrameTimer::default();
    let exit = 'frames: loop {
        // 1. Events: the lifecycle says what to do.
        let mut pending = Vec::new();
        while let Some(event) = instance
            .poll_event(&mut events)
            .map_err(runtime("polling events"))?
        {
            match event {
                xr::Event::SessionStateChanged(e) => {
                    tracing::info!(state = ?e.state(), "session state");
                    pending.push(LifecycleEvent::State(session_state(e.state())));
                }
                xr::Event::InstanceLossPending(_) => {
                    pending.push(LifecycleEvent::InstanceLossPending);
                }
                _ => {}
            }
        }
        let done = opts.frames.is_some_and(|n| report.frames_rendered >= n);
        if done {
            pending.push(LifecycleEvent::QuitRequested);
        }
        for event in pending {
            for action in lifecycle.handle(event) {
                match action {
                    SessionAction::BeginSession => {
                        session
                            .begin(VIEW_TYPE)
                            .map_err(runtime("xrBeginSession"))?;
                    }
                    SessionAction::EndSession => {
                        session.end().map_err(runtime("xrEndSession"))?;
                    }
                    SessionAction::RequestExit => match session.request_exit() {
                        Ok(()) | Err(xr::sys::Result::ERROR_SESSION_NOT_RUNNING) => {}
                        Err(e) => return Err(runtime("xrRequestExitSession")(e)),
                    },
                    SessionAction::Exit(reason) => break 'frames reason,
                }
            }
        }
        if !lifecycle.frame(true).wait {
            std::thread::sleep(Duration::from_millis(10));
            continue;
        }
        // 2. The frame.
        let wait_start = Instant::now();
        let state = waiter.wait().map_err(runtime("xrWaitFrame"))?;
        let begin_start = Instant::now();
        stream.begin().map_err(runtime("xrBeginFrame"))?;
        let render_start = Instant::now();
        report.frames_waited += 1;
        let time = state.predicted_display_time;
        let t0 = *first_time.get_or_insert(time.as_nanos());
        let t = Duration::from_nanos((time.as_nanos() - t0).max(0) as u64).as_secs_f64();
        let plan = lifecycle.frame(state.should_render);
        let mut head_in_stage = None;
        let mut views_in_stage = None;
        if plan.render {
            let (_, views) = session
                .locate_views(VIEW_TYPE, time, &space)
                .map_err(runtime("xrLocateViews"))?;
            if let [l, r] = views.as_slice() {
                let pair = [(pose(&l.pose), fov(&l.fov)), (pose(&r.pose), fov(&r.fov))];
                head_in_stage = Some(XrPose {
                    position: (pair[0].0.position + pair[1].0.position) * 0.5,
                    orientation: pair[0].0.orientation,
                });
                views_in_stage = Some((pair, [l.pose, r.pose], [l.fov, r.fov]));
            }
        }
        // 3. Controllers: a tracker frame through the stage into the session.
        if plan.read_input {
            session
                .sync_actions(&[(&acts.set).into()])
                .map_err(runtime("xrSyncActions"))?;
            let c = controller_state(&acts, &session, &grip_space, &aim_space, &space, time);
            if let Some(fb) = wand.step(app, t, &c, head_in_stage.as_ref())? {
                let v = fb.vibration();
                let vibration = xr::HapticVibration::new()
                    .amplitude(v.amplitude as f32)
                    .frequency(v.frequency_hz as f32)
                    .duration(xr::Duration::from_nanos(
                        Duration::try_from_secs_f64(v.duration_s)
                            .map_or(0, |d| d.as_nanos() as i64),
                    ));
                match acts
                    .haptic
                    .apply_feedback(&session, xr::Path::NULL, &vibration)
                {
                    Ok(()) => report.haptic_pulses += 1,
                    Err(e) => tracing::warn!("haptic pulse ({fb:?}): {e}"),
                }
            }
        }
        // 4. Render both eyes into the swapchains, or end the frame with no layers.
        let Some((pair, xr_poses, xr_fovs)) = views_in_stage.filter(|_| plan.render) else {
            stream
                .end(time, blend, &[])
                .map_err(runtime("xrEndFrame"))?;
            continue;
        };
        let cameras = xr_views(&pair, &display_from_stage, opts.near_far.0, opts.near_far.1)?;
        let mut waited = Duration::ZERO;
        let mut index = [0usize; 2];
        let mut depth_index = [0usize; 2];
        for (eye, sc) in eyes.iter_mut().enumerate() {
            let (i, w) = acquire(sc)?;
            index[eye] = i;
            waited += w;
        }
        if let Some(d) = &mut depth {
            for (eye, sc) in d.eyes.iter_mut().enumerate() {
                let (i, w) = acquire(sc)?;
                depth_index[eye] = i;
                waited += w;
            }
        }
        render_eyes(
            &mut renderer,
            app,
            &cameras,
            [&eyes[0].views[index[0]], &eyes[1].views[index[1]]],
            eye_size,
        );
        if let Some(d) = &depth {
            d.pass.draw(
                &gpu.queue,
                &renderer,
                &cameras,
                [
                    &d.eyes[0].views[depth_index[0]],
                    &d.eyes[1].views[depth_index[1]],
                ],
            );
        }
        let last = opts.frames.is_some_and(|n| report.frames_rendered + 1 >= n);
        let mut captured = Duration::ZERO;
        if opts.capture && last {
            let capture_start = Instant::now();
            let img = read_back(gpu, &eyes[0].textures[index[0]])?;
            let path = dir.join("xr-left.png");
            let mut png = std::io::Cursor::new(Vec::new());
            img.write_to(&mut png, image::ImageFormat::Png)
                .map_err(|source| VrError::Image {
                    path: path.display().to_string(),
                    source,
                })?;
            crate::session::write_atomic(&path, png.get_ref())?;
            report.capture = Some(path);
            captured = capture_start.elapsed();
        }
        for sc in eyes
            .iter_mut()
            .chain(depth.iter_mut().flat_map(|d| d.eyes.iter_mut()))
        {
            sc.handle
                .release_image()
                .map_err(runtime("xrReleaseSwapchainImage"))?;
        }
        let rect = xr::Rect2Di {
            offset: xr::Offset2Di { x: 0, y: 0 },
            extent: xr::Extent2Di {
                width: eye_size.0 as i32,
                height: eye_size.1 as i32,
            },
        };
        // Each view's depth, chained to it (`XrCompositionLayerDepthInfoKHR`); they
        // live until `xrEndFrame` returns.
        let depth_infos = depth.as_ref().map(|d| {
            [0, 1].map(|eye| xr::sys::CompositionLayerDepthInfoKHR {
                ty: xr::sys::CompositionLayerDepthInfoKHR::TYPE,
                next: std::ptr::null(),
                sub_image: xr::SwapchainSubImage::new()
                    .swapchain(&d.eyes[eye].handle)
                    .image_array_index(0)
                    .image_rect(rect)
                    .into_raw(),
                min_depth: layer.min_depth as f32,
                max_depth: layer.max_depth as f32,
                near_z: layer.near_z as f32,
                far_z: layer.far_z as f32,
            })
        });
        let projection_views = [0, 1].map(|eye| {
            let view = xr::CompositionLayerProjectionView::new()
                .pose(xr_poses[eye])
                .fov(xr_fovs[eye])
                .sub_image(
                    xr::SwapchainSubImage::new()
                        .swapchain(&eyes[eye].handle)
                        .image_array_index(0)
                        .image_rect(rect),
                );
            match &depth_infos {
                Some(infos) => {
                    let mut raw = view.into_raw();
                    raw.next = std::ptr::from_ref(&infos[eye]).cast();
                    // SAFETY: the chained depth info and the swapchains it names
                    // outlive the `xrEndFrame` call that reads them.
                    unsafe { xr::CompositionLayerProjectionView::from_raw(raw) }
                }
                None => view,
            }
        });
        let end_start = Instant::now();
        stream
            .end(
                time,
                blend,
                &[&xr::CompositionLayerProjection::new()
                    .space(&space)
                    .views(&projection_views)],
            )
            .map_err(runtime("xrEndFrame"))?;
        report.frames_rendered += 1;
        timer.push(FramePhases {
            wait: begin_start - wait_start,
            begin: render_start - begin_start,
            // The capture's read-back is not a frame's work.
            render: (end_start - render_start).saturating_sub(waited + captured),
            image_wait: waited,
            end: end_start.elapsed(),
        });
    };
    // Gestures still paused end, and the document is saved, as in any session.
    app.session.tick(wand.last_t() + 10.0)?;
    app.session.save_document()?;
    report.exit = match exit {
        ExitReason::Requested => "requested",
        ExitReason::Lost => "lost",
    }
    .into();
    report.controller_frames = wand.frames();
    report.operations = app.session.operations();
    report.strokes = app.session.doc.strokes().len();
    report.timing = timer.summary();
    report.frame_cpu_median_us = report.timing.cpu.median_us;
    // OpenXR objects go before the Vulkan device and instance they use.
    drop(depth);
    drop(eyes);
    drop((space, grip_space, aim_space, acts, stream, waiter, session));
    drop(renderer);
    drop(vulkan);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_runtime_manifest_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no-such-runtime.json");
        let hint = missing_runtime(Some(missing.as_os_str()));
        assert!(hint.contains("does not exist"), "{hint}");
        assert!(hint.contains("no-such-runtime.json"), "{hint}");
        let present = dir.path().join("runtime.json");
        std::fs::write(&present, "{}").unwrap();
        let hint = missing_runtime(Some(present.as_os_str()));
        assert!(hint.contains("did not load"), "{hint}");
        let hint = missing_runtime(None);
        assert!(hint.contains("no active runtime") && hint.contains(RUNTIME_ENV));
        assert_eq!(missing_runtime(Some(std::ffi::OsStr::new(""))), hint);
    }

    #[test]
    fn session_states_map_one_to_one() {
        let all = [
            (xr::SessionState::IDLE, SessionState::Idle),
            (xr::SessionState::READY, SessionState::Ready),
            (xr::SessionState::SYNCHRONIZED, SessionState::Synchronized),
            (xr::SessionState::VISIBLE, SessionState::Visible),
            (xr::SessionState::FOCUSED, SessionState::Focused),
            (xr::SessionState::STOPPING, SessionState::Stopping),
            (xr::SessionState::LOSS_PENDING, SessionState::LossPending),
            (xr::SessionState::EXITING, SessionState::Exiting),
            (xr::SessionState::UNKNOWN, SessionState::Unknown),
        ];
        for (raw, ours) in all {
            assert_eq!(session_state(raw), ours, "{raw:?}");
        }
    }

    /// Against a real runtime (for example Monado's simulated headset, named by
    /// `XR_RUNTIME_JSON`): renders a few frames of the default scene and checks the
    /// session ran and the image is the scene. No CI machine has a runtime, so it is
    /// ignored there and run by hand: `XR_RUNTIME_JSON=... cargo test -p vr-app
    /// --features openxr --lib -- --ignored real_runtime`. Without a runtime it fails.
    #[test]
    #[ignore = "needs an OpenXR runtime named by XR_RUNTIME_JSON"]
    fn a_real_runtime_renders_frames() {
        let json = std::env::var_os(RUNTIME_ENV)
            .filter(|p| std::path::Path::new(p).exists())
            .unwrap_or_else(|| panic!("{RUNTIME_ENV} names no runtime manifest"));
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = crate::config::Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let report = run_xr(
            &mut app,
            &XrOptions {
                frames: Some(30),
                capture: true,
                ..XrOptions::default()
            },
        )
        .unwrap_or_else(|e| panic!("runtime {}: {e}", std::path::Path::new(&json).display()));
        eprintln!("{}", serde_json::to_string_pretty(&report).unwrap());
        eprint!("{}", report.timing);
        assert!(report.frames_rendered >= 30, "{report:?}");
        assert_eq!(report.timing.frames as u64, report.frames_rendered);
        // A runtime that offers depth layers gets one (with a depth format we draw).
        assert_eq!(
            report.depth_format.is_some(),
            report.runtime.depth,
            "{report:?}"
        );
        let img = image::open(report.capture.unwrap()).unwrap().to_rgba8();
        let distinct: std::collections::BTreeSet<[u8; 4]> = img.pixels().map(|p| p.0).collect();
        assert!(
            distinct.len() > 16,
            "a scene, not a clear colour: {}",
            distinct.len()
        );
        assert!(dir.path().join(crate::xr::wand::POSE_LOG_FILE).exists());
    }

    /// Where Monado's remote driver listens, for the controller test below.
    const REMOTE_ENV: &str = "WANDSCULPT_XR_REMOTE";

    /// Controllers through a real runtime's action system: Monado with its remote driver
    /// (`crate::xr::monado_remote`; `P_OVERRIDE_ACTIVE_CONFIG=remote`), whose Valve Index
    /// controllers a TCP peer moves. The right controller draws a 24 cm stroke across the
    /// default sheet with the trigger held, pushes its thumbstick forward, then the left
    /// controller's A and B undo and redo. The session must hold exactly that: one stroke
    /// (with its haptic pulse), tool changes, undo then redo, in the operator log.
    /// Run by hand: `XR_RUNTIME_JSON=... WANDSCULPT_XR_REMOTE=127.0.0.1:4242
    /// P_OVERRIDE_ACTIVE_CONFIG=remote cargo test -p vr-app --features openxr --lib --
    /// --ignored real_runtimes_controllers`.
    #[test]
    #[ignore = "needs Monado's remote driver: XR_RUNTIME_JSON and WANDSCULPT_XR_REMOTE"]
    fn a_real_runtimes_controllers_carve_undo_and_redo() {
        use crate::xr::monado_remote::{self, Controller};
        let addr = std::env::var(REMOTE_ENV)
            .unwrap_or_else(|_| panic!("{REMOTE_ENV} names no remote driver (host:port)"));
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = crate::config::Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        // The default sheet's centre sits at chest height, REACH_M in front of the eyes.
        let (y, z) = (
            (actions::STANDING_EYE_HEIGHT_M - actions::BELOW_EYES_M) as f32,
            -actions::REACH_M as f32,
        );
        let driver = std::thread::spawn(move || {
            let mut stream = monado_remote::connect(&addr, std::time::Duration::from_secs(30))?;
            monado_remote::play(&mut stream, std::time::Duration::from_secs(7), |t| {
                let t = t - 2.0; // Two seconds for the session to start.
                let mut right = Controller {
                    position: [-0.12, y, z],
                    ..Controller::default()
                };
                if (0.0..1.5).contains(&t) {
                    right.position[0] = -0.12 + 0.24 * t / 1.5;
                    right.trigger = 1.0;
                } else if t >= 1.5 {
                    right.position[0] = 0.12;
                }
                if (2.0..2.5).contains(&t) {
                    right.thumbstick = [0.0, 1.0];
                }
                let left = Controller {
                    position: [-0.3, y - 0.15, z + 0.15],
                    a_click: (3.0..3.2).contains(&t),
                    b_click: (3.8..4.0).contains(&t),
                    ..Controller::default()
                };
                (left, right)
            })
        });
        // 900 frames outlast the script at up to 128 Hz.
        let report = run_xr(
            &mut app,
            &XrOptions {
                frames: Some(900),
                ..XrOptions::default()
            },
        )
        .unwrap_or_else(|e| panic!("the runtime: {e}"));
        driver
            .join()
            .unwrap()
            .expect("the remote driver took the script");
        eprintln!("{}", serde_json::to_string_pretty(&report).unwrap());
        assert_eq!(report.strokes, 1, "{report:?}");
        assert!(report.haptic_pulses >= 1, "{report:?}");
        let log = sculpt_core::oplog::decode_bytes(
            &std::fs::read(dir.path().join(crate::session::OPLOG_FILE)).unwrap(),
        )
        .unwrap();
        use sculpt_core::oplog::EventKind;
        let kinds: Vec<&str> = log
            .events
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::StrokeStart => Some("stroke_start"),
                EventKind::StrokeEnd => Some("stroke_end"),
                EventKind::Tool { .. } => Some("tool"),
                EventKind::Undo => Some("undo"),
                EventKind::Redo => Some("redo"),
                _ => None,
            })
            .collect();
        let mut distinct = kinds.clone();
        distinct.dedup();
        assert_eq!(
            distinct,
            ["stroke_start", "stroke_end", "tool", "undo", "redo"],
            "{kinds:?}"
        );
        assert!(dir.path().join(crate::xr::wand::POSE_LOG_FILE).exists());
    }

    /// Plain Vulkan, no runtime: the adapter `WANDSCULPT_ADAPTER` names, else the first.
    struct PlainVulkan;

    impl VulkanSource for PlainVulkan {
        fn check_version(&self, _api_version: u32) -> VrResult<()> {
            Ok(())
        }

        fn create_instance(
            &self,
            entry: &ash::Entry,
            info: &vk::InstanceCreateInfo<'_>,
        ) -> VrResult<vk::Instance> {
            // SAFETY: `info` is valid for the call.
            let instance =
                unsafe { entry.create_instance(info, None) }.map_err(vk_err("vkCreateInstance"))?;
            Ok(instance.handle())
        }

        fn physical_device(&self, instance: &ash::Instance) -> VrResult<vk::PhysicalDevice> {
            // SAFETY: queries on a live instance.
            let devices = unsafe { instance.enumerate_physical_devices() }
                .map_err(vk_err("vkEnumeratePhysicalDevices"))?;
            let want = std::env::var(crate::render::gpu::ADAPTER_ENV)
                .ok()
                .map(|s| s.to_lowercase());
            let named = |d: &vk::PhysicalDevice| {
                // SAFETY: `d` is a physical device of `instance`.
                let props = unsafe { instance.get_physical_device_properties(*d) };
                let name = props
                    .device_name_as_c_str()
                    .map(|n| n.to_string_lossy().to_lowercase())
                    .unwrap_or_default();
                want.as_ref().is_none_or(|w| name.contains(w.as_str()))
            };
            devices.into_iter().find(named).ok_or_else(|| {
                vk_err("no Vulkan physical device")(vk::Result::ERROR_INITIALIZATION_FAILED)
            })
        }

        fn create_device(
            &self,
            _entry: &ash::Entry,
            instance: &ash::Instance,
            physical_device: vk::PhysicalDevice,
            info: &vk::DeviceCreateInfo<'_>,
        ) -> VrResult<vk::Device> {
            // SAFETY: `info` is valid for the call; the device is of this instance.
            let device = unsafe { instance.create_device(physical_device, info, None) }
                .map_err(vk_err("vkCreateDevice"))?;
            Ok(device.handle())
        }
    }

    /// The Vulkan interop of `--xr` without a runtime: wgpu adopts a raw Vulkan
    /// instance and device, wraps images it does not own (stand-ins for swapchain
    /// images, in the colour attachment layout), and the project's renderer draws the
    /// two XR views of the default scene into them.
    #[test]
    fn wgpu_adopts_raw_vulkan_and_draws_both_eyes_into_images_it_does_not_own() {
        let vulkan =
            adopt_vulkan(&PlainVulkan).unwrap_or_else(|e| panic!("Vulkan (lavapipe): {e}"));
        let gpu = &vulkan.gpu;
        let size = (96, 64);
        let format = wgpu::TextureFormat::Rgba8UnormSrgb;
        let owners: Vec<wgpu::Texture> = (0..2)
            .map(|_| {
                gpu.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("owned elsewhere"),
                    size: wgpu::Extent3d {
                        width: size.0,
                        height: size.1,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                })
            })
            .collect();
        // Into the colour attachment layout, as a runtime hands its images out.
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        for t in &owners {
            let view = t.create_view(&Default::default());
            drop(encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            }));
        }
        gpu.queue.submit([encoder.finish()]);
        let wrapped: Vec<wgpu::Texture> = owners
            .iter()
            .map(|t| {
                // SAFETY: the handle stays owned by `t`, which outlives the wrapper.
                let raw = unsafe { t.as_hal::<hal::api::Vulkan>().unwrap().raw_handle() };
                wrap_image(&gpu.device, raw, format, size, ImageRole::Colour).unwrap()
            })
            .collect();
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
        let cameras = xr_views(
            &[(eye(-0.032), fov), (eye(0.032), fov)],
            &stage,
            0.05,
            100.0,
        )
        .unwrap();
        let mut renderer = Renderer::with_samples(gpu, format, app.config.render.msaa);
        let views: Vec<wgpu::TextureView> = wrapped
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let stats = render_eyes(
            &mut renderer,
            &mut app,
            &cameras,
            [&views[0], &views[1]],
            size,
        );
        assert!(stats.triangles > 0, "{stats:?}");
        let left = read_back(gpu, &wrapped[0]).unwrap();
        let right = read_back(gpu, &wrapped[1]).unwrap();
        for img in [&left, &right] {
            let distinct: std::collections::BTreeSet<[u8; 4]> = img.pixels().map(|p| p.0).collect();
            assert!(
                distinct.len() > 16,
                "the shaded sheet, not a clear colour: {}",
                distinct.len()
            );
        }
        assert_ne!(left, right, "two eyes, two pictures");
        // The owner's image holds what was drawn into the wrapper.
        assert_eq!(read_back(gpu, &owners[0]).unwrap(), left);
        drop(views);
        drop(wrapped);
    }
}
