//! Plots, each written as SVG and PNG with plotters: stacked operator bars per method
//! (the paper's Tables 3 and 4), per-participant strips, an operator Gantt chart of one
//! trial, and the speed trace of one trial with its detected movements.
//!
//! Text uses DejaVu Sans, shipped in `tools/assets/` (Bitstream Vera licence) and
//! registered with plotters' `ab_glyph` backend, so no system font library is needed.

use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::extract::{ExtractConfig, OpKind, Trial};
use super::study::Analysis;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The shipped font is a valid TrueType file; a failure would show as missing
        // text, reported by the drawing calls.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

trait Plt<T> {
    fn p(self) -> Result<T>;
}

impl<T, E: std::fmt::Debug> Plt<T> for std::result::Result<T, E> {
    fn p(self) -> Result<T> {
        self.map_err(|e| anyhow!("plotting failed: {e:?}"))
    }
}

/// The colour of an operator kind.
fn colour(op: OpKind) -> RGBColor {
    match op {
        OpKind::P => RGBColor(0x4c, 0x72, 0xb0),
        OpKind::K => RGBColor(0xdd, 0x84, 0x52),
        OpKind::B => RGBColor(0xc4, 0x4e, 0x52),
        OpKind::M => RGBColor(0x55, 0xa8, 0x68),
        OpKind::H => RGBColor(0x81, 0x72, 0xb3),
    }
}

macro_rules! both {
    ($stem:expr, $size:expr, $draw:ident ( $($arg:expr),* )) => {{
        register_font();
        let svg = $stem.with_extension("svg");
        let png = $stem.with_extension("png");
        {
            let root = SVGBackend::new(&svg, $size).into_drawing_area();
            $draw(&root, $($arg),*)?;
            root.present().p()?;
        }
        {
            let root = BitMapBackend::new(&png, $size).into_drawing_area();
            $draw(&root, $($arg),*)?;
            root.present().p()?;
        }
        Ok::<Vec<PathBuf>, anyhow::Error>(vec![svg, png])
    }};
}

/// Writes every study plot into `dir`; returns the files written.
pub fn study_plots(dir: &Path, a: &Analysis) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if a.methods.is_empty() {
        return Ok(files);
    }
    files.extend(both!(
        dir.join("operations_by_method"),
        (800, 500),
        bars(a, false)
    )?);
    files.extend(both!(
        dir.join("time_by_method"),
        (800, 500),
        bars(a, true)
    )?);
    files.extend(both!(dir.join("participants_time"), (800, 500), strips(a))?);
    Ok(files)
}

/// Writes the Gantt chart and speed trace of one trial into `dir`.
pub fn trial_plots(dir: &Path, t: &Trial, cfg: &ExtractConfig) -> Result<Vec<PathBuf>> {
    let tag = format!("{}_{}_{}", safe(&t.participant), safe(&t.method), t.trial);
    let mut files = both!(dir.join(format!("gantt_{tag}")), (900, 300), gantt(t))?;
    files.extend(both!(
        dir.join(format!("speed_{tag}")),
        (900, 400),
        speed(t, cfg)
    )?);
    Ok(files)
}

/// A file-name-safe version of an id.
pub fn safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart with one category per method along x (at 0, 1, ...) and `0..top` along y,
/// its mesh and labels drawn.
fn method_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    a: &Analysis,
    caption: &str,
    top: f64,
    y_desc: &str,
) -> Result<Chart<'a, DB>> {
    let n = a.methods.len();
    let labels: Vec<String> = a.methods.iter().map(|m| m.label.clone()).collect();
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), 0.0..top)
        .p()?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n.max(2) * 2 + 1)
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < sculpt_core::tolerance::AXIS_INTEGER_EPS
                && i >= 0.0
                && (i as usize) < labels.len()
            {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        })
        .y_desc(y_desc)
        .label_style(("sans-serif", 13))
        .draw()
        .p()?;
    Ok(chart)
}

/// Draws the series legend of a chart.
fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>) -> Result<()> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .p()
}

fn bars<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, a: &Analysis, time: bool) -> Result<()> {
    root.fill(&WHITE).p()?;
    let top = a
        .methods
        .iter()
        .map(|m| {
            if time {
                m.total_time.mean
            } else {
                m.total_count.mean
            }
        })
        .fold(0.0, f64::max)
        .max(sculpt_core::tolerance::PLOT_RANGE_MIN)
        * 1.15;
    let caption = if time {
        "Mean execution time per method (s)"
    } else {
        "Mean operations per method"
    };
    let mut chart = method_chart(
        root,
        a,
        caption,
        top,
        if time { "seconds" } else { "operations" },
    )?;
    for (k, &op) in a.ops.iter().enumerate() {
        let rects: Vec<_> = a
            .methods
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let d = if time { &m.time } else { &m.count };
                let below: f64 = d[..k].iter().map(|x| x.mean).sum();
                let x = i as f64;
                Rectangle::new(
                    [(x - 0.3, below), (x + 0.3, below + d[k].mean)],
                    colour(op).filled(),
                )
            })
            .collect();
        chart
            .draw_series(rects)
            .p()?
            .label(op.letter())
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour(op).filled())
            });
    }
    legend(&mut chart)
}

fn strips<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, a: &Analysis) -> Result<()> {
    root.fill(&WHITE).p()?;
    let top = a
        .methods
        .iter()
        .flat_map(|m| m.per_participant.iter().map(|p| p.2))
        .fold(0.0, f64::max)
        .max(sculpt_core::tolerance::PLOT_RANGE_MIN)
        * 1.15;
    let mut chart = method_chart(root, a, "Total time per participant (s)", top, "seconds")?;
    for (i, m) in a.methods.iter().enumerate() {
        let k = m.per_participant.len().max(1) as f64;
        chart
            .draw_series(m.per_participant.iter().enumerate().map(|(j, p)| {
                // Spread the dots evenly across the strip, in participant order.
                let x = i as f64 - 0.2 + 0.4 * (j as f64 + 0.5) / k;
                Circle::new((x, p.2), 4, colour(OpKind::P).filled())
            }))
            .p()?;
        let mean = m.total_time.mean;
        chart
            .draw_series(LineSeries::new(
                [(i as f64 - 0.3, mean), (i as f64 + 0.3, mean)],
                BLACK.stroke_width(2),
            ))
            .p()?;
    }
    Ok(())
}

fn gantt<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, t: &Trial) -> Result<()> {
    root.fill(&WHITE).p()?;
    let kinds: Vec<OpKind> = OpKind::ALL
        .into_iter()
        .filter(|k| t.ops.iter().any(|o| o.op == *k))
        .collect();
    let rows = kinds.len().max(1);
    let (t0, t1) = (t.t0, t.t1.max(t.t0 + sculpt_core::tolerance::MIN_PLOT_SPAN));
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!(
                "Operators: {} / {} / trial {}",
                t.participant, t.method, t.trial
            ),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(40)
        .build_cartesian_2d(t0..t1, -0.5f64..(rows as f64 - 0.5))
        .p()?;
    let names: Vec<&str> = kinds.iter().map(|k| k.letter()).collect();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(rows * 2 + 1)
        .y_label_formatter(&|y| {
            let i = y.round();
            if (y - i).abs() < sculpt_core::tolerance::AXIS_INTEGER_EPS
                && i >= 0.0
                && (i as usize) < names.len()
            {
                names[i as usize].to_owned()
            } else {
                String::new()
            }
        })
        .x_desc("seconds")
        .label_style(("sans-serif", 13))
        .draw()
        .p()?;
    for (r, k) in kinds.iter().enumerate() {
        chart
            .draw_series(t.ops.iter().filter(|o| o.op == *k).map(|o| {
                let y = r as f64;
                // Zero-length operators still show as a thin bar.
                let end = o.t_end.max(o.t_start + (t1 - t0) * 0.002);
                Rectangle::new(
                    [(o.t_start, y - 0.35), (end, y + 0.35)],
                    colour(*k).filled(),
                )
            }))
            .p()?;
    }
    Ok(())
}

fn speed<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    t: &Trial,
    cfg: &ExtractConfig,
) -> Result<()> {
    root.fill(&WHITE).p()?;
    let (t0, t1) = (t.t0, t.t1.max(t.t0 + sculpt_core::tolerance::MIN_PLOT_SPAN));
    let vmax = t
        .speed
        .iter()
        .map(|s| s.1)
        .fold(cfg.v_on, f64::max)
        .max(sculpt_core::tolerance::PLOT_SPEED_MIN)
        * 1.1;
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!(
                "Wand speed: {} / {} / trial {}",
                t.participant, t.method, t.trial
            ),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(t0..t1, 0.0..vmax)
        .p()?;
    chart
        .configure_mesh()
        .x_desc("seconds")
        .y_desc("m/s")
        .label_style(("sans-serif", 13))
        .draw()
        .p()?;
    for o in t.ops.iter().filter(|o| o.op == OpKind::P) {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(o.t_start, 0.0), (o.t_end, vmax)],
                colour(OpKind::P).mix(0.15).filled(),
            )))
            .p()?;
    }
    for o in t.ops.iter().filter(|o| o.op == OpKind::M) {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(o.t_start, 0.0), (o.t_end, vmax * 0.05)],
                colour(OpKind::M).filled(),
            )))
            .p()?;
    }
    for &(s, e) in &t.movements {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(s, 0.0), (e, vmax * 0.97)],
                colour(OpKind::P).stroke_width(1),
            )))
            .p()?;
    }
    chart
        .draw_series(LineSeries::new(
            t.speed.iter().copied(),
            BLACK.stroke_width(1),
        ))
        .p()?
        .label("smoothed speed")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 15, y)], BLACK));
    for (v, name, c) in [(cfg.v_on, "v_on", RED), (cfg.v_off, "v_off", MAGENTA)] {
        chart
            .draw_series(LineSeries::new([(t0, v), (t1, v)], c.stroke_width(1)))
            .p()?
            .label(name)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], c));
    }
    legend(&mut chart)
}
