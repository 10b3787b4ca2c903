//! `.vm` models (Fidget's SSA text): `sculpt_core::implicit::vm::parse`.
//!
//! Checked: no panic; an accepted model compiles to a tape, and its graph written as
//! `.vm` reads back to the same values.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::implicit::{Tape, vm};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(program) = vm::parse(text) {
        let (graph, root) = program.to_graph();
        let p = [0.25, -0.5, 0.75];
        let value = graph.eval_f64(root, p);
        let again = vm::parse(&vm::write(&graph, root)).expect("a written model must read back");
        let back = again.eval_f64(p);
        assert!(
            value.to_bits() == back.to_bits() || (value.is_nan() && back.is_nan()),
            "write-read changed the value: {value} vs {back}"
        );
        let _ = Tape::compile(&graph, root).eval_point([0.25, -0.5, 0.75]);
    }
});
