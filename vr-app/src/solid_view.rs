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

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use sculpt_core::mesh::{MeshSink, PatchKey};
use sculpt_core::sculpt::document::{Document, TargetId};
use sculpt_core::solid::SolidPreview;

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

/// What a [`SolidView`] wrote of one solid into one sink.
#[derive(Debug, Default)]
struct Drawn {
    /// Blocks written as patches (non-empty).
    blocks: Vec<usize>,
    /// The stamp of each block as last written ([`SolidTarget::block_stamps`](sculpt_core::solid::SolidTarget::block_stamps),
    /// or a preview block's, [`SolidPreview::blocks`]; 0: not written).
    stamps: Vec<u64>,
}

/// What a [`SolidView`] wrote of one solid: into the final sink and the interactive
/// one (which shows the live groove, [`SolidPreview`]).
#[derive(Debug, Default)]
struct Written {
    slot: u32,
    sinks: [Drawn; 2],
}

impl Drawn {
    /// Writes block `b` with `write` (which says whether it drew a patch) when its
    /// stamp differs from `stamp`; returns the patches written (0 or 1).
    fn write(
        &mut self,
        b: usize,
        stamp: u64,
        sink: &mut dyn MeshSink,
        write: impl FnOnce(&mut dyn MeshSink) -> bool,
    ) -> usize {
        if self.stamps.len() <= b {
            self.stamps.resize(b + 1, 0);
        }
        if self.stamps[b] == stamp {
            return 0;
        }
        self.stamps[b] = stamp;
        let drawn = write(sink);
        self.blocks.retain(|&x| x != b);
        if drawn {
            self.blocks.push(b);
        }
        usize::from(drawn)
    }
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
    /// from the one written, so the document is only read. `preview`, the stroke being
    /// drawn on a solid ([`DocumentView::solid_preview`](sculpt_core::sculpt::view::DocumentView::solid_preview)), is shown in the
    /// interactive sink: the blocks it changes are written with the groove, and written
    /// back as the document has them once it changes or ends. Returns the patches
    /// written.
    pub fn sync(
        &mut self,
        doc: &Document,
        preview: Option<(TargetId, &SolidPreview)>,
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
                for &b in &w.sinks[0].blocks {
                    final_detail.remove_patch(solid_patch_key(w.slot, b));
                }
                for &b in &w.sinks[1].blocks {
                    interactive.remove_patch(solid_patch_key(w.slot, b));
                }
            }
        }
        let mut patches = 0;
        for record in doc.solids() {
            let slot = self.slot_for(record.id);
            let solid = &record.solid;
            let stamps = solid.block_stamps();
            // The preview's blocks of this solid: block -> (index, stamp).
            let shown: HashMap<usize, (usize, u64)> = preview
                .filter(|(id, _)| *id == record.id)
                .map(|(_, p)| {
                    p.blocks()
                        .enumerate()
                        .map(|(k, (b, _, stamp))| (b, (k, stamp)))
                        .collect()
                })
                .unwrap_or_default();
            let w = self.written.entry(record.id).or_default();
            w.slot = slot;
            for (b, &stamp) in stamps.iter().enumerate() {
                let key = solid_patch_key(slot, b);
                patches += w.sinks[0].write(b, stamp, final_detail, |sink| {
                    solid.write_block(b, key, sink)
                });
                let live = shown.get(&b).map_or(stamp, |&(_, s)| s);
                patches += w.sinks[1].write(b, live, interactive, |sink| {
                    match (shown.get(&b), preview) {
                        (Some(&(k, _)), Some((_, p))) => solid.write_preview_block(p, k, key, sink),
                        _ => solid.write_block(b, key, sink),
                    }
                });
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

    /// A document holding the plate (48 cells), its id, and two empty sinks.
    fn plate_and_sinks() -> (Document, TargetId, PatchMesh, PatchMesh) {
        let mut doc = Document::new();
        let id = doc.add_solid("plate", PLATE, 48).unwrap();
        (doc, id, PatchMesh::new(), PatchMesh::new())
    }

    fn triangles(mesh: &PatchMesh) -> usize {
        mesh.patches().map(|(_, p)| p.triangles.len()).sum()
    }

    /// The sinks hold exactly the solid's mesh after the first sync, after a stroke
    /// (only the touched blocks written again) and after the add is undone (removed).
    #[test]
    fn the_sinks_follow_the_solid_through_a_stroke_and_an_undo() {
        let (mut doc, id, mut fin, mut live) = plate_and_sinks();
        let mut view = SolidView::default();
        let first = view.sync(&doc, None, &mut fin, &mut live);
        let whole = doc.solid_mesh(id).unwrap();
        assert_eq!(triangles(&fin), whole.triangles.len());
        assert_eq!(triangles(&live), whole.triangles.len());
        assert!(first > 1);
        assert_eq!(
            view.sync(&doc, None, &mut fin, &mut live),
            0,
            "nothing changed"
        );
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
        let again = view.sync(&doc, None, &mut fin, &mut live);
        assert!(again > 0 && again < first, "{again} of {first}");
        let carved = doc.solid_mesh(id).unwrap();
        // Cut through (a hole: one handle more).
        assert_eq!(sculpt_core::solid::euler_characteristic(&carved), 0);
        assert_eq!(triangles(&fin), carved.triangles.len());
        // Regression (the model/view split): changes were once drained from the
        // document by the first view that asked, so a second view of the same
        // document never saw them. Views now compare stamps and only read.
        let (mut fin2, mut live2) = (PatchMesh::new(), PatchMesh::new());
        SolidView::default().sync(&doc, None, &mut fin2, &mut live2);
        assert_eq!(triangles(&fin2), carved.triangles.len());
        doc.undo();
        view.sync(&doc, None, &mut fin, &mut live);
        assert_eq!(triangles(&fin), whole.triangles.len(), "the stroke undone");
        doc.undo();
        view.sync(&doc, None, &mut fin, &mut live);
        assert!(doc.solids().is_empty());
        assert_eq!(fin.patches().count(), 0);
        assert_eq!(live.patches().count(), 0);
    }

    /// A patch's vertex positions and triangles.
    type Shape = (Vec<[f32; 3]>, Vec<[u32; 3]>);

    /// Each patch's positions and triangles (the drawn normals of a block the stroke
    /// leaves as it was keep the field without it).
    fn shapes(mesh: &PatchMesh) -> Vec<(u64, Shape)> {
        mesh.patches()
            .map(|(k, p)| {
                let positions = p.vertices.iter().map(|v| v.position).collect();
                (k, (positions, p.triangles.clone()))
            })
            .collect()
    }

    /// The live groove (issue 35 item 3): while a stroke is drawn on a solid, the
    /// interactive sink shows the solid carved by it, patch for patch (positions and
    /// triangles) what the applied stroke gives, while the final sink and the document
    /// stay as they were; once the preview ends the interactive sink holds the
    /// document's solid again.
    #[test]
    fn the_interactive_sink_shows_the_groove_being_drawn() {
        use sculpt_core::sculpt::view::DocumentView;
        let (doc, id, mut fin, mut live) = plate_and_sinks();
        let mut solids = SolidView::default();
        let mut view = DocumentView::new();
        solids.sync(&doc, view.solid_preview(), &mut fin, &mut live);
        let (before_fin, before_live) = (fin.clone(), live.clone());
        let samples: Vec<_> = (0..=10)
            .map(|i| {
                let x = -0.1 + 0.02 * f64::from(i);
                (f64::from(i), glam::DVec3::new(x, 0.0, 0.01))
            })
            .collect();
        let input = |n: usize| StrokeInput {
            samples: samples[..n].to_vec(),
            tool: Tool {
                width: 0.08,
                depth: 0.05,
                ..Tool::default()
            },
        };
        // The stroke grows sample by sample, as the wand draws it.
        for n in [4, 11] {
            view.set_preview(&doc, id, &input(n)).unwrap();
            let written = solids.sync(&doc, view.solid_preview(), &mut fin, &mut live);
            assert!(written > 0, "{n} samples: the groove written");
            assert_eq!(fin, before_fin, "the final sink is the document's");
            let mut carved = doc.clone();
            carved.apply_solid_stroke(id, input(n)).unwrap();
            let (mut carved_fin, mut carved_live) = (PatchMesh::new(), PatchMesh::new());
            SolidView::default().sync(&carved, None, &mut carved_fin, &mut carved_live);
            assert!(
                shapes(&live) == shapes(&carved_live),
                "{n} samples: the preview is the stroke applied"
            );
            assert_ne!(live, before_live);
        }
        assert!(
            doc.solid(id).unwrap().solid.cuts().is_empty(),
            "not applied"
        );
        view.clear_preview();
        solids.sync(&doc, view.solid_preview(), &mut fin, &mut live);
        assert_eq!(live, before_live, "the groove gone with the preview");
        assert_eq!(fin, before_fin);
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
