//! # sculpt-tools
//!
//! The Wandsculpt command-line tools. Each subcommand lives in its own module under
//! `cmd/`; adding one means a module, one variant of [`Command`] and one match arm.
//!
//! - `sculpt-tools eval --surface S.json --uv UV.csv`: surface points `x,y,z` for the
//!   parameters `u,v` of each line.
//! - `sculpt-tools project --surface S.json --points P.csv`: the closest surface point of
//!   each query `x,y,z`, as `u,v,x,y,z,distance`.
//!
//! Input files may be `-` for stdin; `--out FILE` writes to a file instead of stdout.
//! Any bad input ends with one line on stderr naming the file and line, and exit code 1.

use std::process::ExitCode;

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

/// The subcommands.
#[derive(Debug, Subcommand)]
enum Command {
    /// Evaluate a NURBS surface at parameters: reads `u,v` lines, prints `x,y,z`.
    Eval(cmd::eval::Args),
    /// Closest points on a NURBS surface: reads `x,y,z` lines, prints
    /// `u,v,x,y,z,distance`.
    Project(cmd::project::Args),
    /// GOMS / KLM timing studies: operator extraction, KLM predictions, study reports.
    Goms(cmd::goms::GomsArgs),
    /// Convert an Open Brush `.tilt` recording into a pose log (replay input).
    Tilt2poselog(cmd::tilt2poselog::Tilt2PoselogArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval(args) => cmd::eval::run(&args),
        Command::Project(args) => cmd::project::run(&args),
        Command::Goms(args) => cmd::goms::run(args),
        Command::Tilt2poselog(args) => cmd::tilt2poselog::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined with ": ", newlines flattened.
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("sculpt-tools: {msg}");
            ExitCode::FAILURE
        }
    }
}
