//! Material documents (JSON): `sculpt_core::implicit::material::MaterialDocument::from_json`.
//!
//! Checked: no panic; an accepted document builds a field (and its domain, if any) that
//! evaluates, and writes out and reads back unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::implicit::material::MaterialDocument;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(doc) = MaterialDocument::from_json(text) {
        let tape = doc.tape().expect("an accepted document builds");
        let _ = tape.eval_point([0.1, 0.2, 0.3]);
        if let Some(domain) = doc.domain_tape().expect("an accepted domain builds") {
            let _ = domain.eval_point([0.1, 0.2, 0.3]);
        }
        let again =
            MaterialDocument::from_json(&doc.to_json()).expect("a written document must read back");
        assert_eq!(doc, again, "write-read changed the document");
    }
});
