//! A node's snapshots: loading the latest at start, writing them (the writer), and
//! rebuilding when the stream undoes a step older than the loaded one.

use std::path::PathBuf;
use std::sync::mpsc;
use std::time::Instant;

use async_nats::jetstream::stream;

use super::SNAPSHOT_SCENE_FILE;
use super::replica::Node;
use super::report::SnapshotReport;
use super::stream::{OpRecord, follow_stream};
use crate::app::AppState;
use crate::cluster::barrier::Barrier;
use crate::cluster::snapshot::{self, SnapshotError, SnapshotRecord, StreamId};
use crate::cluster::{ClusterError, ClusterSection, KIND_EDIT, NatsFailure};
use crate::error::{VrError, VrResult};

/// A node's snapshot state.
pub(super) struct Snapshots {
    /// The bucket (`None`: snapshots off, or the bucket could not be had).
    pub(super) store: Option<async_nats::jetstream::object_store::ObjectStore>,
    pub(super) session: String,
    pub(super) stream: StreamId,
    /// The stream (to rebuild the document from its start).
    pub(super) ops_stream: stream::Stream,
    /// Write one every this many positions (0: only at the end).
    pub(super) every: u64,
    /// The position the document was loaded at, until a rebuild: undoing a step older
    /// than it needs the whole stream.
    pub(super) loaded: Option<u64>,
    /// The base scene before the snapshot replaced it (`None`: the default document).
    pub(super) base_scene: Option<PathBuf>,
    /// The snapshot being stored.
    pub(super) writing: Option<tokio::task::JoinHandle<Result<(), SnapshotError>>>,
    pub(super) report: SnapshotReport,
}

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

/// Fetches, checks and keeps the latest snapshot: its document is written to the
/// session directory ([`SNAPSHOT_SCENE_FILE`]) for the session to open. `Err(None)`:
/// there is none yet.
pub(super) async fn load_snapshot(
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

/// The latest good snapshot of the session, when there is one: the bucket (`None`:
/// it could not be had), the record, and what happened (in the report). A good one's
/// document becomes the base scene (`files.scene`), written into the session
/// directory; anything wrong is logged once and the node replays the whole stream.
pub(super) fn latest_snapshot(
    rt: &tokio::runtime::Runtime,
    js: &async_nats::jetstream::Context,
    cluster: &ClusterSection,
    stream_id: StreamId,
    stream_last: u64,
    files: &mut crate::config::FilesConfig,
) -> (
    Option<async_nats::jetstream::object_store::ObjectStore>,
    Option<SnapshotRecord>,
    SnapshotReport,
) {
    let mut snap_report = SnapshotReport::default();
    match rt.block_on(snapshot::bucket(js, &cluster.subjects().snapshots)) {
        Ok(store) => {
            let mut loaded = None;
            match rt.block_on(load_snapshot(
                &store,
                &cluster.session,
                stream_id,
                stream_last,
                &files.dir,
            )) {
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
