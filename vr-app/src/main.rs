//! # wandsculpt
//!
//! The Wandsculpt display server. With no arguments it opens a desktop window with the
//! default surface and an emulated wand (mouse and keyboard); with a config naming a
//! tracker it drives a projection wall; `--headless` runs with no window and writes
//! PNGs; `--demo` plays a built-in session; `--gpu-eval` evaluates an implicit model on
//! the GPU (docs/implicit.md); `--gpu-volume-eval` a volume's attributes on a parameter
//! grid (docs/volumes.md). See `docs/cli/wandsculpt.md`.

mod gpu_eval_cli;
mod gpu_volume_cli;

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{CommandFactory, FromArgMatches, Parser};
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::demo::demo_events;
use vr_app::headless::{HeadlessOptions, Input, run_headless};
use vr_app::live::LiveTracking;
use vr_app::output::OutputMode;
use vr_app::render::Gpu;
use vr_app::window::{WindowInput, run_windowed};

/// Wandsculpt display server: head-tracked stereo NURBS sculpting.
#[derive(Debug, Parser)]
#[command(name = "wandsculpt", version, about)]
struct Cli {
    /// TOML configuration (see vr-app/config/wall.toml and desktop.toml).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Run without a window: consume the input, then write the document, journal,
    /// operator log and left/right/frame PNGs into the session directory. With
    /// `--scene` or `--solid` and no other input, renders the scene as it is.
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
    /// A solid target added to the base scene: a JSON solid document or a `.vm`
    /// model (docs/solids.md), carved by the same strokes; Tab selects it.
    #[arg(long, value_name = "MODEL")]
    solid: Option<PathBuf>,
    /// With --solid: grid cells along the solid's longest side (8..=1024, default 128).
    #[arg(long, value_name = "N", requires = "solid")]
    solid_cells: Option<usize>,
    /// Output mode: dual, side-by-side, anaglyph or mono.
    #[arg(long, value_name = "MODE")]
    mode: Option<OutputMode>,
    /// Output size per image, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Headless: also render a frame every N wand events (for frame timing).
    #[arg(long, value_name = "N", default_value_t = 0)]
    render_every: usize,
    /// Listen for the tracking server on this address (DTrack2 over TCP; port 0 picks
    /// a free port). Adds a `tcp-listen` source; without a `[tracking]` section the
    /// wand is `wand0` and the head `body0`.
    #[arg(long, value_name = "ADDR")]
    listen: Option<std::net::SocketAddr>,
    /// Write the bound addresses of listening sources (one `HOST:PORT` per line) to
    /// this file once they are bound, and print them on stderr.
    #[arg(long, value_name = "FILE")]
    addr_file: Option<PathBuf>,
    /// Headless with live tracking: stop after this many seconds without tracking data
    /// (once some arrived), or as soon as every source has disconnected.
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
    /// Draw the UV quadtree leaves coloured by class (exterior, boundary, interior).
    #[arg(long)]
    quadtree: bool,
    /// Show the first painted scalar (e.g. `density`) as a heat map instead of the
    /// painted colour (the `T` key in the window).
    #[arg(long)]
    heat_map: bool,
    /// Desktop mode: turn the framed start view by YAW,PITCH degrees about the
    /// document's centre (as the orbit drag turns it), e.g. for headless pictures from
    /// another side.
    #[arg(long, value_name = "YAW,PITCH", value_parser = parse_view, allow_hyphen_values = true)]
    view: Option<(f64, f64)>,
    /// Swap the eyes.
    #[arg(long)]
    swap_eyes: bool,
    /// Window mode: render this many frames, then exit cleanly (smoke tests).
    #[arg(long, value_name = "N")]
    frames: Option<u64>,
    /// Cluster role (`[cluster]` in --config): `ingest` (publish the tracker's frames)
    /// or `node` (a render node, with --node: windowed on its screen, or --headless).
    /// See docs/cluster.md.
    #[arg(long, value_name = "ROLE")]
    cluster: Option<ClusterRole>,
    /// Cluster: this node's name (a `[[cluster.node]]`).
    #[arg(long, value_name = "NAME")]
    node: Option<String>,
    /// Cluster ingest: the feed to publish (`<session>.tracking.<feed>`).
    #[arg(long, value_name = "NAME", default_value = "main")]
    feed: String,
    /// Cluster: connect as this NATS user (with --nats-password-file), replacing the
    /// config's credentials for this role.
    #[arg(
        long,
        value_name = "USER",
        requires_all = ["nats_password_file", "cluster"]
    )]
    nats_user: Option<String>,
    /// Cluster: the file holding --nats-user's password (its first line).
    #[arg(long, value_name = "FILE", requires = "nats_user")]
    nats_password_file: Option<PathBuf>,
    /// Cluster: connect with the nkey seed in this file, replacing the config's
    /// credentials for this role.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with = "nats_user",
        requires = "cluster"
    )]
    nats_nkey: Option<PathBuf>,
    /// Sculpt in an OpenXR head-mounted display with its controllers as the wand
    /// (feature `openxr`; see docs/openxr.md). With `--frames N`, stop after N frames.
    #[arg(long)]
    xr: bool,
    /// With --xr: read the last frame's left-eye swapchain image back into
    /// `xr-left.png` in the session directory.
    #[arg(long, requires = "xr")]
    xr_capture: bool,
    /// With --xr: do not submit the depth layer (`XR_KHR_composition_layer_depth`)
    /// even when the runtime offers it.
    #[arg(long, requires = "xr")]
    xr_no_depth: bool,
    /// Study mode: record the participant's next trials of this study manifest
    /// (`study.toml` of `sculpt-tools goms study init`) into the logs it names; the HUD
    /// shows participant, method and trial, `Enter` starts and ends a trial (headless:
    /// the whole input is one trial). See docs/goms.md.
    #[arg(
        long,
        value_name = "MANIFEST",
        requires = "participant",
        conflicts_with = "cluster"
    )]
    study: Option<PathBuf>,
    /// With --study: the participant.
    #[arg(long, value_name = "ID", requires = "study")]
    participant: Option<String>,
    /// With --study: the task named in each trial's `trial_start` (default: the method).
    #[arg(long, value_name = "NAME", requires = "study")]
    task: Option<String>,
    /// Evaluate an implicit model (a `.vm` file or a solid document, as `sculpt-tools
    /// implicit eval` reads) on the GPU at the cell centres of --grid, with no window;
    /// --out names the little-endian f32 file (docs/implicit.md).
    #[arg(long, value_name = "MODEL", requires_all = ["grid", "bounds", "out"],
        conflicts_with_all = ["headless", "demo", "xr", "cluster", "study", "config", "scene"])]
    gpu_eval: Option<PathBuf>,
    /// With --gpu-eval: cells per axis, `NxM` (the plane z = 0) or `NxMxK`.
    #[arg(long, value_name = "NxM[xK]", requires = "gpu_eval")]
    grid: Option<String>,
    /// With --gpu-eval: the grid's bounds on every axis, `LO,HI`.
    #[arg(
        long,
        value_name = "LO,HI",
        requires = "gpu_eval",
        allow_hyphen_values = true
    )]
    bounds: Option<String>,
    /// With --gpu-eval or --gpu-volume-eval: evaluate this many times (the file holds
    /// the last values) and report every GPU time, their median and minimum.
    #[arg(long, value_name = "N", default_value_t = 1,
        value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeat: u32,
    /// With --gpu-eval: how the CPU waits for the values (`spin`: poll until they are
    /// mapped, lowest latency; `block`: sleep in the driver's wait). Default: block on
    /// a software adapter, spin on a GPU.
    #[arg(long, value_name = "HOW", requires = "gpu_eval")]
    gpu_wait: Option<GpuWait>,
    /// With --gpu-eval: prune the tape per tile of this many cells on a side on the
    /// CPU first, and send each tile its pruned tape (docs/implicit.md).
    #[arg(long, value_name = "CELLS", requires = "gpu_eval",
        value_parser = clap::value_parser!(u32).range(1..=65536))]
    gpu_prune: Option<u32>,
    /// Evaluate a volume (`wandsculpt-volume` JSON) on the GPU at the points of a
    /// uniform parameter grid (--res), with no window; --out names the little-endian
    /// f32 file, laid out as `sculpt-tools volume grid --f32` writes it (docs/volumes.md).
    #[arg(long, value_name = "VOL", requires_all = ["res", "out"],
        conflicts_with_all = ["gpu_eval", "headless", "demo", "xr", "cluster", "study", "config", "scene"])]
    gpu_volume_eval: Option<PathBuf>,
    /// With --gpu-volume-eval: grid points per direction, `R1,..,Rn`.
    #[arg(long, value_name = "R1,..,Rn", requires = "gpu_volume_eval")]
    res: Option<String>,
}

/// `--gpu-wait` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum GpuWait {
    /// Poll until the values are mapped.
    Spin,
    /// Sleep in the driver's wait.
    Block,
}

/// `--cluster` roles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ClusterRole {
    /// Read the tracker and publish its frames.
    Ingest,
    /// A render node.
    Node,
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

fn parse_view(s: &str) -> Result<(f64, f64), String> {
    let (yaw, pitch) = s
        .split_once(',')
        .ok_or_else(|| format!("expected YAW,PITCH in degrees, got {s:?}"))?;
    let yaw: f64 = yaw.trim().parse().map_err(|e| format!("yaw: {e}"))?;
    let pitch: f64 = pitch.trim().parse().map_err(|e| format!("pitch: {e}"))?;
    if !(yaw.is_finite() && pitch.is_finite()) {
        return Err("yaw and pitch must be finite".into());
    }
    Ok((yaw, pitch))
}

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "wandsculpt=info,vr_app=info,tracking=info".into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    // The desktop keys come from the same table as the on-screen help.
    let keys = format!(
        "Desktop keys and mouse (desktop mode; F1 shows them in the window):\n  {}",
        vr_app::window::key_help().join("\n  ")
    );
    let cli = match Cli::from_arg_matches(&Cli::command().after_help(keys).get_matches()) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("wandsculpt: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    if let (Some(model), Some(grid), Some(bounds), Some(out)) =
        (&cli.gpu_eval, &cli.grid, &cli.bounds, &cli.out)
    {
        let report = gpu_eval_cli::run(&gpu_eval_cli::GpuEvalArgs {
            model,
            grid,
            bounds,
            out,
            repeat: cli.repeat as usize,
            wait: cli.gpu_wait.map(|w| match w {
                GpuWait::Spin => vr_app::gpu_eval::Wait::Spin,
                GpuWait::Block => vr_app::gpu_eval::Wait::Block,
            }),
            prune: cli.gpu_prune.map(|t| t as usize),
        })?;
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    if let (Some(volume), Some(res), Some(out)) = (&cli.gpu_volume_eval, &cli.res, &cli.out) {
        let report = gpu_volume_cli::run(&gpu_volume_cli::GpuVolumeArgs {
            volume,
            res,
            out,
            repeat: cli.repeat as usize,
        })?;
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
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
    if let Some(solid) = &cli.solid {
        config.files.solid = Some(solid.clone());
    }
    if let Some(cells) = cli.solid_cells {
        config.files.solid_cells = cells;
    }
    if let Some(m) = cli.mode {
        config.display.mode = m;
    }
    if let Some((w, h)) = cli.size {
        config.display.width = w;
        config.display.height = h;
    }
    if let Some(addr) = cli.listen {
        let section = config
            .tracking
            .get_or_insert_with(|| vr_app::config::TrackingSection {
                wand: "wand0".into(),
                head: Some("body0".into()),
                timeout: tracking::stage::StageConfig::default().timeout_s,
                input: Default::default(),
                playback: None,
                thumbstick: None,
            });
        section
            .input
            .sources
            .push(tracking::config::SourceConfig::TcpListen { addr });
    }
    config.display.wireframe |= cli.wireframe;
    config.display.quadtree |= cli.quadtree;
    config.display.heat_map |= cli.heat_map;
    config.display.swap_eyes ^= cli.swap_eyes;
    config.validate()?;
    if cli.xr {
        return run_xr(&cli, config);
    }
    if let Some(role) = cli.cluster {
        return run_cluster(&cli, role, config);
    }
    // Every argument is checked, and the study manifest and the GPU are opened, before
    // the session touches a file (journal, operator log): a usage error changes nothing.
    let still = config.files.scene.is_some() || config.files.solid.is_some();
    if cli.headless && !cli.demo && config.tracking.is_none() && !still {
        bail!(
            "--headless needs an input: --demo, a [tracking] section in --config, or \
             --scene or --solid (rendered as it is)"
        );
    }
    let study = match (&cli.study, &cli.participant) {
        (Some(manifest), Some(participant)) => Some(vr_app::study::StudyRun::open(
            manifest,
            participant,
            cli.task.clone(),
        )?),
        _ => None,
    };
    if let Some(model) = &config.files.solid {
        vr_app::solid_view::read_model(model)?;
        let range = sculpt_core::solid::CELLS_RANGE;
        if !range.contains(&config.files.solid_cells) {
            bail!(
                "--solid-cells {}: must be in {}..={}",
                config.files.solid_cells,
                range.start(),
                range.end()
            );
        }
    }
    if cli.headless {
        vr_app::render::check_offscreen_size(config.display.width, config.display.height)?;
    }
    let gpu = if cli.headless {
        Some(Gpu::headless()?)
    } else {
        None
    };
    let mut app = AppState::new(config).context("opening the session")?;
    let bounds = app.document_bounds();
    if let (Some((yaw, pitch)), Some(view)) = (cli.view, &mut app.view) {
        view.yaw = yaw.to_radians();
        view.pitch = pitch.to_radians().clamp(
            -vr_app::desktop_view::MAX_PITCH,
            vr_app::desktop_view::MAX_PITCH,
        );
        // Turned about the document's centre, which stays where the framing put it.
        if let Some((lo, hi)) = bounds {
            let centre = (lo + hi) * 0.5;
            view.pivot = centre - view.rotation() * (centre - view.pivot);
        }
    }
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
    if let Some(study) = study {
        app.start_study(study)?;
    }
    let demo = || demo_events(&app.screen);
    if let Some(gpu) = gpu {
        let events: Box<dyn Iterator<Item = Input>> = if cli.demo {
            Box::new(demo().into_iter().map(Input::Wand))
        } else if let Some(section) = &app.config.tracking {
            let live = start_live(section, cli.addr_file.as_deref())?;
            Box::new(live_inputs(live, cli.idle_exit, cli.duration))
        } else {
            // A scene or solid and no input (checked above): render it as it is.
            Box::new(std::iter::empty())
        };
        let opts = HeadlessOptions {
            width: app.config.display.width,
            height: app.config.display.height,
            mode: app.config.display.mode,
            render_every: cli.render_every,
            realtime: cli.realtime,
        };
        if let Some(study) = &mut app.study {
            study.start_at_first_event(&mut app.session);
        }
        let report = run_headless(&mut app, &gpu, events, &opts)?;
        if let Some(study) = &mut app.study {
            let label = study.trial_label().unwrap_or_default();
            if let Some(log) = study.finish(&mut app.session, None)? {
                eprintln!("wandsculpt: recorded {label} -> {}", log.display());
            }
        }
        println!("{}", serde_json::to_string_pretty(&report)?);
        if !report.failed.is_empty() {
            bail!(
                "the run lost data: {} could not be written",
                report.failed.join("; ")
            );
        }
        return Ok(());
    }
    let input = if cli.demo {
        WindowInput::Scripted(demo())
    } else if let Some(section) = &app.config.tracking {
        let mut live = start_live(section, cli.addr_file.as_deref())?;
        WindowInput::Live(Box::new(move |_| live.poll()))
    } else {
        WindowInput::Desktop
    };
    run_windowed(app, input, cli.frames)?;
    Ok(())
}

/// `--xr`: a headset session. The probe runs first, so a missing loader or runtime is
/// one line naming it, before any session file is written.
#[cfg(feature = "openxr")]
fn run_xr(cli: &Cli, config: Config) -> Result<()> {
    use vr_app::xr_runtime::{XrOptions, probe, run_xr};
    // The OpenXR loader writes its own errors to stderr unless told otherwise; the
    // probe's error names what is missing in one line. XR_LOADER_DEBUG=all shows them.
    if std::env::var_os("XR_LOADER_DEBUG").is_none() {
        // SAFETY: only the main thread exists here (tracking, GPU and session threads
        // start later), so nothing reads the environment while it is written.
        #[allow(unsafe_code)]
        unsafe {
            std::env::set_var("XR_LOADER_DEBUG", "none")
        };
    }
    let info = probe()?;
    eprintln!(
        "wandsculpt: OpenXR runtime {} ({})",
        info.runtime, info.system
    );
    let mut app = AppState::new(config).context("opening the session")?;
    let opts = XrOptions {
        frames: cli.frames,
        capture: cli.xr_capture,
        depth_layer: !cli.xr_no_depth,
        ..XrOptions::default()
    };
    let report = run_xr(&mut app, &opts)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    eprint!("{}", report.timing);
    Ok(())
}

/// `--xr` in a build without the `openxr` feature.
#[cfg(not(feature = "openxr"))]
fn run_xr(_cli: &Cli, _config: Config) -> Result<()> {
    bail!("--xr needs wandsculpt built with `--features openxr`")
}

/// `--cluster ingest|node`.
fn run_cluster(cli: &Cli, role: ClusterRole, config: Config) -> Result<()> {
    use vr_app::cluster::{ingest, node};
    let Some(cluster) = config.cluster.clone() else {
        bail!("--cluster needs a [cluster] section in --config");
    };
    let password = match &cli.nats_password_file {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading --nats-password-file {}", path.display()))?;
            Some(text.lines().next().unwrap_or_default().to_string())
        }
        None => None,
    };
    let credentials = vr_app::cluster::auth::Credentials {
        user: cli.nats_user.clone(),
        password,
        nkey: cli.nats_nkey.clone(),
    };
    match role {
        ClusterRole::Ingest => {
            let Some(section) = &config.tracking else {
                bail!("--cluster ingest needs a [tracking] section (the tracker)");
            };
            let opts = ingest::IngestOptions {
                feed: cli.feed.clone(),
                idle_exit: cli.idle_exit,
                duration: cli.duration,
                addr_file: cli.addr_file.clone(),
                credentials,
            };
            let report = ingest::run_ingest(&cluster, section, &opts)?;
            println!("{}", serde_json::to_string_pretty(&report)?);
        }
        ClusterRole::Node => {
            let Some(name) = &cli.node else {
                bail!("--cluster node needs --node NAME");
            };
            let config = node::node_config(config, name, cli.out.clone())?;
            let opts = node::NodeOptions {
                name: name.clone(),
                idle_exit: cli.idle_exit,
                duration: cli.duration,
                headless: HeadlessOptions {
                    width: config.display.width,
                    height: config.display.height,
                    mode: config.display.mode,
                    render_every: 0,
                    realtime: false,
                },
                credentials,
            };
            let report = if cli.headless {
                let gpu = Gpu::headless()?;
                node::run_node(config, &opts, &gpu)?
            } else {
                // A window on the node's screen (its projector or monitor, as
                // `[display]` says); frames present through the swap lock.
                let (node, app) = node::NodeLoop::start(config, &opts)?;
                vr_app::window::run_windowed_node(app, node, &opts.headless)?
            };
            println!("{}", serde_json::to_string_pretty(&report)?);
        }
    }
    Ok(())
}

/// Starts live tracking and reports where listening sources are bound.
fn start_live(
    section: &vr_app::config::TrackingSection,
    addr_file: Option<&std::path::Path>,
) -> Result<LiveTracking> {
    let live = LiveTracking::start(section)?;
    let bound: Vec<String> = live
        .local_addrs()
        .iter()
        .flatten()
        .map(ToString::to_string)
        .collect();
    for a in &bound {
        eprintln!("wandsculpt: listening on {a}");
    }
    if let Some(path) = addr_file {
        // Written whole, then renamed (fsio): a reader never sees half a file.
        let text: String = bound.iter().map(|a| format!("{a}\n")).collect();
        fsio::write_atomic(path, text.as_bytes())?;
    }
    Ok(live)
}

/// Live tracking as a stream of inputs: polls every 2 ms, and ends once every source
/// has gone after sending (a served session is over), `idle_exit` seconds after the
/// last frame (once one arrived), or after `duration` seconds.
fn live_inputs(
    mut live: LiveTracking,
    idle_exit: f64,
    duration: f64,
) -> impl Iterator<Item = Input> {
    let start = std::time::Instant::now();
    let mut pending: std::collections::VecDeque<Input> = std::collections::VecDeque::new();
    let mut done = false;
    std::iter::from_fn(move || {
        loop {
            if let Some(i) = pending.pop_front() {
                return Some(i);
            }
            if done {
                return None;
            }
            // Checked before draining: frames sent before the sources went are
            // already queued, so this last poll gets all of them.
            let gone = live.sources_done();
            let timed_out = start.elapsed().as_secs_f64() > duration;
            let polled = live.poll();
            let quiet = matches!(polled.as_slice(), [Input::Silence(_)]);
            // Idle only when this poll got nothing: the last frame's time is updated by
            // polling, so a step slower than `idle_exit` (a paint refit in a debug
            // build) once ended a session whose tracker was still sending, and the
            // strokes after it were lost (the `paint` session's kill -9 test).
            let idle = quiet
                && live
                    .last_report()
                    .is_some_and(|last| live.now().saturating_sub(last).as_secs_f64() > idle_exit);
            pending.extend(polled);
            if gone || idle || timed_out {
                tracing::info!(
                    sources_gone = gone,
                    idle,
                    timed_out,
                    dropped = live.dropped(),
                    "live input finished"
                );
                done = true;
            } else if quiet {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
        }
    })
}
