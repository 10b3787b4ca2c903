//! NURBS surface and curve JSON (`sculpt-tools` inputs, targets in documents).
//!
//! Checked: no panic; an accepted surface evaluates to finite points at its corners and
//! centre, and writes out and reads back unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sculpt_core::nurbs::{NurbsCurve, NurbsSurface};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(surface) = NurbsSurface::from_json(text) {
        let (u0, u1) = surface.domain_u();
        let (v0, v1) = surface.domain_v();
        for (u, v) in [(u0, v0), (u1, v1), (0.5 * (u0 + u1), 0.5 * (v0 + v1))] {
            let p = surface.point(u, v);
            assert!(
                p.is_finite(),
                "accepted surface evaluates to {p:?} at ({u}, {v})"
            );
        }
        let once = surface.to_json();
        let again = NurbsSurface::from_json(&once).expect("a written surface must read back");
        assert_eq!(once, again.to_json());
    }
    if let Ok(curve) = NurbsCurve::from_json(text) {
        let once = curve.to_json();
        let again = NurbsCurve::from_json(&once).expect("a written curve must read back");
        assert_eq!(once, again.to_json());
    }
});
