//! The volumes, parameters and seeds of the volume benches (`benches/volume.rs`,
//! `benches/volume_flow.rs`) and of the instruction-count driver
//! (`examples/volume_profile.rs`), so that all three measure the same work.

#![allow(dead_code)] // each includer uses a part

use sculpt_core::volume::{StreamlineOptions, Volume};

/// The evaluation bench volume: a wavy cubic 7^3 net on knots with three interior
/// spans per direction, weights from 0.5 to 2 (so every point divides by a
/// non-constant weight), 5 attributes (`x, y, z`, a density and a temperature).
pub fn bench_volume() -> Volume {
    let c = 7;
    let k = vec![0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.];
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for i in 0..c {
        for j in 0..c {
            for l in 0..c {
                let (x, y, z) = (i as f64 / 6.0, j as f64 / 6.0, l as f64 / 6.0);
                let wobble = 0.05 * (5.0 * x).sin() * (4.0 * y).cos() * (3.0 * z).sin();
                values.extend([x + wobble, y - wobble, z + 0.5 * wobble, 1.0 + z, x * y]);
                weights
                    .push(1.25 + 0.75 * (1.3 * i as f64 - 0.9 * j as f64 + 0.7 * l as f64).sin());
            }
        }
    }
    Volume::new(
        vec![3, 3, 3],
        vec![k.clone(), k.clone(), k],
        ["x", "y", "z", "rho", "t"].map(String::from).to_vec(),
        values,
        Some(weights),
    )
    .expect("valid bench volume")
}

/// `n` deterministic parameters in the unit cube (xorshift).
pub fn params(n: usize) -> Vec<[f64; 3]> {
    let mut state = 0x9E37_79B9_7F4A_7C15_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

/// Steps per streamline in the flow bench.
pub const FLOW_STEPS: usize = 1000;

/// The flow bench volume: a wavy, rational cubic box over `[-1, 1]^3` (7 x 7 x 7 net)
/// whose velocity `vx, vy, vz` is `e_z x x`, a rotation at unit rate, so no line
/// leaves the volume and every line takes exactly its [`FLOW_STEPS`] steps.
pub fn flow_volume() -> Volume {
    let c: usize = 7;
    let knots = [0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.];
    let (mut values, mut weights) = (Vec::new(), Vec::new());
    // The net point by point, the last index fastest (the file's nesting).
    for flat in 0..c.pow(3) {
        let idx = [flat / (c * c), flat / c % c, flat % c];
        let s = idx.map(|a| 2.0 * a as f64 / 6.0 - 1.0);
        let interior = idx.iter().all(|&a| a > 0 && a < c - 1);
        let wobble = if interior {
            0.05 * (5.0 * s[0]).sin() * (4.0 * s[1]).cos()
        } else {
            0.0
        };
        let (x, y, z) = (s[0] + wobble, s[1] - wobble, s[2] + 0.5 * wobble);
        values.extend([x, y, z, -y, x, 0.0]);
        let bump = 0.3 * (1.3 * s[0] - 0.9 * s[1] + 0.7 * s[2]).sin();
        weights.push(if interior { 1.0 + bump } else { 1.0 });
    }
    let k = knots.to_vec();
    Volume::new(
        vec![3, 3, 3],
        vec![k.clone(), k.clone(), k],
        ["x", "y", "z", "vx", "vy", "vz"].map(String::from).to_vec(),
        values,
        Some(weights),
    )
    .expect("valid bench volume")
}

/// `lines` seeds on rings of radius 0.05 to 0.4 in parameter space around the
/// rotation's axis.
pub fn flow_seeds(lines: usize) -> Vec<[f64; 3]> {
    (0..lines)
        .map(|i| {
            let a = i as f64 * 2.399_963;
            let r = 0.05 + 0.35 * (i as f64 / lines as f64);
            [0.5 + r * a.cos(), 0.5 + r * a.sin(), (i % 17) as f64 / 16.0]
        })
        .collect()
}

/// Tracing for [`FLOW_STEPS`] steps (the time is long enough never to end a line).
pub fn flow_options() -> StreamlineOptions {
    StreamlineOptions {
        time: 1e9,
        max_steps: FLOW_STEPS,
        ..StreamlineOptions::new(0.0)
    }
}
