//! # vr-app
//!
//! The library half of the Wandsculpt display server `wandsculpt`: the pure parts
//! (projection maths, configuration, the operation journal) and the headless GPU
//! renderer, so that `replay` and tests can use them without a window.
//!
//! Features: `window` (default) adds `window` (winit windows, desktop mode) and the
//! `wandsculpt` binary; `nats` (default, and part of `window`: a cluster node can run
//! in a window) adds `cluster` (NATS JetStream roles). Without them
//! (`default-features = false`, as `replay` uses it) nothing links a window system or
//! the NATS client; the `[cluster]` config section is still read and checked.
//! `openxr` adds the head-mounted display runtime.
//!
//! Layers (`use crate::` edges between the app's modules, a DAG; any module may also
//! use the leaves):
//! * leaves: [`error`] (it quotes `render::limits`), [`projection`], [`output`]
//!   ([`OutputMode`](output::OutputMode)),
//!   [`input`] (session [`Input`](input::Input)s and
//!   [`TrackingState`](input::TrackingState)), [`journal`], [`preview`];
//! * [`config`] -> output, `render::material` (pure) (it also holds
//!   [`Playback`](config::Playback), the screen and the `[cluster]` section,
//!   [`config::cluster`]);
//! * [`session`] -> config, journal;
//! * [`study`] (`--study`: trials into a study's logs) -> session;
//! * [`scene`] (a frame as plain values: cameras, overlay lines, the meshes of a
//!   document and an interaction) -> preview;
//! * [`gpu_eval`] (wgpu compute: implicit tapes as WGSL) -> render (its [`Gpu`](render::Gpu));
//! * [`render`] (wgpu) -> scene, output: it draws a [`FrameInput`](scene::FrameInput)
//!   and fills mesh sinks it is handed, and never sees the app state;
//! * [`app`] ([`AppState`](app::AppState)) -> config, session, study, scene, input,
//!   [`desktop_view`] (the desktop camera), [`desktop_wand`];
//! * [`live`] (tracking hub on tokio) -> config, input;
//! * `cluster` (feature `nats`: NATS JetStream roles: ingest, node, frame barrier) ->
//!   config, live, app, headless, session, journal;
//! * [`headless`] -> app, render, session, journal, input, output; `window` -> app,
//!   render, output, input, [`desktop_wand`];
//! * [`xr`] (pure: views to cameras, session lifecycle, bindings, controllers as
//!   tracker frames) -> projection, scene; `xr::wand` -> app, live, input;
//!   `xr_runtime` (feature `openxr`: the headset session) -> xr, render, app.
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
#[cfg(feature = "nats")]
pub mod cluster;
pub mod config;
pub mod demo;
pub mod desktop_view;
pub mod desktop_wand;
pub mod error;
pub mod feeder;
pub mod gpu_eval;
pub mod gpu_volume;
pub mod headless;
pub mod input;
pub mod journal;
pub mod lattice_view;
pub mod line_vertex;
pub mod live;
pub mod output;
pub mod paint_view;
pub mod preview;
pub mod projection;
pub mod quadtree;
pub mod render;
pub mod scene;
pub mod session;
pub mod solid_view;
pub mod study;
pub mod thumbstick;
pub mod tolerance;
#[cfg(feature = "window")]
pub mod window;
pub mod xr;
#[cfg(feature = "openxr")]
pub mod xr_runtime;

pub use error::{AdapterError, ConfigError, GpuError, VrError, VrResult, XrError};
