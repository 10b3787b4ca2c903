//! `[cluster]`: the NATS server, the session namespace and the render nodes of
//! `wandsculpt --cluster` (docs/cluster.md). Read and checked in every build; the
//! roles that use it need the `nats` feature.

use serde::{Deserialize, Serialize};

use super::screen::ScreenConfig;
use crate::error::{ClusterConfigError, ClusterError};

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
}
