//! Progress of the long commands (`mesh`, `export`, `reconstruct`, `volume fit`).
//!
//! On a terminal, an indicatif bar on stderr. Otherwise (a pipe, a log file, CI) one line
//! at a time on stderr, at most one every [`LINE_INTERVAL`] (the environment variable
//! `SCULPT_TOOLS_PROGRESS_S` sets another interval in seconds, 0 for every step), each
//! naming the step, the count, the time so far and the memory in use. When the command
//! ends, one line states its time and peak memory, terminal or not:
//!
//! ```text
//! reconstruct: fitting patches (4/7), 182.4 s, 2210 MiB resident
//! reconstruct: done in 589.1 s, peak memory 3364 MiB
//! ```
//!
//! Memory is the process's resident set (`VmRSS`, peak `VmHWM` in `/proc/self/status`);
//! where that file does not exist the lines leave it out.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// The shortest time between two progress lines when stderr is not a terminal.
pub const LINE_INTERVAL: Duration = Duration::from_secs(5);

/// A command's progress: a bar on a terminal, timed lines otherwise.
pub struct Progress {
    label: &'static str,
    bar: Option<ProgressBar>,
    start: Instant,
    last_line: Option<Instant>,
    interval: Duration,
    len: u64,
    pos: u64,
    message: String,
}

/// A field of `/proc/self/status` in MiB (`VmRSS`, `VmHWM`); `None` off Linux.
fn status_mib(field: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

impl Progress {
    /// Starts the progress of command `label` over `len` steps (0 when unknown).
    pub fn new(label: &'static str, len: u64) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({elapsed})")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar
        });
        let interval = std::env::var("SCULPT_TOOLS_PROGRESS_S")
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s >= 0.0)
            .map_or(LINE_INTERVAL, Duration::from_secs_f64);
        Self {
            label,
            bar,
            start: Instant::now(),
            last_line: None,
            interval,
            len,
            pos: 0,
            message: String::new(),
        }
    }

    /// Sets the number of steps.
    pub fn set_length(&mut self, len: u64) {
        self.len = len;
        if let Some(bar) = &self.bar {
            bar.set_length(len);
        }
    }

    /// Names the current step.
    pub fn set_message(&mut self, message: &str) {
        message.clone_into(&mut self.message);
        if let Some(bar) = &self.bar {
            bar.set_message(message.to_owned());
        }
        self.line();
    }

    /// Moves to step `pos`.
    pub fn set_position(&mut self, pos: u64) {
        self.pos = pos;
        if let Some(bar) = &self.bar {
            bar.set_position(pos);
        }
        self.line();
    }

    /// Advances by `n` steps.
    pub fn inc(&mut self, n: u64) {
        self.set_position(self.pos + n);
    }

    /// Ends the progress: clears the bar and prints the time and peak memory.
    pub fn finish(self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
        let memory = status_mib("VmHWM:")
            .map(|m| format!(", peak memory {m:.0} MiB"))
            .unwrap_or_default();
        eprintln!(
            "{}: done in {:.1} s{memory}",
            self.label,
            self.start.elapsed().as_secs_f64()
        );
    }

    /// Prints a line when stderr is not a terminal and the interval has passed.
    fn line(&mut self) {
        if self.bar.is_some() {
            return;
        }
        let now = Instant::now();
        if self
            .last_line
            .is_some_and(|t| now.duration_since(t) < self.interval)
            || (self.last_line.is_none() && now.duration_since(self.start) < self.interval)
        {
            return;
        }
        self.last_line = Some(now);
        let count = if self.len > 0 {
            format!(" ({}/{})", self.pos, self.len)
        } else {
            String::new()
        };
        let memory = status_mib("VmRSS:")
            .map(|m| format!(", {m:.0} MiB resident"))
            .unwrap_or_default();
        eprintln!(
            "{}: {}{count}, {:.1} s{memory}",
            self.label,
            self.message,
            now.duration_since(self.start).as_secs_f64()
        );
    }
}
