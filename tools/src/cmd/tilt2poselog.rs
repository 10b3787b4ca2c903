//! `sculpt-tools tilt2poselog`: a real Open Brush recording (`.tilt`) as a pose log.
//!
//! Every stroke becomes button-down, a sweep through its control points at their
//! recorded timing, and button-up; the sketch is placed and scaled onto a target
//! surface (by default the app's default surface). See `tracking::import`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use glam::DVec3;
use tracking::import::{ImportOptions, Placement};

/// Arguments of `sculpt-tools tilt2poselog`.
#[derive(Debug, clap::Args)]
pub struct Tilt2PoselogArgs {
    /// The Open Brush / Tilt Brush sketch to convert.
    pub input: PathBuf,
    /// Where to write the pose log.
    #[arg(long)]
    pub out: PathBuf,
    /// Frame rate of the pose log (Hz, 1 to 2000).
    #[arg(long, default_value_t = 120.0)]
    pub rate: f64,
    /// Centre of the placed sketch, `X,Y,Z` in display metres (default: the centre of
    /// the default surface).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub center: Option<DVec3>,
    /// Fit the sketch's width and height into `W,H` metres.
    #[arg(long, value_parser = parse_pair, default_value = "0.8,0.45")]
    pub fit: (f64, f64),
    /// Fixed scale instead of fitting: metres per Open Brush unit (decimetre).
    #[arg(long)]
    pub scale: Option<f64>,
    /// Fraction of the sketch's depth kept (0 lays it flat onto the surface).
    #[arg(long, default_value_t = 0.0)]
    pub depth_scale: f64,
    /// Offset along the surface normal after placing, metres (negative: into it).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lift: f64,
    /// Turn the sketch about the vertical first, degrees (chooses the view).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw: f64,
    /// Idle gaps between strokes are shortened to at most this many seconds.
    #[arg(long, default_value_t = 1.0)]
    pub max_gap: f64,
    /// Only strokes `A..B` (0-based, end exclusive) of the sketch.
    #[arg(long, value_parser = parse_range)]
    pub strokes: Option<(usize, usize)>,
    /// Playback speed (2 plays the sketch twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Button held while drawing (0 is the trigger).
    #[arg(long, default_value_t = 0)]
    pub button: u8,
    /// Lay the sketch on a plane through the centre instead of the default surface.
    #[arg(long)]
    pub flat: bool,
}

fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(x, y, z)),
        _ => Err("expected three finite numbers X,Y,Z".into()),
    }
}

fn parse_pair(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("expected W,H")?;
    let a: f64 = a.trim().parse().map_err(|e| format!("{a:?}: {e}"))?;
    let b: f64 = b.trim().parse().map_err(|e| format!("{b:?}: {e}"))?;
    Ok((a, b))
}

fn parse_range(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s.split_once("..").ok_or("expected A..B")?;
    let a: usize = a.trim().parse().map_err(|e| format!("{a:?}: {e}"))?;
    let b: usize = b.trim().parse().map_err(|e| format!("{b:?}: {e}"))?;
    Ok((a, b))
}

/// Runs the conversion.
pub fn run(args: Tilt2PoselogArgs) -> Result<()> {
    let bytes =
        std::fs::read(&args.input).with_context(|| format!("reading {}", args.input.display()))?;
    let tilt = tracking::tilt::read_tilt(&bytes)
        .with_context(|| format!("{} is not a valid .tilt file", args.input.display()))?;
    let mut placement = Placement::default();
    if let Some(c) = args.center {
        placement.center = c;
    }
    placement.fit_m = [args.fit.0, args.fit.1];
    placement.scale = args.scale;
    placement.depth_scale = args.depth_scale;
    placement.lift_m = args.lift;
    placement.yaw_deg = args.yaw;
    let options = ImportOptions {
        rate_hz: args.rate,
        placement,
        max_gap_s: args.max_gap,
        strokes: args.strokes,
        speed: args.speed,
        button: args.button,
        ..ImportOptions::default()
    };
    let surface = tracking::import::DefaultSurface;
    let target: Option<&dyn tracking::import::Target> =
        if args.flat { None } else { Some(&surface) };
    let track = tracking::import::wand_track(&tilt.sketch, &options, target)?;
    if track.samples.is_empty() {
        bail!("the sketch gave no samples");
    }
    let source = format!("tilt2poselog {}", args.input.display());
    // Written atomically: a failure part-way (a full disk) leaves no partial log.
    let mut out = fsio::AtomicFile::create(&args.out)?;
    track.write_pose_log(&mut out, &source, &options)?;
    out.commit()?;
    let dur = track.samples.last().map_or(0.0, |s| s.t);
    println!(
        "{}: {} strokes ({} empty skipped), {} frames, {:.1} s, scale {:.4} m per unit",
        args.out.display(),
        track.strokes.len(),
        track.skipped_empty,
        track.samples.len(),
        dur,
        track.scale
    );
    Ok(())
}
