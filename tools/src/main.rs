//! # sculpt-tools
//!
//! The Wandsculpt command-line tools, one subcommand per module under `cmd/`:
//!
//! - `mesh --scene S.json [--depth interactive|final] --out X.{obj,stl,glb}`: tessellate
//!   a sculpted scene and write the mesh;
//! - `export --scene S.json --out X.igs`: write its NURBS surfaces as IGES 5.3.
//!
//! ```text
//! sculpt-tools mesh --scene tests/data/scenes/sphere-overlaps.json --depth final --out sphere.stl
//! ```

mod cmd;

use clap::{Parser, Subcommand};

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
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Mesh(args) => cmd::mesh::run(args),
        Command::Export(args) => cmd::export::run(args),
    }
}
