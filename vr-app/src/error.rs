//! The one error type of the `vr-app` library.

use thiserror::Error;

/// Everything that can go wrong in the display server's library parts.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum VrError {
    /// A screen definition is unusable.
    #[error("screen: {0}")]
    Screen(String),
    /// A projection could not be built (eye behind the screen, bad clip planes).
    #[error("projection: {0}")]
    Projection(String),
    /// No GPU adapter was found.
    #[error(
        "no GPU adapter found ({0}). Install a Vulkan driver: on Debian/Ubuntu \
         `apt-get install mesa-vulkan-drivers libvulkan1` gives the lavapipe software \
         adapter; or install your GPU vendor's Vulkan driver"
    )]
    NoAdapter(String),
    /// The GPU device could not be created or failed.
    #[error("GPU: {0}")]
    Gpu(String),
    /// The configuration file is invalid.
    #[error("config: {0}")]
    Config(String),
    /// The operation journal is unreadable or could not be written.
    #[error("journal {path}: {reason}")]
    Journal {
        /// The journal file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// An image could not be encoded or decoded.
    #[error("image {path}: {reason}")]
    Image {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// An OpenXR problem (no runtime, session failure).
    #[error("OpenXR: {0}")]
    Xr(String),
    /// An error from the geometry core.
    #[error(transparent)]
    Core(#[from] sculpt_core::Error),
}

/// `Result` with [`VrError`].
pub type VrResult<T> = Result<T, VrError>;
