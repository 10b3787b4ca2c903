//! Live tracking: the tracking crate's transports and hub on a small tokio runtime
//! owned here, plus the app's own playback sources (a pose-log file or the tracker
//! simulator, fed into the same hub in real time), and the per-frame stage.
//!
//! **Every** frame received goes, in arrival order, through the same pure
//! [`FrameStage`] that `replay` runs (`tracking::stage`: order check, time from the
//! frame's DTrack `ts`, calibration with the tool tip, filter, loss and timeout), then
//! to the interaction as wand events stamped with the stage's time. Nothing is
//! sampled "latest only", so a live session builds the same document as the offline
//! replay of its pose log, across a tracker restart or `ts` jumps too (the stage's
//! order and clock rules read the stream alone where frames carry `ts`). Frames
//! without `ts` are timed by their arrival, and a silence in arrival longer than the
//! stage timeout is a loss live only: there the two may differ
//! (`docs/formats/tracking-config.md`).
//!
//! When no frame arrives for longer than the stage timeout, [`FrameStage::idle`]
//! reports the wand lost; a stroke paused by that loss ends `pause_timeout` later
//! (an [`Input::Tick`]). Buttons of a buttons-only source (a serial wand without a
//! pose) are merged into the wand's next samples.

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
use tracking::stage::{FrameStage, StageEvent};
use tracking::{Frame, transport};

pub use crate::config::Playback;
use crate::config::TrackingSection;
use crate::error::{ConfigError, VrError, VrResult};
use crate::input::{Input, TrackingState};
use crate::projection::HeadPose;

/// How long past a paused gesture's timeout the live clock must be before it is
/// ended with a tick (keeps ticks safely behind the next frame's time).
const TICK_MARGIN_S: f64 = 0.25;

/// The inputs for frame-stage events: wand samples (the stage's own conversion,
/// [`tracking::stage::WandSample::wand_event`], which `replay` makes too, with
/// `extra_buttons` of a buttons-only source merged in) and tracked head poses.
pub fn stage_inputs(events: &[StageEvent], extra_buttons: u64, out: &mut Vec<Input>) {
    for ev in events {
        match ev {
            StageEvent::Wand(w) => out.push(Input::Wand(w.wand_event(extra_buttons))),
            StageEvent::Head(h) => out.push(Input::Head(Some(HeadPose {
                position: h.pose.position_m,
                orientation: h.pose.orientation,
            }))),
        }
    }
}

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
    stage: FrameStage,
    wand_id: u32,
    pause_timeout: f64,
    /// Buttons reported by a buttons-only source.
    extra_buttons: u64,
    /// Receive time of the last frame.
    last_receive: Option<Duration>,
    /// Sources that have sent a frame with the configured wand: only these can end a
    /// session by going away (a stray peer's frame and close cannot).
    served: std::collections::BTreeSet<tracking::hub::SourceId>,
    /// Time of the lost sample the idle check emitted, until a tick ended the pause.
    idle_lost_at: Option<f64>,
    state: Option<TrackingState>,
    events: Vec<StageEvent>,
    /// Sources fed from outside (the cluster's tracking feed), registered after the
    /// configured ones and the playback source.
    feeds: Vec<tracking::hub::SourceId>,
    /// Receive times of the frames the last poll handed to the stage.
    staged: Vec<Duration>,
    // Declared last so the transports are aborted before the runtime shuts down.
    runtime: tokio::runtime::Runtime,
}

impl LiveTracking {
    /// Starts every configured source (binding listeners now; connections are retried
    /// in the background) and the playback source, if any. `pause_timeout` is the
    /// interaction's (a stroke paused by silence ends that long after the loss).
    pub fn start(section: &TrackingSection, pause_timeout: f64) -> VrResult<Self> {
        let stage_config = section.stage_config()?;
        let wand_id = stage_config.wand_id;
        let stage = FrameStage::new(stage_config).map_err(|reason| VrError::Tracking {
            what: "tracking".into(),
            reason: Box::new(reason),
        })?;
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
            stage,
            wand_id,
            pause_timeout,
            extra_buttons: 0,
            last_receive: None,
            served: std::collections::BTreeSet::new(),
            idle_lost_at: None,
            state: None,
            events: Vec::new(),
            feeds: Vec::new(),
            staged: Vec::new(),
            runtime,
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

    /// Everything new since the last poll, in order.
    pub fn poll(&mut self) -> Vec<Input> {
        let _guard = self.runtime.enter();
        let mut out = Vec::new();
        let mut events = std::mem::take(&mut self.events);
        events.clear();
        let mut got = false;
        self.staged.clear();
        while let Some(f) = self.frames.try_recv() {
            got = true;
            self.last_receive = Some(f.frame.receive_time);
            if f.frame.wand(self.wand_id).is_some() {
                self.served.insert(f.source);
            }
            if !f.carries_pose {
                if let Some(w) = f.frame.wand(self.wand_id) {
                    self.extra_buttons = w.buttons;
                }
                continue;
            }
            self.staged.push(f.frame.receive_time);
            self.stage.push(&f.frame, &mut events);
        }
        if got {
            self.idle_lost_at = None;
        } else if self.stage.idle(self.hub.now(), &mut events) {
            self.idle_lost_at = events.iter().rev().find_map(|e| e.wand().map(|w| w.t));
        }
        stage_inputs(&events, self.extra_buttons, &mut out);
        self.events = events;
        // Silence past a loss: end a paused stroke once its timeout is well behind
        // the live clock.
        if let (Some(lost_t), Some(stage_t), Some(last)) =
            (self.idle_lost_at, self.stage.time(), self.last_receive)
        {
            let end = lost_t + self.pause_timeout + sculpt_core::tolerance::TIME_EPS;
            let now = stage_t + self.hub.now().saturating_sub(last).as_secs_f64();
            if now > end + TICK_MARGIN_S {
                out.push(Input::Tick(end));
                self.idle_lost_at = None;
            }
        }
        let state = if self.stage.wand_tracked() {
            TrackingState::Ok
        } else {
            TrackingState::Lost
        };
        if self.state != Some(state) {
            self.state = Some(state);
            out.push(Input::Tracking(state));
        }
        out
    }
}
