//! Document snapshots of a session's operation stream: a node that joins late or
//! restarts loads the latest snapshot and replays only the rest of the stream.
//!
//! A snapshot lives in the JetStream object store `WS_<session>_snap`, object
//! [`OBJECT`], as one [`SnapshotRecord`] (see [`SnapshotRecord::encode`] for the
//! bytes): the document ([`Document::to_json`](sculpt_core::sculpt::document::Document::to_json) bytes) after the stream's positions
//! `1..=seq`, the owners whose end markers are among them, the stream's creation time,
//! the [`OpsHash`] of the stream's positions `1..=seq`, the stream position of its
//! [`Attestation`] and a checksum over everything (it detects damage only: anyone can
//! recompute it). Who writes it and when: see `docs/cluster.md` ("Snapshots") and
//! [`super::node`].
//!
//! A snapshot is never trusted blindly. [`SnapshotRecord::decode`] refuses bad bytes
//! (magic, truncation, checksum) and [`SnapshotRecord::check`] one that belongs to
//! another session or stream or lies beyond the stream's end. Then the node checks it
//! against the operation stream, which only owners can write: the attestation the
//! writer published there (a configured owner's subject) must name the record's
//! position, ops hash and the SHA-256 of its document, and the stream's positions
//! `1..=seq` must hash to the record's ops hash. A snapshot that fails any check is
//! logged once and the node replays the whole stream.
//!
//! ```
//! use vr_app::cluster::snapshot::{OpsHash, SnapshotRecord, StreamId};
//! let rec = SnapshotRecord {
//!     session: "cave1".into(),
//!     stream: StreamId { created_unix_ns: 7 },
//!     seq: 12,
//!     ends: vec!["front".into()],
//!     writer: "front".into(),
//!     ops_hash: OpsHash::EMPTY,
//!     attested_at: 13,
//!     document: b"{}".to_vec(),
//! };
//! let bytes = rec.encode()?;
//! assert_eq!(SnapshotRecord::decode(&bytes)?, rec);
//! assert!(SnapshotRecord::decode(&bytes[..bytes.len() - 1]).is_err());
//! # Ok::<(), vr_app::cluster::snapshot::SnapshotError>(())
//! ```

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use thiserror::Error;

/// The object holding a session's latest snapshot in its bucket.
pub const OBJECT: &str = "latest";

/// The record's first bytes (format version 2: the ops hash and the attestation's
/// position).
pub const MAGIC: &[u8; 8] = b"WSSNAP\x00\x02";

/// [`super::HDR_KIND`] of a snapshot's [`Attestation`] in the operation stream.
pub const KIND_SNAPSHOT: &str = "snapshot";

/// The running SHA-256 over a stream's messages, in order: `h(n) = SHA-256(h(n-1) ||
/// seq || subject || kind || payload)` (each field length-prefixed, little-endian),
/// from [`OpsHash::EMPTY`]. It stands for the stream's content up to a position: a
/// message removed, changed or reordered changes every hash after it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct OpsHash(pub [u8; 32]);

impl OpsHash {
    /// The hash of no message.
    pub const EMPTY: OpsHash = OpsHash([0; 32]);

    /// The hash after one more message: stream position `seq` on `subject`, its
    /// [`super::HDR_KIND`] header (if any) and its body.
    pub fn next(&self, seq: u64, subject: &str, kind: Option<&str>, payload: &[u8]) -> OpsHash {
        let mut h = Sha256::new();
        h.update(self.0);
        h.update(seq.to_le_bytes());
        for field in [subject.as_bytes(), kind.unwrap_or("").as_bytes(), payload] {
            h.update((field.len() as u64).to_le_bytes());
            h.update(field);
        }
        OpsHash(h.finalize().into())
    }

    /// Lower-case hex.
    pub fn hex(&self) -> String {
        hex(&self.0)
    }
}

impl std::fmt::Display for OpsHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.hex())
    }
}

impl Serialize for OpsHash {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.hex())
    }
}

impl<'de> Deserialize<'de> for OpsHash {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        let bytes = (0..text.len())
            .step_by(2)
            .map(|i| {
                text.get(i..i + 2)
                    .and_then(|b| u8::from_str_radix(b, 16).ok())
            })
            .collect::<Option<Vec<u8>>>()
            .filter(|b| b.len() == 32 && text.len() == 64)
            .ok_or_else(|| serde::de::Error::custom("an ops hash is 64 hex digits"))?;
        let mut a = [0u8; 32];
        a.copy_from_slice(&bytes);
        Ok(OpsHash(a))
    }
}

/// Lower-case hex of `bytes`.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The SHA-256 of a snapshot's document, hex.
pub fn document_hash(document: &[u8]) -> String {
    hex(&Sha256::digest(document))
}

/// What the snapshot writer publishes into the operation stream (on its own owner
/// subject, kind [`KIND_SNAPSHOT`]) before it stores a snapshot: the position the
/// snapshot covers, the [`OpsHash`] of the positions up to it and the SHA-256 of its
/// document. Only owners can write the stream, so a loader trusts a snapshot only
/// when such a message from a configured owner vouches for it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Attestation {
    /// The last stream position the snapshot covers.
    pub seq: u64,
    /// The [`OpsHash`] of positions `1..=seq`.
    pub ops: OpsHash,
    /// [`document_hash`] of the snapshot's document.
    pub doc: String,
}

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
    /// The [`OpsHash`] of the stream's positions `1..=seq`.
    pub ops_hash: OpsHash,
    /// The stream position of the writer's [`Attestation`] of this snapshot.
    pub attested_at: u64,
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
    ops_hash: OpsHash,
    attested_at: u64,
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
    /// The attestation's position is not after the snapshot's and within the stream.
    #[error("attested at stream position {at}, outside {seq}+1..={last}")]
    AttestationOutside {
        /// The record's attestation position.
        at: u64,
        /// The record's last position.
        seq: u64,
        /// The stream's last position.
        last: u64,
    },
    /// The attestation could not be read from the stream.
    #[error("reading its attestation at stream position {at}")]
    AttestationRead {
        /// The stream position.
        at: u64,
        /// The client's error.
        #[source]
        source: Box<async_nats::jetstream::stream::RawMessageError>,
    },
    /// The message at the attestation's position is not a configured owner's
    /// attestation.
    #[error("stream position {at} ({subject}) is no configured owner's snapshot attestation")]
    NoAttestation {
        /// The stream position.
        at: u64,
        /// Its subject.
        subject: String,
    },
    /// The attestation does not vouch for this record (a doctored snapshot).
    #[error("its {what} is {record}, but the attestation at stream position {at} says {attested}")]
    NotAttested {
        /// The attestation's stream position.
        at: u64,
        /// What differs: `position`, `ops hash`, `document SHA-256`.
        what: &'static str,
        /// The attested value.
        attested: String,
        /// The record's.
        record: String,
    },
    /// The stream's positions `1..=seq` do not hash to the record's ops hash (the
    /// stream was changed under the snapshot).
    #[error("the stream's positions 1..={seq} hash to {stream}, the snapshot says {record}")]
    OpsHash {
        /// The snapshot's last position.
        seq: u64,
        /// The hash of the stream's positions.
        stream: OpsHash,
        /// The record's.
        record: OpsHash,
    },
    /// The stream could not be read up to the snapshot's position.
    #[error("reading the stream up to position {seq}")]
    StreamRead {
        /// The snapshot's last position.
        seq: u64,
        /// Why (the consumer's task ended, or it timed out).
        #[source]
        source: super::NatsFailure,
    },
    /// The writer could not publish its attestation.
    #[error("publishing the attestation")]
    Attest(#[source] super::NatsFailure),
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
    /// Opening the bucket.
    #[error(transparent)]
    Open(#[from] async_nats::jetstream::context::ObjectStoreError),
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

/// FNV-1a, 64 bits: the record's checksum (it detects damage, not forgery: the
/// attestation in the operation stream does that). The journal's document id uses it too.
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
            ops_hash: self.ops_hash,
            attested_at: self.attested_at,
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
            ops_hash: meta.ops_hash,
            attested_at: meta.attested_at,
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
        if self.attested_at <= self.seq || self.attested_at > last {
            return Err(SnapshotError::AttestationOutside {
                at: self.attested_at,
                seq: self.seq,
                last,
            });
        }
        Ok(())
    }

    /// Whether the attestation found at the record's [`Self::attested_at`] (a
    /// configured owner's, the caller checked) vouches for this record: the same
    /// position, ops hash and document.
    pub fn vouched_by(&self, a: &Attestation) -> Result<(), SnapshotError> {
        let mismatch = |what: &'static str, attested: String, record: String| {
            Err(SnapshotError::NotAttested {
                at: self.attested_at,
                what,
                attested,
                record,
            })
        };
        if a.seq != self.seq {
            return mismatch("position", a.seq.to_string(), self.seq.to_string());
        }
        if a.ops != self.ops_hash {
            return mismatch("ops hash", a.ops.hex(), self.ops_hash.hex());
        }
        let doc = document_hash(&self.document);
        if a.doc != doc {
            return mismatch("document SHA-256", a.doc.clone(), doc);
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

/// The session's snapshot bucket, opened (not created: a render node may not create
/// it).
pub async fn open_bucket(
    js: &async_nats::jetstream::Context,
    name: &str,
) -> Result<async_nats::jetstream::object_store::ObjectStore, SnapshotError> {
    js.get_object_store(name)
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
            ops_hash: OpsHash::EMPTY.next(1, "s1.ops.a", Some("edit"), b"{}"),
            attested_at: 41,
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
        // Covers 1..=40, attested at 41.
        assert!(r.check("s1", r.stream, 41).is_ok());
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
        assert!(matches!(
            r.check("s1", r.stream, 40),
            Err(SnapshotError::AttestationOutside { at: 41, .. })
        ));
    }

    /// Regression (issue 31 §10): a snapshot with a stroke removed and its checksum
    /// recomputed decoded and loaded. The attestation in the stream names the
    /// document's SHA-256, which a doctored document cannot match.
    #[test]
    fn a_doctored_document_is_not_vouched_for() {
        let r = record();
        let a = Attestation {
            seq: r.seq,
            ops: r.ops_hash,
            doc: document_hash(&r.document),
        };
        assert!(r.vouched_by(&a).is_ok());
        let mut doctored = r.clone();
        doctored.document.push(b' ');
        let bytes = doctored.encode().unwrap();
        let doctored = SnapshotRecord::decode(&bytes).expect("the checksum is recomputable");
        assert!(matches!(
            doctored.vouched_by(&a),
            Err(SnapshotError::NotAttested {
                what: "document SHA-256",
                ..
            })
        ));
        let other_ops = Attestation {
            ops: OpsHash::EMPTY,
            ..a.clone()
        };
        assert!(matches!(
            r.vouched_by(&other_ops),
            Err(SnapshotError::NotAttested {
                what: "ops hash",
                ..
            })
        ));
        let other_seq = Attestation { seq: 39, ..a };
        assert!(r.vouched_by(&other_seq).is_err());
    }

    #[test]
    fn the_ops_hash_changes_with_every_field_and_the_order() {
        let h = OpsHash::EMPTY;
        let a = h.next(1, "s.ops.a", Some("edit"), b"x");
        assert_ne!(a, h.next(2, "s.ops.a", Some("edit"), b"x"));
        assert_ne!(a, h.next(1, "s.ops.b", Some("edit"), b"x"));
        assert_ne!(a, h.next(1, "s.ops.a", Some("end"), b"x"));
        assert_ne!(a, h.next(1, "s.ops.a", Some("edit"), b"y"));
        // Field boundaries are part of the hash.
        assert_ne!(
            h.next(1, "ab", Some("c"), b""),
            h.next(1, "a", Some("bc"), b"")
        );
        let b = a.next(2, "s.ops.a", None, b"");
        assert_ne!(
            b,
            h.next(2, "s.ops.a", None, b"")
                .next(1, "s.ops.a", Some("edit"), b"x")
        );
        let json = serde_json::to_string(&b).unwrap();
        assert_eq!(json.len(), 66);
        assert_eq!(serde_json::from_str::<OpsHash>(&json).unwrap(), b);
        assert!(serde_json::from_str::<OpsHash>("\"zz\"").is_err());
        // SHA-256 of "abc" (FIPS 180-2, appendix B.1).
        assert_eq!(
            document_hash(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
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
            hash in any::<[u8; 32]>(),
            attested_at in any::<u64>(),
            document in proptest::collection::vec(any::<u8>(), 0..512),
        ) {
            let rec = SnapshotRecord {
                session,
                stream: StreamId { created_unix_ns: created },
                seq,
                ends,
                writer,
                ops_hash: OpsHash(hash),
                attested_at,
                document,
            };
            let bytes = rec.encode().unwrap();
            prop_assert_eq!(SnapshotRecord::decode(&bytes).unwrap(), rec);
        }
    }
}
