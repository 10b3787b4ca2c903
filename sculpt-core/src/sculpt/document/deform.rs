//! Lattice deformations as document steps ([`Document::apply_deform`]): the targets'
//! surfaces are replaced by their mapped versions and every stroke on them is carried
//! along **in UV**, so its groove follows the bent surface; undo puts both back.
//!
//! A stroke keeps its wand samples (they are what the document saves and rebuilds
//! from). Carrying a sample: its closest point on the old surface gives `(u, v)` and
//! its height `h` above the surface along the normal; the carried sample is
//! `S'(u, v) + h n'(u, v)` on the new surface `S'`. Rebuilt there, the stroke's
//! centreline runs through the same `(u, v)` (up to point inversion), and its width
//! and depth stay the tool's, in metres on the bent surface.

use glam::DVec2;

use super::{Built, Document, PIECE_KEYS, Step, StrokeId, TargetId, TargetRecord};
use crate::error::{DocumentError, Error, Result};
use crate::lattice::Lattice;
use crate::nurbs::NurbsSurface;
use crate::sculpt::stroke::{StrokeInput, StrokePieces};
use crate::sculpt::surface::{ParamSurface, TargetSurface, normal_from};

/// Most deformations a document's history holds (each keeps its targets' surfaces
/// before and after): a further one is refused ([`DocumentError::TooManyDeforms`]).
pub const MAX_DEFORMS: usize = 1000;

/// A deformation as the document keeps it for undo and redo: the surfaces and stroke
/// inputs it replaced, and what it replaced them with.
#[derive(Debug, Clone, PartialEq)]
pub struct DeformRecord {
    /// Its id (from the same sequence as targets and strokes: history order).
    pub id: u64,
    /// `(target, before, after)` for every deformed target.
    pub surfaces: Vec<(TargetId, NurbsSurface, NurbsSurface)>,
    /// `(stroke, before, after)` for every stroke on a deformed target.
    pub strokes: Vec<(StrokeId, StrokeInput, StrokeInput)>,
}

/// `input`'s samples carried from `old` onto `new` in UV (see the module docs).
pub fn carry_stroke(old: &TargetSurface, new: &TargetSurface, input: &StrokeInput) -> StrokeInput {
    let mut seed: Option<DVec2> = None;
    let samples = input
        .samples
        .iter()
        .map(|&(t, p)| {
            let uv = match seed {
                None => old.closest_point(p).uv_in_square,
                Some(s) => old.closest_point_from(p, s).uv_in_square,
            };
            seed = Some(uv);
            let was = old.eval(uv);
            let h = (p - was.p).dot(normal_from(old, uv, &was));
            let now = new.eval(uv);
            (t, now.p + normal_from(new, uv, &now) * h)
        })
        .collect();
    StrokeInput {
        samples,
        tool: input.tool.clone(),
    }
}

impl Document {
    /// The deformations applied since the base, in order.
    pub fn deforms(&self) -> &[DeformRecord] {
        &self.deforms
    }

    /// Deforms `targets` through `lattice` as one undoable step: each surface is
    /// mapped ([`Lattice::deform_surface`]) and the strokes on it are carried along in
    /// UV ([`carry_stroke`]) and rebuilt. A missing target, a mapped surface the kernel
    /// refuses, a stroke that no longer builds, or a history of [`MAX_DEFORMS`] already
    /// leaves the document unchanged and says why. Returns the step's id.
    pub fn apply_deform(&mut self, targets: &[TargetId], lattice: &Lattice) -> Result<u64> {
        if self.deforms.len() >= MAX_DEFORMS {
            return Err(Error::Document(DocumentError::TooManyDeforms {
                max: MAX_DEFORMS,
            }));
        }
        let mut surfaces = Vec::with_capacity(targets.len());
        let mut strokes = Vec::new();
        for &id in targets {
            let record = self
                .target(id)
                .ok_or(Error::NotFound { kind: "target", id })?;
            let after = lattice.deform_surface(&record.surface)?;
            let new = TargetSurface::new(&after);
            for s in self.strokes.iter().filter(|s| s.target == id) {
                let carried = carry_stroke(&record.target, &new, &s.input);
                strokes.push((s.id, s.input.clone(), carried));
            }
            surfaces.push((id, record.surface.clone(), after));
        }
        let id = self.next_id.max(1);
        let record = DeformRecord {
            id,
            surfaces,
            strokes,
        };
        self.swap_geometry(&record, After)?;
        self.next_id = id + 1;
        self.redo.clear();
        self.deforms.push(record);
        Ok(id)
    }

    /// Undoes the last deformation (the caller checked it is the last step).
    pub(super) fn pop_deform(&mut self) -> Option<Step> {
        let d = self.deforms.pop()?;
        match self.swap_geometry(&d, Before) {
            Ok(()) => Some(Step::Deform(d)),
            Err(_) => {
                // It was the document's state before: it builds again. Should it not,
                // the step stays where it was.
                self.deforms.push(d);
                None
            }
        }
    }

    /// Redoes an undone deformation; false (and nothing changed) should it not apply.
    pub(super) fn push_deform(&mut self, d: DeformRecord) -> bool {
        let ok = self.swap_geometry(&d, After).is_ok();
        if ok {
            self.next_id = self.next_id.max(d.id + 1);
            self.deforms.push(d);
        }
        ok
    }

    /// Puts the `side` surfaces and stroke inputs of `d` into the document. Everything
    /// is built first; the document changes only once all of it has.
    fn swap_geometry(&mut self, d: &DeformRecord, side: Side) -> Result<()> {
        let pick = |before: &'_ NurbsSurface, after: &'_ NurbsSurface| match side {
            Before => before.clone(),
            After => after.clone(),
        };
        let mut records = Vec::with_capacity(d.surfaces.len());
        for (id, before, after) in &d.surfaces {
            let pos = self
                .targets
                .iter()
                .position(|t| t.id == *id)
                .ok_or(Error::NotFound {
                    kind: "target",
                    id: *id,
                })?;
            let name = self.targets[pos].name.clone();
            records.push((pos, TargetRecord::new(*id, name, pick(before, after))));
        }
        // The new surfaces go in first, so each carried stroke is built among them (on
        // a patch network it may cross onto a neighbour, `build_pieces`); should one
        // fail, the old surfaces go back and nothing has changed.
        let mut replaced = Vec::with_capacity(records.len());
        for (pos, record) in records {
            replaced.push((pos, std::mem::replace(&mut self.targets[pos], record)));
        }
        let built = match self.carried_strokes(d, side) {
            Ok(built) => built,
            Err(e) => {
                for (pos, record) in replaced {
                    self.targets[pos] = record;
                }
                return Err(e);
            }
        };
        // Views see the new geometry by its revision: they drop their meshes of these
        // targets, plan their grids again and find the patch network anew.
        for &(pos, _) in &replaced {
            self.put_geometry(self.targets[pos].id);
        }
        for (pos, input, (pieces, targets)) in built {
            let sid = self.strokes[pos].id;
            if let Some(old) = self.built.remove(&sid) {
                self.touch_built(&old);
            }
            let keys: Vec<u64> = std::iter::once(sid)
                .chain((1..pieces.pieces.len()).map(|_| {
                    self.piece_serial += 1;
                    PIECE_KEYS + self.piece_serial
                }))
                .collect();
            self.samples_total =
                self.samples_total - self.strokes[pos].input.samples.len() + input.samples.len();
            self.strokes[pos].input = input;
            self.bump();
            let built = Built {
                keys,
                pieces,
                targets,
                revision: self.revision,
            };
            self.touch_built(&built);
            self.built.insert(sid, built);
        }
        Ok(())
    }
}

impl Document {
    /// The strokes of `d` at `side`, each built on the targets now in place:
    /// `(position, input, (pieces, target of each piece))`.
    #[allow(clippy::type_complexity)]
    fn carried_strokes(
        &self,
        d: &DeformRecord,
        side: Side,
    ) -> Result<Vec<(usize, StrokeInput, (StrokePieces, Vec<TargetId>))>> {
        let mut built = Vec::with_capacity(d.strokes.len());
        for (sid, before, after) in &d.strokes {
            let input = match side {
                Before => before,
                After => after,
            };
            let pos = self
                .strokes
                .iter()
                .position(|s| s.id == *sid)
                .ok_or(Error::NotFound {
                    kind: "stroke",
                    id: *sid,
                })?;
            let on = self.strokes[pos].target;
            let target = self
                .targets
                .iter()
                .find(|t| t.id == on)
                .ok_or(Error::NotFound {
                    kind: "target",
                    id: on,
                })?;
            built.push((pos, input.clone(), self.build_pieces(target, input)?));
        }
        Ok(built)
    }
}

/// Which side of a [`DeformRecord`] to put in place.
#[derive(Clone, Copy)]
enum Side {
    Before,
    After,
}
use Side::{After, Before};
