//! The one feeder: every driver's raw inputs (tracker frames, a buttons-only serial
//! wand, the thumbstick's axes, desktop keys and commands, silence) become wand events
//! and edits here, the same way for the window, a headless run, live tracking, `replay`,
//! a headset and a cluster node.
//!
//! Stages, in order, for one [`Input`]:
//! 1. a pose-carrying frame ([`Input::Frame`]) goes through the pure
//!    [`FrameStage`] (order, time from `ts`, calibration, filter, loss); each wand
//!    sample becomes the interaction's [`WandEvent`] with the buttons of a buttons-only
//!    source merged in ([`tracking::stage::WandSample::wand_event`]), each head sample
//!    a head pose, in the order the stage emits them;
//! 2. once the frame's samples are in, the wand's analog axes (a thumbstick) change the
//!    tool's width and depth ([`ThumbstickDriver`], when one is configured), reading the
//!    tool as the samples left it;
//! 3. a buttons-only frame ([`Input::Buttons`]) only sets the buttons merged into the
//!    next samples; silence ([`Input::Silence`]) lets the stage report the wand lost
//!    and, once a paused gesture's timeout is well behind the receive clock, ends it
//!    with a tick;
//! 4. wand events, keys and ticks from elsewhere (the desktop pointer, a demo script,
//!    a key binding) go on as they are.
//!
//! What becomes of the events is the [`Sink`]'s business: the display server's
//! [`AppState`](crate::app::AppState) journals and applies them through its
//! [`Session`](crate::session::Session) (which runs sculpt-core's `Interaction`, so
//! every interaction mode flows through unchanged), a cluster node proposes them to
//! the operation stream, `replay` counts them into its metrics. The feeder holds no
//! clock and does no I/O, so a recorded input log gives the same edits through every
//! driver.
//!
//! ```
//! use vr_app::feeder::{Feeder, Sink};
//! use vr_app::input::Input;
//! use sculpt_core::interaction::{Command, Tool, WandEvent};
//! #[derive(Default)]
//! struct Count(usize);
//! impl Sink for Count {
//!     type Error = std::convert::Infallible;
//!     fn wand(&mut self, _ev: &WandEvent) -> Result<(), Self::Error> { self.0 += 1; Ok(()) }
//!     fn tick(&mut self, _t: f64) -> Result<(), Self::Error> { Ok(()) }
//!     fn tool(&self) -> Tool { Tool::default() }
//! }
//! let mut feeder = Feeder::new(Default::default(), 0.5, None)?;
//! let mut sink = Count::default();
//! let Ok(_accepted) = feeder.feed(&Input::Wand(WandEvent::command(0.0, Command::Undo)), &mut sink);
//! assert_eq!(sink.0, 1);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::time::Duration;

use sculpt_core::interaction::{Tool, WandEvent};
use tracking::Frame;
use tracking::stage::{FrameStage, StageConfig, StageEvent};

use crate::config::Config;
use crate::error::{VrError, VrResult};
use crate::input::{Input, TrackingState};
use crate::projection::HeadPose;
use crate::xr::actions::{ThumbstickDriver, ThumbstickTool};

/// How long past a paused gesture's timeout the receive clock must be before silence
/// ends it with a tick (keeps ticks safely behind the next frame's time).
pub const TICK_MARGIN_S: f64 = 0.25;

/// Where the feeder's wand events go: a driver's session.
pub trait Sink {
    /// What handling an event can fail with.
    type Error;
    /// One wand event (a sample or a command), in time order.
    fn wand(&mut self, ev: &WandEvent) -> Result<(), Self::Error>;
    /// Time passed with no input (session seconds): ends gestures paused too long.
    fn tick(&mut self, t: f64) -> Result<(), Self::Error>;
    /// The tool as it is now: the thumbstick changes it relative to this.
    fn tool(&self) -> Tool;
    /// The tracked head moved (`None`: head lost, use the fixed head).
    fn head(&mut self, _head: Option<HeadPose>) {}
    /// Tracking status changed.
    fn tracking(&mut self, _state: TrackingState) {}
    /// A desktop key pressed at `t`, logged as an operator before its command.
    fn key(&mut self, _t: f64, _key: &str) {}
}

/// The staged feeder (see the module docs).
#[derive(Debug)]
pub struct Feeder {
    stage: FrameStage,
    wand_id: u32,
    pause_timeout: f64,
    stick: Option<ThumbstickDriver>,
    /// Buttons reported by a buttons-only source, merged into the wand's samples.
    extra_buttons: u64,
    /// Receive time of the last frame of any kind.
    last_receive: Option<Duration>,
    /// Time of the lost sample silence made the stage emit, until a tick ended the
    /// pause.
    idle_lost_at: Option<f64>,
    /// Tracking status last reported to the sink (only once a frame or silence came).
    state: Option<TrackingState>,
    events: Vec<StageEvent>,
}

impl Feeder {
    /// A feeder with the stage `stage`, the interaction's `pause_timeout` (silence ends
    /// a paused gesture that long after the loss) and, with `thumbstick`, the wand's
    /// axes as tool changes.
    pub fn new(
        stage: StageConfig,
        pause_timeout: f64,
        thumbstick: Option<ThumbstickTool>,
    ) -> VrResult<Self> {
        let wand_id = stage.wand_id;
        let stage = FrameStage::new(stage).map_err(|reason| VrError::Tracking {
            what: "tracking".into(),
            reason: Box::new(reason),
        })?;
        Ok(Self {
            stage,
            wand_id,
            pause_timeout,
            stick: thumbstick.map(ThumbstickDriver::new),
            extra_buttons: 0,
            last_receive: None,
            idle_lost_at: None,
            state: None,
            events: Vec::new(),
        })
    }

    /// The feeder of the display server's config: the `[tracking]` section's stage
    /// and thumbstick (the stage's defaults without one: then only wand events, keys
    /// and ticks come in), the interaction's pause timeout.
    pub fn for_config(config: &Config) -> VrResult<Self> {
        match &config.tracking {
            Some(t) => Self::new(
                t.stage_config()?,
                config.interaction.pause_timeout,
                t.thumbstick,
            ),
            None => Self::new(
                StageConfig::default(),
                config.interaction.pause_timeout,
                None,
            ),
        }
    }

    /// The frame stage (its clock and counts).
    pub fn stage(&self) -> &FrameStage {
        &self.stage
    }

    /// Counts a record whose bytes did not decode into a frame.
    pub fn bad_frame(&mut self) {
        self.stage.bad_frame();
    }

    /// Feeds one input to `sink` (see the module docs). Returns whether it was a
    /// frame the stage accepted.
    pub fn feed<S: Sink>(&mut self, input: &Input, sink: &mut S) -> Result<bool, S::Error> {
        match input {
            Input::Frame(frame) => {
                self.last_receive = Some(frame.receive_time);
                self.idle_lost_at = None;
                let accepted = self.frame(frame, sink)?;
                self.report_state(sink);
                return Ok(accepted);
            }
            Input::Buttons(frame) => {
                self.last_receive = Some(frame.receive_time);
                self.idle_lost_at = None;
                if let Some(w) = frame.wand(self.wand_id) {
                    self.extra_buttons = w.buttons;
                }
            }
            Input::Silence(now) => {
                self.silence(*now, sink)?;
                self.report_state(sink);
            }
            Input::Wand(ev) => sink.wand(ev)?,
            Input::Key { t, key } => sink.key(*t, key),
            Input::Tick(t) => sink.tick(*t)?,
        }
        Ok(false)
    }

    /// Feeds every input in order.
    pub fn feed_all<'a, S: Sink>(
        &mut self,
        inputs: impl IntoIterator<Item = &'a Input>,
        sink: &mut S,
    ) -> Result<(), S::Error> {
        for input in inputs {
            self.feed(input, sink)?;
        }
        Ok(())
    }

    /// A pose-carrying frame: the stage's samples in order, then the thumbstick.
    fn frame<S: Sink>(&mut self, frame: &Frame, sink: &mut S) -> Result<bool, S::Error> {
        let mut events = std::mem::take(&mut self.events);
        events.clear();
        let accepted = self.stage.push(frame, &mut events);
        let sent = self.send(&events, sink);
        self.events = events;
        sent?;
        if let (true, Some(t), Some(stick)) = (accepted, self.stage.time(), &mut self.stick) {
            let tool = sink.tool();
            for ev in stick.commands(t, frame, self.wand_id, &tool) {
                sink.wand(&ev)?;
            }
        }
        Ok(accepted)
    }

    /// No frame arrived by `now` (receive clock): the stage may report the wand lost;
    /// a paused gesture ends once its timeout is [`TICK_MARGIN_S`] behind the clock.
    fn silence<S: Sink>(&mut self, now: Duration, sink: &mut S) -> Result<(), S::Error> {
        let mut events = std::mem::take(&mut self.events);
        events.clear();
        if self.stage.idle(now, &mut events) {
            self.idle_lost_at = events.iter().rev().find_map(|e| e.wand().map(|w| w.t));
        }
        let sent = self.send(&events, sink);
        self.events = events;
        sent?;
        if let (Some(lost_t), Some(stage_t), Some(last)) =
            (self.idle_lost_at, self.stage.time(), self.last_receive)
        {
            let end = lost_t + self.pause_timeout + sculpt_core::tolerance::TIME_EPS;
            let clock = stage_t + now.saturating_sub(last).as_secs_f64();
            if clock > end + TICK_MARGIN_S {
                self.idle_lost_at = None;
                sink.tick(end)?;
            }
        }
        Ok(())
    }

    /// The stage's events to the sink, in order.
    fn send<S: Sink>(&self, events: &[StageEvent], sink: &mut S) -> Result<(), S::Error> {
        for ev in events {
            match ev {
                StageEvent::Wand(w) => sink.wand(&w.wand_event(self.extra_buttons))?,
                StageEvent::Head(h) => sink.head(Some(HeadPose {
                    position: h.pose.position_m,
                    orientation: h.pose.orientation,
                })),
            }
        }
        Ok(())
    }

    fn report_state<S: Sink>(&mut self, sink: &mut S) {
        let state = if self.stage.wand_tracked() {
            TrackingState::Ok
        } else {
            TrackingState::Lost
        };
        if self.state != Some(state) {
            self.state = Some(state);
            sink.tracking(state);
        }
    }
}
