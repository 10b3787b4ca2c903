//! Operator event logs (`operator.log`, `*.oplog`) read by the GOMS harness.
//!
//! Checked: no panic; an accepted log encodes and decodes back to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::oplog::{decode_bytes, encode};

fuzz_target!(|data: &[u8]| {
    if let Ok(log) = decode_bytes(data) {
        let once = encode(&log);
        let again = decode_bytes(&once).expect("an encoded operator log must decode");
        let twice = encode(&again);
        if let Some(at) = once.iter().zip(&twice).position(|(a, b)| a != b) {
            let show = |b: &[u8]| {
                String::from_utf8_lossy(&b[at.saturating_sub(60)..(at + 60).min(b.len())])
                    .into_owned()
            };
            panic!(
                "encode-decode-encode differs at byte {at}:\n{}\n{}",
                show(&once),
                show(&twice)
            );
        }
        assert_eq!(once.len(), twice.len());
    }
});
