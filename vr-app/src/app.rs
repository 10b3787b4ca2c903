//! The display server's per-frame state, shared by the windowed, headless and demo
//! paths: session, screen and head, mesh synchronisation (including the live stroke
//! preview, through [`SceneState`]), the wand cursor overlay and the HUD. No GPU and no
//! window here.

use glam::{DQuat, DVec3};
use sculpt_core::interaction::{InteractionMode, Profile, StrokeMode, TargetIndex, WandSample};
use sculpt_core::sculpt::tessellate::Detail;

use crate::config::Config;
use crate::desktop_view::DesktopView;
use crate::desktop_wand::{Aim, DesktopPointer, EmulatedWand, PointerRig};
use crate::error::{VrError, VrResult};
use crate::feeder::Sink;
pub use crate::input::TrackingState;
use crate::projection::{HeadPose, Screen, StereoRig};
pub use crate::scene::{FOOTPRINT_REACH, MeshSinks, MeshSync, PREVIEW_KEY};
use crate::scene::{LineVertex, SceneState, Views};
use crate::session::Session;

/// The display server's session as the feeder's sink: wand events and ticks are
/// journalled and applied ([`Session::handle`], [`Session::tick`]), keys logged,
/// the head and tracking status kept for the views and the HUD.
impl Sink for AppState {
    type Error = VrError;

    fn wand(&mut self, ev: &sculpt_core::interaction::WandEvent) -> VrResult<()> {
        self.session.wand(ev)
    }

    fn tick(&mut self, t: f64) -> VrResult<()> {
        Sink::tick(&mut self.session, t)
    }

    fn tool(&self) -> sculpt_core::interaction::Tool {
        self.session.tool()
    }

    fn head(&mut self, head: Option<HeadPose>) {
        self.set_head(head);
    }

    fn tracking(&mut self, state: TrackingState) {
        self.tracking = state;
    }

    fn key(&mut self, t: f64, key: &str) {
        Sink::key(&mut self.session, t, key);
    }
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
    /// The desktop camera (desktop mode: no `[tracking]`), framing the document at
    /// start; `None` on a tracked wall, whose view is the physical one.
    pub view: Option<DesktopView>,
    /// Study mode (`--study`): the participant's trials, shown on the HUD.
    pub study: Option<crate::study::StudyRun>,
    /// The desktop pointer (the mouse as the wand, [`AppState::desktop_sample`]).
    pub pointer: DesktopPointer,
    fixed_head: HeadPose,
    scene: SceneState,
    /// The quadtree overlay's lines and the strokes they were drawn for.
    quadtree: Option<(Vec<u64>, Vec<LineVertex>)>,
    /// The other sculptors' wands (a cluster node sets them each frame, see
    /// [`crate::cluster::wand`]), drawn with the own cursor.
    pub peer_wand_lines: Vec<LineVertex>,
    /// Lattice mode: whether the cage is drawn ([`crate::lattice_view`]).
    pub cage: bool,
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
            pointer: DesktopPointer::default(),
            fixed_head: head,
            scene: SceneState::default(),
            quadtree: None,
            peer_wand_lines: Vec::new(),
            cage: true,
        };
        app.reset_view();
        let heat = app.config.display.heat_map;
        app.scene.paint_view().set_heat(heat);
        Ok(app)
    }

    /// The bounding box of the document's targets (their control nets, which hold
    /// the surfaces) and solids (their grids), display frame; `None` for an empty
    /// document.
    pub fn document_bounds(&self) -> Option<(DVec3, DVec3)> {
        let doc = &self.session.doc;
        doc.targets()
            .iter()
            .map(|t| t.surface.control_bounds())
            .chain(doc.solid_bounds())
            .filter(|(lo, hi)| lo.is_finite() && hi.is_finite())
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }

    /// Starts over with new, empty mesh sinks (a new renderer): the next
    /// [`AppState::sync_meshes`] writes the whole document again.
    pub fn new_sinks(&mut self) {
        self.scene = SceneState::default();
        self.session.forget_sinks();
    }

    /// Whether the desktop wand tip follows the surface under the pointer: in the
    /// stroke modes; sketching draws in the air, on the wand plane.
    pub fn pointer_follows_surface(&self) -> bool {
        self.session.interaction.mode() != InteractionMode::Sketch
    }

    /// Desktop mode: aims the emulated wand at the pointer `pixel` of a window of
    /// `size` pixels ([`DesktopPointer::aim`]: the tip on the surface under the
    /// pointer, through the desktop view) and gives the wand sample with `buttons`,
    /// oriented as the view. A pointer with no tip gives a lost sample.
    pub fn desktop_sample(
        &mut self,
        pixel: (f64, f64),
        size: (u32, u32),
        buttons: u32,
    ) -> WandSample {
        let follow = self.pointer_follows_surface();
        let rig = PointerRig {
            screen: &self.screen,
            eye: self.head.position,
            view: self.view.as_ref(),
        };
        let q = self.view.map_or(DQuat::IDENTITY, |v| v.rotation());
        if self.session.interaction.mode() == InteractionMode::Lattice {
            // Lattice mode: the tip snaps onto the cage (see `lattice_view`).
            let tip = self
                .pointer
                .ray(rig, pixel, size)
                .and_then(|(ray, facing)| {
                    let s = &self.session;
                    crate::lattice_view::lattice_tip(&s.doc, &s.interaction, &ray, facing)
                });
            return match tip {
                Some(p) => WandSample::tracked(p, q, buttons),
                None => WandSample::lost(buttons),
            };
        }
        let aim = self
            .pointer
            .aim(&self.session.doc, rig, pixel, size, follow);
        match aim.tip() {
            Some(p) => WandSample::tracked(p, q, buttons),
            None => WandSample::lost(buttons),
        }
    }

    /// Desktop mode: the target under the pointer's last aim when it is not the
    /// selected one (a press there selects it first), as its position.
    pub fn pointer_target_to_select(&self) -> Option<TargetIndex> {
        let id = self.pointer.last.as_ref().and_then(Aim::target)?;
        // Positions as the interaction counts them: the sheets, then the solids.
        let ids = self.session.doc.stroke_target_ids();
        let position = ids.iter().position(|&t| t == id)?;
        let index = TargetIndex(u32::try_from(position).ok()?);
        (index != self.session.interaction.target_position()).then_some(index)
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
        let (doc, view, interaction) = self.session.draw_parts();
        self.scene
            .sync_meshes(doc, view, interaction, facing, sinks)
    }

    /// Shows the first painted scalar as a heat map, or the painted colour again
    /// (the `T` key; [`crate::paint_view`]).
    pub fn toggle_heat_map(&mut self) {
        self.scene.paint_view().toggle_heat();
    }

    /// Whether the heat map is shown.
    pub fn heat_map(&self) -> bool {
        self.scene.paint_view_ref().heat()
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
        if self.cage {
            let s = &self.session;
            crate::lattice_view::cage_lines(&s.doc, &s.interaction, &mut lines);
        }
        lines
    }

    /// The UV quadtree overlay ([`crate::quadtree`]) of the document at final detail,
    /// the maps of the session's view, rebuilt only when the document changed.
    fn quadtree_lines(&mut self) -> &[LineVertex] {
        let doc = &self.session.doc;
        // Every edit (a deformation too) raises the revision.
        let key = vec![doc.revision()];
        if self.quadtree.as_ref().is_none_or(|(k, _)| *k != key) {
            let mut lines = Vec::new();
            let view = self.session.view();
            crate::quadtree::quadtree_lines(doc, view, Detail::Final, &mut lines);
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
    /// participant, method and trial; in desktop mode where the pointer is (on which
    /// target, how high, or off the surface); and the latest refusal, in words, for
    /// [`REFUSAL_SHOWN_S`](crate::session::REFUSAL_SHOWN_S) seconds.
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
                "{mode} {profile} {:.1}x{:.1}mm  target {}/{} {}{live}",
                t.width * 1000.0,
                t.depth * 1000.0,
                i.target_position().0 + 1,
                i.target_count(),
                crate::solid_view::target_kind(&self.session.doc, i.target())
            ),
            format!(
                "{tracking}  {:.0} fps  ops {}",
                self.fps,
                self.session.operations()
            ),
        ];
        lines.extend(self.study.as_ref().map(crate::study::StudyRun::hud_line));
        lines.extend(crate::lattice_view::hud_line(i, self.cage));
        lines.extend(self.scene.paint_view_ref().hud_line(&self.session.doc));
        if self.view.is_some() {
            let follow = self.pointer_follows_surface();
            lines.extend(self.pointer.hud_line(&self.session.doc, t, follow));
        }
        if let Some(r) = self.session.refusal_at(self.session.time()) {
            lines.push(format!("REFUSED  {}", r.words));
        }
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
    use crate::tolerance::{CURSOR_RING_TOL, CURSOR_RING_Z_TOL};
    use glam::DQuat;
    use sculpt_core::assert_near;
    use sculpt_core::editor::default_surface_point;
    use sculpt_core::interaction::{Command, WandEvent, WandSample};
    use sculpt_core::mesh::PatchMesh;
    use sculpt_core::sculpt::document::snap_distance;
    use sculpt_core::sculpt::tessellate::Detail;
    use sculpt_core::tolerance::{COSINE_EPS, POINT_EPS, RAY_HIT_TOL};

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

    /// A fresh tessellation of `doc` at `detail` into an empty mesh.
    fn fresh(doc: &sculpt_core::sculpt::document::Document, detail: Detail) -> PatchMesh {
        let mut mesh = PatchMesh::new();
        sculpt_core::sculpt::view::DocumentView::new().tessellate(doc, detail, &mut mesh);
        mesh
    }

    /// Issue 35 item 1: the targets follow a lattice drag before it is released. The
    /// interactive detail shows the document bent by the edit a release would apply
    /// (the same mesh as a fresh tessellation of a copy bent that way, groove and all),
    /// the document itself is untouched until the release, and afterwards (applied, or
    /// dropped as a click) the interactive detail is the document's again.
    #[test]
    fn a_lattice_drag_bends_the_targets_live_and_the_document_comes_back() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let mut app = AppState::new(cfg).unwrap();
        let mut m = Meshes {
            final_detail: PatchMesh::new(),
            interactive: PatchMesh::new(),
            preview: PatchMesh::new(),
        };
        for i in 0..=10 {
            wand(&mut app, i as f64 * 0.01, -0.1 + 0.02 * i as f64, 1);
        }
        wand(&mut app, 0.11, 0.1, 0);
        assert_eq!(app.session.doc.strokes().len(), 1);
        m.sync(&mut app);
        app.session
            .handle(&WandEvent::command(
                0.2,
                Command::SetMode {
                    mode: InteractionMode::Lattice,
                },
            ))
            .unwrap();
        assert!(!m.sync(&mut app).preview_bent);
        let flat = m.interactive.clone();
        assert_eq!(flat, fresh(&app.session.doc, Detail::Interactive));
        let (doc, _, interaction) = app.session.draw_parts();
        let cage = crate::lattice_view::rest_cage(doc, interaction).unwrap();
        let grab = cage
            .control_points()
            .into_iter()
            .max_by(|a, b| (a.y + a.z).total_cmp(&(b.y + b.z)))
            .unwrap();
        let drag = |app: &mut AppState, t: f64, p: DVec3, buttons: u32| {
            app.session
                .handle(&WandEvent::sample(
                    t,
                    WandSample::tracked(p, DQuat::IDENTITY, buttons),
                ))
                .unwrap();
        };
        drag(&mut app, 0.3, grab, 0);
        drag(&mut app, 0.31, grab, 1);
        for k in 1..=4 {
            let p = grab + DVec3::new(0.0, 0.0, 0.02 * f64::from(k));
            drag(&mut app, 0.31 + 0.01 * f64::from(k), p, 1);
            let live = m.sync(&mut app);
            assert!(live.preview_bent && live.preview, "{live:?}");
            assert_eq!(live.shown, Detail::Interactive);
            let edit = app.session.interaction.live_deform().unwrap();
            let mut bent = app.session.doc.clone();
            assert!(
                sculpt_core::editor::apply_deform(&mut bent, &edit)
                    .unwrap()
                    .changed()
            );
            assert!(
                m.interactive == fresh(&bent, Detail::Interactive),
                "step {k}: the interactive detail is the bent copy"
            );
            assert!(app.session.doc.deforms().is_empty(), "not applied yet");
        }
        assert_ne!(m.interactive, flat);
        // Released: one deformation; the interactive detail is the document's.
        drag(&mut app, 0.4, grab + DVec3::new(0.0, 0.0, 0.08), 0);
        assert_eq!(app.session.doc.deforms().len(), 1);
        let applied = m.sync(&mut app);
        assert!(!applied.preview_bent && !applied.preview, "{applied:?}");
        assert_eq!(applied.shown, Detail::Final);
        assert!(m.interactive == fresh(&app.session.doc, Detail::Interactive));
        assert!(m.final_detail == fresh(&app.session.doc, Detail::Final));
        // A drag out and back to where it grabbed is a click: nothing is applied, and
        // the preview it showed on the way goes.
        let bent_once = m.interactive.clone();
        let (doc, _, interaction) = app.session.draw_parts();
        let grab = crate::lattice_view::rest_cage(doc, interaction)
            .unwrap()
            .control_points()[0];
        drag(&mut app, 0.5, grab, 0);
        drag(&mut app, 0.51, grab, 1);
        drag(&mut app, 0.52, grab + DVec3::new(0.05, 0.0, 0.0), 1);
        assert!(m.sync(&mut app).preview_bent);
        assert_ne!(m.interactive, bent_once);
        drag(&mut app, 0.53, grab, 1);
        drag(&mut app, 0.54, grab, 0);
        assert_eq!(app.session.doc.deforms().len(), 1);
        assert!(!m.sync(&mut app).preview_bent);
        assert!(m.interactive == bent_once, "the document, as it was");
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

    fn desktop_app(dir: &std::path::Path) -> AppState {
        let mut cfg = Config::default();
        cfg.files.dir = dir.to_path_buf();
        AppState::new(cfg).unwrap()
    }

    /// A left drag of the desktop pointer from `from` to `to` (pixels of a `size`
    /// window), `steps` frames apart by 1/60 s from `t0`, as the window feeds it.
    fn drag(
        app: &mut AppState,
        size: (u32, u32),
        from: (f64, f64),
        to: (f64, f64),
        t0: f64,
    ) -> f64 {
        let steps = 30;
        let mut t = t0;
        for k in 0..=steps + 1 {
            let s = f64::from(k.min(steps)) / f64::from(steps);
            let pixel = (from.0 + (to.0 - from.0) * s, from.1 + (to.1 - from.1) * s);
            let buttons = u32::from(k <= steps);
            let sample = app.desktop_sample(pixel, size, buttons);
            app.session.handle(&WandEvent::sample(t, sample)).unwrap();
            t += 1.0 / 60.0;
        }
        t
    }

    /// Issue 30: the desktop wand tip lay on a plane at a fixed depth, which meets the
    /// curved default sheet along one line only, so every drag across it was refused
    /// ("the stroke does not lie on the surface"). Now the tip follows the surface
    /// under the pointer: the three drags (across the centre, near the left
    /// edge, diagonally over the bulge) each carve a stroke.
    #[test]
    fn desktop_drags_across_the_default_sheet_carve() {
        let dir = tempfile::tempdir().unwrap();
        let mut app = desktop_app(dir.path());
        let size = (1280, 720);
        let (w, h) = (f64::from(size.0), f64::from(size.1));
        let drags = [
            ((0.35 * w, 0.5 * h), (0.65 * w, 0.5 * h)),
            ((0.2 * w, 0.3 * h), (0.22 * w, 0.7 * h)),
            ((0.35 * w, 0.3 * h), (0.6 * w, 0.65 * h)),
        ];
        let mut t = 0.0;
        for (k, (from, to)) in drags.into_iter().enumerate() {
            t = drag(&mut app, size, from, to, t) + 0.5;
            assert_eq!(
                app.session.doc.strokes().len(),
                k + 1,
                "drag {k}: {:?} {:?}",
                app.session.last_refusal,
                app.pointer.last
            );
            // Every sample of the stroke lies on the sheet.
            let record = app.session.doc.strokes().last().unwrap();
            for (_, p) in &record.input.samples {
                let on = default_surface_point(p.x, p.y);
                assert_near!(p.z, on.z, RAY_HIT_TOL);
            }
        }
        assert_eq!(app.session.rejected, 0);
        assert!(app.session.refusal_at(t).is_none());
        let hud = app.hud_lines().join("\n");
        assert!(hud.contains("pointer on target 1, touching"), "{hud}");
        // The old wand, a plane through the front of the sheet's control box, is what
        // sketch mode still uses: along the same centre drag it stays farther from the
        // sheet than a stroke's samples may be (so the core refused the stroke).
        let mut plane = desktop_app(tempfile::tempdir().unwrap().path());
        let doc = plane.session.doc.clone();
        let snap = snap_distance(
            plane.session.interaction.tool(),
            doc.targets()[0].surface.size(),
        );
        let nearest = (0..=10)
            .map(|k| {
                let rig = PointerRig {
                    screen: &plane.screen,
                    eye: plane.head.position,
                    view: plane.view.as_ref(),
                };
                let x = (0.35 + 0.03 * f64::from(k)) * w;
                let p = plane.pointer.aim(&doc, rig, (x, 0.5 * h), size, false);
                let p = p.tip().unwrap();
                (p.z - default_surface_point(p.x, p.y).z).abs()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest > snap,
            "the plane comes within {nearest} m of the sheet"
        );
    }

    #[test]
    fn the_wheel_lifts_the_tip_off_the_surface_along_the_ray() {
        let dir = tempfile::tempdir().unwrap();
        let mut app = desktop_app(dir.path());
        let size = (800, 600);
        let pixel = (420.0, 280.0);
        let on = app.desktop_sample(pixel, size, 0).position;
        assert_near!(on.z, default_surface_point(on.x, on.y).z, RAY_HIT_TOL);
        // Three notches up: 15 mm towards the eye, on the same ray (so the pointer
        // still shows it at the same pixel).
        app.pointer.scroll(3.0, app.pointer_follows_surface());
        let up = app.desktop_sample(pixel, size, 0).position;
        assert_near!(up.distance(on), 0.015, RAY_HIT_TOL);
        let views = app.views().unwrap();
        assert_near!(
            views.center.project(up).unwrap().to_array(),
            views.center.project(on).unwrap().to_array(),
            RAY_HIT_TOL
        );
        assert!(app.hud_lines().join(" ").contains("hovering 15 mm"));
        // Far above the snap distance the HUD says the wand will not carve.
        app.pointer.scroll(1000.0, true);
        assert!(app.hud_lines().join(" ").contains("too high to carve"));
        app.pointer.scroll(-1000.0, true);
        app.desktop_sample(pixel, size, 0);
        assert!(app.hud_lines().join(" ").contains("pressing 50 mm"));
        // Off the sheet (the window's corner) the tip stays on the plane through the
        // last hit, facing the viewer.
        let air = app.desktop_sample((2.0, 2.0), size, 0).position;
        assert!(matches!(app.pointer.last, Some(Aim::Air { .. })));
        let facing = app.facing();
        let last_hit = {
            app.pointer.wand.offset = 0.0;
            app.desktop_sample(pixel, size, 0).position
        };
        app.desktop_sample((2.0, 2.0), size, 0);
        assert_near!((air - last_hit).dot(facing), 0.0, RAY_HIT_TOL);
        assert!(
            app.hud_lines()
                .join(" ")
                .contains("pointer off the surface")
        );
    }

    /// Issue 30: a refusal showed only in the log. The HUD now says it in words, for
    /// a while: an off-surface stroke, and a stroke too short to count.
    #[test]
    fn refusals_are_shown_on_the_hud_in_words() {
        let dir = tempfile::tempdir().unwrap();
        let mut app = desktop_app(dir.path());
        let far = DVec3::new(0.0, 1.17, 0.5);
        for (k, x) in [0.0, 0.05, 0.1, 0.0].into_iter().enumerate() {
            let buttons = u32::from(k < 3);
            let p = far + DVec3::X * x;
            app.session
                .handle(&WandEvent::sample(
                    0.1 * k as f64,
                    WandSample::tracked(p, DQuat::IDENTITY, buttons),
                ))
                .unwrap();
        }
        assert_eq!(app.session.rejected, 1);
        let hud = app.hud_lines().join("\n");
        assert!(
            hud.contains("REFUSED  stroke rejected: the stroke does not lie on the surface"),
            "{hud}"
        );
        // It goes away after a while.
        app.session.tick(10.0).unwrap();
        assert!(!app.hud_lines().join(" ").contains("REFUSED"));
        // A 2 mm drag is dropped by the interaction, and says so with its length.
        let p = default_surface_point(0.0, 1.17);
        for (k, x) in [0.0, 0.002, 0.002].into_iter().enumerate() {
            app.session
                .handle(&WandEvent::sample(
                    11.0 + 0.1 * k as f64,
                    WandSample::tracked(p + DVec3::X * x, DQuat::IDENTITY, u32::from(k < 2)),
                ))
                .unwrap();
        }
        let hud = app.hud_lines().join("\n");
        assert!(
            hud.contains("REFUSED  stroke dropped: 2.0 mm long, at least 5.0 mm needed"),
            "{hud}"
        );
    }
}
