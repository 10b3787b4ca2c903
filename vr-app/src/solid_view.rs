//! Solid targets in the display server (issue 35 item 3): `--solid MODEL` loads an
//! implicit solid into the base document ([`load_solid`]), and [`SolidView`] writes each
//! solid's watertight mesh into the renderer's mesh sinks, block by block, as the NURBS
//! targets' tessellation is written: a stroke re-meshes only the blocks its tool
//! reaches, and only those are written again.
//!
//! A solid's block `b` is the patch [`solid_patch_key`]: bit 62 set (the NURBS targets'
//! keys hold a target index below [`MAX_TARGETS`](sculpt_core::sculpt::ids::MAX_TARGETS)
//! in bits 32..62, stroke surfaces set bit 63), the solid's slot in bits 32..38 and the
//! block below, so a batch of the renderer holds neighbouring blocks of one solid.

use std::collections::BTreeMap;
use std::path::Path;

use sculpt_core::mesh::{MeshSink, PatchKey};
use sculpt_core::sculpt::document::{Document, TargetId};

use crate::error::{VrError, VrResult};

/// Most bytes of a `--solid` model file (a JSON solid document or a `.vm` model).
pub const MAX_SOLID_MODEL_BYTES: u64 = 64 << 20;

/// The patch key of block `block` of the solid in slot `slot` (see the module docs).
pub fn solid_patch_key(slot: u32, block: usize) -> PatchKey {
    (1 << 62) | (u64::from(slot) << 32) | block as u64
}

/// The text of the model file `path` (a JSON solid document or a `.vm` model), read
/// (at most [`MAX_SOLID_MODEL_BYTES`]) and parsed
/// ([`sculpt_core::implicit::Model::from_text`]) but not meshed: what the display
/// server checks before it opens the GPU or touches a file. A file that cannot be read
/// or is no model is refused and says why.
pub fn read_model(path: &Path) -> VrResult<String> {
    let bytes = fsio::read_capped(path, MAX_SOLID_MODEL_BYTES)?;
    // Invalid UTF-8 becomes U+FFFD, which no model's grammar accepts.
    let text = String::from_utf8_lossy(&bytes).into_owned();
    sculpt_core::implicit::Model::from_text(&text).map_err(|e| VrError::Solid {
        path: path.to_path_buf(),
        reason: e.into(),
    })?;
    Ok(text)
}

/// Adds the solid that the model file `path` holds ([`read_model`]) to `doc` as part
/// of its base (never undone, [`Document::seal_history`]), named by the file's stem and
/// meshed with `cells` grid cells along its longest side. A file that cannot be read,
/// holds no model or a model with nothing inside, or `cells` out of
/// [`sculpt_core::solid::CELLS_RANGE`], is refused and says why.
pub fn load_solid(doc: &mut Document, path: &Path, cells: usize) -> VrResult<TargetId> {
    let text = read_model(path)?;
    let name = path
        .file_stem()
        .map_or_else(|| "solid".to_string(), |s| s.to_string_lossy().into_owned());
    let id = doc.add_solid(&name, &text, cells).map_err(|e| match e {
        sculpt_core::Error::Solid(reason) => VrError::Solid {
            path: path.to_path_buf(),
            reason,
        },
        other => VrError::Core(other),
    })?;
    doc.seal_history();
    Ok(id)
}

/// The kind of the target `id` as the HUD names it: `solid NAME` for a solid target,
/// `sheet` for a NURBS target.
pub fn target_kind(doc: &Document, id: TargetId) -> String {
    doc.solid(id)
        .map_or_else(|| "sheet".to_string(), |s| format!("solid {}", s.name))
}

/// What a [`SolidView`] wrote of one solid.
#[derive(Debug, Default)]
struct Written {
    slot: u32,
    /// Blocks written as patches (non-empty).
    blocks: Vec<usize>,
    /// The stamp of each block as last written ([`SolidTarget::block_stamps`](sculpt_core::solid::SolidTarget::block_stamps); 0: not
    /// written).
    stamps: Vec<u64>,
}

/// Which solid blocks are in a set of mesh sinks. One per set of sinks (a fresh one for
/// empty sinks), kept by the scene beside the document's own tessellation state.
#[derive(Debug, Default)]
pub struct SolidView {
    written: BTreeMap<TargetId, Written>,
}

impl SolidView {
    /// Writes the blocks of the solids that changed since this view last wrote them
    /// into both sinks (a solid has one mesh, shown at every detail; a fresh view writes
    /// every block), and removes the patches of solids no longer in `doc` (an undone
    /// add). A block changed when its stamp ([`SolidTarget::block_stamps`](sculpt_core::solid::SolidTarget::block_stamps)) differs
    /// from the one written, so the document is only read. Returns the patches written.
    pub fn sync(
        &mut self,
        doc: &Document,
        final_detail: &mut dyn MeshSink,
        interactive: &mut dyn MeshSink,
    ) -> usize {
        let gone: Vec<TargetId> = self
            .written
            .keys()
            .copied()
            .filter(|&id| doc.solid(id).is_none())
            .collect();
        for id in gone {
            if let Some(w) = self.written.remove(&id) {
                for &b in &w.blocks {
                    final_detail.remove_patch(solid_patch_key(w.slot, b));
                    interactive.remove_patch(solid_patch_key(w.slot, b));
                }
            }
        }
        let mut patches = 0;
        for record in doc.solids() {
            let slot = self.slot_for(record.id);
            let stamps = record.solid.block_stamps();
            let w = self.written.entry(record.id).or_default();
            w.slot = slot;
            if w.stamps.len() != stamps.len() {
                w.stamps = vec![0; stamps.len()];
            }
            for (b, &stamp) in stamps.iter().enumerate() {
                if w.stamps[b] == stamp {
                    continue;
                }
                w.stamps[b] = stamp;
                let key = solid_patch_key(slot, b);
                let drawn = record.solid.write_block(b, key, final_detail);
                record.solid.write_block(b, key, interactive);
                w.blocks.retain(|&x| x != b);
                if drawn {
                    w.blocks.push(b);
                    patches += 1;
                }
            }
        }
        patches
    }

    /// The slot of solid `id`: its own when written before, else the lowest free one.
    fn slot_for(&self, id: TargetId) -> u32 {
        if let Some(w) = self.written.get(&id) {
            return w.slot;
        }
        (0..)
            .find(|s| self.written.values().all(|w| w.slot != *s))
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::mesh::PatchMesh;
    use sculpt_core::sculpt::stroke::{StrokeInput, Tool};

    const PLATE: &str = r#"{"version": 1, "solid": {"box": {"min": [-0.3, -0.3, -0.01], "max": [0.3, 0.3, 0.01]}}}"#;

    fn triangles(mesh: &PatchMesh) -> usize {
        mesh.patches().map(|(_, p)| p.triangles.len()).sum()
    }

    /// The sinks hold exactly the solid's mesh after the first sync, after a stroke
    /// (only the touched blocks written again) and after the add is undone (removed).
    #[test]
    fn the_sinks_follow_the_solid_through_a_stroke_and_an_undo() {
        let mut doc = Document::new();
        let id = doc.add_solid("plate", PLATE, 48).unwrap();
        let (mut fin, mut live) = (PatchMesh::new(), PatchMesh::new());
        let mut view = SolidView::default();
        let first = view.sync(&doc, &mut fin, &mut live);
        let whole = doc.solid_mesh(id).unwrap();
        assert_eq!(triangles(&fin), whole.triangles.len());
        assert_eq!(triangles(&live), whole.triangles.len());
        assert!(first > 1);
        assert_eq!(view.sync(&doc, &mut fin, &mut live), 0, "nothing changed");
        let samples = (0..=10)
            .map(|i| {
                let x = -0.1 + 0.02 * f64::from(i);
                (f64::from(i), glam::DVec3::new(x, 0.0, 0.01))
            })
            .collect();
        let input = StrokeInput {
            samples,
            tool: Tool {
                width: 0.08,
                depth: 0.05,
                ..Tool::default()
            },
        };
        doc.apply_solid_stroke(id, input).unwrap();
        let again = view.sync(&doc, &mut fin, &mut live);
        assert!(again > 0 && again < first, "{again} of {first}");
        let carved = doc.solid_mesh(id).unwrap();
        // Cut through (a hole: one handle more).
        assert_eq!(sculpt_core::solid::euler_characteristic(&carved), 0);
        assert_eq!(triangles(&fin), carved.triangles.len());
        // Regression (the model/view split): changes were once drained from the
        // document by the first view that asked, so a second view of the same
        // document never saw them. Views now compare stamps and only read.
        let (mut fin2, mut live2) = (PatchMesh::new(), PatchMesh::new());
        SolidView::default().sync(&doc, &mut fin2, &mut live2);
        assert_eq!(triangles(&fin2), carved.triangles.len());
        doc.undo();
        view.sync(&doc, &mut fin, &mut live);
        assert_eq!(triangles(&fin), whole.triangles.len(), "the stroke undone");
        doc.undo();
        view.sync(&doc, &mut fin, &mut live);
        assert!(doc.solids().is_empty());
        assert_eq!(fin.patches().count(), 0);
        assert_eq!(live.patches().count(), 0);
    }

    #[test]
    fn solid_keys_are_neither_target_nor_stroke_keys() {
        let key = solid_patch_key(3, 1000);
        assert_eq!(key >> 63, 0, "not a stroke surface");
        let target = (key >> 32) as u32;
        assert!(target as usize >= sculpt_core::sculpt::ids::MAX_TARGETS);
        assert_ne!(key, crate::scene::PREVIEW_KEY);
    }

    #[test]
    fn bad_model_files_are_refused_with_their_cause() {
        let dir = tempfile::tempdir().unwrap();
        let mut doc = Document::new();
        let missing = dir.path().join("missing.json");
        let e = load_solid(&mut doc, &missing, 32).unwrap_err().to_string();
        assert!(e.contains("missing.json"), "{e}");
        let bad = dir.path().join("bad.vm");
        std::fs::write(&bad, "not a model").unwrap();
        let e = load_solid(&mut doc, &bad, 32).unwrap_err().to_string();
        assert!(e.contains("bad.vm"), "{e}");
        assert!(doc.solids().is_empty());
        let good_text = dir.path().join("cells.json");
        std::fs::write(&good_text, PLATE).unwrap();
        let e = load_solid(&mut doc, &good_text, 4).unwrap_err().to_string();
        assert!(e.contains("cells.json"), "{e}");
        let good = dir.path().join("plate.json");
        std::fs::write(&good, PLATE).unwrap();
        let id = load_solid(&mut doc, &good, 32).unwrap();
        assert_eq!(doc.solid(id).unwrap().name, "plate");
        assert!(!doc.undo(), "the loaded solid is part of the base");
    }
}
