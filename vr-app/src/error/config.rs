//! What is wrong with a display-server configuration.

use thiserror::Error;

/// What is wrong with a display-server configuration.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The TOML does not parse or does not follow the schema.
    #[error("{0}")]
    Toml(Box<toml::de::Error>),
    /// The playback speed is out of range.
    #[error("tracking.playback.speed must be in (0, 1000], got {0}")]
    PlaybackSpeed(f64),
    /// A `[tracking.thumbstick]` setting cannot work.
    #[error("tracking.thumbstick: {0}")]
    Thumbstick(#[source] crate::thumbstick::ThumbstickError),
    /// A `[tracking]` setting was refused by the tracking layer.
    #[error("{field}: {cause}")]
    Tracking {
        /// The setting (`tracking.wand`, `tracking.input`).
        field: &'static str,
        /// The tracking layer's reason.
        cause: Box<tracking::TrackingError>,
    },
    /// The wand is not a Flystick.
    #[error("tracking.wand: the live path needs a Flystick (wandN) as the wand, not {0}")]
    WandNotFlystick(tracking::DeviceId),
    /// The head is not a body.
    #[error("tracking.head: the head must be a body (bodyN), not {0}")]
    HeadNotBody(tracking::DeviceId),
    /// `[tracking]` has neither a source nor playback.
    #[error("tracking needs at least one [[tracking.input.source]] or a [tracking.playback]")]
    NoTrackingSource,
    /// The eye separation is out of range.
    #[error("stereo.ipd must be in [0, 0.2] m, got {0}")]
    Ipd(f64),
    /// The clip planes are not `0 < near < far`.
    #[error("stereo: need 0 < near < far")]
    ClipPlanes,
    /// The window size is out of range.
    #[error("display size {width}x{height} is outside 1..=16384")]
    DisplaySize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// The sample count is not 1, 2 or 4.
    #[error("render.msaa must be 1, 2 or 4, got {0}")]
    Msaa(u32),
    /// The fixed head position is not in front of the screen.
    #[error("head.position must be finite and in front of the screen")]
    HeadPosition,
    /// The `[interaction]` settings were refused by the sculpting layer.
    #[error("interaction: {0}")]
    Interaction(sculpt_core::Error),
    /// An unknown output mode name.
    #[error("unknown output mode {0:?} (expected dual, side-by-side, anaglyph or mono)")]
    OutputMode(String),
    /// An unknown material name.
    #[error("unknown material {0:?} (expected clay, stone or wood)")]
    Material(String),
}
