//! # sculpt-tools
//!
//! The Wandsculpt command-line tools.
//! Not built yet: running it says so and exits non-zero.

fn main() -> std::process::ExitCode {
    eprintln!("sculpt-tools: not available in this build yet (see the open kernel issue)");
    std::process::ExitCode::FAILURE
}
