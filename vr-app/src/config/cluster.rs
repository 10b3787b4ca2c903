//! `[cluster]`: the NATS server, the session namespace and the render nodes of
//! `wandsculpt --cluster` (docs/cluster.md). Read and checked in every build; the
//! roles that use it need the `nats` feature.

use std::path::PathBuf;

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

    /// The owners' names: the nodes whose end markers close the session.
    pub fn owners(&self) -> Vec<String> {
        self.nodes
            .iter()
            .filter(|n| n.owner)
            .map(|n| n.name.clone())
            .collect()
    }
}

/// One role's credentials: a user and password, or an nkey seed file (`nk -gen user`
/// writes one; the server knows the public key). Empty: connect without credentials.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Credentials {
    /// NATS user name (with `password`).
    pub user: Option<String>,
    /// NATS password.
    pub password: Option<String>,
    /// A file holding the role's nkey seed (`SU...`), instead of a user and password.
    pub nkey: Option<PathBuf>,
}

impl Credentials {
    /// Whether nothing is set.
    pub fn is_empty(&self) -> bool {
        self.user.is_none() && self.password.is_none() && self.nkey.is_none()
    }

    /// `self` unless it is empty, else `other`: credentials are taken whole from one
    /// place, never mixed.
    pub fn or(self, other: Credentials) -> Credentials {
        if self.is_empty() { other } else { self }
    }

    /// Checks that a user comes with a password and that an nkey is not mixed with
    /// them; `whose` names the place in the config.
    pub fn validate(&self, whose: &str) -> Result<(), ClusterConfigError> {
        if self.user.is_some() != self.password.is_some() {
            return Err(ClusterConfigError::Credentials(whose.to_string()));
        }
        if self.nkey.is_some() && self.user.is_some() {
            return Err(ClusterConfigError::NkeyAndUser(whose.to_string()));
        }
        Ok(())
    }
}
