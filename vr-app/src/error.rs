//! The one error type of the `vr-app` library.
//!
//! This file holds [`VrError`]; the reasons its variants carry live in submodules by
//! subsystem (GPU, configuration, OpenXR, screen and projection, journal, cluster) and
//! are re-exported here. None of them uses this file or another app module, so the
//! error types are a leaf of the module graph.

use std::path::PathBuf;
use thiserror::Error;

mod cluster;
mod config;
mod gpu;
mod journal;
mod projection;
mod xr;

#[cfg(feature = "nats")]
pub use cluster::NatsFailure;
pub use cluster::{ClusterConfigError, ClusterError};
pub use config::ConfigError;
pub use gpu::{AdapterError, GpuError};
pub use journal::JournalError;
pub use projection::{ProjectionError, ScreenError};
pub use xr::XrError;

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
    /// A `--solid` model file (a JSON solid document or a `.vm` model) was refused.
    #[error("solid {}", path.display())]
    Solid {
        /// The model file.
        path: PathBuf,
        /// Why it was refused.
        #[source]
        reason: sculpt_core::solid::SolidError,
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

/// `Result` with [`VrError`].
pub type VrResult<T> = Result<T, VrError>;
