//! The node role: a render node of the cluster, in a window on its screen
//! (`window::run_windowed_node` (feature `window`): each frame presents after the swap lock) or
//! headless ([`run_node`]); either writes the document and its own screen's pictures
//! when the session ends.
//!
//! The node follows its tracking feed through its own hub and
//! [`tracking::stage::FrameStage`] (the [`LiveTracking`] of a display server, fed from
//! NATS instead of a socket) and its own interaction. An owner node publishes the edits
//! its interaction proposes to the JetStream stream and waits until the stream has
//! stored them and they have come back; every node applies the stream in order, from
//! its first operation (so a node that starts late or restarts after a crash replays
//! it and converges). The session ends for a node once every owner's end marker is in
//! the stream.

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use async_nats::HeaderMap;
use async_nats::jetstream::{self, consumer, stream};
use futures_util::StreamExt;
use sculpt_core::interaction::Edit;
use serde::{Deserialize, Serialize};

use super::barrier::{Barrier, BarrierStats};
use super::snapshot::{self, SnapshotError, SnapshotRecord, StreamId};
use super::wand::{PeerWandStats, PeerWands, WandPose, WandRate, show_peers};
use super::{
    ClusterConfigError, ClusterError, ClusterSection, HDR_KIND, HDR_OWNER, HDR_POSE, HDR_RECEIVED,
    HDR_RECEIVED_UNIX, HDR_SENT, KIND_EDIT, KIND_END, NatsFailure, NodeSection, Percentiles,
    Subjects, header, unix_ns,
};
use crate::app::AppState;
use crate::config::Config;
use crate::error::{VrError, VrResult};
use crate::headless::{HeadlessOptions, HeadlessReport, run_headless};
use crate::input::Input;
use crate::live::LiveTracking;
use crate::render::Gpu;
use crate::session::JOURNAL_FILE;

/// The file a node writes into its session directory once it is subscribed to its
/// feed and the stream (tests and scripts wait for it before starting the tracker).
pub const READY_FILE: &str = "cluster.ready";

/// Further tries at creating (or finding) the operation stream, and the pause between.
const STREAM_ATTEMPTS: u32 = 10;
const STREAM_RETRY: Duration = Duration::from_millis(300);

/// How long an owner waits for JetStream to acknowledge one publish before retrying.
const ACK_WAIT: Duration = Duration::from_secs(2);

/// The base scene a node opens when it starts from a snapshot (the snapshot's
/// document), in its session directory.
pub const SNAPSHOT_SCENE_FILE: &str = "snapshot.scene.json";

/// Positions a node keeps in [`NodeReport::apply_by_seq`].
pub const APPLY_LOG_CAP: usize = 4096;

/// One operation in the stream: the body of a `<session>.ops` message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpRecord {
    /// Session time of the operation (seconds).
    pub t: f64,
    /// The operation.
    pub edit: Edit,
}

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
}

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
    /// The same per stream position (the first [`APPLY_LOG_CAP`]): the slowest node's
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

/// One stream message as the ops task hands it over.
#[derive(Debug)]
struct OpMsg {
    seq: u64,
    kind: Option<String>,
    owner: Option<String>,
    sent_ns: Option<u64>,
    payload: Vec<u8>,
}

/// Counters the tracking task shares with the node loop.
#[derive(Debug, Default)]
struct FeedStats {
    frames: AtomicU64,
    garbage: AtomicU64,
    /// [`FeedClock::base`]: to turn a staged frame's receive time into the Unix time
    /// the ingest received it.
    clock: Mutex<Option<(Duration, u64)>>,
}

/// How far ahead of this node's clock a feed frame's receive time may be before
/// [`FeedClock`] starts a new base.
const FEED_CLOCK_AHEAD: Duration = Duration::from_secs(1);
/// How far behind (a node held up, then catching up on buffered frames).
const FEED_CLOCK_BEHIND: Duration = Duration::from_secs(30);

/// The receive times a node gives the feed's frames: the ingest's (its hub clock,
/// [`HDR_RECEIVED`]), moved onto this node's hub clock at the first frame. So every
/// node's stage sees the same intervals between frames as the ingest's did (the stage
/// reads them where frames carry no timestamp), whatever the network did to them.
#[derive(Debug, Default)]
struct FeedClock {
    /// The ingest's receive time and this node's hub time at the first frame, and the
    /// Unix time the ingest received it ([`HDR_RECEIVED_UNIX`]), if sent.
    base: Option<(Duration, Duration, Option<u64>)>,
    /// The ingest's receive time of the last frame.
    last: Option<Duration>,
}

impl FeedClock {
    /// The receive time of a frame that arrives at `now` (this node's hub clock) with
    /// the ingest's receive time `ingest_us` and its Unix time `ingest_unix_ns`. A frame
    /// without the ingest's time is stamped `now`; an ingest whose clock went back (a
    /// new ingest process) starts a new base.
    fn receive_time(
        &mut self,
        now: Duration,
        ingest_us: Option<u64>,
        ingest_unix_ns: Option<u64>,
    ) -> Duration {
        let Some(us) = ingest_us else {
            return now;
        };
        let ingest = Duration::from_micros(us);
        if self.last.is_some_and(|l| ingest < l) {
            self.base = None;
        }
        self.last = Some(ingest);
        let (ingest0, node0, _) = *self.base.get_or_insert((ingest, now, ingest_unix_ns));
        let t = node0 + ingest.saturating_sub(ingest0);
        // A time far from this node's own clock (a hostile or broken peer, a new
        // ingest whose clock happens to be ahead): start a new base at this frame.
        if t > now + FEED_CLOCK_AHEAD || t + FEED_CLOCK_BEHIND < now {
            self.base = Some((ingest, now, ingest_unix_ns));
            return now;
        }
        t
    }

    /// This node's hub time of the first frame and the Unix time the ingest received
    /// it, when it said.
    fn base(&self) -> Option<(Duration, u64)> {
        let (_, node0, unix0) = self.base?;
        Some((node0, unix0?))
    }
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

/// The running node.
struct Node {
    rt: tokio::runtime::Runtime,
    js: jetstream::Context,
    subjects: Subjects,
    name: String,
    owner: bool,
    owners: BTreeSet<String>,
    commit_timeout: Duration,
    run_id: u64,
    proposed: u64,
    ops: mpsc::Receiver<OpMsg>,
    applied_seq: u64,
    applied: u64,
    committed: u64,
    garbage_ops: u64,
    ends: BTreeSet<String>,
    commit_ms: Vec<f64>,
    apply_ms: Vec<f64>,
    /// Stream position -> proposer's publish to applied here (ms), for the figure
    /// "applied on every node" (the slowest node per operation).
    apply_by_seq: Vec<(u64, f64)>,
    snap: Snapshots,
}

/// A node's snapshot state.
struct Snapshots {
    /// The bucket (`None`: snapshots off, or the bucket could not be had).
    store: Option<async_nats::jetstream::object_store::ObjectStore>,
    session: String,
    stream: StreamId,
    /// The stream (to rebuild the document from its start).
    ops_stream: stream::Stream,
    /// Write one every this many positions (0: only at the end).
    every: u64,
    /// The position the document was loaded at, until a rebuild: undoing a step older
    /// than it needs the whole stream.
    loaded: Option<u64>,
    /// The base scene before the snapshot replaced it (`None`: the default document).
    base_scene: Option<PathBuf>,
    /// The snapshot being stored.
    writing: Option<tokio::task::JoinHandle<Result<(), SnapshotError>>>,
    report: SnapshotReport,
}

impl Node {
    /// Applies one stream message (once: a message seen again after the consumer was
    /// recreated is skipped).
    fn take(&mut self, app: &mut AppState, m: OpMsg) -> VrResult<()> {
        if m.seq <= self.applied_seq {
            return Ok(());
        }
        self.applied_seq = m.seq;
        match m.kind.as_deref() {
            Some(KIND_END) => {
                if let Some(o) = m.owner {
                    tracing::info!(owner = %o, seq = m.seq, "end of an owner's session");
                    self.ends.insert(o);
                } else {
                    self.garbage_ops += 1;
                }
            }
            Some(KIND_EDIT) => match serde_json::from_slice::<OpRecord>(&m.payload) {
                Ok(rec) => {
                    if rec.edit == Edit::Undo
                        && self.snap.loaded.is_some()
                        && !app.session.doc.can_undo()
                    {
                        // The step to undo is older than the snapshot, whose document
                        // has no history: rebuild from the whole stream first.
                        self.rebuild(app, m.seq - 1)?;
                    }
                    app.session.apply_committed(rec.t, &rec.edit)?;
                    self.applied += 1;
                    if let Some(sent) = m.sent_ns {
                        let ms = unix_ns().saturating_sub(sent) as f64 / 1e6;
                        self.apply_ms.push(ms);
                        if self.apply_by_seq.len() < APPLY_LOG_CAP {
                            self.apply_by_seq.push((m.seq, ms));
                        }
                    }
                }
                Err(e) => {
                    tracing::warn!(
                        seq = m.seq,
                        "ignoring an operation that does not decode: {e}"
                    );
                    self.garbage_ops += 1;
                }
            },
            _ => {
                tracing::warn!(
                    seq = m.seq,
                    "ignoring a stream message that is not an operation"
                );
                self.garbage_ops += 1;
            }
        }
        Ok(())
    }

    /// Replaces the document (loaded from a snapshot, so without undo history) with
    /// the one the stream's positions `1..=upto` build from the base scene, as a node
    /// that replayed the whole stream has it.
    fn rebuild(&mut self, app: &mut AppState, upto: u64) -> VrResult<()> {
        let from = self.snap.loaded.take().unwrap_or_default();
        tracing::warn!(
            snapshot = from,
            upto,
            "the stream undoes a step older than the snapshot; rebuilding the document from the whole stream"
        );
        let mut doc = match &self.snap.base_scene {
            Some(p) => crate::session::load_scene(p)?,
            None => sculpt_core::editor::default_document(),
        };
        let deadline = Instant::now() + self.commit_timeout;
        let ops_stream = self.snap.ops_stream.clone();
        let subject = self.subjects.ops.clone();
        let (tx, rx) = mpsc::channel();
        let task = self.rt.spawn(follow_stream(ops_stream, subject, 1, tx));
        let mut seq = 0;
        while seq < upto {
            let left = deadline.saturating_duration_since(Instant::now());
            let m = rx.recv_timeout(left).map_err(|_| ClusterError::JetStream {
                what: "operation stream (rebuild)",
                source: NatsFailure::ConsumerEnded,
            })?;
            seq = m.seq;
            if m.kind.as_deref() == Some(KIND_EDIT)
                && let Ok(rec) = serde_json::from_slice::<OpRecord>(&m.payload)
            {
                sculpt_core::editor::apply(&mut doc, &rec.edit);
            }
        }
        task.abort();
        *app.session.draw_parts().0 = doc;
        self.snap.report.rebuilt += 1;
        Ok(())
    }

    /// The snapshot writer's turn: stores a snapshot of the document when `every`
    /// positions have passed since the last (or, at `end`, when any have), in the
    /// background. Only at a position whose document says everything the stream
    /// needs: no undone step waiting for a redo (the document's JSON has no history).
    fn snapshot(&mut self, app: &AppState, end: bool) {
        let Some(store) = self.snap.store.clone() else {
            return;
        };
        if let Some(task) = &self.snap.writing {
            if !task.is_finished() && !end {
                return;
            }
            if let Some(task) = self.snap.writing.take() {
                match self.rt.block_on(task) {
                    Ok(Ok(())) => {}
                    Ok(Err(e)) => {
                        tracing::warn!("storing a snapshot: {}", sculpt_core::error::Chain(&e))
                    }
                    Err(e) => tracing::warn!("storing a snapshot: {e}"),
                }
            }
        }
        let last = self.snap.report.written_seq.unwrap_or_default();
        let due = if end {
            self.applied_seq > last
        } else {
            self.snap.every > 0 && self.applied_seq >= last + self.snap.every
        };
        if !due || app.session.doc.can_redo() {
            return;
        }
        let record = SnapshotRecord {
            session: self.snap.session.clone(),
            stream: self.snap.stream,
            seq: self.applied_seq,
            ends: self.ends.iter().cloned().collect(),
            writer: self.name.clone(),
            document: app.session.doc.to_json(),
        };
        let bytes = match record.encode() {
            Ok(b) => b,
            Err(e) => {
                tracing::warn!("encoding a snapshot: {}", sculpt_core::error::Chain(&e));
                return;
            }
        };
        tracing::info!(seq = record.seq, bytes = bytes.len(), "writing a snapshot");
        self.snap.report.written += 1;
        self.snap.report.written_seq = Some(record.seq);
        let task = self
            .rt
            .spawn(async move { snapshot::store(&store, bytes).await });
        if end {
            let timeout = self.commit_timeout;
            // (The timer needs the runtime: build it inside.)
            match self
                .rt
                .block_on(async move { tokio::time::timeout(timeout, task).await })
            {
                Ok(Ok(Ok(()))) => {}
                Ok(Ok(Err(e))) => {
                    tracing::warn!("storing a snapshot: {}", sculpt_core::error::Chain(&e));
                }
                Ok(Err(e)) => tracing::warn!("storing a snapshot: {e}"),
                Err(_) => tracing::warn!("storing a snapshot: not done within {timeout:?}"),
            }
        } else {
            self.snap.writing = Some(task);
        }
    }

    /// Applies what the stream has delivered so far.
    fn drain(&mut self, app: &mut AppState) -> VrResult<()> {
        while let Ok(m) = self.ops.try_recv() {
            self.take(app, m)?;
        }
        Ok(())
    }

    /// Waits until the stream position `seq` is applied (or `deadline` passes).
    fn wait_applied(&mut self, app: &mut AppState, seq: u64, deadline: Instant) -> VrResult<()> {
        while self.applied_seq < seq {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ClusterError::CommitTimeout(self.commit_timeout).into());
            }
            match self.ops.recv_timeout(left) {
                Ok(m) => self.take(app, m)?,
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(ClusterError::JetStream {
                        what: "operation stream",
                        source: NatsFailure::ConsumerEnded,
                    }
                    .into());
                }
            }
        }
        Ok(())
    }

    /// Publishes one message to the stream and waits for JetStream's acknowledgement,
    /// retrying (with the same message id, so a retry is never stored twice) through a
    /// server restart. Returns the stream position.
    fn publish(&mut self, kind: &str, payload: Vec<u8>, deadline: Instant) -> VrResult<u64> {
        self.proposed += 1;
        let msg_id = format!("{}-{:x}-{}", self.name, self.run_id, self.proposed);
        loop {
            let mut headers = HeaderMap::new();
            headers.insert(async_nats::header::NATS_MESSAGE_ID, msg_id.as_str());
            headers.insert(HDR_KIND, kind);
            headers.insert(HDR_OWNER, self.name.as_str());
            headers.insert(HDR_SENT, unix_ns().to_string().as_str());
            let js = self.js.clone();
            let subject = self.subjects.ops.clone();
            let body = payload.clone();
            let acked = self.rt.block_on(async move {
                let ack = js
                    .publish_with_headers(subject, headers, body.into())
                    .await?;
                tokio::time::timeout(ACK_WAIT, ack)
                    .await
                    .map_err(|_| NatsFailure::NoAck(ACK_WAIT))?
                    .map_err(NatsFailure::from)
            });
            match acked {
                Ok(ack) => return Ok(ack.sequence),
                Err(source) => {
                    if Instant::now() >= deadline {
                        return Err(ClusterError::Publish {
                            subject: self.subjects.ops.clone(),
                            source,
                        }
                        .into());
                    }
                    tracing::warn!("operation not acknowledged ({source}); retrying");
                    std::thread::sleep(Duration::from_millis(200));
                }
            }
        }
    }

    /// Commits edits proposed by this (owner) node, one at a time: each is stored and
    /// applied (through the stream) before the next input, as a local edit would be.
    fn commit(&mut self, app: &mut AppState, t: f64, edits: Vec<Edit>) -> VrResult<()> {
        for edit in edits {
            let started = Instant::now();
            let deadline = started + self.commit_timeout;
            let body = serde_json::to_vec(&OpRecord { t, edit }).map_err(|cause| {
                ClusterError::Encode {
                    what: "an operation",
                    cause,
                }
            })?;
            let seq = self.publish(KIND_EDIT, body, deadline)?;
            self.committed += 1;
            self.wait_applied(app, seq, deadline)?;
            self.commit_ms.push(started.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// Feeds one input: edits are committed by an owner and dropped by other nodes
    /// (whose documents follow the stream only).
    fn input(&mut self, app: &mut AppState, input: Input, last_t: &mut f64) -> VrResult<()> {
        match input {
            Input::Wand(ev) => {
                let edits = app.session.propose(&ev)?;
                if ev.t.is_finite() {
                    *last_t = last_t.max(ev.t);
                }
                if self.owner {
                    self.commit(app, ev.t, edits)?;
                }
            }
            Input::Head(h) => app.set_head(h),
            Input::Tracking(t) => app.tracking = t,
            Input::Tick(t) => {
                let edits = app.session.propose_tick(t)?;
                if self.owner {
                    self.commit(app, t, edits)?;
                }
            }
        }
        Ok(())
    }
}

/// A running node, from its start (connected, subscribed, caught up with the stream)
/// to its end. Its drivers call [`NodeLoop::step`] every turn and [`NodeLoop::swap_lock`]
/// between drawing a frame and presenting it: the headless one ([`run_node`]) and the
/// window's (`window::run_windowed_node` (feature `window`)), whose presentation of frame N
/// waits until every live node has frame N ready.
pub struct NodeLoop {
    node: Node,
    live: LiveTracking,
    client: async_nats::Client,
    cluster: ClusterSection,
    me: NodeSection,
    barrier: Option<Barrier>,
    peers: PeerWands,
    wand_rate: WandRate,
    wand_subject: String,
    wand_rx: mpsc::Receiver<(String, Vec<u8>)>,
    feed: Arc<FeedStats>,
    started: Instant,
    idle_exit: f64,
    duration: f64,
    frame_dt: Duration,
    next_frame: Instant,
    frame_no: u64,
    last_t: f64,
    ended: bool,
    backlog: u64,
    catch_up_s: f64,
    propagation_ms: Vec<f64>,
    presented: u64,
}

impl std::fmt::Debug for NodeLoop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NodeLoop")
            .field("node", &self.me.name)
            .field("owner", &self.node.owner)
            .field("frame", &self.frame_no)
            .finish_non_exhaustive()
    }
}

/// Runs a headless node until every owner's session has ended (or `duration`
/// passes), then writes its document and its screen's pictures.
pub fn run_node(config: Config, opts: &NodeOptions, gpu: &Gpu) -> VrResult<NodeReport> {
    let (mut node, mut app) = NodeLoop::start(config, opts)?;
    while !node.step(&mut app)? {
        if node.barrier.is_some() {
            let now = Instant::now();
            if now < node.next_frame {
                std::thread::sleep((node.next_frame - now).min(Duration::from_millis(2)));
                continue;
            }
            node.swap_lock()?;
        } else {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    node.finish(&mut app, gpu, &opts.headless)
}

impl NodeLoop {
    /// Connects, finds (or creates) the operation stream, loads the latest good
    /// snapshot, subscribes to the feed, the barrier and the wands, and applies the
    /// stream's backlog; then writes [`READY_FILE`]. Returns the node and the display
    /// state its documents live in.
    pub fn start(mut config: Config, opts: &NodeOptions) -> VrResult<(Self, AppState)> {
        let cluster: ClusterSection = config
            .cluster
            .clone()
            .ok_or(ClusterError::Config(ClusterConfigError::NoSection))?;
        cluster.validate()?;
        let me = cluster.node(&opts.name)?.clone();
        let subjects = cluster.subjects();
        let mut section = config
            .tracking
            .clone()
            .ok_or(ClusterError::Config(ClusterConfigError::NoTracking))?;
        // The feed is the node's only source; the configured ones are the ingest's.
        section.input.sources.clear();
        section.playback = None;
        let mut live = LiveTracking::start(&section, config.interaction.pause_timeout)?;
        let (hub, feed_src) = live.add_feed(&format!("nats:{}", me.feed));
        let rt = super::runtime("wandsculpt-cluster")?;
        let started = Instant::now();
        let client = rt.block_on(cluster.connect(&format!("wandsculpt-{}", me.name)))?;
        let js = jetstream::new(client.clone());
        let jserr =
            |what: &'static str| move |e: NatsFailure| ClusterError::JetStream { what, source: e };
        // Nodes starting together race to create the stream, and a server just started
        // may not have JetStream ready yet: retry for a while before giving up.
        let stream_config = stream::Config {
            name: subjects.stream.clone(),
            subjects: vec![subjects.ops.clone()],
            storage: stream::StorageType::File,
            ..Default::default()
        };
        let mut attempt = 0;
        let mut ops_stream = loop {
            match rt.block_on(js.get_or_create_stream(stream_config.clone())) {
                Ok(stream) => break stream,
                Err(e) if attempt < STREAM_ATTEMPTS => {
                    attempt += 1;
                    tracing::warn!("creating the operation stream: {e}; retrying");
                    std::thread::sleep(STREAM_RETRY);
                }
                Err(e) => return Err(jserr("stream")(e.into()).into()),
            }
        };
        let info = rt
            .block_on(ops_stream.info())
            .map_err(|e| jserr("stream info")(e.into()))?;
        let stream_last = info.state.last_sequence;
        let stream_id = StreamId {
            created_unix_ns: i64::try_from(info.created.unix_timestamp_nanos()).unwrap_or(i64::MAX),
        };

        // The latest snapshot, when there is a good one: its document becomes the base
        // scene and the stream is followed from the position after it.
        let base_scene = config.files.scene.clone();
        let mut snap_report = SnapshotReport::default();
        let mut snap_store = None;
        let mut loaded: Option<SnapshotRecord> = None;
        if cluster.snapshots {
            match rt.block_on(snapshot::bucket(&js, &subjects.snapshots)) {
                Ok(store) => {
                    match rt.block_on(load_snapshot(
                        &store,
                        &cluster.session,
                        stream_id,
                        stream_last,
                        &config.files.dir,
                    )) {
                        Ok((rec, path)) => {
                            tracing::info!(
                                seq = rec.seq,
                                writer = %rec.writer,
                                "starting from the snapshot"
                            );
                            config.files.scene = Some(path);
                            snap_report.loaded_seq = Some(rec.seq);
                            loaded = Some(rec);
                        }
                        Err(reason) => {
                            let text = reason.map_or_else(
                                || "no snapshot stored".to_string(),
                                |e| sculpt_core::error::Chain(&e).to_string(),
                            );
                            if text != "no snapshot stored" {
                                tracing::warn!(
                                    "snapshot not used, replaying the whole stream: {text}"
                                );
                            }
                            snap_report.fallback = Some(text);
                        }
                    }
                    snap_store = Some(store);
                }
                Err(e) => {
                    let text = sculpt_core::error::Chain(&e).to_string();
                    tracing::warn!("no snapshot bucket, replaying the whole stream: {text}");
                    snap_report.fallback = Some(text);
                }
            }
        }
        let start_seq = loaded.as_ref().map_or(0, |r| r.seq);
        let backlog = stream_last.saturating_sub(start_seq);
        let mut app = AppState::new(config.clone())?;

        // The operation stream, in order, from the position after the snapshot.
        let (ops_tx, ops_rx) = mpsc::channel();
        rt.spawn(follow_stream(
            ops_stream.clone(),
            subjects.ops.clone(),
            start_seq + 1,
            ops_tx,
        ));

        // The tracking feed into this node's hub.
        let feed = Arc::new(FeedStats::default());
        let mut tracking_sub = rt
            .block_on(client.subscribe(subjects.tracking(&me.feed)))
            .map_err(|e| jserr("tracking subscription")(e.into()))?;
        let feed_stats = feed.clone();
        rt.spawn(async move {
            let mut opened = false;
            let mut clock = FeedClock::default();
            while let Some(msg) = tracking_sub.next().await {
                if header(&msg, HDR_KIND) == Some(KIND_END) {
                    if opened {
                        hub.connection_closed(feed_src, hub.now());
                    }
                    continue;
                }
                match tracking::dtrack::parse_frame(&msg.payload) {
                    Ok(mut frame) => {
                        if !opened {
                            hub.connection_opened(feed_src);
                            opened = true;
                        }
                        let ingest_us = header(&msg, HDR_RECEIVED).and_then(|s| s.parse().ok());
                        let ingest_unix =
                            header(&msg, HDR_RECEIVED_UNIX).and_then(|s| s.parse().ok());
                        frame.receive_time = clock.receive_time(hub.now(), ingest_us, ingest_unix);
                        let pose = header(&msg, HDR_POSE) != Some("0");
                        hub.apply(feed_src, &frame, pose);
                        feed_stats.frames.fetch_add(1, Ordering::Relaxed);
                        if let Ok(mut base) = feed_stats.clock.lock() {
                            *base = clock.base();
                        }
                    }
                    Err(e) => {
                        feed_stats.garbage.fetch_add(1, Ordering::Relaxed);
                        tracing::debug!("ignoring a tracking message that is not a frame: {e}");
                    }
                }
            }
        });

        // The frame barrier.
        let barrier = if cluster.barrier {
            let (tx, rx) = mpsc::channel();
            let mut sub = rt
                .block_on(client.subscribe(subjects.barrier.clone()))
                .map_err(|e| jserr("barrier subscription")(e.into()))?;
            rt.spawn(async move {
                while let Some(msg) = sub.next().await {
                    if tx.send(msg.payload.to_vec()).is_err() {
                        break;
                    }
                }
            });
            let names: Vec<String> = cluster.nodes.iter().map(|n| n.name.clone()).collect();
            Some(Barrier::new(
                &me.name,
                &names,
                Duration::from_secs_f64(cluster.barrier_timeout),
                rx,
            ))
        } else {
            None
        };
        // The other sculptors' wands.
        let (wand_tx, wand_rx) = mpsc::channel::<(String, Vec<u8>)>();
        let mut wand_sub = rt
            .block_on(client.subscribe(subjects.wands.clone()))
            .map_err(|e| jserr("wand subscription")(e.into()))?;
        rt.spawn(async move {
            while let Some(msg) = wand_sub.next().await {
                let node = msg
                    .subject
                    .rsplit('.')
                    .next()
                    .unwrap_or_default()
                    .to_string();
                if wand_tx.send((node, msg.payload.to_vec())).is_err() {
                    break;
                }
            }
        });
        let (own_feed, other_feeds): (Vec<&super::NodeSection>, Vec<&super::NodeSection>) = cluster
            .nodes
            .iter()
            .filter(|n| n.owner)
            .partition(|n| n.feed == me.feed);
        let peers = PeerWands::new(
            other_feeds.iter().map(|n| n.name.clone()),
            own_feed.iter().map(|n| n.name.clone()),
            Duration::from_secs_f64(cluster.wand_stale),
        );
        let wand_rate = WandRate::new(cluster.wand_rate);
        let wand_subject = subjects.wand(&me.name);

        rt.block_on(client.flush())
            .map_err(|e| jserr("flush")(e.into()))?;

        let mut node = Node {
            rt,
            js,
            subjects: subjects.clone(),
            name: me.name.clone(),
            owner: me.owner,
            owners: cluster.owners().into_iter().collect(),
            commit_timeout: Duration::from_secs_f64(cluster.commit_timeout),
            run_id: unix_ns(),
            proposed: 0,
            ops: ops_rx,
            applied_seq: start_seq,
            applied: 0,
            committed: 0,
            garbage_ops: 0,
            ends: loaded
                .as_ref()
                .map(|r| r.ends.iter().cloned().collect())
                .unwrap_or_default(),
            commit_ms: Vec::new(),
            apply_ms: Vec::new(),
            apply_by_seq: Vec::new(),
            snap: Snapshots {
                store: snap_store,
                session: cluster.session.clone(),
                stream: stream_id,
                ops_stream,
                every: cluster.snapshot_every,
                loaded: loaded.as_ref().map(|r| r.seq),
                base_scene,
                writing: None,
                report: snap_report,
            },
        };
        drop(loaded);
        // Catch up with the stream before following the feed.
        node.wait_applied(
            &mut app,
            stream_last,
            started + Duration::from_secs_f64(opts.duration),
        )?;
        let catch_up_s = started.elapsed().as_secs_f64();
        tracing::info!(node = %me.name, backlog, catch_up_s, "caught up with the operation stream");
        crate::session::write_atomic(
            &app.session.dir().join(READY_FILE),
            format!("{}\n", me.name).as_bytes(),
        )?;

        let frame_dt = Duration::from_secs_f64(1.0 / cluster.frame_rate);
        let me_section = me.clone();
        Ok((
            Self {
                node,
                live,
                client,
                cluster,
                me: me_section,
                barrier,
                peers,
                wand_rate,
                wand_subject,
                wand_rx,
                feed,
                started,
                idle_exit: opts.idle_exit,
                duration: opts.duration,
                frame_dt,
                next_frame: Instant::now(),
                frame_no: 0,
                last_t: 0.0,
                ended: false,
                backlog,
                catch_up_s,
                propagation_ms: Vec::new(),
                presented: 0,
            },
            app,
        ))
    }

    /// Whether this node's interaction proposes edits.
    pub fn owner(&self) -> bool {
        self.node.owner
    }

    /// One turn: the tracking feed's new samples through the interaction (an owner
    /// commits the edits it proposes), the stream's new operations, the other
    /// sculptors' wands, a snapshot when due, and the owner's end of session. Returns
    /// `true` once the session is over for this node (every owner has ended, or the
    /// duration passed).
    pub fn step(&mut self, app: &mut AppState) -> VrResult<bool> {
        for input in self.live.poll() {
            self.node.input(app, input, &mut self.last_t)?;
        }
        self.note_propagation();
        self.node.drain(app)?;
        let now = Instant::now();
        show_peers(app, &mut self.peers, self.wand_rx.try_iter(), now);
        if self.node.owner
            && !self.ended
            && let Some((t, tip, q)) = app.session.interaction.wand()
            && self.wand_rate.due(t, now)
        {
            let active = app.session.interaction.gesture_active();
            let body = WandPose::new(tip, q, active).encode()?;
            // Best effort, as tracking frames: a lost pose is followed by the next.
            if let Err(e) = self
                .node
                .rt
                .block_on(self.client.publish(self.wand_subject.clone(), body.into()))
            {
                tracing::debug!("publishing the wand pose: {e}");
            } else {
                self.peers.published();
            }
        }
        if snapshot_writer(&self.node, &self.cluster, self.barrier.as_ref()) {
            self.node.snapshot(app, false);
        }
        let idle = self
            .live
            .last_report()
            .is_some_and(|l| self.live.now().saturating_sub(l).as_secs_f64() > self.idle_exit);
        let timed_out = self.started.elapsed().as_secs_f64() > self.duration;
        if self.live.sources_done() || idle || timed_out {
            self.end_session(app)?;
        }
        if !self.node.owners.is_empty() && self.node.owners.is_subset(&self.node.ends) {
            return Ok(true);
        }
        if timed_out {
            tracing::warn!(node = %self.me.name, "duration passed before every owner ended");
            return Ok(true);
        }
        Ok(false)
    }

    /// An owner ends its session: past the last input a stroke paused by tracking loss
    /// ends, then its end marker goes into the stream (once; other nodes do nothing).
    fn end_session(&mut self, app: &mut AppState) -> VrResult<()> {
        if !self.node.owner || self.ended {
            return Ok(());
        }
        let t = self.last_t + 10.0;
        let edits = app.session.propose_tick(t)?;
        self.node.commit(app, t, edits)?;
        let deadline = Instant::now() + self.node.commit_timeout;
        let seq = self.node.publish(KIND_END, Vec::new(), deadline)?;
        self.node.wait_applied(app, seq, deadline)?;
        self.ended = true;
        Ok(())
    }

    /// Propagation of the frames the last poll staged: from the ingest receiving each
    /// frame from the tracker to this node's stage taking it.
    fn note_propagation(&mut self) {
        let Some((node_at, unix_at)) = self.feed.clock.lock().ok().and_then(|b| *b) else {
            return;
        };
        let now = unix_ns();
        for &received in self.live.staged() {
            let since = received.saturating_sub(node_at).as_nanos();
            let unix = unix_at.saturating_add(u64::try_from(since).unwrap_or(u64::MAX));
            self.propagation_ms
                .push(now.saturating_sub(unix) as f64 / 1e6);
        }
    }

    /// Frame lock and software swap lock: reports this node's current frame ready
    /// and waits until every live node has reported it (or the barrier's timeout drops
    /// the late ones); the caller presents the frame after this returns. Without a
    /// barrier it returns at once.
    pub fn swap_lock(&mut self) -> VrResult<()> {
        let Some(b) = self.barrier.as_mut() else {
            self.presented += 1;
            return Ok(());
        };
        let report = b.report(self.frame_no)?;
        let subject = self.node.subjects.barrier.clone();
        self.node
            .rt
            .block_on(self.client.publish(subject.clone(), report.into()))
            .map_err(|e| ClusterError::Publish {
                subject,
                source: e.into(),
            })?;
        self.frame_no = b.wait(self.frame_no);
        self.next_frame = (self.next_frame + self.frame_dt).max(Instant::now());
        self.presented += 1;
        Ok(())
    }

    /// A command from the node's own keys (undo, a mode, the tool): an owner commits
    /// its edits through the stream like the wand's; on any other node it changes
    /// nothing (its document follows the stream only).
    pub fn command(
        &mut self,
        app: &mut AppState,
        ev: &sculpt_core::interaction::WandEvent,
    ) -> VrResult<()> {
        if !self.node.owner {
            tracing::info!(node = %self.me.name, "not an owner: edits come from the stream only");
            return Ok(());
        }
        self.node
            .input(app, Input::Wand(ev.clone()), &mut self.last_t)
    }

    /// Ends the session: a non-owner's interaction ends a paused gesture, the
    /// snapshot writer stores the last snapshot, and the document and this screen's
    /// pictures are written (with `gpu`, as a headless run writes them).
    pub fn finish(
        mut self,
        app: &mut AppState,
        gpu: &Gpu,
        pictures: &HeadlessOptions,
    ) -> VrResult<NodeReport> {
        // An owner whose window closed before its feed ended ends its session now,
        // so the other nodes need not wait for `--duration`. Not an owner: the
        // interaction, too, ends a paused gesture (its edits are the owner's to
        // commit, and are already in the stream).
        if self.node.owner {
            self.end_session(app)?;
        } else {
            app.session.propose_tick(self.last_t + 10.0)?;
        }
        // The writer's last snapshot covers the whole session (a clean exit).
        if snapshot_writer(&self.node, &self.cluster, self.barrier.as_ref()) {
            self.node.snapshot(app, true);
        }
        let Self {
            mut node,
            live,
            barrier,
            peers,
            feed,
            backlog,
            catch_up_s,
            mut propagation_ms,
            presented,
            me,
            ..
        } = self;
        drop(live);
        let headless = run_headless(app, gpu, std::iter::empty(), pictures)?;
        Ok(NodeReport {
            node: me.name.clone(),
            owner: me.owner,
            headless,
            applied: node.applied,
            committed: node.committed,
            backlog,
            catch_up_s,
            snapshot: node.snap.report.clone(),
            peer_wands: peers.stats(),
            garbage_ops: node.garbage_ops,
            garbage_frames: feed.garbage.load(Ordering::Relaxed),
            frames: feed.frames.load(Ordering::Relaxed),
            propagation_ms: Percentiles::of(&mut propagation_ms),
            commit_ms: Percentiles::of(&mut node.commit_ms),
            apply_ms: Percentiles::of(&mut node.apply_ms),
            apply_by_seq: std::mem::take(&mut node.apply_by_seq),
            presented,
            windowed: false,
            ended_owners: node.ends.iter().cloned().collect(),
            barrier: barrier.map(|mut b| b.stats()),
        })
    }
}

/// Whether this node writes the snapshots now: the lowest-named owner among those the
/// frame barrier sees live (every configured owner, without a barrier).
fn snapshot_writer(node: &Node, cluster: &ClusterSection, barrier: Option<&Barrier>) -> bool {
    node.owner
        && node.snap.store.is_some()
        && cluster.snapshots
        && node
            .owners
            .iter()
            .find(|o| **o == node.name || barrier.is_none_or(|b| b.is_live(o)))
            == Some(&node.name)
}

/// Fetches, checks and keeps the latest snapshot: its document is written to the
/// session directory ([`SNAPSHOT_SCENE_FILE`]) for the session to open. `Err(None)`:
/// there is none yet.
async fn load_snapshot(
    store: &async_nats::jetstream::object_store::ObjectStore,
    session: &str,
    stream: StreamId,
    last: u64,
    dir: &std::path::Path,
) -> Result<(SnapshotRecord, PathBuf), Option<SnapshotError>> {
    let bytes = snapshot::fetch(store).await?.ok_or(None)?;
    let rec = SnapshotRecord::decode(&bytes)?;
    rec.check(session, stream, last)?;
    sculpt_core::sculpt::document::Document::from_json(&rec.document)
        .map_err(|e| SnapshotError::Document(Box::new(e)))?;
    let write = |e: VrError| SnapshotError::Write(Box::new(e));
    crate::session::create_output_dir(dir).map_err(|source| {
        write(VrError::Io {
            path: dir.display().to_string(),
            source,
        })
    })?;
    let path = dir.join(SNAPSHOT_SCENE_FILE);
    crate::session::write_atomic(&path, &rec.document).map_err(write)?;
    Ok((rec, path))
}

/// Follows the operation stream with an ordered consumer from position `start` on,
/// recreating it after an error (a server restart), and hands every message over in
/// order.
async fn follow_stream(
    stream: stream::Stream,
    subject: String,
    start: u64,
    tx: mpsc::Sender<OpMsg>,
) {
    let mut next = start.max(1);
    loop {
        let deliver_policy = if next <= 1 {
            consumer::DeliverPolicy::All
        } else {
            consumer::DeliverPolicy::ByStartSequence {
                start_sequence: next,
            }
        };
        let created = stream
            .create_consumer(consumer::pull::OrderedConfig {
                filter_subject: subject.clone(),
                deliver_policy,
                ..Default::default()
            })
            .await;
        let messages = match created {
            Ok(c) => c.messages().await,
            Err(e) => {
                tracing::warn!("operation stream consumer: {e}; retrying");
                tokio::time::sleep(Duration::from_millis(250)).await;
                continue;
            }
        };
        let mut messages = match messages {
            Ok(m) => m,
            Err(e) => {
                tracing::warn!("operation stream: {e}; retrying");
                tokio::time::sleep(Duration::from_millis(250)).await;
                continue;
            }
        };
        while let Some(m) = messages.next().await {
            let m = match m {
                Ok(m) => m,
                Err(e) => {
                    tracing::warn!("operation stream: {e}; resuming at {next}");
                    break;
                }
            };
            let Ok(info) = m.info() else {
                continue;
            };
            let seq = info.stream_sequence;
            next = seq + 1;
            let get = |name: &str| header(&m.message, name).map(str::to_string);
            let msg = OpMsg {
                seq,
                kind: get(HDR_KIND),
                owner: get(HDR_OWNER),
                sent_ns: get(HDR_SENT).and_then(|s| s.parse().ok()),
                payload: m.message.payload.to_vec(),
            };
            if tx.send(msg).is_err() {
                return;
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn the_feed_keeps_the_ingests_intervals_on_the_nodes_clock() {
        let mut c = FeedClock::default();
        assert_eq!(c.base(), None);
        // First frame: received by the ingest at 5 s, here at 1 s (node clock).
        assert_eq!(
            c.receive_time(1000 * MS, Some(5_000_000), Some(77)),
            1000 * MS
        );
        assert_eq!(c.base(), Some((1000 * MS, 77)));
        // 10 ms later at the ingest; the network delayed it by 7 ms more than the
        // first: the stage still sees 10 ms.
        assert_eq!(c.receive_time(1017 * MS, Some(5_010_000), None), 1010 * MS);
        // A frame without the ingest's time is stamped on arrival.
        assert_eq!(c.receive_time(1030 * MS, None, None), 1030 * MS);
        // A new ingest (its clock went back): a new base.
        assert_eq!(c.receive_time(2000 * MS, Some(1_000), Some(99)), 2000 * MS);
        assert_eq!(c.base(), Some((2000 * MS, 99)));
        // A time an hour ahead of the node's clock (a hostile peer): a new base, and
        // the frame is stamped on arrival.
        assert_eq!(
            c.receive_time(2010 * MS, Some(3_600_000_000), Some(5)),
            2010 * MS
        );
        assert_eq!(c.base(), Some((2010 * MS, 5)));
        assert_eq!(
            c.receive_time(2030 * MS, Some(3_600_010_000), None),
            2020 * MS
        );
        // The largest time the header can carry: no overflow, a new base.
        assert_eq!(c.receive_time(2040 * MS, Some(u64::MAX), None), 2040 * MS);
    }
}
