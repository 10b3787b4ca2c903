//! The operation stream: its records, and a task that follows it in order.

use std::sync::mpsc;
use std::time::Duration;

use async_nats::jetstream::{self, consumer, stream};
use futures_util::StreamExt;
use sculpt_core::interaction::Edit;
use serde::{Deserialize, Serialize};

use crate::cluster::snapshot::StreamId;
use crate::cluster::{ClusterError, HDR_KIND, HDR_OWNER, HDR_SENT, NatsFailure, Subjects, header};

/// Further tries at creating (or finding) the operation stream, and the pause between.
pub(super) const STREAM_ATTEMPTS: u32 = 10;
pub(super) const STREAM_RETRY: Duration = Duration::from_millis(300);

/// How long an owner waits for JetStream to acknowledge one publish before retrying.
pub(super) const ACK_WAIT: Duration = Duration::from_secs(2);

/// One operation in the stream: the body of a `<session>.ops.<owner>` message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpRecord {
    /// Session time of the operation (seconds).
    pub t: f64,
    /// The operation.
    pub edit: Edit,
}

/// One stream message as the ops task hands it over.
#[derive(Debug)]
pub(super) struct OpMsg {
    pub(super) seq: u64,
    /// `<session>.ops.<owner>`: the owner the server let publish it.
    pub(super) subject: String,
    pub(super) kind: Option<String>,
    pub(super) owner: Option<String>,
    pub(super) sent_ns: Option<u64>,
    pub(super) payload: Vec<u8>,
}

/// Follows the operation stream with an ordered consumer from position `start` on,
/// recreating it after an error (a server restart), and hands every message over in
/// order.
pub(super) async fn follow_stream(
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
                subject: m.message.subject.to_string(),
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

/// Finds (or, for an owner, creates) the session's operation stream: the stream, its
/// last position and its identity. Nodes starting together race to create the stream,
/// and a server just started may not have JetStream ready yet: this retries for a
/// while before giving up. A render node may not create it (its user may not): it
/// waits up to `wait` for an owner to.
pub(super) fn open_stream(
    rt: &tokio::runtime::Runtime,
    js: &jetstream::Context,
    subjects: &Subjects,
    create: bool,
    wait: Duration,
) -> Result<(stream::Stream, u64, StreamId), ClusterError> {
    let jserr =
        |what: &'static str| move |e: NatsFailure| ClusterError::JetStream { what, source: e };
    let stream_config = stream::Config {
        name: subjects.stream.clone(),
        subjects: vec![subjects.ops.clone()],
        storage: stream::StorageType::File,
        ..Default::default()
    };
    let mut attempt = 0;
    let deadline = std::time::Instant::now() + wait;
    let mut ops_stream = loop {
        if create {
            match rt.block_on(js.get_or_create_stream(stream_config.clone())) {
                Ok(stream) => break stream,
                Err(e) if attempt < STREAM_ATTEMPTS => {
                    attempt += 1;
                    tracing::warn!("creating the operation stream: {e}; retrying");
                    std::thread::sleep(STREAM_RETRY);
                }
                Err(e) => return Err(jserr("stream")(e.into())),
            }
        } else {
            match rt.block_on(js.get_stream(&subjects.stream)) {
                Ok(stream) => break stream,
                Err(e) if std::time::Instant::now() < deadline => {
                    if attempt == 0 {
                        tracing::info!("waiting for an owner to create the operation stream: {e}");
                    }
                    attempt += 1;
                    std::thread::sleep(STREAM_RETRY);
                }
                Err(e) => return Err(jserr("stream")(e.into())),
            }
        }
    };
    let info = rt
        .block_on(ops_stream.info())
        .map_err(|e| jserr("stream info")(e.into()))?;
    let stream_last = info.state.last_sequence;
    let stream_id = StreamId {
        created_unix_ns: i64::try_from(info.created.unix_timestamp_nanos()).unwrap_or(i64::MAX),
    };
    Ok((ops_stream, stream_last, stream_id))
}
