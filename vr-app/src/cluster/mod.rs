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
//! Subjects are namespaced by the session name (`[cluster] session`). Each role
//! connects with its own credentials ([`auth`]: a user per role, held to its subjects
//! by the server); an operation's owner is the last token of its subject, and nodes
//! refuse operations from an owner the config does not name. The default server is
//! loopback. See `docs/cluster.md`.

pub mod auth;
pub mod barrier;
pub mod ingest;
pub mod node;
pub mod snapshot;
pub mod wand;

use std::path::PathBuf;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::config::ScreenConfig;
use auth::Credentials;

/// Header: what a message is ([`KIND_FRAME`], [`KIND_EDIT`], [`KIND_END`]).
pub const HDR_KIND: &str = "Ws-Kind";
/// Header: the proposing node of an operation (it must be the owner its subject,
/// `<session>.ops.<owner>`, names; the subject decides).
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
        path: PathBuf,
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
/// assert_eq!(c.subjects().ops, "cave1.ops.*");
/// assert_eq!(c.subjects().op("front"), "cave1.ops.front");
/// # Ok::<(), vr_app::VrError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterSection {
    /// The NATS server (default loopback).
    pub url: String,
    /// NATS user name (with `password`): every role's credentials unless its own
    /// section or the command line gives others.
    pub user: Option<String>,
    /// NATS password.
    pub password: Option<String>,
    /// A file holding an nkey seed, instead of a user and password.
    pub nkey: Option<PathBuf>,
    /// `[cluster.ingest]`: the ingest's credentials.
    pub ingest: Credentials,
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
            nkey: None,
            ingest: Credentials::default(),
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
    /// This node's NATS user (with `password`), replacing `[cluster]`'s.
    #[serde(default)]
    pub user: Option<String>,
    /// This node's NATS password.
    #[serde(default)]
    pub password: Option<String>,
    /// This node's nkey seed file, replacing `[cluster]`'s credentials.
    #[serde(default)]
    pub nkey: Option<PathBuf>,
}

impl NodeSection {
    /// The credentials of this node's section (empty: `[cluster]`'s apply).
    pub fn credentials(&self) -> Credentials {
        Credentials {
            user: self.user.clone(),
            password: self.password.clone(),
            nkey: self.nkey.clone(),
        }
    }
}

fn default_feed() -> String {
    "main".into()
}

/// The subjects and stream of a session.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Subjects {
    /// The JetStream stream holding the operations.
    pub stream: String,
    /// Every owner's operations (JetStream): the stream's subject filter.
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
    /// The operations of owner `node` (JetStream): only its user may publish here.
    pub fn op(&self, node: &str) -> String {
        format!("{}.ops.{node}", self.prefix)
    }

    /// The owner an operation's subject names (`<session>.ops.<owner>`), if it is one.
    pub fn op_owner<'a>(&self, subject: &'a str) -> Option<&'a str> {
        subject
            .strip_prefix(self.prefix.as_str())?
            .strip_prefix(".ops.")
            .filter(|o| valid_token(o))
    }

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
            ops: format!("{}.ops.*", self.session),
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
        if let Err(e) = self
            .defaults()
            .validate("[cluster]")
            .and_then(|()| self.ingest.validate("[cluster.ingest]"))
        {
            return bad(e);
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
            if let Err(e) = n.credentials().validate(&format!("node {:?}", n.name)) {
                return bad(e);
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

    /// `[cluster]`'s own credentials (every role's, unless replaced).
    pub fn defaults(&self) -> Credentials {
        Credentials {
            user: self.user.clone(),
            password: self.password.clone(),
            nkey: self.nkey.clone(),
        }
    }

    /// The ingest's credentials: the command line's (`cli`), else `[cluster.ingest]`,
    /// else `[cluster]`'s; each place's are taken whole.
    pub fn ingest_credentials(&self, cli: &Credentials) -> Credentials {
        cli.clone().or(self.ingest.clone()).or(self.defaults())
    }

    /// Node `node`'s credentials: the command line's, else its `[[cluster.node]]`'s,
    /// else `[cluster]`'s.
    pub fn node_credentials(&self, node: &NodeSection, cli: &Credentials) -> Credentials {
        cli.clone().or(node.credentials()).or(self.defaults())
    }

    /// Connects with `credentials`. The client reconnects by itself after a server
    /// restart; the first connection is not retried, so a refused connection (bad
    /// credentials) is an error at once. What the server refuses later (a publish
    /// its permissions do not allow) is logged and noted in `refused`.
    pub async fn connect(
        &self,
        name: &str,
        credentials: &Credentials,
        refused: &ServerRefusals,
    ) -> Result<async_nats::Client, ClusterError> {
        credentials
            .validate("credentials")
            .map_err(ClusterError::Config)?;
        let noted = refused.clone();
        credentials
            .connect_options()?
            .name(name)
            .event_callback(move |event| {
                let noted = noted.clone();
                async move {
                    if let async_nats::Event::ServerError(e) = event {
                        // Said once: a refused publisher hears this for every message.
                        if noted.note(e.to_string()) == 1 {
                            tracing::warn!("the NATS server says: {e}");
                        }
                    }
                }
            })
            .connect(self.url.as_str())
            .await
            .map_err(|source| ClusterError::Connect {
                url: self.url.clone(),
                source,
            })
    }
}

/// The errors the server sent a connection after it was made (a permissions
/// violation: a publish its user may not make, which the server drops), shared with
/// the connection's event handler.
#[derive(Debug, Clone, Default)]
pub struct ServerRefusals(std::sync::Arc<std::sync::Mutex<Vec<String>>>);

impl ServerRefusals {
    /// Notes one error (the first 16 are kept); returns how many were noted so far.
    fn note(&self, e: String) -> usize {
        let Ok(mut v) = self.0.lock() else {
            return 0;
        };
        if v.len() < 16 {
            v.push(e);
        }
        v.len()
    }

    /// The first error the server sent, if any.
    pub fn first(&self) -> Option<String> {
        self.0.lock().ok()?.first().cloned()
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
            user: None,
            password: None,
            nkey: None,
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
        assert_eq!(c.subjects().op("left"), "s1.ops.left");
        let s = c.subjects();
        assert_eq!(s.op_owner("s1.ops.left"), Some("left"));
        assert_eq!(s.op_owner("s1.ops"), None);
        assert_eq!(s.op_owner("s2.ops.left"), None);
        assert_eq!(s.op_owner("s1.ops.a.b"), None);
        assert_eq!(s.op_owner("s1.barrier"), None);
        c.nodes[0].nkey = Some("/k".into());
        c.nodes[0].user = Some("u".into());
        c.nodes[0].password = Some("p".into());
        assert!(
            matches!(
                c.validate(),
                Err(ClusterError::Config(ClusterConfigError::NkeyAndUser(w))) if w.contains("left")
            ),
            "an nkey and a user on one node"
        );
        c.nodes[0].user = None;
        c.nodes[0].password = None;
        assert!(c.validate().is_ok());
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
