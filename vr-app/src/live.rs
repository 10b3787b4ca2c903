//! Live tracking: the tracking crate's transports and hub on a small tokio runtime
//! owned here, plus the app's own playback sources (a pose-log file or the tracker
//! simulator, fed into the same hub in real time), and the per-frame stage.
//!
//! **Every** frame received goes, in arrival order, to the caller as a raw
//! [`Input`] ([`Input::Frame`], or [`Input::Buttons`] from a buttons-only source such
//! as a serial wand without a pose), and [`Input::Silence`] when nothing arrived; the
//! caller's [`Feeder`](crate::feeder::Feeder) runs them through the same pure
//! [`FrameStage`](tracking::stage::FrameStage) that `replay` runs. Nothing is sampled
//! "latest only", so a live session builds the same document as the offline replay of
//! its pose log, across a tracker restart or `ts` jumps too (the stage's order and
//! clock rules read the stream alone where frames carry `ts`). Frames without `ts` are
//! timed by their arrival, and a silence in arrival longer than the stage timeout is a
//! loss live only: there the two may differ (`docs/formats/tracking-config.md`).

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use glam::DVec3;
use sculpt_core::editor;
use tracking::hub::{FrameSubscription, Hub};
use tracking::poselog::PoseLog;
use tracking::sim::{Script, Simulator};
use tracking::{Frame, transport};

pub use crate::config::Playback;
use crate::config::TrackingSection;
use crate::error::{ConfigError, VrError, VrResult};
use crate::input::Input;

/// Playback's I/O: the frames of a pose-log file or of a simulator run.
impl Playback {
    /// The frames to play, with their times (from the start of playback, before the
    /// speed is applied).
    pub fn frames(&self) -> VrResult<Vec<Frame>> {
        match self {
            Playback::Poselog { path, .. } => {
                let log = PoseLog::read(path).map_err(|reason| VrError::Tracking {
                    what: path.display().to_string(),
                    reason: Box::new(reason),
                })?;
                let (frames, bad) = log.frames();
                if !log.corrupt.is_empty() || !bad.is_empty() {
                    tracing::warn!(
                        corrupt = log.corrupt.len(),
                        bad_frames = bad.len(),
                        "pose log {}: skipping unreadable records",
                        path.display()
                    );
                }
                Ok(frames)
            }
            Playback::Sim { script, config, .. } => {
                let script = match script {
                    Some(p) => {
                        let text = std::fs::read_to_string(p).map_err(|source| VrError::Io {
                            path: p.display().to_string(),
                            source,
                        })?;
                        toml::from_str(&text).map_err(|e| VrError::ConfigFile {
                            path: p.clone(),
                            reason: Box::new(VrError::Config(ConfigError::Toml(Box::new(e)))),
                        })?
                    }
                    None => builtin_script(),
                };
                let sim = Simulator::new(&script, config.clone()).map_err(|reason| {
                    VrError::Tracking {
                        what: "tracking.playback".into(),
                        reason: Box::new(reason),
                    }
                })?;
                Ok(sim.collect())
            }
        }
    }
}

/// The simulator's built-in script: hover, then carve a 30 cm stroke across the
/// default surface, release and hover.
pub fn builtin_script() -> Script {
    let from = editor::default_surface_point(-0.15, 1.2);
    let to = editor::default_surface_point(0.15, 1.18);
    Script::new(from)
        .head_start(DVec3::new(0.05, 1.17, 0.6))
        .hold(0.3)
        .press(0)
        .move_to(to, 1.0)
        .release(0)
        .hold(0.3)
}

/// A playback source running on its own thread.
#[derive(Debug)]
struct PlaybackThread {
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl PlaybackThread {
    fn start(playback: &Playback, hub: Hub) -> VrResult<Self> {
        playback.validate()?;
        let frames = playback.frames()?;
        let speed = playback.speed();
        let src = hub.add_source(playback.describe());
        let stop = Arc::new(AtomicBool::new(false));
        let stop_flag = stop.clone();
        let handle = std::thread::Builder::new()
            .name("wandsculpt-playback".into())
            .spawn(move || {
                hub.connection_opened(src);
                let start = Instant::now();
                let t0 = frames.first().map_or(Duration::ZERO, |f| f.receive_time);
                for mut frame in frames {
                    let due = frame.receive_time.saturating_sub(t0).div_f64(speed);
                    while let Some(wait) = due.checked_sub(start.elapsed()) {
                        if stop_flag.load(Ordering::Relaxed) {
                            return;
                        }
                        std::thread::sleep(wait.min(Duration::from_millis(50)));
                    }
                    frame.receive_time = hub.now();
                    hub.apply_frame(src, &frame);
                }
                hub.connection_closed(src, hub.now());
            })
            .map_err(|source| VrError::Spawn {
                what: "playback thread",
                source,
            })?;
        Ok(Self {
            stop,
            handle: Some(handle),
        })
    }
}

impl Drop for PlaybackThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// Running tracking input.
#[derive(Debug)]
pub struct LiveTracking {
    hub: Hub,
    running: transport::Running,
    playback: Option<PlaybackThread>,
    frames: FrameSubscription,
    wand_id: u32,
    /// Receive time of the last frame.
    last_receive: Option<Duration>,
    /// Sources that have sent a frame with the configured wand: only these can end a
    /// session by going away (a stray peer's frame and close cannot).
    served: std::collections::BTreeSet<tracking::hub::SourceId>,
    /// Sources fed from outside (the cluster's tracking feed), registered after the
    /// configured ones and the playback source.
    feeds: Vec<tracking::hub::SourceId>,
    /// Receive times of the frames the last poll handed to the stage.
    staged: Vec<Duration>,
    // Declared last so the transports are aborted before the runtime shuts down; held
    // only to keep the transports running.
    _runtime: tokio::runtime::Runtime,
}

impl LiveTracking {
    /// Starts every configured source (binding listeners now; connections are retried
    /// in the background) and the playback source, if any.
    pub fn start(section: &TrackingSection) -> VrResult<Self> {
        let wand_id = section.stage_config()?.wand_id;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .thread_name("wandsculpt-tracking")
            .build()
            .map_err(|source| VrError::Spawn {
                what: "tracking runtime",
                source,
            })?;
        let hub = Hub::new(&section.input);
        // Subscribe before any source starts, so no frame is missed. Every frame
        // received, not only those the hub keeps: the stage makes the order decision
        // from the frames' contents, exactly as `replay` does on the pose log (whose
        // records are every frame received), whatever the arrival timing.
        let frames = hub.subscribe_received();
        let running = runtime
            .block_on(transport::start_with_hub(hub.clone(), &section.input))
            .map_err(|reason| VrError::Tracking {
                what: "tracking".into(),
                reason: Box::new(reason),
            })?;
        for (src, addr) in section.input.sources.iter().zip(&running.local_addrs) {
            tracing::info!(source = %src.describe(), local = ?addr, "tracking source started");
        }
        let playback = section
            .playback
            .as_ref()
            .map(|p| {
                tracing::info!(source = %p.describe(), "playback source started");
                PlaybackThread::start(p, hub.clone())
            })
            .transpose()?;
        Ok(Self {
            hub,
            running,
            playback,
            frames,
            wand_id,
            last_receive: None,
            served: std::collections::BTreeSet::new(),
            feeds: Vec::new(),
            staged: Vec::new(),
            _runtime: runtime,
        })
    }

    /// Bound local addresses of listening sources, in config order.
    pub fn local_addrs(&self) -> &[Option<SocketAddr>] {
        &self.running.local_addrs
    }

    /// Receive time (hub clock) of the latest frame, if any arrived.
    pub fn last_report(&self) -> Option<Duration> {
        self.last_receive
    }

    /// The hub's clock.
    pub fn now(&self) -> Duration {
        self.hub.now()
    }

    /// Frames lost because this consumer fell behind the hub (should stay 0).
    pub fn dropped(&self) -> u64 {
        self.frames.dropped()
    }

    /// True once every source has served the session (sent a frame with the
    /// configured wand) and is now gone: a served session is over. A peer that sends a
    /// frame without the wand and closes (a stray local connection) does not end it;
    /// peers the transports refuse never reach here at all.
    pub fn sources_done(&self) -> bool {
        let mut ids = self.running.sources.clone();
        if self.playback.is_some() {
            // The playback source is registered after the configured ones.
            ids.push(tracking::hub::SourceId(ids.len()));
        }
        ids.extend(&self.feeds);
        self.last_receive.is_some()
            && ids.iter().all(|&s| {
                self.served.contains(&s)
                    && self
                        .hub
                        .source_stats(s)
                        .is_some_and(|st| st.connections > 0 && !st.connected)
            })
    }

    /// Registers a source fed from outside (frames applied to the returned hub by the
    /// caller, as the cluster's tracking feed does): it goes through the same stage,
    /// and counts for [`LiveTracking::sources_done`] like a configured source.
    pub fn add_feed(&mut self, name: &str) -> (Hub, tracking::hub::SourceId) {
        let id = self.hub.add_source(name);
        self.feeds.push(id);
        (self.hub.clone(), id)
    }

    /// The receive times (hub clock) of the frames with poses that the last
    /// [`LiveTracking::poll`] handed to the stage, in order.
    pub fn staged(&self) -> &[Duration] {
        &self.staged
    }

    /// Everything received since the last poll, in arrival order, as raw inputs for
    /// a [`Feeder`](crate::feeder::Feeder); [`Input::Silence`] at the hub's clock
    /// when nothing arrived.
    pub fn poll(&mut self) -> Vec<Input> {
        let mut out = Vec::new();
        self.staged.clear();
        while let Some(f) = self.frames.try_recv() {
            self.last_receive = Some(f.frame.receive_time);
            if f.frame.wand(self.wand_id).is_some() {
                self.served.insert(f.source);
            }
            if f.carries_pose {
                self.staged.push(f.frame.receive_time);
                out.push(Input::Frame(f.frame));
            } else {
                out.push(Input::Buttons(f.frame));
            }
        }
        if out.is_empty() {
            out.push(Input::Silence(self.hub.now()));
        }
        out
    }
}
