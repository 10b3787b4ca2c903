//! Why a cluster role (`wandsculpt --cluster`, the `cluster` module) failed, and what
//! is wrong with a `[cluster]` section. The section is read and checked in every build
//! ([`crate::config::cluster`]); the variants that carry the NATS client's errors exist
//! with the `nats` feature only.

use std::time::Duration;

use thiserror::Error;

/// Why a cluster role failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ClusterError {
    /// The `[cluster]` section is missing or invalid.
    #[error("config: {0}")]
    Config(ClusterConfigError),
    /// An operation or barrier report could not be encoded.
    #[error("encoding {what}: {cause}")]
    Encode {
        /// `an operation` or `a barrier report`.
        what: &'static str,
        /// The JSON error.
        cause: serde_json::Error,
    },
    /// The NATS server could not be reached or refused the credentials.
    #[cfg(feature = "nats")]
    #[error("connecting to {url}: {source}")]
    Connect {
        /// The server URL.
        url: String,
        /// The client's error.
        #[source]
        source: async_nats::ConnectError,
    },
    /// A JetStream or NATS request failed (stream, subscription, flush).
    #[cfg(feature = "nats")]
    #[error("JetStream {what}")]
    JetStream {
        /// What was asked: `stream`, `stream info`, `tracking subscription`, ...
        what: &'static str,
        /// The client's error.
        #[source]
        source: NatsFailure,
    },
    /// Publishing failed.
    #[cfg(feature = "nats")]
    #[error("publishing on {subject}")]
    Publish {
        /// The subject.
        subject: String,
        /// The client's error.
        #[source]
        source: NatsFailure,
    },
    /// The server refused what this role published (its user may not publish there).
    #[error("the NATS server refused publishing on {subject}: {said}")]
    Refused {
        /// The subject.
        subject: String,
        /// What the server said.
        said: String,
    },
    /// An operation was not acknowledged by JetStream in time.
    #[error("operation not committed within {0:?} (is the NATS server up?)")]
    CommitTimeout(Duration),
    /// The async runtime could not start.
    #[error("runtime: {0}")]
    Runtime(#[source] std::io::Error),
}

/// Why a NATS or JetStream request failed: the client's own error, kept as the source.
#[cfg(feature = "nats")]
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum NatsFailure {
    /// Creating (or finding) the operation stream.
    #[error(transparent)]
    CreateStream(#[from] async_nats::jetstream::context::CreateStreamError),
    /// A JetStream request (stream info).
    #[error(transparent)]
    Request(#[from] async_nats::jetstream::context::RequestError),
    /// Subscribing to a subject.
    #[error(transparent)]
    Subscribe(#[from] async_nats::SubscribeError),
    /// Flushing the connection.
    #[error(transparent)]
    Flush(#[from] async_nats::client::FlushError),
    /// A core NATS publish.
    #[error(transparent)]
    Publish(#[from] async_nats::PublishError),
    /// A JetStream publish, or its acknowledgement.
    #[error(transparent)]
    JetStreamPublish(#[from] async_nats::jetstream::context::PublishError),
    /// Finding the operation stream.
    #[error(transparent)]
    GetStream(#[from] async_nats::jetstream::context::GetStreamError),
    /// JetStream did not acknowledge a publish in time.
    #[error("no acknowledgement within {0:?}")]
    NoAck(Duration),
    /// The task that follows the operation stream ended (its connection closed).
    #[error("the stream's consumer task ended")]
    ConsumerEnded,
}

/// What is wrong with the `[cluster]` section or a node's part of the config.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ClusterConfigError {
    /// `--cluster` without a `[cluster]` section.
    #[error("--cluster needs a [cluster] section")]
    NoSection,
    /// A node without `[tracking]` (the wand and head names of its feed).
    #[error("a node needs [tracking] (the wand and head names of its feed)")]
    NoTracking,
    /// The session name is not a subject token.
    #[error("session {0:?} must be 1..=64 of A-Z a-z 0-9 - _")]
    Session(String),
    /// Only one of user and password is given.
    #[error("{0}: user and password go together")]
    Credentials(String),
    /// An nkey and a user are both given.
    #[error("{0}: give an nkey or a user and password, not both")]
    NkeyAndUser(String),
    /// The nkey seed file could not be read.
    #[error("reading the nkey seed file {path}")]
    NkeyFile {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A time or rate is not positive.
    #[error("{name} must be positive, got {value}")]
    NotPositive {
        /// The key.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A node or feed name is not a subject token.
    #[error("node {node:?} feed {feed:?}: names must be 1..=64 of A-Z a-z 0-9 - _")]
    Name {
        /// The node's name.
        node: String,
        /// Its feed's name.
        feed: String,
    },
    /// Two nodes share a name.
    #[error("node {0:?} is named twice")]
    Duplicate(String),
    /// `--node NAME` names no `[[cluster.node]]`.
    #[error("no [[cluster.node]] named {name:?} (have {have:?})")]
    UnknownNode {
        /// The name asked for.
        name: String,
        /// The names configured.
        have: Vec<String>,
    },
}
