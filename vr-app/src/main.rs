//! # wandsculpt
//!
//! The Wandsculpt display server. With no arguments it opens a desktop window with the
//! default surface and an emulated wand (mouse and keyboard); with a config naming a
//! tracker it drives a projection wall; `--headless` runs with no window and writes
//! PNGs; `--demo` plays a built-in session. See the README's `vr-app` section.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Parser;
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::demo::demo_events;
use vr_app::headless::{HeadlessOptions, Input, run_headless};
use vr_app::live::LiveTracking;
use vr_app::render::{Gpu, OutputMode};
use vr_app::window::{WindowInput, run_windowed};

/// Wandsculpt display server: head-tracked stereo NURBS sculpting.
#[derive(Debug, Parser)]
#[command(name = "wandsculpt", version, about)]
struct Cli {
    /// TOML configuration (see vr-app/config/wall.toml and desktop.toml).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Run without a window: consume the input, then write the document, journal,
    /// operator log and left/right/frame PNGs into the session directory.
    #[arg(long)]
    headless: bool,
    /// Play the built-in demo session instead of live input.
    #[arg(long)]
    demo: bool,
    /// Session directory (journal, autosave, document, operator log, PNGs).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Base scene to start from (a `scene.json`, `Document::to_json` format); the
    /// default is the shared default surface.
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Output mode: dual, side-by-side, anaglyph or mono.
    #[arg(long, value_name = "MODE")]
    mode: Option<OutputMode>,
    /// Output size per image, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Headless: also render a frame every N wand events (for frame timing).
    #[arg(long, value_name = "N", default_value_t = 0)]
    render_every: usize,
    /// Headless with live tracking: stop after this many seconds without wand data
    /// (once some arrived).
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0)]
    idle_exit: f64,
    /// Headless with live tracking: stop after this many seconds in any case.
    #[arg(long, value_name = "SECONDS", default_value_t = 3600.0)]
    duration: f64,
    /// Headless: pace the input in real time (as a live session would arrive).
    #[arg(long)]
    realtime: bool,
    /// Draw the mesh wireframe.
    #[arg(long)]
    wireframe: bool,
    /// Swap the eyes.
    #[arg(long)]
    swap_eyes: bool,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let w: u32 = w.parse().map_err(|e| format!("width: {e}"))?;
    let h: u32 = h.parse().map_err(|e| format!("height: {e}"))?;
    if !(1..=8192).contains(&w) || !(1..=8192).contains(&h) {
        return Err("width and height must be in 1..=8192".into());
    }
    Ok((w, h))
}

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "wandsculpt=info,vr_app=info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("wandsculpt: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    let mut config = match &cli.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    if let Some(dir) = &cli.out {
        config.files.dir = dir.clone();
    }
    if let Some(scene) = &cli.scene {
        config.files.scene = Some(scene.clone());
    }
    if let Some(m) = cli.mode {
        config.display.mode = m;
    }
    if let Some((w, h)) = cli.size {
        config.display.width = w;
        config.display.height = h;
    }
    config.display.wireframe |= cli.wireframe;
    config.display.swap_eyes ^= cli.swap_eyes;
    config.validate()?;
    let app = AppState::new(config).context("opening the session")?;
    if app.session.recovered > 0 {
        eprintln!(
            "wandsculpt: recovered {} operations from {}",
            app.session.recovered,
            app.session
                .dir()
                .join(vr_app::session::JOURNAL_FILE)
                .display()
        );
    }
    let demo = || demo_events(&app.screen);
    if cli.headless {
        let events: Box<dyn Iterator<Item = Input>> = if cli.demo {
            Box::new(demo().into_iter().map(Input::Wand))
        } else if let Some(section) = &app.config.tracking {
            Box::new(live_inputs(
                LiveTracking::start(section)?,
                cli.idle_exit,
                cli.duration,
            ))
        } else {
            bail!("--headless needs an input: --demo, or a [tracking] section in --config");
        };
        let gpu = Gpu::headless()?;
        let opts = HeadlessOptions {
            width: app.config.display.width,
            height: app.config.display.height,
            mode: app.config.display.mode,
            render_every: cli.render_every,
            realtime: cli.realtime,
        };
        let mut app = app;
        let report = run_headless(&mut app, &gpu, events, &opts)?;
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    let input = if cli.demo {
        WindowInput::Scripted(demo())
    } else if let Some(section) = &app.config.tracking {
        let mut live = LiveTracking::start(section)?;
        WindowInput::Live(Box::new(move |t| live.poll(t)))
    } else {
        WindowInput::Desktop
    };
    run_windowed(app, input)?;
    Ok(())
}

/// Live tracking as a stream of inputs: polls every 4 ms with the session clock, and
/// ends `idle_exit` seconds after the last wand report (once one arrived) or after
/// `duration` seconds.
fn live_inputs(
    mut live: LiveTracking,
    idle_exit: f64,
    duration: f64,
) -> impl Iterator<Item = Input> {
    let start = std::time::Instant::now();
    let mut pending: std::collections::VecDeque<Input> = std::collections::VecDeque::new();
    std::iter::from_fn(move || {
        loop {
            if let Some(i) = pending.pop_front() {
                return Some(i);
            }
            let t = start.elapsed().as_secs_f64();
            if t > duration {
                return None;
            }
            if let Some(last) = live.last_report()
                && live.now().saturating_sub(last).as_secs_f64() > idle_exit
            {
                tracing::info!("no tracking data for {idle_exit} s: finishing");
                return None;
            }
            pending.extend(live.poll(t));
            if pending.is_empty() {
                std::thread::sleep(std::time::Duration::from_millis(4));
            }
        }
    })
}
