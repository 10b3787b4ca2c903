//! DTrack2 ASCII codec: the streaming decoder under any split of the input, and the
//! one-frame parser.
//!
//! Checked: no panic; the decoder's buffer stays within its caps whatever arrives; a
//! frame the parser accepts, once written by the encoder, reads back to the same
//! bytes (the encoder's output is a fixed point of parse-then-encode).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tracking::dtrack::{DTrackDecoder, Decoded, DecoderLimits, encode_frame, parse_frame};

fuzz_target!(|data: &[u8]| {
    let Some((&split, bytes)) = data.split_first() else {
        return;
    };
    let limits = DecoderLimits {
        max_line: 512,
        max_frame: 4096,
        max_devices: 16,
    };
    // Slack for one partial line plus one partial frame, with Vec growth.
    let bound = 2 * (limits.max_line + limits.max_frame) + 64;
    let mut decoder = DTrackDecoder::new(limits).keep_raw(true);
    let chunk = usize::from(split).max(1);
    let mut frames = 0u64;
    let mut check = |d: Decoded| {
        if let Decoded::Frame(frame, raw) = d {
            frames += 1;
            assert!(frame.bodies.len() + frame.wands.len() <= limits.max_devices);
            assert!(raw.is_some_and(|r| r.len() <= limits.max_frame));
        }
    };
    for piece in bytes.chunks(chunk) {
        decoder.push(piece, &mut check);
        assert!(
            decoder.buffered() <= bound,
            "decoder holds {} bytes",
            decoder.buffered()
        );
        // Odd first bytes: each piece is one UDP datagram.
        if split & 1 == 1 {
            decoder.end_datagram(&mut check);
        }
    }
    assert_eq!(decoder.stats().frames, frames);

    if let Ok(frame) = parse_frame(bytes) {
        let mut once = Vec::new();
        encode_frame(&frame, &mut once);
        let again = parse_frame(&once).expect("the encoder's output must parse");
        let mut twice = Vec::new();
        encode_frame(&again, &mut twice);
        assert_eq!(once, twice, "parse-then-encode is not a fixed point");
    }
});
