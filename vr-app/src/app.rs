//! The display server's per-frame state, shared by the windowed, headless and demo
//! paths: session, screen and head, mesh synchronisation (including the live stroke
//! preview), the wand cursor overlay and the HUD. No GPU and no window here.

use glam::DVec3;
use sculpt_core::interaction::{Mode, Profile, StrokeMode};
use sculpt_core::mesh::{MeshSink, PatchKey};

use crate::config::Config;
use crate::error::VrResult;
use crate::projection::{HeadPose, Screen, StereoRig};
use crate::render::{LineVertex, Views, cursor_lines};
use crate::scene_mesh::{SceneMesher, write_grid_surface, write_stroke};
use crate::session::Session;

/// Patch key of the live stroke or sketch preview.
pub const PREVIEW_KEY: PatchKey = PatchKey::MAX - 1;

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

/// The app state of one display server.
#[derive(Debug)]
pub struct AppState {
    /// The configuration.
    pub config: Config,
    /// The sculpting session.
    pub session: Session,
    /// The screen.
    pub screen: Screen,
    /// Stereo parameters.
    pub rig: StereoRig,
    /// The current head pose (tracked, or fixed).
    pub head: HeadPose,
    /// Tracking status for the HUD.
    pub tracking: TrackingState,
    /// Smoothed frames per second, for the HUD.
    pub fps: f64,
    mesher: SceneMesher,
    fixed_head: HeadPose,
    preview_shown: bool,
}

impl AppState {
    /// Opens the session described by `config` (recovering its journal).
    pub fn new(config: Config) -> VrResult<Self> {
        let screen = config.screen.screen()?;
        let head = config.fixed_head()?;
        let session = Session::open(&config)?;
        let tracking = if config.tracking.is_some() {
            TrackingState::Lost
        } else {
            TrackingState::Emulated
        };
        Ok(Self {
            rig: config.stereo,
            config,
            session,
            screen,
            head,
            tracking,
            fps: 0.0,
            mesher: SceneMesher::new(6),
            fixed_head: head,
            preview_shown: false,
        })
    }

    /// Sets the tracked head, or returns to the fixed head with `None`. A head pose
    /// that gives no valid projection (non-finite, behind the screen) is ignored.
    pub fn set_head(&mut self, head: Option<HeadPose>) {
        match head {
            Some(h) if Views::new(&self.rig, &self.screen, &h).is_ok() => self.head = h,
            Some(_) => {}
            None => self.head = self.fixed_head,
        }
    }

    /// The cameras for the current head.
    pub fn views(&self) -> VrResult<Views> {
        Views::new(&self.rig, &self.screen, &self.head)
            .or_else(|_| Views::new(&self.rig, &self.screen, &self.fixed_head))
    }

    /// The direction the targets face (the screen normal).
    pub fn facing(&self) -> DVec3 {
        self.screen.basis().2
    }

    /// Brings the GPU meshes up to date: changed document patches, and the preview of a
    /// live stroke or sketch. Returns the number of patches written.
    pub fn sync_meshes(&mut self, targets: &mut dyn MeshSink, strokes: &mut dyn MeshSink) -> usize {
        let facing = self.facing();
        let mut written = self
            .mesher
            .update(&self.session.doc, facing, targets, strokes);
        let i = &self.session.interaction;
        if let Some(live) = i.live_stroke().filter(|s| s.samples.len() >= 2) {
            write_stroke(&live, facing, PREVIEW_KEY, strokes);
            self.preview_shown = true;
            written += 1;
        } else if let Some(rows) = i.live_sketch().filter(|r| r.len() >= 2) {
            write_grid_surface(rows, 1, PREVIEW_KEY, targets);
            self.preview_shown = true;
            written += 1;
        } else if self.preview_shown {
            strokes.remove_patch(PREVIEW_KEY);
            targets.remove_patch(PREVIEW_KEY);
            self.preview_shown = false;
        }
        written
    }

    /// The wand cursor and its tool footprint (a circle of the tool width around the
    /// tip, in the screen's plane orientation).
    pub fn overlay_lines(&self) -> Vec<LineVertex> {
        let mut lines = Vec::new();
        let i = &self.session.interaction;
        if let Some((_, tip, q)) = i.wand() {
            let (vr, vu, vn) = self.screen.basis();
            let r = 0.5 * i.tool().width;
            let ring: Vec<DVec3> = (0..=24)
                .map(|k| {
                    let a = k as f64 / 24.0 * std::f64::consts::TAU;
                    tip + (vr * a.cos() + vu * a.sin()) * r - vn * 0.001
                })
                .collect();
            let axis = q * DVec3::NEG_Z;
            cursor_lines(tip, axis, &ring, i.gesture_active(), &mut lines);
        }
        lines
    }

    /// HUD text: mode, tool, target, tracking, fps, operations.
    pub fn hud_lines(&self) -> Vec<String> {
        let i = &self.session.interaction;
        let mode = match i.mode() {
            Mode::Sketch => "sketch",
            Mode::Carve => "carve",
            Mode::Emboss => "emboss",
        };
        let t = i.tool();
        let profile = match t.profile {
            Profile::V => "V",
            Profile::U => "U",
        };
        let tracking = match (self.tracking, i.gesture_paused()) {
            (_, true) => "TRACKING LOST (stroke paused)",
            (TrackingState::Lost, _) => "TRACKING LOST",
            (TrackingState::Ok, _) => "tracking ok",
            (TrackingState::Emulated, _) => "desktop wand",
        };
        let live = match i.live_stroke().map(|s| s.mode) {
            Some(StrokeMode::Carve) => "  carving",
            Some(StrokeMode::Emboss) => "  embossing",
            None => "",
        };
        vec![
            format!(
                "{mode} {profile} {:.1}x{:.1}mm  target {}/{}{live}",
                t.width * 1000.0,
                t.depth * 1000.0,
                i.target() + 1,
                self.session.doc.targets.len()
            ),
            format!(
                "{tracking}  {:.0} fps  ops {}",
                self.fps,
                self.session.operations()
            ),
        ]
    }

    /// Updates the smoothed fps from one frame's duration (seconds).
    pub fn note_frame_time(&mut self, dt: f64) {
        if dt.is_finite() && dt > 0.0 {
            let f = 1.0 / dt;
            self.fps = if self.fps == 0.0 {
                f
            } else {
                self.fps * 0.9 + f * 0.1
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use sculpt_core::interaction::{WandEvent, WandSample};
    use sculpt_core::mesh::PatchMesh;

    #[test]
    fn preview_follows_the_live_stroke_and_hud_reports_state() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let (mut t, mut s) = (PatchMesh::new(), PatchMesh::new());
        assert_eq!(app.sync_meshes(&mut t, &mut s), 1);
        for i in 0..3 {
            let p = DVec3::new(i as f64 * 0.01, 1.17, 0.0);
            app.session
                .handle(&WandEvent::sample(
                    i as f64 * 0.01,
                    WandSample::tracked(p, DQuat::IDENTITY, 1),
                ))
                .unwrap();
        }
        app.sync_meshes(&mut t, &mut s);
        assert!(s.patches().any(|(k, _)| k == PREVIEW_KEY));
        assert!(!app.overlay_lines().is_empty());
        assert!(app.hud_lines()[0].contains("carving"));
        app.session
            .handle(&WandEvent::sample(0.05, WandSample::lost(1)))
            .unwrap();
        assert!(app.hud_lines()[1].contains("TRACKING LOST"));
        app.session
            .handle(&WandEvent::sample(
                0.06,
                WandSample::tracked(DVec3::new(0.03, 1.17, 0.0), DQuat::IDENTITY, 0),
            ))
            .unwrap();
        app.sync_meshes(&mut t, &mut s);
        assert!(!s.patches().any(|(k, _)| k == PREVIEW_KEY));
        assert_eq!(app.session.doc.strokes.len(), 1);
        // A head behind the screen is ignored rather than breaking the projection.
        let before = app.head;
        app.set_head(Some(HeadPose {
            position: DVec3::new(0.0, 1.0, -1.0),
            orientation: DQuat::IDENTITY,
        }));
        assert_eq!(app.head, before);
    }
}
