//! # wandsculpt (vr-app)
//!
//! The Wandsculpt display server: head-tracked stereo on a projection wall.
//! Not built yet: running it says so and exits non-zero.

fn main() -> std::process::ExitCode {
    eprintln!("wandsculpt: not available in this build yet (see the open vr-app issue)");
    std::process::ExitCode::FAILURE
}
