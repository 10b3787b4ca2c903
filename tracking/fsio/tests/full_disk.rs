//! The atomic writer on a real full disk (a small tmpfs; `fsio::testing::SmallDisk`).

use fsio::testing::SmallDisk;

/// Regression (issue 31, item 2): on a full disk a writer left a truncated file. Now
/// the write fails with "No space left on device", the old file keeps its content and
/// nothing new is left in the folder.
#[test]
fn a_full_disk_leaves_the_old_content_and_no_new_file() {
    let Some(disk) = SmallDisk::mount_or_skip(64, "a_full_disk_leaves_the_old_content") else {
        return;
    };
    let path = disk.path().join("scene.json");
    fsio::write_atomic(&path, b"{\"old\":true}").unwrap();
    let big = vec![b'x'; 256 << 10];
    let e = fsio::write_atomic(&path, &big).unwrap_err();
    assert!(matches!(e, fsio::FsError::Write { .. }), "{e:?}");
    assert!(e.to_string().contains("No space left"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), b"{\"old\":true}");
    assert_eq!(disk.entries(), ["scene.json"]);
    // A set: the first member fits, the second does not; neither is written.
    let a = disk.path().join("a.obj");
    let b = disk.path().join("b.stl");
    assert!(fsio::write_all_atomic(&[(&a, &big[..8 << 10]), (&b, &big[..])]).is_err());
    assert_eq!(disk.entries(), ["scene.json"]);
}
