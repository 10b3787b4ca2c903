//! The operation journal: every completed operation is appended as one JSON line and
//! fsync'd before it counts, so a crash (even `kill -9`) loses nothing that was
//! reported done.
//!
//! Format (`*.journal`, UTF-8 JSON lines):
//! - line 1, the header: `{"wandsculpt_journal":2,"document":"fnv1a64:…"}`, naming the
//!   document the journal belongs to ([`document_id`]: a hash of the base scene). A
//!   header without `document` (journals written before it was added) is still read;
//!   its entries' targets are then checked against the base scene instead;
//! - then one [`JournalEntry`] per line: `{"seq":0,"t":1.25,"edit":{"edit":"stroke",...}}`,
//!   `seq` counting up from 0 with no gaps. Edits name their target by its id
//!   ([`TargetId`](sculpt_core::interaction::TargetId)).
//!
//! Version 1 (header `{"wandsculpt_journal":1}`) named targets by their position in
//! the document instead. It is still read: [`Journal::version`] says which was opened,
//! the session resolves the positions as it re-applies the entries
//! ([`Edit::with_positions_resolved`]) and rewrites the file as version 2
//! ([`Journal::upgrade`]) before appending to it.
//!
//! **A journal is never changed by a run that cannot use it.** Opening is two steps:
//! [`Journal::recover`] reads and checks the file without changing anything (a journal
//! naming another document is refused with [`JournalError::OtherDocument`]), and only
//! once the caller has checked the entries against its document (the session checks
//! that every target they name exists) does [`Journal::resume`] create the file, cut
//! off a torn final line or (for version 1) [`Journal::upgrade`] it.
//!
//! A final line without its newline that starts like a journal line (a write torn by a
//! crash) is cut off on resume; a final line that does not (binary data, NUL bytes) is
//! [`JournalError::Garbage`], and any other bad line is an error naming its line
//! number: never silently skipped or reset.
//!
//! ```
//! use vr_app::journal::Journal;
//! use sculpt_core::interaction::Edit;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("s.journal");
//! let (mut j, old) = Journal::open(&path, "fnv1a64:0000000000000001")?;
//! assert!(old.is_empty());
//! j.append(0.5, &Edit::Undo)?;
//! drop(j);
//! let (_, recovered) = Journal::open(&path, "fnv1a64:0000000000000001")?;
//! assert_eq!(recovered[0].edit, Edit::Undo);
//! // Another document's run is refused, and the file is left as it was.
//! let before = std::fs::read(&path).unwrap();
//! assert!(Journal::open(&path, "fnv1a64:0000000000000002").is_err());
//! assert_eq!(std::fs::read(&path).unwrap(), before);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use sculpt_core::interaction::Edit;
use sculpt_core::sculpt::document::Document;
use serde::{Deserialize, Serialize};

use crate::error::{JournalError, VrError, VrResult};

/// The journal version this build writes.
pub const VERSION: u32 = 2;
/// The header line of a version 2 journal that names no document (as written before
/// [`document_id`] was added); still read. New journals name their document
/// ([`header_line`]).
pub const HEADER: &str = "{\"wandsculpt_journal\":2}";
/// How every header line starts (a torn header is a prefix of this or starts with it).
const HEADER_START: &str = "{\"wandsculpt_journal\":";
/// How every entry line starts (a torn entry is a prefix of this or starts with it).
const ENTRY_START: &str = "{\"seq\":";
/// A version 1 journal's header line (targets named by position).
pub const HEADER_V1: &str = "{\"wandsculpt_journal\":1}";
/// Longest journal line accepted (bytes); a longer one is corruption.
pub const MAX_LINE: usize = 64 << 20;

/// The id of a document, as a journal names the document it belongs to: the 64-bit
/// FNV-1a hash of its [`Document::to_json`] bytes, `fnv1a64:` and 16 hex digits.
pub fn document_id(doc: &Document) -> String {
    format!("fnv1a64:{:016x}", fnv1a64(&doc.to_json()))
}

/// FNV-1a, 64 bits (Fowler, Noll, Vo; offset basis `0xcbf29ce484222325`, prime
/// `0x100000001b3`): the [`document_id`] hash, and the checksum of a cluster's document
/// snapshots. It detects damage, not forgery.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    bytes
        .iter()
        .fold(OFFSET, |h, &b| (h ^ u64::from(b)).wrapping_mul(PRIME))
}

/// The header line of a [`VERSION`] journal of the document `document`.
pub fn header_line(document: &str) -> String {
    let id = serde_json::Value::String(document.to_owned());
    format!("{{\"wandsculpt_journal\":{VERSION},\"document\":{id}}}")
}

/// The header line as read.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    wandsculpt_journal: u32,
    #[serde(default)]
    document: Option<String>,
}

/// One journalled operation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JournalEntry {
    /// Sequence number, from 0.
    pub seq: u64,
    /// Session time of the operation (seconds).
    pub t: f64,
    /// The operation.
    pub edit: Edit,
}

/// An open journal, appending.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: File,
    next_seq: u64,
    /// The file's version: [`VERSION`], or 1 until [`Journal::upgrade`].
    version: u32,
    /// The document id written into a new or upgraded header.
    document: String,
}

/// A journal read and checked by [`Journal::recover`]; nothing on disk has changed
/// yet. [`Journal::resume`] opens it for appending.
#[derive(Debug)]
pub struct Stored {
    path: PathBuf,
    /// The entries as stored: in a version 1 journal their targets are positions.
    pub entries: Vec<JournalEntry>,
    /// The header's version (1 or [`VERSION`]).
    pub version: u32,
    /// The document the header names (`None` in journals written before documents
    /// were named).
    pub document: Option<String>,
    /// The id of this run's document (checked against `document`).
    expected: String,
    /// The byte length of the intact prefix, and of the file (`None`: no file).
    good: u64,
    len: Option<u64>,
}

fn jerr(path: &Path, reason: JournalError) -> VrError {
    VrError::Journal {
        path: path.display().to_string(),
        reason,
    }
}

fn io(path: &Path, source: std::io::Error) -> VrError {
    VrError::Io {
        path: path.display().to_string(),
        source,
    }
}

impl Journal {
    /// Reads and checks the journal at `path` for the document `document` (its
    /// [`document_id`]) without changing anything on disk. A missing file is an empty
    /// journal. A journal that names another document is
    /// [`JournalError::OtherDocument`]; a bad line is an error naming it.
    pub fn recover(path: impl AsRef<Path>, document: &str) -> VrResult<Stored> {
        let path = path.as_ref().to_path_buf();
        let mut file = match File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Stored {
                    path,
                    entries: Vec::new(),
                    version: VERSION,
                    document: None,
                    expected: document.to_owned(),
                    good: 0,
                    len: None,
                });
            }
            Err(e) => return Err(io(&path, e)),
        };
        let len = file.metadata().map_err(|e| io(&path, e))?.len();
        let read = read_entries(&path, &mut file)?;
        if let Some(found) = &read.document
            && found != document
        {
            return Err(jerr(
                &path,
                JournalError::OtherDocument {
                    found: found.clone(),
                    expected: document.to_owned(),
                },
            ));
        }
        Ok(Stored {
            path,
            entries: read.entries,
            version: read.version,
            document: read.document,
            expected: document.to_owned(),
            good: read.good,
            len: Some(len),
        })
    }

    /// Opens a recovered journal for appending: creates the file (with a header naming
    /// the document) or cuts off a torn final line. A version 1 journal must then be
    /// [`Journal::upgrade`]d before it is appended to.
    pub fn resume(stored: &Stored) -> VrResult<Self> {
        let path = stored.path.clone();
        let mut file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(&path)
            .map_err(|e| io(&path, e))?;
        let mut version = stored.version;
        match stored.len {
            None | Some(0) => {
                file.write_all(format!("{}\n", header_line(&stored.expected)).as_bytes())
                    .map_err(|e| io(&path, e))?;
                file.sync_all().map_err(|e| io(&path, e))?;
                sync_parent(&path);
                version = VERSION;
            }
            Some(len) if stored.good < len => {
                let good = stored.good;
                tracing::warn!(path = %path.display(), cut = len - good, "journal: cutting off a torn final line");
                file.set_len(good).map_err(|e| io(&path, e))?;
                if good == 0 {
                    // Even the header was torn: start the file afresh.
                    file.write_all(format!("{}\n", header_line(&stored.expected)).as_bytes())
                        .map_err(|e| io(&path, e))?;
                    version = VERSION;
                }
                file.sync_all().map_err(|e| io(&path, e))?;
            }
            Some(_) => {}
        }
        let next_seq = stored.entries.last().map_or(0, |e| e.seq + 1);
        Ok(Self {
            path,
            file,
            next_seq,
            version,
            document: stored.expected.clone(),
        })
    }

    /// [`Journal::recover`] then [`Journal::resume`]: opens (or creates) the journal
    /// of the document `document` and returns it with the entries it already holds.
    pub fn open(path: impl AsRef<Path>, document: &str) -> VrResult<(Self, Vec<JournalEntry>)> {
        let stored = Self::recover(path, document)?;
        let journal = Self::resume(&stored)?;
        Ok((journal, stored.entries))
    }

    /// Reads a journal without opening it for writing (a torn tail is ignored). The
    /// entries are as stored: in a version 1 journal their targets are positions.
    pub fn read(path: impl AsRef<Path>) -> VrResult<Vec<JournalEntry>> {
        let path = path.as_ref();
        let mut file = File::open(path).map_err(|e| io(path, e))?;
        Ok(read_entries(path, &mut file)?.entries)
    }

    /// The version of the file as opened: [`VERSION`], or 1 for a journal written
    /// before targets were named by id (see the module docs).
    pub fn version(&self) -> u32 {
        self.version
    }

    /// Rewrites the journal as a [`VERSION`] journal holding `entries` (the opened
    /// entries with their targets resolved to ids), atomically: the new file is
    /// written and fsync'd beside the old one and renamed over it, so a crash leaves
    /// either journal whole. Appending continues after `entries`.
    pub fn upgrade(&mut self, entries: &[JournalEntry]) -> VrResult<()> {
        let tmp = self.path.with_extension("journal.upgrade");
        let mut text = format!("{}\n", header_line(&self.document));
        for entry in entries {
            let line = serde_json::to_string(entry)
                .map_err(|e| jerr(&self.path, JournalError::Encode(e.into())))?;
            text.push_str(&line);
            text.push('\n');
        }
        let write = || -> std::io::Result<File> {
            let mut f = File::create(&tmp)?;
            f.write_all(text.as_bytes())?;
            f.sync_all()?;
            std::fs::rename(&tmp, &self.path)?;
            OpenOptions::new().read(true).append(true).open(&self.path)
        };
        self.file = write().map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            io(&self.path, e)
        })?;
        sync_parent(&self.path);
        self.next_seq = entries.last().map_or(0, |e| e.seq + 1);
        self.version = VERSION;
        Ok(())
    }

    /// Appends an operation and fsyncs; when this returns `Ok` the operation is
    /// durable. Returns its sequence number. A version 1 journal must be upgraded
    /// first ([`Journal::upgrade`]): its edits name targets differently.
    pub fn append(&mut self, t: f64, edit: &Edit) -> VrResult<u64> {
        if self.version != VERSION {
            return Err(jerr(
                &self.path,
                JournalError::NotUpgraded {
                    version: self.version,
                },
            ));
        }
        let entry = JournalEntry {
            seq: self.next_seq,
            t: if t.is_finite() { t } else { 0.0 },
            edit: edit.clone(),
        };
        let mut line = serde_json::to_string(&entry)
            .map_err(|e| jerr(&self.path, JournalError::Encode(e.into())))?;
        line.push('\n');
        self.file
            .write_all(line.as_bytes())
            .map_err(|e| io(&self.path, e))?;
        self.file.sync_data().map_err(|e| io(&self.path, e))?;
        self.next_seq += 1;
        Ok(entry.seq)
    }

    /// Number of operations in the journal.
    pub fn len(&self) -> u64 {
        self.next_seq
    }

    /// True when the journal holds no operations.
    pub fn is_empty(&self) -> bool {
        self.next_seq == 0
    }

    /// The journal's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Makes a newly created file's directory entry durable (best effort).
fn sync_parent(path: &Path) {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
        && let Ok(d) = File::open(dir)
    {
        // Not every filesystem supports fsync on directories; the file itself is synced.
        let _ = d.sync_all();
    }
}

/// A parsed journal.
struct Entries {
    entries: Vec<JournalEntry>,
    /// The byte length of the intact prefix.
    good: u64,
    /// The header's version.
    version: u32,
    /// The document the header names.
    document: Option<String>,
}

/// Whether `torn` (a final line without its newline) can be the start of a line
/// beginning with `start` cut off by a crash: text that agrees with `start` as far as
/// either goes, and no control characters (a file of NUL bytes is not a torn write).
fn is_torn(torn: &[u8], start: &str) -> bool {
    let Ok(text) = std::str::from_utf8(torn) else {
        return false;
    };
    !text.chars().any(char::is_control) && (start.starts_with(text) || text.starts_with(start))
}

/// Parses the journal.
fn read_entries(path: &Path, file: &mut File) -> VrResult<Entries> {
    file.seek(SeekFrom::Start(0)).map_err(|e| io(path, e))?;
    let mut reader = BufReader::new(file.take(u64::MAX));
    let mut entries = Vec::new();
    let mut good: u64 = 0;
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    let mut version = VERSION;
    let mut document = None;
    loop {
        buf.clear();
        let n = (&mut reader)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| io(path, e))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        if buf.last() != Some(&b'\n') {
            if n > MAX_LINE {
                return Err(jerr(
                    path,
                    JournalError::LineTooLong {
                        line: line_no,
                        max: MAX_LINE,
                    },
                ));
            }
            let start = if line_no == 1 {
                HEADER_START
            } else {
                ENTRY_START
            };
            if !is_torn(&buf, start) {
                return Err(jerr(
                    path,
                    JournalError::Garbage {
                        line: line_no,
                        bytes: n,
                    },
                ));
            }
            // Torn final write: stop here, the caller cuts it off.
            break;
        }
        let text = std::str::from_utf8(&buf[..n - 1])
            .map_err(|_| jerr(path, JournalError::NotUtf8 { line: line_no }))?;
        if line_no == 1 {
            let header = serde_json::from_str::<Header>(text.trim())
                .ok()
                .filter(|h| h.wandsculpt_journal == 1 || h.wandsculpt_journal == VERSION);
            let Some(header) = header else {
                return Err(jerr(
                    path,
                    JournalError::NotAJournal {
                        found: truncate(text),
                    },
                ));
            };
            version = header.wandsculpt_journal;
            document = header.document;
        } else {
            let entry: JournalEntry = serde_json::from_str(text).map_err(|e| {
                jerr(
                    path,
                    JournalError::Entry {
                        line: line_no,
                        error: e.into(),
                    },
                )
            })?;
            let want = entries.len() as u64;
            if entry.seq != want {
                return Err(jerr(
                    path,
                    JournalError::Sequence {
                        line: line_no,
                        found: entry.seq,
                        expected: want,
                    },
                ));
            }
            entries.push(entry);
        }
        good += n as u64;
    }
    Ok(Entries {
        entries,
        good,
        version,
        document,
    })
}

fn truncate(s: &str) -> String {
    s.chars().take(60).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::interaction::{DEFAULT_TARGET, StrokeEdit, StrokeSample, Tool};

    /// The document id the tests' journals belong to.
    const DOC: &str = "fnv1a64:00000000000000d0";

    fn stroke() -> Edit {
        Edit::Stroke(StrokeEdit::new(
            DEFAULT_TARGET,
            Tool::default(),
            vec![
                StrokeSample {
                    t: 0.0,
                    position: glam::DVec3::new(0.0, 1.0, 0.0),
                },
                StrokeSample {
                    t: 0.1,
                    position: glam::DVec3::new(0.1, 1.0, 0.0),
                },
            ],
        ))
    }

    #[test]
    fn append_reopen_continue() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.journal");
        let (mut j, old) = Journal::open(&p, DOC).unwrap();
        assert!(old.is_empty());
        assert_eq!(j.append(0.1, &stroke()).unwrap(), 0);
        assert_eq!(j.append(0.2, &Edit::Undo).unwrap(), 1);
        drop(j);
        let (mut j, old) = Journal::open(&p, DOC).unwrap();
        assert_eq!(old.len(), 2);
        assert_eq!(old[0].edit, stroke());
        assert_eq!(j.append(0.3, &Edit::Redo).unwrap(), 2);
        assert_eq!(Journal::read(&p).unwrap().len(), 3);
    }

    #[test]
    fn torn_tail_is_cut_and_appending_continues() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.journal");
        let (mut j, _) = Journal::open(&p, DOC).unwrap();
        j.append(0.1, &stroke()).unwrap();
        drop(j);
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        f.write_all(b"{\"seq\":1,\"t\":0.2,\"edit\":{\"ed").unwrap();
        drop(f);
        let (mut j, old) = Journal::open(&p, DOC).unwrap();
        assert_eq!(old.len(), 1);
        assert_eq!(j.append(0.3, &Edit::Undo).unwrap(), 1);
        let all = Journal::read(&p).unwrap();
        assert_eq!(all.len(), 2);
        assert_eq!(all[1].edit, Edit::Undo);
    }

    #[test]
    fn corruption_is_an_error_with_a_line_number() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.journal");
        std::fs::write(&p, format!("{HEADER}\nnot json\n")).unwrap();
        let e = Journal::open(&p, DOC).unwrap_err();
        assert!(
            matches!(
                e,
                VrError::Journal {
                    reason: JournalError::Entry { line: 2, .. },
                    ..
                }
            ),
            "{e:?}"
        );
        let e = e.to_string();
        assert!(e.contains("line 2"), "{e}");
        std::fs::write(&p, "hello\n").unwrap();
        assert!(
            Journal::open(&p, DOC)
                .unwrap_err()
                .to_string()
                .contains("not a wandsculpt journal")
        );
        std::fs::write(
            &p,
            format!("{HEADER}\n{{\"seq\":5,\"t\":0.0,\"edit\":{{\"edit\":\"undo\"}}}}\n"),
        )
        .unwrap();
        assert!(
            Journal::open(&p, DOC)
                .unwrap_err()
                .to_string()
                .contains("sequence 5")
        );
    }

    /// Regression (issue 31, item 1): a journal of 5,000 NUL bytes was taken for a
    /// torn header and silently reset to an empty journal. It is now refused, and the
    /// file is left as it was.
    #[test]
    fn a_journal_of_nul_bytes_is_refused_not_reset() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("z.journal");
        std::fs::write(&p, vec![0u8; 5000]).unwrap();
        let e = Journal::open(&p, DOC).unwrap_err();
        assert!(
            matches!(
                e,
                VrError::Journal {
                    reason: JournalError::Garbage {
                        line: 1,
                        bytes: 5000
                    },
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("left as it is"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), vec![0u8; 5000]);
        // NUL bytes after good entries (not a torn entry) are refused the same way.
        let (mut j, _) = Journal::open(dir.path().join("y.journal"), DOC).unwrap();
        j.append(0.1, &Edit::Undo).unwrap();
        drop(j);
        let q = dir.path().join("y.journal");
        let mut f = OpenOptions::new().append(true).open(&q).unwrap();
        f.write_all(&[0u8; 100]).unwrap();
        drop(f);
        let before = std::fs::read(&q).unwrap();
        assert!(Journal::open(&q, DOC).is_err());
        assert_eq!(std::fs::read(&q).unwrap(), before);
    }

    /// A header torn by a crash while the journal was created is still cut off and
    /// started afresh (the file held nothing else).
    #[test]
    fn a_torn_header_starts_afresh() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.journal");
        std::fs::write(&p, "{\"wandsculpt_jou").unwrap();
        let (mut j, old) = Journal::open(&p, DOC).unwrap();
        assert!(old.is_empty());
        j.append(0.1, &Edit::Undo).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with(&header_line(DOC)), "{text}");
    }

    /// Regression (issue 31, item 1): a journal of another document was re-applied
    /// to this run's scene (0 of its strokes applied, exit 0). The header names the
    /// document now; a mismatch is refused before anything is written.
    #[test]
    fn another_documents_journal_is_refused_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("o.journal");
        let (mut j, _) = Journal::open(&p, DOC).unwrap();
        j.append(0.1, &stroke()).unwrap();
        drop(j);
        let before = std::fs::read(&p).unwrap();
        let e = Journal::open(&p, "fnv1a64:00000000000000e0").unwrap_err();
        assert!(
            matches!(
                e,
                VrError::Journal {
                    reason: JournalError::OtherDocument { .. },
                    ..
                }
            ),
            "{e:?}"
        );
        let msg = e.to_string();
        assert!(!msg.contains('\n'), "{msg}");
        assert!(msg.contains(DOC) && msg.contains("left as it is"), "{msg}");
        assert_eq!(std::fs::read(&p).unwrap(), before);
        // The same document reopens it.
        assert_eq!(Journal::open(&p, DOC).unwrap().1.len(), 1);
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(64))]
            #[test]
            fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), header in any::<bool>()) {
                let dir = tempfile::tempdir().unwrap();
                let p = dir.path().join("p.journal");
                let mut data = if header { format!("{HEADER}\n").into_bytes() } else { Vec::new() };
                data.extend_from_slice(&bytes);
                std::fs::write(&p, &data).unwrap();
                let _ = Journal::read(&p);
                if let Ok((mut j, old)) = Journal::open(&p, DOC) {
                    prop_assert_eq!(j.append(1.0, &Edit::Undo).unwrap(), old.len() as u64);
                    prop_assert_eq!(Journal::read(&p).unwrap().len(), old.len() + 1);
                }
            }
        }
    }
}
