//! The one error type of the `vr-app` library.

use std::path::PathBuf;
use thiserror::Error;

mod cluster;

#[cfg(feature = "nats")]
pub use cluster::NatsFailure;
pub use cluster::{ClusterConfigError, ClusterError};

/// Everything that can go wrong in the display server's library parts.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum VrError {
    /// A screen definition is unusable.
    #[error("screen: {0}")]
    Screen(ScreenError),
    /// A projection could not be built (eye behind the screen, bad clip planes).
    #[error("projection: {0}")]
    Projection(ProjectionError),
    /// No GPU adapter was found.
    #[error(
        "no GPU adapter found ({0}). Install a Vulkan driver: on Debian/Ubuntu \
         `apt-get install mesa-vulkan-drivers libvulkan1` gives the lavapipe software \
         adapter; or install your GPU vendor's Vulkan driver"
    )]
    NoAdapter(AdapterError),
    /// The GPU device, a window or a readback failed.
    #[error("GPU: {0}")]
    Gpu(GpuError),
    /// The configuration is invalid.
    #[error("config: {0}")]
    Config(ConfigError),
    /// A configuration file was refused; `reason` says why.
    #[error("{}: {reason}", path.display())]
    ConfigFile {
        /// The file.
        path: PathBuf,
        /// Why it was refused.
        reason: Box<VrError>,
    },
    /// A study manifest (`--study`) could not be used, or a trial not recorded.
    #[error("study {}: {reason}", path.display())]
    Study {
        /// The manifest or the session log.
        path: PathBuf,
        /// Why.
        reason: Box<sculpt_core::study::StudyError>,
    },
    /// A study trial could not be appended to its session log.
    #[error("study log {}: {reason}", path.display())]
    StudyLog {
        /// The session log.
        path: PathBuf,
        /// Why.
        reason: Box<sculpt_core::Error>,
    },
    /// A base scene could not be read as a document.
    #[error("scene {}: {reason}", path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// Why it was refused.
        reason: Box<sculpt_core::Error>,
    },
    /// A tracking input (pose log, simulator script) could not be used.
    #[error("{what}: {reason}")]
    Tracking {
        /// The file or setting involved.
        what: String,
        /// Why.
        reason: Box<tracking::TrackingError>,
    },
    /// A worker thread or runtime could not be started.
    #[error("starting the {what}")]
    Spawn {
        /// `playback thread` or `tracking runtime`.
        what: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The operation journal is unreadable or could not be written.
    #[error("journal {path}: {reason}")]
    Journal {
        /// The journal file.
        path: String,
        /// What went wrong.
        reason: JournalError,
    },
    /// An output file could not be written (a full disk; nothing new was left:
    /// `fsio` writes a temporary file, fsyncs and renames it), or an input was larger
    /// than its cap (checked before it was read).
    #[error(transparent)]
    File(#[from] fsio::FsError),
    /// The run lost data: the operator log stopped being written (a full disk), so
    /// it is not reported as written and the run does not end as a success.
    #[error("the run lost data: the operator log {path} could not be written ({reason})")]
    OperatorLogLost {
        /// The operator log.
        path: String,
        /// The write error.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// An image could not be encoded or decoded.
    #[error("image {path}")]
    Image {
        /// The file.
        path: String,
        /// What went wrong.
        #[source]
        source: image::ImageError,
    },
    /// An OpenXR problem (no runtime, session failure, bad view).
    #[error("OpenXR: {0}")]
    Xr(XrError),
    /// An error from the geometry core.
    #[error(transparent)]
    Core(#[from] sculpt_core::Error),
    /// A cluster problem (NATS connection, JetStream stream, barrier).
    #[error("cluster: {0}")]
    Cluster(#[from] ClusterError),
}

/// Why no GPU adapter could be used.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum AdapterError {
    /// `--adapter NAME` matched none of the adapters found.
    #[error("no adapter named like {want:?}; found {found:?}")]
    NotNamed {
        /// The name asked for.
        want: String,
        /// The adapters found.
        found: Vec<String>,
    },
    /// wgpu found no suitable adapter.
    #[error("{0}")]
    Request(wgpu::RequestAdapterError),
}

/// What failed on the GPU or in the window system.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GpuError {
    /// The adapter refused to open a device.
    #[error("cannot open a device on {adapter}: {cause}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        cause: wgpu::RequestDeviceError,
    },
    /// An offscreen image size is out of range.
    #[error(
        "image size {width}x{height} is out of range: each side 1 to {} and at most {} \
         pixels (3840x2160) per image, which bounds the memory a headless run takes; \
         give a smaller --size",
        crate::render::limits::MAX_OFFSCREEN_SIDE,
        crate::render::limits::MAX_OFFSCREEN_PIXELS
    )]
    OffscreenSize {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// Waiting for the GPU failed.
    #[error("waiting for the GPU: {0}")]
    Poll(wgpu::PollError),
    /// Mapping the readback buffer failed.
    #[error("readback: {0}")]
    Map(wgpu::BufferAsyncError),
    /// The mapping callback was dropped before it ran.
    #[error("readback: the mapping callback never ran")]
    MapLost,
    /// The mapped range could not be viewed.
    #[error("readback: {0}")]
    MapRange(wgpu::MapRangeError),
    /// The read-back pixels do not fill the image.
    #[error("readback size mismatch")]
    ReadbackSize,
    #[cfg(feature = "window")]
    /// No display server (X11, Wayland) to open windows on.
    #[error(
        "no display available ({0}). On a machine without a display run \
         `wandsculpt --headless` (add --demo for the built-in session)"
    )]
    NoDisplay(winit::error::EventLoopError),
    #[cfg(feature = "window")]
    /// The window event loop failed.
    #[error("window event loop: {0}")]
    EventLoop(winit::error::EventLoopError),
    #[cfg(feature = "window")]
    /// A window could not be opened.
    #[error("cannot open a window: {0}")]
    Window(winit::error::OsError),
    /// A window surface could not be created.
    #[error("cannot create a window surface: {0}")]
    Surface(wgpu::CreateSurfaceError),
    /// The window surface offers no texture format.
    #[error("the window surface supports no format")]
    NoSurfaceFormat,
    /// The adapter cannot present to the window surface.
    #[error("the window surface is not supported by the adapter")]
    SurfaceUnsupported,
}

/// What is wrong with a display-server configuration.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The TOML does not parse or does not follow the schema.
    #[error("{0}")]
    Toml(Box<toml::de::Error>),
    /// The playback speed is out of range.
    #[error("tracking.playback.speed must be in (0, 1000], got {0}")]
    PlaybackSpeed(f64),
    /// A `[tracking]` setting was refused by the tracking layer.
    #[error("{field}: {cause}")]
    Tracking {
        /// The setting (`tracking.wand`, `tracking.input`).
        field: &'static str,
        /// The tracking layer's reason.
        cause: Box<tracking::TrackingError>,
    },
    /// The wand is not a Flystick.
    #[error("tracking.wand: the live path needs a Flystick (wandN) as the wand, not {0}")]
    WandNotFlystick(tracking::DeviceId),
    /// The head is not a body.
    #[error("tracking.head: the head must be a body (bodyN), not {0}")]
    HeadNotBody(tracking::DeviceId),
    /// `[tracking]` has neither a source nor playback.
    #[error("tracking needs at least one [[tracking.input.source]] or a [tracking.playback]")]
    NoTrackingSource,
    /// The eye separation is out of range.
    #[error("stereo.ipd must be in [0, 0.2] m, got {0}")]
    Ipd(f64),
    /// The clip planes are not `0 < near < far`.
    #[error("stereo: need 0 < near < far")]
    ClipPlanes,
    /// The window size is out of range.
    #[error("display size {width}x{height} is outside 1..=16384")]
    DisplaySize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// The sample count is not 1, 2 or 4.
    #[error("render.msaa must be 1, 2 or 4, got {0}")]
    Msaa(u32),
    /// The fixed head position is not in front of the screen.
    #[error("head.position must be finite and in front of the screen")]
    HeadPosition,
    /// The `[interaction]` settings were refused by the sculpting layer.
    #[error("interaction: {0}")]
    Interaction(sculpt_core::Error),
    /// An unknown output mode name.
    #[error("unknown output mode {0:?} (expected dual, side-by-side, anaglyph or mono)")]
    OutputMode(String),
    /// An unknown material name.
    #[error("unknown material {0:?} (expected clay, stone or wood)")]
    Material(String),
}

/// What is wrong on the OpenXR path.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum XrError {
    /// A view's field of view is not a valid frustum (left, right, up, down in
    /// radians).
    #[error("invalid field of view {0:?} (left, right, up, down)")]
    Fov([f64; 4]),
    /// The clip planes are not `0 < near < far`.
    #[error("need 0 < near < far")]
    ClipPlanes,
    /// An eye or stage pose is not finite.
    #[error("eye pose is not finite")]
    EyePose,
    /// The OpenXR loader could not be loaded.
    #[cfg(feature = "openxr")]
    #[error("no loader: libopenxr_loader.so.1 did not load ({cause}); install libopenxr-loader1")]
    Loader {
        /// The loader's reason.
        cause: openxr::EntryError,
    },
    /// The loader found no usable runtime; `hint` says what is missing.
    #[cfg(feature = "openxr")]
    #[error("no runtime: {hint} ({cause})")]
    NoRuntime {
        /// What is missing (the runtime manifest named by `XR_RUNTIME_JSON`, or any
        /// active runtime).
        hint: String,
        /// The loader's result code.
        cause: openxr::sys::Result,
    },
    /// The runtime cannot share Vulkan images (`XR_KHR_vulkan_enable2`).
    #[cfg(feature = "openxr")]
    #[error("the OpenXR runtime {runtime} does not offer XR_KHR_vulkan_enable2")]
    NoVulkanEnable2 {
        /// The runtime's name.
        runtime: String,
    },
    /// The Vulkan loader could not be loaded.
    #[cfg(feature = "openxr")]
    #[error("no Vulkan loader: {0}")]
    VulkanLoader(#[source] ash::LoadingError),
    /// A Vulkan call made for the runtime failed; `what` names the step.
    #[cfg(feature = "openxr")]
    #[error("{what}: {cause}")]
    Vulkan {
        /// The step.
        what: &'static str,
        /// Vulkan's result.
        cause: ash::vk::Result,
    },
    /// The runtime's Vulkan version range excludes what wgpu can use.
    #[cfg(feature = "openxr")]
    #[error("the OpenXR runtime needs Vulkan {min} to {max}; this Vulkan offers {have}")]
    VulkanVersion {
        /// The runtime's minimum.
        min: String,
        /// The runtime's maximum.
        max: String,
        /// The instance's version.
        have: String,
    },
    /// wgpu could not adopt the runtime's Vulkan instance, device or images.
    #[cfg(feature = "openxr")]
    #[error("wgpu on the runtime's Vulkan device: {what}: {cause}")]
    Hal {
        /// The step.
        what: &'static str,
        /// wgpu's reason.
        #[source]
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A file of the headset session (pose log header, replay config) could not be
    /// encoded.
    #[error("encoding {what}: {cause}")]
    Encode {
        /// The file.
        what: &'static str,
        /// The encoder's reason.
        #[source]
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
    /// None of the swapchain formats the runtime offers is one the renderer draws.
    #[error("no usable swapchain format among {0:?} (VkFormat values)")]
    SwapchainFormat(Vec<i64>),
    /// A runtime call failed; `what` names the step.
    #[cfg(feature = "openxr")]
    #[error("{what}: {cause}")]
    Runtime {
        /// The step (`creating an instance`, `no head-mounted display is connected`).
        what: &'static str,
        /// The runtime's result code.
        cause: openxr::sys::Result,
    },
}

/// Why a screen definition is unusable.
#[derive(Debug, Error, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ScreenError {
    /// A corner is NaN or infinite.
    #[error("a corner is not finite")]
    CornerNotFinite,
    /// An edge is shorter than 0.1 mm.
    #[error("an edge is shorter than 0.1 mm")]
    EdgeTooShort,
    /// The lower and left edges are not perpendicular.
    #[error("the lower and left edges are not perpendicular")]
    NotRectangular,
}

/// Why a projection cannot be built.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ProjectionError {
    /// The eye position is NaN or infinite.
    #[error("eye position is not finite")]
    EyeNotFinite,
    /// The clip planes are not `0 < near < far`.
    #[error("need 0 < near < far, got {near} and {far}")]
    ClipPlanes {
        /// Near plane, metres.
        near: f64,
        /// Far plane, metres.
        far: f64,
    },
    /// The eye is too close to (or behind) the screen plane.
    #[error(
        "eye is {distance_m:.4} m in front of the screen plane; it must be at least {min_m} m in front"
    )]
    EyeTooClose {
        /// Distance in front of the plane, metres.
        distance_m: f64,
        /// The least allowed, metres.
        min_m: f64,
    },
}

/// Why the operation journal is unreadable or could not be written.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum JournalError {
    /// A line is longer than the cap.
    #[error("line {line} is longer than {max} bytes")]
    LineTooLong {
        /// 1-based line.
        line: usize,
        /// The cap.
        max: usize,
    },
    /// A line is not UTF-8.
    #[error("line {line} is not UTF-8")]
    NotUtf8 {
        /// 1-based line.
        line: usize,
    },
    /// A version 1 journal (targets named by position) was appended to before it was
    /// upgraded.
    #[error("a version {version} journal must be upgraded before it is appended to")]
    NotUpgraded {
        /// The file's version.
        version: u32,
    },
    /// The first line is not the journal header.
    #[error("not a wandsculpt journal (line 1 is {found:?})")]
    NotAJournal {
        /// The first line (truncated).
        found: String,
    },
    /// A line is not a journal entry.
    #[error("line {line}: {error}")]
    Entry {
        /// 1-based line.
        line: usize,
        /// The JSON error.
        error: sculpt_core::error::JsonError,
    },
    /// An entry's sequence number is out of order.
    #[error("line {line}: sequence {found} where {expected} was expected")]
    Sequence {
        /// 1-based line.
        line: usize,
        /// The sequence number read.
        found: u64,
        /// The one expected.
        expected: u64,
    },
    /// An entry could not be encoded.
    #[error("encoding an entry: {0}")]
    Encode(sculpt_core::error::JsonError),
    /// The journal names another document than this run's base scene. The file is
    /// left as it is.
    #[error(
        "belongs to another document (journal {found}, this run's base scene {expected}); \
         the file was left as it is: give the --scene it was recorded with, or another --out"
    )]
    OtherDocument {
        /// The document id in the journal's header.
        found: String,
        /// The id of this run's base scene.
        expected: String,
    },
    /// An entry names a target the base scene does not have: the journal was recorded
    /// on another document. The file is left as it is.
    #[error(
        "line {line} names target {target}, which this run's base scene does not have \
         ({targets} targets): the journal was recorded on another document; the file was \
         left as it is: give the --scene it was recorded with, or another --out"
    )]
    UnknownTarget {
        /// 1-based line.
        line: usize,
        /// The target as the entry names it (a position in a version 1 journal, an id
        /// in version 2).
        target: u64,
        /// The base scene's target count.
        targets: usize,
    },
    /// The last line is neither a whole line nor the start of one cut off by a crash
    /// (binary data, NUL bytes). The file is left as it is.
    #[error(
        "line {line}: {bytes} bytes that are not a journal line (nor one cut off by a crash); \
         the file was left as it is"
    )]
    Garbage {
        /// 1-based line.
        line: usize,
        /// Its length.
        bytes: usize,
    },
}

/// `Result` with [`VrError`].
pub type VrResult<T> = Result<T, VrError>;
