//! `sculpt-tools implicit`: evaluate and mesh implicit solids (docs/implicit.md).
//!
//! - `implicit eval MODEL --points P.csv [--out V.txt]`: one value per CSV row (`x,y`
//!   or `x,y,z`; a missing z is 0), one per line.
//! - `implicit eval MODEL --grid NxM[xK] --bounds LO,HI --out V.f32`: little-endian
//!   f32 at the cell centres `LO + (i + 0.5) (HI - LO) / N` on every axis, x fastest;
//!   a 2D grid (`NxM`) samples the plane z = 0.
//! - `implicit mesh MODEL --res N --bounds LO,HI --out M.{stl,obj,glb} [--method M]`:
//!   a closed, manifold, outward-oriented mesh of the solid on an N^3 grid. The
//!   default (`--method octree`) is dual contouring (sharp edges and corners kept,
//!   `sculpt_core::implicit::dual`) with smooth regions collapsed into octree nodes
//!   (`sculpt_core::implicit::octree`), the fewest triangles; `--method dc` is dual
//!   contouring without the collapse, `--method mt` plain marching tetrahedra on the
//!   grid's corners.
//!
//! MODEL is a `.vm` file (Fidget's SSA text, negative inside) or a solid document
//! (JSON, omega >= 0 inside, recognised by its leading `{`). Values written are
//! always negative inside (Fidget's convention): a solid document's omega is negated.
//! `implicit eval` also takes a material document (JSON with a top-level `material`:
//! values interpolated from points and implicit boundaries, `implicit::material`) and
//! writes its field's values as they are. With a 2D `--grid`, `--png P.png` also
//! draws the values (one pixel a cell, a colour bar), white outside a material's
//! `domain` or a solid's inside.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use sculpt_core::formats::MeshFormat;
use sculpt_core::implicit::contour::contour;
use sculpt_core::implicit::dual::{dual_contour, dual_contour_simplified};
use sculpt_core::implicit::material::{self, MaterialDocument};
use sculpt_core::implicit::octree::OctreeSimplify;
use sculpt_core::implicit::tape::Grid;
use sculpt_core::implicit::{Model, Tape};

use super::io;
use super::rfm::{FieldError, FieldView, render_field};

/// Arguments of `implicit`.
#[derive(Debug, Args)]
pub struct ImplicitArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: ImplicitCommand,
}

/// The `implicit` subcommands.
#[derive(Debug, Subcommand)]
pub enum ImplicitCommand {
    /// Values of a model at points or on a grid (negative inside).
    Eval(EvalArgs),
    /// A closed triangle mesh of a model's solid.
    Mesh(MeshArgs),
}

/// Arguments of `implicit eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// The model: `.vm` text or a solid document (JSON); `-` for stdin.
    pub model: PathBuf,
    /// CSV of points, `x,y` or `x,y,z` per line.
    #[arg(long, conflicts_with_all = ["grid", "bounds"], required_unless_present = "grid")]
    pub points: Option<PathBuf>,
    /// Grid cells per axis: `NxM` (the plane z = 0) or `NxMxK`.
    #[arg(long, requires_all = ["bounds", "out"])]
    pub grid: Option<String>,
    /// The grid's bounds on every axis: `LO,HI`.
    #[arg(long, allow_hyphen_values = true)]
    pub bounds: Option<String>,
    /// Output file (required with `--grid`; text to stdout otherwise).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also draw a 2D grid's values as a PNG with a colour bar (white outside the
    /// material's domain, or outside the solid for a model).
    #[arg(long, requires = "grid")]
    pub png: Option<PathBuf>,
}

/// Arguments of `implicit mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    /// The model: `.vm` text or a solid document (JSON); `-` for stdin.
    pub model: PathBuf,
    /// Grid cells per axis.
    #[arg(long)]
    pub res: usize,
    /// The grid's bounds on every axis: `LO,HI`.
    #[arg(long, allow_hyphen_values = true)]
    pub bounds: String,
    /// Output mesh: `.stl`, `.obj` or `.glb`.
    #[arg(long)]
    pub out: PathBuf,
    /// `octree` (the default): dual contouring with octree simplification of smooth
    /// regions (sharp features, fewest triangles); `dc`: dual contouring vertices on
    /// sharp edges and corners, in the marching-tetrahedra mesh; `mt`: marching
    /// tetrahedra (docs/implicit.md).
    #[arg(long, value_enum, default_value_t = MeshMethod::Octree)]
    pub method: MeshMethod,
}

/// How `implicit mesh` meshes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MeshMethod {
    /// Marching tetrahedra.
    Mt,
    /// Dual contouring (sharp features).
    Dc,
    /// Dual contouring with octree simplification (fewer triangles).
    Octree,
}

/// Runs `implicit`.
pub fn run(args: ImplicitArgs) -> Result<()> {
    match args.command {
        ImplicitCommand::Eval(a) => eval(&a),
        ImplicitCommand::Mesh(a) => mesh(&a),
    }
}

fn read_model(path: &Path) -> Result<Model> {
    let text = io::read_input(path)?;
    Model::from_text(&text).with_context(|| format!("{}: invalid model", io::display_name(path)))
}

/// `LO,HI` with finite `LO < HI`.
fn parse_bounds(text: &str) -> Result<(f64, f64)> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [lo, hi] = parts.as_slice() else {
        bail!("--bounds {text:?}: expected LO,HI");
    };
    let lo: f64 = lo
        .parse()
        .with_context(|| format!("--bounds {text:?}: LO is not a number"))?;
    let hi: f64 = hi
        .parse()
        .with_context(|| format!("--bounds {text:?}: HI is not a number"))?;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        bail!("--bounds {text:?}: expected finite LO < HI");
    }
    Ok((lo, hi))
}

/// `NxM` or `NxMxK`, each a positive count; 2D grids get one layer.
fn parse_grid(text: &str) -> Result<([usize; 3], bool)> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    if !(2..=3).contains(&parts.len()) {
        bail!("--grid {text:?}: expected NxM or NxMxK");
    }
    let mut n = [1usize; 3];
    for (slot, p) in n.iter_mut().zip(&parts) {
        *slot = p
            .trim()
            .parse()
            .ok()
            .filter(|&k: &usize| k > 0)
            .with_context(|| format!("--grid {text:?}: {p:?} is not a positive count"))?;
    }
    Ok((n, parts.len() == 2))
}

/// Points `x,y[,z]` per line; blank and `#` lines skipped, a header `x,y[,z]` too.
fn read_points(path: &Path) -> Result<Vec<[f32; 3]>> {
    let text = io::read_input(path)?;
    let name = io::display_name(path);
    let mut points = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let compact = line.replace(' ', "").to_ascii_lowercase();
        if points.is_empty() && (compact == "x,y" || compact == "x,y,z") {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if !(2..=3).contains(&fields.len()) {
            bail!(
                "{name}:{}: expected 2 or 3 numbers, found {}",
                i + 1,
                fields.len()
            );
        }
        let mut p = [0.0f32; 3];
        for (c, f) in p.iter_mut().zip(&fields) {
            let v: f64 = f
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .with_context(|| format!("{name}:{}: {f:?} is not a finite number", i + 1))?;
            *c = v as f32;
        }
        points.push(p);
    }
    Ok(points)
}

/// The tape `implicit eval` evaluates: a model's in Fidget's convention (negative
/// inside), or a material document's field as it is (a material has no inside); and
/// the region a picture shows, as a tape non-negative there (a model's inside, a
/// material's domain; `None`: everywhere).
fn eval_tape(path: &Path) -> Result<(Tape, Option<Tape>)> {
    let text = io::read_input(path)?;
    if material::is_material_document(&text) {
        let context = || format!("{}: invalid material document", io::display_name(path));
        let doc = MaterialDocument::from_json(&text).with_context(context)?;
        return Ok((
            doc.tape().with_context(context)?,
            doc.domain_tape().with_context(context)?,
        ));
    }
    let model = Model::from_text(&text)
        .with_context(|| format!("{}: invalid model", io::display_name(path)))?;
    Ok((
        model.tape_negative_inside(),
        Some(model.tape_positive_inside()),
    ))
}

/// Draws the values of a 2D grid's box, one pixel a cell (`--png`).
fn picture(tape: &Tape, shown: Option<&Tape>, grid: &Grid, path: &Path) -> Result<()> {
    let inside =
        |p: [f64; 2]| shown.is_none_or(|t| t.eval_point([p[0] as f32, p[1] as f32, 0.0]) >= 0.0);
    let values = |pts: &[[f64; 2]]| {
        let pts: Vec<[f32; 3]> = pts
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32, 0.0])
            .collect();
        let mut out = vec![0.0f32; pts.len()];
        tape.eval_points(&pts, &mut out);
        out.into_iter().map(f64::from).collect()
    };
    let view = FieldView {
        lo: [grid.lo[0], grid.lo[1]],
        hi: [grid.hi[0], grid.hi[1]],
        size: grid.n[0] as u32,
        label: "value",
    };
    let picture = render_field(view, inside, values).map_err(|e| match e {
        FieldError::NoPixel => anyhow::anyhow!("--png: no cell of the grid is inside the domain"),
        FieldError::NotFinite => anyhow::anyhow!("--png: no value in the domain is finite"),
        FieldError::Png(e) => e,
    })?;
    io::write_file(path, &picture.png)
}

fn eval(args: &EvalArgs) -> Result<()> {
    let (tape, shown) = eval_tape(&args.model)?;
    if let Some(points) = &args.points {
        io::check_one_stdin(&[&args.model, points])?;
        let pts = read_points(points)?;
        let mut values = vec![0.0f32; pts.len()];
        tape.eval_points(&pts, &mut values);
        let mut out = io::open_output(args.out.as_ref())?;
        for v in values {
            writeln!(out, "{v}").context("cannot write output")?;
        }
        return io::finish_output(out, args.out.as_ref());
    }
    let (Some(grid), Some(bounds), Some(out)) = (&args.grid, &args.bounds, &args.out) else {
        bail!("give --points, or --grid with --bounds and --out");
    };
    let (n, flat) = parse_grid(grid)?;
    let (lo, hi) = parse_bounds(bounds)?;
    // A 2D grid is one layer whose centre is z = 0.
    let (zlo, zhi) = if flat { (-0.5, 0.5) } else { (lo, hi) };
    let grid = Grid::new(n, [lo, lo, zlo], [hi, hi, zhi])?;
    if args.png.is_some() {
        if !flat {
            bail!("--png draws 2D grids (NxM) only");
        }
        if !(64..=4096).contains(&n[0]) {
            bail!(
                "--png: the grid's {} columns are the picture's width: 64 to 4096",
                n[0]
            );
        }
    }
    let values = tape.eval_grid(&grid);
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    io::write_file(out, &bytes)?;
    match &args.png {
        Some(png) => picture(&tape, shown.as_ref(), &grid, png),
        None => Ok(()),
    }
}

fn mesh(args: &MeshArgs) -> Result<()> {
    let format = MeshFormat::from_extension(&args.out.to_string_lossy()).with_context(|| {
        format!(
            "{}: the output must end in .stl, .obj or .glb",
            args.out.display()
        )
    })?;
    let model = read_model(&args.model)?;
    let (lo, hi) = parse_bounds(&args.bounds)?;
    let tape = model.tape_negative_inside();
    let (n, lo3, hi3) = ([args.res; 3], [lo; 3], [hi; 3]);
    let (mesh, dual) = match args.method {
        MeshMethod::Mt => (contour(&tape, n, lo3, hi3)?, None),
        MeshMethod::Dc => {
            let (mesh, report) = dual_contour(&tape, n, lo3, hi3)?;
            (mesh, Some(report))
        }
        MeshMethod::Octree => {
            let settings = OctreeSimplify::default();
            let (mesh, report) = dual_contour_simplified(&tape, n, lo3, hi3, &settings)?;
            (mesh, Some(report))
        }
    };
    if mesh.triangles.is_empty() {
        bail!(
            "{}: the model's surface does not cross the box [{lo}, {hi}]^3",
            io::display_name(&args.model)
        );
    }
    let bytes = format.write(&mesh)?;
    io::write_file(&args.out, &bytes)?;
    match dual {
        None => println!(
            "{{\"vertices\": {}, \"triangles\": {}}}",
            mesh.vertices.len(),
            mesh.triangles.len()
        ),
        Some(r) => println!(
            "{{\"vertices\": {}, \"triangles\": {}, \"fans\": {}, \"kept\": {}, \"split_cells\": {}, \"feature_vertices\": {}, \"flips\": {}{}}}",
            mesh.vertices.len(),
            mesh.triangles.len(),
            r.fans,
            r.kept,
            r.split_cells,
            r.feature_vertices,
            r.flips,
            if args.method == MeshMethod::Octree {
                format!(
                    ", \"node_fans\": {}, \"chain_collapses\": {}, \"widest_node\": {}",
                    r.node_fans, r.chain_collapses, r.widest_node
                )
            } else {
                String::new()
            }
        ),
    }
    Ok(())
}
