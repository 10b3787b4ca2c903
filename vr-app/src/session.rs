//! The sculpting session: the interaction state machine, the scene document, the
//! operation journal and the operator log, tied together without any GPU.
//!
//! Every edit the state machine emits is appended to the journal (and fsync'd)
//! *before* it is applied, so an operation the sculptor saw happen survives a crash;
//! [`Session::open`] replays the journal to recover. Operator events go to
//! `operator.log` (JSON lines: `{"t":..,"op":..}`) for the GOMS harness.
//!
//! ```
//! use vr_app::session::Session;
//! use vr_app::config::Config;
//! let dir = tempfile::tempdir().unwrap();
//! let mut cfg = Config::default();
//! cfg.files.dir = dir.path().to_path_buf();
//! let session = Session::open(&cfg)?;
//! assert_eq!(session.doc.targets.len(), 1, "a fresh session has the default surface");
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;
use sculpt_core::interaction::{Edit, Interaction, OperatorEvent, Output, StrokeEdit, WandEvent};
use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::error::{VrError, VrResult};
use crate::journal::Journal;

/// The journal's file name inside the session directory.
pub const JOURNAL_FILE: &str = "session.journal";
/// The operator log's file name.
pub const OPLOG_FILE: &str = "operator.log";
/// The autosaved document's file name.
pub const AUTOSAVE_FILE: &str = "autosave.wsdoc.json";
/// The explicitly saved document's file name.
pub const DOCUMENT_FILE: &str = "document.wsdoc.json";
/// Document format name and version.
pub const DOC_FORMAT: &str = "wandsculpt-scene";
/// Current document version.
pub const DOC_VERSION: u32 = 1;

/// A target surface, as the point grid it was sketched (or built) from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// Rows of points (display frame metres), all rows the same length.
    pub grid: Vec<Vec<DVec3>>,
}

/// The scene document: target surfaces and the strokes applied to them, in order, with
/// undo and redo.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneDoc {
    /// Format name, always [`DOC_FORMAT`].
    pub format: String,
    /// Format version.
    pub version: u32,
    /// Target surfaces; the first is the starting surface.
    pub targets: Vec<Target>,
    /// Applied strokes.
    pub strokes: Vec<StrokeEdit>,
    /// The selected target.
    pub selected: u32,
    /// Applied content edits in order (sketches and strokes), for undo.
    pub history: Vec<Edit>,
    /// Undone edits, most recent last.
    pub redo: Vec<Edit>,
}

/// What changed in the document, for incremental re-meshing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Changes {
    /// Targets were added or removed.
    pub targets: bool,
    /// Strokes were added or removed.
    pub strokes: bool,
}

impl SceneDoc {
    /// A document with one starting surface.
    pub fn new(base: Target) -> Self {
        Self {
            format: DOC_FORMAT.into(),
            version: DOC_VERSION,
            targets: vec![base],
            strokes: Vec::new(),
            selected: 0,
            history: Vec::new(),
            redo: Vec::new(),
        }
    }

    /// Applies an edit. Undo with nothing to undo (and redo likewise) changes nothing.
    pub fn apply(&mut self, edit: &Edit) -> Changes {
        match edit {
            Edit::Sketch { .. } | Edit::Stroke(_) => {
                self.redo.clear();
                self.push(edit.clone())
            }
            Edit::Undo => match self.history.pop() {
                Some(e) => {
                    let c = match &e {
                        Edit::Sketch { .. } => {
                            self.targets.pop();
                            self.selected = self
                                .selected
                                .min(self.targets.len().saturating_sub(1) as u32);
                            Changes {
                                targets: true,
                                strokes: false,
                            }
                        }
                        _ => {
                            self.strokes.pop();
                            Changes {
                                targets: false,
                                strokes: true,
                            }
                        }
                    };
                    self.redo.push(e);
                    c
                }
                None => Changes::default(),
            },
            Edit::Redo => match self.redo.pop() {
                Some(e) => self.push(e),
                None => Changes::default(),
            },
            Edit::SelectTarget { index } => {
                if (*index as usize) < self.targets.len() {
                    self.selected = *index;
                }
                Changes::default()
            }
            Edit::Save => Changes::default(),
        }
    }

    fn push(&mut self, e: Edit) -> Changes {
        let c = match &e {
            Edit::Sketch { rows } => {
                self.targets.push(Target { grid: rows.clone() });
                Changes {
                    targets: true,
                    strokes: false,
                }
            }
            Edit::Stroke(s) => {
                self.strokes.push(s.clone());
                Changes {
                    targets: false,
                    strokes: true,
                }
            }
            _ => return Changes::default(),
        };
        self.history.push(e);
        c
    }

    /// Serialises to pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Parses a document, rejecting other formats and newer versions.
    pub fn from_json(text: &str) -> VrResult<Self> {
        let doc: SceneDoc =
            serde_json::from_str(text).map_err(|e| VrError::Config(format!("document: {e}")))?;
        if doc.format != DOC_FORMAT {
            return Err(VrError::Config(format!(
                "document: format {:?} is not {DOC_FORMAT:?}",
                doc.format
            )));
        }
        if doc.version > DOC_VERSION {
            return Err(VrError::Config(format!(
                "document: version {} is newer than {DOC_VERSION}",
                doc.version
            )));
        }
        if doc.targets.is_empty() || doc.selected as usize >= doc.targets.len() {
            return Err(VrError::Config(
                "document: no targets, or the selection is out of range".into(),
            ));
        }
        Ok(doc)
    }

    /// Writes the document atomically (temporary file, fsync, rename).
    pub fn save(&self, path: &Path) -> VrResult<()> {
        let tmp = path.with_extension("tmp");
        let io = |p: &Path, source| VrError::Io {
            path: p.display().to_string(),
            source,
        };
        let mut f = File::create(&tmp).map_err(|e| io(&tmp, e))?;
        f.write_all(self.to_json().as_bytes())
            .map_err(|e| io(&tmp, e))?;
        f.sync_all().map_err(|e| io(&tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| io(path, e))
    }
}

/// The default starting surface: a gently curved 1 m x 0.6 m sheet facing the viewer,
/// as a 9 x 9 point grid, centred at `center`.
pub fn default_target(center: DVec3) -> Target {
    let n = 9;
    let grid = (0..n)
        .map(|i| {
            let v = i as f64 / (n - 1) as f64 - 0.5;
            (0..n)
                .map(|j| {
                    let u = j as f64 / (n - 1) as f64 - 0.5;
                    center + DVec3::new(u * 1.0, v * 0.6, -0.25 * (u * u * 2.0 + v * v))
                })
                .collect()
        })
        .collect();
    Target { grid }
}

/// A running session.
#[derive(Debug)]
pub struct Session {
    /// The interaction state machine.
    pub interaction: Interaction,
    /// The document.
    pub doc: SceneDoc,
    dir: PathBuf,
    journal: Journal,
    oplog: BufWriter<File>,
    autosave_every: u32,
    since_autosave: u32,
    /// Operations recovered from the journal at open.
    pub recovered: usize,
    /// Changes since the last [`Session::take_changes`].
    changes: Changes,
    outputs: Vec<Output>,
}

impl Session {
    /// Opens the session in `config.files.dir`: creates the directory, replays the
    /// journal (recovering after a crash) and opens the operator log for appending.
    pub fn open(config: &Config) -> VrResult<Self> {
        let dir = config.files.dir.clone();
        std::fs::create_dir_all(&dir).map_err(|source| VrError::Io {
            path: dir.display().to_string(),
            source,
        })?;
        let screen = config.screen.screen()?;
        let (_, _, vn) = screen.basis();
        let base = default_target(screen.center() - vn * 0.1);
        let (journal, entries) = Journal::open(dir.join(JOURNAL_FILE))?;
        let mut doc = SceneDoc::new(base);
        for e in &entries {
            doc.apply(&e.edit);
        }
        let oplog_path = dir.join(OPLOG_FILE);
        let oplog = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&oplog_path)
            .map_err(|source| VrError::Io {
                path: oplog_path.display().to_string(),
                source,
            })?;
        let mut interaction =
            Interaction::new(config.interaction, config.tool.mode, config.tool.tool());
        interaction.set_target_count(doc.targets.len() as u32);
        if doc.selected > 0 {
            let mut sink = Vec::new();
            interaction.handle(
                &WandEvent::command(
                    0.0,
                    sculpt_core::interaction::Command::SelectTarget {
                        index: doc.selected,
                    },
                ),
                &mut sink,
            )?;
        }
        if !entries.is_empty() {
            tracing::info!(
                operations = entries.len(),
                "recovered the session from its journal"
            );
        }
        Ok(Self {
            interaction,
            doc,
            dir,
            journal,
            oplog: BufWriter::new(oplog),
            autosave_every: config.files.autosave_every,
            since_autosave: 0,
            recovered: entries.len(),
            changes: Changes {
                targets: true,
                strokes: true,
            },
            outputs: Vec::new(),
        })
    }

    /// The session directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Operations in the journal.
    pub fn operations(&self) -> u64 {
        self.journal.len()
    }

    /// Feeds one wand event. Invalid events (time going backwards) are logged and
    /// dropped; edits are journalled, then applied. Returns the edits applied.
    pub fn handle(&mut self, ev: &WandEvent) -> VrResult<Vec<Edit>> {
        self.outputs.clear();
        if let Err(e) = self.interaction.handle(ev, &mut self.outputs) {
            tracing::warn!("dropped an input: {e}");
            return Ok(Vec::new());
        }
        self.consume(ev.t)
    }

    /// Advances time with no input (ends strokes paused too long by tracking loss).
    pub fn tick(&mut self, t: f64) -> VrResult<Vec<Edit>> {
        self.outputs.clear();
        self.interaction.tick(t, &mut self.outputs);
        self.consume(t)
    }

    fn consume(&mut self, t: f64) -> VrResult<Vec<Edit>> {
        let outputs = std::mem::take(&mut self.outputs);
        let mut applied = Vec::new();
        for o in &outputs {
            match o {
                Output::Op { t, event } => self.log_op(*t, event)?,
                Output::Edit(edit) => {
                    let seq = self.journal.append(t, edit)?;
                    tracing::info!(seq, "operation committed");
                    let c = self.doc.apply(edit);
                    self.changes.targets |= c.targets;
                    self.changes.strokes |= c.strokes;
                    self.interaction
                        .set_target_count(self.doc.targets.len() as u32);
                    if *edit == Edit::Save {
                        self.save_document()?;
                    }
                    self.since_autosave += 1;
                    if self.autosave_every > 0 && self.since_autosave >= self.autosave_every {
                        self.autosave()?;
                    }
                    applied.push(edit.clone());
                }
            }
        }
        self.outputs = outputs;
        Ok(applied)
    }

    fn log_op(&mut self, t: f64, event: &OperatorEvent) -> VrResult<()> {
        #[derive(Serialize)]
        struct Line<'a> {
            t: f64,
            #[serde(flatten)]
            event: &'a OperatorEvent,
        }
        let line = serde_json::to_string(&Line { t, event })
            .map_err(|e| VrError::Config(e.to_string()))?;
        writeln!(self.oplog, "{line}").map_err(|source| VrError::Io {
            path: self.dir.join(OPLOG_FILE).display().to_string(),
            source,
        })
    }

    /// Flushes the operator log.
    pub fn flush(&mut self) -> VrResult<()> {
        self.oplog.flush().map_err(|source| VrError::Io {
            path: self.dir.join(OPLOG_FILE).display().to_string(),
            source,
        })
    }

    /// Writes the autosave document.
    pub fn autosave(&mut self) -> VrResult<PathBuf> {
        self.since_autosave = 0;
        let p = self.dir.join(AUTOSAVE_FILE);
        self.doc.save(&p)?;
        Ok(p)
    }

    /// Writes the document to the session directory's document file.
    pub fn save_document(&mut self) -> VrResult<PathBuf> {
        let p = self.dir.join(DOCUMENT_FILE);
        self.doc.save(&p)?;
        self.flush()?;
        Ok(p)
    }

    /// What changed since the last call.
    pub fn take_changes(&mut self) -> Changes {
        std::mem::take(&mut self.changes)
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        // Best effort on a clean exit; the journal (not this log) is what recovery needs.
        let _ = self.oplog.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use sculpt_core::interaction::{Command, WandSample};

    fn config(dir: &Path) -> Config {
        let mut c = Config::default();
        c.files.dir = dir.to_path_buf();
        c.files.autosave_every = 2;
        c
    }

    fn stroke(s: &mut Session, t0: f64, x0: f64) {
        for i in 0..=5 {
            let p = DVec3::new(x0 + i as f64 * 0.01, 1.17, 0.0);
            s.handle(&WandEvent::sample(
                t0 + i as f64 * 0.01,
                WandSample::tracked(p, DQuat::IDENTITY, u32::from(i < 5)),
            ))
            .unwrap();
        }
    }

    #[test]
    fn edits_are_journalled_applied_and_recovered() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = config(dir.path());
        {
            let mut s = Session::open(&cfg).unwrap();
            stroke(&mut s, 0.0, 0.0);
            stroke(&mut s, 1.0, 0.1);
            s.handle(&WandEvent::command(2.0, Command::Undo)).unwrap();
            assert_eq!(s.doc.strokes.len(), 1);
            assert_eq!(s.operations(), 3);
            assert!(
                dir.path().join(AUTOSAVE_FILE).exists(),
                "autosave after 2 operations"
            );
        }
        let s = Session::open(&cfg).unwrap();
        assert_eq!(s.recovered, 3);
        assert_eq!(s.doc.strokes.len(), 1);
        assert_eq!(s.doc.redo.len(), 1);
        let log = std::fs::read_to_string(dir.path().join(OPLOG_FILE)).unwrap();
        assert!(log.contains("\"op\":\"gesture-start\""));
        assert!(log.contains("\"op\":\"button-down\""));
    }

    #[test]
    fn undo_redo_sketch_and_documents_round_trip() {
        let mut d = SceneDoc::new(default_target(DVec3::ZERO));
        let sketch = Edit::Sketch {
            rows: vec![vec![DVec3::ZERO, DVec3::X]; 4],
        };
        assert!(d.apply(&sketch).targets);
        d.apply(&Edit::SelectTarget { index: 1 });
        assert_eq!(d.selected, 1);
        d.apply(&Edit::Undo);
        assert_eq!((d.targets.len(), d.selected), (1, 0));
        assert_eq!(
            d.apply(&Edit::Undo),
            Changes::default(),
            "nothing left to undo"
        );
        d.apply(&Edit::Redo);
        assert_eq!(d.targets.len(), 2);
        let back = SceneDoc::from_json(&d.to_json()).unwrap();
        assert_eq!(back, d);
        assert!(SceneDoc::from_json("{}").is_err());
        let mut newer = d.clone();
        newer.version = 99;
        assert!(
            SceneDoc::from_json(&newer.to_json())
                .unwrap_err()
                .to_string()
                .contains("newer")
        );
    }
}
