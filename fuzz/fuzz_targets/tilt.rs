//! Open Brush `.tilt` files: the zip container reader and the sketch parser.
//!
//! Checked: no panic; a sketch the parser accepts encodes and parses back to the same
//! bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tracking::tilt::{encode_sketch, parse_sketch, read_tilt};

fuzz_target!(|data: &[u8]| {
    let _ = read_tilt(data);
    if let Ok(sketch) = parse_sketch(data) {
        let once = encode_sketch(&sketch);
        let again = parse_sketch(&once).expect("an encoded sketch must parse");
        assert_eq!(once, encode_sketch(&again));
    }
});
