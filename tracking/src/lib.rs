//! # tracking
//!
//! Wand and head poses for Wandsculpt: DTrack2 ASCII over TCP and UDP, serial wands,
//! filtering, tracking-loss handling, calibration, pose logs and a tracker simulator.
//!
//! Layering:
//! * pure, no tokio, always built: the codecs ([`dtrack`], [`serial`], [`poselog`]), the
//!   [`sim`]ulator, [`filter`] (One Euro), [`calibration`] (Umeyama fit, tip offsets),
//!   [`config`], the frame [`stage`], and Open Brush input: the [`tilt`] codec and the
//!   [`import`]er that turns a sketch into a wand track and a pose log. They live here
//!   (not in `replay`) because their product is a pose log, and so that pure tools
//!   (`sculpt-tools tilt2poselog`) need no GPU, window or async runtime;
//! * feature `io` (default): `hub`, the merge layer, latest state per device on tokio
//!   `watch` channels and ordered events on a `broadcast` channel (no runtime needed to
//!   drive it); and `transport`, where the tokio runtime lives: TCP listen/connect, UDP,
//!   serial, paced senders; and the `wandtrack` binary. Build with
//!   `default-features = false` for the pure layer only.
//!
//! [`Frame`] carries tracker units (millimetres, `tracker_from_body` matrices);
//! [`calibration::Calibration`] turns them into metres in the display frame.
//!
//! ```
//! use tracking::{dtrack, sim::{Script, SimConfig, Simulator}};
//! use glam::DVec3;
//! // A scripted session, as DTrack2 bytes, decoded back.
//! let script = Script::new(DVec3::new(0.0, 1.0, 0.0)).move_to(DVec3::new(0.1, 1.0, 0.0), 0.1);
//! let bytes = Simulator::new(&script, SimConfig::default()).unwrap().to_dtrack_bytes();
//! let mut decoder = dtrack::DTrackDecoder::default();
//! let mut frames = 0;
//! decoder.push(&bytes, &mut |d| if let dtrack::Decoded::Frame(..) = d { frames += 1 });
//! assert_eq!(frames, 13);
//! ```
#![warn(missing_docs)]

pub mod calibration;
pub mod config;
pub mod dtrack;
pub mod error;
pub mod filter;
pub mod frame;
#[cfg(feature = "io")]
pub mod hub;
pub mod import;
pub mod poselog;
pub mod serial;
pub mod sim;
pub mod stage;
pub mod tilt;
pub mod tolerance;
#[cfg(feature = "io")]
pub mod transport;

pub use error::{
    CalibrationError, ConfigError, Degeneracy, ImportError, Result, SimError, SketchError,
    TiltContainerError, TrackingError,
};
pub use frame::{Body, DeviceId, Frame, Pose, Wand};
