//! `wandtrack`: the tracking toolbox. Simulate a tracker, listen to real ones and
//! record pose logs, re-send pose logs byte for byte, check logs, fit calibrations.
//! See `docs/cli/wandtrack.md` for every flag.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use glam::DVec3;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tracking::calibration::{Calibration, FitOptions, fit};
use tracking::config::TrackingConfig;
use tracking::poselog::{PoseLog, PoseLogHeader, RecordKind};
use tracking::sim::{Script, SimConfig, Simulator};
use tracking::transport::{frames_as_items, send_paced, send_paced_udp};

#[derive(Parser)]
#[command(name = "wandtrack", version, about = "Wandsculpt tracking toolbox")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Args)]
#[group(required = true, multiple = false)]
struct Output {
    /// Write a pose log to this path.
    #[arg(long)]
    log: Option<PathBuf>,
    /// Connect to a display server listening here and push frames over TCP.
    #[arg(long)]
    tcp_connect: Option<SocketAddr>,
    /// Listen here, act as the tracking server, push frames to the first client.
    #[arg(long)]
    tcp_listen: Option<SocketAddr>,
    /// Send DTrack2 UDP datagrams to this address (DTrack's default port is 5000).
    #[arg(long)]
    udp: Option<SocketAddr>,
    /// Write the DTrack2 ASCII stream to standard output.
    #[arg(long)]
    stdout: bool,
}

/// Options for the network outputs.
#[derive(Args)]
struct Hello {
    /// With --tcp-connect: a file whose first line is the display server's tracking
    /// `secret`; the connection starts with its hello line.
    #[arg(long, value_name = "FILE")]
    secret_file: Option<PathBuf>,
}

impl Hello {
    /// The hello line to send first, if a secret file was given.
    fn line(&self) -> Result<Option<Vec<u8>>> {
        let Some(p) = &self.secret_file else {
            return Ok(None);
        };
        let text = std::fs::read_to_string(p)
            .with_context(|| format!("reading the secret file {}", p.display()))?;
        let hello = tracking::config::hello_from_secret_text(&text)
            .with_context(|| p.display().to_string())?;
        Ok(Some(hello))
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Run the tracker simulator on a script.
    Sim {
        /// Script TOML (see docs/formats/sim-script.md); without it a built-in demo gesture is used.
        #[arg(long)]
        script: Option<PathBuf>,
        /// Simulator settings TOML (`SimConfig` fields).
        #[arg(long)]
        sim_config: Option<PathBuf>,
        /// Frame rate in Hz (overrides the settings file).
        #[arg(long)]
        rate: Option<f64>,
        /// Random seed (overrides the settings file).
        #[arg(long)]
        seed: Option<u64>,
        /// Playback speed for network outputs: 1 = real time, 0 = as fast as possible.
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
        #[command(flatten)]
        out: Output,
        #[command(flatten)]
        hello: Hello,
    },
    /// Run the configured sources; print events and states as JSON lines.
    Listen {
        /// Tracking config TOML.
        #[arg(long)]
        config: PathBuf,
        /// Record every raw frame to this pose log (overrides `record` in the config).
        #[arg(long)]
        record: Option<PathBuf>,
        /// Stop after this many seconds (default: run until Ctrl-C).
        #[arg(long)]
        seconds: Option<f64>,
        /// Print every device state this often, ms (0: events only).
        #[arg(long, default_value_t = 500)]
        every_ms: u64,
    },
    /// Re-send a pose log's DTrack records byte for byte with their original timing.
    Play {
        /// The pose log.
        #[arg(value_name = "LOG")]
        input: PathBuf,
        /// Playback speed: 1 = real time, 0 = as fast as possible.
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
        #[command(flatten)]
        out: Output,
        #[command(flatten)]
        hello: Hello,
    },
    /// Check a pose log: counts, corrupt lines with line numbers, truncated tail.
    /// Exits with status 1 when anything is corrupt.
    Check {
        /// The pose log.
        log: PathBuf,
    },
    /// Pivot calibration: fit a device's tip offset from a pose log recorded while its
    /// tip was held on one point and the device turned; prints the `tips` entry.
    Pivot {
        /// The pose log.
        #[arg(value_name = "LOG")]
        input: PathBuf,
        /// The device, e.g. `wand0` or `body1`.
        #[arg(long, default_value = "wand0")]
        device: String,
        /// Tracking config whose calibration maps tracker to display (default: mm to m).
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Fit a tracker-to-display calibration from point pairs and print it as TOML.
    Calibrate {
        /// CSV, one pair per line: `tx,ty,tz,wx,wy,wz` (tracker mm, display m);
        /// `#` comments allowed.
        pairs: PathBuf,
        /// Axis remap before fitting, e.g. `x,z,-y` for a Z-up tracker and Y-up display.
        #[arg(long, default_value = "x,y,z")]
        axes: String,
        /// Fit the scale too (otherwise 0.001, mm to m).
        #[arg(long)]
        fit_scale: bool,
    },
}

fn demo_script() -> Script {
    Script::new(DVec3::new(0.0, 1.2, 0.4))
        .mark("reach")
        .move_to(DVec3::new(0.25, 1.35, 0.1), 0.8)
        .hold(0.3)
        .mark("sketch")
        .press(0)
        .move_to(DVec3::new(-0.25, 1.35, 0.1), 1.5)
        .release(0)
        .hold(0.5)
        .head_move_to(DVec3::new(0.3, 1.7, 0.6), 1.0)
        .occlude_wand(0.2)
        .move_to(DVec3::new(0.0, 1.2, 0.4), 0.8)
}

async fn emit(
    items: Vec<(Duration, Vec<u8>)>,
    speed: f64,
    out: &Output,
    hello: &Hello,
    source: &str,
) -> Result<()> {
    if speed.is_nan() || speed.is_infinite() || speed < 0.0 {
        bail!("--speed must be a finite number >= 0 (0: as fast as possible)");
    }
    let hello = hello.line()?;
    if hello.is_some() && out.tcp_connect.is_none() {
        bail!("--secret-file goes with --tcp-connect only");
    }
    if let Some(path) = &out.log {
        let mut w = tracking::poselog::PoseLogWriter::create(path, &PoseLogHeader::new(source))?;
        for (t, bytes) in &items {
            w.write(RecordKind::DTrack, *t, bytes)?;
        }
        eprintln!("wrote {} frames to {}", items.len(), path.display());
    } else if let Some(addr) = out.tcp_connect {
        let mut s = TcpStream::connect(addr)
            .await
            .with_context(|| format!("connect {addr}"))?;
        s.set_nodelay(true)?;
        if let Some(line) = &hello {
            s.write_all(line)
                .await
                .with_context(|| format!("hello to {addr}"))?;
        }
        let n = send_paced(&mut s, items, speed).await?;
        eprintln!("sent {n} bytes to {addr}");
    } else if let Some(addr) = out.tcp_listen {
        let l = TcpListener::bind(addr)
            .await
            .with_context(|| format!("bind {addr}"))?;
        eprintln!("waiting for a display server on {}", l.local_addr()?);
        let (mut s, peer) = l.accept().await?;
        s.set_nodelay(true)?;
        let n = send_paced(&mut s, items, speed).await?;
        eprintln!("sent {n} bytes to {peer}");
    } else if let Some(addr) = out.udp {
        let sock = UdpSocket::bind(if addr.is_ipv4() {
            "0.0.0.0:0"
        } else {
            "[::]:0"
        })
        .await?;
        let n = send_paced_udp(&sock, addr, items, speed).await?;
        eprintln!("sent {n} bytes to {addr}");
    } else if out.stdout {
        use std::io::Write;
        let mut o = std::io::stdout().lock();
        for (_, b) in items {
            o.write_all(&b)?;
        }
    }
    Ok(())
}

/// Reports a failure on one line, the whole chain of causes included.
#[tokio::main]
async fn main() -> std::process::ExitCode {
    match run().await {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("wandtrack: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

async fn run() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    match Cli::parse().command {
        Cmd::Sim {
            script,
            sim_config,
            rate,
            seed,
            speed,
            out,
            hello,
        } => {
            let script = match script {
                Some(p) => toml::from_str(
                    &std::fs::read_to_string(&p).with_context(|| p.display().to_string())?,
                )
                .with_context(|| format!("script {}", p.display()))?,
                None => demo_script(),
            };
            let mut cfg: SimConfig = match sim_config {
                Some(p) => toml::from_str(&std::fs::read_to_string(&p)?)
                    .with_context(|| format!("{}", p.display()))?,
                None => SimConfig::default(),
            };
            if let Some(r) = rate {
                cfg.rate_hz = r;
            }
            if let Some(s) = seed {
                cfg.seed = s;
            }
            let source = format!("wandtrack sim rate={} seed={}", cfg.rate_hz, cfg.seed);
            let items: Vec<_> = frames_as_items(Simulator::new(&script, cfg)?).collect();
            emit(items, speed, &out, &hello, &source).await
        }
        Cmd::Listen {
            config,
            record,
            seconds,
            every_ms,
        } => {
            let mut cfg = TrackingConfig::load(&config)?;
            if record.is_some() {
                cfg.record = record;
            }
            if cfg.sources.is_empty() {
                bail!("{}: no [[source]] configured", config.display());
            }
            // Subscribe before any source starts, so no early event is missed.
            let hub = tracking::hub::Hub::new(&cfg);
            let mut events = hub.subscribe();
            let running = tracking::transport::start_with_hub(hub, &cfg).await?;
            for (s, a) in cfg.sources.iter().zip(&running.local_addrs) {
                eprintln!(
                    "source {} {}",
                    s.describe(),
                    a.map(|a| format!("(bound {a})")).unwrap_or_default()
                );
            }
            let mut tick = tokio::time::interval(Duration::from_millis(every_ms.max(1)));
            let deadline = tokio::time::sleep(
                seconds.map_or(Duration::from_secs(u64::MAX / 4), Duration::from_secs_f64),
            );
            tokio::pin!(deadline);
            loop {
                tokio::select! {
                    e = events.recv() => match e {
                        Ok(e) => println!("{}", serde_json::json!({"event": e})),
                        Err(tokio::sync::broadcast::error::RecvError::Lagged(n)) => eprintln!("missed {n} events"),
                        Err(_) => break,
                    },
                    _ = tick.tick(), if every_ms > 0 => {
                        for s in running.hub.snapshot() {
                            println!("{}", serde_json::json!({"state": s}));
                        }
                    }
                    _ = &mut deadline => break,
                    _ = tokio::signal::ctrl_c() => break,
                }
            }
            Ok(())
        }
        Cmd::Play {
            input: log,
            speed,
            out,
            hello,
        } => {
            let l = PoseLog::read(&log)?;
            for e in &l.corrupt {
                eprintln!("{}: {e}", log.display());
            }
            let items: Vec<_> = l
                .records
                .iter()
                .filter(|r| r.kind == RecordKind::DTrack)
                .map(|r| (r.time, r.bytes.clone()))
                .collect();
            emit(
                items,
                speed,
                &out,
                &hello,
                &format!("wandtrack play {}", log.display()),
            )
            .await
        }
        Cmd::Check { log } => {
            let l = PoseLog::read(&log)?;
            let (frames, bad) = l.frames();
            let span = l.records.last().map_or(0.0, |r| r.time.as_secs_f64());
            println!(
                "{}: version {}, source {:?}",
                log.display(),
                tracking::poselog::VERSION,
                l.header.source
            );
            println!(
                "records {}, DTrack frames {}, span {span:.3} s",
                l.records.len(),
                frames.len()
            );
            for e in l.corrupt.iter().chain(&bad) {
                println!("corrupt: {e}");
            }
            if l.truncated_tail {
                println!("last line truncated (dropped)");
            }
            if !l.corrupt.is_empty() || !bad.is_empty() {
                std::process::exit(1);
            }
            Ok(())
        }
        Cmd::Pivot {
            input,
            device,
            config,
        } => {
            let calibration = match config {
                Some(p) => TrackingConfig::load(&p)?.calibration,
                None => Calibration::default(),
            };
            let id: tracking::DeviceId = device.parse()?;
            let (frames, bad) = PoseLog::read(&input)?.frames();
            for e in &bad {
                eprintln!("{}: {e}", input.display());
            }
            let marker_only = Calibration {
                tips: Default::default(),
                ..calibration
            };
            let mut poses = Vec::new();
            for f in &frames {
                let pose = match id {
                    tracking::DeviceId::Body(b) => f.body(b).map(|b| b.pose),
                    tracking::DeviceId::Wand(w) => {
                        f.wand(w).filter(|w| w.is_tracked()).map(|w| w.pose)
                    }
                };
                if let Some(wp) = pose.and_then(|p| marker_only.pose_in_display(id, &p)) {
                    poses.push((wp.position_m, wp.orientation));
                }
            }
            let f = tracking::calibration::fit_tip(&poses)?;
            let t = f.tip_in_body_m;
            println!(
                "# {} poses, rms residual {:.3} mm, max {:.3} mm; pivot at {:.4} {:.4} {:.4} m",
                poses.len(),
                f.rms_residual_m * 1e3,
                f.max_residual_m * 1e3,
                f.pivot_in_display_m.x,
                f.pivot_in_display_m.y,
                f.pivot_in_display_m.z
            );
            println!(
                "[calibration.tips]\n{device} = [{:.6}, {:.6}, {:.6}]",
                t.x, t.y, t.z
            );
            Ok(())
        }
        Cmd::Calibrate {
            pairs,
            axes,
            fit_scale,
        } => {
            let text =
                std::fs::read_to_string(&pairs).with_context(|| pairs.display().to_string())?;
            let mut pts = Vec::new();
            for (i, line) in text.lines().enumerate() {
                let line = line.trim();
                if line.is_empty() || line.starts_with('#') {
                    continue;
                }
                let v: Vec<f64> = line
                    .split(',')
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .with_context(|| format!("{} line {}", pairs.display(), i + 1))?;
                if v.len() != 6 {
                    bail!("{} line {}: want 6 numbers", pairs.display(), i + 1);
                }
                pts.push((DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5])));
            }
            let a: Vec<String> = axes.split(',').map(|s| s.trim().to_string()).collect();
            let Ok(axes) = <[String; 3]>::try_from(a) else {
                bail!("--axes wants three entries like x,z,-y");
            };
            let base = Calibration {
                axes,
                ..Calibration::default()
            };
            let f = fit(&pts, &FitOptions { base, fit_scale })?;
            println!(
                "# {} pairs, rms residual {:.3} mm, max {:.3} mm",
                pts.len(),
                f.rms_residual_m * 1e3,
                f.max_residual_m * 1e3
            );
            for (i, r) in f.residuals_m.iter().enumerate() {
                println!("# pair {}: {:.3} mm", i + 1, r * 1e3);
            }
            println!("[calibration]\n{}", toml::to_string(&f.calibration)?);
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn cli_is_well_formed() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }
}
