//! `sculpt-tools project`: closest points on a surface (point inversion).

use std::path::PathBuf;

use anyhow::{Context, Result};
use glam::DVec3;

use super::io;

/// Arguments of `project`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The surface, JSON (`-` for stdin).
    #[arg(long)]
    pub surface: PathBuf,
    /// Lines `x,y,z` (`-` for stdin).
    #[arg(long)]
    pub points: PathBuf,
    /// Write `u,v,x,y,z,distance` lines here instead of stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `project`: one output line per query, in input order, computed in parallel.
pub fn run(args: &Args) -> Result<()> {
    io::check_one_stdin(&[&args.surface, &args.points])?;
    let surface = io::read_surface(&args.surface)?;
    let rows = io::read_rows::<3>(&args.points, "x,y,z")?;
    let queries: Vec<DVec3> = rows.iter().map(|r| DVec3::from_array(*r)).collect();
    let answers = surface.inverter().closest_points(&queries);
    let mut out = io::open_output(args.out.as_ref())?;
    for a in answers {
        let row = [
            a.uv_in_knots.x,
            a.uv_in_knots.y,
            a.point.x,
            a.point.y,
            a.point.z,
            a.distance,
        ];
        io::write_row(&mut out, &row).context("cannot write output")?;
    }
    io::finish_output(out, args.out.as_ref())
}
