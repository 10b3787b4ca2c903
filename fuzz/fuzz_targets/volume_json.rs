//! Volumes (`wandsculpt-volume` JSON, `sculpt_core::volume::Volume::from_json`).
//!
//! Checked: no panic; a volume the reader accepts writes out and reads back with the
//! same shape, and evaluates at the centre of its domain without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::volume::Volume;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(vol) = Volume::from_json(text) {
        let again = Volume::from_json(&vol.to_json()).expect("a written volume must read back");
        assert_eq!(again.degrees(), vol.degrees());
        assert_eq!(again.counts(), vol.counts());
        let centre: Vec<f64> = vol.domain().iter().map(|(a, b)| 0.5 * (a + b)).collect();
        let _ = vol.derivatives(&centre, 2);
    }
});
