//! # vr-app
//!
//! The library half of the Wandsculpt display server `wandsculpt`: the pure parts
//! (projection maths, configuration, the operation journal) and the headless GPU
//! renderer, so that `replay` and tests can use them without a window.
//!
//! ```
//! use vr_app::projection::{fixed_head, Screen, StereoRig};
//! use glam::DVec3;
//! let screen = Screen::new(DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(-1.0, 1.5, 0.0))?;
//! let head = fixed_head(&screen, 2.0);
//! let (left, right) = StereoRig::default().eye_cameras(&screen, &head)?;
//! assert!(left.eye.x < right.eye.x);
//! # Ok::<(), vr_app::VrError>(())
//! ```
#![warn(missing_docs)]

pub mod app;
pub mod config;
pub mod demo;
pub mod desktop_wand;
pub mod error;
pub mod headless;
pub mod journal;
pub mod live;
pub mod preview;
pub mod projection;
pub mod render;
pub mod session;
pub mod window;
pub mod xr;
#[cfg(feature = "openxr")]
pub mod xr_runtime;

pub use error::{VrError, VrResult};
