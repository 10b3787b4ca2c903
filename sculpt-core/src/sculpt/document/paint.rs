//! Paint strokes as document steps ([`Document::apply_paint`]): each stroke deposits
//! samples on a target ([`crate::paint::deposit`]) and refits that target's field of
//! the painted attribute ([`AttributeField::painted`]); the step keeps the field
//! before and after, so undo and redo swap them. The surfaces and strokes are
//! untouched: paint changes no geometry.

use glam::DVec3;

use super::{Document, Step, TargetId};
use crate::error::{DocumentError, Error, Result};
use crate::mesh::WeldedMesh;
use crate::paint::{AttributeField, COLOUR, PaintEdit, PaintShading, deposit, strongest};

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
    /// The stroke as applied (the document file keeps it, [`Document::to_json`]).
    pub edit: PaintEdit,
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
        strongest(self.fields_of(attribute), p)
    }

    /// What a renderer tints the targets with: the colour fields (`heat: None`), or
    /// the scalar `heat`'s fields as a heat map; `None` when nothing of it was painted.
    pub fn paint_shading(&self, heat: Option<&str>) -> Option<PaintShading> {
        match heat {
            None => PaintShading::colour(self.fields_of(COLOUR).cloned().collect()),
            Some(attribute) => {
                PaintShading::heat(attribute, self.fields_of(attribute).cloned().collect())
            }
        }
    }

    /// The painted colour of every vertex of `mesh` (the document's mesh: vertices on
    /// its targets) blended over `base`; `None` when no target was painted with
    /// colour (the mesh keeps its material).
    pub fn vertex_colours(&self, mesh: &WeldedMesh, base: [f32; 3]) -> Option<Vec<[f32; 3]>> {
        Some(self.paint_shading(None)?.colours_over(mesh, base))
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
        Some(
            self.paint_shading(Some(attribute))?
                .colours_over(mesh, base),
        )
    }

    /// The name of the first scalar (not [`COLOUR`]) painted on any target, in
    /// history order: the attribute a heat map shows.
    pub fn first_scalar(&self) -> Option<&str> {
        self.paints
            .iter()
            .map(|p| p.after.name())
            .find(|n| *n != COLOUR)
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
            edit: edit.clone(),
        });
        self.next_id = id + 1;
        self.bump();
        self.redo.clear();
        Ok((id, positions.len()))
    }

    /// Reads the document file's paint strokes into a document that holds its
    /// targets: each is applied again in order, as a paint stroke is (the file keeps
    /// the strokes, not the fields they made), and any the document refuses (a bad
    /// edit, a missing target, a brush off its target) is the file's error.
    pub(super) fn load_paints(&mut self, paints: Vec<PaintEdit>) -> Result<()> {
        if paints.len() > MAX_PAINTS {
            return Err(Error::Document(DocumentError::TooManyPaints {
                max: MAX_PAINTS,
            }));
        }
        for (index, edit) in paints.iter().enumerate() {
            self.apply_paint(edit).map_err(|e| {
                Error::Document(DocumentError::Paint {
                    index,
                    error: Box::new(e),
                })
            })?;
        }
        Ok(())
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
