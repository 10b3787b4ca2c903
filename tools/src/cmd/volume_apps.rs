//! The applications of `sculpt-tools volume` (Park 2005, sec. 5.2 to 5.4;
//! docs/volumes.md):
//!
//! - `volume streamlines VOL.json --velocity vx,vy,vz --seeds S.csv --time T --out L.csv`:
//!   seeds are physical points (CSV `x,y,z`, optional header); each is mapped to its
//!   parameters and traced (adaptive Dormand-Prince 5(4) in parameter space) for time
//!   `T` or until it leaves the volume, on all cores (`std::thread::scope`). Output rows
//!   `line,x,y,z` after a header, `line` the seed's 0-based row.
//! - `volume critical VOL.json --velocity vx,vy,vz`: prints
//!   `{"critical_points": [{"x", "y", "z", "eigenvalues", "kind"}]}`, the eigenvalues
//!   as `[re, im]` pairs.
//! - `volume isosurface VOL.json --attribute NAME --level L --res N --out M.stl`: the
//!   level set, watertight, as STL, OBJ or GLB (from the extension).
//! - `volume morph A.png B.png --frames F [--lines L.json] --out DIR/`: `F` PNG frames
//!   `DIR/frame_0000.png` .., frame 0 being A and the last B.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use sculpt_core::formats::MeshFormat;
use sculpt_core::volume::morph::{FeatureLines, ImageMorph};
use sculpt_core::volume::{
    FlowField, Streamline, StreamlineEnd, StreamlineOptions, Volume, VolumeError,
};

use super::io;
use super::io::read_volume;

/// Arguments of `volume streamlines`.
#[derive(Debug, clap::Args)]
pub struct StreamlinesArgs {
    /// The volume, JSON (`-` for stdin).
    volume: PathBuf,
    /// The three velocity attributes: `vx,vy,vz`.
    #[arg(long, value_delimiter = ',')]
    velocity: Vec<String>,
    /// CSV of seed points `x,y,z` in physical space (an optional header line).
    #[arg(long)]
    seeds: PathBuf,
    /// How long to trace (negative: backwards).
    #[arg(long, allow_hyphen_values = true)]
    time: f64,
    /// The CSV to write (`line,x,y,z`).
    #[arg(long)]
    out: PathBuf,
    /// Local error per step, relative to the parameter domain.
    #[arg(long, default_value_t = sculpt_core::tolerance::STREAMLINE_STEP_REL)]
    tolerance: f64,
    /// The most steps per streamline.
    #[arg(long, default_value_t = 100_000)]
    max_steps: usize,
}

/// Arguments of `volume critical`.
#[derive(Debug, clap::Args)]
pub struct CriticalArgs {
    /// The volume, JSON (`-` for stdin).
    volume: PathBuf,
    /// The three velocity attributes: `vx,vy,vz`.
    #[arg(long, value_delimiter = ',')]
    velocity: Vec<String>,
}

/// Arguments of `volume isosurface`.
#[derive(Debug, clap::Args)]
pub struct IsosurfaceArgs {
    /// The volume, JSON (`-` for stdin).
    volume: PathBuf,
    /// The attribute whose level set is meshed.
    #[arg(long)]
    attribute: String,
    /// The level.
    #[arg(long, allow_hyphen_values = true)]
    level: f64,
    /// Grid cells per parameter direction.
    #[arg(long, default_value_t = 32)]
    res: usize,
    /// The mesh to write: `.stl`, `.obj` or `.glb`.
    #[arg(long)]
    out: PathBuf,
}

/// Arguments of `volume morph`.
#[derive(Debug, clap::Args)]
pub struct MorphArgs {
    /// The first image (PNG): frame 0.
    a: PathBuf,
    /// The second image (PNG, the same size): the last frame.
    b: PathBuf,
    /// The number of frames (at least 2).
    #[arg(long)]
    frames: usize,
    /// Feature lines (docs/formats/morph-lines.md); without them, a cross-dissolve.
    #[arg(long)]
    lines: Option<PathBuf>,
    /// The directory for `frame_0000.png` .. (created if missing).
    #[arg(long)]
    out: PathBuf,
}

/// The most seeds `volume streamlines` traces.
const MAX_SEEDS: usize = 100_000;
/// Seeds traced together (on all cores) before their lines are written.
const TRACE_BATCH: usize = 256;
/// The most frames `volume morph` writes.
const MAX_FRAMES: usize = 10_000;
/// The largest image file `volume morph` reads (bytes).
const MAX_IMAGE_BYTES: u64 = 64 << 20;

/// The three attribute indices of `--velocity`.
fn velocity_attributes(vol: &Volume, names: &[String]) -> Result<[usize; 3]> {
    if names.len() != 3 {
        bail!(
            "--velocity needs three attribute names (vx,vy,vz), found {}",
            names.len()
        );
    }
    let mut out = [0; 3];
    for (slot, name) in out.iter_mut().zip(names) {
        *slot = vol.attribute_index(name)?;
    }
    Ok(out)
}

/// Runs `volume streamlines`.
pub fn streamlines(args: &StreamlinesArgs) -> Result<()> {
    io::check_one_stdin(&[&args.volume, &args.seeds])?;
    if !args.time.is_finite() {
        bail!("--time {}: not a finite number", args.time);
    }
    if !(args.tolerance > 0.0 && args.tolerance < 1.0) {
        bail!("--tolerance {}: use a number in (0, 1)", args.tolerance);
    }
    let vol = read_volume(&args.volume)?;
    let velocity = velocity_attributes(&vol, &args.velocity)?;
    let field = FlowField::new(&vol, velocity)?;
    let inverter = vol.inverter()?;
    let seeds = io::read_rows::<3>(&args.seeds, "x,y,z")?;
    if seeds.len() > MAX_SEEDS {
        bail!(
            "{}: {} seeds, at most {MAX_SEEDS}",
            io::display_name(&args.seeds),
            seeds.len()
        );
    }
    let opts = StreamlineOptions {
        time: args.time,
        tolerance: args.tolerance,
        max_steps: args.max_steps,
    };
    let seeds_name = io::display_name(&args.seeds);
    let mut out = io::open_output(Some(&args.out))?;
    writeln!(out, "line,x,y,z")?;
    // Every seed is mapped first, so a seed outside fails before any tracing.
    let params = seeds
        .iter()
        .enumerate()
        .map(|(i, s)| {
            inverter
                .invert(glam::DVec3::from_array(*s))
                .with_context(|| format!("{seeds_name}: seed {i}"))
        })
        .collect::<Result<Vec<_>>>()?;
    // Lines are traced on all cores, a batch at a time (bounded memory), and written in
    // seed order.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    for (b, batch) in params.chunks(TRACE_BATCH).enumerate() {
        let per = batch.len().div_ceil(threads);
        let traced: Vec<Result<Streamline, VolumeError>> = std::thread::scope(|scope| {
            let handles: Vec<_> = batch
                .chunks(per)
                .map(|part| {
                    let (field, opts) = (&field, &opts);
                    scope.spawn(move || {
                        part.iter()
                            .map(|u| field.trace(*u, opts))
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        });
        for (j, line) in traced.into_iter().enumerate() {
            let i = b * TRACE_BATCH + j;
            let line = line.with_context(|| format!("{seeds_name}: seed {i}"))?;
            if line.end == StreamlineEnd::Singular {
                let last = line.params.last().copied().unwrap_or(params[i]);
                eprintln!(
                    "warning: streamline {i} stops at parameters {last:?}: the map is singular next to it"
                );
            }
            for p in &line.points {
                writeln!(out, "{i},{},{},{}", p.x, p.y, p.z)?;
            }
        }
    }
    io::finish_output(out, Some(&args.out))
}

/// Runs `volume critical`.
pub fn critical(args: &CriticalArgs) -> Result<()> {
    let vol = read_volume(&args.volume)?;
    let velocity = velocity_attributes(&vol, &args.velocity)?;
    let points = vol.critical_points(velocity)?;
    let list: Vec<serde_json::Value> = points
        .iter()
        .map(|c| {
            serde_json::json!({
                "x": c.point.x,
                "y": c.point.y,
                "z": c.point.z,
                "eigenvalues": c.eigenvalues,
                "kind": c.kind.name(),
            })
        })
        .collect();
    println!("{}", serde_json::json!({ "critical_points": list }));
    Ok(())
}

/// Runs `volume isosurface`.
pub fn isosurface(args: &IsosurfaceArgs) -> Result<()> {
    let format = MeshFormat::from_extension(&args.out.to_string_lossy()).with_context(|| {
        format!(
            "{}: the output must end in .stl, .obj or .glb",
            args.out.display()
        )
    })?;
    let vol = read_volume(&args.volume)?;
    let attr = vol.attribute_index(&args.attribute)?;
    let mesh = vol.isosurface(attr, args.level, [args.res; 3])?;
    if mesh.triangles.is_empty() {
        bail!(
            "{}: attribute {} does not reach the level {} on a {}^3 grid",
            io::display_name(&args.volume),
            args.attribute,
            args.level,
            args.res
        );
    }
    io::write_file(&args.out, &format.write(&mesh)?)?;
    println!(
        "{{\"vertices\": {}, \"triangles\": {}}}",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    Ok(())
}

/// Reads a PNG (or any format the `image` crate's enabled decoders know) as RGBA8.
fn read_rgba(path: &Path) -> Result<(Vec<u8>, usize, usize)> {
    let bytes = fsio::read_capped(path, MAX_IMAGE_BYTES)?;
    let img = image::load_from_memory(&bytes)
        .with_context(|| format!("{}: not a readable PNG image", path.display()))?
        .into_rgba8();
    let (w, h) = (img.width() as usize, img.height() as usize);
    Ok((img.into_raw(), w, h))
}

/// Encodes an RGBA8 buffer as PNG.
fn png_rgba(rgba: &[u8], w: usize, h: usize) -> Result<Vec<u8>> {
    use image::ImageEncoder as _;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(rgba, w as u32, h as u32, image::ExtendedColorType::Rgba8)
        .context("encoding a PNG frame")?;
    Ok(png)
}

/// Runs `volume morph`.
pub fn morph(args: &MorphArgs) -> Result<()> {
    if !(2..=MAX_FRAMES).contains(&args.frames) {
        bail!(
            "--frames {}: use 2 to {MAX_FRAMES} (the first is A, the last B)",
            args.frames
        );
    }
    let lines = match &args.lines {
        Some(p) => FeatureLines::from_json(&io::read_input(p)?)
            .with_context(|| format!("{}: invalid lines", io::display_name(p)))?,
        None => FeatureLines::default(),
    };
    let a = read_rgba(&args.a)?;
    let b = read_rgba(&args.b)?;
    let morph = ImageMorph::new((&a.0, a.1, a.2), (&b.0, b.1, b.2), lines).with_context(|| {
        format!(
            "cannot morph {} into {}",
            args.a.display(),
            args.b.display()
        )
    })?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the directory", args.out.display()))?;
    for f in 0..args.frames {
        let w = f as f64 / (args.frames - 1) as f64;
        let frame = morph.frame(w);
        let path = args.out.join(format!("frame_{f:04}.png"));
        io::write_file(&path, &png_rgba(&frame, a.1, a.2)?)?;
    }
    println!(
        "{{\"frames\": {}, \"width\": {}, \"height\": {}}}",
        args.frames, a.1, a.2
    );
    Ok(())
}
