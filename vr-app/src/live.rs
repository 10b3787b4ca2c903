//! Live tracking: the tracking crate's transports and hub, running on a small tokio
//! runtime owned here, polled once a frame into wand events and head poses.
//!
//! Button edges come from the hub's ordered event channel, so a press and release
//! between two frames is not lost; poses come from the per-device watch state (the
//! latest filtered pose in the display frame).

use std::net::SocketAddr;
use std::time::Duration;

use sculpt_core::interaction::{WandEvent, WandSample};
use tokio::sync::{broadcast, watch};
use tracking::hub::{DeviceState, TrackingEvent, TrackingStatus};
use tracking::{DeviceId, transport};

use crate::app::TrackingState;
use crate::config::TrackingSection;
use crate::error::{VrError, VrResult};
use crate::headless::Input;
use crate::projection::HeadPose;

/// Running tracking input.
#[derive(Debug)]
pub struct LiveTracking {
    running: transport::Running,
    wand: DeviceId,
    wand_rx: watch::Receiver<DeviceState>,
    head_rx: Option<watch::Receiver<DeviceState>>,
    events: broadcast::Receiver<TrackingEvent>,
    buttons: u32,
    last_frame: Option<(u64, Duration)>,
    last_head_frame: Option<u64>,
    state: Option<TrackingState>,
    // Declared last so the transports are aborted before the runtime shuts down.
    runtime: tokio::runtime::Runtime,
}

impl LiveTracking {
    /// Starts every configured source (binding listeners now; connections are retried
    /// in the background).
    pub fn start(section: &TrackingSection) -> VrResult<Self> {
        let wand = section.wand_id()?;
        let head = section.head_id()?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .thread_name("wandsculpt-tracking")
            .build()
            .map_err(|e| VrError::Config(format!("tracking runtime: {e}")))?;
        let running = runtime
            .block_on(transport::start(&section.input))
            .map_err(|e| VrError::Config(format!("tracking: {e}")))?;
        let wand_rx = running.hub.watch(wand);
        let head_rx = head.map(|h| running.hub.watch(h));
        let events = running.hub.subscribe();
        for (src, addr) in section.input.sources.iter().zip(&running.local_addrs) {
            tracing::info!(source = %src.describe(), local = ?addr, "tracking source started");
        }
        Ok(Self {
            running,
            wand,
            wand_rx,
            head_rx,
            events,
            buttons: 0,
            last_frame: None,
            last_head_frame: None,
            state: None,
            runtime,
        })
    }

    /// Bound local addresses of listening sources, in config order.
    pub fn local_addrs(&self) -> &[Option<SocketAddr>] {
        &self.running.local_addrs
    }

    /// Receive time (hub clock) of the wand's latest report, if any arrived.
    pub fn last_report(&self) -> Option<Duration> {
        self.last_frame.map(|(_, t)| t)
    }

    /// The hub's clock.
    pub fn now(&self) -> Duration {
        self.running.hub.now()
    }

    fn sample(&self, state: &DeviceState, buttons: u32) -> WandSample {
        match (&state.status, &state.pose) {
            (TrackingStatus::Tracking, Some(p)) => {
                WandSample::tracked(p.tool_m, p.orientation, buttons)
            }
            _ => WandSample::lost(buttons),
        }
    }

    /// Everything new since the last poll, stamped with session time `t`.
    pub fn poll(&mut self, t: f64) -> Vec<Input> {
        let _guard = self.runtime.enter();
        let mut out = Vec::new();
        let wand_state = self.wand_rx.borrow_and_update().clone();
        loop {
            match self.events.try_recv() {
                Ok(TrackingEvent::Button {
                    device,
                    button,
                    pressed,
                    ..
                }) if device == self.wand && button < 32 => {
                    let bit = 1u32 << button;
                    if pressed {
                        self.buttons |= bit;
                    } else {
                        self.buttons &= !bit;
                    }
                    out.push(Input::Wand(WandEvent::sample(
                        t,
                        self.sample(&wand_state, self.buttons),
                    )));
                }
                Ok(_) => {}
                Err(broadcast::error::TryRecvError::Lagged(n)) => {
                    tracing::warn!(
                        missed = n,
                        "tracking events lagged; resynchronising buttons"
                    );
                }
                Err(_) => break,
            }
        }
        let fresh = self.last_frame.map(|(f, _)| f) != Some(wand_state.frame)
            && wand_state.last_seen > Duration::ZERO;
        if fresh {
            self.last_frame = Some((wand_state.frame, wand_state.last_seen));
            // The device state is the truth for held buttons.
            self.buttons = (wand_state.buttons & u64::from(u32::MAX)) as u32;
            out.push(Input::Wand(WandEvent::sample(
                t,
                self.sample(&wand_state, self.buttons),
            )));
        }
        let state = match wand_state.status {
            TrackingStatus::Tracking => TrackingState::Ok,
            _ => TrackingState::Lost,
        };
        if self.state != Some(state) {
            self.state = Some(state);
            out.push(Input::Tracking(state));
            if state == TrackingState::Lost && !fresh {
                out.push(Input::Wand(WandEvent::sample(
                    t,
                    WandSample::lost(self.buttons),
                )));
            }
        }
        if let Some(rx) = &mut self.head_rx {
            let h = rx.borrow_and_update().clone();
            if self.last_head_frame != Some(h.frame)
                && let (TrackingStatus::Tracking, Some(p)) = (h.status, h.pose)
            {
                self.last_head_frame = Some(h.frame);
                out.push(Input::Head(Some(HeadPose {
                    position: p.position_m,
                    orientation: p.orientation,
                })));
            }
        }
        out
    }
}
