//! `sculpt-tools eval`: surface points at given parameters.

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::io;

/// Arguments of `eval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The surface, JSON (`-` for stdin).
    #[arg(long)]
    pub surface: PathBuf,
    /// Lines `u,v` (`-` for stdin). Parameters outside the domain are clamped to it.
    #[arg(long)]
    pub uv: PathBuf,
    /// Write `x,y,z` lines here instead of stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `eval`.
pub fn run(args: &Args) -> Result<()> {
    io::check_one_stdin(&[&args.surface, &args.uv])?;
    let surface = io::read_surface(&args.surface)?;
    let rows = io::read_rows::<2>(&args.uv, "u,v")?;
    let mut out = io::open_output(args.out.as_ref())?;
    for [u, v] in rows {
        let p = surface.point(u, v);
        io::write_row(&mut out, &p.to_array()).context("cannot write output")?;
    }
    io::finish_output(out, args.out.as_ref())
}
