//! # fsio: every output file, written whole or not at all
//!
//! The one writer behind every file the Wandsculpt programs produce (`wandsculpt`'s
//! documents and autosaves, `replay --out`, every `sculpt-tools` output). A file is
//! written to a temporary file in the same folder (`.NAME.PID-N.tmp`), flushed and
//! fsync'd, then renamed over its destination; the folder is then fsync'd (best
//! effort). A rename within one folder is atomic on POSIX file systems, so a reader, a
//! crash or a full disk never sees half a file: the destination holds either its old
//! content (or is absent) or the whole new content.
//!
//! On any failure, a full disk included, the temporary file is removed and the
//! destination is left as it was: **a failed write leaves no new file.** An
//! [`AtomicFile`] dropped without [`AtomicFile::commit`] (an error part-way through
//! producing it, a panic) removes its temporary file too.
//!
//! A run that writes several files writes them as a set with [`commit_all`] (or
//! [`write_all_atomic`]): every temporary file is written and synced first, and only
//! when all of them are on disk are they renamed into place. So a full disk part-way
//! through leaves none of the set. (Should a rename itself fail after others succeeded,
//! which needs the folder to change under the run, the files this set had newly created
//! are removed again; files it replaced keep their new content.)
//!
//! Inputs have the mirror rule: [`read_capped`] checks a file's size against the
//! reader's cap before reading it, so memory is bounded by the cap, not by the file.
//!
//! This crate does I/O, so the pure `sculpt-core` does not use it; the programs
//! (`sculpt-tools`, `replay`, `vr-app`) do. It depends on nothing but `thiserror`.
//!
//! ```
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("scene.json");
//! fsio::write_atomic(&path, b"{}")?;
//! assert_eq!(std::fs::read(&path).unwrap(), b"{}");
//! // A write that fails part-way leaves the old content and no temporary file.
//! let failed = fsio::write_atomic_with(&path, |w| {
//!     use std::io::Write;
//!     w.write_all(b"{\"half")?;
//!     Err(std::io::Error::other("the producer failed"))
//! });
//! assert!(failed.is_err());
//! assert_eq!(std::fs::read(&path).unwrap(), b"{}");
//! assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
//! # Ok::<(), fsio::FsError>(())
//! ```

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

pub mod testing;

/// Why a file could not be written (the destination is as it was before) or read.
#[derive(Debug, thiserror::Error)]
pub enum FsError {
    /// An input file is larger than the reader's cap; it was not read.
    #[error("{}: {size} bytes, more than the {max} bytes this input may have; not read", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size (bytes; at least `max + 1` when it was found while reading).
        size: u64,
        /// The cap.
        max: u64,
    },
    /// An input file could not be read.
    #[error("{}: cannot read ({source})", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The temporary file beside the destination could not be created.
    #[error("{}: cannot create {} ({source})", path.display(), tmp.display())]
    Create {
        /// The destination.
        path: PathBuf,
        /// The temporary file.
        tmp: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// Writing, flushing or syncing the content failed (a full disk: `No space left on
    /// device`).
    #[error("{}: cannot write ({source}); nothing was written", path.display())]
    Write {
        /// The destination.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The synced temporary file could not be renamed over the destination.
    #[error("{}: cannot rename {} into place ({source}); nothing was written", path.display(), tmp.display())]
    Rename {
        /// The destination.
        path: PathBuf,
        /// The temporary file (removed).
        tmp: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The destination has no file name (a folder, `..`, the root).
    #[error("{}: not a file name to write", path.display())]
    NotAFile {
        /// The destination as given.
        path: PathBuf,
    },
}

impl FsError {
    /// The destination the failed write was for.
    pub fn path(&self) -> &Path {
        match self {
            Self::Create { path, .. }
            | Self::Write { path, .. }
            | Self::Rename { path, .. }
            | Self::NotAFile { path }
            | Self::TooLarge { path, .. }
            | Self::Read { path, .. } => path,
        }
    }
}

/// Temporary names are unique within the process (and the PID makes them unique
/// between processes).
static NEXT_TMP: AtomicU64 = AtomicU64::new(0);

/// An output file being written: a temporary file beside the destination, renamed over
/// it by [`AtomicFile::commit`]. Dropped without a commit, it removes the temporary
/// file and the destination is untouched.
///
/// Writes are buffered; a write error is returned by the [`Write`] calls as usual and
/// the file should then be dropped.
#[derive(Debug)]
pub struct AtomicFile {
    dest: PathBuf,
    tmp: PathBuf,
    /// `None` once committed (or after a failed commit, which removed the file).
    file: Option<BufWriter<File>>,
    /// Whether the destination existed when this file was created (so that a set whose
    /// later rename fails can remove what it newly created).
    existed: bool,
}

impl AtomicFile {
    /// Starts writing `dest`: creates the temporary file in the destination's folder
    /// (which must exist).
    pub fn create(dest: impl AsRef<Path>) -> Result<Self, FsError> {
        let dest = dest.as_ref().to_path_buf();
        let Some(name) = dest.file_name() else {
            return Err(FsError::NotAFile { path: dest });
        };
        let n = NEXT_TMP.fetch_add(1, Ordering::Relaxed);
        let tmp_name = format!(".{}.{}-{n}.tmp", name.to_string_lossy(), std::process::id());
        let tmp = dest.with_file_name(tmp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|source| FsError::Create {
                path: dest.clone(),
                tmp: tmp.clone(),
                source,
            })?;
        let existed = std::fs::symlink_metadata(&dest).is_ok();
        Ok(Self {
            dest,
            tmp,
            file: Some(BufWriter::new(file)),
            existed,
        })
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// Flushes and fsyncs the temporary file. On failure it is removed.
    fn sync(&mut self) -> Result<(), FsError> {
        let result = match self.file.as_mut() {
            Some(f) => f.flush().and_then(|()| f.get_ref().sync_all()),
            None => Ok(()),
        };
        result.map_err(|source| {
            self.discard();
            FsError::Write {
                path: self.dest.clone(),
                source,
            }
        })
    }

    /// Renames the synced temporary file over the destination. On failure it is
    /// removed.
    fn rename(&mut self) -> Result<(), FsError> {
        // Closed before the rename (some systems refuse to rename an open file).
        drop(self.file.take());
        std::fs::rename(&self.tmp, &self.dest).map_err(|source| {
            let _ = std::fs::remove_file(&self.tmp);
            FsError::Rename {
                path: self.dest.clone(),
                tmp: self.tmp.clone(),
                source,
            }
        })?;
        sync_parent(&self.dest);
        Ok(())
    }

    /// Finishes the file: flush, fsync, rename over the destination, fsync the folder.
    /// On failure the temporary file is removed and the destination is as it was.
    pub fn commit(mut self) -> Result<(), FsError> {
        self.sync()?;
        self.rename()
    }

    /// Removes the temporary file (nothing is renamed).
    fn discard(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self.file.as_mut() {
            Some(f) => f.write(buf),
            None => Err(io::Error::other("the file was already committed")),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self.file.as_mut() {
            Some(f) => f.write_all(buf),
            None => Err(io::Error::other("the file was already committed")),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.as_mut().map_or(Ok(()), Write::flush)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        self.discard();
    }
}

/// Commits a set of files together: all are synced first, then all are renamed. If
/// any fails to sync, none is renamed (and every temporary file is removed). If a
/// rename fails, the files of the set renamed before it that had not existed are
/// removed again (see the module docs).
pub fn commit_all(files: Vec<AtomicFile>) -> Result<(), FsError> {
    let mut files = files;
    for f in &mut files {
        // On an error `files` is dropped, which removes every temporary file.
        f.sync()?;
    }
    let mut done: Vec<(PathBuf, bool)> = Vec::with_capacity(files.len());
    for f in &mut files {
        if let Err(e) = f.rename() {
            for (path, existed) in done {
                if !existed {
                    let _ = std::fs::remove_file(path);
                }
            }
            return Err(e);
        }
        done.push((f.dest.clone(), f.existed));
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically (see the module docs).
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), FsError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes `path` atomically with the content `produce` writes. When `produce` fails,
/// its error is returned as [`FsError::Write`] and nothing is written.
pub fn write_atomic_with(
    path: impl AsRef<Path>,
    produce: impl FnOnce(&mut AtomicFile) -> io::Result<()>,
) -> Result<(), FsError> {
    let mut file = AtomicFile::create(path)?;
    if let Err(source) = produce(&mut file) {
        return Err(FsError::Write {
            path: file.dest.clone(),
            source,
        });
    }
    file.commit()
}

/// Writes a set of files atomically as one (see [`commit_all`]): either all of them
/// are written, or none is new.
pub fn write_all_atomic<P: AsRef<Path>, B: AsRef<[u8]>>(files: &[(P, B)]) -> Result<(), FsError> {
    let mut staged = Vec::with_capacity(files.len());
    for (path, bytes) in files {
        let mut f = AtomicFile::create(path)?;
        f.write_all(bytes.as_ref())
            .map_err(|source| FsError::Write {
                path: f.dest.clone(),
                source,
            })?;
        staged.push(f);
    }
    commit_all(staged)
}

/// Reads a whole input file of at most `max` bytes. The size is checked before
/// anything is read, and the read stops after `max + 1` bytes whatever the size said
/// (a file still growing, a pipe or device), so memory stays bounded by the cap, not
/// by the file: a larger file is [`FsError::TooLarge`].
pub fn read_capped(path: impl AsRef<Path>, max: u64) -> Result<Vec<u8>, FsError> {
    use std::io::Read as _;
    let path = path.as_ref();
    let read_err = |source| FsError::Read {
        path: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(read_err)?;
    let meta = file.metadata().map_err(read_err)?;
    let too_large = |size| FsError::TooLarge {
        path: path.to_path_buf(),
        size,
        max,
    };
    if meta.is_file() && meta.len() > max {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(if meta.is_file() {
        usize::try_from(meta.len()).unwrap_or(0)
    } else {
        0
    });
    file.take(max.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(read_err)?;
    if bytes.len() as u64 > max {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Makes the renamed file's directory entry durable (best effort: not every file
/// system supports fsync on a folder; the file itself is synced).
pub fn sync_parent(path: &Path) {
    if let Some(dir) = path.parent() {
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// Regression (issue 31, item 2): a writer that fails part-way (as a full disk
    /// does) left a truncated file. Now the old content stays and no file is added.
    #[test]
    fn an_injected_write_error_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.json");
        std::fs::write(&path, b"old").unwrap();
        let e = write_atomic_with(&path, |w| {
            w.write_all(&[b'x'; 100_000])?;
            Err(io::Error::from_raw_os_error(28))
        })
        .unwrap_err();
        assert!(matches!(e, FsError::Write { .. }), "{e:?}");
        assert!(e.to_string().contains("scene.json"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(names(dir.path()), ["scene.json"]);
        // A new destination stays absent.
        let new = dir.path().join("new.obj");
        assert!(write_atomic_with(&new, |_| Err(io::Error::other("no"))).is_err());
        assert!(!new.exists());
        assert_eq!(names(dir.path()), ["scene.json"]);
    }

    #[test]
    fn a_dropped_file_leaves_nothing_and_a_committed_one_replaces() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"half").unwrap();
        drop(f);
        assert!(names(dir.path()).is_empty());
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"whole").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"whole");
        assert_eq!(names(dir.path()), ["a.txt"]);
    }

    #[test]
    fn a_set_is_renamed_only_when_every_member_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a");
        let b = dir.path().join("b");
        write_all_atomic(&[(&a, b"1".as_slice()), (&b, b"2".as_slice())]).unwrap();
        assert_eq!(std::fs::read(&b).unwrap(), b"2");
        // The second member's folder is missing: the first is not written either.
        let c = dir.path().join("c");
        let missing = dir.path().join("no-such-folder").join("d");
        let e =
            write_all_atomic(&[(&c, b"3".as_slice()), (&missing, b"4".as_slice())]).unwrap_err();
        assert!(matches!(e, FsError::Create { .. }), "{e:?}");
        assert_eq!(e.path(), missing);
        assert_eq!(names(dir.path()), ["a", "b"]);
        // A rename that fails (the destination is a non-empty folder) removes the set's
        // new files renamed before it.
        let blocked = dir.path().join("blocked");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("inside"), b"x").unwrap();
        let e =
            write_all_atomic(&[(&c, b"3".as_slice()), (&blocked, b"4".as_slice())]).unwrap_err();
        assert!(matches!(e, FsError::Rename { .. }), "{e:?}");
        assert_eq!(names(dir.path()), ["a", "b", "blocked"]);
    }

    /// Regression (issue 31, item 7): a 3 GB input was read whole before it was
    /// refused. A file over the cap is refused from its size, and a device that never
    /// ends (`/dev/zero`, no size) is cut at the cap.
    #[test]
    fn an_input_over_the_cap_is_refused_before_it_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.json");
        // Sparse: 3 GB by its size, no memory or disk spent.
        let f = File::create(&path).unwrap();
        f.set_len(3 << 30).unwrap();
        drop(f);
        let e = read_capped(&path, 1 << 20).unwrap_err();
        assert!(
            matches!(e, FsError::TooLarge { size, max, .. } if size == 3 << 30 && max == 1 << 20),
            "{e:?}"
        );
        assert!(e.to_string().contains("big.json"), "{e}");
        let e = read_capped("/dev/zero", 4096).unwrap_err();
        assert!(matches!(e, FsError::TooLarge { size: 4097, .. }), "{e:?}");
        std::fs::write(&path, b"{}").unwrap();
        assert_eq!(read_capped(&path, 2).unwrap(), b"{}");
        assert!(matches!(
            read_capped(dir.path().join("none"), 2),
            Err(FsError::Read { .. })
        ));
    }

    #[test]
    fn a_folder_is_not_a_file_name() {
        assert!(matches!(
            write_atomic("/", b"x"),
            Err(FsError::NotAFile { .. })
        ));
    }
}
