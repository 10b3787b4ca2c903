//! The recorded-session library: deterministic generation of the pose logs shipped in
//! `tests/data/sessions/`.
//!
//! Every session is the tracker simulator ([`tracking::sim`]) performing a script with
//! the wand, written as a pose log, optionally followed by a *trouble* transform on the
//! recorded records (dropped frames, out-of-order frames, a TCP reconnect, a truncated
//! last line). The same code and seed always give the same bytes, so the shipped files
//! can be regenerated with `cargo run -p replay --bin make-sessions -- tests/data/sessions`
//! and a test checks that they are up to date.
//!
//! Geometry: the sessions sculpt the app's default surface, a gently curved 1 m x 0.6 m
//! sheet of [`default_surface_point`], in the display
//! frame with the default calibration (tracker millimetres = display metres x 1000).
//! Buttons follow the interaction's default map: 0 draws, 1 cycles the mode
//! (carve -> emboss -> sketch), 5 selects the next target, 6 turns lattice mode on and
//! off.
//!
//! ```
//! let names: Vec<_> = replay::sessions::catalogue().iter().map(|s| s.name).collect();
//! assert!(names.contains(&"patch-carve"));
//! ```

use std::time::Duration;

use glam::{DQuat, DVec3};
use tracking::poselog::{PoseLog, PoseLogHeader, PoseLogWriter, RecordKind};
use tracking::sim::{Script, SimConfig, Simulator};

use crate::error::{Error, Result};
use crate::import::default_surface_point;

/// What goes wrong in a session, applied to the recorded records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trouble {
    /// Nothing.
    None,
    /// About one frame in eight lost, plus a burst of 20 consecutive frames.
    DroppedFrames,
    /// Every 25th pair of neighbouring frames swapped (frame numbers go backwards).
    OutOfOrder,
    /// The connection dies mid-frame (a half frame is recorded), 0.8 s pass with no
    /// data, then frames resume.
    TcpReconnect,
    /// The log ends in the middle of a line, as after a crash.
    TruncatedLastLine,
    /// Frames 151 to 250 renumbered 9850 down to 9751: the counter jumps far ahead,
    /// then runs backwards, then returns to 251 (more than the reorder window behind).
    CounterJumpsBack,
}

/// One shipped session.
#[derive(Debug, Clone)]
pub struct SessionSpec {
    /// File stem (`NAME.poselog`).
    pub name: &'static str,
    /// What it shows.
    pub description: &'static str,
    /// The wand script.
    pub script: Script,
    /// Simulator settings (rate, seed, tremor, noise).
    pub sim: SimConfig,
    /// The trouble transform.
    pub trouble: Trouble,
    /// Carving strokes the script draws (what a clean replay should apply).
    pub strokes: usize,
    /// Lattice drags the script makes (deformations a clean replay should apply).
    pub deforms: usize,
    /// The solid target the session sculpts beside the sheet (its header names it and
    /// `replay` adds it to the base), if any.
    pub solid: Option<tracking::poselog::SessionSolid>,
    /// Paint strokes the script makes (what a clean replay should apply).
    pub paints: usize,
}

/// A wand orientation that keeps the sketch axis (wand +x) horizontal.
fn level() -> DQuat {
    DQuat::IDENTITY
}

/// Script helpers: lift above the surface, come down, draw through waypoints on the
/// surface, lift off.
struct Sculptor {
    script: Script,
    hover: f64,
}

impl Sculptor {
    fn new() -> Self {
        let start = default_surface_point(0.0, 1.17) + DVec3::new(0.0, 0.0, 0.12);
        Self {
            script: Script::new(start).wand_orientation(level()).hold(0.3),
            hover: 0.05,
        }
    }

    /// Cycles the mode `n` times with button 1.
    fn cycle_mode(mut self, n: usize) -> Self {
        for _ in 0..n {
            self.script = self.script.click(1, 0.08).hold(0.15);
        }
        self
    }

    /// A stroke along `path` (display x, y pairs on the default surface), `secs` long.
    fn stroke_on_surface(self, path: &[(f64, f64)], secs: f64) -> Self {
        let pts: Vec<DVec3> = path
            .iter()
            .map(|&(x, y)| default_surface_point(x, y))
            .collect();
        self.stroke(&pts, secs)
    }

    /// A stroke through `pts` (display metres), `secs` long in all.
    fn stroke(mut self, pts: &[DVec3], secs: f64) -> Self {
        let Some(&first) = pts.first() else {
            return self;
        };
        let above = |p: DVec3| p + DVec3::new(0.0, 0.0, self.hover);
        let per = secs / (pts.len().max(2) - 1) as f64;
        let mut s = self
            .script
            .move_to(above(first), 0.45)
            .move_to(first, 0.2)
            .press(0);
        for &p in &pts[1..] {
            s = s.move_to(p, per);
        }
        let last = pts[pts.len() - 1];
        self.script = s.release(0).move_to(above(last), 0.25).hold(0.2);
        self
    }

    fn occlude(mut self, secs: f64) -> Self {
        self.script = self.script.occlude_wand(secs);
        self
    }

    fn finish(self) -> Script {
        self.script.hold(0.3)
    }
}

/// Waypoints of a straight stroke across the surface at height `y`, x from `x0` to `x1`.
fn across(y: f64, x0: f64, x1: f64, n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| (x0 + (x1 - x0) * i as f64 / (n - 1) as f64, y))
        .collect()
}

/// Three parallel strokes (paper scene 1 and 2 layout).
fn three_parallel(s: Sculptor) -> Sculptor {
    s.stroke_on_surface(&across(1.07, -0.3, 0.3, 7), 1.2)
        .stroke_on_surface(&across(1.17, -0.3, 0.3, 7), 1.2)
        .stroke_on_surface(&across(1.27, -0.3, 0.3, 7), 1.2)
}

/// A wavy stroke crossing the line `y = 1.17` three times, and that straight line:
/// two strokes overlapping in three places (paper scene 3 layout).
fn crossing_pair(s: Sculptor) -> Sculptor {
    let wave: Vec<(f64, f64)> = (0..13)
        .map(|i| {
            let x = -0.3 + 0.6 * i as f64 / 12.0;
            (
                x,
                1.17 + 0.08 * (x / 0.6 * 3.0 * std::f64::consts::TAU).sin(),
            )
        })
        .collect();
    s.stroke_on_surface(&across(1.17, -0.33, 0.33, 7), 1.3)
        .stroke_on_surface(&wave, 2.0)
}

/// A face-like set on the sheet (paper scene 4 layout): two wrinkles embossed, a
/// carved eyebrow and two crossing carved strokes.
fn mask(s: Sculptor) -> Sculptor {
    let brow: Vec<(f64, f64)> = (0..7)
        .map(|i| {
            let x = -0.3 + 0.2 * i as f64 / 6.0;
            (x, 1.28 + 0.03 * (1.0 - ((x + 0.2) / 0.1).powi(2)))
        })
        .collect();
    s.cycle_mode(1) // carve -> emboss
        .stroke_on_surface(&across(1.36, -0.25, 0.25, 6), 1.0)
        .stroke_on_surface(&across(1.32, -0.22, 0.22, 6), 1.0)
        .cycle_mode(2) // emboss -> sketch -> carve
        .stroke_on_surface(&brow, 0.9)
        .stroke_on_surface(&[(0.05, 1.0), (0.15, 1.1), (0.25, 1.2)], 0.8)
        .stroke_on_surface(&[(0.25, 1.0), (0.15, 1.1), (0.05, 1.2)], 0.8)
}

/// The sessions shipped in `tests/data/sessions/`.
pub fn catalogue() -> Vec<SessionSpec> {
    let clean = SimConfig {
        rate_hz: 60.0,
        seed: 11,
        ..SimConfig::default()
    };
    let jitter = SimConfig {
        tremor_mm: 1.5,
        noise_mm: 1.0,
        noise_deg: 0.5,
        seed: 12,
        ..clean.clone()
    };
    let spec = |name, description, script, sim: &SimConfig, trouble, strokes| SessionSpec {
        name,
        description,
        script,
        sim: sim.clone(),
        trouble,
        strokes,
        deforms: 0,
        solid: None,
        paints: 0,
    };
    // Tracking lost mid-stroke: the wand is occluded for 0.2 s in the middle of the
    // second stroke; the stroke pauses and resumes.
    let lost = {
        let s = Sculptor::new().stroke_on_surface(&across(1.07, -0.3, 0.3, 7), 1.2);
        let mid = default_surface_point(0.0, 1.17);
        let s = Sculptor {
            script: s
                .script
                .move_to(default_surface_point(-0.3, 1.17) + DVec3::Z * 0.05, 0.45)
                .move_to(default_surface_point(-0.3, 1.17), 0.2)
                .press(0)
                .move_to(mid, 0.6),
            hover: 0.05,
        }
        .occlude(0.2);
        // The sculptor holds still while the cameras lose the wand.
        let s = Sculptor {
            script: s.script.hold(0.25),
            hover: 0.05,
        };
        let s = Sculptor {
            script: s
                .script
                .move_to(default_surface_point(0.3, 1.17), 0.6)
                .release(0)
                .hold(0.3),
            hover: 0.05,
        };
        s.stroke_on_surface(&across(1.27, -0.3, 0.3, 7), 1.2)
            .finish()
    };
    let mut soak = Sculptor::new();
    for k in 0..12 {
        let y = 1.0 + 0.03 * k as f64;
        soak = soak.stroke_on_surface(&across(y, -0.35, 0.35, 8), 1.6);
        if k == 5 {
            soak = soak.cycle_mode(1);
        }
    }
    let soak_script = {
        // Fill up to a minute with slow hovering between strokes.
        let mut s = soak.script;
        let d = s.duration();
        if d < 60.0 {
            s = s.hold(60.0 - d);
        }
        s
    };
    // A wand with eight buttons: the lattice button (6) is beyond a six-button
    // Flystick's.
    let eight_buttons = SimConfig {
        button_count: 8,
        ..clean.clone()
    };
    let lattice = SessionSpec {
        deforms: 1,
        ..spec(
            "lattice-bend",
            "a groove, then lattice mode (button 6): drag the cage's top front control point 8 cm out; the sheet and the groove bend",
            lattice_bend(),
            &eight_buttons,
            Trouble::None,
            1,
        )
    };
    let solid = SessionSpec {
        solid: Some(carve_solid_plate()),
        ..spec(
            "carve-solid",
            "a 3 mm solid plate in front of the sheet: select it (button 5), two default V grooves (5 mm deep) cut through it, opening two slots",
            carve_solid(),
            &clean,
            Trouble::None,
            2,
        )
    };
    vec![
        spec(
            "patch-carve",
            "paper scene 1: three parallel V grooves carved across the default patch",
            three_parallel(Sculptor::new()).finish(),
            &clean,
            Trouble::None,
            3,
        ),
        spec(
            "patch-emboss",
            "paper scene 2: mode to emboss, three parallel ridges",
            three_parallel(Sculptor::new().cycle_mode(1)).finish(),
            &clean,
            Trouble::None,
            3,
        ),
        spec(
            "patch-overlaps",
            "paper scene 3 layout: a straight and a wavy groove crossing in three places",
            crossing_pair(Sculptor::new()).finish(),
            &clean,
            Trouble::None,
            2,
        ),
        spec(
            "patch-mask",
            "paper scene 4 layout: two embossed wrinkles, a carved brow, two crossing grooves",
            mask(Sculptor::new()).finish(),
            &clean,
            Trouble::None,
            5,
        ),
        spec(
            "sketch-carve",
            "sketch mode: sweep a new surface in front of the sheet, select it, carve across it",
            sketch_then_carve(),
            &clean,
            Trouble::None,
            1,
        ),
        spec(
            "patch-carve-jitter",
            "scene 1 with heavy tremor (1.5 mm) and measurement noise (1 mm)",
            three_parallel(Sculptor::new()).finish(),
            &jitter,
            Trouble::None,
            3,
        ),
        spec(
            "patch-carve-dropped",
            "scene 1 with one frame in eight dropped and a 20-frame burst",
            three_parallel(Sculptor::new()).finish(),
            &clean,
            Trouble::DroppedFrames,
            3,
        ),
        spec(
            "patch-carve-lost",
            "tracking lost mid-stroke: 0.2 s (the stroke resumes) between two clean strokes",
            lost,
            &clean,
            Trouble::None,
            3,
        ),
        spec(
            "patch-carve-reconnect",
            "scene 1 with a TCP reconnect: half a frame, 0.8 s of silence, frames resume",
            three_parallel(Sculptor::new()).finish(),
            &clean,
            Trouble::TcpReconnect,
            3,
        ),
        spec(
            "patch-carve-reordered",
            "scene 1 with every 25th pair of frames swapped",
            three_parallel(Sculptor::new()).finish(),
            &clean,
            Trouble::OutOfOrder,
            3,
        ),
        spec(
            "patch-carve-backwards",
            "scene 1 with frames 151 to 250 renumbered 9850 down to 9751 (counter runs backwards)",
            three_parallel(Sculptor::new()).finish(),
            &clean,
            Trouble::CounterJumpsBack,
            3,
        ),
        spec(
            "patch-carve-truncated",
            "scene 1 whose last line is cut off mid-record, as after a crash",
            three_parallel(Sculptor::new()).finish(),
            &clean,
            Trouble::TruncatedLastLine,
            3,
        ),
        spec(
            "soak-60s",
            "a minute of work: twelve strokes (six carved, six embossed), for speed and soak",
            soak_script,
            &clean,
            Trouble::None,
            12,
        ),
        lattice,
        solid,
        SessionSpec {
            paints: 3,
            ..spec(
                "paint",
                "a groove, then paint mode (button 7): three sweeps paint a terracotta band across the sheet, over the groove",
                paint_band(),
                &eight_buttons,
                Trouble::None,
                1,
            )
        },
    ]
}

/// Carve one groove, switch to paint mode (button 7), sweep the brush across the
/// sheet three times just above it (a band over the groove), switch back.
fn paint_band() -> Script {
    let s = Sculptor::new().stroke_on_surface(&across(1.17, -0.3, 0.3, 7), 1.2);
    let mut s = Sculptor {
        script: s.script.click(7, 0.08).hold(0.15),
        hover: 0.05,
    };
    for y in [1.13, 1.17, 1.21] {
        let pts: Vec<DVec3> = across(y, -0.35, 0.35, 8)
            .iter()
            .map(|&(x, y)| default_surface_point(x, y) + DVec3::new(0.0, 0.0, 0.008))
            .collect();
        s = s.stroke(&pts, 1.4);
    }
    Sculptor {
        script: s.script.click(7, 0.08).hold(0.15),
        hover: 0.05,
    }
    .finish()
}

/// The plate of the `carve-solid` session: 30 cm x 20 cm, 3 mm thick, its top face at
/// z = [`CARVE_SOLID_TOP`], centred in front of the sheet.
pub fn carve_solid_plate() -> tracking::poselog::SessionSolid {
    let (top, bottom) = (CARVE_SOLID_TOP, CARVE_SOLID_TOP - 0.003);
    tracking::poselog::SessionSolid {
        name: "plate".into(),
        model: format!(
            r#"{{"version": 1, "solid": {{"box": {{"min": [-0.15, 1.07, {bottom}], "max": [0.15, 1.27, {top}]}}}}}}"#
        ),
        cells: 256,
    }
}

/// The top face of the `carve-solid` plate (display z, metres).
pub const CARVE_SOLID_TOP: f64 = 0.05;

/// Select the plate (button 5), then two grooves across it with the default tool.
fn carve_solid() -> Script {
    let s = Sculptor::new();
    let script = s.script.click(5, 0.08).hold(0.2);
    let groove = |y: f64| -> Vec<DVec3> {
        (0..7)
            .map(|i| DVec3::new(-0.1 + 0.2 * i as f64 / 6.0, y, CARVE_SOLID_TOP))
            .collect()
    };
    Sculptor {
        script,
        hover: 0.05,
    }
    .stroke(&groove(1.12), 1.2)
    .stroke(&groove(1.22), 1.2)
    .finish()
}

/// The cage control point the lattice session grabs: of the default lattice around
/// the default sheet, the one at the top front, a third in from the left
/// (`[1, 3, 3]`).
pub fn lattice_grab_point() -> DVec3 {
    let sheet = sculpt_core::editor::default_surface();
    let lattice = sculpt_core::lattice::Lattice::around(
        sculpt_core::lattice::LatticeSpec::default(),
        &[&sheet],
    )
    .unwrap_or_else(|e| unreachable!("the default sheet has a lattice: {e}"));
    lattice.rest_point(lattice.flat([1, 3, 3]))
}

/// Carve one groove, switch to lattice mode (button 6), drag the cage point of
/// [`lattice_grab_point`] 8 cm towards the viewer and 3 cm up, switch back.
fn lattice_bend() -> Script {
    let s = Sculptor::new().stroke_on_surface(&across(1.27, -0.3, 0.3, 7), 1.2);
    let grab = lattice_grab_point();
    let script = s
        .script
        .click(6, 0.08)
        .hold(0.15)
        .move_to(grab + DVec3::new(0.0, 0.0, 0.05), 0.5)
        .move_to(grab, 0.25)
        .hold(0.1)
        .press(0)
        .move_to(grab + DVec3::new(0.0, 0.03, 0.08), 0.8)
        .hold(0.1)
        .release(0)
        .hold(0.2)
        .click(6, 0.08)
        .hold(0.15);
    Sculptor {
        script,
        hover: 0.05,
    }
    .finish()
}

/// Sketch a surface 12 cm in front of the sheet, select it (button 5), then carve
/// one groove across it.
fn sketch_then_carve() -> Script {
    let z = 0.05;
    let s = Sculptor::new().cycle_mode(2); // carve -> emboss -> sketch
    let start = DVec3::new(-0.15, 1.05, z);
    let script = s
        .script
        .move_to(start + DVec3::Z * 0.05, 0.4)
        .move_to(start, 0.2)
        .press(0)
        .move_to(DVec3::new(-0.15, 1.15, z + 0.02), 0.6)
        .move_to(DVec3::new(-0.15, 1.25, z + 0.02), 0.6)
        .move_to(DVec3::new(-0.15, 1.35, z), 0.6)
        .release(0)
        .hold(0.2)
        .click(1, 0.08) // sketch -> carve
        .hold(0.15)
        .click(5, 0.08) // select the new target
        .hold(0.2);
    // The sketched sheet spans x in [-0.15, 0.15] (the 0.3 m sketch axis), y in
    // [1.05, 1.35]; carve across its middle.
    let pts: Vec<DVec3> = (0..6)
        .map(|i| DVec3::new(-0.12 + 0.24 * i as f64 / 5.0, 1.2, z + 0.02))
        .collect();
    Sculptor {
        script,
        hover: 0.05,
    }
    .stroke(&pts, 1.0)
    .finish()
}

/// Renders a session: the simulator's pose log, then its trouble.
pub fn render(spec: &SessionSpec) -> Result<Vec<u8>> {
    let track = Error::Tracking;
    let header = PoseLogHeader {
        source: format!("sim session={} seed={}", spec.name, spec.sim.seed),
        solid: spec.solid.clone(),
        ..PoseLogHeader::default()
    };
    let sim = Simulator::new(&spec.script, spec.sim.clone()).map_err(track)?;
    let clean = sim.write_pose_log(Vec::new(), &header).map_err(track)?;
    apply_trouble(&clean, spec.trouble, spec.sim.seed)
}

/// Every session of the [`catalogue`] as `(file name, bytes)`.
pub fn render_all() -> Result<Vec<(String, Vec<u8>)>> {
    catalogue()
        .iter()
        .map(|s| Ok((format!("{}.poselog", s.name), render(s)?)))
        .collect()
}

/// The `README.md` index of the session directory.
pub fn index_markdown() -> String {
    let mut out = String::from(
        "# Recorded sessions\n\n\
         Generated by `cargo run -p replay --bin make-sessions -- tests/data/sessions` from\n\
         `replay/src/sessions.rs` (the tracker simulator performing scripted wand motion);\n\
         do not edit by hand. The format is the tracking crate's pose log.\n\n\
         | file | seconds | rate | strokes | what |\n|---|---|---|---|---|\n",
    );
    for s in catalogue() {
        out.push_str(&format!(
            "| `{}.poselog` | {:.1} | {} Hz | {} | {} |\n",
            s.name,
            s.script.duration(),
            s.sim.rate_hz,
            s.strokes,
            s.description
        ));
    }
    out
}

/// A small deterministic generator (SplitMix64) for the trouble transforms.
struct Mix(u64);

impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// Applies a trouble transform to a clean pose log.
pub fn apply_trouble(clean: &[u8], trouble: Trouble, seed: u64) -> Result<Vec<u8>> {
    if trouble == Trouble::None {
        return Ok(clean.to_vec());
    }
    let track = Error::Tracking;
    let log = PoseLog::from_bytes(clean).map_err(track)?;
    let mut records: Vec<(RecordKind, Duration, Vec<u8>)> = log
        .records
        .into_iter()
        .map(|r| (r.kind, r.time, r.bytes))
        .collect();
    let n = records.len();
    let mut rng = Mix(seed);
    match trouble {
        Trouble::None | Trouble::TruncatedLastLine => {}
        Trouble::DroppedFrames => {
            let burst = n / 2..(n / 2 + 20).min(n);
            let mut i = 0;
            records.retain(|_| {
                let keep = !burst.contains(&i) && !rng.next().is_multiple_of(8);
                i += 1;
                keep
            });
        }
        Trouble::OutOfOrder => {
            let mut i = 10;
            while i + 1 < n {
                // Swap the payloads, keep the receive times in order.
                let (a, b) = records.split_at_mut(i + 1);
                std::mem::swap(&mut a[i].2, &mut b[0].2);
                i += 25;
            }
        }
        Trouble::CounterJumpsBack => {
            for r in &mut records {
                let Some(rest) = r.2.strip_prefix(b"fr ") else {
                    continue;
                };
                let end = rest.iter().position(|&b| b == b'\r').unwrap_or(rest.len());
                let n: Option<u64> = std::str::from_utf8(&rest[..end])
                    .ok()
                    .and_then(|t| t.parse().ok());
                if let Some(n @ 151..=250) = n {
                    let mut bytes = format!("fr {}", 10_001 - n).into_bytes();
                    bytes.extend_from_slice(&rest[end..]);
                    r.2 = bytes;
                }
            }
        }
        Trouble::TcpReconnect => {
            let cut = n * 2 / 5;
            let gap = Duration::from_millis(800);
            if let Some(r) = records.get_mut(cut) {
                let half = r.2.len() / 2;
                r.2.truncate(half);
            }
            let t_cut = records.get(cut).map_or(Duration::ZERO, |r| r.1);
            // Frames that would have arrived during the outage are gone.
            records.retain(|r| r.1 <= t_cut || r.1 > t_cut + gap);
        }
    }
    let mut out = Vec::new();
    let mut w = PoseLogWriter::new(&mut out, &log.header).map_err(track)?;
    for (kind, t, bytes) in &records {
        w.write(*kind, *t, bytes).map_err(track)?;
    }
    drop(w);
    if trouble == Trouble::TruncatedLastLine {
        // Cut the last record in the middle.
        let body_end = out.len() - 1;
        let line_start = out[..body_end]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1);
        out.truncate(line_start + (body_end - line_start) / 2);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_session_renders_deterministically_and_stays_small() {
        for spec in catalogue() {
            let a = render(&spec).unwrap();
            let b = render(&spec).unwrap();
            assert_eq!(a, b, "{}", spec.name);
            let limit = if spec.name.starts_with("soak") {
                2 << 20
            } else {
                400 << 10
            };
            assert!(a.len() < limit, "{}: {} bytes", spec.name, a.len());
        }
    }

    #[test]
    fn troubles_do_what_they_say() {
        let spec = &catalogue()[0];
        let clean = render(spec).unwrap();
        let n_clean = PoseLog::from_bytes(&clean).unwrap().records.len();
        let dropped = apply_trouble(&clean, Trouble::DroppedFrames, 1).unwrap();
        let n = PoseLog::from_bytes(&dropped).unwrap().records.len();
        assert!(
            n < n_clean * 15 / 16 && n > n_clean * 3 / 4,
            "{n} of {n_clean}"
        );
        let truncated = apply_trouble(&clean, Trouble::TruncatedLastLine, 1).unwrap();
        let log = PoseLog::from_bytes(&truncated).unwrap();
        assert!(log.truncated_tail);
        assert_eq!(log.records.len(), n_clean - 1);
        let reconnect = apply_trouble(&clean, Trouble::TcpReconnect, 1).unwrap();
        let log = PoseLog::from_bytes(&reconnect).unwrap();
        let (_, bad) = log.frames();
        assert_eq!(bad.len(), 1, "the half frame is the one bad record");
        let gaps = log
            .records
            .windows(2)
            .filter(|w| w[1].time - w[0].time > Duration::from_millis(700));
        assert_eq!(gaps.count(), 1);
        let reordered = apply_trouble(&clean, Trouble::OutOfOrder, 1).unwrap();
        let (frames, _) = PoseLog::from_bytes(&reordered).unwrap().frames();
        let backwards = frames
            .windows(2)
            .filter(|w| w[1].number < w[0].number)
            .count();
        assert!(backwards >= 3, "{backwards}");
        let jumped = apply_trouble(&clean, Trouble::CounterJumpsBack, 1).unwrap();
        let (frames, _) = PoseLog::from_bytes(&jumped).unwrap().frames();
        let numbers: Vec<u64> = frames.iter().map(|f| f.number).collect();
        assert_eq!(numbers[149..252], {
            let mut want = vec![150];
            want.extend((9751..=9850).rev());
            want.extend([251, 252]);
            want
        });
    }
}
