//! The one error type of the `vr-app` library.

use thiserror::Error;

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
        reason: JournalError,
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
    /// An OpenXR problem (no runtime, session failure).
    #[error("OpenXR: {0}")]
    Xr(String),
    /// An error from the geometry core.
    #[error(transparent)]
    Core(#[from] sculpt_core::Error),
    /// A cluster problem (NATS connection, JetStream stream, barrier).
    #[error("cluster: {0}")]
    Cluster(#[from] crate::cluster::ClusterError),
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
}

/// `Result` with [`VrError`].
pub type VrResult<T> = Result<T, VrError>;
