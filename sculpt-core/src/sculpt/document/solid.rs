//! Solid targets in the document ([`crate::solid`]): implicit solids beside the NURBS
//! targets, with ids from the same sequence. A stroke edit that names a solid
//! ([`crate::editor::apply`]) carves it ([`Document::apply_solid_stroke`]); adding a
//! solid and every stroke on one are steps of the one history, undone and redone in
//! order with the others, and saved in the document file (`"solids"`, see
//! [`super::json`]).

use super::json::{SolidJson, SolidStrokeJson};
use super::{Document, Step, StrokeId, TargetId};
use crate::error::{DocumentError, Error, Result};
use crate::mesh::WeldedMesh;
use crate::sculpt::stroke::StrokeInput;
use crate::solid::{Cut, Remeshed, SolidTarget};

/// Most solid targets a document holds.
pub const MAX_SOLIDS: usize = 64;

/// A solid target.
#[derive(Debug, Clone, PartialEq)]
pub struct SolidRecord {
    /// Its id (from the same sequence as the NURBS targets).
    pub id: TargetId,
    /// A name for people.
    pub name: String,
    /// The solid with its strokes.
    pub solid: SolidTarget,
}

/// A solid step of the history, as kept for redo.
#[derive(Debug, Clone, PartialEq)]
pub enum SolidStep {
    /// A solid was added.
    Added(Box<SolidRecord>),
    /// A stroke was carved into the solid with this id.
    Cut(TargetId, Box<Cut>),
}

impl Document {
    /// The solid targets, in order.
    pub fn solids(&self) -> &[SolidRecord] {
        &self.solids
    }

    /// The solid target with id `id`.
    pub fn solid(&self, id: TargetId) -> Option<&SolidRecord> {
        self.solids.iter().find(|s| s.id == id)
    }

    /// Every target a stroke may name: the NURBS targets, then the solids.
    pub fn stroke_target_ids(&self) -> Vec<TargetId> {
        self.targets
            .iter()
            .map(|t| t.id)
            .chain(self.solids.iter().map(|s| s.id))
            .collect()
    }

    /// Adds the solid that `text` describes (a solid document or a `.vm` model),
    /// meshed with `cells` grid cells along its longest side, as an undoable step.
    pub fn add_solid(&mut self, name: &str, text: &str, cells: usize) -> Result<TargetId> {
        if self.solids.len() >= MAX_SOLIDS {
            return Err(Error::Document(DocumentError::TooManySolids {
                max: MAX_SOLIDS,
            }));
        }
        let solid = SolidTarget::new(text, cells)?;
        let id = self.fresh_id();
        self.bump();
        self.redo.clear();
        self.solid_history.push(id);
        self.solids.push(SolidRecord {
            id,
            name: name.to_string(),
            solid,
        });
        Ok(id)
    }

    /// Carves (or embosses) `input` into the solid `target` as one undoable step. A
    /// refused stroke leaves the document unchanged and says why.
    pub fn apply_solid_stroke(
        &mut self,
        target: TargetId,
        input: StrokeInput,
    ) -> Result<(StrokeId, Remeshed)> {
        self.check_stroke_caps(input.samples.len())?;
        let id = self.next_id.max(1);
        let record = self
            .solids
            .iter_mut()
            .find(|s| s.id == target)
            .ok_or(Error::NotFound {
                kind: "target",
                id: target,
            })?;
        let remeshed = record.solid.cut(id, &input)?;
        self.samples_total += input.samples.len();
        self.next_id = id + 1;
        self.bump();
        self.redo.clear();
        self.solid_history.push(id);
        Ok((id, remeshed))
    }

    /// The mesh of the solid `id`: closed, 2-manifold, wound outward.
    pub fn solid_mesh(&self, id: TargetId) -> Option<WeldedMesh> {
        self.solid(id).map(|s| s.solid.mesh())
    }

    /// The box holding every solid's grid, display frame; `None` without solids.
    pub fn solid_bounds(&self) -> Option<(glam::DVec3, glam::DVec3)> {
        self.solids
            .iter()
            .map(|s| {
                let f = s.solid.frame();
                let size = glam::DVec3::from(f.n.map(|k| k as f64)) * f.h;
                (f.lo, f.lo + size)
            })
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }

    /// Appends every solid's mesh to `mesh` (the exports write targets and solids as
    /// one mesh; each solid's part stays closed).
    pub fn append_solid_meshes(&self, mesh: &mut WeldedMesh) {
        for s in &self.solids {
            let part = s.solid.mesh();
            let base = mesh.vertices.len() as u32;
            mesh.vertices.extend(part.vertices);
            mesh.triangles
                .extend(part.triangles.iter().map(|t| t.map(|v| v + base)));
        }
    }

    /// The id of the last solid step (undo takes the newest step of every kind).
    pub(super) fn last_solid_step(&self) -> Option<u64> {
        self.solid_history.last().copied()
    }

    /// Undoes the last solid step (the caller checked it is the last step).
    pub(super) fn pop_solid_step(&mut self) -> Option<Step> {
        let id = self.solid_history.pop()?;
        if self.solids.last().is_some_and(|s| s.id == id) {
            let record = self.solids.pop()?;
            return Some(Step::Solid(SolidStep::Added(Box::new(record))));
        }
        let record = self
            .solids
            .iter_mut()
            .find(|s| s.solid.cuts().last().is_some_and(|c| c.id == id))?;
        let cut = record.solid.uncut()?;
        self.samples_total -= cut.input.samples.len();
        Some(Step::Solid(SolidStep::Cut(record.id, Box::new(cut))))
    }

    /// Redoes an undone solid step; false (nothing changed) should it not apply.
    pub(super) fn push_solid_step(&mut self, step: SolidStep) -> bool {
        match step {
            SolidStep::Added(record) => {
                self.next_id = self.next_id.max(record.id + 1);
                self.solid_history.push(record.id);
                self.solids.push(*record);
                true
            }
            SolidStep::Cut(target, cut) => {
                let Some(record) = self.solids.iter_mut().find(|s| s.id == target) else {
                    return false;
                };
                let id = cut.id;
                self.samples_total += cut.input.samples.len();
                record.solid.recut(*cut);
                self.next_id = self.next_id.max(id + 1);
                self.solid_history.push(id);
                true
            }
        }
    }
}

impl Document {
    /// The solids as the document file writes them.
    pub(super) fn solids_json(&self) -> Vec<SolidJson> {
        self.solids
            .iter()
            .map(|s| SolidJson {
                id: s.id,
                name: s.name.clone(),
                model: s.solid.text().to_string(),
                cells: s.solid.cells(),
                strokes: s
                    .solid
                    .cuts()
                    .iter()
                    .map(|c| SolidStrokeJson {
                        id: c.id,
                        tool: c.input.tool.clone(),
                        samples: super::json::samples_json(&c.input),
                    })
                    .collect(),
            })
            .collect()
    }

    /// Reads the file's solids into a document that holds its targets and strokes:
    /// ids must be new, every stroke must carve again as it did.
    pub(super) fn load_solids(&mut self, solids: Vec<SolidJson>) -> Result<()> {
        if solids.len() > MAX_SOLIDS {
            return Err(Error::Document(DocumentError::TooManySolids {
                max: MAX_SOLIDS,
            }));
        }
        let mut seen: Vec<u64> = self.stroke_target_ids();
        seen.extend(self.strokes.iter().map(|s| s.id));
        for s in solids {
            if s.id == 0 || seen.contains(&s.id) {
                return Err(Error::Document(DocumentError::TargetId { id: s.id }));
            }
            seen.push(s.id);
            let mut solid = SolidTarget::new(&s.model, s.cells)?;
            for c in s.strokes {
                if c.id == 0 || seen.contains(&c.id) {
                    return Err(Error::Document(DocumentError::StrokeId { id: c.id }));
                }
                seen.push(c.id);
                self.check_stroke_caps(c.samples.len())?;
                let input = super::json::input_from_json(&c.samples, c.tool);
                let id = c.id;
                solid.cut(id, &input).map_err(|e| {
                    Error::Document(DocumentError::Stroke {
                        id,
                        error: Box::new(e.into()),
                    })
                })?;
                self.samples_total += input.samples.len();
            }
            self.solids.push(SolidRecord {
                id: s.id,
                name: s.name,
                solid,
            });
        }
        self.next_id = self
            .next_id
            .max(seen.iter().copied().max().unwrap_or(0) + 1);
        Ok(())
    }
}
