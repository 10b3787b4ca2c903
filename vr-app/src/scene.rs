//! What one frame shows, as plain values: the [`Views`] (cameras), overlay
//! [`LineVertex`] lines, HUD text ([`FrameInput`]) and the meshes of a document and a
//! live interaction, written into any [`MeshSinks`] by [`SceneState`]. No GPU, no
//! window and no session here: the display server (`app::AppState`)
//! and `replay --render` both describe their frames with these, and the
//! `render::Renderer` draws them.

use glam::DVec3;
use sculpt_core::interaction::Interaction;
use sculpt_core::mesh::{MeshSink, PatchKey};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;

use crate::error::VrResult;
use crate::lattice_view::LatticePreview;
pub use crate::line_vertex::LineVertex;
use crate::paint_view::PaintView;
use crate::preview::write_stroke_ribbon;
use crate::projection::{EyeCamera, HeadPose, Screen, StereoRig, kooima};
use crate::solid_view::SolidView;

/// Patch key of the live stroke preview (in the preview sink).
pub const PREVIEW_KEY: PatchKey = PatchKey::MAX - 1;

/// Patches whose keys agree above these low bits share a GPU batch (the renderer's
/// mesh store groups them so).
pub const BATCH_SHIFT: u32 = 6;

/// What a drawn surface is, for its colour and outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SurfaceClass {
    /// A target surface (with its carved strokes).
    Target,
    /// A target made by a sketch.
    Sketched,
    /// The selected target, outlined (only when there are several targets).
    Selected,
    /// The live stroke ribbon.
    Preview,
}

impl SurfaceClass {
    /// The class number written into the geometry image (0 is nothing or an overlay).
    pub fn id(self) -> f32 {
        match self {
            SurfaceClass::Target => 1.0,
            SurfaceClass::Sketched => 2.0,
            SurfaceClass::Selected => 3.0,
            SurfaceClass::Preview => 4.0,
        }
    }

    /// Every class, in the order of the renderer's material bind groups.
    pub const ALL: [SurfaceClass; 4] = [
        SurfaceClass::Target,
        SurfaceClass::Sketched,
        SurfaceClass::Selected,
        SurfaceClass::Preview,
    ];

    /// Index into [`Self::ALL`].
    pub fn index(self) -> usize {
        match self {
            SurfaceClass::Target => 0,
            SurfaceClass::Sketched => 1,
            SurfaceClass::Selected => 2,
            SurfaceClass::Preview => 3,
        }
    }
}

/// Which targets are drawn how: the selected one outlined (set it only when there
/// are several targets), sketched ones tinted. Target indices as in the document.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SurfaceClasses {
    /// The selected target, outlined in amber.
    pub selected: Option<u32>,
    /// Targets made by sketching.
    pub sketched: Vec<u32>,
}

impl SurfaceClasses {
    /// The class of the document batch `batch` (a patch key shifted right by
    /// `BATCH_SHIFT` bits (the renderer's batches)): target patches carry their target's index in the
    /// key's high 32 bits; stroke surfaces (key's top bit set) count as targets.
    pub fn of_batch(&self, batch: u64) -> SurfaceClass {
        let key = batch << BATCH_SHIFT;
        if key >> 63 == 1 {
            return SurfaceClass::Target;
        }
        let target = (key >> 32) as u32;
        if self.selected == Some(target) {
            SurfaceClass::Selected
        } else if self.sketched.contains(&target) {
            SurfaceClass::Sketched
        } else {
            SurfaceClass::Target
        }
    }
}

/// How far (metres) the wand tip may be from the selected target for the tool
/// footprint to be drawn on it.
pub const FOOTPRINT_REACH: f64 = 0.25;

/// The three cameras of a frame: both eyes and the head centre (for mono).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Views {
    /// Left eye.
    pub left: EyeCamera,
    /// Right eye.
    pub right: EyeCamera,
    /// Head centre.
    pub center: EyeCamera,
}

impl Views {
    /// The cameras for `head` looking through `screen`.
    pub fn new(rig: &StereoRig, screen: &Screen, head: &HeadPose) -> VrResult<Self> {
        let (left, right) = rig.eye_cameras(screen, head)?;
        let center = kooima(screen, head.position, rig.near, rig.far)?;
        Ok(Self {
            left,
            right,
            center,
        })
    }
}

/// What one frame shows besides the meshes.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// The cameras.
    pub views: &'a Views,
    /// Overlay line segments (pairs of vertices).
    pub lines: &'a [LineVertex],
    /// HUD text lines.
    pub hud: &'a [String],
}

/// Where [`SceneState::sync_meshes`] writes: the document at each detail (one sink per
/// detail, as `Document::tessellate` requires) and the live preview.
pub struct MeshSinks<'a> {
    /// The document at [`Detail::Final`].
    pub final_detail: &'a mut dyn MeshSink,
    /// The document at [`Detail::Interactive`].
    pub interactive: &'a mut dyn MeshSink,
    /// The live stroke preview.
    pub preview: &'a mut dyn MeshSink,
}

/// What [`SceneState::sync_meshes`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshSync {
    /// The detail to draw now: interactive while a stroke or sketch is live, final
    /// otherwise.
    pub shown: Detail,
    /// Document patches written (only changed ones are).
    pub patches_written: usize,
    /// Whether a preview is shown.
    pub preview: bool,
    /// Whether the preview is the real groove or ridge, carved by the core into the
    /// interactive detail (otherwise it is the ribbon along the wand path, shown while
    /// the core rejects the stroke so far: too short, or off the surface).
    pub preview_carved: bool,
    /// Whether the interactive detail shows the targets bent by a live lattice drag
    /// ([`LatticePreview`]).
    pub preview_bent: bool,
}

/// What a scene has written into its [`MeshSinks`] so far: the document's
/// tessellation state lives in the session's [`DocumentView`], this keeps the rest (whether the first
/// full write happened, the live preview). The tool footprint projects through the
/// target's own inverter, which the document builds once and shares. One per set of
/// sinks: a fresh one for empty sinks.
#[derive(Debug, Default)]
pub struct SceneState {
    primed: bool,
    preview_shown: bool,
    /// Samples of the live stroke last handed to `DocumentView::set_preview` (0: none).
    previewed_samples: usize,
    preview_carved: bool,
    /// The live lattice drag's bent targets in the interactive sink.
    lattice: LatticePreview,
    /// The solid targets' blocks in both document sinks.
    solids: SolidView,
    /// The paint shading given to the document's sinks.
    paint: PaintView,
}

impl SceneState {
    /// Brings the meshes of `doc` with `interaction` live up to date in `sinks`: the
    /// document's changed patches at the detail to show (interactive while a gesture
    /// is live, final otherwise; the first call writes both) and the preview of a live
    /// stroke (carved by the core, or a ribbon along the wand path facing `facing`)
    /// or of a live lattice drag (the targets bent, [`LatticePreview`]). Only patches
    /// the document marks changed are written, and patches of removed targets are
    /// removed.
    pub fn sync_meshes(
        &mut self,
        doc: &Document,
        view: &mut DocumentView,
        interaction: &Interaction,
        facing: DVec3,
        sinks: MeshSinks<'_>,
    ) -> MeshSync {
        let live = interaction.gesture_active();
        let shown = if live {
            Detail::Interactive
        } else {
            Detail::Final
        };
        let live_stroke = interaction.live_stroke().filter(|s| s.samples.len() >= 2);
        // The stroke being drawn is carved into the interactive detail by the core, as
        // it will be once applied; re-done only when it gained samples.
        match &live_stroke {
            Some(stroke) if stroke.samples.len() != self.previewed_samples => {
                self.previewed_samples = stroke.samples.len();
                // A NURBS target or a solid (whose groove the solid view shows).
                let target = doc
                    .target(stroke.target)
                    .map(|t| t.id)
                    .or_else(|| doc.solid(stroke.target).map(|s| s.id));
                self.preview_carved = target.is_some_and(|id| {
                    view.set_preview(doc, id, &sculpt_core::editor::stroke_input(stroke))
                        .is_ok()
                });
            }
            Some(_) => {}
            None if self.previewed_samples > 0 => {
                view.clear_preview();
                self.previewed_samples = 0;
                self.preview_carved = false;
            }
            None => {}
        }
        self.paint
            .sync(doc, [&mut *sinks.final_detail, &mut *sinks.interactive]);
        let mut written = 0;
        if !self.primed || shown == Detail::Interactive {
            written += view
                .tessellate(doc, Detail::Interactive, sinks.interactive)
                .patches_written;
        }
        if !self.primed || shown == Detail::Final {
            written += view
                .tessellate(doc, Detail::Final, sinks.final_detail)
                .patches_written;
        }
        self.primed = true;
        written += self.solids.sync(
            doc,
            view.solid_preview(),
            sinks.final_detail,
            sinks.interactive,
        );
        // A lattice drag bends a copy of the document over the interactive detail;
        // when it ends the document is put back there.
        let preview_bent = self.lattice.sync(doc, view, interaction, sinks.interactive);
        match live_stroke {
            Some(stroke) if !self.preview_carved => {
                write_stroke_ribbon(&stroke, facing, PREVIEW_KEY, sinks.preview);
                self.preview_shown = true;
            }
            _ if self.preview_shown => {
                sinks.preview.remove_patch(PREVIEW_KEY);
                self.preview_shown = false;
            }
            _ => {}
        }
        MeshSync {
            shown,
            patches_written: written,
            preview: self.preview_shown || self.preview_carved || preview_bent,
            preview_carved: self.preview_carved,
            preview_bent,
        }
    }

    /// The paint shading: the heat-map switch ([`PaintView`]).
    pub fn paint_view(&mut self) -> &mut PaintView {
        &mut self.paint
    }

    /// The paint shading, to read.
    pub fn paint_view_ref(&self) -> &PaintView {
        &self.paint
    }

    /// The closest point of the selected target to `p` and the surface normal there,
    /// when `p` is within [`FOOTPRINT_REACH`] of it.
    pub fn project_on_target(
        &mut self,
        doc: &Document,
        interaction: &Interaction,
        p: DVec3,
    ) -> Option<(DVec3, DVec3)> {
        let target = doc.target(interaction.target())?;
        let hit = target.target_surface().inverter().closest_point(p);
        let n = target.surface.normal(hit.uv_in_knots.x, hit.uv_in_knots.y);
        (hit.distance <= FOOTPRINT_REACH && hit.point.is_finite() && n.is_finite())
            .then_some((hit.point, n))
    }

    /// The wand cursor with the tool footprint projected onto the selected target (a
    /// circle of the tool width in the surface's tangent plane at the closest point,
    /// joined to the tip), or around the tip when the target is out of reach; and the
    /// rows of a live sketch.
    pub fn overlay_lines(
        &mut self,
        doc: &Document,
        interaction: &Interaction,
        screen: &Screen,
    ) -> Vec<LineVertex> {
        let mut lines = Vec::new();
        let Some((_, tip, q)) = interaction.wand() else {
            return lines;
        };
        let r = 0.5 * interaction.tool().width;
        let (vr, vu, vn) = screen.basis();
        let (centre, e1, e2, lift) = match self.project_on_target(doc, interaction, tip) {
            Some((foot, n)) => {
                let e1 = if n.cross(vu).length_squared() > crate::tolerance::PARALLEL_SIN2_EPS {
                    vu.cross(n).normalize()
                } else {
                    vr
                };
                (foot, e1, n.cross(e1).normalize(), n * 0.001)
            }
            None => (tip, vr, vu, -vn * 0.001),
        };
        let ring: Vec<DVec3> = (0..=24)
            .map(|k| {
                let a = k as f64 / 24.0 * std::f64::consts::TAU;
                centre + (e1 * a.cos() + e2 * a.sin()) * r + lift
            })
            .collect();
        let i = interaction;
        cursor_lines(tip, q * DVec3::NEG_Z, &ring, i.gesture_active(), &mut lines);
        if centre != tip {
            let c = [1.0, 0.95, 0.3, 0.6];
            lines.push(LineVertex::new(tip, c));
            lines.push(LineVertex::new(centre, c));
        }
        if let Some(rows) = i.live_sketch() {
            let c = [0.55, 0.9, 0.55, 1.0];
            for row in rows {
                for w in row.windows(2) {
                    lines.push(LineVertex::new(w[0], c));
                    lines.push(LineVertex::new(w[1], c));
                }
            }
            for pair in rows.windows(2) {
                for (a, b) in pair[0].iter().zip(&pair[1]) {
                    lines.push(LineVertex::new(*a, c));
                    lines.push(LineVertex::new(*b, c));
                }
            }
        }
        lines
    }
}

/// Overlay lines for the wand cursor: a small 3D cross at the tip, the wand's pointing
/// axis, and the tool footprint outline (already in the display frame).
pub fn cursor_lines(
    tip: DVec3,
    axis: DVec3,
    footprint: &[DVec3],
    active: bool,
    out: &mut Vec<LineVertex>,
) {
    if !tip.is_finite() {
        return;
    }
    let color = if active {
        [1.0, 0.55, 0.15, 1.0]
    } else {
        [0.3, 0.9, 1.0, 1.0]
    };
    let s = 0.015;
    for d in [DVec3::X, DVec3::Y, DVec3::Z] {
        out.push(LineVertex::new(tip - d * s, color));
        out.push(LineVertex::new(tip + d * s, color));
    }
    if axis.is_finite() && axis.length_squared() > 0.0 {
        out.push(LineVertex::new(tip, color));
        out.push(LineVertex::new(
            tip - axis.normalize() * 0.12,
            [0.7, 0.7, 0.7, 1.0],
        ));
    }
    let ring = [1.0, 0.95, 0.3, 1.0];
    for w in footprint.windows(2) {
        if w[0].is_finite() && w[1].is_finite() {
            out.push(LineVertex::new(w[0], ring));
            out.push(LineVertex::new(w[1], ring));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_take_the_class_of_their_target() {
        let classes = SurfaceClasses {
            selected: Some(2),
            sketched: vec![1, 2],
        };
        let batch = |target: u64, root: u64| ((target << 32) | root) >> BATCH_SHIFT;
        assert_eq!(classes.of_batch(batch(0, 0)), SurfaceClass::Target);
        assert_eq!(classes.of_batch(batch(0, 200)), SurfaceClass::Target);
        assert_eq!(classes.of_batch(batch(1, 63)), SurfaceClass::Sketched);
        // Selection wins over the sketch tint: the outline is what marks it.
        assert_eq!(classes.of_batch(batch(2, 64)), SurfaceClass::Selected);
        // Stroke surfaces (top key bit) are drawn as their targets are.
        let stroke = sculpt_core::sculpt::document::stroke_patch_key(7) >> BATCH_SHIFT;
        assert_eq!(classes.of_batch(stroke), SurfaceClass::Target);
        assert_eq!(
            SurfaceClasses::default().of_batch(batch(1, 0)),
            SurfaceClass::Target
        );
        for (i, c) in SurfaceClass::ALL.iter().enumerate() {
            assert_eq!(c.index(), i);
        }
    }
}
