//! The one error type of the `replay` library.

use thiserror::Error;

/// Everything that can go wrong while importing, converting or replaying a session.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum Error {
    /// A serve endpoint is malformed, or could not be reached or bound.
    #[error("serve: {0}")]
    Endpoint(String),
    /// The tracking layer reported an error.
    #[error("tracking: {0}")]
    Tracking(String),
    /// The replay configuration is invalid.
    #[error("config: {0}")]
    Config(String),
    /// Rendering through vr-app's headless renderer failed (no adapter, bad size).
    #[error("render: {0}")]
    Render(String),
    /// A base scene or session could not be used.
    #[error("{0}")]
    Session(String),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
