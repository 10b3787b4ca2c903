//! Test support: [`SmallDisk`], a full disk on demand.
//!
//! `/dev/full` fails every write but cannot be renamed into, so it cannot stand for a
//! full disk under an atomic writer. A tmpfs of a few kilobytes can: files are created
//! and renamed there as on any disk, and a write past its size fails with `No space
//! left on device`. Mounting needs root (or `CAP_SYS_ADMIN`).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicU64, Ordering};

static NEXT: AtomicU64 = AtomicU64::new(0);

/// A tmpfs of a given size mounted on a fresh folder under the system's temporary
/// folder; unmounted and removed when dropped.
#[derive(Debug)]
pub struct SmallDisk {
    dir: PathBuf,
}

impl SmallDisk {
    /// Mounts a tmpfs of `kib` KiB (rounded up to whole pages by the kernel). `None`
    /// when mounting is not allowed here (not root, no `mount`).
    pub fn mount(kib: u32) -> Option<Self> {
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("fsio-small-disk-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).ok()?;
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={kib}k"), "tmpfs"])
            .arg(&dir)
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            Some(Self { dir })
        } else {
            let _ = std::fs::remove_dir(&dir);
            None
        }
    }

    /// [`SmallDisk::mount`], or `None` with a note on stderr when mounting is not
    /// allowed; when the environment variable `CI` is set (non-empty) that is a
    /// failure instead, so CI never skips the full-disk tests.
    pub fn mount_or_skip(kib: u32, test: &str) -> Option<Self> {
        let disk = Self::mount(kib);
        if disk.is_none() {
            let ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
            assert!(
                !ci,
                "{test}: cannot mount a tmpfs (root needed); CI must run the full-disk tests"
            );
            eprintln!("{test}: skipped: cannot mount a tmpfs here (root needed)");
        }
        disk
    }

    /// The mounted folder.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The folder's entries (names, sorted), for checking that nothing was left.
    pub fn entries(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&self.dir)
            .map(|d| {
                d.filter_map(Result::ok)
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.dir).output();
        let _ = std::fs::remove_dir(&self.dir);
    }
}
