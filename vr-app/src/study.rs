//! Study mode (`wandsculpt --study MANIFEST --participant P`): the display server
//! records the participant's trials of a timing study into the logs the manifest
//! names, as `replay --study` does (the model is `sculpt_core::study`).
//!
//! [`StudyRun::open`] finds the participant's next trial ([`Manifest::next_trial`],
//! what `sculpt-tools goms study next` names). A trial starts and ends on a signal (the
//! `Enter` key on the desktop, the start and end of the input in a headless run); its
//! operator events, desktop keys included, are appended to the session's log with
//! [`sculpt_core::study::append_span`], framed by `trial_start` / `trial_end`, and the
//! next trial is looked up again. The HUD shows participant, method and trial
//! ([`StudyRun::hud_line`]).

use std::path::{Path, PathBuf};

use sculpt_core::study::{Manifest, NextTrial, append_span};

use crate::error::{VrError, VrResult};
use crate::session::Session;

/// The `source` a study log written by the display server names.
pub const STUDY_SOURCE: &str = "wandsculpt";

/// A participant's study run: the manifest, the next trial and whether it is being
/// recorded.
#[derive(Debug, Clone)]
pub struct StudyRun {
    manifest_path: PathBuf,
    manifest: Manifest,
    participant: String,
    task: Option<String>,
    /// The trial to record next; `None` once every trial is recorded.
    next: Option<NextTrial>,
    /// Start time (session clock) of the trial being recorded.
    recording: Option<f64>,
    /// The trial being recorded starts at its first event (a headless run).
    from_first_event: bool,
}

fn study_err(path: &Path, e: sculpt_core::study::StudyError) -> VrError {
    VrError::Study {
        path: path.to_path_buf(),
        reason: Box::new(e),
    }
}

impl StudyRun {
    /// Reads the manifest and finds the participant's next trial. An unknown
    /// participant, a bad log, or a participant with every trial recorded is an error.
    /// `task` names the trials' task (default: the method).
    pub fn open(manifest_path: &Path, participant: &str, task: Option<String>) -> VrResult<Self> {
        let text = std::fs::read_to_string(manifest_path).map_err(|source| VrError::Io {
            path: manifest_path.display().to_string(),
            source,
        })?;
        let manifest = Manifest::parse(&text).map_err(|e| study_err(manifest_path, e))?;
        let mut run = Self {
            manifest_path: manifest_path.to_path_buf(),
            manifest,
            participant: participant.to_owned(),
            task,
            next: None,
            recording: None,
            from_first_event: false,
        };
        run.next = Some(run.find_next()?);
        Ok(run)
    }

    fn dir(&self) -> &Path {
        self.manifest_path.parent().unwrap_or(Path::new("."))
    }

    fn find_next(&self) -> VrResult<NextTrial> {
        let dir = self.dir().to_path_buf();
        self.manifest
            .next_trial(&self.participant, |log| std::fs::read(dir.join(log)).ok())
            .map_err(|e| study_err(&self.manifest_path, e))
    }

    /// The trial to record next (or being recorded); `None` once all are recorded.
    pub fn next(&self) -> Option<&NextTrial> {
        self.next.as_ref()
    }

    /// Whether a trial is being recorded.
    pub fn recording(&self) -> bool {
        self.recording.is_some()
    }

    /// The participant.
    pub fn participant(&self) -> &str {
        &self.participant
    }

    /// Prepares the session's operator log for the study (header with participant and
    /// the first method). Call before any input.
    pub fn attach(&self, session: &mut Session) -> VrResult<()> {
        let method = self.next.as_ref().map_or("", |n| n.session.method.as_str());
        session.start_study(&self.participant, method)
    }

    fn task(&self, next: &NextTrial) -> String {
        self.task
            .clone()
            .unwrap_or_else(|| next.session.method.clone())
    }

    /// Starts recording the next trial at `t` (session seconds). False when a trial is
    /// already being recorded or every trial is recorded.
    pub fn start(&mut self, session: &mut Session, t: f64) -> bool {
        let Some(next) = &self.next else {
            return false;
        };
        if self.recording.is_some() {
            return false;
        }
        let t = t.max(session.log_time());
        let task = self.task(next);
        let at = (!self.from_first_event).then_some(t);
        session.begin_trial(at, next.trial, Some(&task), &next.session.method);
        self.recording = Some(t);
        true
    }

    /// Starts recording the next trial, spanning from its first event (a headless run,
    /// whose input is the trial). False as [`StudyRun::start`].
    pub fn start_at_first_event(&mut self, session: &mut Session) -> bool {
        let t = session.log_time();
        self.from_first_event = true;
        self.from_first_event = self.start(session, t);
        self.from_first_event
    }

    /// Ends the trial being recorded at `t` (`None`: at its last event), appends it to
    /// the session log the manifest names (written beside and renamed, so a crash never
    /// leaves half a log) and finds the next trial. Returns the log written, `None`
    /// when no trial was being recorded.
    pub fn finish(&mut self, session: &mut Session, t: Option<f64>) -> VrResult<Option<PathBuf>> {
        let (Some(start), Some(next)) = (self.recording.take(), self.next.clone()) else {
            return Ok(None);
        };
        let end = t.unwrap_or_else(|| session.log_time());
        let Some(events) = session.end_trial(end, next.trial) else {
            return Ok(None);
        };
        let start = match events.first() {
            Some(e) if std::mem::take(&mut self.from_first_event) => e.t,
            _ => start,
        };
        let end = end.max(events.last().map_or(start, |e| e.t));
        let log = self.dir().join(&next.session.log);
        let existing = match std::fs::read(&log) {
            Ok(b) => Some(b),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(source) => {
                return Err(VrError::Io {
                    path: log.display().to_string(),
                    source,
                });
            }
        };
        let task = self.task(&next);
        let bytes = append_span(
            existing.as_deref(),
            &next,
            STUDY_SOURCE,
            Some(&task),
            &events,
            (start, end),
        )
        .map_err(|e| VrError::StudyLog {
            path: log.clone(),
            reason: Box::new(e),
        })?;
        if let Some(parent) = log.parent() {
            crate::session::create_output_dir(parent).map_err(|source| VrError::Io {
                path: parent.display().to_string(),
                source,
            })?;
        }
        crate::session::write_atomic(&log, &bytes)?;
        tracing::info!(
            participant = %self.participant,
            method = %next.session.method,
            trial = next.trial,
            log = %log.display(),
            "study trial recorded"
        );
        self.next = match self.find_next() {
            Ok(n) => Some(n),
            Err(VrError::Study { reason, .. })
                if matches!(*reason, sculpt_core::study::StudyError::Done(_)) =>
            {
                None
            }
            Err(e) => return Err(e),
        };
        Ok(Some(log))
    }

    /// Starts the next trial, or finishes the one being recorded (the desktop's trial
    /// key). Returns the log written when a trial was finished.
    pub fn toggle(&mut self, session: &mut Session, t: f64) -> VrResult<Option<PathBuf>> {
        if self.recording() {
            self.finish(session, Some(t))
        } else {
            self.start(session, t);
            Ok(None)
        }
    }

    /// `P1 / wall trial 2 of 3`: the trial to record next (or being recorded);
    /// `None` once every trial is recorded.
    pub fn trial_label(&self) -> Option<String> {
        self.next.as_ref().map(|n| {
            format!(
                "{} / {} trial {} of {}",
                self.participant,
                self.manifest.label(&n.session.method),
                n.trial,
                n.session.trials
            )
        })
    }

    /// The HUD line: participant, method, trial, and what the trial key does now.
    pub fn hud_line(&self) -> String {
        match self.trial_label() {
            None => format!("study: {} has recorded every trial", self.participant),
            Some(label) => {
                let what = if self.recording() {
                    "RECORDING (Enter ends the trial)"
                } else {
                    "Enter starts the trial"
                };
                format!("study: {label}  {what}")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use glam::DQuat;
    use sculpt_core::editor::default_surface_point;
    use sculpt_core::interaction::{Command, WandEvent, WandSample};
    use sculpt_core::oplog::{EventKind, decode_bytes};

    fn stroke(s: &mut Session, t0: f64) {
        for i in 0..=10 {
            let p = default_surface_point(-0.1 + i as f64 * 0.02, 1.1);
            s.handle(&WandEvent::sample(
                t0 + i as f64 * 0.01,
                WandSample::tracked(p, DQuat::IDENTITY, u32::from(i < 10)),
            ))
            .unwrap();
        }
    }

    /// A participant's trials go into the manifest's log, framed, with keys as `key`
    /// events, and the next trial follows as `goms study next` names it.
    #[test]
    fn trials_are_recorded_into_the_manifests_log_and_advance() {
        let dir = tempfile::tempdir().unwrap();
        let ps = vec!["P1".to_owned()];
        let ms = vec!["wall".to_owned(), "desk".to_owned()];
        let manifest = Manifest::plan(&ps, &ms, 2, false);
        let path = dir.path().join(sculpt_core::study::MANIFEST);
        std::fs::write(&path, manifest.to_toml().unwrap()).unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().join("run");
        let mut session = Session::open(&cfg).unwrap();
        let mut run = StudyRun::open(&path, "P1", None).unwrap();
        run.attach(&mut session).unwrap();
        assert!(
            run.hud_line().contains("P1 / wall trial 1 of 2"),
            "{}",
            run.hud_line()
        );
        // Before the start signal nothing is recorded.
        stroke(&mut session, 0.0);
        assert!(run.start(&mut session, 1.0));
        assert!(run.hud_line().contains("RECORDING"));
        stroke(&mut session, 1.5);
        session.key(2.0, "Ctrl+Z");
        session
            .handle(&WandEvent::command(2.0, Command::Undo))
            .unwrap();
        let log = run.finish(&mut session, Some(3.0)).unwrap().unwrap();
        assert_eq!(log, dir.path().join("logs/P1-wall.oplog"));
        assert!(run.hud_line().contains("P1 / wall trial 2 of 2"));
        let study = decode_bytes(&std::fs::read(&log).unwrap()).unwrap();
        assert_eq!(study.header.participant.as_deref(), Some("P1"));
        assert_eq!(study.header.method.as_deref(), Some("wall"));
        assert_eq!(study.header.source.as_deref(), Some(STUDY_SOURCE));
        let first = study.events.first().unwrap();
        let last = study.events.last().unwrap();
        assert!(matches!(first.kind, EventKind::TrialStart { trial: 1, .. }));
        assert!(matches!(last.kind, EventKind::TrialEnd { trial: 1 }));
        // The trial is the span between the signals, moved to start at zero.
        sculpt_core::assert_near!(last.t - first.t, 2.0, sculpt_core::tolerance::TIME_EPS);
        let kinds: Vec<&EventKind> = study.events.iter().map(|e| &e.kind).collect();
        assert!(kinds.contains(&&EventKind::Key {
            key: "Ctrl+Z".into()
        }));
        assert_eq!(
            kinds
                .iter()
                .filter(|k| ***k == EventKind::StrokeStart)
                .count(),
            1,
            "only the stroke after the start signal"
        );
        // Trial 2 of wall, then desk's two trials, then the study is done.
        for (want, t) in [
            ("wall trial 2", 4.0),
            ("desk trial 1", 6.0),
            ("desk trial 2", 8.0),
        ] {
            assert!(run.hud_line().contains(want), "{}", run.hud_line());
            run.toggle(&mut session, t).unwrap();
            stroke(&mut session, t + 0.1);
            assert!(run.toggle(&mut session, t + 1.0).unwrap().is_some());
        }
        assert!(run.next().is_none());
        assert!(!run.start(&mut session, 10.0));
        assert!(run.hud_line().contains("every trial"));
        let again = StudyRun::open(&path, "P1", None).unwrap_err().to_string();
        assert!(again.contains("every trial"), "{again}");
        assert!(StudyRun::open(&path, "P9", None).is_err());
    }
}
