//! The display server's per-frame state, shared by the windowed, headless and demo
//! paths: session, screen and head, mesh synchronisation (including the live stroke
//! preview, through [`SceneState`]), the wand cursor overlay and the HUD. No GPU and no
//! window here.

use glam::DVec3;
use sculpt_core::interaction::{Profile, StrokeMode};
use sculpt_core::sculpt::tessellate::Detail;

use crate::config::Config;
use crate::desktop_view::DesktopView;
use crate::desktop_wand::EmulatedWand;
use crate::error::VrResult;
pub use crate::input::TrackingState;
use crate::projection::{HeadPose, Screen, StereoRig};
pub use crate::scene::{FOOTPRINT_REACH, MeshSinks, MeshSync, PREVIEW_KEY};
use crate::scene::{LineVertex, SceneState, Views};
use crate::session::Session;

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
    /// The desktop camera (desktop mode: no `[tracking]`), framing the document at
    /// start; `None` on a tracked wall, whose view is the physical one.
    pub view: Option<DesktopView>,
    /// Study mode (`--study`): the participant's trials, shown on the HUD.
    pub study: Option<crate::study::StudyRun>,
    fixed_head: HeadPose,
    scene: SceneState,
    /// The quadtree overlay's lines and the strokes they were drawn for.
    quadtree: Option<(Vec<u64>, Vec<LineVertex>)>,
    /// The other sculptors' wands (a cluster node sets them each frame, see
    /// [`crate::cluster::wand`]), drawn with the own cursor.
    pub peer_wand_lines: Vec<LineVertex>,
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
        let view = config
            .tracking
            .is_none()
            .then(|| DesktopView::new(&screen, head.position, EmulatedWand::default().depth));
        let mut app = Self {
            rig: config.stereo,
            config,
            session,
            screen,
            head,
            tracking,
            fps: 0.0,
            view,
            study: None,
            fixed_head: head,
            scene: SceneState::default(),
            quadtree: None,
            peer_wand_lines: Vec::new(),
        };
        app.reset_view();
        Ok(app)
    }

    /// The bounding box of the document's targets (their control nets, which hold
    /// the surfaces), display frame; `None` for an empty document.
    pub fn document_bounds(&self) -> Option<(DVec3, DVec3)> {
        self.session
            .doc
            .targets()
            .iter()
            .map(|t| t.surface.control_bounds())
            .filter(|(lo, hi)| lo.is_finite() && hi.is_finite())
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }

    /// Starts over with new, empty mesh sinks (a new renderer): the next
    /// [`AppState::sync_meshes`] writes the whole document again.
    pub fn new_sinks(&mut self) {
        self.scene = SceneState::default();
        self.session.draw_parts().0.forget_sinks();
    }

    /// Frames the whole document again (desktop mode; no-op on a wall).
    pub fn reset_view(&mut self) {
        let bounds = self.document_bounds();
        if let (Some(view), Some((lo, hi))) = (&mut self.view, bounds) {
            view.frame(lo, hi);
        }
    }

    /// The screen as the viewer sees it: moved by the desktop view, if any.
    pub fn view_screen(&self) -> Screen {
        self.view
            .and_then(|v| v.screen(&self.screen).ok())
            .unwrap_or(self.screen)
    }

    /// How the renderer tells targets apart: sketched targets (named `sketch ...` by
    /// the editor) tinted, the selected one outlined when there are several.
    pub fn surface_classes(&self) -> crate::scene::SurfaceClasses {
        let targets = self.session.doc.targets();
        crate::scene::SurfaceClasses {
            selected: (targets.len() > 1).then(|| self.session.interaction.target_position().0),
            sketched: targets
                .iter()
                .enumerate()
                .filter(|(_, t)| t.name.starts_with("sketch"))
                .map(|(i, _)| i as u32)
                .collect(),
        }
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

    /// The cameras for the current head (through the desktop view, if any).
    pub fn views(&self) -> VrResult<Views> {
        if let Some(v) = &self.view
            && let Ok(screen) = v.screen(&self.screen)
            && let Ok(views) = Views::new(&v.rig(&self.rig), &screen, &v.head(&self.head))
        {
            return Ok(views);
        }
        Views::new(&self.rig, &self.screen, &self.head)
            .or_else(|_| Views::new(&self.rig, &self.screen, &self.fixed_head))
    }

    /// The direction the targets face (the normal of the screen as seen).
    pub fn facing(&self) -> DVec3 {
        self.view_screen().basis().2
    }

    /// Brings the meshes up to date: the document's changed patches at the detail to
    /// show (interactive while a gesture is live, final otherwise; the first call
    /// writes both) and the preview of a live stroke. Only patches the document marks
    /// changed are written, and patches of removed targets are removed.
    pub fn sync_meshes(&mut self, sinks: MeshSinks<'_>) -> MeshSync {
        let facing = self.facing();
        let (doc, interaction) = self.session.draw_parts();
        self.scene.sync_meshes(doc, interaction, facing, sinks)
    }

    /// The closest point of the selected target to `p` and the surface normal there,
    /// when `p` is within [`FOOTPRINT_REACH`] of it.
    pub fn project_on_target(&mut self, p: DVec3) -> Option<(DVec3, DVec3)> {
        self.scene
            .project_on_target(&self.session.doc, &self.session.interaction, p)
    }

    /// The wand cursor with the tool footprint projected onto the selected target (a
    /// circle of the tool width in the surface's tangent plane at the closest point,
    /// joined to the tip), or around the tip when the target is out of reach; and the
    /// rows of a live sketch.
    pub fn overlay_lines(&mut self) -> Vec<LineVertex> {
        let screen = self.view_screen();
        let mut lines =
            self.scene
                .overlay_lines(&self.session.doc, &self.session.interaction, &screen);
        if self.config.display.quadtree {
            lines.extend_from_slice(self.quadtree_lines());
        }
        lines.extend_from_slice(&self.peer_wand_lines);
        lines
    }

    /// The UV quadtree overlay ([`crate::quadtree`]) of the document at final detail,
    /// rebuilt only when its targets or strokes changed.
    fn quadtree_lines(&mut self) -> &[LineVertex] {
        let doc = &self.session.doc;
        let key: Vec<u64> = std::iter::once(doc.targets().len() as u64)
            .chain(doc.strokes().iter().map(|s| s.id))
            .collect();
        if self.quadtree.as_ref().is_none_or(|(k, _)| *k != key) {
            let mut lines = Vec::new();
            crate::quadtree::quadtree_lines(doc, Detail::Final, &mut lines);
            self.quadtree = Some((key, lines));
        }
        self.quadtree.as_ref().map_or(&[], |(_, l)| l.as_slice())
    }

    /// Study mode: records the participant's trials of `study` in this session (the
    /// operator log is started again for the study; call before any input).
    pub fn start_study(&mut self, study: crate::study::StudyRun) -> VrResult<()> {
        study.attach(&mut self.session)?;
        self.study = Some(study);
        Ok(())
    }

    /// HUD text: mode, tool, target, tracking, fps, operations; in study mode the
    /// participant, method and trial.
    pub fn hud_lines(&self) -> Vec<String> {
        let i = &self.session.interaction;
        let mode = i.mode().name();
        let t = i.tool();
        let profile = match t.profile {
            Profile::V => "V",
            Profile::U => "U",
            Profile::Custom(_) => "custom",
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
        let mut lines = vec![
            format!(
                "{mode} {profile} {:.1}x{:.1}mm  target {}/{}{live}",
                t.width * 1000.0,
                t.depth * 1000.0,
                i.target_position().0 + 1,
                self.session.doc.targets().len()
            ),
            format!(
                "{tracking}  {:.0} fps  ops {}",
                self.fps,
                self.session.operations()
            ),
        ];
        lines.extend(self.study.as_ref().map(crate::study::StudyRun::hud_line));
        lines.extend(last_stroke_pieces(&self.session.doc));
        lines
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

/// The HUD line for the document's last stroke when it was carved in several pieces or
/// had pieces dropped (a stroke over basin jumps, see
/// [`StrokePieces`](sculpt_core::sculpt::stroke::StrokePieces)); `None` otherwise.
fn last_stroke_pieces(doc: &sculpt_core::sculpt::document::Document) -> Option<String> {
    let built = doc.stroke(doc.strokes().last()?.id)?;
    let (pieces, dropped) = (built.pieces.len(), built.dropped);
    (pieces > 1 || dropped > 0)
        .then(|| format!("last stroke: {pieces} pieces carved, {dropped} too short (dropped)"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use sculpt_core::assert_near;
    use sculpt_core::editor::default_surface_point;
    use sculpt_core::interaction::{Command, WandEvent, WandSample};
    use sculpt_core::mesh::PatchMesh;
    use sculpt_core::sculpt::tessellate::Detail;
    use sculpt_core::tolerance::{COSINE_EPS, CURSOR_RING_TOL, CURSOR_RING_Z_TOL, POINT_EPS};

    struct Meshes {
        final_detail: PatchMesh,
        interactive: PatchMesh,
        preview: PatchMesh,
    }

    impl Meshes {
        fn sync(&mut self, app: &mut AppState) -> MeshSync {
            app.sync_meshes(MeshSinks {
                final_detail: &mut self.final_detail,
                interactive: &mut self.interactive,
                preview: &mut self.preview,
            })
        }
    }

    fn wand(app: &mut AppState, t: f64, x: f64, buttons: u32) {
        let p = default_surface_point(x, 1.17);
        app.session
            .handle(&WandEvent::sample(
                t,
                WandSample::tracked(p, DQuat::IDENTITY, buttons),
            ))
            .unwrap();
    }

    #[test]
    fn document_meshes_follow_edits_at_the_right_detail_with_a_live_preview() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let mut m = Meshes {
            final_detail: PatchMesh::new(),
            interactive: PatchMesh::new(),
            preview: PatchMesh::new(),
        };
        let first = m.sync(&mut app);
        assert_eq!(first.shown, Detail::Final);
        let full = first.patches_written;
        assert_eq!(
            full,
            app.session.doc.patch_count(Detail::Final)
                + app.session.doc.patch_count(Detail::Interactive),
            "the first sync writes both details"
        );
        let untouched = m.final_detail.clone();
        assert!(untouched.triangle_count() > m.interactive.triangle_count());
        assert_eq!(m.sync(&mut app).patches_written, 0, "nothing changed");

        for i in 0..=10 {
            wand(&mut app, i as f64 * 0.01, -0.1 + 0.02 * i as f64, 1);
        }
        let interactive_before = m.interactive.clone();
        let live = m.sync(&mut app);
        assert_eq!(live.shown, Detail::Interactive);
        assert!(live.preview && live.preview_carved, "{live:?}");
        assert!(
            !m.preview.patches().any(|(k, _)| k == PREVIEW_KEY),
            "no ribbon while the core carves the preview"
        );
        assert_ne!(
            m.interactive, interactive_before,
            "the live stroke is carved into the interactive detail"
        );
        assert!(app.session.doc.strokes().is_empty(), "but not applied yet");
        assert!(app.hud_lines()[0].contains("carving"));
        app.session
            .handle(&WandEvent::sample(0.15, WandSample::lost(1)))
            .unwrap();
        assert!(app.hud_lines()[1].contains("TRACKING LOST"));
        wand(&mut app, 0.16, 0.1, 0);
        assert_eq!(app.session.doc.strokes().len(), 1);
        let applied = m.sync(&mut app);
        assert_eq!(applied.shown, Detail::Final);
        assert!(!applied.preview);
        assert!(!m.preview.patches().any(|(k, _)| k == PREVIEW_KEY));
        assert!(
            applied.patches_written > 0
                && applied.patches_written < app.session.doc.patch_count(Detail::Final),
            "only the patches under the stroke are re-sent: {applied:?}"
        );
        assert_ne!(m.final_detail, untouched);
        app.session
            .handle(&WandEvent::command(0.2, Command::Undo))
            .unwrap();
        m.sync(&mut app);
        assert_eq!(m.final_detail, untouched, "undo restores the surface");

        // A head behind the screen is ignored rather than breaking the projection.
        let before = app.head;
        app.set_head(Some(HeadPose {
            position: DVec3::new(0.0, 1.0, -1.0),
            orientation: DQuat::IDENTITY,
        }));
        assert_eq!(app.head, before);
    }

    /// A stroke lifted off the sheet half-way is carved in two pieces, and the HUD and
    /// the operator log say so; a stroke in one piece adds no HUD line.
    #[test]
    fn a_stroke_in_pieces_shows_its_pieces_on_the_hud_and_in_the_log() {
        use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample, Tool};
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let target = app.session.doc.targets()[0].id;
        // 40 cm across the sheet; the middle 10 cm lifted 30 cm off it when `lift`.
        let stroke = |lift: bool| {
            let samples = (0..=40)
                .map(|i| {
                    let x = -0.2 + 0.01 * f64::from(i);
                    let off = if lift && (15..=25).contains(&i) {
                        0.3
                    } else {
                        0.0
                    };
                    StrokeSample {
                        t: 0.01 * f64::from(i),
                        position: default_surface_point(x, 1.17) + DVec3::Z * off,
                    }
                })
                .collect();
            Edit::Stroke(StrokeEdit::new(target, Tool::default(), samples))
        };
        let base = app.hud_lines().len();
        app.session.apply_committed(0.5, &stroke(false)).unwrap();
        assert_eq!(app.hud_lines().len(), base, "one piece: no line");
        app.session.apply_committed(1.0, &stroke(true)).unwrap();
        let hud = app.hud_lines();
        assert_eq!(hud.len(), base + 1);
        assert_eq!(
            hud[base],
            "last stroke: 2 pieces carved, 0 too short (dropped)"
        );
        let log = std::fs::read_to_string(dir.path().join(crate::session::OPLOG_FILE)).unwrap();
        let id = app.session.doc.strokes()[1].id;
        assert!(
            log.contains(&format!("stroke {id}: 2 pieces, 0 dropped")),
            "{log}"
        );
        assert_eq!(log.matches("\"marker\"").count(), 1, "{log}");
    }

    #[test]
    fn the_desktop_view_starts_framing_the_whole_sheet() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let (lo, hi) = app.document_bounds().unwrap();
        let views = app.views().unwrap();
        // Every corner of the sheet's box is in view, with a margin: the silhouette
        // shows against the background.
        for x in [lo.x, hi.x] {
            for y in [lo.y, hi.y] {
                for z in [lo.z, hi.z] {
                    let ndc = views.center.project(DVec3::new(x, y, z)).unwrap();
                    assert!(ndc.x.abs() < 0.95 && ndc.y.abs() < 0.95, "{ndc}");
                }
            }
        }
        // Orbiting moves the cameras; reset returns to the framed view.
        app.view.as_mut().unwrap().orbit(50.0, 20.0);
        assert_ne!(app.views().unwrap(), views);
        app.reset_view();
        assert_eq!(app.views().unwrap(), views);
    }

    #[test]
    fn the_tool_footprint_lies_on_the_target_under_the_wand() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        assert!(app.overlay_lines().is_empty(), "no wand yet");
        // 5 cm in front of the surface.
        let on = default_surface_point(0.05, 1.2);
        app.session
            .handle(&WandEvent::sample(
                0.0,
                WandSample::tracked(on + DVec3::Z * 0.05, DQuat::IDENTITY, 0),
            ))
            .unwrap();
        let tip = on + DVec3::Z * 0.05;
        let (foot, n) = app.project_on_target(tip).unwrap();
        // The closest point: on the surface, straight below the tip along the normal.
        assert_near!(foot.z, default_surface_point(foot.x, foot.y).z, POINT_EPS);
        assert_near!((tip - foot).normalize().dot(n), 1.0, COSINE_EPS);
        assert!(n.z > 0.9, "{n}");
        let lines = app.overlay_lines();
        let ring_colour = [1.0, 0.95, 0.3, 1.0];
        let ring: Vec<DVec3> = lines
            .iter()
            .filter(|l| l.color == ring_colour)
            .map(|l| DVec3::from(l.position.map(f64::from)))
            .collect();
        assert!(!ring.is_empty());
        let r = 0.5 * app.session.interaction.tool().width;
        // not a tolerance: 1e-6 is the square of the ring's 1 mm lift
        let lifted = (r * r + 1e-6).sqrt();
        for p in ring {
            assert_near!(p.distance(foot), lifted, CURSOR_RING_TOL);
            assert_near!(p.z, default_surface_point(p.x, p.y).z, CURSOR_RING_Z_TOL);
        }
        assert!(app.project_on_target(on + DVec3::Z * 2.0).is_none());
    }
}
