//! CPU time per XR frame, by phase: how long `xrWaitFrame` blocked (the runtime's
//! pacing), `xrBeginFrame`, the frame's own work (views, controllers, both eyes
//! encoded and submitted, the depth pass) and `xrEndFrame`; with the median and 99th
//! percentile of each over the rendered frames, reported when the session ends (as
//! the headless run reports its frame time).
//!
//! ```
//! use std::time::Duration;
//! use vr_app::xr::timing::{FramePhases, FrameTimer};
//! let mut timer = FrameTimer::default();
//! for ms in 1..=100 {
//!     let d = Duration::from_millis(ms);
//!     timer.push(FramePhases { wait: d, begin: d, render: d, image_wait: Duration::ZERO, end: d });
//! }
//! let t = timer.summary();
//! assert_eq!(t.frames, 100);
//! assert_eq!(t.render.p99_us, 99_000.0);
//! ```

use std::time::Duration;

use sculpt_core::percentile;
use serde::Serialize;

/// One rendered frame's phases (CPU wall time on the frame loop's thread).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FramePhases {
    /// `xrWaitFrame`: blocked until the runtime wants the next frame.
    pub wait: Duration,
    /// `xrBeginFrame`.
    pub begin: Duration,
    /// From `xrBeginFrame`'s return to `xrEndFrame`'s call, less `image_wait`:
    /// views, controllers into the session, both eyes (and their depth) encoded and
    /// submitted, images acquired and released.
    pub render: Duration,
    /// `xrWaitSwapchainImage`: blocked until the compositor let go of the images.
    pub image_wait: Duration,
    /// `xrEndFrame`.
    pub end: Duration,
}

impl FramePhases {
    /// The frame's own CPU time: begin, render and end (no waiting).
    pub fn cpu(&self) -> Duration {
        self.begin + self.render + self.end
    }
}

/// Median and 99th percentile of one phase, microseconds, by the workspace's one
/// percentile rule ([`sculpt_core::percentile`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct PhaseStats {
    /// The median (the upper middle of an even count, as the headless report).
    pub median_us: f64,
    /// The 99th percentile.
    pub p99_us: f64,
    /// The largest.
    pub max_us: f64,
}

impl PhaseStats {
    /// The statistics of `samples` (any order); zeros when there are none.
    pub fn of(mut samples: Vec<Duration>) -> Self {
        samples.sort();
        let us = |d: Option<Duration>| d.map_or(0.0, |d| d.as_secs_f64() * 1e6);
        Self {
            median_us: us(percentile::median(&samples)),
            p99_us: us(percentile::p99(&samples)),
            max_us: us(samples.last().copied()),
        }
    }
}

/// The frame timing of a headset session ([`FrameTimer::summary`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct XrFrameTiming {
    /// Rendered frames measured.
    pub frames: usize,
    /// `xrWaitFrame`.
    pub wait: PhaseStats,
    /// `xrBeginFrame`.
    pub begin: PhaseStats,
    /// The frame's work between begin and end (see [`FramePhases::render`]).
    pub render: PhaseStats,
    /// `xrWaitSwapchainImage`.
    pub image_wait: PhaseStats,
    /// `xrEndFrame`.
    pub end: PhaseStats,
    /// Begin + render + end per frame: the CPU time the frame costs.
    pub cpu: PhaseStats,
}

/// Collects [`FramePhases`] of the rendered frames.
#[derive(Debug, Clone, Default)]
pub struct FrameTimer {
    frames: Vec<FramePhases>,
}

impl FrameTimer {
    /// Records one rendered frame.
    pub fn push(&mut self, phases: FramePhases) {
        self.frames.push(phases);
    }

    /// Frames recorded.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame was recorded.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Median, 99th percentile and maximum of each phase.
    pub fn summary(&self) -> XrFrameTiming {
        let of =
            |f: fn(&FramePhases) -> Duration| PhaseStats::of(self.frames.iter().map(f).collect());
        XrFrameTiming {
            frames: self.frames.len(),
            wait: of(|p| p.wait),
            begin: of(|p| p.begin),
            render: of(|p| p.render),
            image_wait: of(|p| p.image_wait),
            end: of(|p| p.end),
            cpu: of(FramePhases::cpu),
        }
    }
}

impl std::fmt::Display for XrFrameTiming {
    /// One line per phase: median, p99 and max in milliseconds.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "XR frame CPU time over {} rendered frames (ms): median / p99 / max",
            self.frames
        )?;
        for (name, s) in [
            ("wait", &self.wait),
            ("begin", &self.begin),
            ("render", &self.render),
            ("image wait", &self.image_wait),
            ("end", &self.end),
            ("cpu (begin+render+end)", &self.cpu),
        ] {
            writeln!(
                f,
                "  {name:<24} {:>8.3} {:>8.3} {:>8.3}",
                s.median_us / 1e3,
                s.p99_us / 1e3,
                s.max_us / 1e3
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_p99_use_the_nearest_rank() {
        let us = |v: &[u64]| v.iter().map(|&u| Duration::from_micros(u)).collect();
        // 200 samples 1..=200 us, shuffled: p99 is the 198th, the median the 101st.
        let mut v: Vec<u64> = (1..=200).collect();
        v.reverse();
        v.swap(3, 150);
        let s = PhaseStats::of(us(&v));
        assert_eq!(s.median_us, 101.0);
        assert_eq!(s.p99_us, 198.0);
        assert_eq!(s.max_us, 200.0);
        // One sample is its own median and p99; none gives zeros.
        let one = PhaseStats::of(us(&[7]));
        assert_eq!((one.median_us, one.p99_us, one.max_us), (7.0, 7.0, 7.0));
        assert_eq!(PhaseStats::of(Vec::new()), PhaseStats::default());
        // A single slow frame in a hundred is the p99, not hidden by the median.
        let mut v = vec![1000; 99];
        v.push(50_000);
        let s = PhaseStats::of(us(&v));
        assert_eq!(
            (s.median_us, s.p99_us, s.max_us),
            (1000.0, 1000.0, 50_000.0)
        );
        v.push(60_000);
        let s = PhaseStats::of(us(&v));
        assert_eq!(s.p99_us, 50_000.0);
    }

    #[test]
    fn the_summary_splits_phases_and_sums_the_cpu_time() {
        let ms = Duration::from_millis;
        let mut timer = FrameTimer::default();
        assert!(timer.is_empty());
        for i in 0..10 {
            timer.push(FramePhases {
                wait: ms(11),
                begin: ms(1),
                render: ms(5 + i),
                image_wait: ms(2),
                end: ms(1),
            });
        }
        let t = timer.summary();
        assert_eq!(t.frames, 10);
        assert_eq!(t.wait.median_us, 11_000.0);
        assert_eq!(t.render.median_us, 10_000.0);
        assert_eq!(t.render.max_us, 14_000.0);
        assert_eq!(t.image_wait.p99_us, 2_000.0);
        // cpu = begin + render + end, no waits.
        assert_eq!(t.cpu.median_us, 12_000.0);
        assert_eq!(t.cpu.max_us, 16_000.0);
        let text = t.to_string();
        assert!(text.contains("10 rendered frames"), "{text}");
        assert!(text.contains("cpu (begin+render+end)"), "{text}");
    }
}
