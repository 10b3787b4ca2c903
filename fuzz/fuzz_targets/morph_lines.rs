//! Morph feature lines (`wandsculpt-morph-lines` JSON,
//! `sculpt_core::volume::morph::FeatureLines::from_json`).
//!
//! Checked: no panic; accepted lines pass validation again, and warp a small morph
//! whose end frames equal its images.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::volume::morph::{FeatureLines, ImageMorph};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(lines) = FeatureLines::from_json(text) {
        lines.validate().expect("accepted lines validate");
        let a: Vec<u8> = (0..4 * 4 * 4).map(|i| (i * 7) as u8).collect();
        let b: Vec<u8> = (0..4 * 4 * 4).map(|i| (i * 13 + 5) as u8).collect();
        let m = ImageMorph::new((&a, 4, 4), (&b, 4, 4), lines).expect("a valid morph");
        assert!(m.frame(0.0) == a);
        assert!(m.frame(1.0) == b);
        let _ = m.frame(0.5);
    }
});
