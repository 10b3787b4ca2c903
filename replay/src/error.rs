//! The one error type of the `replay` library, and the typed reasons it carries.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use thiserror::Error;

/// Everything that can go wrong while importing, converting or replaying a session.
///
/// A wrapped error (I/O, tracking, the display server, the sculpting layer) is the
/// [`std::error::Error::source`], not part of the message, so `{:#}` prints it once.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum Error {
    /// A serve endpoint or option is malformed, or no client connected.
    #[error("serve: {0}")]
    Endpoint(EndpointError),
    /// A serve socket could not be bound or set up.
    #[error("serve: {what} {addr}")]
    Socket {
        /// What was being done ("cannot listen on", "setting up").
        what: &'static str,
        /// The address.
        addr: SocketAddr,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The tracking layer reported an error.
    #[error(transparent)]
    Tracking(#[from] tracking::TrackingError),
    /// The replay configuration is invalid.
    #[error("config: {0}")]
    Config(ConfigError),
    /// A section of the configuration was refused by the tracking layer.
    #[error("config: {section}")]
    ConfigTracking {
        /// `[tracking]`, `calibration` or `filter`.
        section: &'static str,
        /// Why.
        #[source]
        source: tracking::TrackingError,
    },
    /// A section of a display server config was refused by the display server.
    #[error("config: {section}")]
    ConfigDisplay {
        /// The section (`[tracking]`).
        section: &'static str,
        /// Why.
        #[source]
        source: vr_app::VrError,
    },
    /// The solid target the session's header names was refused (issue 35).
    #[error("the session's solid target `{name}`")]
    SessionSolid {
        /// Its name in the header.
        name: String,
        /// Why.
        #[source]
        source: sculpt_core::Error,
    },
    /// The configured tool was refused by the sculpting layer.
    #[error("config: tool")]
    ConfigTool(#[source] sculpt_core::Error),
    /// The `[thumbstick]` settings (a headset session's tool changes) cannot work.
    #[error("config: thumbstick")]
    ConfigThumbstick(#[source] vr_app::xr::actions::ThumbstickError),
    /// The `[interaction]` settings were refused by the sculpting layer (the one
    /// validation `wandsculpt` uses too).
    #[error("config: interaction")]
    ConfigInteraction(#[source] sculpt_core::Error),
    /// The configuration file is neither layout (both reasons are given).
    #[error("config: neither a display server config ({display}) nor a replay config ({flat})")]
    ConfigUnrecognised {
        /// Why it is not a display server config.
        display: Box<vr_app::VrError>,
        /// Why it is not a replay config.
        flat: Box<toml::de::Error>,
    },
    /// The requested image size is out of range.
    #[error(
        "render: image size {width}x{height} is out of range: each side 1 to {} and at \
         most {} pixels (3840x2160) per image, which bounds the memory taken",
        vr_app::render::MAX_OFFSCREEN_SIDE,
        vr_app::render::MAX_OFFSCREEN_PIXELS
    )]
    ImageSize {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// Rendering through vr-app's headless renderer failed (no adapter, bad screen).
    #[error("render")]
    Render(#[source] vr_app::VrError),
    /// A rendered image could not be saved.
    #[error("render: {}", path.display())]
    SaveImage {
        /// The image file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: image::ImageError,
    },
    /// The sculpting layer failed to tessellate the final mesh (the scene was saved).
    #[error("the sculpting layer failed to tessellate the final mesh; {} was written", written.display())]
    Tessellation {
        /// The scene file already written.
        written: PathBuf,
    },
    /// A mesh or IGES output could not be encoded (a NaN or infinite number in it).
    #[error("encoding {file}")]
    Export {
        /// The output file's name.
        file: &'static str,
        /// Why.
        #[source]
        source: sculpt_core::Error,
    },
    /// An output could not be encoded as JSON.
    #[error("encoding JSON")]
    Encode(#[source] serde_json::Error),
    /// An output file could not be written (a full disk; nothing new was left:
    /// `fsio` writes temporary files, fsyncs and renames them), or an input was
    /// larger than its cap (checked before it was read).
    #[error(transparent)]
    File(#[from] fsio::FsError),
    /// A file could not be read or written.
    #[error("{path}")]
    Io {
        /// The file involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// Why a serve endpoint or option is unusable.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum EndpointError {
    /// The endpoint text is malformed.
    #[error("{text:?}: {why}")]
    Malformed {
        /// The text given.
        text: String,
        /// What is wrong.
        why: &'static str,
    },
    /// The speed is not finite or negative.
    #[error("speed must be finite and >= 0, got {speed}")]
    Speed {
        /// The speed given.
        speed: f64,
    },
    /// No client connected in time.
    #[error("no connection with {endpoint} within {timeout:?}")]
    NoConnection {
        /// The endpoint, as `Debug` shows it.
        endpoint: String,
        /// How long it waited.
        timeout: Duration,
    },
}

/// Why a replay setting is unusable; each names the setting.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ConfigError {
    /// A `--render` time is not a number.
    #[error("--render: `{text}` is not a number of seconds")]
    RenderTimeNotANumber {
        /// The text given.
        text: String,
    },
    /// A `--render` time is negative or not finite.
    #[error("--render: {t} must be >= 0 seconds")]
    RenderTimeNegative {
        /// The time.
        t: f64,
    },
    /// Too few or too many `--render` times.
    #[error("--render needs 1 to {max} times")]
    RenderTimeCount {
        /// The most allowed.
        max: usize,
    },
    /// The `--render-every` step is not positive.
    #[error("--render-every {step} must be > 0")]
    RenderStep {
        /// The step.
        step: f64,
    },
    /// `--render-every` would make too many images.
    #[error("--render-every {step}: {count} images, more than {max}")]
    RenderStepCount {
        /// The step.
        step: f64,
        /// Images it would make.
        count: usize,
        /// The most allowed.
        max: usize,
    },
}

/// `Result` with [`Error`](enum@Error).
pub type Result<T, E = Error> = std::result::Result<T, E>;
