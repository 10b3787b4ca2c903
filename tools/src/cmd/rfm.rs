//! `sculpt-tools rfm`: mesh-free analysis by the R-function method (docs/implicit.md).
//!
//! `rfm heat SPEC.toml --probes P.csv --out DIR/` solves steady heat conduction on the
//! spec's implicit domain with film conditions on its boundary pieces
//! (`sculpt_core::implicit::rfm`) and writes
//! - `DIR/probes.csv`: `x,y,T` per probe (T in K);
//! - `DIR/temperature.png`: the temperature field over the domain with a colour bar;
//! - `DIR/report.json`: the basis, counts, solve time, temperature range, probes and
//!   the mean temperature on each boundary piece.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use sculpt_core::implicit::Model;
use sculpt_core::implicit::rfm::heat::{HeatSolution, Piece, solve};
use sculpt_core::implicit::rfm::spec::HeatSpec;
use serde_json::json;

use super::io;
use crate::goms::plot::png_bytes;
use crate::goms::text;

/// Arguments of `rfm`.
#[derive(Debug, Args)]
pub struct RfmArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: RfmCommand,
}

/// The `rfm` subcommands.
#[derive(Debug, Subcommand)]
pub enum RfmCommand {
    /// Steady heat conduction with film conditions on an implicit domain.
    Heat(HeatArgs),
}

/// Arguments of `rfm heat`.
#[derive(Debug, Args)]
pub struct HeatArgs {
    /// The problem (TOML: `conductivity`, `[basis]`, `[[boundary]]`).
    pub spec: PathBuf,
    /// CSV of probe points `x,y`.
    #[arg(long)]
    pub probes: PathBuf,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Width of the picture's field in pixels.
    #[arg(long, default_value_t = 400)]
    pub size: u32,
}

/// Runs `rfm`.
pub fn run(args: RfmArgs) -> Result<()> {
    match args.command {
        RfmCommand::Heat(a) => heat(&a),
    }
}

/// The smallest and largest picture widths.
const SIZE_RANGE: std::ops::RangeInclusive<u32> = 64..=4096;

fn heat(args: &HeatArgs) -> Result<()> {
    if !SIZE_RANGE.contains(&args.size) {
        bail!("--size {}: expected 64 to 4096 pixels", args.size);
    }
    let spec_name = io::display_name(&args.spec);
    let text = io::read_input(&args.spec)?;
    let spec =
        HeatSpec::from_toml(&text).with_context(|| format!("{spec_name}: invalid heat spec"))?;
    let settings = spec
        .settings()
        .with_context(|| format!("{spec_name}: invalid heat spec"))?;
    let dir = args.spec.parent().unwrap_or(Path::new("."));
    let mut pieces = Vec::with_capacity(spec.boundary.len());
    for (i, b) in spec.boundary.iter().enumerate() {
        let path = dir.join(&b.model);
        let model_text = io::read_input(&path)
            .with_context(|| format!("{spec_name}: boundary {i}: cannot read its model"))?;
        let model = Model::from_text(&model_text)
            .with_context(|| format!("{}: invalid model", io::display_name(&path)))?;
        pieces.push(Piece {
            model,
            ambient: b.ambient,
            film: b.film,
        });
    }
    let probes = io::read_rows::<2>(&args.probes, "x,y")?;
    let started = Instant::now();
    let solution =
        solve(&settings, &pieces).with_context(|| format!("{spec_name}: cannot solve"))?;
    let solve_seconds = started.elapsed().as_secs_f64();
    let points: Vec<[f64; 2]> = probes.iter().map(|p| [p[0], p[1]]).collect();
    let temps = solution.temperatures(&points);

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut csv = Vec::new();
    writeln!(csv, "x,y,T")?;
    for (p, t) in points.iter().zip(&temps) {
        io::write_row(&mut csv, &[p[0], p[1], *t])?;
    }
    io::write_file(&args.out.join("probes.csv"), &csv)?;

    let picture = render(&solution, args.size)?;
    io::write_file(&args.out.join("temperature.png"), &picture.png)?;

    let counts = solution.counts();
    let (lo, hi) = solution.basis().bounds();
    let report = json!({
        "spec": spec_name,
        "conductivity": spec.conductivity,
        "basis": {
            "degree": solution.basis().degree(),
            "count": solution.basis().count(),
            "bounds": [lo[0], lo[1], hi[0], hi[1]],
        },
        "counts": {
            "unknowns": counts.unknowns,
            "active_unknowns": counts.active,
            "interior_points": counts.interior_points,
            "boundary_points": counts.boundary_points,
        },
        "solve_seconds": solve_seconds,
        "min_T": picture.range.0,
        "max_T": picture.range.1,
        "probes": points.iter().zip(&temps).map(|(p, t)| json!({
            "x": p[0], "y": p[1], "T": t, "inside": solution.omega(*p) >= 0.0,
        })).collect::<Vec<_>>(),
        "boundaries": spec.boundary.iter().zip(solution.boundary_means()).map(|(b, m)| json!({
            "model": b.model, "ambient": b.ambient, "film": b.film,
            "mean_T": if m.is_finite() { json!(m) } else { json!(null) },
        })).collect::<Vec<_>>(),
    });
    let mut bytes = serde_json::to_vec_pretty(&report)?;
    bytes.push(b'\n');
    io::write_file(&args.out.join("report.json"), &bytes)?;
    println!(
        "{}: {} unknowns ({} active), solved in {:.1} ms; T {:.2} .. {:.2} K; wrote {}",
        spec_name,
        counts.unknowns,
        counts.active,
        solve_seconds * 1e3,
        picture.range.0,
        picture.range.1,
        args.out.display()
    );
    Ok(())
}

/// A rendered picture and the value range its colours span.
pub(crate) struct Picture {
    pub(crate) png: Vec<u8>,
    pub(crate) range: (f64, f64),
}

/// Colour stops of the map, cold to hot (a blue-cyan-yellow-red ramp).
const STOPS: [[f64; 3]; 5] = [
    [0.19, 0.21, 0.58],
    [0.17, 0.57, 0.82],
    [0.42, 0.80, 0.45],
    [0.98, 0.80, 0.22],
    [0.80, 0.12, 0.15],
];

/// The colour of `t` in `[0, 1]`.
fn colour(t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let c = |k: usize| ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0).round() as u8;
    [c(0), c(1), c(2)]
}

/// Pixel margins of the picture: around the field, the colour bar's width and its
/// labels' column.
const MARGIN: u32 = 16;
const TITLE: u32 = 28;
const BAR: u32 = 20;
const LABELS: u32 = 96;
const FONT_PX: f32 = 14.0;
const TICKS: usize = 5;

/// Renders the temperature over the basis box (white outside the domain) with a
/// colour bar and its scale labels.
fn render(solution: &HeatSolution, size: u32) -> Result<Picture> {
    let (lo, hi) = solution.basis().bounds();
    let tape = solution.tape();
    let inside = |p: [f64; 2]| tape.eval_point([p[0] as f32, p[1] as f32, 0.0]) >= 0.0;
    let mut picture = render_field(
        FieldView {
            lo,
            hi,
            size,
            label: "T (K)",
        },
        inside,
        |pts| solution.temperatures(pts),
    )
    .map_err(|e| match e {
        FieldError::NoPixel => {
            anyhow::anyhow!("the picture has no pixel inside the domain (try a larger --size)")
        }
        FieldError::NotFinite => anyhow::anyhow!("the temperature is not finite in the domain"),
        FieldError::Png(e) => e,
    })?;
    picture.range = (
        picture.range.0.min(solution.range().0),
        picture.range.1.max(solution.range().1),
    );
    Ok(picture)
}

/// The box and size of a field picture, and its colour bar's title.
pub(crate) struct FieldView<'a> {
    pub(crate) lo: [f64; 2],
    pub(crate) hi: [f64; 2],
    /// Width of the field in pixels.
    pub(crate) size: u32,
    pub(crate) label: &'a str,
}

/// Why a field picture could not be drawn.
#[derive(Debug)]
pub(crate) enum FieldError {
    /// No pixel centre is inside the domain.
    NoPixel,
    /// No value inside the domain is finite.
    NotFinite,
    /// PNG encoding failed.
    Png(anyhow::Error),
}

/// Renders a scalar field over `view`'s box (white where `inside` is false, the
/// values of the pixel centres from `values` elsewhere) with a colour bar and its
/// scale labels.
pub(crate) fn render_field(
    view: FieldView<'_>,
    inside: impl Fn([f64; 2]) -> bool,
    values: impl FnOnce(&[[f64; 2]]) -> Vec<f64>,
) -> Result<Picture, FieldError> {
    let FieldView {
        lo,
        hi,
        size,
        label,
    } = view;
    let fw = size;
    let fh =
        ((f64::from(size) * (hi[1] - lo[1]) / (hi[0] - lo[0])).round() as u32).clamp(16, 4 * size);
    let width = MARGIN + fw + MARGIN + BAR + 8 + LABELS;
    let height = TITLE + fh + MARGIN;
    // The field, row 0 at the top (largest y).
    let mut field = vec![f64::NAN; (fw * fh) as usize];
    let mut pts = Vec::new();
    let mut slots = Vec::new();
    for r in 0..fh {
        for c in 0..fw {
            let x = lo[0] + (f64::from(c) + 0.5) * (hi[0] - lo[0]) / f64::from(fw);
            let y = hi[1] - (f64::from(r) + 0.5) * (hi[1] - lo[1]) / f64::from(fh);
            if inside([x, y]) {
                pts.push([x, y]);
                slots.push((r * fw + c) as usize);
            }
        }
    }
    if pts.is_empty() {
        return Err(FieldError::NoPixel);
    }
    for (s, t) in slots.iter().zip(values(&pts)) {
        field[*s] = t;
    }
    let (mut tmin, mut tmax) = field
        .iter()
        .filter(|t| t.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
            (a.min(t), b.max(t))
        });
    if !(tmin.is_finite() && tmax.is_finite()) {
        return Err(FieldError::NotFinite);
    }
    if tmax - tmin < f64::EPSILON * tmax.abs().max(1.0) {
        tmin -= 0.5;
        tmax += 0.5;
    }
    let mut canvas = Canvas {
        rgb: vec![255u8; (width * height * 3) as usize],
        width,
        height,
    };
    let mut put = |x: u32, y: u32, c: [u8; 3]| canvas.put(x, y, c);
    for r in 0..fh {
        for c in 0..fw {
            let t = field[(r * fw + c) as usize];
            if t.is_finite() {
                put(MARGIN + c, TITLE + r, colour((t - tmin) / (tmax - tmin)));
            }
        }
    }
    // The colour bar: high values at the top, framed.
    let bx = MARGIN + fw + MARGIN;
    for r in 0..fh {
        let c = colour(1.0 - (f64::from(r) + 0.5) / f64::from(fh));
        for k in 0..BAR {
            put(bx + k, TITLE + r, c);
        }
    }
    for k in 0..BAR {
        put(bx + k, TITLE, [0; 3]);
        put(bx + k, TITLE + fh - 1, [0; 3]);
    }
    for r in 0..fh {
        put(bx, TITLE + r, [0; 3]);
        put(bx + BAR - 1, TITLE + r, [0; 3]);
    }
    // Labels: the tick values, with enough decimals to tell them apart.
    let step = (tmax - tmin) / (TICKS - 1) as f64;
    let decimals = (2.0 - step.log10().floor()).clamp(0.0, 6.0) as usize;
    for k in 0..TICKS {
        let value = tmin + step * k as f64;
        let y = TITLE + fh - 1 - ((fh - 1) as f64 * k as f64 / (TICKS - 1) as f64).round() as u32;
        for d in 0..5 {
            canvas.put(bx + BAR + d, y, [0; 3]);
        }
        canvas.text(
            &format!("{value:.decimals$}"),
            bx + BAR + 8,
            y.saturating_sub(8),
        );
    }
    canvas.text(label, bx, 6);
    let span = format!(
        "x {:.3} .. {:.3}, y {:.3} .. {:.3}",
        lo[0], hi[0], lo[1], hi[1]
    );
    canvas.text(&span, MARGIN, 6);
    Ok(Picture {
        png: png_bytes(&canvas.rgb, (width, height)).map_err(FieldError::Png)?,
        range: (tmin, tmax),
    })
}

/// An RGB raster with clipped pixel writes and text.
struct Canvas {
    rgb: Vec<u8>,
    width: u32,
    height: u32,
}

impl Canvas {
    fn put(&mut self, x: u32, y: u32, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let at = ((y * self.width + x) * 3) as usize;
            self.rgb[at..at + 3].copy_from_slice(&c);
        }
    }

    /// Black text (DejaVu Sans, antialiased onto white) with its top-left at `x, y`.
    fn text(&mut self, s: &str, x: u32, y: u32) {
        text::rasterise(s, FONT_PX, |dx, dy, cov| {
            let (px, py) = (x as i32 + dx, y as i32 + dy);
            if px >= 0 && py >= 0 && cov > 0.0 {
                let g = (255.0 * (1.0 - cov.min(1.0))) as u8;
                self.put(px as u32, py as u32, [g; 3]);
            }
        });
    }
}
