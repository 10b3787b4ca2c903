//! The operation journal: every completed operation is appended as one JSON line and
//! fsync'd before it counts, so a crash (even `kill -9`) loses nothing that was
//! reported done.
//!
//! Format (`*.journal`, UTF-8 JSON lines):
//! - line 1, the header: `{"wandsculpt_journal":2}`;
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
//! On open, a final line without its newline (a write torn by a crash) is cut off;
//! any other bad line is an error naming its line number, never silently skipped.
//!
//! ```
//! use vr_app::journal::Journal;
//! use sculpt_core::interaction::Edit;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("s.journal");
//! let (mut j, old) = Journal::open(&path)?;
//! assert!(old.is_empty());
//! j.append(0.5, &Edit::Undo)?;
//! drop(j);
//! let (_, recovered) = Journal::open(&path)?;
//! assert_eq!(recovered[0].edit, Edit::Undo);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use sculpt_core::interaction::Edit;
use serde::{Deserialize, Serialize};

use crate::error::{JournalError, VrError, VrResult};

/// The journal version this build writes.
pub const VERSION: u32 = 2;
/// The header line.
pub const HEADER: &str = "{\"wandsculpt_journal\":2}";
/// A version 1 journal's header line (targets named by position).
pub const HEADER_V1: &str = "{\"wandsculpt_journal\":1}";
/// Longest journal line accepted (bytes); a longer one is corruption.
pub const MAX_LINE: usize = 64 << 20;

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
    /// Opens (or creates) the journal at `path` and returns it with the entries it
    /// already holds, cutting off a torn final line.
    pub fn open(path: impl AsRef<Path>) -> VrResult<(Self, Vec<JournalEntry>)> {
        let path = path.as_ref().to_path_buf();
        let mut file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(&path)
            .map_err(|e| io(&path, e))?;
        let len = file.metadata().map_err(|e| io(&path, e))?.len();
        let (entries, good_len, mut version) = if len == 0 {
            file.write_all(format!("{HEADER}\n").as_bytes())
                .map_err(|e| io(&path, e))?;
            file.sync_all().map_err(|e| io(&path, e))?;
            sync_parent(&path);
            (Vec::new(), None, VERSION)
        } else {
            let read = read_entries(&path, &mut file)?;
            (
                read.entries,
                (read.good < len).then_some(read.good),
                read.version,
            )
        };
        if let Some(good) = good_len {
            tracing::warn!(path = %path.display(), cut = len - good, "journal: cutting off a torn final line");
            file.set_len(good).map_err(|e| io(&path, e))?;
            if good == 0 {
                // Even the header was torn: start the file afresh.
                file.write_all(format!("{HEADER}\n").as_bytes())
                    .map_err(|e| io(&path, e))?;
                version = VERSION;
            }
            file.sync_all().map_err(|e| io(&path, e))?;
        }
        let next_seq = entries.last().map_or(0, |e: &JournalEntry| e.seq + 1);
        Ok((
            Self {
                path,
                file,
                next_seq,
                version,
            },
            entries,
        ))
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
        let mut text = format!("{HEADER}\n");
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
            // Torn final write: stop here, the caller cuts it off.
            break;
        }
        let text = std::str::from_utf8(&buf[..n - 1])
            .map_err(|_| jerr(path, JournalError::NotUtf8 { line: line_no }))?;
        if line_no == 1 {
            version = match text.trim() {
                HEADER => VERSION,
                HEADER_V1 => 1,
                _ => {
                    return Err(jerr(
                        path,
                        JournalError::NotAJournal {
                            found: truncate(text),
                        },
                    ));
                }
            };
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
    })
}

fn truncate(s: &str) -> String {
    s.chars().take(60).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::interaction::{DEFAULT_TARGET, StrokeEdit, StrokeSample, Tool};

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
        let (mut j, old) = Journal::open(&p).unwrap();
        assert!(old.is_empty());
        assert_eq!(j.append(0.1, &stroke()).unwrap(), 0);
        assert_eq!(j.append(0.2, &Edit::Undo).unwrap(), 1);
        drop(j);
        let (mut j, old) = Journal::open(&p).unwrap();
        assert_eq!(old.len(), 2);
        assert_eq!(old[0].edit, stroke());
        assert_eq!(j.append(0.3, &Edit::Redo).unwrap(), 2);
        assert_eq!(Journal::read(&p).unwrap().len(), 3);
    }

    #[test]
    fn torn_tail_is_cut_and_appending_continues() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.journal");
        let (mut j, _) = Journal::open(&p).unwrap();
        j.append(0.1, &stroke()).unwrap();
        drop(j);
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        f.write_all(b"{\"seq\":1,\"t\":0.2,\"edit\":{\"ed").unwrap();
        drop(f);
        let (mut j, old) = Journal::open(&p).unwrap();
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
        let e = Journal::open(&p).unwrap_err();
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
            Journal::open(&p)
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
            Journal::open(&p)
                .unwrap_err()
                .to_string()
                .contains("sequence 5")
        );
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
                if let Ok((mut j, old)) = Journal::open(&p) {
                    prop_assert_eq!(j.append(1.0, &Edit::Undo).unwrap(), old.len() as u64);
                    prop_assert_eq!(Journal::read(&p).unwrap().len(), old.len() + 1);
                }
            }
        }
    }
}
