//! Where wand gestures become sculpting: the interaction's [`Edit`]s applied to a
//! [`Document`], and its [`OperatorEvent`]s turned into operator-log events.
//!
//! The display server (`vr-app`) and `replay` both call [`apply`] for every edit the
//! [`Interaction`](crate::interaction::Interaction) emits, so a live session and the
//! replay of its pose log build the same document. Both start from the same
//! [`default_document`] when no scene is given.
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::editor::{self, Applied};
//! use sculpt_core::interaction::{Edit, StrokeEdit, StrokeSample, Tool, DEFAULT_TARGET};
//!
//! let mut doc = editor::default_document();
//! let samples = (0..=20)
//!     .map(|i| {
//!         let x = -0.2 + 0.02 * i as f64;
//!         StrokeSample { t: 0.01 * i as f64, position: editor::default_surface_point(x, 1.17) }
//!     })
//!     .collect();
//! let edit = Edit::Stroke(StrokeEdit::new(DEFAULT_TARGET, Tool::default(), samples));
//! assert!(matches!(editor::apply(&mut doc, &edit), Applied::Stroke { .. }));
//! assert_eq!(doc.strokes().len(), 1);
//! assert_eq!(editor::apply(&mut doc, &Edit::Undo), Applied::Undone);
//! assert!(doc.strokes().is_empty());
//! ```

use glam::DVec3;

use crate::error::FitError;
use crate::interaction::{Edit, InteractionMode, OperatorEvent, StrokeEdit};
use crate::lattice::{DeformEdit, Lattice};
use crate::nurbs::NurbsSurface;
use crate::oplog::{EventKind, TrackingState};
use crate::sculpt::document::{Document, StrokeId, TargetId};
use crate::sculpt::stroke::{Profile, StrokeInput, Tool};
use crate::{Error, Result};

/// Centre of the default surface (display frame metres): 1.17 m up, 0.1 m behind the
/// wall plane, so it sits in front of a standing sculptor.
pub const DEFAULT_SURFACE_CENTER: DVec3 = DVec3::new(0.0, 1.17, -0.1);

/// Largest control net (per direction) a sketch is fitted with.
pub const SKETCH_MAX_CONTROL: usize = 12;

// A sketch's surface is always within the document's cap on control points.
const _: () = assert!(
    SKETCH_MAX_CONTROL * SKETCH_MAX_CONTROL <= crate::sculpt::document::MAX_TARGET_CONTROL_POINTS
);

/// The point of the default surface over display `(x, y)`: the gently curved
/// 1 m x 0.6 m sheet `z = c.z - 0.25 (2 u^2 + v^2)` with `u = x - c.x` (metres) and
/// `v = (y - c.y) / 0.6`, centred at [`DEFAULT_SURFACE_CENTER`], facing the viewer
/// (+z).
pub fn default_surface_point(x: f64, y: f64) -> DVec3 {
    let c = DEFAULT_SURFACE_CENTER;
    let u = x - c.x;
    let v = (y - c.y) / 0.6;
    DVec3::new(x, y, c.z - 0.25 * (2.0 * u * u + v * v))
}

/// The default surface as a NURBS target: the sheet of [`default_surface_point`],
/// exactly, as one biquadratic Bézier patch (1 m x 0.6 m).
///
/// The sheet is quadratic in `(x, y)`, so its Bernstein coefficients follow from
/// three samples per direction: `c0 = f(0)`, `c1 = 2 f(1/2) - (f(0) + f(1)) / 2`,
/// `c2 = f(1)`, applied along u and then along v.
pub fn default_surface() -> NurbsSurface {
    let c = DEFAULT_SURFACE_CENTER;
    let s = [0.0, 0.5, 1.0];
    let w = [[1.0, 0.0, 0.0], [-0.5, 2.0, -0.5], [0.0, 0.0, 1.0]];
    let sample =
        |a: usize, b: usize| default_surface_point(c.x - 0.5 + s[a], c.y - 0.3 + 0.6 * s[b]);
    let control: Vec<Vec<DVec3>> = (0..3)
        .map(|i| {
            (0..3)
                .map(|j| {
                    let mut p = DVec3::ZERO;
                    for a in 0..3 {
                        for b in 0..3 {
                            p += sample(a, b) * (w[i][a] * w[j][b]);
                        }
                    }
                    p
                })
                .collect()
        })
        .collect();
    let knots = vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    // The construction is fixed and valid; a failure here is a kernel regression.
    NurbsSurface::new(2, 2, knots.clone(), knots, control, None)
        .unwrap_or_else(|e| unreachable!("the default surface is valid: {e}"))
}

/// A new document holding the default surface, named `default`, as its base (undo
/// never removes it).
pub fn default_document() -> Document {
    let mut doc = Document::new();
    doc.add_target("default", default_surface());
    doc.seal_history();
    doc
}

/// Fits a sketched point grid (`rows[k]` is the wand segment at sweep sample `k`) with
/// the kernel's least-squares grid approximation (P&T A9.7 style): a non-rational
/// surface of degree up to 3 with at most [`SKETCH_MAX_CONTROL`] control points per
/// direction. Rows closer than 0.1 mm to the previous kept row (the wand held still)
/// are dropped first, so the chord-length parameters stay distinct.
pub fn fit_sketch(rows: &[Vec<DVec3>]) -> Result<NurbsSurface> {
    let cols = rows.first().map_or(0, Vec::len);
    if cols < 2 || rows.iter().any(|r| r.len() != cols) {
        return Err(Error::FitFailed(FitError::SketchRows));
    }
    if rows.iter().flatten().any(|p| !p.is_finite()) {
        return Err(Error::FitFailed(FitError::NotFinite {
            what: "a sketch point",
        }));
    }
    let mut kept: Vec<Vec<DVec3>> = Vec::with_capacity(rows.len());
    for row in rows {
        let moved = kept.last().is_none_or(|last: &Vec<DVec3>| {
            last.iter()
                .zip(row)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0, f64::max)
                > crate::tolerance::ROW_MOVED_EPS
        });
        if moved {
            kept.push(row.clone());
        }
    }
    if kept.len() < 2 {
        return Err(Error::FitFailed(FitError::SketchDidNotMove));
    }
    let count_u = kept.len().min(SKETCH_MAX_CONTROL);
    let count_v = cols.min(SKETCH_MAX_CONTROL);
    NurbsSurface::approximate_grid(
        &kept,
        count_u,
        count_v,
        (count_u - 1).min(3),
        (count_v - 1).min(3),
    )
}

/// The sculpting layer's input for an interaction stroke: its samples and its tool,
/// carving or embossing as the edit's mode says.
pub fn stroke_input(edit: &StrokeEdit) -> StrokeInput {
    StrokeInput {
        samples: edit.samples.iter().map(|s| (s.t, s.position)).collect(),
        tool: Tool {
            mode: edit.mode,
            ..edit.tool.clone()
        },
    }
}

/// What [`apply`] did to the document: the outcome of an [`Edit`], naming targets and
/// strokes by their document ids.
#[derive(Debug, Clone, PartialEq)]
pub enum Applied {
    /// A stroke was added: one operation, carved in one or more pieces (see
    /// [`StrokePieces`](crate::sculpt::stroke::StrokePieces)).
    Stroke {
        /// The new stroke.
        id: StrokeId,
        /// The target it was applied to.
        target: TargetId,
        /// The pieces carved: more than one where the stroke passed over basin jumps
        /// or left the surface between pieces.
        pieces: usize,
        /// Pieces left uncarved, no longer than the minimum stroke length.
        dropped: usize,
    },
    /// A sketch was fitted and added as a new target.
    Sketch {
        /// The new target.
        target: TargetId,
    },
    /// Targets were deformed through a lattice (one operation).
    Deform {
        /// The step's id in the document's history.
        id: u64,
        /// The deformed targets.
        targets: Vec<TargetId>,
        /// Lattice control points moved.
        points: usize,
    },
    /// A paint stroke was applied (one operation).
    Paint {
        /// The step's id in the document's history.
        id: u64,
        /// The painted target.
        target: TargetId,
        /// The painted attribute.
        attribute: String,
        /// Samples deposited on the target.
        samples: usize,
    },
    /// The last step was undone.
    Undone,
    /// The last undone step was redone.
    Redone,
    /// Nothing changed: undo or redo with nothing to do, a selection, or a save (the
    /// caller writes the file).
    Unchanged,
    /// The edit was refused; the document is as it was.
    Rejected(Error),
}

impl Applied {
    /// True when the document's content changed.
    pub fn changed(&self) -> bool {
        matches!(
            self,
            Applied::Stroke { .. }
                | Applied::Sketch { .. }
                | Applied::Deform { .. }
                | Applied::Paint { .. }
                | Applied::Undone
                | Applied::Redone
        )
    }
}

/// Applies one interaction edit to `doc`.
///
/// Strokes go to the target the edit names ([`Document::target`]) through
/// [`Document::apply_stroke`]; sketches are fitted ([`fit_sketch`]) and added
/// as targets named `sketch N`; undo and redo step the document's history. A refused
/// stroke or sketch leaves the document unchanged and says why.
pub fn apply(doc: &mut Document, edit: &Edit) -> Applied {
    match edit {
        Edit::Stroke(s) if doc.solid(s.target).is_some() => {
            match doc.apply_solid_stroke(s.target, stroke_input(s)) {
                Ok((id, _)) => Applied::Stroke {
                    id,
                    target: s.target,
                    pieces: 1,
                    dropped: 0,
                },
                Err(e) => Applied::Rejected(e),
            }
        }
        Edit::Stroke(s) => {
            let Some(target) = doc.target(s.target).map(|t| t.id) else {
                return Applied::Rejected(Error::NotFound {
                    kind: "target",
                    id: s.target,
                });
            };
            match doc.apply_stroke(target, stroke_input(s)) {
                Ok(id) => {
                    let (pieces, dropped) = doc
                        .stroke(id)
                        .map_or((0, 0), |b| (b.pieces.len(), b.dropped));
                    Applied::Stroke {
                        id,
                        target,
                        pieces,
                        dropped,
                    }
                }
                Err(e) => Applied::Rejected(e),
            }
        }
        Edit::Sketch { rows } => {
            let added = fit_sketch(rows).and_then(|surface| {
                let name = format!("sketch {}", doc.targets().len());
                doc.try_add_target(&name, surface)
            });
            match added {
                Ok(target) => Applied::Sketch { target },
                Err(e) => Applied::Rejected(e),
            }
        }
        Edit::Deform(d) => match apply_deform(doc, d) {
            Ok(applied) => applied,
            Err(e) => Applied::Rejected(e),
        },
        Edit::Paint(p) => match doc.apply_paint(p) {
            Ok((id, samples)) => Applied::Paint {
                id,
                target: p.target,
                attribute: p.attribute.clone(),
                samples,
            },
            Err(e) => Applied::Rejected(e),
        },
        Edit::Undo if doc.undo() => Applied::Undone,
        Edit::Redo if doc.redo() => Applied::Redone,
        Edit::Undo | Edit::Redo | Edit::SelectTarget { .. } | Edit::Save => Applied::Unchanged,
    }
}

/// A lattice deformation ([`DeformEdit`]): the lattice is fitted around the targets
/// the edit names, its control points within the radius of the grab point moved, and
/// the targets mapped through it as one undoable step
/// ([`Document::apply_deform`]).
pub fn apply_deform(doc: &mut Document, edit: &DeformEdit) -> Result<Applied> {
    edit.validate()?;
    let mut surfaces = Vec::with_capacity(edit.targets.len());
    for &id in &edit.targets {
        let t = doc
            .target(id)
            .ok_or(Error::NotFound { kind: "target", id })?;
        surfaces.push(&t.surface);
    }
    let mut lattice = Lattice::around(edit.lattice, &surfaces)?;
    let group = lattice.group(edit.grab, edit.radius)?;
    lattice.displace(&group, edit.displacement)?;
    let id = doc.apply_deform(&edit.targets, &lattice)?;
    Ok(Applied::Deform {
        id,
        targets: edit.targets.clone(),
        points: group.len(),
    })
}

/// Checks an edit against the document's size caps before it is journalled or applied
/// (see [`crate::sculpt::document::MAX_STROKES`] and the caps beside it): a stroke
/// needs room for one more stroke and its samples, a sketch room for one more target.
/// [`apply`] refuses an edit over a cap with the same error.
pub fn check_caps(doc: &Document, edit: &Edit) -> Result<()> {
    match edit {
        Edit::Stroke(s) => doc.check_stroke_caps(s.samples.len()),
        Edit::Sketch { .. } if doc.targets().len() >= crate::sculpt::document::MAX_TARGETS => Err(
            Error::Document(crate::error::DocumentError::TooManyTargets {
                max: crate::sculpt::document::MAX_TARGETS,
            }),
        ),
        Edit::Deform(d) => {
            d.validate()?;
            if doc.deforms().len() >= crate::sculpt::document::MAX_DEFORMS {
                return Err(Error::Document(
                    crate::error::DocumentError::TooManyDeforms {
                        max: crate::sculpt::document::MAX_DEFORMS,
                    },
                ));
            }
            Ok(())
        }
        Edit::Paint(p) => {
            p.validate()?;
            doc.check_paint_caps()
        }
        _ => Ok(()),
    }
}

/// The operator-log name of a mode (`sketch`, `carve`, `emboss`).
pub fn mode_name(mode: InteractionMode) -> &'static str {
    mode.name()
}

/// The operator-log name of a tool (`v-chisel`, `u-chisel`, `custom-chisel`).
pub fn tool_name(tool: &Tool) -> &'static str {
    match tool.profile {
        Profile::V => "v-chisel",
        Profile::U => "u-chisel",
        Profile::Custom(_) => "custom-chisel",
    }
}

/// The operator-log event for what an edit did, when it says more than the operator
/// events around it: a stroke carved in several pieces, or with pieces dropped, is a
/// `marker` labelled `stroke <id>: <n> pieces, <m> dropped` (the GOMS harness reads no
/// markers, so its operators are unchanged); a lattice deformation is a `marker`
/// labelled `deform <id>: <n> lattice points, <m> targets`. `None` for everything
/// else, a stroke carved in one piece included.
pub fn oplog_applied(applied: &Applied) -> Option<EventKind> {
    match applied {
        Applied::Stroke {
            id,
            pieces,
            dropped,
            ..
        } if *pieces > 1 || *dropped > 0 => Some(EventKind::Marker {
            label: format!("stroke {id}: {pieces} pieces, {dropped} dropped"),
        }),
        Applied::Deform {
            id,
            targets,
            points,
        } => Some(EventKind::Marker {
            label: format!(
                "deform {id}: {points} lattice points, {} targets",
                targets.len()
            ),
        }),
        Applied::Paint {
            id,
            attribute,
            samples,
            ..
        } => Some(EventKind::Marker {
            label: format!("paint {id}: {attribute}, {samples} samples"),
        }),
        _ => None,
    }
}

/// The operator-log event (`sculpt_core::oplog`, read by the GOMS harness) for an
/// interaction operator event.
pub fn oplog_event(event: &OperatorEvent) -> EventKind {
    match event {
        OperatorEvent::ButtonDown { button } => EventKind::Button {
            id: *button,
            down: true,
        },
        OperatorEvent::ButtonUp { button } => EventKind::Button {
            id: *button,
            down: false,
        },
        OperatorEvent::ModeChange { to, .. } => EventKind::Mode {
            mode: mode_name(*to).into(),
        },
        OperatorEvent::ToolChange { tool } => EventKind::Tool {
            tool: tool_name(tool).into(),
        },
        OperatorEvent::GestureStart { .. } => EventKind::StrokeStart,
        OperatorEvent::GestureEnd { .. } => EventKind::StrokeEnd,
        OperatorEvent::TrackingLost => EventKind::Tracking {
            state: TrackingState::Lost,
        },
        OperatorEvent::TrackingRegained => EventKind::Tracking {
            state: TrackingState::Tracked,
        },
        OperatorEvent::Command { edit } => match edit {
            Edit::Undo => EventKind::Undo,
            Edit::Redo => EventKind::Redo,
            Edit::Save => EventKind::Save,
            Edit::SelectTarget { target } => EventKind::Marker {
                label: format!("select-target {target}"),
            },
            Edit::Sketch { .. } | Edit::Stroke(_) | Edit::Deform(_) | Edit::Paint(_) => {
                EventKind::Marker {
                    label: "edit".into(),
                }
            }
        },
        OperatorEvent::Pose {
            position,
            orientation,
        } => EventKind::Pose {
            p: *position,
            q: orientation.normalize(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::interaction::{DEFAULT_TARGET, StrokeSample};
    use crate::sculpt::document::TargetId;
    use crate::tolerance::{EXACT_EPS, POINT_EPS};

    fn carve(target: TargetId, y: f64) -> Edit {
        Edit::Stroke(StrokeEdit::new(
            target,
            Tool::default(),
            (0..=30)
                .map(|i| StrokeSample {
                    t: i as f64 * 0.01,
                    position: default_surface_point(-0.3 + 0.02 * i as f64, y),
                })
                .collect(),
        ))
    }

    #[test]
    fn the_default_nurbs_surface_is_the_default_sheet() {
        let s = default_surface();
        let c = DEFAULT_SURFACE_CENTER;
        for (u, v) in [(0.0, 0.0), (0.3, 0.7), (0.5, 0.5), (1.0, 0.25)] {
            let p = s.point(u, v);
            assert_near!(p.z, default_surface_point(p.x, p.y).z, EXACT_EPS);
            assert_near!(p.x, c.x - 0.5 + u, EXACT_EPS);
            assert_near!(p.y, c.y - 0.3 + 0.6 * v, EXACT_EPS);
        }
    }

    #[test]
    fn sketches_fit_through_their_corners_and_bad_grids_are_refused() {
        let rows: Vec<Vec<DVec3>> = (0..30)
            .map(|i| {
                (0..8)
                    .map(|j| {
                        let (x, y) = (j as f64 * 0.04, 1.0 + i as f64 * 0.01);
                        DVec3::new(x, y, 0.1 * x * x)
                    })
                    .collect()
            })
            .collect();
        let s = fit_sketch(&rows).unwrap();
        assert_near!(
            s.point(0.0, 0.0).to_array(),
            rows[0][0].to_array(),
            POINT_EPS
        );
        assert_near!(
            s.point(1.0, 1.0).to_array(),
            rows[29][7].to_array(),
            POINT_EPS
        );
        assert!(fit_sketch(&rows[..1]).is_err(), "one row");
        let still = vec![rows[0].clone(); 10];
        assert!(fit_sketch(&still).is_err(), "the wand never moved");
        let mut nan = rows.clone();
        nan[3][2].x = f64::NAN;
        assert!(fit_sketch(&nan).is_err());
    }

    #[test]
    fn edits_apply_undo_and_redo_in_order() {
        let mut doc = default_document();
        assert!(matches!(
            apply(&mut doc, &carve(DEFAULT_TARGET, 1.1)),
            Applied::Stroke { .. }
        ));
        let sketch = Edit::Sketch {
            rows: (0..5)
                .map(|i| {
                    vec![
                        DVec3::new(0.0, i as f64 * 0.05, 0.3),
                        DVec3::new(0.2, i as f64 * 0.05, 0.3),
                    ]
                })
                .collect(),
        };
        assert!(matches!(apply(&mut doc, &sketch), Applied::Sketch { .. }));
        assert_eq!(doc.targets().len(), 2);
        assert_eq!(doc.targets()[1].name, "sketch 1");
        assert_eq!(apply(&mut doc, &Edit::Undo), Applied::Undone);
        assert_eq!(doc.targets().len(), 1);
        assert_eq!(apply(&mut doc, &Edit::Redo), Applied::Redone);
        assert_eq!(apply(&mut doc, &Edit::Redo), Applied::Unchanged);
        assert_eq!(doc.targets().len(), 2);
        assert!(!apply(&mut doc, &Edit::Save).changed());
    }

    /// A version 1 journal named targets by position: read back, each position
    /// becomes the id of the target there.
    #[test]
    fn version_1_positions_become_the_targets_ids() {
        let mut doc = default_document();
        let sketch_id = doc.add_target("sketch 1", default_surface());
        let ids = doc.target_ids();
        assert_eq!(ids, vec![DEFAULT_TARGET, sketch_id]);
        let resolved = carve(1, 1.1).with_positions_resolved(&doc);
        let Edit::Stroke(s) = &resolved else {
            unreachable!()
        };
        assert_eq!(s.target, sketch_id);
        assert_eq!(
            Edit::SelectTarget { target: 0 }.with_positions_resolved(&doc),
            Edit::SelectTarget {
                target: DEFAULT_TARGET
            }
        );
        let Edit::Stroke(past) = carve(7, 1.1).with_positions_resolved(&doc) else {
            unreachable!()
        };
        assert_eq!(past.target, TargetId::MAX, "no target there: still refused");
        assert!(matches!(
            apply(&mut doc, &Edit::Stroke(past)),
            Applied::Rejected(_)
        ));
        assert!(matches!(apply(&mut doc, &resolved), Applied::Stroke { .. }));
    }

    #[test]
    fn refused_edits_leave_the_document_alone() {
        let mut doc = default_document();
        let Applied::Rejected(e) = apply(&mut doc, &carve(5, 1.1)) else {
            panic!("target 5 does not exist");
        };
        assert!(e.to_string().contains("target 5"), "{e}");
        // Far above the surface: off the target.
        let Edit::Stroke(mut off) = carve(DEFAULT_TARGET, 1.1) else {
            unreachable!()
        };
        for s in &mut off.samples {
            s.position.z += 3.0;
        }
        assert!(matches!(
            apply(&mut doc, &Edit::Stroke(off)),
            Applied::Rejected(_)
        ));
        assert!(doc.strokes().is_empty());
        // Nothing to undo: the base surface stays (see the regression test below).
        assert_eq!(apply(&mut doc, &Edit::Undo), Applied::Unchanged);
        assert_eq!(doc.targets().len(), 1);
    }

    /// Regression: the default surface was added as an ordinary undoable step, so one
    /// undo more than there were edits removed it (HUD "target 1/0", a dark screen).
    #[test]
    fn undo_past_the_first_edit_no_longer_removes_the_default_surface() {
        let mut doc = default_document();
        assert!(!doc.can_undo());
        assert!(matches!(
            apply(&mut doc, &carve(DEFAULT_TARGET, 1.1)),
            Applied::Stroke { .. }
        ));
        assert!(doc.can_undo());
        assert_eq!(apply(&mut doc, &Edit::Undo), Applied::Undone);
        for _ in 0..3 {
            assert_eq!(apply(&mut doc, &Edit::Undo), Applied::Unchanged);
        }
        assert_eq!(doc.targets().len(), 1);
        assert!(doc.strokes().is_empty());
        // Redo still brings the stroke back.
        assert_eq!(apply(&mut doc, &Edit::Redo), Applied::Redone);
        assert_eq!(doc.strokes().len(), 1);
        // A loaded document is all base: its strokes and targets stay too.
        let mut loaded = Document::from_json(&doc.to_json()).unwrap();
        assert_eq!(apply(&mut loaded, &Edit::Undo), Applied::Unchanged);
        assert_eq!(loaded.strokes().len(), 1);
        assert_eq!(loaded.targets().len(), 1);
        // Edits after loading undo as usual, down to the loaded base.
        assert!(matches!(
            apply(&mut loaded, &carve(DEFAULT_TARGET, 1.2)),
            Applied::Stroke { .. }
        ));
        assert_eq!(apply(&mut loaded, &Edit::Undo), Applied::Undone);
        assert_eq!(apply(&mut loaded, &Edit::Undo), Applied::Unchanged);
        assert_eq!(loaded.strokes().len(), 1);
    }

    #[test]
    fn operator_events_map_onto_the_oplog() {
        use crate::oplog::{OpLogHeader, OpLogWriter, decode_bytes};
        let events = [
            OperatorEvent::ButtonDown { button: 0 },
            OperatorEvent::GestureStart {
                mode: InteractionMode::CARVE,
            },
            OperatorEvent::ModeChange {
                from: InteractionMode::CARVE,
                to: InteractionMode::EMBOSS,
            },
            OperatorEvent::ToolChange {
                tool: Tool {
                    profile: Profile::U,
                    ..Tool::default()
                },
            },
            OperatorEvent::TrackingLost,
            OperatorEvent::Command { edit: Edit::Undo },
        ];
        let mut w = OpLogWriter::new(&OpLogHeader::new());
        for (k, e) in events.iter().enumerate() {
            w.push(k as f64, oplog_event(e)).unwrap();
        }
        let log = decode_bytes(&w.take()).unwrap();
        let kinds: Vec<_> = log.events.iter().map(|e| e.kind.clone()).collect();
        assert_eq!(kinds[0], EventKind::Button { id: 0, down: true });
        assert_eq!(kinds[1], EventKind::StrokeStart);
        assert_eq!(
            kinds[2],
            EventKind::Mode {
                mode: "emboss".into()
            }
        );
        assert_eq!(
            kinds[3],
            EventKind::Tool {
                tool: "u-chisel".into()
            }
        );
        assert_eq!(
            kinds[4],
            EventKind::Tracking {
                state: TrackingState::Lost
            }
        );
        assert_eq!(kinds[5], EventKind::Undo);
    }
}
