//! `--render`: left and right eye PNGs of the replayed scene at chosen session times,
//! through vr-app's headless renderer (`vr_app::render`, wgpu; lavapipe in CI).
//! One [`SceneRenderer`] (one GPU device, one set of pipelines) serves a whole run; no
//! display-server session or journal is opened.
//!
//! At each time the renderer is given what the display server would show at that
//! moment: the replayed [`Document`](sculpt_core::sculpt::document::Document), the
//! interaction (wand cursor, live stroke preview) and the tracked head pose, for
//! head-tracked off-axis stereo on the configured screen. Times are session seconds
//! from the first frame; a time is rendered at the first frame at or after it (times
//! past the end show the last frame).
//!
//! ```no_run
//! use replay::{config::ReplayConfig, pipeline, render::{SceneRenderer, parse_times}};
//! let log = std::fs::read("tests/data/sessions/patch-carve.poselog")?;
//! let times = parse_times("2.5,5.0")?;
//! let mut renderer = SceneRenderer::new(&vr_app::config::Config::default(), 320, 180)?;
//! let mut shots = Vec::new();
//! pipeline::replay_log_rendering(&log, &ReplayConfig::default(), pipeline::default_document(), "s", &times,
//!     &mut |t, r| { shots.push((t, renderer.render(r)?)); Ok(()) })?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use sculpt_core::sculpt::view::DocumentView;
use std::path::{Path, PathBuf};

use vr_app::config::Config;
use vr_app::output::OutputMode;
use vr_app::projection::{HeadPose, Screen, StereoRig};
use vr_app::render::{Gpu, Renderer};
use vr_app::scene::{FrameInput, SceneState, Views};

use crate::error::{ConfigError, Error, Result};
use crate::pipeline::Replayer;

/// Most render times one run may ask for.
pub const MAX_RENDER_TIMES: usize = 1000;

/// Parses `--render` times: comma-separated non-negative seconds (`2.5,5.0`), sorted.
pub fn parse_times(text: &str) -> Result<Vec<f64>> {
    let mut times = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let t: f64 = part.parse().map_err(|_| {
            Error::Config(ConfigError::RenderTimeNotANumber {
                text: part.to_string(),
            })
        })?;
        if !(t.is_finite() && t >= 0.0) {
            return Err(Error::Config(ConfigError::RenderTimeNegative { t }));
        }
        times.push(t);
    }
    if times.is_empty() || times.len() > MAX_RENDER_TIMES {
        return Err(Error::Config(ConfigError::RenderTimeCount {
            max: MAX_RENDER_TIMES,
        }));
    }
    times.sort_by(f64::total_cmp);
    Ok(times)
}

/// `--render-every S` over a session of `duration` seconds: 0, S, 2S, ... up to the end.
pub fn every(step: f64, duration: f64) -> Result<Vec<f64>> {
    if !(step.is_finite() && step > 0.0) {
        return Err(Error::Config(ConfigError::RenderStep { step }));
    }
    let n = (duration.max(0.0) / step).floor() as usize + 1;
    if n > MAX_RENDER_TIMES {
        return Err(Error::Config(ConfigError::RenderStepCount {
            step,
            count: n,
            max: MAX_RENDER_TIMES,
        }));
    }
    Ok((0..n).map(|k| k as f64 * step).collect())
}

/// The stereo pair at one time.
#[derive(Debug, Clone)]
pub struct StereoShot {
    /// Left eye.
    pub left: image::RgbaImage,
    /// Right eye.
    pub right: image::RgbaImage,
}

impl StereoShot {
    /// Writes `render-<T>-left.png` and `render-<T>-right.png` (T in seconds, three
    /// decimals) into `dir` and returns their paths.
    pub fn save(&self, dir: &Path, t: f64) -> Result<[PathBuf; 2]> {
        let name = |eye: &str| dir.join(format!("render-{t:.3}-{eye}.png"));
        let paths = [name("left"), name("right")];
        // Encoded in memory, then written as a pair (fsio): a full disk leaves neither.
        let mut pngs = Vec::with_capacity(2);
        for (img, path) in [(&self.left, &paths[0]), (&self.right, &paths[1])] {
            let mut png = std::io::Cursor::new(Vec::new());
            img.write_to(&mut png, image::ImageFormat::Png)
                .map_err(|source| Error::SaveImage {
                    path: path.clone(),
                    source,
                })?;
            pngs.push((path.clone(), png.into_inner()));
        }
        fsio::write_all_atomic(&pngs)?;
        Ok(paths)
    }
}

/// vr-app's headless renderer, set up once for a replay and reused for every picture.
pub struct SceneRenderer {
    gpu: Gpu,
    renderer: Renderer,
    screen: Screen,
    rig: StereoRig,
    fixed_head: HeadPose,
    width: u32,
    height: u32,
}

impl SceneRenderer {
    /// A renderer for eye images of `width` x `height` with `display`'s screen, stereo
    /// rig and fixed head (its other settings are not used: no HUD, no session). The
    /// GPU, the pipelines and the mesh stores are made once, here.
    pub fn new(display: &Config, width: u32, height: u32) -> Result<Self> {
        if vr_app::render::check_offscreen_size(width, height).is_err() {
            return Err(Error::ImageSize { width, height });
        }
        let err = Error::Render;
        let screen = display.screen.screen().map_err(err)?;
        let fixed_head = display.fixed_head().map_err(err)?;
        let gpu = Gpu::headless().map_err(err)?;
        let renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
        Ok(Self {
            gpu,
            renderer,
            screen,
            rig: display.stereo,
            fixed_head,
            width,
            height,
        })
    }

    /// The adapter in use, for logs.
    pub fn adapter(&self) -> String {
        self.gpu.describe()
    }

    /// Renders both eyes of what the display server would show now: the replayed
    /// document and interaction (wand cursor, footprint, live stroke preview) seen from
    /// the tracked head (the fixed head when there is none, or it gives no valid
    /// projection).
    pub fn render(&mut self, replayer: &Replayer) -> Result<StereoShot> {
        let err = Error::Render;
        let interaction = replayer.interaction();
        // The preview is carved into a view of the document, as the app does.
        let doc = replayer.document();
        let head = replayer
            .head()
            .copied()
            .filter(|h| Views::new(&self.rig, &self.screen, h).is_ok())
            .unwrap_or(self.fixed_head);
        let views = Views::new(&self.rig, &self.screen, &head).map_err(err)?;
        // Each picture is written from scratch: empty stores, a fresh view of the
        // document and a fresh scene state.
        self.renderer.clear_meshes();
        let mut scene = SceneState::default();
        let mut view = DocumentView::new();
        let facing = self.screen.basis().2;
        self.renderer
            .sync_with(|sinks| scene.sync_meshes(doc, &mut view, interaction, facing, sinks));
        let lines = scene.overlay_lines(doc, interaction, &self.screen);
        let input = FrameInput {
            views: &views,
            lines: &lines,
            hud: &[],
        };
        let frame = self
            .renderer
            .render_offscreen(&input, OutputMode::Dual, self.width, self.height)
            .map_err(err)?;
        Ok(StereoShot {
            left: frame.left,
            right: frame.right,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_parsed_sorted_and_checked() {
        assert_eq!(parse_times("5, 2.5,").unwrap(), vec![2.5, 5.0]);
        for bad in ["", "x", "-1", "nan", "inf"] {
            assert!(parse_times(bad).is_err(), "{bad}");
        }
        assert_eq!(every(2.0, 5.0).unwrap(), vec![0.0, 2.0, 4.0]);
        assert!(every(0.0, 5.0).is_err());
        assert!(every(1e-6, 60.0).is_err(), "too many images"); // not a tolerance: an image period
    }
}
