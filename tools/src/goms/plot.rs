//! Plots, each written as SVG and PNG with plotters: stacked operator bars per method
//! (the paper's Tables 3 and 4), per-participant strips, an operator Gantt chart of one
//! trial, and the speed trace of one trial with its detected movements.
//!
//! Text uses DejaVu Sans, shipped in `tools/assets/` (Bitstream Vera licence) and
//! registered with plotters' `ab_glyph` backend, so no system font library is needed;
//! the PNGs draw it through [`Kerned`], which places glyphs by the font's advances,
//! bearings and kerning.

use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::extract::{ExtractConfig, OpKind, Trial};
use super::study::Analysis;
use super::text::{FONT, Kerned};

static REGISTER: Once = Once::new();

pub(crate) fn register_font() {
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

/// What an operator kind is, for axis labels and legends.
fn describe(op: OpKind) -> &'static str {
    match op {
        OpKind::P => "P pointing",
        OpKind::K => "K keystroke",
        OpKind::B => "B button edge",
        OpKind::M => "M mental",
        OpKind::H => "H homing",
        OpKind::R => "R wait / hold",
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
        OpKind::R => RGBColor(0xb0, 0xb0, 0xb0),
    }
}

/// Encodes an RGB buffer as PNG.
pub(crate) fn png_bytes(rgb: &[u8], (w, h): (u32, u32)) -> Result<Vec<u8>> {
    use image::ImageEncoder as _;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow!("encoding the PNG: {e}"))?;
    Ok(png)
}

/// Draws a plot as SVG and PNG in memory, then writes both atomically as a pair
/// (fsio): a failure (a full disk) leaves neither.
macro_rules! both {
    ($stem:expr, $size:expr, $draw:ident ( $($arg:expr),* )) => {{
        register_font();
        let svg = $stem.with_extension("svg");
        let png = $stem.with_extension("png");
        let size: (u32, u32) = $size;
        let mut svg_text = String::new();
        {
            let root = SVGBackend::with_string(&mut svg_text, size).into_drawing_area();
            $draw(&root, $($arg),*)?;
            root.present().p()?;
        }
        let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
        {
            let root = Kerned(BitMapBackend::with_buffer(&mut rgb, size)).into_drawing_area();
            $draw(&root, $($arg),*)?;
            root.present().p()?;
        }
        let png_data = png_bytes(&rgb, size)?;
        fsio::write_all_atomic(&[(&svg, svg_text.as_bytes()), (&png, &png_data[..])])?;
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
        // The categories get their own ticks and labels: plotters' numeric ticks on
        // -0.5..n-0.5 fall between them (stray ticks on a single-category axis).
        .x_labels(0)
        .y_desc(y_desc)
        .label_style(("sans-serif", 13))
        .draw()
        .p()?;
    category_axis(root, &chart, &labels, Axis::X)?;
    Ok(chart)
}

/// Which axis holds the categories.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Axis {
    X,
    Y,
}

/// Length of a category tick mark, pixels.
const TICK_PX: i32 = 5;

/// One tick mark and label per category, at the category's position (0, 1, ...) on the
/// axis: exactly as many ticks as categories.
fn category_axis<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &Chart<'_, DB>,
    labels: &[impl AsRef<str>],
    axis: Axis,
) -> Result<()> {
    let (xr, yr) = (chart.x_range(), chart.y_range());
    let style = ("sans-serif", 13).into_font().color(&BLACK);
    for (i, label) in labels.iter().enumerate() {
        let c = i as f64;
        match axis {
            Axis::X => {
                let (x, y) = chart.backend_coord(&(c, yr.start));
                root.draw(&PathElement::new([(x, y), (x, y + TICK_PX)], BLACK))
                    .p()?;
                let pos = Pos::new(HPos::Center, VPos::Top);
                root.draw_text(label.as_ref(), &style.pos(pos), (x, y + 2 * TICK_PX))
                    .p()?;
            }
            Axis::Y => {
                let (x, y) = chart.backend_coord(&(xr.start, c));
                root.draw(&PathElement::new([(x - TICK_PX, y), (x, y)], BLACK))
                    .p()?;
                let pos = Pos::new(HPos::Right, VPos::Center);
                root.draw_text(label.as_ref(), &style.pos(pos), (x - 2 * TICK_PX, y))
                    .p()?;
            }
        }
    }
    Ok(())
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
        .max(crate::tolerance::PLOT_RANGE_MIN)
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
        .max(crate::tolerance::PLOT_RANGE_MIN)
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
    let (t0, t1) = (t.t0, t.t1.max(t.t0 + crate::tolerance::MIN_PLOT_SPAN));
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
        .y_label_area_size(110)
        .build_cartesian_2d(t0..t1, -0.5f64..(rows as f64 - 0.5))
        .p()?;
    let names: Vec<&str> = kinds.iter().map(|k| describe(*k)).collect();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(0)
        .x_desc("seconds")
        .label_style(("sans-serif", 13))
        .draw()
        .p()?;
    category_axis(root, &chart, &names, Axis::Y)?;
    // One bar per operator, outlined in white so that operators of one kind that follow
    // each other stay two bars.
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
        chart
            .draw_series(t.ops.iter().filter(|o| o.op == *k).map(|o| {
                let y = r as f64;
                let end = o.t_end.max(o.t_start + (t1 - t0) * 0.002);
                Rectangle::new(
                    [(o.t_start, y - 0.35), (end, y + 0.35)],
                    WHITE.stroke_width(1),
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
    let (t0, t1) = (t.t0, t.t1.max(t.t0 + crate::tolerance::MIN_PLOT_SPAN));
    let vmax = t
        .speed
        .iter()
        .map(|s| s.1)
        .fold(cfg.v_on, f64::max)
        .max(crate::tolerance::PLOT_SPEED_MIN)
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
    let swatch =
        |c: ShapeStyle| move |(x, y): (i32, i32)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], c);
    chart
        .draw_series(t.ops.iter().filter(|o| o.op == OpKind::P).map(|o| {
            Rectangle::new(
                [(o.t_start, 0.0), (o.t_end, vmax)],
                colour(OpKind::P).mix(0.15).filled(),
            )
        }))
        .p()?
        .label("P operator (shaded: pointing time)")
        .legend(swatch(colour(OpKind::P).mix(0.15).filled()));
    chart
        .draw_series(t.ops.iter().filter(|o| o.op == OpKind::M).map(|o| {
            Rectangle::new(
                [(o.t_start, 0.0), (o.t_end, vmax * 0.05)],
                colour(OpKind::M).filled(),
            )
        }))
        .p()?
        .label("M operator (green band: mental pause)")
        .legend(swatch(colour(OpKind::M).filled()));
    chart
        .draw_series(t.movements.iter().map(|&(s, e)| {
            Rectangle::new(
                [(s, 0.0), (e, vmax * 0.97)],
                colour(OpKind::P).stroke_width(1),
            )
        }))
        .p()?
        .label("sub-movement (outline: onset to offset)")
        .legend(swatch(colour(OpKind::P).stroke_width(1)));
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
            .label(format!("{name} threshold ({v} m/s)"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], c));
    }
    legend(&mut chart)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::goms::extract::Operator;

    fn op(op: OpKind, t_start: f64, t_end: f64) -> Operator {
        Operator {
            op,
            t_start,
            t_end,
            fitts: None,
        }
    }

    /// Regression (issue 19): operators of one kind that followed each other were drawn
    /// as one bar (five P's looked like one).
    #[test]
    fn regression_gantt_draws_one_bar_per_operator() {
        let t = Trial {
            participant: "P1".into(),
            method: "m".into(),
            trial: 1,
            task: None,
            t0: 0.0,
            t1: 4.0,
            ops: vec![
                op(OpKind::P, 0.0, 1.0),
                op(OpKind::P, 1.0, 2.0),
                op(OpKind::P, 2.0, 3.0),
                op(OpKind::K, 3.0, 3.2),
                op(OpKind::R, 3.2, 4.0),
            ],
            speed: Vec::new(),
            movements: Vec::new(),
        };
        t.check_tiling().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files = trial_plots(dir.path(), &t, &ExtractConfig::default()).unwrap();
        let svg = std::fs::read_to_string(&files[0]).unwrap();
        let fill = |c: RGBColor| format!("fill=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2);
        let count = |needle: &str| {
            svg.split("<rect")
                .skip(1)
                .filter(|r| r.split("/>").next().is_some_and(|r| r.contains(needle)))
                .count()
        };
        assert_eq!(count(&fill(colour(OpKind::P))), 3, "{svg}");
        assert_eq!(count(&fill(colour(OpKind::K))), 1);
        // Each bar has its own white outline.
        assert_eq!(count("stroke=\"#FFFFFF\""), t.ops.len());
        for k in [OpKind::P, OpKind::K, OpKind::R] {
            assert!(svg.contains(describe(k)), "{k:?}");
        }
        // The speed plot explains its bands.
        let speed = std::fs::read_to_string(&files[2]).unwrap();
        for label in [
            "pointing time",
            "mental pause",
            "sub-movement",
            "v_on threshold",
        ] {
            assert!(speed.contains(label), "{label}");
        }
    }

    /// The two-point polylines and lines of an SVG as `((x1, y1), (x2, y2))`.
    fn segments(svg: &str) -> Vec<((i32, i32), (i32, i32))> {
        let attr = |tag: &str, name: &str| -> Option<String> {
            let at = tag.find(&format!(" {name}=\""))? + name.len() + 3;
            Some(tag[at..].split('"').next()?.to_owned())
        };
        let num = |s: &str| s.trim().parse::<f64>().ok().map(|v| v.round() as i32);
        let mut out = Vec::new();
        for tag in svg.split('<').filter(|t| t.starts_with("polyline ")) {
            let pts: Vec<(i32, i32)> = attr(tag, "points")
                .unwrap_or_default()
                .split_whitespace()
                .filter_map(|p| {
                    let (x, y) = p.split_once(',')?;
                    Some((num(x)?, num(y)?))
                })
                .collect();
            if let [a, b] = pts[..] {
                out.push((a, b));
            }
        }
        for tag in svg.split('<').filter(|t| t.starts_with("line ")) {
            let v: Vec<i32> = ["x1", "y1", "x2", "y2"]
                .iter()
                .filter_map(|n| num(&attr(tag, n)?))
                .collect();
            if let [x1, y1, x2, y2] = v[..] {
                out.push(((x1, y1), (x2, y2)));
            }
        }
        out
    }

    /// Short tick marks: vertical (on a horizontal axis) and horizontal (on a vertical
    /// axis), at most twice the tick length.
    fn ticks(svg: &str) -> (Vec<i32>, Vec<i32>) {
        let short = |d: i32| d != 0 && d.abs() <= 2 * TICK_PX;
        let segs = segments(svg);
        let vertical = segs
            .iter()
            .filter(|(a, b)| a.0 == b.0 && short(b.1 - a.1))
            .map(|(a, _)| a.0)
            .collect();
        let horizontal = segs
            .iter()
            .filter(|(a, b)| a.1 == b.1 && short(b.0 - a.0))
            .map(|(a, _)| a.1)
            .collect();
        (vertical, horizontal)
    }

    /// Regression (issue 19): an axis of one category (one method, one operator kind)
    /// had stray ticks between the categories. Each category axis now has exactly one
    /// tick per category, at its bar.
    #[test]
    fn regression_a_category_axis_has_one_tick_per_category() {
        use crate::goms::study::TallyRow;
        for n in [1usize, 3] {
            let rows: Vec<TallyRow> = (0..n)
                .flat_map(|m| {
                    (1..=2).map(move |p| TallyRow {
                        participant: format!("P{p}"),
                        method: format!("m{m}"),
                        trial: 1,
                        op: "P".into(),
                        count: 2.0 + m as f64,
                        time: 3.0 + p as f64,
                    })
                })
                .collect();
            let a = crate::goms::aggregate_with(
                &rows,
                None,
                &[],
                None,
                crate::goms::stats::Bootstrap::default(),
            );
            let dir = tempfile::tempdir().unwrap();
            study_plots(dir.path(), &a).unwrap();
            let svg = std::fs::read_to_string(dir.path().join("operations_by_method.svg")).unwrap();
            let (x_ticks, _) = ticks(&svg);
            assert_eq!(x_ticks.len(), n, "{x_ticks:?}");
            // Each at the centre of its method's bar.
            let fill = format!(
                "fill=\"#{:02X}{:02X}{:02X}\"",
                colour(OpKind::P).0,
                colour(OpKind::P).1,
                colour(OpKind::P).2
            );
            let mut centres: Vec<i32> = svg
                .split("<rect")
                .skip(1)
                .filter(|r| r.split("/>").next().is_some_and(|r| r.contains(&fill)))
                .filter_map(|r| {
                    let v = |name: &str| -> Option<i32> {
                        let at = r.find(&format!(" {name}=\""))? + name.len() + 3;
                        r[at..].split('"').next()?.parse().ok()
                    };
                    // Bars, not the legend's 10 px swatch.
                    let width = v("width")?;
                    (width > 2 * TICK_PX).then_some(v("x")? + width / 2)
                })
                .collect();
            centres.sort_unstable();
            let mut xs = x_ticks.clone();
            xs.sort_unstable();
            assert_eq!(centres.len(), n);
            for (t, c) in xs.iter().zip(&centres) {
                assert!((t - c).abs() <= 1, "tick {t}, bar centre {c}");
            }
        }
        // The Gantt's operator axis: one tick per operator kind shown.
        let t = Trial {
            participant: "P1".into(),
            method: "m".into(),
            trial: 1,
            task: None,
            t0: 0.0,
            t1: 1.0,
            ops: vec![op(OpKind::P, 0.0, 1.0)],
            speed: Vec::new(),
            movements: Vec::new(),
        };
        let dir = tempfile::tempdir().unwrap();
        let files = trial_plots(dir.path(), &t, &ExtractConfig::default()).unwrap();
        let (_, y_ticks) = ticks(&std::fs::read_to_string(&files[0]).unwrap());
        assert_eq!(y_ticks.len(), 1, "{y_ticks:?}");
    }
}
