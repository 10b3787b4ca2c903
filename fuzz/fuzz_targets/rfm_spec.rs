//! Heat problem specs (TOML): `sculpt_core::implicit::rfm::spec::HeatSpec::from_toml`.
//!
//! Checked: no panic; an accepted spec has valid settings, and writes out and reads
//! back unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::implicit::rfm::spec::HeatSpec;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(spec) = HeatSpec::from_toml(text) {
        spec.settings()
            .expect("an accepted spec has valid settings");
        let again = HeatSpec::from_toml(&spec.to_toml()).expect("a written spec must read back");
        assert_eq!(spec, again, "write-read changed the spec");
    }
});
