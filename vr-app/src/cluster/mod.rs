//! The CAVE cluster and shared sculpting over NATS JetStream (`wandsculpt --cluster`).
//!
//! Replication, as Vrui does it: every render node runs the same deterministic pipeline
//! (`FrameStage -> Interaction -> editor::apply`) on the same input, and the document
//! changes only through one ordered, durable operation log. Roles:
//! - **ingest** ([`ingest::run_ingest`]): reads the tracker as a display server does
//!   (the `[tracking]` sources) and publishes each raw DTrack2 frame it receives, with
//!   its receive time, on `<session>.tracking.<feed>` (core NATS);
//! - **node** ([`node::NodeLoop`], windowed or headless): subscribes to its feed, runs its own
//!   [`tracking::stage::FrameStage`] and interaction; an *owner* node publishes the
//!   edits its interaction proposes to the JetStream stream on `<session>.ops`; every
//!   node (the proposer too) applies the stream in order, so every document is
//!   byte-identical. A frame barrier ([`barrier::Barrier`]) on `<session>.barrier`
//!   holds each frame until every live node is ready (software swap lock).
//!
//! Subjects are namespaced by the session name (`[cluster] session`); nodes connect
//! with the user and password of `[cluster]`; the default server is loopback. See
//! `docs/cluster.md`.

pub mod barrier;
pub mod ingest;
pub mod node;
pub mod snapshot;
pub mod wand;

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::config::ScreenConfig;

/// Header: what a message is ([`KIND_FRAME`], [`KIND_EDIT`], [`KIND_END`]).
pub const HDR_KIND: &str = "Ws-Kind";
/// Header: the proposing node of an operation.
pub const HDR_OWNER: &str = "Ws-Owner";
/// Header: when the message was sent, Unix time in nanoseconds (for the latency
/// figures only; nothing depends on it).
pub const HDR_SENT: &str = "Ws-Sent-Unix-Ns";
/// Header: the ingest's receive time of a tracking frame (its hub clock, microseconds).
pub const HDR_RECEIVED: &str = "Ws-Receive-Us";
/// Header: when the ingest received a tracking frame, Unix time in nanoseconds (the
/// propagation figure only).
pub const HDR_RECEIVED_UNIX: &str = "Ws-Receive-Unix-Ns";
/// Header: `0` for a frame from a buttons-only source (no poses).
pub const HDR_POSE: &str = "Ws-Pose";
/// [`HDR_KIND`] of a tracking frame.
pub const KIND_FRAME: &str = "frame";
/// [`HDR_KIND`] of an operation.
pub const KIND_EDIT: &str = "edit";
/// [`HDR_KIND`] of an end marker: the feed's tracker is gone, or the owner's
/// session is over.
pub const KIND_END: &str = "end";

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
    #[error("connecting to {url}: {source}")]
    Connect {
        /// The server URL.
        url: String,
        /// The client's error.
        #[source]
        source: async_nats::ConnectError,
    },
    /// A JetStream or NATS request failed (stream, subscription, flush).
    #[error("JetStream {what}")]
    JetStream {
        /// What was asked: `stream`, `stream info`, `tracking subscription`, ...
        what: &'static str,
        /// The client's error.
        #[source]
        source: NatsFailure,
    },
    /// Publishing failed.
    #[error("publishing on {subject}")]
    Publish {
        /// The subject.
        subject: String,
        /// The client's error.
        #[source]
        source: NatsFailure,
    },
    /// An operation was not acknowledged by JetStream in time.
    #[error("operation not committed within {0:?} (is the NATS server up?)")]
    CommitTimeout(Duration),
    /// The async runtime could not start.
    #[error("runtime: {0}")]
    Runtime(#[source] std::io::Error),
}

/// Why a NATS or JetStream request failed: the client's own error, kept as the source.
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
    #[error("user and password go together")]
    Credentials,
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

/// `[cluster]`: the NATS server, the session namespace and the nodes.
///
/// ```
/// let cfg = vr_app::config::Config::from_toml_str(r#"
/// [cluster]
/// session = "cave1"
/// user = "cave"
/// password = "secret"
/// [[cluster.node]]
/// name = "front"
/// owner = true
/// [cluster.node.screen]
/// lower_left = [-1.5, 0.0, -1.5]
/// lower_right = [1.5, 0.0, -1.5]
/// upper_left = [-1.5, 3.0, -1.5]
/// "#)?;
/// let c = cfg.cluster.unwrap();
/// assert_eq!(c.url, "nats://127.0.0.1:4222");
/// assert_eq!(c.subjects().ops, "cave1.ops");
/// # Ok::<(), vr_app::VrError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterSection {
    /// The NATS server (default loopback).
    pub url: String,
    /// NATS user name (with `password`).
    pub user: Option<String>,
    /// NATS password.
    pub password: Option<String>,
    /// The session: the prefix of every subject and the stream's name.
    pub session: String,
    /// Frame barrier: seconds to wait for a node before dropping it from the barrier.
    pub barrier_timeout: f64,
    /// Frame rate of a headless node's frame loop (frames per second); each frame
    /// passes the barrier. A windowed node's frames come at its display's rate.
    pub frame_rate: f64,
    /// Whether nodes hold each frame at the barrier.
    pub barrier: bool,
    /// Seconds an owner waits for JetStream to acknowledge an operation (retrying
    /// through a server restart) before giving up.
    pub commit_timeout: f64,
    /// Whether nodes load the session's latest document snapshot at start (and the
    /// snapshot writer writes them); off, a node replays the whole stream.
    pub snapshots: bool,
    /// The snapshot writer (the lowest-named live owner) writes a snapshot every this
    /// many stream positions, and once more when the session ends; 0: only at the end.
    pub snapshot_every: u64,
    /// Owners publish their wand's pose at most this often (per second) on
    /// `<session>.wand.<node>`, for the other nodes to draw.
    pub wand_rate: f64,
    /// An other sculptor's wand not heard of for this many seconds is no longer drawn.
    pub wand_stale: f64,
    /// The render nodes.
    #[serde(rename = "node")]
    pub nodes: Vec<NodeSection>,
}

impl Default for ClusterSection {
    fn default() -> Self {
        Self {
            url: "nats://127.0.0.1:4222".into(),
            user: None,
            password: None,
            session: "wandsculpt".into(),
            barrier_timeout: 0.5,
            frame_rate: 60.0,
            barrier: true,
            commit_timeout: 30.0,
            snapshots: true,
            snapshot_every: 500,
            wand_rate: 30.0,
            wand_stale: 1.0,
            nodes: Vec::new(),
        }
    }
}

/// `[[cluster.node]]`: one render node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSection {
    /// The node's name (`wandsculpt --cluster node --node NAME`).
    pub name: String,
    /// The tracking feed it follows (`<session>.tracking.<feed>`).
    #[serde(default = "default_feed")]
    pub feed: String,
    /// Whether its interaction proposes edits (the sculptor's node). Two owners on two
    /// feeds sculpt one document together.
    #[serde(default)]
    pub owner: bool,
    /// Its screen (the three corners), replacing `[screen]`.
    #[serde(default)]
    pub screen: Option<ScreenConfig>,
    /// Its session directory, replacing `[files] dir` (`--out` wins).
    #[serde(default)]
    pub out: Option<std::path::PathBuf>,
}

fn default_feed() -> String {
    "main".into()
}

/// The subjects and stream of a session.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Subjects {
    /// The JetStream stream holding the operations.
    pub stream: String,
    /// Operations (JetStream).
    pub ops: String,
    /// Frame barrier reports (core NATS).
    pub barrier: String,
    /// The JetStream object store bucket of the document snapshots.
    pub snapshots: String,
    /// Every owner's wand poses (core NATS), for a subscription.
    pub wands: String,
    prefix: String,
}

impl Subjects {
    /// The wand poses of owner `node` (core NATS).
    pub fn wand(&self, node: &str) -> String {
        format!("{}.wand.{node}", self.prefix)
    }

    /// Tracking frames of `feed` (core NATS).
    pub fn tracking(&self, feed: &str) -> String {
        format!("{}.tracking.{feed}", self.prefix)
    }
}

/// Names usable in a subject token and a stream name.
fn valid_token(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 64
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
}

impl ClusterSection {
    /// The session's subjects.
    pub fn subjects(&self) -> Subjects {
        Subjects {
            stream: format!("WS_{}", self.session),
            ops: format!("{}.ops", self.session),
            barrier: format!("{}.barrier", self.session),
            snapshots: format!("WS_{}_snap", self.session),
            wands: format!("{}.wand.*", self.session),
            prefix: self.session.clone(),
        }
    }

    /// Checks names and times.
    pub fn validate(&self) -> Result<(), ClusterError> {
        let bad = |e: ClusterConfigError| Err(ClusterError::Config(e));
        if !valid_token(&self.session) {
            return bad(ClusterConfigError::Session(self.session.clone()));
        }
        if self.user.is_some() != self.password.is_some() {
            return bad(ClusterConfigError::Credentials);
        }
        for (name, v) in [
            ("barrier_timeout", self.barrier_timeout),
            ("frame_rate", self.frame_rate),
            ("commit_timeout", self.commit_timeout),
            ("wand_rate", self.wand_rate),
            ("wand_stale", self.wand_stale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(ClusterConfigError::NotPositive { name, value: v });
            }
        }
        let mut names = std::collections::BTreeSet::new();
        for n in &self.nodes {
            if !valid_token(&n.name) || !valid_token(&n.feed) {
                return bad(ClusterConfigError::Name {
                    node: n.name.clone(),
                    feed: n.feed.clone(),
                });
            }
            if !names.insert(&n.name) {
                return bad(ClusterConfigError::Duplicate(n.name.clone()));
            }
        }
        Ok(())
    }

    /// The node called `name`.
    pub fn node(&self, name: &str) -> Result<&NodeSection, ClusterError> {
        self.nodes.iter().find(|n| n.name == name).ok_or_else(|| {
            ClusterError::Config(ClusterConfigError::UnknownNode {
                name: name.to_string(),
                have: self.nodes.iter().map(|n| n.name.clone()).collect(),
            })
        })
    }

    /// The owners' names: the nodes whose end markers close the session.
    pub fn owners(&self) -> Vec<String> {
        self.nodes
            .iter()
            .filter(|n| n.owner)
            .map(|n| n.name.clone())
            .collect()
    }

    /// Connects with the configured credentials. The client reconnects by itself
    /// after a server restart; the first connection is not retried, so a refused
    /// connection (bad credentials) is an error at once.
    pub async fn connect(&self, name: &str) -> Result<async_nats::Client, ClusterError> {
        let opts = match (&self.user, &self.password) {
            (Some(u), Some(p)) => {
                async_nats::ConnectOptions::with_user_and_password(u.clone(), p.clone())
            }
            _ => async_nats::ConnectOptions::new(),
        };
        opts.name(name)
            .connection_timeout(Duration::from_secs(5))
            .connect(self.url.as_str())
            .await
            .map_err(|source| ClusterError::Connect {
                url: self.url.clone(),
                source,
            })
    }
}

/// The one-worker tokio runtime a cluster role runs its NATS client on, its thread
/// named `thread`.
pub fn runtime(thread: &str) -> Result<tokio::runtime::Runtime, ClusterError> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .thread_name(thread)
        .build()
        .map_err(ClusterError::Runtime)
}

/// Nanoseconds since the Unix epoch (the latency figures' shared clock between
/// processes on one machine).
pub fn unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// Median and 99th percentile of samples (sorted in place), in the samples' unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Percentiles {
    /// Samples.
    pub n: usize,
    /// Median.
    pub median: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
}

impl Percentiles {
    /// Of `samples` (sorted here).
    pub fn of(samples: &mut [f64]) -> Self {
        samples.sort_by(f64::total_cmp);
        let at = |q: f64| {
            samples
                .get(((samples.len() as f64 - 1.0) * q).round() as usize)
                .copied()
                .unwrap_or_default()
        };
        Self {
            n: samples.len(),
            median: at(0.5),
            p99: at(0.99),
            max: samples.last().copied().unwrap_or_default(),
        }
    }
}

/// A header's value as text.
pub fn header<'a>(msg: &'a async_nats::Message, name: &str) -> Option<&'a str> {
    msg.headers.as_ref()?.get(name).map(|v| v.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sessions_and_node_names_must_be_subject_tokens() {
        let mut c = ClusterSection::default();
        assert!(c.validate().is_ok());
        c.session = "a.b".into();
        assert!(c.validate().is_err(), "a dot would split the namespace");
        c.session = "s1".into();
        c.user = Some("u".into());
        assert!(c.validate().is_err(), "a user without a password");
        c.password = Some("p".into());
        c.nodes.push(NodeSection {
            name: "left wall".into(),
            feed: "main".into(),
            owner: false,
            screen: None,
            out: None,
        });
        assert!(c.validate().is_err());
        c.nodes[0].name = "left".into();
        c.nodes.push(c.nodes[0].clone());
        assert!(c.validate().is_err(), "two nodes with one name");
        c.nodes.pop();
        assert!(c.validate().is_ok());
        assert_eq!(c.subjects().tracking("main"), "s1.tracking.main");
        assert_eq!(c.subjects().stream, "WS_s1");
        assert_eq!(c.subjects().snapshots, "WS_s1_snap");
        assert_eq!(c.subjects().wand("left"), "s1.wand.left");
        c.wand_rate = 0.0;
        assert!(c.validate().is_err());
    }

    #[test]
    fn percentiles_of_a_hundred_samples() {
        let mut v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        let p = Percentiles::of(&mut v);
        assert_eq!((p.n, p.median, p.p99, p.max), (100, 51.0, 99.0, 100.0));
        assert_eq!(Percentiles::of(&mut []).n, 0);
    }

    /// Regression (issue 14 §4): `Publish` and `JetStream` carried the client's error
    /// as a formatted string, so callers could not match on it and the chain was lost.
    #[test]
    fn publish_errors_keep_the_clients_error_as_their_source() {
        use std::error::Error as _;
        let e = ClusterError::Publish {
            subject: "s.ops".into(),
            source: NatsFailure::NoAck(Duration::from_secs(2)),
        };
        let source = e.source().expect("a source");
        assert!(matches!(
            source.downcast_ref::<NatsFailure>(),
            Some(NatsFailure::NoAck(d)) if *d == Duration::from_secs(2)
        ));
        assert_eq!(
            sculpt_core::error::Chain(&e).to_string(),
            "publishing on s.ops: no acknowledgement within 2s"
        );
    }
}
