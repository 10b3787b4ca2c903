//! # replay
//!
//! Deterministic replay of recorded pose logs through the live Wandsculpt pipeline, and
//! tracking-server emulation. Not built yet: running it says so and exits non-zero.

fn main() -> std::process::ExitCode {
    eprintln!("replay: not available in this build yet (see the open replay issue)");
    std::process::ExitCode::FAILURE
}
