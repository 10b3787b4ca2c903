//! # replay
//!
//! `replay SESSION.poselog --out DIR`: runs a recorded tracking session through the
//! sculpting pipeline on a virtual clock and writes the document, exports, operator log
//! and metrics. `replay SESSION.poselog --serve tcp://127.0.0.1:PORT` (or `--connect`)
//! acts as the tracking server instead. See `docs/cli/replay.md`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Parser;
use replay::config::ReplayConfig;
use replay::render::{SceneRenderer, every, parse_times};
use replay::serve::{Endpoint, ServeOptions};
use sculpt_core::sculpt::document::Document;
use tracking::poselog::{PoseLog, RecordKind};

/// Deterministic replay of a recorded tracking session, or tracking-server emulation.
#[derive(Debug, Parser)]
#[command(name = "replay", version, about)]
struct Cli {
    /// The pose log to replay.
    session: PathBuf,
    /// Output directory (scene.json, exports, operator.log, metrics.json, timing.json).
    #[arg(long, required_unless_present_any = ["serve", "connect", "study"])]
    out: Option<PathBuf>,
    /// Study mode: record this replay as the participant's next trial of the study
    /// manifest (`study.toml` of `sculpt-tools goms study init`), appended to the log the
    /// manifest names, with participant, method and trial marked in it.
    #[arg(long, value_name = "MANIFEST", requires = "participant", conflicts_with_all = ["serve", "connect"])]
    study: Option<PathBuf>,
    /// With --study: the participant recording the trial.
    #[arg(long, requires = "study")]
    participant: Option<String>,
    /// With --study: the task named in the trial's `trial_start` (default: the method).
    #[arg(long, requires = "study")]
    task: Option<String>,
    /// Start from this document instead of the default surface.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// The display config (calibration, wand id, tool, interaction settings).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Pace the replay by the log's timing instead of running as fast as possible.
    #[arg(long)]
    realtime: bool,
    /// Compare metrics.json against these expectations; exit 2 with a diff on mismatch.
    #[arg(long)]
    check: Option<PathBuf>,
    /// Act as the tracking server: listen here (`tcp://127.0.0.1:PORT`, port 0 picks
    /// one and prints it) or write to `serial:///dev/DEVICE`.
    #[arg(long, conflicts_with_all = ["connect", "out"])]
    serve: Option<String>,
    /// Act as the tracking server by connecting to a display server at `tcp://HOST:PORT`.
    #[arg(long, conflicts_with = "out")]
    connect: Option<String>,
    /// With --serve/--connect: time scale (1 original timing, 0 as fast as possible).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// With --connect (or --serve): a file whose first line is the display server's
    /// tracking `secret`; every connection starts with its hello line.
    #[arg(long, value_name = "FILE")]
    secret_file: Option<PathBuf>,
    /// With --serve/--connect: seconds to wait for the display server.
    #[arg(long, default_value_t = 30.0)]
    wait: f64,
    /// Also render left and right eye PNGs at these session times (seconds since the
    /// first frame, comma-separated, e.g. `2.5,5.0`) through vr-app's headless renderer.
    #[arg(long, value_name = "TIMES", conflicts_with = "render_every")]
    render: Option<String>,
    /// Render every S seconds of the session (0, S, 2S, ...).
    #[arg(long, value_name = "S")]
    render_every: Option<f64>,
    /// Size of each rendered eye image.
    #[arg(long, value_name = "WxH", default_value = "640x360")]
    render_size: String,
    /// The display server's config (`wandsculpt` TOML) for the rendered screen, stereo
    /// rig and fixed head; default: vr-app's defaults.
    #[arg(long, value_name = "FILE")]
    render_config: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// The render times and the renderer asked for, if any.
fn renderer(
    cli: &Cli,
    bytes: &[u8],
    out: &std::path::Path,
) -> Result<Option<(Vec<f64>, SceneRenderer)>> {
    let times = match (&cli.render, cli.render_every) {
        (Some(list), _) => parse_times(list)?,
        (None, Some(step)) => {
            let log = PoseLog::from_bytes(bytes).context("reading the pose log")?;
            let span = match (log.records.first(), log.records.last()) {
                (Some(a), Some(b)) => (b.time - a.time).as_secs_f64(),
                _ => 0.0,
            };
            every(step, span)?
        }
        (None, None) => return Ok(None),
    };
    let (w, h) = cli
        .render_size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .with_context(|| format!("--render-size {}: want WxH", cli.render_size))?;
    let display = match &cli.render_config {
        Some(p) => {
            vr_app::config::Config::load(p).with_context(|| format!("in {}", p.display()))?
        }
        None => vr_app::config::Config::default(),
    };
    vr_app::session::create_output_dir(out)
        .with_context(|| format!("creating {}", out.display()))?;
    let r = SceneRenderer::new(&display, w, h)?;
    Ok(Some((times, r)))
}

/// The exit status of a run that lost data (records a receiver did not get).
const EXIT_LOST_DATA: u8 = 3;

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("replay: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn progress_bar(quiet: bool, what: &str) -> Option<indicatif::ProgressBar> {
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(0);
    let style = indicatif::ProgressStyle::with_template(
        "{msg} [{bar:40}] {pos}/{len} lines {elapsed_precise} eta {eta}",
    )
    .map(|s| s.progress_chars("=> "));
    if let Ok(style) = style {
        bar.set_style(style);
    }
    bar.set_message(what.to_string());
    Some(bar)
}

/// What every replay reads besides the session: the config (`--config`, else the
/// defaults), the base document (`--scene`, else the default sheet) and the session's
/// name (its file stem).
fn replay_inputs(cli: &Cli) -> Result<(ReplayConfig, Document, String)> {
    let cfg = match &cli.config {
        Some(p) => ReplayConfig::from_toml_str(
            &std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?,
        )
        .with_context(|| format!("in {}", p.display()))?,
        None => ReplayConfig::default(),
    };
    let base = match &cli.scene {
        Some(p) => Document::from_json(&fsio::read_capped(
            p,
            sculpt_core::sculpt::document::MAX_DOCUMENT_BYTES as u64,
        )?)
        .with_context(|| format!("loading the scene {}", p.display()))?,
        None => replay::pipeline::default_document(),
    };
    let name = cli.session.file_stem().map_or_else(
        || "session".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    Ok((cfg, base, name))
}

fn run(cli: Cli) -> Result<ExitCode> {
    // Refused from its size before it is read: memory stays bounded by the cap.
    let bytes = fsio::read_capped(&cli.session, tracking::poselog::MAX_LOG_BYTES)?;
    if let Some(target) = cli
        .serve
        .as_deref()
        .map(|s| (s, true))
        .or(cli.connect.as_deref().map(|s| (s, false)))
    {
        return serve(&cli, &bytes, target.0, target.1);
    }
    if let (Some(manifest), Some(participant)) = (&cli.study, &cli.participant) {
        return study_trial(&cli, &bytes, manifest, participant);
    }
    let Some(out) = cli.out.as_ref() else {
        bail!("--out DIR is required");
    };
    let (cfg, base, name) = replay_inputs(&cli)?;
    let bar = progress_bar(cli.quiet, &name);
    let mut tick = |at: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(at);
        }
    };
    let outcome = match renderer(&cli, &bytes, out)? {
        None => {
            replay::pipeline::replay_log(&bytes, &cfg, base, &name, cli.realtime, Some(&mut tick))?
        }
        Some((times, mut r)) => {
            let mut shots = 0;
            let outcome = replay::pipeline::replay_log_rendering(
                &bytes,
                &cfg,
                base,
                &name,
                &times,
                &mut |t, replayer| {
                    r.render(replayer)?.save(out, t)?;
                    shots += 1;
                    Ok(())
                },
            )?;
            println!(
                "rendered {shots} stereo pairs ({}) into {}",
                r.adapter(),
                out.display()
            );
            outcome
        }
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    replay::output::write_outputs(&outcome, out)?;
    let m = &outcome.metrics;
    println!(
        "{name}: {} strokes applied, {} rejected, {} sketches, {} frames ({} out of order, {} bad, {} corrupt lines), {} tracking losses; {:.1} s replayed at {:.0}x real time -> {}",
        m.gestures.strokes_applied,
        m.gestures.strokes_rejected,
        m.gestures.sketches,
        m.frames.used,
        m.frames.out_of_order,
        m.frames.bad_frames,
        m.frames.corrupt_lines,
        m.tracking.losses,
        m.duration_s,
        outcome.timing.speed_ratio,
        out.display()
    );
    if m.frames.receive_timed > 0 {
        println!(
            "{name}: {} frames had no ts and were timed by their receive time: a live run of this log may differ from this replay",
            m.frames.receive_timed
        );
    }
    if m.frames.clock_breaks > 0 {
        println!(
            "{name}: {} frames broke the tracker clock (restart or ts jump); each continued one frame period on",
            m.frames.clock_breaks
        );
    }
    if let Some(check) = &cli.check {
        let expected: serde_json::Value = serde_json::from_slice(
            &std::fs::read(check).with_context(|| format!("reading {}", check.display()))?,
        )
        .with_context(|| format!("{} is not JSON", check.display()))?;
        let actual = serde_json::to_value(m)?;
        let diff = replay::check::check(&expected, &actual);
        if !diff.is_empty() {
            eprintln!("replay: {} differs from {}:", name, check.display());
            for line in &diff {
                eprintln!("  {line}");
            }
            return Ok(ExitCode::from(2));
        }
        println!("{name}: matches {}", check.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// `--study`: replays the session as the participant's next trial of the study and
/// appends it to the session log the manifest names (see `sculpt_core::study`); with
/// `--out`, the other outputs are written there too.
fn study_trial(
    cli: &Cli,
    bytes: &[u8],
    manifest: &std::path::Path,
    participant: &str,
) -> Result<ExitCode> {
    use sculpt_core::study::{Manifest, append_trial};
    let text = std::fs::read_to_string(manifest)
        .with_context(|| format!("reading {}", manifest.display()))?;
    let m = Manifest::parse(&text).with_context(|| format!("in {}", manifest.display()))?;
    let dir = manifest.parent().unwrap_or(std::path::Path::new("."));
    let next = m.next_trial(participant, |log| std::fs::read(dir.join(log)).ok())?;
    let (cfg, base, name) = replay_inputs(cli)?;
    let outcome = replay::pipeline::replay_log(bytes, &cfg, base, &name, cli.realtime, None)?;
    let log = dir.join(&next.session.log);
    let existing = if log.exists() {
        Some(std::fs::read(&log).with_context(|| format!("reading {}", log.display()))?)
    } else {
        None
    };
    let task = cli.task.as_deref().unwrap_or(&next.session.method);
    let all = append_trial(
        existing.as_deref(),
        &next,
        "replay",
        Some(task),
        &outcome.oplog,
    )
    .with_context(|| format!("recording into {}", log.display()))?;
    if let Some(parent) = log.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    // Written atomically (fsio): a crash or a full disk never leaves half a log.
    fsio::write_atomic(&log, &all)?;
    if let Some(out) = &cli.out {
        replay::output::write_outputs(&outcome, out)?;
    }
    println!(
        "{participant} / {} trial {} of {} ({name}, {:.1} s) -> {}",
        next.session.method,
        next.trial,
        next.session.trials,
        outcome.metrics.duration_s,
        log.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn serve(cli: &Cli, bytes: &[u8], target: &str, listen: bool) -> Result<ExitCode> {
    let endpoint = Endpoint::parse(target, listen)?;
    let log = PoseLog::from_bytes(bytes).context("reading the pose log")?;
    // Serial endpoints take serial records; TCP takes the DTrack2 stream.
    let kind = match endpoint {
        Endpoint::Serial(_) if log.records.iter().any(|r| r.kind == RecordKind::Serial) => {
            RecordKind::Serial
        }
        _ => RecordKind::DTrack,
    };
    let records: Vec<(Duration, Vec<u8>)> = log
        .records
        .into_iter()
        .filter(|r| r.kind == kind)
        .map(|r| (r.time, r.bytes))
        .collect();
    if !(cli.wait.is_finite() && cli.wait >= 0.0) {
        bail!("--wait must be a non-negative number of seconds");
    }
    let hello = match &cli.secret_file {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("reading the secret file {}", p.display()))?;
            Some(
                tracking::config::hello_from_secret_text(&text)
                    .with_context(|| p.display().to_string())?,
            )
        }
        None => None,
    };
    let bar = progress_bar(cli.quiet, "serving");
    let mut on_listening = |addr: std::net::SocketAddr| {
        // Tests and scripts read this line to find an ephemeral port.
        println!("listening on tcp://{addr}");
    };
    let mut on_progress = |done: usize, total: usize| {
        if let Some(b) = &bar {
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
    };
    let report = replay::serve::serve(
        &records,
        &endpoint,
        ServeOptions {
            speed: cli.speed,
            connect_timeout: Duration::from_secs_f64(cli.wait),
            reconnect_timeout: Duration::from_secs_f64(cli.wait),
            on_listening: Some(&mut on_listening),
            on_progress: Some(&mut on_progress),
            hello,
        },
    )?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    println!(
        "sent {} records ({} bytes) over {} connection(s); {} missed while disconnected; {} unconfirmed (written on connections that broke); {}; {}",
        report.sent,
        report.bytes,
        report.connections,
        report.missed,
        report.unconfirmed,
        report.losses(),
        report.delivery
    );
    if report.lost_data() {
        eprintln!("replay: the run lost data: {}", report.losses());
        if report.delivery.failed() {
            eprintln!("replay: the receiver did not take the session");
        }
        return Ok(ExitCode::from(EXIT_LOST_DATA));
    }
    Ok(ExitCode::SUCCESS)
}
