//! The raw inputs of a session, whatever produces them (live tracking, a pose-log or
//! simulator playback, a headset's controller, the desktop wand, a demo script), and
//! the tracking status. [`crate::feeder::Feeder`] turns them into wand events and
//! edits, the same way for every driver.

use std::time::Duration;

use sculpt_core::interaction::WandEvent;
use tracking::Frame;

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

/// One raw input of a session (headless, windowed, live, headset or replayed), in
/// arrival order.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A tracker frame that carries poses (DTrack2, a serial wand that sends its pose,
    /// a headset controller written as a frame), stamped with its receive time.
    Frame(Frame),
    /// A frame of a buttons-only source (a serial wand without a pose): its wand's
    /// buttons are merged into the wand's next samples.
    Buttons(Frame),
    /// No frame arrived by this receive time (the hub's clock): the wand may be lost,
    /// and a paused gesture may end.
    Silence(Duration),
    /// A wand event from elsewhere: the desktop pointer, a demo script, a command.
    Wand(WandEvent),
    /// A desktop key pressed at `t` (session seconds), logged as an operator (its
    /// command follows as a [`Input::Wand`] at the same time).
    Key {
        /// When (session seconds).
        t: f64,
        /// The key as the key help names it (`Ctrl+Z`, `2`).
        key: String,
    },
    /// Time passed with no input (session seconds): ends gestures paused too long.
    Tick(f64),
}
