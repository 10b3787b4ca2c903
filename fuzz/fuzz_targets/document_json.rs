//! Documents (`wandsculpt-document` JSON): the reader that `sculpt-tools`, `replay
//! --scene` and the display server's load path share.
//!
//! Checked: no panic; a document the reader accepts writes out and reads back to the
//! same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::sculpt::document::Document;

fuzz_target!(|data: &[u8]| {
    if let Ok(doc) = Document::from_json(data) {
        let once = doc.to_json();
        let again = Document::from_json(&once).expect("a written document must read back");
        assert_eq!(
            once,
            again.to_json(),
            "write-read-write changed the document"
        );
    }
});
