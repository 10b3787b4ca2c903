//! The replica: a node's copy of the document, changed only by the operation stream
//! in order; an owner proposes its edits through the stream.

use std::collections::BTreeSet;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use async_nats::HeaderMap;
use async_nats::jetstream;
use sculpt_core::interaction::{Edit, Tool, WandEvent};

use super::APPLY_LOG_CAP;
use super::report::SnapshotReport;
use super::stream::{ACK_WAIT, OpMsg, OpRecord};
use crate::app::AppState;
use crate::cluster::snapshot::{KIND_SNAPSHOT, OpsHash};
use crate::cluster::{
    ClusterError, HDR_KIND, HDR_OWNER, HDR_SENT, KIND_EDIT, KIND_END, NatsFailure, Subjects,
    unix_ns,
};
use crate::error::{VrError, VrResult};
use crate::feeder::Sink;
use crate::input::TrackingState;
use crate::projection::HeadPose;

/// A node's snapshot state (its work is in `snapshots`; the state lives beside the
/// node that holds it, so `snapshots` uses this file and not the other way round).
pub(super) struct Snapshots {
    /// The bucket (`None`: snapshots off, or the bucket could not be had).
    pub(super) store: Option<async_nats::jetstream::object_store::ObjectStore>,
    pub(super) session: String,
    pub(super) stream: crate::cluster::snapshot::StreamId,
    /// The stream (to rebuild the document from its start).
    pub(super) ops_stream: jetstream::stream::Stream,
    /// Write one every this many positions (0: only at the end).
    pub(super) every: u64,
    /// The position the document was loaded at, until a rebuild: undoing a step older
    /// than it needs the whole stream.
    pub(super) loaded: Option<u64>,
    /// The base scene before the snapshot replaced it (`None`: the default document).
    pub(super) base_scene: Option<std::path::PathBuf>,
    /// The snapshot being stored.
    pub(super) writing:
        Option<tokio::task::JoinHandle<Result<(), crate::cluster::snapshot::SnapshotError>>>,
    pub(super) report: SnapshotReport,
}

/// The running node.
pub(super) struct Node {
    pub(super) rt: tokio::runtime::Runtime,
    pub(super) js: jetstream::Context,
    pub(super) subjects: Subjects,
    pub(super) name: String,
    pub(super) owner: bool,
    pub(super) owners: BTreeSet<String>,
    pub(super) commit_timeout: Duration,
    pub(super) run_id: u64,
    pub(super) proposed: u64,
    pub(super) ops: mpsc::Receiver<OpMsg>,
    pub(super) applied_seq: u64,
    pub(super) applied: u64,
    pub(super) committed: u64,
    pub(super) garbage_ops: u64,
    /// Stream messages refused: not from a configured owner, or claiming another
    /// owner than their subject names.
    pub(super) refused_ops: u64,
    /// The [`OpsHash`] of the stream's positions up to `applied_seq` (the snapshot
    /// writer's attestation names it).
    pub(super) chain: OpsHash,
    /// The last stream position applied that is not a snapshot attestation (the
    /// writer counts these, so its own attestations never make a snapshot due).
    pub(super) last_op_seq: u64,
    pub(super) ends: BTreeSet<String>,
    pub(super) commit_ms: Vec<f64>,
    pub(super) apply_ms: Vec<f64>,
    /// Stream position -> proposer's publish to applied here (ms), for the figure
    /// "applied on every node" (the slowest node per operation).
    pub(super) apply_by_seq: Vec<(u64, f64)>,
    pub(super) snap: Snapshots,
}

/// Why a stream message is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(super) enum Refusal {
    /// Its subject names no owner (`<session>.ops.<owner>`).
    #[error("subject {0:?} names no owner")]
    Subject(String),
    /// Its subject names an owner the config does not.
    #[error("{0:?} is not an owner in the config")]
    NotAnOwner(String),
    /// Its header claims another owner than its subject names.
    #[error("published as {subject:?} but claims to be {header:?}")]
    Claims {
        /// The owner its subject names (whose credentials published it).
        subject: String,
        /// The owner its header claims.
        header: String,
    },
}

impl Node {
    /// The owner whose message `m` is: the one its subject names, which the server
    /// let publish there; refused when the config names no such owner or the message
    /// claims another.
    pub(super) fn accept(&self, m: &OpMsg) -> Result<String, Refusal> {
        let Some(owner) = self.subjects.op_owner(&m.subject) else {
            return Err(Refusal::Subject(m.subject.clone()));
        };
        if !self.owners.contains(owner) {
            return Err(Refusal::NotAnOwner(owner.to_string()));
        }
        if let Some(h) = &m.owner
            && h != owner
        {
            return Err(Refusal::Claims {
                subject: owner.to_string(),
                header: h.clone(),
            });
        }
        Ok(owner.to_string())
    }

    /// Applies one stream message (once: a message seen again after the consumer was
    /// recreated is skipped), if a configured owner sent it; any other is refused and
    /// logged.
    pub(super) fn take(&mut self, app: &mut AppState, m: OpMsg) -> VrResult<()> {
        if m.seq <= self.applied_seq {
            return Ok(());
        }
        self.applied_seq = m.seq;
        self.chain = self
            .chain
            .next(m.seq, &m.subject, m.kind.as_deref(), &m.payload);
        if m.kind.as_deref() != Some(KIND_SNAPSHOT) {
            self.last_op_seq = m.seq;
        }
        let owner = match self.accept(&m) {
            Ok(o) => o,
            Err(why) => {
                tracing::warn!(
                    seq = m.seq,
                    kind = m.kind.as_deref().unwrap_or("none"),
                    "refusing a stream message: {why}"
                );
                self.refused_ops += 1;
                return Ok(());
            }
        };
        match m.kind.as_deref() {
            Some(KIND_END) => {
                tracing::info!(owner = %owner, seq = m.seq, "end of an owner's session");
                self.ends.insert(owner);
            }
            Some(KIND_SNAPSHOT) => {
                tracing::debug!(owner = %owner, seq = m.seq, "a snapshot attestation");
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

    /// Applies what the stream has delivered so far.
    pub(super) fn drain(&mut self, app: &mut AppState) -> VrResult<()> {
        while let Ok(m) = self.ops.try_recv() {
            self.take(app, m)?;
        }
        Ok(())
    }

    /// Waits until the stream position `seq` is applied (or `deadline` passes).
    pub(super) fn wait_applied(
        &mut self,
        app: &mut AppState,
        seq: u64,
        deadline: Instant,
    ) -> VrResult<()> {
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
    pub(super) fn publish(
        &mut self,
        kind: &str,
        payload: Vec<u8>,
        deadline: Instant,
    ) -> VrResult<u64> {
        self.proposed += 1;
        let msg_id = format!("{}-{:x}-{}", self.name, self.run_id, self.proposed);
        loop {
            let mut headers = HeaderMap::new();
            headers.insert(async_nats::header::NATS_MESSAGE_ID, msg_id.as_str());
            headers.insert(HDR_KIND, kind);
            headers.insert(HDR_OWNER, self.name.as_str());
            headers.insert(HDR_SENT, unix_ns().to_string().as_str());
            let js = self.js.clone();
            let subject = self.subjects.op(&self.name);
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
                            subject: self.subjects.op(&self.name),
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
    pub(super) fn commit(&mut self, app: &mut AppState, t: f64, edits: Vec<Edit>) -> VrResult<()> {
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
}

/// A node's session as the [`Feeder`](crate::feeder::Feeder)'s sink: wand events
/// and ticks are proposed to the interaction; an owner commits the edits through the
/// stream, other nodes drop them (their documents follow the stream only).
pub(super) struct NodeSink<'a> {
    pub(super) node: &'a mut Node,
    pub(super) app: &'a mut AppState,
    /// The latest wand event time seen.
    pub(super) last_t: &'a mut f64,
}

impl Sink for NodeSink<'_> {
    type Error = VrError;

    fn wand(&mut self, ev: &WandEvent) -> VrResult<()> {
        let edits = self.app.session.propose(ev)?;
        if ev.t.is_finite() {
            *self.last_t = self.last_t.max(ev.t);
        }
        if self.node.owner {
            self.node.commit(self.app, ev.t, edits)?;
        }
        Ok(())
    }

    fn tick(&mut self, t: f64) -> VrResult<()> {
        let edits = self.app.session.propose_tick(t)?;
        if self.node.owner {
            self.node.commit(self.app, t, edits)?;
        }
        Ok(())
    }

    fn tool(&self) -> Tool {
        self.app.session.interaction.tool().clone()
    }

    fn head(&mut self, head: Option<HeadPose>) {
        self.app.set_head(head);
    }

    fn tracking(&mut self, state: TrackingState) {
        self.app.tracking = state;
    }

    fn key(&mut self, t: f64, key: &str) {
        self.app.session.key(t, key);
    }
}
