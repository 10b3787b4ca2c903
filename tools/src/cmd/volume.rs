//! `sculpt-tools volume`: volumetric NURBS (Park 2005) from the command line
//! (docs/volumes.md, docs/formats/volume.md).
//!
//! - `volume eval VOL.json --params P.csv [--derivatives 1]`: one CSV row per input row,
//!   the `k` attribute values, then (with `--derivatives 1`) `d/du1` of every
//!   attribute, `d/du2`, and so on. Parameters are in the knot domain.
//! - `volume fit DATA.csv --params n --degrees p1,..,pn --counts c1,..,cn --out VOL.json`:
//!   scattered samples (a header row; `n` parameter columns, then the attributes named
//!   by the header) to a volume: least squares, or the minimum-norm interpolant when
//!   there are fewer samples than control points.
//! - `volume analyze VOL.json --integrate`: `{"volume": V, "integrals": {...}}`.
//! - `volume grid VOL.json --res r1,..,rn --out G.vtk [--binary]`: the volume sampled
//!   on a uniform parameter grid, as a legacy VTK structured grid (first index
//!   fastest), the geometry as points and the other attributes as point data.
//! - `volume streamlines`, `critical`, `isosurface`, `morph`: the applications, in
//!   [`super::volume_apps`].

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use sculpt_core::volume::{PointArray, StructuredGrid, Volume};

use super::io;

/// Arguments of `volume`.
#[derive(Debug, clap::Args)]
pub struct VolumeArgs {
    #[command(subcommand)]
    command: VolumeCommand,
}

#[derive(Debug, clap::Subcommand)]
enum VolumeCommand {
    /// Evaluate a volume at parameters: one CSV row of attribute values (and first
    /// derivatives) per row of parameters.
    Eval(EvalArgs),
    /// Fit a volume to scattered samples with known parameters.
    Fit(FitArgs),
    /// Analyse a volume: its volume and the integral of every attribute.
    Analyze(AnalyzeArgs),
    /// Sample a volume on a uniform parameter grid into a legacy VTK structured grid.
    Grid(GridArgs),
    /// Trace streamlines of a velocity attribute from physical seed points.
    Streamlines(super::volume_apps::StreamlinesArgs),
    /// Find and classify the zeros of a velocity attribute.
    Critical(super::volume_apps::CriticalArgs),
    /// Mesh a level set of an attribute (watertight) into STL, OBJ or GLB.
    Isosurface(super::volume_apps::IsosurfaceArgs),
    /// Morph one image into another through an image volume: PNG frames.
    Morph(super::volume_apps::MorphArgs),
}

/// Arguments of `volume fit`.
#[derive(Debug, clap::Args)]
struct FitArgs {
    /// CSV samples with a header row: `n` parameter columns, then the attributes.
    data: PathBuf,
    /// The number of parameter columns `n` (1 to 4).
    #[arg(long)]
    params: usize,
    /// Degrees, one per direction: `3,3,3`.
    #[arg(long, value_delimiter = ',')]
    degrees: Vec<usize>,
    /// Control points per direction: `8,8,8`.
    #[arg(long, value_delimiter = ',')]
    counts: Vec<usize>,
    /// The volume file to write.
    #[arg(long)]
    out: PathBuf,
}

/// Arguments of `volume grid`.
#[derive(Debug, clap::Args)]
struct GridArgs {
    /// The volume, JSON (`-` for stdin).
    volume: PathBuf,
    /// Grid points per direction: `20,10,5` (each at least 2).
    #[arg(long, value_delimiter = ',')]
    res: Vec<usize>,
    /// The `.vtk` file to write (with `--f32`: the raw values).
    #[arg(long)]
    out: PathBuf,
    /// Write VTK BINARY (big-endian doubles) instead of ASCII.
    #[arg(long, conflicts_with = "f32")]
    binary: bool,
    /// Write raw little-endian f32 instead of VTK: every attribute (`k` values per
    /// point, in the file's order), the first index fastest; the layout of
    /// `wandsculpt --gpu-volume-eval`, for comparing the two.
    #[arg(long)]
    f32: bool,
}

/// Arguments of `volume eval`.
#[derive(Debug, clap::Args)]
struct EvalArgs {
    /// The volume, JSON (`-` for stdin).
    volume: PathBuf,
    /// CSV rows of `n` parameters (an optional header line of names is skipped).
    #[arg(long)]
    params: PathBuf,
    /// 1: append the `n x k` first partial derivatives to every row.
    #[arg(long, default_value_t = 0)]
    derivatives: usize,
    /// Write the rows here instead of stdout.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Arguments of `volume analyze`.
#[derive(Debug, clap::Args)]
struct AnalyzeArgs {
    /// The volume, JSON (`-` for stdin).
    volume: PathBuf,
    /// Print the volume (area, length) and the integral of every attribute.
    #[arg(long)]
    integrate: bool,
    /// Gauss-Legendre points per direction and knot span.
    #[arg(long, default_value_t = 8)]
    gauss: usize,
}

/// Runs `volume`.
pub fn run(args: VolumeArgs) -> Result<()> {
    match args.command {
        VolumeCommand::Eval(a) => eval(&a),
        VolumeCommand::Fit(a) => fit(&a),
        VolumeCommand::Analyze(a) => analyze(&a),
        VolumeCommand::Grid(a) => grid(&a),
        VolumeCommand::Streamlines(a) => super::volume_apps::streamlines(&a),
        VolumeCommand::Critical(a) => super::volume_apps::critical(&a),
        VolumeCommand::Isosurface(a) => super::volume_apps::isosurface(&a),
        VolumeCommand::Morph(a) => super::volume_apps::morph(&a),
    }
}

/// Parses CSV rows of `n` finite numbers; a first line that does not parse as numbers
/// is a header and skipped. Errors name the file and the 1-based line.
fn read_param_rows(path: &Path, n: usize) -> Result<Vec<Vec<f64>>> {
    let text = io::read_input(path)?;
    let name = io::display_name(path);
    let mut rows = Vec::new();
    let mut first = true;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed: Vec<Option<f64>> = fields.iter().map(|f| f.parse::<f64>().ok()).collect();
        if first && parsed.iter().all(Option::is_none) {
            first = false;
            continue;
        }
        first = false;
        if fields.len() != n {
            bail!(
                "{name}:{}: expected {n} comma-separated parameters, found {} fields",
                i + 1,
                fields.len()
            );
        }
        let mut row = Vec::with_capacity(n);
        for (f, v) in fields.iter().zip(parsed) {
            match v {
                Some(x) if x.is_finite() => row.push(x),
                Some(_) => bail!("{name}:{}: {} is not a finite number", i + 1, io::quote(f)),
                None => bail!("{name}:{}: {} is not a number", i + 1, io::quote(f)),
            }
        }
        rows.push(row);
    }
    Ok(rows)
}

fn eval(args: &EvalArgs) -> Result<()> {
    io::check_one_stdin(&[&args.volume, &args.params])?;
    if args.derivatives > 1 {
        bail!(
            "--derivatives {}: only 0 (values) and 1 (values and first derivatives) are printed",
            args.derivatives
        );
    }
    let vol = io::read_volume(&args.volume)?;
    let n = vol.directions();
    let k = vol.components();
    let rows = read_param_rows(&args.params, n)?;
    let width = if args.derivatives == 1 {
        k * (n + 1)
    } else {
        k
    };
    let mut values = vec![0.0; width];
    let mut out = io::open_output(args.out.as_ref())?;
    for (i, u) in rows.iter().enumerate() {
        let r = if args.derivatives == 1 {
            vol.eval_d1_into(u, &mut values)
        } else {
            vol.eval_into(u, &mut values)
        };
        r.with_context(|| format!("{}: row {}", io::display_name(&args.params), i + 1))?;
        io::write_row(&mut out, &values).context("cannot write output")?;
    }
    io::finish_output(out, args.out.as_ref())
}

fn analyze(args: &AnalyzeArgs) -> Result<()> {
    if !args.integrate {
        bail!("volume analyze: say what to compute (--integrate)");
    }
    if args.gauss == 0 || args.gauss > 64 {
        bail!("--gauss {}: use 1 to 64 points per span", args.gauss);
    }
    let vol = io::read_volume(&args.volume)?;
    let totals = vol.integrate(args.gauss);
    let integrals: serde_json::Map<String, serde_json::Value> = vol
        .attributes()
        .iter()
        .zip(&totals.integrals)
        .map(|(name, v)| (name.clone(), serde_json::Value::from(*v)))
        .collect();
    let doc = serde_json::json!({"volume": totals.measure, "integrals": integrals});
    println!("{doc}");
    Ok(())
}

/// The most grid points `volume grid` writes (a 512^3 grid would be gigabytes).
const MAX_GRID_POINTS: usize = 1 << 24;

fn fit(args: &FitArgs) -> Result<()> {
    let name = io::display_name(&args.data);
    let n = args.params;
    if n == 0 || n > 4 {
        bail!("--params {n}: a volume has 1 to 4 parameter directions");
    }
    if args.degrees.len() != n || args.counts.len() != n {
        bail!(
            "--degrees and --counts need {n} values each (one per parameter), found {} and {}",
            args.degrees.len(),
            args.counts.len()
        );
    }
    let text = io::read_input(&args.data)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((_, header)) = lines.next() else {
        bail!("{name}: empty (expected a header row and samples)");
    };
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    if names.len() <= n {
        bail!(
            "{name}:1: the header has {} columns; {n} parameters need at least one attribute after them",
            names.len()
        );
    }
    let attributes = names[n..].to_vec();
    let width = names.len();
    let (mut params, mut values) = (Vec::new(), Vec::new());
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != width {
            bail!(
                "{name}:{}: expected {width} columns as the header has, found {}",
                i + 1,
                fields.len()
            );
        }
        for (c, f) in fields.iter().enumerate() {
            let v: f64 = f
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    anyhow::anyhow!("{name}:{}: {} is not a finite number", i + 1, io::quote(f))
                })?;
            if c < n {
                params.push(v)
            } else {
                values.push(v)
            }
        }
    }
    let vol = Volume::fit_scattered(&params, &values, attributes, &args.degrees, &args.counts)
        .with_context(|| format!("{name}: cannot fit"))?;
    io::write_file(&args.out, vol.to_json().as_bytes())
}

fn grid(args: &GridArgs) -> Result<()> {
    let vol = io::read_volume(&args.volume)?;
    let n = vol.directions();
    if args.res.len() != n {
        bail!(
            "--res needs {n} values (one per direction), found {}",
            args.res.len()
        );
    }
    if let Some(r) = args.res.iter().find(|&&r| r < 2) {
        bail!("--res: {r} points cannot span a direction (need at least 2)");
    }
    let total = args.res.iter().try_fold(1usize, |a, &r| a.checked_mul(r));
    if total.is_none_or(|t| t > MAX_GRID_POINTS) {
        bail!(
            "--res {:?}: more than {MAX_GRID_POINTS} grid points",
            args.res
        );
    }
    let total = total.unwrap_or(0);
    if args.f32 {
        let values = vol.eval_grid_f32(&args.res)?;
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        return io::write_file(&args.out, &bytes);
    }
    let mut dims = [1usize; 3];
    dims[..n.min(3)].copy_from_slice(&args.res[..n.min(3)]);
    if n == 4 {
        // VTK grids are 3D: the fourth direction is flattened into the third.
        dims[2] *= args.res[3];
    }
    let geometry = vol.geometry();
    let others: Vec<usize> = (0..vol.components())
        .filter(|c| !geometry.contains(c))
        .collect();
    let domain = vol.domain();
    let mut points = Vec::with_capacity(total);
    let mut data = vec![Vec::with_capacity(total); others.len()];
    let mut value = vec![0.0; vol.components()];
    let mut u = vec![0.0; n];
    for flat in 0..total {
        // The first index varies fastest, as VTK orders points.
        let mut rest = flat;
        for d in 0..n {
            let i = rest % args.res[d];
            rest /= args.res[d];
            let (a, b) = domain[d];
            u[d] = a + (b - a) * i as f64 / (args.res[d] - 1) as f64;
        }
        vol.eval_into(&u, &mut value)?;
        let mut p = [0.0; 3];
        for (slot, c) in p.iter_mut().enumerate() {
            *c = match geometry.get(slot) {
                Some(&g) => value[g],
                None if geometry.is_empty() => u.get(slot).copied().unwrap_or(0.0),
                None => 0.0,
            };
        }
        points.push(p);
        for (dst, &c) in data.iter_mut().zip(&others) {
            dst.push(value[c]);
        }
    }
    let arrays = others
        .iter()
        .zip(data)
        .map(|(&c, values)| PointArray {
            name: vol.attributes()[c].clone(),
            components: 1,
            values,
        })
        .collect();
    let g = StructuredGrid {
        dims,
        points,
        arrays,
    };
    let title = format!(
        "wandsculpt volume grid of {}",
        io::display_name(&args.volume)
    );
    io::write_file(&args.out, &g.to_vtk(&title, args.binary))
}
