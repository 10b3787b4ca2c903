//! The document file: JSON with its targets and stroke inputs.

use super::*;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DocumentJson {
    pub(super) format: String,
    pub(super) version: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) description: Option<String>,
    pub(super) targets: Vec<TargetJson>,
    pub(super) strokes: Vec<StrokeJson>,
    /// Solid targets with their strokes ([`super::solid`]); absent when there are none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) solids: Vec<SolidJson>,
    /// Paint strokes in the order applied (the journal's `paint` edits,
    /// [`crate::paint::PaintEdit`]); absent when nothing is painted, so a file from
    /// before paint reads as unpainted.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) paints: Vec<crate::paint::PaintEdit>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TargetJson {
    pub(super) id: u64,
    pub(super) name: String,
    pub(super) surface: NurbsSurface,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct StrokeJson {
    pub(super) id: u64,
    pub(super) target: u64,
    pub(super) tool: Tool,
    pub(super) samples: Vec<[f64; 4]>,
}

#[derive(Deserialize)]
pub(super) struct Header {
    pub(super) format: Option<String>,
    pub(super) version: Option<serde_json::Value>,
}

impl Document {
    /// The document as JSON bytes (format of the module docs). Undo history is not saved.
    pub fn to_json(&self) -> Vec<u8> {
        let doc = DocumentJson {
            format: FORMAT.into(),
            version: VERSION,
            description: None,
            targets: self
                .targets
                .iter()
                .map(|t| TargetJson {
                    id: t.id,
                    name: t.name.clone(),
                    surface: t.surface.clone(),
                })
                .collect(),
            strokes: self
                .strokes
                .iter()
                .map(|s| StrokeJson {
                    id: s.id,
                    target: s.target,
                    tool: s.input.tool.clone(),
                    samples: samples_json(&s.input),
                })
                .collect(),
            solids: self.solids_json(),
            paints: self.paints.iter().map(|p| p.edit.clone()).collect(),
        };
        serde_json::to_vec_pretty(&doc).unwrap_or_default()
    }

    /// Reads a document, replaying every stroke; rejects bad files with a clear error.
    pub fn from_json(bytes: &[u8]) -> Result<Self> {
        if bytes.len() > MAX_DOCUMENT_BYTES {
            return Err(Error::Document(DocumentError::TooLarge {
                bytes: bytes.len(),
                max: MAX_DOCUMENT_BYTES,
            }));
        }
        let header: Header = serde_json::from_slice(bytes)
            .map_err(|e| Error::Document(DocumentError::NotAnObject(e.into())))?;
        if header.format.as_deref() != Some(FORMAT) {
            return Err(Error::Document(DocumentError::Format {
                expected: FORMAT,
                found: header.format.as_deref().map(crate::error::Excerpt::new),
            }));
        }
        match header.version.as_ref().and_then(serde_json::Value::as_u64) {
            Some(v) if v == u64::from(VERSION) => {}
            other => {
                return Err(Error::Document(DocumentError::Version {
                    found: other,
                    supported: VERSION,
                }));
            }
        }
        let json: DocumentJson = serde_json::from_slice(bytes)
            .map_err(|e| Error::Document(DocumentError::Schema(e.into())))?;
        if json.targets.len() > MAX_TARGETS {
            return Err(Error::Document(DocumentError::TooManyTargets {
                max: MAX_TARGETS,
            }));
        }
        if json.strokes.len() > MAX_STROKES {
            return Err(Error::Document(DocumentError::TooManyStrokes {
                max: MAX_STROKES,
            }));
        }
        let mut doc = Document::new();
        for t in json.targets {
            if t.id == 0 || doc.targets.iter().any(|o| o.id == t.id) {
                return Err(Error::Document(DocumentError::TargetId { id: t.id }));
            }
            // Surfaces are read with the surface reader's caps; this is the same cap.
            doc.check_target_caps(&t.surface)?;
            doc.push_target(TargetRecord::new(t.id, t.name, t.surface));
        }
        for s in json.strokes {
            if s.id == 0 || doc.targets.iter().any(|t| t.id == s.id) {
                return Err(Error::Document(DocumentError::StrokeId { id: s.id }));
            }
            let input = input_from_json(&s.samples, s.tool);
            let id = s.id;
            doc.push_stroke(StrokeRecord {
                id,
                target: s.target,
                input,
            })
            .map_err(|e| {
                Error::Document(DocumentError::Stroke {
                    id,
                    error: Box::new(e),
                })
            })?;
        }
        doc.next_id = doc
            .targets
            .iter()
            .map(|t| t.id)
            .chain(doc.strokes.iter().map(|s| s.id))
            .max()
            .unwrap_or(0)
            + 1;
        doc.load_solids(json.solids)?;
        doc.load_paints(json.paints)?;
        // A loaded document has no history: what it holds is the base.
        doc.seal_history();
        Ok(doc)
    }
}

/// A stroke's samples as the file writes them: `[t, x, y, z]`.
pub(super) fn samples_json(input: &StrokeInput) -> Vec<[f64; 4]> {
    input
        .samples
        .iter()
        .map(|(t, p)| [*t, p.x, p.y, p.z])
        .collect()
}

/// A stroke read from the file's samples and tool.
pub(super) fn input_from_json(samples: &[[f64; 4]], tool: Tool) -> StrokeInput {
    StrokeInput {
        samples: samples
            .iter()
            .map(|a| (a[0], DVec3::new(a[1], a[2], a[3])))
            .collect(),
        tool,
    }
}

/// A solid target in the document file: `{"id": 3, "name": "plate", "model": "<solid
/// document or .vm text>", "cells": 128, "strokes": [{"id": 4, "tool": {..},
/// "samples": [[t, x, y, z], ..]}]}`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SolidJson {
    pub(super) id: u64,
    pub(super) name: String,
    pub(super) model: String,
    pub(super) cells: usize,
    pub(super) strokes: Vec<SolidStrokeJson>,
}

/// A stroke on a solid in the document file.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SolidStrokeJson {
    pub(super) id: u64,
    pub(super) tool: Tool,
    pub(super) samples: Vec<[f64; 4]>,
}
