//! Scan point files (`.xyz`, `.pwn`, PLY, OBJ, OFF): the readers of
//! `sculpt-tools reconstruct` (`sculpt_core::reconstruct::read`). The first byte picks
//! the format.
//!
//! Checked: no panic; accepted files have at least one point, every coordinate finite,
//! and one normal per point when they have normals.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::reconstruct::read::{PointFormat, read_points};

const FORMATS: [PointFormat; 5] = [
    PointFormat::Xyz,
    PointFormat::Pwn,
    PointFormat::Ply,
    PointFormat::Obj,
    PointFormat::Off,
];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    if let Ok(cloud) = read_points(bytes, FORMATS[usize::from(pick) % FORMATS.len()]) {
        assert!(!cloud.points.is_empty());
        assert!(cloud.points.iter().all(|p| p.is_finite()));
        if let Some(n) = &cloud.normals {
            assert_eq!(n.len(), cloud.points.len());
        }
    }
});
