//! A fixed amount of the volume benches' work, for counting instructions with
//! callgrind (the CPU-time benches still depend on what else runs on the machine):
//!
//! ```sh
//! cargo build --release -p sculpt-core --example volume_profile
//! valgrind --tool=callgrind target/release/examples/volume_profile eval 100000
//! valgrind --tool=callgrind target/release/examples/volume_profile flow 20
//! ```
//!
//! `eval N`: `N` evaluations with all first derivatives of the `volume/eval_d1_1024`
//! bench volume (its 1024 parameters over and over). `flow L`: `L` streamlines of the
//! `volume_flow/streamlines_1000x1000` bench (1,000 Dormand-Prince steps each, six
//! evaluations per step). Divide callgrind's total by `N` or by `L x 1000` steps.

use std::hint::black_box;

use sculpt_core::volume::FlowField;

#[path = "../benches/support/volume_data.rs"]
mod volume_data;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(0);
    match (args.first().map(String::as_str), count) {
        (Some("eval"), n) if n > 0 => {
            let vol = volume_data::bench_volume();
            let pts = volume_data::params(1024);
            let mut row = [0.0; 5 * 4];
            let mut acc = 0.0;
            for u in pts.iter().cycle().take(n) {
                vol.eval_d1_into(black_box(u), &mut row)
                    .expect("valid parameters");
                acc += row[0] + row[19];
            }
            println!("{n} evaluations, checksum {acc}");
        }
        (Some("flow"), lines) if lines > 0 => {
            let vol = volume_data::flow_volume();
            let field = FlowField::new(&vol, [3, 4, 5]).expect("a flow");
            let opts = volume_data::flow_options();
            let mut steps = 0;
            for s in volume_data::flow_seeds(lines) {
                let line = field.trace(black_box(s), &opts).expect("a valid seed");
                steps += line.points.len() - 1;
            }
            println!("{lines} streamlines, {steps} steps");
        }
        _ => {
            eprintln!("usage: volume_profile eval N | flow LINES");
            std::process::exit(2);
        }
    }
}
