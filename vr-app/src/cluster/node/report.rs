//! What a node run did: its JSON report.

use serde::Serialize;

use crate::cluster::Percentiles;
use crate::cluster::barrier::BarrierStats;
use crate::cluster::wand::PeerWandStats;
use crate::headless::HeadlessReport;

/// What a node run did (printed as JSON by `wandsculpt --cluster node`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeReport {
    /// The node.
    pub node: String,
    /// Whether it proposed edits.
    pub owner: bool,
    /// The headless run's report (document, pictures).
    pub headless: HeadlessReport,
    /// Operations applied from the stream.
    pub applied: u64,
    /// Operations this node proposed and the stream acknowledged.
    pub committed: u64,
    /// Stream positions to replay when the node started (a late join's backlog: the
    /// whole stream, or what follows the snapshot it loaded).
    pub backlog: u64,
    /// Seconds from connecting to having applied the backlog (the snapshot loaded).
    pub catch_up_s: f64,
    /// Snapshots loaded and written.
    pub snapshot: SnapshotReport,
    /// The other sculptors' wands.
    pub peer_wands: PeerWandStats,
    /// Stream messages that were not operations (counted and ignored).
    pub garbage_ops: u64,
    /// Stream messages refused (logged and ignored): from an owner the config does not
    /// name, or claiming another owner than the subject they were published on.
    pub refused_ops: u64,
    /// Tracking messages that were not DTrack2 frames (counted and ignored).
    pub garbage_frames: u64,
    /// Tracking frames received.
    pub frames: u64,
    /// From the ingest receiving a tracker frame to this node's stage taking it
    /// (the staged sample), milliseconds.
    pub propagation_ms: Percentiles,
    /// Owner: propose to applied here (acknowledged by JetStream and back through the
    /// stream), milliseconds.
    pub commit_ms: Percentiles,
    /// Proposer's publish to applied on this node, milliseconds.
    pub apply_ms: Percentiles,
    /// The same per stream position (the first [`APPLY_LOG_CAP`](super::APPLY_LOG_CAP)): the slowest node's
    /// figure for a position is the operation's latency to applied on every node.
    pub apply_by_seq: Vec<(u64, f64)>,
    /// Frames presented (windowed) or passed (headless) after the swap lock.
    pub presented: u64,
    /// Whether the node drew into a window (`window::run_windowed_node` (feature `window`)).
    pub windowed: bool,
    /// The owners whose end of session this node applied from the stream.
    pub ended_owners: Vec<String>,
    /// The frame barrier, when on.
    pub barrier: Option<BarrierStats>,
}

/// What a node did with snapshots (in its report).
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct SnapshotReport {
    /// The stream position of the snapshot the node started from.
    pub loaded_seq: Option<u64>,
    /// Why no snapshot was used (none stored, or what was wrong with it: the node
    /// replayed the whole stream).
    pub fallback: Option<String>,
    /// Snapshots this node wrote.
    pub written: u64,
    /// The stream position of the last one it wrote.
    pub written_seq: Option<u64>,
    /// Times the stream undid a step older than the loaded snapshot and the node
    /// rebuilt its document from the whole stream.
    pub rebuilt: u64,
}
