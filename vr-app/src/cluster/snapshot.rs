//! Document snapshots of a session's operation stream: a node that joins late or
//! restarts loads the latest snapshot and replays only the rest of the stream.
//!
//! A snapshot lives in the JetStream object store `WS_<session>_snap`, object
//! [`OBJECT`], as one [`SnapshotRecord`] (see [`SnapshotRecord::encode`] for the
//! bytes): the document ([`Document::to_json`](sculpt_core::sculpt::document::Document::to_json) bytes) after the stream's positions
//! `1..=seq`, the owners whose end markers are among them, the stream's creation time
//! and a checksum over everything. Who writes it and when: see `docs/cluster.md`
//! ("Snapshots") and [`super::node`].
//!
//! A snapshot is never trusted blindly: [`SnapshotRecord::decode`] refuses bad bytes
//! (magic, truncation, checksum) and [`SnapshotRecord::check`] one that belongs to
//! another session or stream or lies beyond the stream's end; the node then logs why
//! once and replays the whole stream.
//!
//! ```
//! use vr_app::cluster::snapshot::{SnapshotRecord, StreamId};
//! let rec = SnapshotRecord {
//!     session: "cave1".into(),
//!     stream: StreamId { created_unix_ns: 7 },
//!     seq: 12,
//!     ends: vec!["front".into()],
//!     writer: "front".into(),
//!     document: b"{}".to_vec(),
//! };
//! let bytes = rec.encode()?;
//! assert_eq!(SnapshotRecord::decode(&bytes)?, rec);
//! assert!(SnapshotRecord::decode(&bytes[..bytes.len() - 1]).is_err());
//! # Ok::<(), vr_app::cluster::snapshot::SnapshotError>(())
//! ```

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The object holding a session's latest snapshot in its bucket.
pub const OBJECT: &str = "latest";

/// The record's first bytes (format version 1).
pub const MAGIC: &[u8; 8] = b"WSSNAP\x00\x01";

/// The largest metadata block accepted (names and end markers; far below this).
const MAX_META: usize = 64 * 1024;

/// Which stream a snapshot was taken from: the stream's creation time. A stream
/// deleted and created again under the same name is another stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StreamId {
    /// The stream's creation time, Unix nanoseconds (JetStream's stream info).
    pub created_unix_ns: i64,
}

/// One snapshot: the document after the stream's positions `1..=seq`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SnapshotRecord {
    /// The session (`[cluster] session`).
    pub session: String,
    /// The stream it was taken from.
    pub stream: StreamId,
    /// The last stream position it covers.
    pub seq: u64,
    /// The owners whose end markers are at or before `seq`.
    pub ends: Vec<String>,
    /// The node that wrote it (for the logs).
    pub writer: String,
    /// The document, [`sculpt_core::sculpt::document::Document::to_json`] bytes.
    pub document: Vec<u8>,
}

/// The record's metadata block (JSON).
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Meta {
    session: String,
    stream: StreamId,
    seq: u64,
    ends: Vec<String>,
    writer: String,
}

/// Why a snapshot was not used (the node replays the whole stream instead).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SnapshotError {
    /// The bytes do not start with [`MAGIC`].
    #[error("not a snapshot record (bad magic)")]
    Magic,
    /// The record ends early.
    #[error("truncated: {need} bytes needed, {have} present")]
    Truncated {
        /// Bytes the header says there are (at least).
        need: u64,
        /// Bytes present.
        have: u64,
    },
    /// Bytes follow the checksum.
    #[error("{0} bytes after the checksum")]
    Trailing(u64),
    /// The checksum does not match the bytes.
    #[error("checksum mismatch: stored {stored:016x}, computed {computed:016x}")]
    Checksum {
        /// The checksum in the record.
        stored: u64,
        /// The checksum of the bytes.
        computed: u64,
    },
    /// The metadata block is too large to be a record's.
    #[error("metadata block of {0} bytes")]
    MetaTooLarge(u64),
    /// The metadata block is not the record's JSON.
    #[error("metadata")]
    Meta(#[source] serde_json::Error),
    /// The metadata could not be encoded.
    #[error("encoding the metadata")]
    Encode(#[source] serde_json::Error),
    /// The snapshot is another session's.
    #[error("snapshot of session {found:?}, this is {expected:?}")]
    WrongSession {
        /// The session in the record.
        found: String,
        /// This node's session.
        expected: String,
    },
    /// The snapshot was taken from another stream of the same name (deleted and
    /// created again since).
    #[error("snapshot of a stream created at {found} ns, this one was created at {expected} ns")]
    WrongStream {
        /// The record's stream creation time.
        found: i64,
        /// This stream's.
        expected: i64,
    },
    /// The snapshot covers positions the stream does not have.
    #[error("snapshot covers position {seq}, the stream ends at {last}")]
    BeyondStream {
        /// The record's last position.
        seq: u64,
        /// The stream's last position.
        last: u64,
    },
    /// The document does not load.
    #[error("its document")]
    Document(#[source] Box<sculpt_core::Error>),
    /// The document could not be kept in the session directory (the base scene the
    /// session opens).
    #[error("writing its document")]
    Write(#[source] Box<crate::error::VrError>),
    /// Fetching or storing it failed.
    #[error("object store {what}")]
    Store {
        /// `bucket`, `get`, `read`, `put`.
        what: &'static str,
        /// The client's error.
        #[source]
        source: StoreFailure,
    },
}

/// The object store client's error.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum StoreFailure {
    /// Creating or finding the bucket.
    #[error(transparent)]
    Bucket(#[from] async_nats::jetstream::context::CreateObjectStoreError),
    /// Getting the object.
    #[error(transparent)]
    Get(#[from] async_nats::jetstream::object_store::GetError),
    /// Reading its bytes (a bad digest, a lost chunk).
    #[error(transparent)]
    Read(#[from] std::io::Error),
    /// Storing it.
    #[error(transparent)]
    Put(#[from] async_nats::jetstream::object_store::PutError),
}

/// FNV-1a, 64 bits: the record's checksum (it detects damage, not forgery; the
/// server's credentials keep strangers out). The journal's document id uses it too.
pub use crate::journal::fnv1a64;

/// Reads `n` bytes at `*at`, or says how many were needed.
fn take<'a>(bytes: &'a [u8], at: &mut usize, n: u64) -> Result<&'a [u8], SnapshotError> {
    let have = bytes.len() as u64;
    let end = (*at as u64).saturating_add(n);
    if end > have {
        return Err(SnapshotError::Truncated { need: end, have });
    }
    // `end <= bytes.len()`, so it fits in usize.
    let slice = &bytes[*at..end as usize];
    *at = end as usize;
    Ok(slice)
}

fn u32_at(bytes: &[u8], at: &mut usize) -> Result<u32, SnapshotError> {
    let b = take(bytes, at, 4)?;
    Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn u64_at(bytes: &[u8], at: &mut usize) -> Result<u64, SnapshotError> {
    let b = take(bytes, at, 8)?;
    let mut a = [0u8; 8];
    a.copy_from_slice(b);
    Ok(u64::from_le_bytes(a))
}

impl SnapshotRecord {
    /// The record's bytes: [`MAGIC`], the metadata length (`u32` little-endian), the
    /// metadata (JSON: session, stream, seq, ends, writer), the document length
    /// (`u64` LE), the document, and the [`fnv1a64`] of everything before (`u64` LE).
    pub fn encode(&self) -> Result<Vec<u8>, SnapshotError> {
        let meta = serde_json::to_vec(&Meta {
            session: self.session.clone(),
            stream: self.stream,
            seq: self.seq,
            ends: self.ends.clone(),
            writer: self.writer.clone(),
        })
        .map_err(SnapshotError::Encode)?;
        let meta_len = u32::try_from(meta.len())
            .ok()
            .filter(|&n| n as usize <= MAX_META)
            .ok_or(SnapshotError::MetaTooLarge(meta.len() as u64))?;
        let mut out = Vec::with_capacity(8 + 4 + meta.len() + 8 + self.document.len() + 8);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&meta_len.to_le_bytes());
        out.extend_from_slice(&meta);
        out.extend_from_slice(&(self.document.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.document);
        let sum = fnv1a64(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        Ok(out)
    }

    /// Reads a record; any damage is an error, never a panic.
    pub fn decode(bytes: &[u8]) -> Result<Self, SnapshotError> {
        let mut at = 0usize;
        if take(bytes, &mut at, MAGIC.len() as u64).map_err(|_| SnapshotError::Magic)? != MAGIC {
            return Err(SnapshotError::Magic);
        }
        let meta_len = u64::from(u32_at(bytes, &mut at)?);
        if meta_len > MAX_META as u64 {
            return Err(SnapshotError::MetaTooLarge(meta_len));
        }
        let meta = take(bytes, &mut at, meta_len)?;
        let doc_len = u64_at(bytes, &mut at)?;
        let document = take(bytes, &mut at, doc_len)?;
        let covered = at;
        let stored = u64_at(bytes, &mut at)?;
        if at < bytes.len() {
            return Err(SnapshotError::Trailing((bytes.len() - at) as u64));
        }
        let computed = fnv1a64(&bytes[..covered]);
        if stored != computed {
            return Err(SnapshotError::Checksum { stored, computed });
        }
        let meta: Meta = serde_json::from_slice(meta).map_err(SnapshotError::Meta)?;
        Ok(Self {
            session: meta.session,
            stream: meta.stream,
            seq: meta.seq,
            ends: meta.ends,
            writer: meta.writer,
            document: document.to_vec(),
        })
    }

    /// Whether this snapshot may stand for the positions `1..=seq` of this session's
    /// stream (`stream`, whose last position is `last`).
    pub fn check(&self, session: &str, stream: StreamId, last: u64) -> Result<(), SnapshotError> {
        if self.session != session {
            return Err(SnapshotError::WrongSession {
                found: self.session.clone(),
                expected: session.to_string(),
            });
        }
        if self.stream != stream {
            return Err(SnapshotError::WrongStream {
                found: self.stream.created_unix_ns,
                expected: stream.created_unix_ns,
            });
        }
        if self.seq > last {
            return Err(SnapshotError::BeyondStream {
                seq: self.seq,
                last,
            });
        }
        Ok(())
    }
}

/// The session's snapshot bucket (created when missing).
pub async fn bucket(
    js: &async_nats::jetstream::Context,
    name: &str,
) -> Result<async_nats::jetstream::object_store::ObjectStore, SnapshotError> {
    js.create_object_store(async_nats::jetstream::object_store::Config {
        bucket: name.to_string(),
        description: Some("wandsculpt document snapshots".into()),
        storage: async_nats::jetstream::stream::StorageType::File,
        ..Default::default()
    })
    .await
    .map_err(|e| SnapshotError::Store {
        what: "bucket",
        source: e.into(),
    })
}

/// The bytes of the latest snapshot; `Ok(None)` when there is none yet.
pub async fn fetch(
    store: &async_nats::jetstream::object_store::ObjectStore,
) -> Result<Option<Vec<u8>>, SnapshotError> {
    use async_nats::jetstream::object_store::GetErrorKind;
    use tokio::io::AsyncReadExt;
    let mut object = match store.get(OBJECT).await {
        Ok(o) => o,
        Err(e) if e.kind() == GetErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(SnapshotError::Store {
                what: "get",
                source: e.into(),
            });
        }
    };
    let mut bytes = Vec::new();
    object
        .read_to_end(&mut bytes)
        .await
        .map_err(|e| SnapshotError::Store {
            what: "read",
            source: e.into(),
        })?;
    Ok(Some(bytes))
}

/// Stores `bytes` as the latest snapshot (replacing the one before).
pub async fn store(
    store: &async_nats::jetstream::object_store::ObjectStore,
    bytes: Vec<u8>,
) -> Result<(), SnapshotError> {
    store
        .put(OBJECT, &mut std::io::Cursor::new(bytes))
        .await
        .map_err(|e| SnapshotError::Store {
            what: "put",
            source: e.into(),
        })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn record() -> SnapshotRecord {
        SnapshotRecord {
            session: "s1".into(),
            stream: StreamId {
                created_unix_ns: 1_700_000_000_000_000_000,
            },
            seq: 40,
            ends: vec!["a".into()],
            writer: "a".into(),
            document: sculpt_core::editor::default_document().to_json(),
        }
    }

    #[test]
    fn fnv1a64_matches_the_published_test_vectors() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn damage_is_named() {
        let bytes = record().encode().unwrap();
        assert!(matches!(
            SnapshotRecord::decode(b"garbage"),
            Err(SnapshotError::Magic)
        ));
        assert!(matches!(
            SnapshotRecord::decode(&bytes[..bytes.len() - 3]),
            Err(SnapshotError::Truncated { .. })
        ));
        let mut flipped = bytes.clone();
        flipped[bytes.len() / 2] ^= 0x20;
        assert!(matches!(
            SnapshotRecord::decode(&flipped),
            Err(SnapshotError::Checksum { .. })
        ));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(matches!(
            SnapshotRecord::decode(&longer),
            Err(SnapshotError::Trailing(1))
        ));
    }

    #[test]
    fn a_snapshot_of_another_session_stream_or_beyond_the_stream_is_refused() {
        let r = record();
        assert!(r.check("s1", r.stream, 40).is_ok());
        assert!(r.check("s1", r.stream, 90).is_ok());
        assert!(matches!(
            r.check("s2", r.stream, 90),
            Err(SnapshotError::WrongSession { .. })
        ));
        assert!(matches!(
            r.check(
                "s1",
                StreamId {
                    created_unix_ns: 5
                },
                90
            ),
            Err(SnapshotError::WrongStream { found, expected: 5 }) if found == r.stream.created_unix_ns
        ));
        assert!(matches!(
            r.check("s1", r.stream, 39),
            Err(SnapshotError::BeyondStream { seq: 40, last: 39 })
        ));
    }

    /// Arbitrary bytes, and real records cut short or with one byte changed, decode
    /// to an error or a record, never a panic; every generated case is accepted.
    #[test]
    fn decode_never_panics() {
        use proptest::test_runner::{Config, TestRunner};
        let good = record().encode().unwrap();
        let accepted = std::cell::Cell::new(0u32);
        let mut runner = TestRunner::new(Config::with_cases(512));
        let cases = (
            proptest::collection::vec(any::<u8>(), 0..256),
            any::<prop::sample::Index>(),
            any::<prop::sample::Index>(),
        );
        runner
            .run(&cases, |(bytes, cut, flip)| {
                let _ = SnapshotRecord::decode(&bytes);
                prop_assert!(SnapshotRecord::decode(&good[..cut.index(good.len())]).is_err());
                let mut bad = good.clone();
                let i = flip.index(bad.len());
                bad[i] = bad[i].wrapping_add(1);
                prop_assert!(SnapshotRecord::decode(&bad).is_err());
                accepted.set(accepted.get() + 1);
                Ok(())
            })
            .unwrap();
        assert!(accepted.get() >= 512, "{} cases", accepted.get());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Any record decodes to itself.
        #[test]
        fn round_trip(
            session in "[A-Za-z0-9_-]{1,64}",
            created in any::<i64>(),
            seq in any::<u64>(),
            ends in proptest::collection::vec("[a-z]{1,8}", 0..4),
            writer in "[a-z]{0,8}",
            document in proptest::collection::vec(any::<u8>(), 0..512),
        ) {
            let rec = SnapshotRecord {
                session,
                stream: StreamId { created_unix_ns: created },
                seq,
                ends,
                writer,
                document,
            };
            let bytes = rec.encode().unwrap();
            prop_assert_eq!(SnapshotRecord::decode(&bytes).unwrap(), rec);
        }
    }
}
