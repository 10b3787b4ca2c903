//! Lattice mode on the screen: the cage (the lattice around the document's targets,
//! [`sculpt_core::lattice`]) drawn as lines, and where the desktop pointer puts the
//! wand tip so that a drag grabs a cage control point.
//!
//! The interaction does the rest ([`InteractionMode::Lattice`]): a drag from a control
//! point is one [`Edit::Deform`](sculpt_core::interaction::Edit::Deform), journalled
//! and undone like a stroke. While the drag is live the cage is drawn with the grabbed
//! group moved.
//!
//! While the drag is live the targets bend with it too ([`LatticePreview`]): a copy of
//! the document is deformed by the edit a release would apply and drawn at interactive
//! detail in place of the document, so the sculptor sees the bent surfaces, grooves
//! and all, before letting go.
//!
//! - **Desktop**: the pointer snaps the tip onto the first cage control point along its ray
//!   (within [`PICK_M`]); while the button is held the tip slides on the plane through
//!   the grabbed point facing the viewer ([`lattice_tip`]).
//! - **Wall and headset**: the tracked tip is the wand; the cage is drawn the same way.
//!
//! ```
//! use sculpt_core::editor::default_document;
//! use sculpt_core::interaction::{Interaction, InteractionConfig, InteractionMode, Tool};
//! let doc = default_document();
//! let lattice = Interaction::new(InteractionConfig::default(), InteractionMode::Lattice, Tool::default());
//! let mut lines = Vec::new();
//! vr_app::lattice_view::cage_lines(&doc, &lattice, &mut lines);
//! // 4 x 4 x 4 points: 144 edges and a cross on each of the 64 points.
//! assert_eq!(lines.len(), 2 * (144 + 3 * 64));
//! ```

use std::collections::BTreeSet;

use glam::DVec3;
use sculpt_core::editor;
use sculpt_core::interaction::{Interaction, InteractionMode};
use sculpt_core::lattice::{DeformEdit, Lattice};
use sculpt_core::mesh::{MeshSink, MeshVertex, PatchKey};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::ray::Ray;
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;

use crate::desktop_wand::plane_hit;
use crate::line_vertex::LineVertex;

/// How close (metres) the pointer's ray must pass a cage control point to snap onto
/// it.
pub const PICK_M: f64 = 0.03;
/// Half the size of the cross drawn on each control point (metres).
const CROSS_M: f64 = 0.006;
/// The cage's colour (linear RGBA).
const CAGE: [f32; 4] = [0.35, 0.75, 1.0, 0.7];
/// The grabbed group's colour.
const GROUP: [f32; 4] = [1.0, 0.55, 0.15, 1.0];

/// The lattice around every target of `doc` in the shape `interaction` uses, as it is
/// at rest; `None` for a document without targets.
pub fn rest_cage(doc: &Document, interaction: &Interaction) -> Option<Lattice> {
    let surfaces: Vec<_> = doc.targets().iter().map(|t| &t.surface).collect();
    Lattice::around(interaction.lattice_spec(), &surfaces).ok()
}

/// The cage as it is drawn now: at rest, or with the live drag's group moved; and the
/// group (flat indices) being dragged.
fn live_cage(doc: &Document, interaction: &Interaction) -> Option<(Lattice, Vec<usize>)> {
    let mut lattice = rest_cage(doc, interaction)?;
    let mut group = Vec::new();
    if let Some((grab, moved)) = interaction.live_lattice()
        && let Ok(g) = lattice.group(grab, interaction.lattice_radius())
        && lattice.displace(&g, moved).is_ok()
    {
        group = g;
    }
    Some((lattice, group))
}

/// Appends the cage's lines (pairs of vertices: its edges and a cross on each control
/// point, the dragged group highlighted) when `interaction` is in lattice mode.
pub fn cage_lines(doc: &Document, interaction: &Interaction, out: &mut Vec<LineVertex>) {
    if interaction.mode() != InteractionMode::Lattice {
        return;
    }
    let Some((lattice, group)) = live_cage(doc, interaction) else {
        return;
    };
    for (a, b) in lattice.cage_edges() {
        out.push(LineVertex::new(a, CAGE));
        out.push(LineVertex::new(b, CAGE));
    }
    for (flat, p) in lattice.control_points().into_iter().enumerate() {
        let color = if group.contains(&flat) { GROUP } else { CAGE };
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            out.push(LineVertex::new(p - axis * CROSS_M, color));
            out.push(LineVertex::new(p + axis * CROSS_M, color));
        }
    }
}

/// The desktop wand tip in lattice mode for the pointer's `ray` (display frame) and
/// the viewer's `facing` direction: during a drag, on the plane through the grabbed
/// point facing the viewer; otherwise on the first cage control point along the ray
/// that it passes within [`PICK_M`] of, else on the plane through the cage's centre (a press
/// there grabs nothing, and the session says so). `None` when the ray misses every
/// plane.
pub fn lattice_tip(
    doc: &Document,
    interaction: &Interaction,
    ray: &Ray,
    facing: DVec3,
) -> Option<DVec3> {
    if let Some((grab, _)) = interaction.live_lattice() {
        return plane_hit(ray, grab, facing);
    }
    let lattice = rest_cage(doc, interaction)?;
    // Of the points the ray passes within reach, the first along it (the one in
    // front, as the viewer sees the cage).
    let first = lattice
        .control_points()
        .into_iter()
        .filter_map(|p| {
            let s = (p - ray.origin).dot(ray.dir);
            (s > 0.0 && ray.at(s).distance(p) <= PICK_M).then_some((s, p))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0));
    match first {
        Some((_, p)) => Some(p),
        None => {
            let (lo, hi) = lattice.bounds();
            plane_hit(ray, 0.5 * (lo + hi), facing)
        }
    }
}

/// The live preview of a lattice drag in the interactive-detail sink: the document
/// bent by the deformation a release would apply ([`Interaction::live_deform`]),
/// written over the document's own patches while the drag is live, and the document
/// put back when it ends. One per interactive sink, like
/// [`SceneState`](crate::scene::SceneState).
#[derive(Debug, Default)]
pub struct LatticePreview {
    /// The deformation last tried (drawn when [`Self::bent`]).
    tried: Option<DeformEdit>,
    /// Whether the sink shows a bent copy.
    bent: bool,
    /// Every patch the bent copy wrote into the sink.
    keys: BTreeSet<PatchKey>,
}

/// A sink that notes the key of every patch written through it.
struct Noting<'a> {
    sink: &'a mut dyn MeshSink,
    keys: &'a mut BTreeSet<PatchKey>,
}

impl MeshSink for Noting<'_> {
    fn begin_patch(&mut self, key: PatchKey) {
        self.keys.insert(key);
        self.sink.begin_patch(key);
    }
    fn push_vertex(&mut self, vertex: MeshVertex) -> u32 {
        self.sink.push_vertex(vertex)
    }
    fn push_triangle(&mut self, a: u32, b: u32, c: u32) {
        self.sink.push_triangle(a, b, c);
    }
    fn end_patch(&mut self) {
        self.sink.end_patch();
    }
    fn remove_patch(&mut self, key: PatchKey) {
        self.sink.remove_patch(key);
    }
}

impl LatticePreview {
    /// Brings `interactive` (the sink `doc` tessellates into at
    /// [`Detail::Interactive`], up to date with it) in line with the live drag of
    /// `interaction`. When the drag moved: the last preview's patches are removed and
    /// a copy of the document, bent, writes what it changes (the copy starts from the
    /// document's tessellation state, so its deformed targets are written whole and
    /// everything else is left as the document wrote it). When the drag has ended, or
    /// the document refuses the deformation (a stroke that no longer builds), the
    /// preview's patches are removed and the document is written again in full.
    /// Returns whether a bent copy is shown.
    pub fn sync(
        &mut self,
        doc: &Document,
        view: &mut DocumentView,
        interaction: &Interaction,
        interactive: &mut dyn MeshSink,
    ) -> bool {
        let live = interaction.live_deform();
        if live == self.tried {
            return self.bent;
        }
        self.tried.clone_from(&live);
        let was_bent = self.bent;
        for key in std::mem::take(&mut self.keys) {
            interactive.remove_patch(key);
        }
        if let Some(edit) = live {
            let mut bent = doc.clone();
            if editor::apply_deform(&mut bent, &edit).is_ok_and(|a| a.changed()) {
                let mut noting = Noting {
                    sink: interactive,
                    keys: &mut self.keys,
                };
                // The bent copy's view starts from the document's, as the copy does.
                view.clone()
                    .tessellate(&bent, Detail::Interactive, &mut noting);
                self.bent = true;
                return true;
            }
        }
        self.bent = false;
        if was_bent {
            // The sink lacks what the preview replaced: the document, whole.
            view.forget_sink(Detail::Interactive);
            view.tessellate(doc, Detail::Interactive, interactive);
        }
        false
    }
}

/// The HUD line of lattice mode: the lattice's shape, the grab radius, and whether the
/// cage is shown.
pub fn hud_line(interaction: &Interaction, shown: bool) -> Option<String> {
    if interaction.mode() != InteractionMode::Lattice {
        return None;
    }
    let spec = interaction.lattice_spec();
    let [a, b, c] = spec.counts;
    Some(format!(
        "lattice {a}x{b}x{c} degree {:?}  grab radius {:.0} mm  cage {} (L)",
        spec.degree,
        interaction.lattice_radius() * 1000.0,
        if shown { "shown" } else { "hidden" }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::editor::default_document;
    use sculpt_core::interaction::{Command, InteractionConfig, Tool, WandEvent, WandSample};

    fn lattice_mode() -> Interaction {
        Interaction::new(
            InteractionConfig::default(),
            InteractionMode::Lattice,
            Tool::default(),
        )
    }

    #[test]
    fn the_pointer_snaps_onto_the_control_point_its_ray_passes() {
        let doc = default_document();
        let i = lattice_mode();
        let cage = rest_cage(&doc, &i).unwrap();
        // The front point of a column: the ray passes the whole column, the front
        // point first.
        let target = cage.control_points()[cage.flat([1, 1, 3])];
        let eye = target + DVec3::new(0.01, 0.0, 1.0);
        let ray = Ray::through(eye, target + DVec3::new(0.0, 0.01, 0.0)).unwrap();
        let tip = lattice_tip(&doc, &i, &ray, DVec3::Z).unwrap();
        assert_eq!(tip, target);
        // Far from every point: on the plane through the cage's centre.
        let (lo, hi) = cage.bounds();
        let away = Ray::through(
            DVec3::new(hi.x + 1.0, hi.y + 1.0, 2.0),
            DVec3::new(hi.x + 1.0, hi.y + 1.0, 0.0),
        )
        .unwrap();
        let tip = lattice_tip(&doc, &i, &away, DVec3::Z).unwrap();
        sculpt_core::assert_near!(
            tip.z,
            0.5 * (lo.z + hi.z),
            sculpt_core::tolerance::POINT_EPS
        );
    }

    #[test]
    fn a_live_drag_moves_the_drawn_group_and_hiding_draws_nothing_else() {
        let doc = default_document();
        let mut i = lattice_mode();
        let cage = rest_cage(&doc, &i).unwrap();
        let grab = cage.control_points()[0];
        let mut out = Vec::new();
        let q = glam::DQuat::IDENTITY;
        i.handle(
            &WandEvent::sample(0.0, WandSample::tracked(grab, q, 0)),
            &mut out,
        )
        .unwrap();
        i.handle(
            &WandEvent::sample(0.1, WandSample::tracked(grab, q, 1)),
            &mut out,
        )
        .unwrap();
        let to = grab + DVec3::new(0.0, 0.0, 0.05);
        i.handle(
            &WandEvent::sample(0.2, WandSample::tracked(to, q, 1)),
            &mut out,
        )
        .unwrap();
        let mut lines = Vec::new();
        cage_lines(&doc, &i, &mut lines);
        let moved = to.as_vec3().to_array();
        assert!(
            lines.iter().any(|v| v.color == GROUP),
            "the group is highlighted"
        );
        assert!(
            lines.iter().any(|v| v.position == moved),
            "an edge starts at the moved point"
        );
        // The drag slides on the plane through the grabbed point.
        let ray = Ray::through(to + DVec3::new(0.0, 0.0, 1.0), to).unwrap();
        let tip = lattice_tip(&doc, &i, &ray, DVec3::Z).unwrap();
        sculpt_core::assert_near!(tip.z, grab.z, sculpt_core::tolerance::POINT_EPS);
        // Released: the drag is one deformation; in another mode no cage is drawn.
        out.clear();
        i.handle(
            &WandEvent::sample(0.3, WandSample::tracked(to, q, 0)),
            &mut out,
        )
        .unwrap();
        assert!(out.iter().any(|o| matches!(
            o,
            sculpt_core::interaction::Output::Edit(sculpt_core::interaction::Edit::Deform(_))
        )));
        i.handle(
            &WandEvent::command(
                0.4,
                Command::SetMode {
                    mode: InteractionMode::CARVE,
                },
            ),
            &mut out,
        )
        .unwrap();
        let mut none = Vec::new();
        cage_lines(&doc, &i, &mut none);
        assert!(none.is_empty());
    }
}
