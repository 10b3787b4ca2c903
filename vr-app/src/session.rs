//! The sculpting session: the shared edit loop ([`EditLoop`]: the interaction state
//! machine and the sculpted [`Document`]), the operation journal and the operator log,
//! tied together without any GPU.
//!
//! The document starts from a base scene (the shared
//! [`editor::default_document`], or a `--scene` / `files.scene` file in the
//! [`Document::to_json`] format). Every edit the state machine emits is appended to the
//! journal (and fsync'd) *before* the [`EditLoop`] applies it (the loop `replay` runs
//! too, in an [`EditHooks::before_apply`]), so an operation the sculptor saw happen
//! survives a crash; [`Session::open`] re-applies the journal to the base scene to
//! recover.
//!
//! Files in the session directory:
//! - [`JOURNAL_FILE`] (`session.journal`): the operation journal ([`crate::journal`]);
//! - [`DOCUMENT_FILE`] (`scene.json`): the saved document, [`Document::to_json`] bytes,
//!   written on a save command and when a headless run ends;
//! - [`AUTOSAVE_FILE`] (`autosave.scene.json`): the same format, every
//!   `files.autosave_every` operations;
//! - [`OPLOG_FILE`] (`operator.log`): the operator events of this run in the
//!   `sculpt_core::oplog` format (header `source = "wandsculpt"`), appended and flushed
//!   per event, read by `sculpt-tools goms`. A log left by an earlier run is kept as
//!   `operator.N.log` (the first free `N`), since each run's clock starts at zero.
//!   Desktop keys are logged as `key` events ([`Session::key`], a K operator), and so
//!   are the mouse presses that are no wand button ([`Session::mouse`]). The
//!   log is cut into segments, one per interaction mode
//!   ([`sculpt_core::oplog::ModeSegments`], as `replay` does), so `sculpt-tools goms`
//!   counts each operator under the mode it was made in. In study mode ([`Session::start_study`]) the
//!   study's method is the method and the study's trials are the segments.
//!
//! ```
//! use vr_app::session::Session;
//! use vr_app::config::Config;
//! let dir = tempfile::tempdir().unwrap();
//! let mut cfg = Config::default();
//! cfg.files.dir = dir.path().to_path_buf();
//! let session = Session::open(&cfg)?;
//! assert_eq!(session.doc.targets().len(), 1, "a fresh session has the default surface");
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::fs::File;
use std::io::Write;
use std::ops::Deref;
use std::path::{Path, PathBuf};

use sculpt_core::edit_loop::{EditHooks, EditLoop, LoopError, NoHooks, Step};
use sculpt_core::editor::{self, Applied};
use sculpt_core::error::{Chain, StrokeRejection};
use sculpt_core::interaction::{Command, Edit, Interaction, OperatorEvent, TargetIndex, WandEvent};
use sculpt_core::oplog::{EventKind, ModeSegments, OpEvent, OpLogHeader, OpLogWriter};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::view::DocumentView;

use crate::config::Config;
use crate::error::{JournalError, VrError, VrResult};
use crate::journal::{self, Journal};

/// The journal's file name inside the session directory.
pub const JOURNAL_FILE: &str = "session.journal";
/// The operator log's file name.
pub const OPLOG_FILE: &str = "operator.log";
/// The autosaved document's file name.
pub const AUTOSAVE_FILE: &str = "autosave.scene.json";
/// The saved document's file name.
pub const DOCUMENT_FILE: &str = "scene.json";
/// The `source` written in the operator log's header.
pub const OPLOG_SOURCE: &str = "wandsculpt";

fn io_err(path: &Path, source: std::io::Error) -> VrError {
    VrError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Creates an output directory (and its parents). A path that exists and is not a
/// directory is an error that says so (`create_dir_all` alone says only "File
/// exists").
pub fn create_output_dir(dir: &Path) -> std::io::Result<()> {
    if let Ok(meta) = std::fs::metadata(dir)
        && !meta.is_dir()
    {
        return Err(std::io::Error::new(
            std::io::ErrorKind::NotADirectory,
            "exists and is not a directory; give an output directory",
        ));
    }
    std::fs::create_dir_all(dir)
}

/// Fails when `dir` exists and is not a directory (as [`create_output_dir`] would),
/// without creating anything.
fn check_output_dir(dir: &Path) -> std::io::Result<()> {
    match std::fs::metadata(dir) {
        Ok(meta) if !meta.is_dir() => Err(std::io::Error::new(
            std::io::ErrorKind::NotADirectory,
            "exists and is not a directory; give an output directory",
        )),
        _ => Ok(()),
    }
}

/// Checks that every target a journal's entries name exists in the base document,
/// for journals whose header names no document (version 1, which names targets by
/// position, and the first version 2 journals): a target the document lacks means the
/// journal was recorded on another document ([`JournalError::UnknownTarget`]), and
/// re-applying it would lose its strokes.
fn check_journal_targets(stored: &journal::Stored, doc: &Document, path: &Path) -> VrResult<()> {
    if stored.document.is_some() {
        // The header names the document, and `Journal::recover` checked it.
        return Ok(());
    }
    let targets = doc.targets();
    for (i, entry) in stored.entries.iter().enumerate() {
        let named = match &entry.edit {
            Edit::Stroke(s) => vec![s.target],
            Edit::SelectTarget { target } => vec![*target],
            Edit::Deform(d) => d.targets.clone(),
            Edit::Paint(p) => vec![p.target],
            Edit::Sketch { .. } | Edit::Undo | Edit::Redo | Edit::Save => continue,
        };
        let unknown = named.into_iter().find(|&named| {
            !if stored.version == 1 {
                usize::try_from(named).is_ok_and(|p| p < targets.len())
            } else {
                targets.iter().any(|t| t.id == named)
            }
        });
        if let Some(named) = unknown {
            return Err(VrError::Journal {
                path: path.display().to_string(),
                reason: JournalError::UnknownTarget {
                    line: i + 2,
                    target: named,
                    targets: targets.len(),
                },
            });
        }
    }
    Ok(())
}

/// Reads a base scene in the [`Document::to_json`] format. A file larger than
/// [`MAX_DOCUMENT_BYTES`](sculpt_core::sculpt::document::MAX_DOCUMENT_BYTES) is
/// refused from its size, before it is read.
pub fn load_scene(path: &Path) -> VrResult<Document> {
    let bytes = fsio::read_capped(
        path,
        sculpt_core::sculpt::document::MAX_DOCUMENT_BYTES as u64,
    )?;
    Document::from_json(&bytes).map_err(|reason| VrError::Scene {
        path: path.to_path_buf(),
        reason: Box::new(reason),
    })
}

/// Writes bytes atomically with the one output writer, [`fsio::write_atomic`]: a
/// temporary file beside `path`, fsync, rename. On any failure (a full disk) the
/// temporary file is removed and `path` keeps its old content, so no partial file is
/// ever left behind.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> VrResult<()> {
    Ok(fsio::write_atomic(path, bytes)?)
}

/// The operator log file: one event per line, written and flushed as it happens.
///
/// It is a by-product of sculpting (the journal is the record of truth), so once a
/// write fails (a full disk) it warns once and stops writing; sculpting goes on.
#[derive(Debug)]
struct OperatorLog {
    path: PathBuf,
    file: File,
    writer: OpLogWriter,
    /// Set by the first failed write (its error): nothing more is written.
    failed: Option<String>,
    /// Plain sessions: one segment per mode; `None` in study mode, whose trials are
    /// the segments.
    segments: Option<ModeSegments>,
    /// Study mode: the events of the trial being recorded.
    capture: Option<Vec<OpEvent>>,
    /// Study mode: a `trial_start` to write just before the next event (at its time):
    /// a trial starts at its first event, not at time zero (a live session's clock is
    /// the tracker's).
    pending: Option<EventKind>,
    /// The latest event time written.
    last_t: f64,
}

impl OperatorLog {
    /// Starts `path` afresh, keeping an earlier run's log as `operator.N.log`.
    fn create(path: PathBuf, method: &str) -> VrResult<Self> {
        if std::fs::metadata(&path).is_ok_and(|m| m.len() > 0) {
            let stem = path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("operator")
                .to_string();
            let kept = (1..)
                .map(|n| path.with_file_name(format!("{stem}.{n}.log")))
                .find(|p| !p.exists())
                .unwrap_or_else(|| path.with_extension("old.log"));
            std::fs::rename(&path, &kept).map_err(|e| io_err(&path, e))?;
        }
        let file = File::create(&path).map_err(|e| io_err(&path, e))?;
        let writer = OpLogWriter::new(
            &OpLogHeader::new()
                .with_source(OPLOG_SOURCE)
                .with_method(method),
        );
        let mut log = Self {
            path,
            file,
            writer,
            failed: None,
            segments: Some(ModeSegments::new(method)),
            capture: None,
            pending: None,
            last_t: 0.0,
        };
        log.flush();
        Ok(log)
    }

    /// Starts the log again with `header` and no segments (study mode). Only before
    /// any input: the file holds nothing but the header and the first segment's start.
    fn restart(&mut self, header: &OpLogHeader) -> VrResult<()> {
        self.file
            .set_len(0)
            .and_then(|()| std::io::Seek::rewind(&mut self.file))
            .map_err(|e| io_err(&self.path, e))?;
        self.writer = OpLogWriter::new(header);
        self.segments = None;
        self.pending = None;
        self.last_t = 0.0;
        self.flush();
        Ok(())
    }

    fn push(&mut self, t: f64, event: &OperatorEvent) -> VrResult<()> {
        self.push_kind(t, editor::oplog_event(event));
        Ok(())
    }

    /// Logs one event (and captures it for a study trial being recorded).
    fn push_kind(&mut self, t: f64, kind: EventKind) {
        if let Some(c) = &mut self.capture
            && t >= self.last_t
        {
            c.push(OpEvent {
                t,
                kind: kind.clone(),
            });
        }
        let lines = match &mut self.segments {
            Some(segments) => segments.marked(t, kind),
            None => vec![kind],
        };
        for k in lines {
            self.write(t, k);
        }
    }

    /// Writes one event to the file (after a pending `trial_start`, at the same time).
    fn write(&mut self, t: f64, kind: EventKind) {
        if let Some(start) = self.pending.take() {
            self.write_now(t, start);
        }
        self.write_now(t, kind);
    }

    fn write_now(&mut self, t: f64, kind: EventKind) {
        // The state machine never goes back in time; an event it could not order is
        // reported and left out rather than corrupting the log.
        if let Err(e) = self.writer.push(t, kind) {
            tracing::warn!("operator log: {}", Chain(&e));
            return;
        }
        self.last_t = t;
        self.flush();
    }

    /// Writes what is pending; after a failure, warns once and writes nothing more.
    fn flush(&mut self) {
        let bytes = self.writer.take();
        if self.failed.is_some() {
            return;
        }
        if let Err(e) = self.file.write_all(&bytes).and_then(|()| self.file.flush()) {
            self.failed = Some(e.to_string());
            tracing::warn!(
                "operator log {} could not be written ({e}); it stops here, sculpting goes on",
                self.path.display()
            );
        }
    }
}

/// How long (session seconds) the HUD shows a refusal.
pub const REFUSAL_SHOWN_S: f64 = 6.0;

/// Something the session refused, in words for the HUD.
#[derive(Debug, Clone, PartialEq)]
pub struct Refusal {
    /// When (session seconds).
    pub t: f64,
    /// What and why (`stroke rejected: the stroke does not lie on the surface`).
    pub words: String,
}

/// A gesture the interaction dropped, in words: a too-short stroke says how long it
/// was and how long it must be.
fn dropped_words(why: &StrokeRejection) -> String {
    match why {
        StrokeRejection::TooShort { length_m, min_m } => format!(
            "stroke dropped: {:.1} mm long, at least {:.1} mm needed",
            length_m * 1000.0,
            min_m * 1000.0
        ),
        other => format!("gesture dropped: {other}"),
    }
}

/// A desktop mouse press that is an operator but no wand button, logged by
/// [`Session::mouse`] as a `key` event (see `docs/formats/oplog.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MouseOperator {
    /// The right button: orbits the view, or pans it with Shift.
    Right {
        /// Shift held (pan).
        shift: bool,
    },
    /// The middle button: pans the view.
    Middle,
    /// One notch of the wheel (or the start of a touchpad scroll): the wand plane, or
    /// with Ctrl the view's zoom.
    Wheel {
        /// Ctrl held (zoom).
        ctrl: bool,
    },
}

impl MouseOperator {
    /// The `key` the log names it by: `MouseRight`, `Shift+MouseRight`,
    /// `MouseMiddle`, `Wheel`, `Ctrl+Wheel` (modifiers as the keys write them).
    pub fn key_name(self) -> &'static str {
        match self {
            Self::Right { shift: false } => "MouseRight",
            Self::Right { shift: true } => "Shift+MouseRight",
            Self::Middle => "MouseMiddle",
            Self::Wheel { ctrl: false } => "Wheel",
            Self::Wheel { ctrl: true } => "Ctrl+Wheel",
        }
    }
}

/// The session's files, written as the edit loop runs: the journal before each edit
/// is applied, the operator log per event, the document on a save and the autosave.
#[derive(Debug)]
struct SessionFiles {
    dir: PathBuf,
    journal: Journal,
    oplog: OperatorLog,
    autosave_every: u32,
    since_autosave: u32,
    /// Journal sequence number of the edit being applied, for the logs.
    seq: u64,
}

impl SessionFiles {
    fn autosave(&mut self, doc: &Document) -> VrResult<PathBuf> {
        self.since_autosave = 0;
        let p = self.dir.join(AUTOSAVE_FILE);
        write_atomic(&p, &doc.to_json())?;
        Ok(p)
    }

    fn save_document(&self, doc: &Document) -> VrResult<PathBuf> {
        let p = self.dir.join(DOCUMENT_FILE);
        write_atomic(&p, &doc.to_json())?;
        Ok(p)
    }
}

impl EditHooks for SessionFiles {
    type Error = VrError;

    fn operator_event(&mut self, t: f64, event: &OperatorEvent) -> VrResult<()> {
        self.oplog.push(t, event)
    }

    /// Journals the edit (and fsyncs) before it is applied, so an operation the
    /// sculptor saw happen survives a crash.
    fn before_apply(&mut self, t: f64, edit: &Edit) -> VrResult<()> {
        self.seq = self.journal.append(t, edit)?;
        tracing::info!(seq = self.seq, "operation committed");
        Ok(())
    }

    fn after_apply(
        &mut self,
        t: f64,
        edit: &Edit,
        applied: &Applied,
        doc: &Document,
    ) -> VrResult<()> {
        let seq = self.seq;
        match applied {
            Applied::Rejected(e) => {
                tracing::warn!(seq, "the sculpting layer refused an edit: {}", Chain(e));
            }
            a => tracing::debug!(seq, "applied: {a:?}"),
        }
        // A stroke carved in several pieces (or with pieces dropped) says so.
        if let Some(kind) = editor::oplog_applied(applied) {
            self.oplog.push_kind(t, kind);
        }
        if *edit == Edit::Save {
            self.save_document(doc)?;
        }
        self.since_autosave += 1;
        if self.autosave_every > 0 && self.since_autosave >= self.autosave_every {
            self.autosave(doc)?;
        }
        Ok(())
    }
}

/// A running session: the shared [`EditLoop`] (the interaction state machine and the
/// sculpted document, read as `session.interaction` and `session.doc` through
/// [`Deref`]) with the journal, the operator log and the saved documents around it.
///
/// Feed it with [`Session::handle`] and [`Session::tick`], which journal each edit
/// before applying it; the loop's own `handle` and `tick` are shadowed by these.
#[derive(Debug)]
pub struct Session {
    edit_loop: EditLoop,
    /// What is drawn from the document (its tessellation into the renderer's sinks,
    /// the preview, stroke surfaces): derived state, synced from `&Document`.
    view: DocumentView,
    files: SessionFiles,
    /// Operations recovered from the journal at open.
    pub recovered: usize,
    /// Edits the sculpting layer refused (the document stayed as it was).
    pub rejected: usize,
    /// The latest thing refused (an edit, a gesture too short to count, an input), in
    /// words, for the HUD ([`Session::refusal_at`]).
    pub last_refusal: Option<Refusal>,
    /// The latest event or tick time accepted.
    time: f64,
}

impl Deref for Session {
    type Target = EditLoop;

    fn deref(&self) -> &EditLoop {
        &self.edit_loop
    }
}

/// A session as the feeder's sink with no views: wand events and ticks journalled
/// and applied, keys logged (the display server's [`AppState`](crate::app::AppState)
/// adds the head and the tracking status).
impl crate::feeder::Sink for Session {
    type Error = VrError;

    fn wand(&mut self, ev: &WandEvent) -> VrResult<()> {
        self.handle(ev).map(drop)
    }

    fn tick(&mut self, t: f64) -> VrResult<()> {
        Session::tick(self, t).map(drop)
    }

    fn tool(&self) -> sculpt_core::interaction::Tool {
        self.edit_loop.interaction.tool().clone()
    }

    fn key(&mut self, t: f64, key: &str) {
        Session::key(self, t, key);
    }
}

impl Session {
    /// The document (read only), its view (the derived state the renderer's mesh sync
    /// brings up to date) and the interaction, for drawing. Edits go only through
    /// [`Session::handle`] and [`Session::tick`], which journal them first, and a whole
    /// document only through [`Session::replace_document`]: the session gives out no
    /// `&mut Document` and no `&mut EditLoop`.
    pub fn draw_parts(&mut self) -> (&Document, &mut DocumentView, &Interaction) {
        let edits = &self.edit_loop;
        (&edits.doc, &mut self.view, &edits.interaction)
    }

    /// The document's view as last synced (its UV maps for the quadtree overlay).
    pub fn view(&self) -> &DocumentView {
        &self.view
    }

    /// Replaces the whole document with `doc` (a cluster node's document rebuilt
    /// from its operation stream): the interaction is told the new document's
    /// targets, and the view starts over ([`DocumentView::start_over`]): the next
    /// mesh sync takes the old document's patches out of the sinks and writes the new
    /// one whole. Not journalled: the caller's record (the stream) holds the
    /// operations.
    pub fn replace_document(&mut self, doc: Document) {
        self.edit_loop.doc = doc;
        self.edit_loop.sync_targets();
        self.view.start_over();
    }

    /// Forgets what the document's view wrote (a new renderer with empty mesh sinks):
    /// the next mesh sync writes every patch again.
    pub fn forget_sinks(&mut self) {
        self.view.forget_sinks();
    }

    /// Opens the session in `config.files.dir`: loads the base scene
    /// (`config.files.scene`, or the default document), reads the journal and checks
    /// that it belongs to that document, re-applies it (recovering after a crash), and
    /// only then creates the directory, opens the journal for appending and starts the
    /// operator log. A run that cannot use the journal (another document's, a corrupt
    /// one, a bad scene) fails before any file is touched.
    pub fn open(config: &Config) -> VrResult<Self> {
        let dir = config.files.dir.clone();
        let mut doc = match &config.files.scene {
            Some(p) => load_scene(p)?,
            None => editor::default_document(),
        };
        if let Some(model) = &config.files.solid {
            crate::solid_view::load_solid(&mut doc, model, config.files.solid_cells)?;
        }
        check_output_dir(&dir).map_err(|e| io_err(&dir, e))?;
        let journal_path = dir.join(JOURNAL_FILE);
        let stored = Journal::recover(&journal_path, &journal::document_id(&doc))?;
        check_journal_targets(&stored, &doc, &journal_path)?;
        let interaction =
            Interaction::new(config.interaction, config.tool.mode, config.tool.tool());
        let mut edit_loop = EditLoop::new(interaction, doc);
        // A version 1 journal names targets by position: each becomes the id of the
        // target there when the entry is re-applied, and the file is rewritten so.
        let positions = stored.version == 1;
        let mut entries = Vec::with_capacity(stored.entries.len());
        let mut selected = None;
        for mut e in stored.entries.iter().cloned() {
            if positions {
                e.edit = e.edit.with_positions_resolved(&edit_loop.doc);
            }
            match &e.edit {
                Edit::SelectTarget { target } => selected = Some(*target),
                edit => {
                    if let Applied::Rejected(err) = edit_loop.apply(edit) {
                        tracing::debug!(
                            seq = e.seq,
                            "journalled edit refused again: {}",
                            Chain(&err)
                        );
                    }
                }
            }
            entries.push(e);
        }
        // Everything checked: from here on files are written.
        create_output_dir(&dir).map_err(|e| io_err(&dir, e))?;
        let mut journal = Journal::resume(&stored)?;
        if positions {
            journal.upgrade(&entries)?;
            tracing::info!("journal upgraded to version {}", crate::journal::VERSION);
        }
        let oplog = OperatorLog::create(dir.join(OPLOG_FILE), editor::mode_name(config.tool.mode))?;
        let position =
            selected.and_then(|id| edit_loop.doc.targets().iter().position(|t| t.id == id));
        if let Some(index) = position
            .and_then(|p| u32::try_from(p).ok())
            .map(TargetIndex)
        {
            // At t = 0, so that any live event may follow; not journalled again.
            let select = WandEvent::command(0.0, Command::SelectTarget { index });
            match edit_loop.handle(&select, &mut NoHooks) {
                Ok(_) => {}
                Err(LoopError::Refused(e)) => return Err(e.into()),
                Err(LoopError::Hook(never)) => match never {},
            }
        }
        if !entries.is_empty() {
            tracing::info!(
                operations = entries.len(),
                "recovered the session from its journal"
            );
        }
        Ok(Self {
            edit_loop,
            view: DocumentView::new(),
            files: SessionFiles {
                dir,
                journal,
                oplog,
                autosave_every: config.files.autosave_every,
                since_autosave: 0,
                seq: 0,
            },
            recovered: entries.len(),
            rejected: 0,
            last_refusal: None,
            time: 0.0,
        })
    }

    /// The session directory.
    pub fn dir(&self) -> &Path {
        &self.files.dir
    }

    /// Operations in the journal.
    pub fn operations(&self) -> u64 {
        self.files.journal.len()
    }

    /// The latest event or tick time the session accepted (session seconds): the
    /// time for a command given from outside the wand's own clock.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Feeds one wand event. Invalid events (time going backwards) are logged and
    /// dropped; edits are journalled, then applied. Returns the edits applied.
    pub fn handle(&mut self, ev: &WandEvent) -> VrResult<Vec<Edit>> {
        let step = match self.edit_loop.handle(ev, &mut self.files) {
            Ok(step) => step,
            Err(LoopError::Refused(e)) => {
                tracing::warn!("dropped an input: {}", Chain(&e));
                self.refuse(ev.t, format!("input dropped: {}", Chain(&e)));
                return Ok(Vec::new());
            }
            Err(LoopError::Hook(e)) => {
                self.time = self.time.max(ev.t);
                return Err(e);
            }
        };
        self.time = self.time.max(ev.t);
        Ok(self.applied(&step))
    }

    /// Advances time with no input (ends strokes paused too long by tracking loss).
    pub fn tick(&mut self, t: f64) -> VrResult<Vec<Edit>> {
        if t.is_finite() {
            self.time = self.time.max(t);
        }
        let step = self.edit_loop.tick(t, &mut self.files)?;
        Ok(self.applied(&step))
    }

    /// Feeds one wand event to the interaction without applying its edits: they are
    /// handed back for the cluster's operation stream, and come back through
    /// [`Session::apply_committed`] in the stream's order. Operator events are logged
    /// as they happen; an invalid event is logged and dropped.
    pub fn propose(&mut self, ev: &WandEvent) -> VrResult<Vec<Edit>> {
        let edits = match self.edit_loop.propose(ev, &mut self.files) {
            Ok(edits) => edits,
            Err(LoopError::Refused(e)) => {
                tracing::warn!("dropped an input: {}", Chain(&e));
                self.refuse(ev.t, format!("input dropped: {}", Chain(&e)));
                Vec::new()
            }
            Err(LoopError::Hook(e)) => return Err(e),
        };
        self.time = self.time.max(ev.t);
        Ok(edits)
    }

    /// Advances time without applying the edits (see [`Session::propose`]).
    pub fn propose_tick(&mut self, t: f64) -> VrResult<Vec<Edit>> {
        if t.is_finite() {
            self.time = self.time.max(t);
        }
        self.edit_loop.propose_tick(t, &mut self.files)
    }

    /// Applies one operation committed to the cluster's operation stream: journalled
    /// (the local cache of the stream), applied, saved or autosaved as a local edit
    /// would be. A refused edit is counted in [`Session::rejected`].
    pub fn apply_committed(&mut self, t: f64, edit: &Edit) -> VrResult<Applied> {
        self.files.before_apply(t, edit)?;
        let applied = self.edit_loop.apply(edit);
        if let Applied::Rejected(e) = &applied {
            self.rejected += 1;
            self.refuse(t, Chain(e).to_string());
        }
        self.files
            .after_apply(t, edit, &applied, &self.edit_loop.doc)?;
        Ok(applied)
    }

    /// The step's edits, counting the refused ones and keeping the last refusal (a
    /// refused edit, or a gesture dropped as too short) for the HUD.
    fn applied(&mut self, step: &Step) -> Vec<Edit> {
        self.rejected += step.rejections().count();
        for (t, event) in step.operator_events() {
            if let OperatorEvent::GestureEnd {
                dropped: Some(why), ..
            } = event
            {
                tracing::info!("gesture dropped: {why}");
                self.refuse(t, dropped_words(why));
            }
        }
        if let Some((_, e)) = step.rejections().last() {
            self.refuse(step.t, Chain(e).to_string());
        }
        step.edits().map(|(edit, _)| edit.clone()).collect()
    }

    fn refuse(&mut self, t: f64, words: String) {
        self.last_refusal = Some(Refusal { t, words });
    }

    /// The latest refusal if it happened at most [`REFUSAL_SHOWN_S`] seconds before
    /// `t` (session seconds): what the HUD shows.
    pub fn refusal_at(&self, t: f64) -> Option<&Refusal> {
        self.last_refusal
            .as_ref()
            .filter(|r| t - r.t <= REFUSAL_SHOWN_S)
    }

    /// Why the operator log stopped being written (a full disk), if it did: the run
    /// lost operator events, so it must not report the log as written nor end as a
    /// success.
    pub fn oplog_failure(&self) -> Option<&str> {
        self.files.oplog.failed.as_deref()
    }

    /// Writes the autosave document ([`AUTOSAVE_FILE`]).
    pub fn autosave(&mut self) -> VrResult<PathBuf> {
        self.files.autosave(&self.edit_loop.doc)
    }

    /// Writes the document to the session directory's [`DOCUMENT_FILE`].
    pub fn save_document(&mut self) -> VrResult<PathBuf> {
        self.files.save_document(&self.edit_loop.doc)
    }

    /// Logs a desktop key press at `t` as a `key` event (a K operator for
    /// `sculpt-tools goms`), named as the key help names it (`Ctrl+Z`, `2`). Log it
    /// before the key's command, which follows at the same time.
    pub fn key(&mut self, t: f64, key: &str) {
        self.files.oplog.push_kind(
            t,
            EventKind::Key {
                key: key.to_owned(),
            },
        );
        if t.is_finite() {
            self.time = self.time.max(t);
        }
    }

    /// Logs a desktop mouse press that is no wand button (the view's orbit and pan
    /// buttons, a wheel notch) at `t` as a `key` event named
    /// [`MouseOperator::key_name`]: a K for `sculpt-tools goms`, as a key is. The left
    /// button is the wand's action button and is logged by the state machine (`button`).
    pub fn mouse(&mut self, t: f64, press: MouseOperator) {
        self.key(t, press.key_name());
    }

    /// Study mode: the operator log starts again with a header naming the participant
    /// and the method (the study condition); the study's trials
    /// ([`Session::begin_trial`]) replace the per-mode segments. Call it before any
    /// input.
    pub fn start_study(&mut self, participant: &str, method: &str) -> VrResult<()> {
        self.files.oplog.restart(
            &OpLogHeader::new()
                .with_source(OPLOG_SOURCE)
                .with_participant(participant)
                .with_method(method),
        )
    }

    /// Study mode: marks a trial's start in the operator log (`trial_start` with the
    /// trial number, the task and the study method) at `t`, or with `None` at the next
    /// event, and starts recording its events.
    pub fn begin_trial(&mut self, t: Option<f64>, trial: u32, task: Option<&str>, method: &str) {
        let log = &mut self.files.oplog;
        let start = EventKind::TrialStart {
            trial,
            task: task.map(str::to_owned),
            method: Some(method.to_owned()),
        };
        match t {
            Some(t) => log.write(t, start),
            None => log.pending = Some(start),
        }
        log.capture = Some(Vec::new());
    }

    /// Study mode: marks the trial's end at `t` (no earlier than its last event) and
    /// hands back the events recorded since [`Session::begin_trial`]; `None` when no
    /// trial was being recorded.
    pub fn end_trial(&mut self, t: f64, trial: u32) -> Option<Vec<OpEvent>> {
        let log = &mut self.files.oplog;
        let events = log.capture.take()?;
        if log.pending.take().is_some() {
            // It never started: no event came.
            return None;
        }
        let end = t.max(log.last_t);
        log.write(end, EventKind::TrialEnd { trial });
        Some(events)
    }

    /// The latest time in the operator log.
    pub fn log_time(&self) -> f64 {
        self.files.oplog.last_t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};
    use sculpt_core::interaction::WandSample;
    use sculpt_core::oplog::{EventKind, decode_bytes};

    fn config(dir: &Path) -> Config {
        let mut c = Config::default();
        c.files.dir = dir.to_path_buf();
        c.files.autosave_every = 2;
        c
    }

    /// A carve stroke across the default surface at height `y`, starting at `t0`.
    fn stroke(s: &mut Session, t0: f64, y: f64) {
        for i in 0..=10 {
            let p = editor::default_surface_point(-0.1 + i as f64 * 0.02, y);
            s.handle(&WandEvent::sample(
                t0 + i as f64 * 0.01,
                WandSample::tracked(p, DQuat::IDENTITY, u32::from(i < 10)),
            ))
            .unwrap();
        }
    }

    #[test]
    fn edits_are_journalled_applied_to_the_core_and_recovered() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = config(dir.path());
        let saved = {
            let mut s = Session::open(&cfg).unwrap();
            stroke(&mut s, 0.0, 1.1);
            stroke(&mut s, 1.0, 1.2);
            assert_eq!(s.doc.strokes().len(), 2);
            s.handle(&WandEvent::command(2.0, Command::Undo)).unwrap();
            assert_eq!(s.doc.strokes().len(), 1);
            assert_eq!(s.operations(), 3);
            assert_eq!(s.rejected, 0);
            assert!(
                dir.path().join(AUTOSAVE_FILE).exists(),
                "autosave after 2 operations"
            );
            s.save_document().unwrap();
            s.doc.to_json()
        };
        let on_disk = std::fs::read(dir.path().join(DOCUMENT_FILE)).unwrap();
        assert_eq!(on_disk, saved);
        let back = Document::from_json(&on_disk).unwrap();
        assert_eq!(back.strokes().len(), 1);
        let mut s = Session::open(&cfg).unwrap();
        assert_eq!(s.recovered, 3);
        assert_eq!(
            s.doc.to_json(),
            saved,
            "recovery rebuilds the same document"
        );
        assert!(s.doc.can_redo(), "the undone stroke can be redone");
        s.handle(&WandEvent::command(0.5, Command::Redo)).unwrap();
        assert_eq!(s.doc.strokes().len(), 2);
    }

    #[test]
    fn operator_log_is_the_core_format_flushed_per_event() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = config(dir.path());
        let mut s = Session::open(&cfg).unwrap();
        stroke(&mut s, 0.0, 1.1);
        // Not dropped or flushed: every event is already on disk.
        let log = decode_bytes(&std::fs::read(dir.path().join(OPLOG_FILE)).unwrap()).unwrap();
        assert_eq!(log.header.source.as_deref(), Some(OPLOG_SOURCE));
        let kinds: Vec<&EventKind> = log.events.iter().map(|e| &e.kind).collect();
        let at = |k: &EventKind| kinds.iter().position(|x| *x == k);
        let down = at(&EventKind::Button { id: 0, down: true }).unwrap();
        let start = at(&EventKind::StrokeStart).unwrap();
        let end = at(&EventKind::StrokeEnd).unwrap();
        assert!(down <= start && start < end, "{kinds:?}");
        assert!(kinds.iter().any(|k| matches!(k, EventKind::Pose { .. })));
        drop(s);
        // A second run keeps the first run's log and starts its own.
        let mut s = Session::open(&cfg).unwrap();
        s.handle(&WandEvent::command(0.1, Command::Undo)).unwrap();
        assert!(dir.path().join("operator.1.log").exists());
        let log = decode_bytes(&std::fs::read(dir.path().join(OPLOG_FILE)).unwrap()).unwrap();
        assert_eq!(log.events.last().unwrap().kind, EventKind::Undo);
    }

    /// Regression (issue 19): desktop keys were no operator events, and the log's
    /// header kept the start mode ("carve") after a switch to emboss or sketch. Keys
    /// are `key` events now, and each mode's operators are in a segment that names
    /// the mode.
    #[test]
    fn regression_keys_are_logged_and_each_mode_is_a_segment() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = Session::open(&config(dir.path())).unwrap();
        stroke(&mut s, 0.0, 1.1);
        s.key(0.5, "3");
        s.handle(&WandEvent::command(
            0.5,
            Command::SetMode {
                mode: sculpt_core::interaction::InteractionMode::EMBOSS,
            },
        ))
        .unwrap();
        stroke(&mut s, 1.0, 1.2);
        s.key(2.0, "Ctrl+Z");
        s.handle(&WandEvent::command(2.0, Command::Undo)).unwrap();
        s.key(2.5, "2");
        s.handle(&WandEvent::command(
            2.5,
            Command::SetMode {
                mode: sculpt_core::interaction::InteractionMode::CARVE,
            },
        ))
        .unwrap();
        let log = decode_bytes(&std::fs::read(dir.path().join(OPLOG_FILE)).unwrap()).unwrap();
        let marks: Vec<String> = log
            .events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::TrialStart { trial, method, .. } => Some(format!(
                    "start {} {trial}",
                    method.as_deref().unwrap_or("-")
                )),
                EventKind::TrialEnd { trial } => Some(format!("end {trial}")),
                EventKind::Key { key } => Some(format!("key {key}")),
                _ => None,
            })
            .collect();
        assert_eq!(
            marks,
            [
                "start carve 1",
                "key 3",
                "end 1",
                "start emboss 1",
                "key Ctrl+Z",
                "key 2",
                "end 1",
                "start carve 2"
            ]
        );
        // A segment starts at its first event (a live clock is the tracker's, far from
        // zero), and a mode switch before any event leaves no empty segment.
        let dir = tempfile::tempdir().unwrap();
        let mut s = Session::open(&config(dir.path())).unwrap();
        s.key(100.0, "3");
        s.handle(&WandEvent::command(
            100.0,
            Command::SetMode {
                mode: sculpt_core::interaction::InteractionMode::EMBOSS,
            },
        ))
        .unwrap();
        let log = decode_bytes(&std::fs::read(dir.path().join(OPLOG_FILE)).unwrap()).unwrap();
        let first = &log.events[0];
        assert_eq!(first.t, 100.0);
        assert_eq!(
            first.kind,
            EventKind::TrialStart {
                trial: 1,
                task: None,
                method: Some("carve".into())
            }
        );
        let starts = log
            .events
            .iter()
            .filter(|e| matches!(e.kind, EventKind::TrialStart { .. }))
            .count();
        assert_eq!(starts, 2, "{:?}", log.events);
    }

    /// Regression (issue 19): in desktop mode the right and middle buttons (orbit,
    /// pan) and the wheel were no operator events, although every key and button of
    /// the task is one. Each press is a `key` event now, in the open mode segment and
    /// in order with the wand's own events; the left button (the wand's action
    /// button) stays a `button` edge only.
    #[test]
    fn regression_mouse_buttons_and_wheel_are_logged_as_keys() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = Session::open(&config(dir.path())).unwrap();
        stroke(&mut s, 0.0, 1.1);
        s.mouse(0.2, MouseOperator::Right { shift: false });
        s.mouse(0.4, MouseOperator::Right { shift: true });
        s.mouse(0.6, MouseOperator::Middle);
        s.mouse(0.8, MouseOperator::Wheel { ctrl: false });
        s.mouse(0.9, MouseOperator::Wheel { ctrl: true });
        stroke(&mut s, 1.0, 1.2);
        let log = decode_bytes(&std::fs::read(dir.path().join(OPLOG_FILE)).unwrap()).unwrap();
        let marks: Vec<(f64, String)> = log
            .events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Key { key } => Some((e.t, format!("key {key}"))),
                EventKind::Button { down: true, .. } => Some((e.t, "press".into())),
                EventKind::TrialStart { method, .. } => {
                    Some((e.t, format!("start {}", method.as_deref().unwrap_or("-"))))
                }
                _ => None,
            })
            .collect();
        let names: Vec<&str> = marks.iter().map(|m| m.1.as_str()).collect();
        assert_eq!(
            names,
            [
                "start carve",
                "press",
                "key MouseRight",
                "key Shift+MouseRight",
                "key MouseMiddle",
                "key Wheel",
                "key Ctrl+Wheel",
                "press"
            ]
        );
        for (m, t) in marks[2..7].iter().zip([0.2, 0.4, 0.6, 0.8, 0.9]) {
            sculpt_core::assert_near!(m.0, t, sculpt_core::tolerance::TIME_EPS, "{}", m.1);
        }
    }

    /// Regression (issue 15, item 7): on a full disk a failed `operator.log` write
    /// ended the live session. The operator log (here `/dev/full`, where every write
    /// fails with ENOSPC) now warns once and stops; strokes are still journalled and
    /// applied.
    #[test]
    fn a_full_disk_under_the_operator_log_does_not_stop_sculpting() {
        let dir = tempfile::tempdir().unwrap();
        std::os::unix::fs::symlink("/dev/full", dir.path().join(OPLOG_FILE)).unwrap();
        let cfg = config(dir.path());
        let mut s = Session::open(&cfg).unwrap();
        stroke(&mut s, 0.0, 1.1);
        stroke(&mut s, 1.0, 1.2);
        assert_eq!(s.doc.strokes().len(), 2);
        assert_eq!(s.operations(), 2);
        assert!(s.oplog_failure().is_some_and(|e| e.contains("No space")));
        assert_eq!(
            Journal::read(dir.path().join(JOURNAL_FILE)).unwrap().len(),
            2
        );
    }

    /// Regression (issue 15, item 7): a failed write left a partial `scene.tmp` behind.
    /// A write that fails now removes its temporary file and keeps the old content
    /// (the full-disk case is `fsio`'s `tests/full_disk.rs`).
    #[test]
    fn a_failed_atomic_write_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.json");
        std::fs::write(&path, b"old").unwrap();
        // The rename fails (a directory stands where the file goes) after the
        // temporary file was written in full.
        let blocked = dir.path().join("blocked.json");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("inside"), b"x").unwrap();
        let e = write_atomic(&blocked, b"new").unwrap_err();
        assert!(e.to_string().contains("blocked.json"), "{e}");
        let mut left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        left.sort();
        assert_eq!(left, ["blocked.json", "scene.json"], "temporary file left");
        assert!(write_atomic(&path, b"new").is_ok());
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
    }

    /// Regression (issue 15, item 7): `--out /etc/hostname` said only "File exists".
    #[test]
    fn an_output_path_that_is_a_file_says_it_is_not_a_directory() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("hostname");
        std::fs::write(&file, b"x").unwrap();
        // As the binary prints it: the error and its causes on one line.
        let e = Session::open(&config(&file)).unwrap_err();
        let e = sculpt_core::error::Chain(&e).to_string();
        assert!(e.contains("hostname"), "{e}");
        assert!(e.contains("exists and is not a directory"), "{e}");
        create_output_dir(&dir.path().join("a/b")).unwrap();
        assert!(dir.path().join("a/b").is_dir());
    }

    /// A version 1 journal named targets by position (`"target": 1` is the second
    /// target, whatever its id): recovered, it strokes and selects the same targets,
    /// and is rewritten as version 2, with ids, before anything is appended.
    #[test]
    fn a_version_1_journal_is_recovered_by_position_and_upgraded() {
        use crate::journal::HEADER_V1;
        let dir = tempfile::tempdir().unwrap();
        let mut base = editor::default_document();
        let second = base.add_target("second", editor::default_surface());
        assert_ne!(second, 1, "ids and positions differ in this test");
        let scene = dir.path().join("base.json");
        std::fs::write(&scene, base.to_json()).unwrap();
        let run = dir.path().join("run");
        std::fs::create_dir_all(&run).unwrap();
        let samples: Vec<String> = (0..=20)
            .map(|i| {
                let p = editor::default_surface_point(-0.2 + 0.02 * f64::from(i), 1.1);
                format!(
                    r#"{{"t":{},"position":[{},{},{}]}}"#,
                    f64::from(i) * 0.01,
                    p.x,
                    p.y,
                    p.z
                )
            })
            .collect();
        let stroke = format!(
            r#"{{"seq":0,"t":0.2,"edit":{{"edit":"stroke","target":1,"mode":"carve","tool":{{"profile":"v","width":0.02,"depth":0.005}},"samples":[{}]}}}}"#,
            samples.join(",")
        );
        let select = r#"{"seq":1,"t":0.3,"edit":{"edit":"select-target","index":1}}"#;
        std::fs::write(
            run.join(JOURNAL_FILE),
            format!("{HEADER_V1}\n{stroke}\n{select}\n"),
        )
        .unwrap();
        let mut cfg = config(&run);
        cfg.files.scene = Some(scene);
        let mut s = Session::open(&cfg).unwrap();
        assert_eq!(s.recovered, 2);
        assert_eq!(s.doc.strokes().len(), 1);
        assert_eq!(s.doc.strokes()[0].target, second, "position 1 is `second`");
        assert_eq!(s.interaction.target(), second, "and so is the selection");
        let text = std::fs::read_to_string(run.join(JOURNAL_FILE)).unwrap();
        let header = crate::journal::header_line(&crate::journal::document_id(&base));
        assert_eq!(text.lines().next(), Some(header.as_str()));
        let entries = Journal::read(run.join(JOURNAL_FILE)).unwrap();
        assert!(
            matches!(&entries[0].edit, Edit::Stroke(e) if e.target == second),
            "{:?}",
            entries[0].edit
        );
        assert_eq!(entries[1].edit, Edit::SelectTarget { target: second });
        s.handle(&WandEvent::command(0.5, Command::Undo)).unwrap();
        assert_eq!(Journal::read(run.join(JOURNAL_FILE)).unwrap().len(), 3);
        assert!(s.doc.strokes().is_empty());
    }

    /// A replaced document (a cluster node's rebuild) is the session's, and the
    /// interaction selects among its targets: before `replace_document` the cluster
    /// wrote the document through `&mut` and left the interaction's targets stale.
    #[test]
    fn a_replaced_document_is_the_one_edited_and_its_targets_are_selectable() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = Session::open(&config(dir.path())).unwrap();
        let mut doc = editor::default_document();
        let second = doc.add_target("second", editor::default_surface());
        let journalled = s.operations();
        s.replace_document(doc.clone());
        assert_eq!(s.doc.to_json(), doc.to_json());
        assert_eq!(s.operations(), journalled, "not journalled");
        s.handle(&WandEvent::command(0.0, Command::SelectNextTarget))
            .unwrap();
        assert_eq!(s.interaction.target(), second);
    }

    #[test]
    fn a_base_scene_file_is_the_starting_document_and_bad_ones_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let mut base = editor::default_document();
        base.add_target("second", editor::default_surface());
        let scene = dir.path().join("base.json");
        std::fs::write(&scene, base.to_json()).unwrap();
        let mut cfg = config(&dir.path().join("run"));
        cfg.files.scene = Some(scene.clone());
        let mut s = Session::open(&cfg).unwrap();
        assert_eq!(s.doc.targets().len(), 2);
        s.handle(&WandEvent::command(0.0, Command::SelectNextTarget))
            .unwrap();
        let second = s.doc.targets()[1].id;
        assert_eq!(
            s.interaction.target(),
            second,
            "both targets can be selected"
        );
        drop(s);
        let s = Session::open(&cfg).unwrap();
        assert_eq!(s.interaction.target(), second, "the selection is recovered");
        std::fs::write(&scene, b"{\"format\":\"nope\"}").unwrap();
        let e = Session::open(&cfg).unwrap_err().to_string();
        assert!(e.contains("base.json"), "{e}");
        let _ = DVec3::ZERO;
    }
}
