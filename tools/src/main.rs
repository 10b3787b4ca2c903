//! # sculpt-tools
//!
//! The Wandsculpt command-line tools. Each subcommand lives in its own module under
//! `cmd/`; adding one means a module, one variant of `Command` and one match arm.
//!
//! - `sculpt-tools eval --surface S.json --uv UV.csv`: surface points `x,y,z` for the
//!   parameters `u,v` of each line.
//! - `sculpt-tools project --surface S.json --points P.csv`: the closest surface point of
//!   each query `x,y,z`, as `u,v,x,y,z,distance`.
//! - `sculpt-tools mesh --scene S.json [--depth interactive|final] --out X.{obj,stl,glb}`:
//!   tessellate a sculpted scene and write the mesh.
//! - `sculpt-tools export --scene S.json --out X.igs`: its NURBS surfaces as IGES 5.3.
//! - `sculpt-tools goms ...`: the GOMS / KLM timing-study harness.
//! - `sculpt-tools tilt2poselog IN.tilt --out OUT.poselog`: Open Brush strokes as a
//!   recorded wand session.
//! - `sculpt-tools reconstruct POINTS --patches K [--degree 2|3] [--control N] [--out
//!   scan.json] [--igs X.igs] [--obj X.obj] [--report R.json] [--layout L.ply]`: scan
//!   points into a network of NURBS patches to sculpt on (docs/reconstruct.md).
//! - `sculpt-tools implicit eval MODEL (--points P.csv | --grid NxM[xK] --bounds LO,HI
//!   --out V.f32)` and `implicit mesh MODEL --res N --bounds LO,HI --out M.stl`:
//!   implicit solids (docs/implicit.md).
//!
//! Pure: the tools link only `sculpt-core` and the pure layer of `tracking` (the
//! `.tilt` codec, the importer and pose logs, `default-features = false`), never a GPU,
//! window system or async runtime (`cargo tree -p sculpt-tools` shows no `wgpu`,
//! `winit` or `tokio`).
//!
//! Input files may be `-` for stdin; `--out FILE` writes to a file instead of stdout.
//! Any bad input ends with one line on stderr naming the file and line, and exit code 1.
//!
//! ```text
//! sculpt-tools project --surface patch.json --points queries.csv --out answers.csv
//! sculpt-tools mesh --scene tests/data/scenes/sphere-overlaps.json --depth final --out sphere.stl
//! sculpt-tools goms klm builtin:multires-sculpting
//! ```

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod goms;
mod progress;
// some of its tolerances only the unit tests use
#[cfg_attr(not(test), allow(dead_code))]
mod tolerance;

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
    /// Tessellate a scene and write the sculpted mesh (OBJ, STL or GLB).
    Mesh(cmd::mesh::MeshArgs),
    /// Write a scene's NURBS surfaces as IGES 5.3 (trimmed surfaces, entity 144).
    Export(cmd::export::ExportArgs),
    /// GOMS / KLM timing studies: operator extraction, KLM predictions, study reports.
    Goms(cmd::goms::GomsArgs),
    /// Convert an Open Brush `.tilt` sketch into a pose log (each stroke a button-down,
    /// sweep, button-up at its recorded timing).
    Tilt2poselog(cmd::tilt2poselog::Tilt2PoselogArgs),
    /// Scan reconstruction: points to a network of NURBS patches (a document, IGES,
    /// OBJ), with a report and a patch-layout PLY.
    Reconstruct(cmd::reconstruct::ReconstructArgs),
    /// Volumetric NURBS (Park 2005): evaluate, fit, analyse, grids (docs/volumes.md).
    Volume(cmd::volume::VolumeArgs),
    /// Implicit solids (`.vm` or solid documents): evaluate at points or on a grid,
    /// or mesh them.
    Implicit(cmd::implicit::ImplicitArgs),
    /// Mesh-free analysis by the R-function method: steady heat conduction with film
    /// conditions on an implicit domain (docs/implicit.md).
    Rfm(cmd::rfm::RfmArgs),
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Eval(args) => cmd::eval::run(&args),
        Command::Project(args) => cmd::project::run(&args),
        Command::Mesh(args) => cmd::mesh::run(args),
        Command::Export(args) => cmd::export::run(args),
        Command::Goms(args) => cmd::goms::run(args),
        Command::Tilt2poselog(args) => cmd::tilt2poselog::run(args),
        Command::Reconstruct(args) => cmd::reconstruct::run(args),
        Command::Volume(args) => cmd::volume::run(args),
        Command::Implicit(args) => cmd::implicit::run(args),
        Command::Rfm(args) => cmd::rfm::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader closed the pipe (`| head`): it has all it wanted.
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            // One line: the context chain joined with ": ", newlines flattened.
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("sculpt-tools: {msg}");
            ExitCode::FAILURE
        }
    }
}
