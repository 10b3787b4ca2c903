//! The inputs of a session, whatever produces them (live tracking, a pose-log or
//! simulator playback, the desktop wand, a demo script): wand events, the tracked head,
//! tracking status and the passing of time.

use sculpt_core::interaction::WandEvent;

use crate::projection::HeadPose;

/// Whether tracking data is arriving.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackingState {
    /// No tracker configured (desktop mode or demo).
    Emulated,
    /// Frames arriving and the wand is visible.
    Ok,
    /// Frames arriving but the wand is not visible, or no frames for a while.
    Lost,
}

/// One input of a session (headless, windowed or live).
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A wand event.
    Wand(WandEvent),
    /// The tracked head moved (`None`: head lost, use the fixed head).
    Head(Option<HeadPose>),
    /// Tracking status changed.
    Tracking(TrackingState),
    /// Time passed with no input (session seconds): ends gestures paused too long.
    Tick(f64),
}
