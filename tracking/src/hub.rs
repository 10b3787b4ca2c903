//! The merge layer: every source's frames become the latest state per device.
//!
//! A [`Hub`] keeps, per device, a tokio `watch` channel of [`DeviceState`] (the latest
//! calibrated, filtered pose with its [`TrackingStatus`]), one ordered `broadcast`
//! channel of [`TrackingEvent`]s (button edges and status changes), and a frame
//! subscription ([`Hub::subscribe_frames`]): every accepted raw frame, with its
//! source, in acceptance order, for consumers that must see every frame; and
//! [`Hub::subscribe_received`]: every frame received, dropped or not, in arrival
//! order, which is what a pose log records (the display server feeds these to the same
//! per-frame stage as `replay`, which makes its own order decision from the frames'
//! contents, so a live session equals the replay of its log whatever the arrival
//! timing). It is driven by
//! the transports (or directly, by replay) with frames stamped with their receive time,
//! and is itself clock-free: staleness is checked against a time you pass in, so
//! replaying a log is deterministic.
//!
//! Rules:
//! * a tracked pose (quality ≥ 0, a valid rotation) is calibrated, filtered and
//!   published with status `Tracking`;
//! * a wand with quality < 0, a body missing from a frame of the source that reported
//!   it, or a device whose last tracked pose is older than `lost_after` becomes `Lost`:
//!   its pose freezes where it was (motion is never invented) and the filter restarts
//!   when tracking resumes;
//! * when the source a device came from disconnects, the device is `Disconnected`;
//! * frames older than the newest one accepted from the same source (by frame counter)
//!   are dropped as out of order, unless the source was quiet for a second or more
//!   (a restarted tracker counts from 1 again);
//! * button edges of every wand go, in order, to the event channel, whether or not its
//!   pose is tracked.
//!
//! ```
//! use tracking::hub::{Hub, TrackingStatus};
//! use tracking::config::TrackingConfig;
//! use tracking::{DeviceId, Frame, Pose, Wand};
//! use glam::DVec3;
//! let hub = Hub::new(&TrackingConfig::default());
//! let src = hub.add_source("test");
//! let wand = hub.watch(DeviceId::Wand(0));
//! let mut f = Frame::new(1);
//! f.wands.push(Wand::tracked(0, Pose::from_position_mm(DVec3::new(0.0, 1000.0, 0.0))));
//! hub.apply_frame(src, &f);
//! let state = wand.borrow().clone();
//! assert_eq!(state.status, TrackingStatus::Tracking);
//! assert!((state.pose.unwrap().position_m.y - 1.0).abs() < 1e-12);
//! ```

use crate::calibration::{Calibration, DisplayPose};
use crate::config::TrackingConfig;
use crate::filter::{FilterConfig, PoseFilter};
use crate::frame::{DeviceId, Frame, Pose};
use crate::poselog::{PoseLogWriter, RecordKind};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::BufWriter;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::{broadcast, watch};

/// Capacity of the event channel (a receiver that falls further behind gets
/// `RecvError::Lagged` with the count it missed).
pub const EVENT_CAPACITY: usize = 4096;
/// Capacity of the frame subscription: a subscriber that falls further behind loses
/// the oldest frames and counts them ([`FrameSubscription::dropped`]). 16384 frames are
/// over 4 minutes at 60 Hz.
pub const FRAME_CAPACITY: usize = 16_384;
pub use crate::frame::{COUNTER_RESET_AFTER, REORDER_WINDOW};

/// Whether a device's pose can be trusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum TrackingStatus {
    /// Fresh, tracked pose.
    Tracking,
    /// Seen recently but not tracked (occluded, quality < 0, or stale): pose frozen.
    Lost,
    /// Its source is gone (or it was never seen).
    Disconnected,
}

/// The latest state of one device.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeviceState {
    /// Which device.
    pub device: DeviceId,
    /// Tracking status.
    pub status: TrackingStatus,
    /// The filtered pose in the display frame (frozen while not `Tracking`; `None`
    /// until the first tracked pose).
    pub pose: Option<DisplayPose>,
    /// The last tracked raw pose in tracker units.
    pub raw: Option<Pose>,
    /// Quality of the latest report.
    pub quality: f64,
    /// Button mask (wands).
    pub buttons: u64,
    /// Number of buttons (wands).
    pub button_count: u8,
    /// Analog axes (wands).
    pub analog: Vec<f64>,
    /// Frame counter of the latest report.
    pub frame: u64,
    /// Tracker timestamp of the latest report.
    pub tracker_time: Option<f64>,
    /// Receive time of the latest report.
    pub last_seen: Duration,
    /// Receive time of the latest tracked pose.
    pub last_tracked: Duration,
    /// The source of the latest report.
    pub source: SourceId,
}

impl DeviceState {
    fn unseen(device: DeviceId) -> Self {
        Self {
            device,
            status: TrackingStatus::Disconnected,
            pose: None,
            raw: None,
            quality: -1.0,
            buttons: 0,
            button_count: 0,
            analog: Vec::new(),
            frame: 0,
            tracker_time: None,
            last_seen: Duration::ZERO,
            last_tracked: Duration::ZERO,
            source: SourceId(usize::MAX),
        }
    }
}

/// An ordered tracking event.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum TrackingEvent {
    /// A button went down or up.
    Button {
        /// The wand.
        device: DeviceId,
        /// Button index.
        button: u8,
        /// Down (true) or up.
        pressed: bool,
        /// Receive time of the frame that showed it.
        time: Duration,
        /// That frame's counter.
        frame: u64,
    },
    /// A device's status changed.
    Status {
        /// The device.
        device: DeviceId,
        /// The new status.
        status: TrackingStatus,
        /// When (receive time, or the time passed to [`Hub::check_stale`]).
        time: Duration,
    },
}

/// A frame the hub accepted, with where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct SourcedFrame {
    /// The source it came from.
    pub source: SourceId,
    /// The raw frame (tracker units, stamped with its receive time).
    pub frame: Frame,
    /// False for a buttons-only source (its wands carry no pose).
    pub carries_pose: bool,
}

/// A bounded, in-order subscription to every frame the hub accepts (see
/// [`Hub::subscribe_frames`]). Nothing is lost unless the subscriber falls more than
/// [`FRAME_CAPACITY`] frames behind; then the oldest are skipped and counted.
#[derive(Debug)]
pub struct FrameSubscription {
    rx: broadcast::Receiver<SourcedFrame>,
    dropped: u64,
}

impl FrameSubscription {
    /// The next frame if one is waiting (never blocks).
    pub fn try_recv(&mut self) -> Option<SourcedFrame> {
        loop {
            match self.rx.try_recv() {
                Ok(f) => return Some(f),
                Err(broadcast::error::TryRecvError::Lagged(n)) => self.lag(n),
                Err(_) => return None,
            }
        }
    }

    /// Waits for the next frame; `None` once the hub is gone and everything was read.
    pub async fn recv(&mut self) -> Option<SourcedFrame> {
        loop {
            match self.rx.recv().await {
                Ok(f) => return Some(f),
                Err(broadcast::error::RecvError::Lagged(n)) => self.lag(n),
                Err(broadcast::error::RecvError::Closed) => return None,
            }
        }
    }

    fn lag(&mut self, n: u64) {
        tracing::warn!(missed = n, "frame subscriber fell behind; frames dropped");
        self.dropped += n;
    }

    /// Frames skipped because this subscriber fell behind.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// Identifies a source registered with a hub.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct SourceId(pub usize);

/// Per-source counters.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct SourceStats {
    /// The source's name.
    pub name: String,
    /// Whether it is connected now.
    pub connected: bool,
    /// Frames applied.
    pub frames: u64,
    /// Frames dropped as out of order (or duplicates).
    pub out_of_order: u64,
    /// Frames dropped as malformed or over a cap.
    pub bad_frames: u64,
    /// Connections made (TCP) or port openings (serial).
    pub connections: u64,
    /// Peers refused (a connection or datagram from outside the allow-list, or while
    /// the source already had its peer); nothing they sent was read.
    pub refused: u64,
}

#[derive(Debug)]
struct Source {
    stats: SourceStats,
    last_frame: Option<u64>,
    last_accept: Duration,
    bodies: BTreeSet<u32>,
    active: usize,
}

#[derive(Debug)]
struct Device {
    state: DeviceState,
    tx: watch::Sender<DeviceState>,
    filter: PoseFilter,
}

#[derive(Debug)]
struct Merge {
    devices: BTreeMap<DeviceId, Device>,
    sources: Vec<Source>,
    recorder: Option<PoseLogWriter<BufWriter<File>>>,
}

#[derive(Debug)]
struct Inner {
    epoch: Instant,
    lost_after: Duration,
    filter: FilterConfig,
    calibration: Calibration,
    merge: Mutex<Merge>,
    events: broadcast::Sender<TrackingEvent>,
    frames: broadcast::Sender<SourcedFrame>,
    received: broadcast::Sender<SourcedFrame>,
}

/// The merged tracking state; cheap to clone (shared).
#[derive(Debug, Clone)]
pub struct Hub {
    inner: Arc<Inner>,
}

enum PoseReport {
    Tracked(Pose),
    Untracked,
    NotCarried,
}

impl Hub {
    /// A hub with the config's filter, calibration and `lost_after`.
    pub fn new(config: &TrackingConfig) -> Self {
        let (events, _) = broadcast::channel(EVENT_CAPACITY);
        let (frames, _) = broadcast::channel(FRAME_CAPACITY);
        let (received, _) = broadcast::channel(FRAME_CAPACITY);
        Self {
            inner: Arc::new(Inner {
                epoch: Instant::now(),
                lost_after: config.lost_after(),
                filter: config.filter,
                calibration: config.calibration.clone(),
                merge: Mutex::new(Merge {
                    devices: BTreeMap::new(),
                    sources: Vec::new(),
                    recorder: None,
                }),
                events,
                frames,
                received,
            }),
        }
    }

    fn lock(&self) -> MutexGuard<'_, Merge> {
        // A panic elsewhere while holding the lock leaves consistent-enough state.
        self.inner.merge.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The hub's monotonic clock: time since it was created (used as receive time).
    pub fn now(&self) -> Duration {
        self.inner.epoch.elapsed()
    }

    /// The calibration in force.
    pub fn calibration(&self) -> &Calibration {
        &self.inner.calibration
    }

    /// Registers a source and returns its id.
    pub fn add_source(&self, name: impl Into<String>) -> SourceId {
        let mut m = self.lock();
        m.sources.push(Source {
            stats: SourceStats {
                name: name.into(),
                ..SourceStats::default()
            },
            last_frame: None,
            last_accept: Duration::ZERO,
            bodies: BTreeSet::new(),
            active: 0,
        });
        SourceId(m.sources.len() - 1)
    }

    /// Records every raw frame from now on to `writer` (its header should already hold
    /// the config). Write errors stop the recording and are logged.
    pub fn set_recorder(&self, writer: PoseLogWriter<BufWriter<File>>) {
        self.lock().recorder = Some(writer);
    }

    /// Whether a recorder is attached (transports then keep raw bytes).
    pub fn is_recording(&self) -> bool {
        self.lock().recorder.is_some()
    }

    /// Appends a raw record to the recording, if any.
    pub fn record(&self, kind: RecordKind, time: Duration, bytes: &[u8]) {
        let mut m = self.lock();
        if let Some(w) = m.recorder.as_mut()
            && let Err(e) = w.write(kind, time, bytes)
        {
            tracing::error!(
                "pose log recording stopped: {}",
                sculpt_core::error::Chain(&e)
            );
            m.recorder = None;
        }
    }

    /// A receiver of `device`'s latest state (created `Disconnected` if unseen).
    pub fn watch(&self, device: DeviceId) -> watch::Receiver<DeviceState> {
        let mut m = self.lock();
        self.device(&mut m, device).tx.subscribe()
    }

    /// A receiver of the ordered event stream (events from now on).
    pub fn subscribe(&self) -> broadcast::Receiver<TrackingEvent> {
        self.inner.events.subscribe()
    }

    /// A subscription to every frame accepted from now on (frames dropped as out of
    /// order are not sent), with its source, in the order the hub applied them.
    pub fn subscribe_frames(&self) -> FrameSubscription {
        FrameSubscription {
            rx: self.inner.frames.subscribe(),
            dropped: 0,
        }
    }

    /// A subscription to every frame received from now on, whether the hub keeps it or
    /// drops it as out of order, in arrival order: the frames a pose log records. The
    /// display server's [`FrameStage`](crate::stage::FrameStage) reads these and
    /// decides the order itself, as `replay` does on the log.
    pub fn subscribe_received(&self) -> FrameSubscription {
        FrameSubscription {
            rx: self.inner.received.subscribe(),
            dropped: 0,
        }
    }

    /// Every known device's latest state.
    pub fn snapshot(&self) -> Vec<DeviceState> {
        self.lock()
            .devices
            .values()
            .map(|d| d.state.clone())
            .collect()
    }

    /// One source's counters.
    pub fn source_stats(&self, source: SourceId) -> Option<SourceStats> {
        self.lock().sources.get(source.0).map(|s| s.stats.clone())
    }

    fn device<'a>(&self, m: &'a mut Merge, device: DeviceId) -> &'a mut Device {
        m.devices.entry(device).or_insert_with(|| {
            let state = DeviceState::unseen(device);
            let (tx, _) = watch::channel(state.clone());
            Device {
                state,
                tx,
                filter: PoseFilter::new(self.inner.filter),
            }
        })
    }

    fn event(&self, e: TrackingEvent) {
        // No receivers is fine.
        let _ = self.inner.events.send(e);
    }

    /// Counts a refused peer against a source; returns the count so far.
    pub fn refused(&self, source: SourceId) -> u64 {
        self.lock().sources.get_mut(source.0).map_or(0, |s| {
            s.stats.refused += 1;
            s.stats.refused
        })
    }

    /// Counts a dropped malformed frame against a source.
    pub fn bad_frame(&self, source: SourceId) {
        if let Some(s) = self.lock().sources.get_mut(source.0) {
            s.stats.bad_frames += 1;
        }
    }

    /// Marks a connectionless source (UDP) as receiving or gone quiet; when gone, its
    /// devices become `Disconnected`.
    pub fn set_connected(&self, source: SourceId, connected: bool, time: Duration) {
        let active = self.lock().sources.get(source.0).map_or(0, |s| s.active);
        if connected && active == 0 {
            self.connection_opened(source);
        } else if !connected && active > 0 {
            self.close_all(source, time);
        }
    }

    /// A stream connection of `source` opened (several may be open at once).
    pub fn connection_opened(&self, source: SourceId) {
        let mut m = self.lock();
        if let Some(s) = m.sources.get_mut(source.0) {
            s.active += 1;
            s.stats.connected = true;
            s.stats.connections += 1;
            s.last_frame = None;
        }
    }

    /// A stream connection of `source` closed; when none is left, its devices become
    /// `Disconnected`.
    pub fn connection_closed(&self, source: SourceId, time: Duration) {
        let last = {
            let mut m = self.lock();
            m.sources.get_mut(source.0).is_some_and(|s| {
                s.active = s.active.saturating_sub(1);
                s.active == 0
            })
        };
        if last {
            self.close_all(source, time);
        }
    }

    fn close_all(&self, source: SourceId, time: Duration) {
        let mut m = self.lock();
        let Some(s) = m.sources.get_mut(source.0) else {
            return;
        };
        s.active = 0;
        s.stats.connected = false;
        s.bodies.clear();
        for d in m.devices.values_mut() {
            if d.state.source == source && d.state.status != TrackingStatus::Disconnected {
                d.state.status = TrackingStatus::Disconnected;
                d.tx.send_replace(d.state.clone());
                self.event(TrackingEvent::Status {
                    device: d.state.device,
                    status: TrackingStatus::Disconnected,
                    time,
                });
            }
        }
    }

    /// Marks devices whose last tracked pose is older than `lost_after` as `Lost`.
    /// Call it periodically with [`now`](Self::now) (the transports do), or with log
    /// time when replaying.
    pub fn check_stale(&self, now: Duration) {
        let lost_after = self.inner.lost_after;
        let mut m = self.lock();
        for d in m.devices.values_mut() {
            if d.state.status == TrackingStatus::Tracking
                && now.saturating_sub(d.state.last_tracked) > lost_after
            {
                d.state.status = TrackingStatus::Lost;
                d.tx.send_replace(d.state.clone());
                self.event(TrackingEvent::Status {
                    device: d.state.device,
                    status: TrackingStatus::Lost,
                    time: now,
                });
            }
        }
    }

    /// Applies one DTrack frame (stamped with its receive time) from `source`.
    /// Returns false when it was dropped as out of order.
    pub fn apply_frame(&self, source: SourceId, frame: &Frame) -> bool {
        self.apply(source, frame, true)
    }

    /// Applies a frame from a source that may not carry poses (a buttons-only serial
    /// wand: `carries_pose = false` updates buttons and analog axes only).
    pub fn apply(&self, source: SourceId, frame: &Frame, carries_pose: bool) -> bool {
        let time = frame.receive_time;
        let mut m = self.lock();
        let Some(src) = m.sources.get_mut(source.0) else {
            return false;
        };
        // Sent under the merge lock, so subscribers see frames in arrival order.
        if self.inner.received.receiver_count() > 0 {
            let _ = self.inner.received.send(SourcedFrame {
                source,
                frame: frame.clone(),
                carries_pose,
            });
        }
        if let Some(last) = src.last_frame {
            let quiet = time.saturating_sub(src.last_accept) >= COUNTER_RESET_AFTER;
            if frame.number <= last && last - frame.number < REORDER_WINDOW && !quiet {
                src.stats.out_of_order += 1;
                return false;
            }
        }
        src.last_frame = Some(frame.number);
        src.last_accept = time;
        // Sent under the merge lock, so subscribers see frames in acceptance order.
        if self.inner.frames.receiver_count() > 0 {
            let _ = self.inner.frames.send(SourcedFrame {
                source,
                frame: frame.clone(),
                carries_pose,
            });
        }
        src.stats.frames += 1;
        if src.active == 0 {
            src.active = 1;
            src.stats.connected = true;
            src.stats.connections += 1;
        }
        // Bodies this source reported before but not now are untracked.
        let now_bodies: BTreeSet<u32> = frame.bodies.iter().map(|b| b.id).collect();
        let gone: Vec<u32> = src.bodies.difference(&now_bodies).copied().collect();
        src.bodies = now_bodies;
        for b in &frame.bodies {
            self.update(
                &mut m,
                source,
                frame,
                DeviceId::Body(b.id),
                b.quality,
                if b.quality >= 0.0 {
                    PoseReport::Tracked(b.pose)
                } else {
                    PoseReport::Untracked
                },
                None,
            );
        }
        for id in gone {
            self.update(
                &mut m,
                source,
                frame,
                DeviceId::Body(id),
                -1.0,
                PoseReport::Untracked,
                None,
            );
        }
        for w in &frame.wands {
            let report = if !carries_pose {
                PoseReport::NotCarried
            } else if w.quality >= 0.0 {
                PoseReport::Tracked(w.pose)
            } else {
                PoseReport::Untracked
            };
            self.update(
                &mut m,
                source,
                frame,
                DeviceId::Wand(w.id),
                w.quality,
                report,
                Some(w),
            );
        }
        true
    }

    #[allow(clippy::too_many_arguments)]
    fn update(
        &self,
        m: &mut Merge,
        source: SourceId,
        frame: &Frame,
        device: DeviceId,
        quality: f64,
        report: PoseReport,
        wand: Option<&crate::frame::Wand>,
    ) {
        let time = frame.receive_time;
        let calibration = &self.inner.calibration;
        let d = self.device(m, device);
        let before = d.state.status;
        d.state.last_seen = time;
        d.state.frame = frame.number;
        d.state.tracker_time = frame.tracker_time;
        if let Some(w) = wand {
            let changed = d.state.buttons ^ w.buttons;
            for b in 0..64u8 {
                if changed & (1u64 << b) != 0 {
                    self.event(TrackingEvent::Button {
                        device,
                        button: b,
                        pressed: w.buttons & (1u64 << b) != 0,
                        time,
                        frame: frame.number,
                    });
                }
            }
            d.state.buttons = w.buttons;
            d.state.button_count = w.button_count;
            d.state.analog.clone_from(&w.analog);
        }
        match report {
            PoseReport::Tracked(pose) => match calibration.pose_in_display(device, &pose) {
                Some(in_display) => {
                    if before != TrackingStatus::Tracking {
                        d.filter.reset();
                    }
                    d.state.pose = Some(d.filter.filter(time.as_secs_f64(), in_display));
                    d.state.raw = Some(pose);
                    d.state.quality = quality;
                    d.state.status = TrackingStatus::Tracking;
                    d.state.last_tracked = time;
                    d.state.source = source;
                }
                None => {
                    d.state.quality = -1.0;
                    d.state.status = TrackingStatus::Lost;
                    d.state.source = source;
                }
            },
            PoseReport::Untracked => {
                d.state.quality = quality;
                d.state.status = TrackingStatus::Lost;
                d.state.source = source;
            }
            PoseReport::NotCarried => {
                if before == TrackingStatus::Disconnected {
                    d.state.status = TrackingStatus::Lost;
                    d.state.source = source;
                }
            }
        }
        let after = d.state.status;
        d.tx.send_replace(d.state.clone());
        if after != before {
            self.event(TrackingEvent::Status {
                device,
                status: after,
                time,
            });
        }
    }
}
