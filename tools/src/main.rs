//! # sculpt-tools
//!
//! The Wandsculpt command-line tools, one subcommand per module under `cmd/`:
//!
//! - `mesh --scene S.json [--depth interactive|final] --out X.{obj,stl,glb}`: tessellate
//!   a sculpted scene and write the mesh;
//! - `export --scene S.json --out X.igs`: write its NURBS surfaces as IGES 5.3;
//! - `goms ...`: the GOMS / KLM timing-study harness (see the README's `goms` section).
//!
//! ```text
//! sculpt-tools mesh --scene tests/data/scenes/sphere-overlaps.json --depth final --out sphere.stl
//! sculpt-tools goms klm builtin:multires-sculpting
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
    /// Tessellate a scene and write the sculpted mesh (OBJ, STL or GLB).
    Mesh(cmd::mesh::MeshArgs),
    /// Write a scene's NURBS surfaces as IGES 5.3 (trimmed surfaces, entity 144).
    Export(cmd::export::ExportArgs),
    /// GOMS / KLM timing studies: operator extraction, KLM predictions, study reports.
    Goms(cmd::goms::GomsArgs),
}

fn main() -> std::process::ExitCode {
    let result = match Cli::parse().command {
        Command::Mesh(args) => cmd::mesh::run(args),
        Command::Export(args) => cmd::export::run(args),
        Command::Goms(args) => cmd::goms::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sculpt-tools: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
