//! Why no GPU adapter could be used, and what failed on the GPU or in the window
//! system.

use thiserror::Error;

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
