//! The serial wand protocol: the resynchronising decoder and the one-line parser.
//!
//! Checked: no panic; every accepted record, encoded again, parses to the same record.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tracking::serial::{SerialDecoder, encode_serial, parse_serial};

fuzz_target!(|data: &[u8]| {
    let mut decoder = SerialDecoder::default();
    let mut accepted = Vec::new();
    decoder.push(data, &mut |rec, _line| {
        if let Ok(rec) = rec {
            accepted.push(rec);
        }
    });
    assert!(decoder.skipped_bytes <= data.len() as u64);
    for rec in accepted {
        let mut line = Vec::new();
        encode_serial(&rec, &mut line);
        let text = line.strip_suffix(b"\r\n").unwrap_or(&line);
        let again = parse_serial(text).expect("the encoder's output must parse");
        let mut line_again = Vec::new();
        encode_serial(&again, &mut line_again);
        assert_eq!(line, line_again, "encode-parse-encode changed the record");
    }
});
