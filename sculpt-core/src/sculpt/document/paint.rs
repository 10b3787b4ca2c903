//! Paint strokes as document steps ([`Document::apply_paint`]): each stroke deposits
//! samples on a target ([`crate::paint::deposit`]) and refits that target's field of
//! the painted attribute ([`AttributeField::painted`]); the step keeps the field
//! before and after, so undo and redo swap them. The surfaces and strokes are
//! untouched: paint changes no geometry.

use glam::DVec3;

use super::{Document, Step, TargetId};
use crate::error::{DocumentError, Error, Result};
use crate::mesh::WeldedMesh;
use crate::paint::{AttributeField, COLOUR, PaintEdit, blend, deposit};

/// Most paint strokes a document's history holds (each keeps its field before and
/// after): a further one is refused ([`DocumentError::TooManyPaints`]).
pub const MAX_PAINTS: usize = 1000;

/// A paint stroke as the document keeps it for undo and redo.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintRecord {
    /// Its id (from the same sequence as targets and strokes: history order).
    pub id: u64,
    /// The painted target.
    pub target: TargetId,
    /// The field before the stroke (`None`: the attribute was not painted yet).
    pub before: Option<AttributeField>,
    /// The field after it.
    pub after: AttributeField,
    /// Samples the stroke deposited.
    pub deposited: usize,
}

impl Document {
    /// The paint strokes applied since the base, in order.
    pub fn paints(&self) -> &[PaintRecord] {
        &self.paints
    }

    /// The field of `attribute` on `target` now, if it was ever painted.
    pub fn attribute_field(&self, target: TargetId, attribute: &str) -> Option<&AttributeField> {
        self.paints
            .iter()
            .rev()
            .find(|p| p.target == target && p.after.name() == attribute)
            .map(|p| &p.after)
    }

    /// The names of the attributes painted on `target`, in the order first painted.
    pub fn attribute_names(&self, target: TargetId) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for p in self.paints.iter().filter(|p| p.target == target) {
            if !names.iter().any(|n| n == p.after.name()) {
                names.push(p.after.name().to_owned());
            }
        }
        names
    }

    /// The colour at `p` (a point of `target`): the colour field blended over `base`,
    /// or `base` where the target was never painted.
    pub fn colour_at(&self, target: TargetId, p: DVec3, base: [f32; 3]) -> [f32; 3] {
        self.attribute_field(target, COLOUR)
            .map_or(base, |f| f.colour_over(p, base))
    }

    /// The current fields of `attribute`, one per target painted with it.
    fn fields_of<'a>(&'a self, attribute: &'a str) -> impl Iterator<Item = &'a AttributeField> {
        self.targets
            .iter()
            .filter_map(move |t| self.attribute_field(t.id, attribute))
    }

    /// `attribute` at a point in space: of the targets' fields of it, the one with
    /// the most coverage there; `(value, coverage)`, or `None` where no field has any.
    pub fn attribute_at_point(&self, attribute: &str, p: DVec3) -> Option<(Vec<f64>, f64)> {
        self.fields_of(attribute)
            .map(|f| f.eval(p))
            .filter(|(_, a)| *a > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The painted colour of every vertex of `mesh` (the document's mesh: vertices on
    /// its targets) blended over `base`; `None` when no target was painted with
    /// colour (the mesh keeps its material).
    pub fn vertex_colours(&self, mesh: &WeldedMesh, base: [f32; 3]) -> Option<Vec<[f32; 3]>> {
        self.fields_of(COLOUR).next()?;
        Some(
            mesh.vertices
                .iter()
                .map(|v| {
                    let p = DVec3::from(v.position.map(f64::from));
                    match self.attribute_at_point(COLOUR, p) {
                        Some((value, a)) => blend(base, &value, a),
                        None => base,
                    }
                })
                .collect(),
        )
    }

    /// The heat map of the scalar `attribute` at every vertex of `mesh`: the painted
    /// range (its least to its greatest painted value) mapped blue to red
    /// ([`crate::paint::heat`]) and blended over `base` by coverage; `None` when no
    /// target was painted with it.
    pub fn heat_colours(
        &self,
        mesh: &WeldedMesh,
        attribute: &str,
        base: [f32; 3],
    ) -> Option<Vec<[f32; 3]>> {
        let (lo, hi) = self
            .fields_of(attribute)
            .filter_map(AttributeField::value_range)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))?;
        let span = (hi - lo).max(f64::MIN_POSITIVE);
        Some(
            mesh.vertices
                .iter()
                .map(|v| {
                    let p = DVec3::from(v.position.map(f64::from));
                    match self.attribute_at_point(attribute, p) {
                        Some((value, a)) => {
                            let t = (value[0] - lo) / span;
                            let heat = crate::paint::heat(if hi > lo { t } else { 1.0 });
                            blend(base, &heat.map(f64::from), a)
                        }
                        None => base,
                    }
                })
                .collect(),
        )
    }

    /// Applies a paint stroke as one undoable step: deposits its samples on the
    /// target and refits the attribute's field (see the module docs). A bad edit, a
    /// missing target, a brush that reaches no part of the target, a full field or a
    /// history of [`MAX_PAINTS`] already leaves the document unchanged and says why.
    /// Returns the step's id and the number of samples deposited.
    pub fn apply_paint(&mut self, edit: &PaintEdit) -> Result<(u64, usize)> {
        edit.validate()?;
        self.check_paint_caps()?;
        let record = self.target(edit.target).ok_or(Error::NotFound {
            kind: "target",
            id: edit.target,
        })?;
        let positions = deposit(&record.target, &edit.samples, edit.radius);
        if positions.is_empty() {
            return Err(crate::paint::PaintError::NothingUnderBrush {
                radius: edit.radius,
            }
            .into());
        }
        let before = self.attribute_field(edit.target, &edit.attribute).cloned();
        let empty;
        let start = match &before {
            Some(f) => f,
            None => {
                empty = AttributeField::around(
                    &edit.attribute,
                    crate::paint::components_of(&edit.attribute),
                    &record.surface,
                    &record.target,
                )?;
                &empty
            }
        };
        let after = start.painted(&positions, &edit.value, edit.radius)?;
        let id = self.next_id.max(1);
        self.paints.push(PaintRecord {
            id,
            target: edit.target,
            before,
            after,
            deposited: positions.len(),
        });
        self.next_id = id + 1;
        self.bump();
        self.redo.clear();
        Ok((id, positions.len()))
    }

    /// Checks that one more paint stroke fits the history ([`MAX_PAINTS`]).
    pub fn check_paint_caps(&self) -> Result<()> {
        if self.paints.len() >= MAX_PAINTS {
            return Err(Error::Document(DocumentError::TooManyPaints {
                max: MAX_PAINTS,
            }));
        }
        Ok(())
    }

    /// Undoes the last paint stroke (the caller checked it is the last step).
    pub(super) fn pop_paint(&mut self) -> Option<Step> {
        self.paints.pop().map(|p| Step::Paint(Box::new(p)))
    }

    /// Redoes an undone paint stroke.
    pub(super) fn push_paint(&mut self, p: PaintRecord) -> bool {
        self.next_id = self.next_id.max(p.id + 1);
        self.paints.push(p);
        true
    }
}
