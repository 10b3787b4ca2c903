//! # sculpt-tools
//!
//! The Wandsculpt command-line tools. Today: the GOMS / KLM timing-study harness
//! (`sculpt-tools goms ...`); see the README's `goms` section.
//!
//! ```text
//! sculpt-tools goms klm builtin:multires-sculpting
//! sculpt-tools goms analyze my-study/ --sensitivity
//! ```

use clap::{Parser, Subcommand};

mod cmd;
mod goms;

/// The Wandsculpt command-line tools.
#[derive(Debug, Parser)]
#[command(name = "sculpt-tools", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// GOMS / KLM timing studies: operator extraction, KLM predictions, study reports.
    Goms(cmd::goms::GomsArgs),
    /// Convert an Open Brush `.tilt` recording into a pose log (replay input).
    Tilt2poselog(cmd::tilt2poselog::Tilt2PoselogArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Goms(args) => cmd::goms::run(args),
        Command::Tilt2poselog(args) => cmd::tilt2poselog::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sculpt-tools: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
