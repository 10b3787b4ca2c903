//! # tracking
//!
//! Wand and head poses for Wandsculpt: DTrack2 ASCII over TCP and UDP, serial wands,
//! filtering, tracking-loss handling, calibration, pose logs and a tracker simulator.
//!
//! Layering: the codecs ([`dtrack`], [`poselog`]) and the [`sim`]ulator are
//! pure (bytes in, frames out, no tokio). [`Frame`] carries tracker units
//! (millimetres, `tracker_from_body` matrices).
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

pub mod dtrack;
pub mod error;
pub mod frame;
pub mod poselog;
pub mod sim;

pub use error::{Result, TrackingError};
pub use frame::{Body, DeviceId, Frame, Pose, Wand};
