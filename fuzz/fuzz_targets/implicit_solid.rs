//! Solid documents (JSON): `sculpt_core::implicit::solid::SolidDocument::from_json`.
//!
//! Checked: no panic; an accepted document builds a graph, evaluates, and writes out
//! and reads back unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::implicit::Tape;
use sculpt_core::implicit::solid::SolidDocument;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(doc) = SolidDocument::from_json(text) {
        let (graph, root) = doc.to_graph().expect("an accepted document builds");
        let _ = Tape::compile(&graph, root).eval_point([0.1, 0.2, 0.3]);
        let json = doc.to_json();
        let again = SolidDocument::from_json(&json).expect("a written document must read back");
        assert_eq!(doc, again, "write-read changed the document");
    }
});
