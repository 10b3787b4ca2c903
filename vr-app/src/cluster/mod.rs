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

use std::time::{SystemTime, UNIX_EPOCH};

use serde::Serialize;

pub use crate::config::cluster::{ClusterSection, NodeSection, Subjects};
pub use crate::error::{ClusterConfigError, ClusterError, NatsFailure};
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

impl ClusterSection {
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

/// Median and 99th percentile of samples (sorted in place), in the samples' unit, by
/// the workspace's one percentile rule ([`sculpt_core::percentile`]).
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
        Self {
            n: samples.len(),
            median: sculpt_core::percentile::median(samples).unwrap_or_default(),
            p99: sculpt_core::percentile::p99(samples).unwrap_or_default(),
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
    use std::time::Duration;

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
