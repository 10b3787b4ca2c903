//! A node's snapshots: loading the latest at start, writing them (the writer), and
//! rebuilding when the stream undoes a step older than the loaded one.

use std::path::PathBuf;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use async_nats::HeaderMap;

use async_nats::jetstream::stream;

use super::SNAPSHOT_SCENE_FILE;
use super::replica::Node;
use super::report::SnapshotReport;
use super::stream::{OpRecord, follow_stream};
use crate::app::AppState;
use crate::cluster::barrier::Barrier;
use crate::cluster::snapshot::{
    self, Attestation, KIND_SNAPSHOT, OpsHash, SnapshotError, SnapshotRecord, StreamId,
};
use crate::cluster::{
    ClusterError, ClusterSection, HDR_KIND, HDR_OWNER, HDR_SENT, KIND_EDIT, NatsFailure, unix_ns,
};
use crate::error::{VrError, VrResult};

impl Node {
    /// Replaces the document (loaded from a snapshot, so without undo history) with
    /// the one the stream's positions `1..=upto` build from the base scene, as a node
    /// that replayed the whole stream has it.
    pub(super) fn rebuild(&mut self, app: &mut AppState, upto: u64) -> VrResult<()> {
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
                && self.accept(&m).is_ok()
                && let Ok(rec) = serde_json::from_slice::<OpRecord>(&m.payload)
            {
                sculpt_core::editor::apply(&mut doc, &rec.edit);
            }
        }
        task.abort();
        app.session.replace_document(doc);
        self.snap.report.rebuilt += 1;
        Ok(())
    }

    /// The snapshot writer's turn: stores a snapshot of the document when `every`
    /// positions have passed since the last (or, at `end`, when any have), in the
    /// background. Only at a position whose document says everything the stream
    /// needs: no undone step waiting for a redo (the document's JSON has no history).
    pub(super) fn snapshot(&mut self, app: &AppState, end: bool) {
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
            self.last_op_seq > last
        } else {
            self.snap.every > 0 && self.last_op_seq >= last + self.snap.every
        };
        if !due || app.session.doc.can_redo() {
            return;
        }
        let document = app.session.doc.to_json();
        let attestation = Attestation {
            seq: self.applied_seq,
            ops: self.chain,
            doc: snapshot::document_hash(&document),
        };
        let mut record = SnapshotRecord {
            session: self.snap.session.clone(),
            stream: self.snap.stream,
            seq: self.applied_seq,
            ends: self.ends.iter().cloned().collect(),
            writer: self.name.clone(),
            ops_hash: self.chain,
            attested_at: 0,
            document,
        };
        let body = match serde_json::to_vec(&attestation) {
            Ok(b) => b,
            Err(e) => {
                tracing::warn!("encoding a snapshot attestation: {e}");
                return;
            }
        };
        tracing::info!(seq = record.seq, "writing a snapshot");
        self.snap.report.written += 1;
        self.snap.report.written_seq = Some(record.seq);
        // First the attestation into the stream (only owners can write there), then
        // the record naming its position into the bucket.
        let mut headers = HeaderMap::new();
        let msg_id = format!("{}-{:x}-snap-{}", self.name, self.run_id, record.seq);
        headers.insert(async_nats::header::NATS_MESSAGE_ID, msg_id.as_str());
        headers.insert(HDR_KIND, KIND_SNAPSHOT);
        headers.insert(HDR_OWNER, self.name.as_str());
        headers.insert(HDR_SENT, unix_ns().to_string().as_str());
        let js = self.js.clone();
        let subject = self.subjects.op(&self.name);
        let task = self.rt.spawn(async move {
            let ack = js
                .publish_with_headers(subject, headers, body.into())
                .await
                .map_err(|e| SnapshotError::Attest(e.into()))?
                .await
                .map_err(|e| SnapshotError::Attest(e.into()))?;
            record.attested_at = ack.sequence;
            snapshot::store(&store, record.encode()?).await
        });
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
}

/// Whether this node writes the snapshots now: the lowest-named owner among those the
/// frame barrier sees live (every configured owner, without a barrier).
pub(super) fn snapshot_writer(
    node: &Node,
    cluster: &ClusterSection,
    barrier: Option<&Barrier>,
) -> bool {
    node.owner
        && node.snap.store.is_some()
        && cluster.snapshots
        && node
            .owners
            .iter()
            .find(|o| **o == node.name || barrier.is_none_or(|b| b.is_live(o)))
            == Some(&node.name)
}

/// What a snapshot is checked against: this session's operation stream.
pub(super) struct StreamCheck<'a> {
    pub(super) rt: &'a tokio::runtime::Runtime,
    pub(super) cluster: &'a ClusterSection,
    pub(super) ops_stream: &'a stream::Stream,
    pub(super) stream_id: StreamId,
    /// The stream's last position.
    pub(super) last: u64,
    /// How long reading the stream up to the snapshot may take.
    pub(super) wait: Duration,
}

impl StreamCheck<'_> {
    /// Whether the message at the record's attestation position is a configured
    /// owner's attestation of this very record (position, ops hash, document).
    fn attested(&self, rec: &SnapshotRecord) -> Result<(), SnapshotError> {
        let at = rec.attested_at;
        let msg = self
            .rt
            .block_on(self.ops_stream.get_raw_message(at))
            .map_err(|e| SnapshotError::AttestationRead {
                at,
                source: Box::new(e),
            })?;
        let subject = msg.subject.to_string();
        let subjects = self.cluster.subjects();
        let get = |name: &str| msg.headers.get(name).map(|v| v.as_str().to_string());
        let owner = subjects
            .op_owner(&subject)
            .filter(|o| self.cluster.owners().iter().any(|c| c == o));
        let from_owner = owner.is_some_and(|o| get(HDR_OWNER).is_none_or(|h| h == o));
        let attestation = serde_json::from_slice::<Attestation>(&msg.payload).ok();
        match attestation {
            Some(a) if from_owner && get(HDR_KIND).as_deref() == Some(KIND_SNAPSHOT) => {
                rec.vouched_by(&a)
            }
            _ => Err(SnapshotError::NoAttestation { at, subject }),
        }
    }

    /// The [`OpsHash`] of the stream's positions `1..=seq`, read in order.
    fn ops_hash(&self, seq: u64) -> Result<OpsHash, SnapshotError> {
        let (tx, rx) = mpsc::channel();
        let task = self.rt.spawn(follow_stream(
            self.ops_stream.clone(),
            self.cluster.subjects().ops,
            1,
            tx,
        ));
        let deadline = Instant::now() + self.wait;
        let mut hash = OpsHash::EMPTY;
        let mut at = 0;
        let result = loop {
            if at >= seq {
                break Ok(hash);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match rx.recv_timeout(left) {
                Ok(m) => {
                    at = m.seq;
                    if at <= seq {
                        hash = hash.next(m.seq, &m.subject, m.kind.as_deref(), &m.payload);
                    }
                }
                Err(_) => {
                    break Err(SnapshotError::StreamRead {
                        seq,
                        source: NatsFailure::ConsumerEnded,
                    });
                }
            }
        };
        task.abort();
        result
    }

    /// Fetches the latest snapshot and checks it: its bytes, its session and stream,
    /// its attestation in the stream and the stream's ops hash up to it; a good one's
    /// document is written to the session directory ([`SNAPSHOT_SCENE_FILE`]) for the
    /// session to open. `Err(None)`: there is none yet.
    fn load(
        &self,
        store: &async_nats::jetstream::object_store::ObjectStore,
        dir: &std::path::Path,
    ) -> Result<(SnapshotRecord, PathBuf), Option<SnapshotError>> {
        let bytes = self.rt.block_on(snapshot::fetch(store))?.ok_or(None)?;
        let rec = SnapshotRecord::decode(&bytes)?;
        rec.check(&self.cluster.session, self.stream_id, self.last)?;
        self.attested(&rec)?;
        let stream = self.ops_hash(rec.seq)?;
        if stream != rec.ops_hash {
            return Err(Some(SnapshotError::OpsHash {
                seq: rec.seq,
                stream,
                record: rec.ops_hash,
            }));
        }
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

    /// The latest good snapshot of the session, when there is one: the bucket
    /// (`None`: it could not be had), the record, and what happened (in the report).
    /// An owner creates the bucket, a render node only opens it. A good snapshot's
    /// document becomes the base scene (`files.scene`), written into the session
    /// directory; anything wrong is logged once and the node replays the whole stream.
    pub(super) fn latest(
        &self,
        js: &async_nats::jetstream::Context,
        owner: bool,
        files: &mut crate::config::FilesConfig,
    ) -> (
        Option<async_nats::jetstream::object_store::ObjectStore>,
        Option<SnapshotRecord>,
        SnapshotReport,
    ) {
        let mut snap_report = SnapshotReport::default();
        let bucket = self.cluster.subjects().snapshots;
        let store = if owner {
            self.rt.block_on(snapshot::bucket(js, &bucket))
        } else {
            self.rt.block_on(snapshot::open_bucket(js, &bucket))
        };
        match store {
            Ok(store) => {
                let mut loaded = None;
                match self.load(&store, &files.dir) {
                    Ok((rec, path)) => {
                        tracing::info!(
                            seq = rec.seq,
                            writer = %rec.writer,
                            "starting from the snapshot"
                        );
                        files.scene = Some(path);
                        snap_report.loaded_seq = Some(rec.seq);
                        loaded = Some(rec);
                    }
                    Err(reason) => {
                        let text = reason.map_or_else(
                            || "no snapshot stored".to_string(),
                            |e| sculpt_core::error::Chain(&e).to_string(),
                        );
                        if text != "no snapshot stored" {
                            tracing::warn!("snapshot not used, replaying the whole stream: {text}");
                        }
                        snap_report.fallback = Some(text);
                    }
                }
                (Some(store), loaded, snap_report)
            }
            Err(e) => {
                let text = sculpt_core::error::Chain(&e).to_string();
                tracing::warn!("no snapshot bucket, replaying the whole stream: {text}");
                snap_report.fallback = Some(text);
                (None, None, snap_report)
            }
        }
    }
}
