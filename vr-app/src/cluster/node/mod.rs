//! The node role: a render node of the cluster, in a window on its screen
//! (`window::run_windowed_node` (feature `window`): each frame presents after the swap lock) or
//! headless ([`run_node`]); either writes the document and its own screen's pictures
//! when the session ends.
//!
//! The node follows its tracking feed through its own hub and
//! [`tracking::stage::FrameStage`] (the [`LiveTracking`](crate::live::LiveTracking) of
//! a display server, fed from NATS instead of a socket) and its own interaction. An owner node publishes the edits
//! its interaction proposes to the JetStream stream and waits until the stream has
//! stored them and they have come back; every node applies the stream in order, from
//! its first operation (so a node that starts late or restarts after a crash replays
//! it and converges). The session ends for a node once every owner's end marker is in
//! the stream.

use std::path::PathBuf;

use super::auth::Credentials;
use super::{ClusterConfigError, ClusterError};
use crate::config::Config;
use crate::error::{VrError, VrResult};
use crate::headless::HeadlessOptions;
use crate::session::JOURNAL_FILE;

mod feed;
mod replica;
mod report;
mod run;
mod snapshots;
mod stream;

pub use report::{NodeReport, SnapshotReport};
pub use run::{NodeLoop, run_node};
pub use stream::OpRecord;

/// The file a node writes into its session directory once it is subscribed to its
/// feed and the stream (tests and scripts wait for it before starting the tracker).
pub const READY_FILE: &str = "cluster.ready";

/// The base scene a node opens when it starts from a snapshot (the snapshot's
/// document), in its session directory.
pub const SNAPSHOT_SCENE_FILE: &str = "snapshot.scene.json";

/// Positions a node keeps in [`NodeReport::apply_by_seq`].
pub const APPLY_LOG_CAP: usize = 4096;

/// Options of a node run.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeOptions {
    /// The node's name (a `[[cluster.node]]`).
    pub name: String,
    /// An owner ends its session this many seconds after its feed's last frame.
    pub idle_exit: f64,
    /// Stop after this many seconds in any case.
    pub duration: f64,
    /// The final pictures.
    pub headless: HeadlessOptions,
    /// Credentials from the command line, replacing the config's.
    pub credentials: Credentials,
}

/// Prepares a node's configuration: its screen and session directory from its
/// `[[cluster.node]]` (`out` wins over both), and moves an earlier run's journal
/// aside (as `rejoin.N.journal`): the stream is the record, replayed from its start.
pub fn node_config(mut config: Config, name: &str, out: Option<PathBuf>) -> VrResult<Config> {
    let cluster = config
        .cluster
        .clone()
        .ok_or(ClusterError::Config(ClusterConfigError::NoSection))?;
    let node = cluster.node(name)?;
    if let Some(s) = &node.screen {
        config.screen = *s;
    }
    if let Some(dir) = out.or_else(|| node.out.clone()) {
        config.files.dir = dir;
    }
    if config.tracking.is_none() {
        return Err(ClusterError::Config(ClusterConfigError::NoTracking).into());
    }
    // Checked before any file is touched (issue 31: a run that cannot go on changes
    // nothing).
    config.validate()?;
    let journal = config.files.dir.join(JOURNAL_FILE);
    if journal.exists() {
        let kept = (1..)
            .map(|n| config.files.dir.join(format!("rejoin.{n}.journal")))
            .find(|p| !p.exists())
            .unwrap_or_else(|| config.files.dir.join("rejoin.journal"));
        std::fs::rename(&journal, &kept).map_err(|source| VrError::Io {
            path: journal.display().to_string(),
            source,
        })?;
        tracing::info!(
            "node {name}: earlier journal kept as {}; replaying the stream",
            kept.display()
        );
    }
    let _ = std::fs::remove_file(config.files.dir.join(READY_FILE));
    Ok(config)
}
