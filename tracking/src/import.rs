//! Open Brush strokes as a wand track: placement near a target surface and timing.
//!
//! [`wand_track`] turns a decoded [`Sketch`] into a list of
//! [`TrackSample`]s at a fixed frame rate: for every stroke the action button goes down
//! at the first control point, the wand sweeps through the points at their recorded
//! millisecond timing, and the button comes up at the last point. Between strokes the
//! wand moves on a minimum-jerk path, with the button up, to the next stroke's start;
//! idle gaps longer than [`ImportOptions::max_gap_s`] are shortened to it.
//!
//! ## Placement
//! Open Brush positions are decimetres in Unity's left-handed frame (x right, y up,
//! z away from the viewer). They are first turned right-handed (`z -> -z`, which
//! makes z point at the viewer, as in the display frame), optionally turned about the
//! vertical by [`Placement::yaw_deg`], then the bounding box of the chosen strokes is
//! centred on [`Placement::center`] and its x/y extent scaled to fit
//! [`Placement::fit_m`] (or by a fixed [`Placement::scale`], metres per Open Brush
//! unit). The sketch's depth is scaled by [`Placement::depth_scale`]: 0 flattens it onto
//! the target, 1 keeps its true depth. With a [`Target`], each point is then carried
//! along the placement normal onto the surface and lifted by [`Placement::lift_m`]
//! plus its scaled depth, so a flattened sketch lies exactly on a curved target.
//!
//! ```
//! use tracking::import::{wand_track, ImportOptions};
//! use tracking::tilt::{ControlPoint, Sketch, TiltStroke};
//! let sketch = Sketch { version: 5, strokes: vec![TiltStroke {
//!     points: (0..10).map(|i| ControlPoint::at([i as f32, 0.0, 0.0], 1000 + 20 * i)).collect(),
//!     ..TiltStroke::default()
//! }]};
//! let track = wand_track(&sketch, &ImportOptions::default(), None).unwrap();
//! let down = track.samples.iter().filter(|s| s.buttons & 1 != 0).count();
//! assert!(down >= 20, "0.18 s of sweep at 120 Hz");
//! assert_eq!(track.strokes.len(), 1);
//! ```

use std::io::Write;
use std::time::Duration;

use crate::error::{ImportError, Result, TrackingError as Error};
use crate::poselog::{PoseLogHeader, PoseLogWriter};
use crate::{Body, Frame, Pose, Wand};
use glam::{DQuat, DVec3};
use serde::Serialize;

/// Where the head target is held in imported sessions (display metres): 0.6 m in
/// front of the default surface at eye height.
pub const DEFAULT_HEAD_M: DVec3 = DVec3::new(0.0, 1.6, 0.6);
use crate::tilt::Sketch;

/// A surface the sketch is laid onto.
pub trait Target {
    /// The point of the surface hit by the line through `p` along `dir` (a unit vector)
    /// nearest to `p`, with the surface's unit normal there; `None` when the line misses.
    fn hit(&self, p: DVec3, dir: DVec3) -> Option<(DVec3, DVec3)>;
}

/// A plane as a [`Target`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub origin: DVec3,
    /// The unit normal.
    pub normal: DVec3,
}

impl Target for Plane {
    fn hit(&self, p: DVec3, dir: DVec3) -> Option<(DVec3, DVec3)> {
        let denom = dir.dot(self.normal);
        if denom.abs() < sculpt_core::tolerance::PARALLEL_COS_EPS {
            return None;
        }
        let s = (self.origin - p).dot(self.normal) / denom;
        Some((p + dir * s, self.normal))
    }
}

pub use sculpt_core::editor::{DEFAULT_SURFACE_CENTER as SURFACE_CENTER, default_surface_point};

/// The app's default surface as a [`Target`] (see [`default_surface_point`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DefaultSurface;

impl Target for DefaultSurface {
    fn hit(&self, p: DVec3, dir: DVec3) -> Option<(DVec3, DVec3)> {
        if dir.z.abs() < 0.3 {
            return None;
        }
        // The sheet is a height field over (x, y) with slopes below 0.6 on its extent:
        // fixed-point iteration on the distance along `dir` converges.
        let mut s = 0.0;
        for _ in 0..50 {
            let q = p + dir * s;
            let next = (default_surface_point(q.x, q.y).z - p.z) / dir.z;
            if (next - s).abs() < crate::tolerance::FIXED_POINT_EPS {
                s = next;
                break;
            }
            s = next;
        }
        let q = p + dir * s;
        let on = default_surface_point(q.x, q.y);
        let u = on.x - SURFACE_CENTER.x;
        let v = (on.y - SURFACE_CENTER.y) / 0.6;
        let normal = DVec3::new(u, 0.5 * v / 0.6, 1.0).normalize();
        (on.is_finite() && (on - q).length() < sculpt_core::tolerance::POINT_EPS)
            .then_some((on, normal))
    }
}

/// Where and how big the sketch goes, in the display frame (metres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Placement {
    /// Where the centre of the sketch's bounding box goes.
    pub center: DVec3,
    /// The display direction of the sketch's x axis (unit).
    pub right: DVec3,
    /// The display direction of the sketch's y axis (unit).
    pub up: DVec3,
    /// The largest width and height (metres) the sketch's x/y extent is scaled into.
    pub fit_m: [f64; 2],
    /// A fixed scale (metres per Open Brush unit) instead of fitting.
    pub scale: Option<f64>,
    /// Fraction of the sketch's depth kept (0 flattens it onto the target).
    pub depth_scale: f64,
    /// Offset along the normal after landing on the target (metres; negative goes in).
    pub lift_m: f64,
    /// Turn about the vertical (degrees) before placing, to choose the view.
    pub yaw_deg: f64,
}

impl Placement {
    /// The unit normal of the placement plane (`right x up`, towards the viewer).
    pub fn normal(&self) -> DVec3 {
        self.right.cross(self.up).normalize_or_zero()
    }
}

impl Default for Placement {
    fn default() -> Self {
        Self {
            center: DVec3::new(0.0, 1.17, -0.1),
            right: DVec3::X,
            up: DVec3::Y,
            fit_m: [0.8, 0.45],
            scale: None,
            depth_scale: 0.0,
            lift_m: 0.0,
            yaw_deg: 0.0,
        }
    }
}

/// How a sketch becomes a wand track.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportOptions {
    /// Frame rate of the track (Hz), 1 to 2000.
    pub rate_hz: f64,
    /// Placement in the display frame.
    pub placement: Placement,
    /// Idle time between strokes is shortened to at most this (seconds).
    pub max_gap_s: f64,
    /// Still time before the first stroke and after the last (seconds).
    pub lead_s: f64,
    /// The strokes to take (`first..end` indices into the sketch); all when `None`.
    pub strokes: Option<(usize, usize)>,
    /// Button bit held during each stroke (0 is the trigger).
    pub button: u8,
    /// Playback speed: 2 plays the sketch twice as fast.
    pub speed: f64,
    /// Milliseconds between points that carry no timestamp.
    pub default_point_ms: f64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            rate_hz: 120.0,
            placement: Placement::default(),
            max_gap_s: 1.0,
            lead_s: 0.5,
            strokes: None,
            button: 0,
            speed: 1.0,
            default_point_ms: 11.0,
        }
    }
}

impl ImportOptions {
    fn validate(&self) -> Result<()> {
        let bad = |e: ImportError| Err(Error::Import(e));
        let p = &self.placement;
        if !(self.rate_hz.is_finite() && (1.0..=2000.0).contains(&self.rate_hz)) {
            return bad(ImportError::Rate);
        }
        if !(self.speed.is_finite() && self.speed > 0.0 && self.speed <= 1000.0) {
            return bad(ImportError::Speed);
        }
        let finite = [
            self.max_gap_s,
            self.lead_s,
            self.default_point_ms,
            p.fit_m[0],
            p.fit_m[1],
            p.depth_scale,
            p.lift_m,
            p.yaw_deg,
        ];
        if finite.iter().any(|v| !v.is_finite()) || !p.center.is_finite() {
            return bad(ImportError::NotFinite);
        }
        if self.max_gap_s < 0.0 || self.lead_s < 0.0 || self.default_point_ms <= 0.0 {
            return bad(ImportError::Timing);
        }
        if self.max_gap_s > 3600.0 || self.lead_s > 3600.0 {
            return bad(ImportError::TooLong);
        }
        if p.fit_m[0] <= 0.0 || p.fit_m[1] <= 0.0 {
            return bad(ImportError::FitBox);
        }
        if let Some(s) = p.scale
            && !(s.is_finite() && s > 0.0)
        {
            return bad(ImportError::Scale);
        }
        if p.right.length() < sculpt_core::tolerance::POINT_EPS
            || p.up.length() < sculpt_core::tolerance::POINT_EPS
            || p.normal().length() < 0.5
        {
            return bad(ImportError::Axes);
        }
        if self.button >= 32 {
            return bad(ImportError::Button);
        }
        Ok(())
    }
}

/// One sample of the wand track (display frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackSample {
    /// Seconds since the start of the track.
    pub t: f64,
    /// Wand position, metres.
    pub position_m: DVec3,
    /// `display_from_wand` rotation.
    pub orientation: DQuat,
    /// Button bits held.
    pub buttons: u32,
}

/// Where one imported stroke sits in the track.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackStroke {
    /// Index of the stroke in the `.tilt` sketch.
    pub source_index: usize,
    /// Button-down time, seconds.
    pub start_s: f64,
    /// Button-up time, seconds.
    pub end_s: f64,
    /// The placed control points (display frame metres).
    pub points_m: Vec<DVec3>,
}

/// A sketch turned into wand motion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Track {
    /// Samples at the frame rate, from t = 0.
    pub samples: Vec<TrackSample>,
    /// The strokes, in order.
    pub strokes: Vec<TrackStroke>,
    /// Metres per Open Brush unit actually used.
    pub scale: f64,
    /// Strokes skipped because they had no control points.
    pub skipped_empty: usize,
}

/// Placed points and timing of one stroke before sampling.
struct Placed {
    source_index: usize,
    times_s: Vec<f64>,
    points: Vec<DVec3>,
    rotations: Vec<DQuat>,
}

/// Turns `sketch` into a wand track. `target` is the surface the sketch lands on
/// (see the module docs); without one, the placement plane is used.
pub fn wand_track(
    sketch: &Sketch,
    options: &ImportOptions,
    target: Option<&dyn Target>,
) -> Result<Track> {
    options.validate()?;
    let p = &options.placement;
    let (first, end) = options.strokes.unwrap_or((0, sketch.strokes.len()));
    if first >= end || end > sketch.strokes.len() {
        return Err(Error::Import(ImportError::StrokeRange {
            first,
            end,
            count: sketch.strokes.len(),
        }));
    }
    // Right-handed, yawed Open Brush coordinates (still Open Brush units).
    let yaw = DQuat::from_rotation_y(p.yaw_deg.to_radians());
    let to_rh = |v: DVec3| yaw * DVec3::new(v.x, v.y, -v.z);
    let to_rh_q = |q: DQuat| yaw * DQuat::from_xyzw(-q.x, -q.y, q.z, q.w);
    let chosen: Vec<_> = (first..end)
        .filter(|&i| !sketch.strokes[i].points.is_empty())
        .collect();
    let skipped_empty = (end - first) - chosen.len();
    if chosen.is_empty() {
        return Err(Error::Import(ImportError::NoPoints));
    }
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for &i in &chosen {
        for pt in &sketch.strokes[i].points {
            let v = to_rh(pt.position_dm());
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let mid = (lo + hi) * 0.5;
    let extent = hi - lo;
    let scale = p.scale.unwrap_or_else(|| {
        let sx = if extent.x > sculpt_core::tolerance::POINT_EPS {
            p.fit_m[0] / extent.x
        } else {
            f64::INFINITY
        };
        let sy = if extent.y > sculpt_core::tolerance::POINT_EPS {
            p.fit_m[1] / extent.y
        } else {
            f64::INFINITY
        };
        let s = sx.min(sy);
        if s.is_finite() { s } else { 0.1 }
    });
    let (right, up) = (p.right.normalize(), p.up.normalize());
    let normal = p.normal();
    let place = |v: DVec3| -> DVec3 {
        let d = (to_rh(v) - mid) * scale;
        let in_plane = p.center + right * d.x + up * d.y;
        let depth = d.z * p.depth_scale + p.lift_m;
        match target.and_then(|t| t.hit(in_plane, normal)) {
            Some((on, n)) if on.is_finite() && n.is_finite() => {
                // Lift along the side of the surface normal that faces the viewer.
                let n = if n.dot(normal) < 0.0 { -n } else { n };
                on + n * depth
            }
            _ => in_plane + normal * depth,
        }
    };
    let frame_dt = 1.0 / options.rate_hz;
    let mut placed = Vec::with_capacity(chosen.len());
    let mut clock = options.lead_s;
    let mut prev_end_ms: Option<f64> = None;
    for &i in &chosen {
        let stroke = &sketch.strokes[i];
        // Monotone times in ms, relative to the stroke's first point.
        let mut ms = Vec::with_capacity(stroke.points.len());
        let mut last = f64::NEG_INFINITY;
        for (k, pt) in stroke.points.iter().enumerate() {
            let raw = pt
                .timestamp_ms
                .map(f64::from)
                .unwrap_or_else(|| k as f64 * options.default_point_ms);
            let t = if k == 0 { raw } else { raw.max(last) };
            ms.push(t);
            last = t;
        }
        let start_ms = ms[0];
        // Gap from the previous stroke, in session seconds.
        let gap_s = match prev_end_ms {
            None => 0.0,
            Some(e) => ((start_ms - e) / 1000.0 / options.speed).clamp(0.0, options.max_gap_s),
        };
        // At least two frames between strokes so the button is seen up.
        if prev_end_ms.is_some() {
            clock += gap_s.max(2.0 * frame_dt);
        }
        let mut times_s: Vec<f64> = ms
            .iter()
            .map(|m| clock + (m - start_ms) / 1000.0 / options.speed)
            .collect();
        // A stroke lasts at least one frame, so its button-down is seen.
        let t_first = times_s[0];
        if let Some(last) = times_s.last_mut()
            && *last - t_first < frame_dt
        {
            *last = t_first + frame_dt;
        }
        clock = *times_s.last().unwrap_or(&clock);
        prev_end_ms = ms.last().copied();
        placed.push(Placed {
            source_index: i,
            times_s,
            points: stroke
                .points
                .iter()
                .map(|pt| place(pt.position_dm()))
                .collect(),
            rotations: stroke
                .points
                .iter()
                .map(|pt| to_rh_q(pt.rotation()))
                .collect(),
        });
    }
    let duration = clock + options.lead_s;
    let frames = (duration * options.rate_hz).ceil() as usize + 1;
    let max_frames = 50_000_000;
    if frames > max_frames {
        return Err(Error::Import(ImportError::TooManyFrames {
            frames,
            max: max_frames,
        }));
    }
    let button = 1u32 << options.button;
    let mut samples = Vec::with_capacity(frames);
    let mut k = 0; // index of the current-or-next stroke
    for n in 0..frames {
        let t = n as f64 * frame_dt;
        while k < placed.len() && t > *placed[k].times_s.last().unwrap_or(&t) {
            k += 1;
        }
        let sample = if k == placed.len() {
            let s = placed.last().map_or_else(
                || (p.center, DQuat::IDENTITY),
                |s| {
                    (
                        s.points[s.points.len() - 1],
                        s.rotations[s.rotations.len() - 1],
                    )
                },
            );
            TrackSample {
                t,
                position_m: s.0,
                orientation: s.1,
                buttons: 0,
            }
        } else if t >= placed[k].times_s[0] {
            let (pos, rot) = along(&placed[k], t);
            TrackSample {
                t,
                position_m: pos,
                orientation: rot,
                buttons: button,
            }
        } else {
            // Transit from the previous stroke's end (or hold before the first).
            let next = &placed[k];
            let (from, from_rot, t0) = match k.checked_sub(1).map(|j| &placed[j]) {
                Some(prev) => (
                    prev.points[prev.points.len() - 1],
                    prev.rotations[prev.rotations.len() - 1],
                    prev.times_s[prev.times_s.len() - 1],
                ),
                None => (next.points[0], next.rotations[0], 0.0),
            };
            let t1 = next.times_s[0];
            let s = if t1 > t0 {
                min_jerk((t - t0) / (t1 - t0))
            } else {
                1.0
            };
            TrackSample {
                t,
                position_m: from.lerp(next.points[0], s),
                orientation: from_rot.slerp(next.rotations[0], s),
                buttons: 0,
            }
        };
        samples.push(sample);
    }
    let strokes = placed
        .into_iter()
        .map(|s| TrackStroke {
            source_index: s.source_index,
            start_s: s.times_s[0],
            end_s: s.times_s[s.times_s.len() - 1],
            points_m: s.points,
        })
        .collect();
    Ok(Track {
        samples,
        strokes,
        scale,
        skipped_empty,
    })
}

impl Track {
    /// The track as tracker frames, with the default calibration (display metres =
    /// tracker millimetres / 1000): the wand as Flystick `wand_id` with six buttons, and
    /// the head as body 0 held still at `head_m` (none: no head target).
    pub fn frames(&self, wand_id: u32, head_m: Option<DVec3>) -> Vec<Frame> {
        self.samples
            .iter()
            .enumerate()
            .map(|(n, s)| {
                let mut f = Frame::new(n as u64 + 1);
                f.tracker_time = Some(s.t);
                f.receive_time = Duration::from_secs_f64(s.t);
                if let Some(h) = head_m {
                    f.calibrated_bodies = Some(1);
                    f.bodies.push(Body {
                        id: 0,
                        quality: 1.0,
                        pose: Pose::from_position_mm(h * 1000.0),
                    });
                }
                f.calibrated_wands = Some(1);
                let mut wand = Wand::tracked(
                    wand_id,
                    Pose::from_quat(s.position_m * 1000.0, s.orientation),
                );
                wand.buttons = u64::from(s.buttons);
                f.wands.push(wand);
                f
            })
            .collect()
    }

    /// Writes the track as a pose log; the header's `config` records `options`.
    pub fn write_pose_log<W: Write>(
        &self,
        w: W,
        source: &str,
        options: &ImportOptions,
    ) -> Result<W> {
        let header = PoseLogHeader {
            source: source.to_string(),
            config: serde_json::json!({ "tilt2poselog": options }),
            ..PoseLogHeader::default()
        };
        let mut log = PoseLogWriter::new(w, &header)?;
        for f in self.frames(0, Some(DEFAULT_HEAD_M)) {
            log.write_frame(&f)?;
        }
        Ok(log.into_inner())
    }
}

/// Position and rotation of a placed stroke at session time `t` (linear in time
/// between control points, slerp for rotation).
fn along(s: &Placed, t: f64) -> (DVec3, DQuat) {
    let i = s.times_s.partition_point(|&ti| ti <= t);
    if i == 0 {
        return (s.points[0], s.rotations[0]);
    }
    if i >= s.times_s.len() {
        let j = s.times_s.len() - 1;
        return (s.points[j], s.rotations[j]);
    }
    let (t0, t1) = (s.times_s[i - 1], s.times_s[i]);
    let a = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
    (
        s.points[i - 1].lerp(s.points[i], a),
        s.rotations[i - 1].slerp(s.rotations[i], a),
    )
}

/// The minimum-jerk profile `10 s^3 - 15 s^4 + 6 s^5` on [0, 1] (Flash and Hogan).
fn min_jerk(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tilt::{ControlPoint, TiltStroke};
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::POINT_EPS;

    fn line(y: f32, t0: u32, n: u32) -> TiltStroke {
        TiltStroke {
            points: (0..n)
                .map(|i| ControlPoint::at([i as f32, y, 3.0], t0 + 10 * i))
                .collect(),
            ..TiltStroke::default()
        }
    }

    fn two_lines() -> Sketch {
        Sketch {
            version: 5,
            strokes: vec![
                line(0.0, 0, 11),
                TiltStroke::default(),
                line(5.0, 60_000, 11),
            ],
        }
    }

    #[test]
    fn strokes_become_button_down_sweep_button_up() {
        let track = wand_track(&two_lines(), &ImportOptions::default(), None).unwrap();
        assert_eq!(track.strokes.len(), 2);
        assert_eq!(track.skipped_empty, 1);
        // Each stroke lasts 100 ms; the one-minute gap is cut to max_gap_s.
        let s = &track.strokes;
        assert_near!(s[0].start_s, 0.5, POINT_EPS);
        assert_near!(s[0].end_s - s[0].start_s, 0.1, POINT_EPS);
        assert_near!(s[1].start_s - s[0].end_s, 1.0, POINT_EPS);
        // Exactly two runs of button-down frames.
        let downs: Vec<bool> = track.samples.iter().map(|x| x.buttons == 1).collect();
        let edges = downs.windows(2).filter(|w| !w[0] && w[1]).count();
        assert_eq!(edges, 2);
        // Fit: x extent 10 dm into 0.8 m (0.08 m/dm) binds before y (5 dm into 0.45 m).
        assert_near!(track.scale, 0.08, POINT_EPS);
        // Flattened onto the default plane (z = -0.1), centred.
        for smp in &track.samples {
            assert_near!(smp.position_m.z, -0.1, POINT_EPS);
        }
        let first = s[0].points_m[0];
        assert_near!(first.x, -5.0 * track.scale, POINT_EPS);
    }

    #[test]
    fn samples_follow_recorded_timing_during_a_stroke() {
        let opts = ImportOptions {
            rate_hz: 1000.0,
            lead_s: 0.0,
            ..ImportOptions::default()
        };
        let track = wand_track(&two_lines(), &opts, None).unwrap();
        // 1 dm per 10 ms: at t = 0.025 s the wand is 2.5 dm along.
        let smp = track.samples[25];
        assert_eq!(smp.buttons, 1);
        let along = (smp.position_m.x - track.strokes[0].points_m[0].x) / track.scale;
        assert_near!(along, 2.5, POINT_EPS);
    }

    #[test]
    fn a_curved_target_receives_every_point() {
        struct Bowl;
        impl Target for Bowl {
            fn hit(&self, p: DVec3, _dir: DVec3) -> Option<(DVec3, DVec3)> {
                let z = -0.2 * (p.x * p.x);
                Some((DVec3::new(p.x, p.y, z), DVec3::Z))
            }
        }
        let mut opts = ImportOptions::default();
        opts.placement.lift_m = -0.001;
        let track = wand_track(&two_lines(), &opts, Some(&Bowl)).unwrap();
        for s in &track.strokes {
            for q in &s.points_m {
                assert_near!(q.z, -0.2 * q.x * q.x - 0.001, POINT_EPS);
            }
        }
    }

    #[test]
    fn bad_options_and_ranges_are_errors() {
        let sk = two_lines();
        let mut o = ImportOptions {
            rate_hz: f64::NAN,
            ..ImportOptions::default()
        };
        assert!(wand_track(&sk, &o, None).is_err());
        o.rate_hz = 120.0;
        o.strokes = Some((2, 9));
        assert!(
            wand_track(&sk, &o, None)
                .unwrap_err()
                .to_string()
                .contains("2..9")
        );
        o.strokes = Some((1, 2));
        assert!(
            wand_track(&sk, &o, None)
                .unwrap_err()
                .to_string()
                .contains("no stroke")
        );
        o.strokes = None;
        o.placement.up = DVec3::X;
        assert!(wand_track(&sk, &o, None).is_err());
    }

    #[test]
    fn unordered_and_missing_timestamps_still_give_a_monotone_track() {
        let mut sk = two_lines();
        sk.strokes[0].points[3].timestamp_ms = Some(0);
        for pt in &mut sk.strokes[2].points {
            pt.timestamp_ms = None;
        }
        let track = wand_track(&sk, &ImportOptions::default(), None).unwrap();
        assert!(track.samples.windows(2).all(|w| w[1].t > w[0].t));
        assert!(track.samples.iter().all(|s| s.position_m.is_finite()));
        assert!(track.strokes[1].start_s > track.strokes[0].end_s);
    }
}
