//! Timing-study manifests (`study.toml`) and recording trials into a study's operator
//! logs.
//!
//! A study is participants x methods x trials. `sculpt-tools goms study init` writes the
//! manifest; the programs that record sessions (`replay --study`, `wandsculpt --study`)
//! read it to find a participant's next trial ([`Manifest::next_trial`]) and append the
//! trial to the session's log ([`append_trial`]); `sculpt-tools goms analyze` reads the
//! logs back. The model is pure (no file access), so the tools and the display programs
//! share it without the tools linking anything else.
//!
//! ```toml
//! name = "wall vs desk"
//! baseline = "desk"
//!
//! [[method]]
//! id = "wall"
//! label = "Sculpting at the wall"      # optional
//! klm = "builtin:multires-sculpting"   # optional KLM prediction
//!
//! [[session]]
//! participant = "P1"
//! method = "wall"
//! order = 1        # position in the participant's task order
//! trials = 3       # trials the session records
//! log = "logs/P1-wall.oplog"   # relative to the study directory
//! ```

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

use crate::oplog::{self, EventKind, OpLogHeader, OpLogWriter};

/// File name of the manifest inside a study directory.
pub const MANIFEST: &str = "study.toml";

/// A manifest that cannot be used, or a trial that cannot be recorded.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The text is not a manifest.
    #[error("study manifest is not valid: {0}")]
    Toml(#[from] toml::de::Error),
    /// The manifest cannot be written as TOML.
    #[error("study manifest cannot be written: {0}")]
    Write(#[from] toml::ser::Error),
    /// Two `[[method]]`s share an id.
    #[error("study manifest: method id {0:?} appears twice")]
    DuplicateMethod(String),
    /// A session names a method no `[[method]]` defines.
    #[error(
        "study manifest: session {session} uses method {method:?}, which no [[method]] defines"
    )]
    UnknownMethod {
        /// 1-based session index.
        session: usize,
        /// The method named.
        method: String,
    },
    /// A session without a participant or a log.
    #[error("study manifest: session {0} needs a participant and a log")]
    Incomplete(usize),
    /// The baseline is not a method.
    #[error("study manifest: baseline {0:?} is not a [[method]] id")]
    Baseline(String),
    /// The participant has no session in the manifest.
    #[error("participant {0:?} has no session in the study")]
    NoSuchParticipant(String),
    /// Every session of the participant has all its trials.
    #[error("participant {0:?} has recorded every trial of the study")]
    Done(String),
    /// A session's existing log does not decode.
    #[error("the log {log} of participant {participant:?}: {source}")]
    Log {
        /// Participant.
        participant: String,
        /// Log path as the manifest names it.
        log: String,
        /// Why it does not decode.
        source: crate::Error,
    },
}

/// A method (study condition) of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodSpec {
    /// Id used in sessions and logs.
    pub id: String,
    /// Label for tables and plots (defaults to the id).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// KLM method to predict against: `builtin:<id>` or a path relative to the study.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub klm: Option<String>,
}

/// One session: a participant doing one method, in one log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Session {
    /// Participant id.
    pub participant: String,
    /// Method id.
    pub method: String,
    /// Position in the participant's task order (1-based).
    #[serde(default)]
    pub order: u32,
    /// Trials the session should record.
    #[serde(default = "one")]
    pub trials: u32,
    /// Log path relative to the study directory.
    pub log: String,
}

fn one() -> u32 {
    1
}

/// The `study.toml` manifest.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Manifest {
    /// Study name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Method id the percentages and paired tests are relative to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline: Option<String>,
    /// Methods in table order.
    #[serde(default, rename = "method")]
    pub methods: Vec<MethodSpec>,
    /// Sessions in run order.
    #[serde(default, rename = "session")]
    pub sessions: Vec<Session>,
}

/// The trial to record next: which session, and its trial number.
#[derive(Debug, Clone, PartialEq)]
pub struct NextTrial {
    /// The session (participant, method, log path).
    pub session: Session,
    /// The trial number to record (1-based).
    pub trial: u32,
}

impl Manifest {
    /// Parses and checks a manifest.
    pub fn parse(text: &str) -> Result<Self, StudyError> {
        let m: Manifest = toml::from_str(text)?;
        let mut ids = BTreeSet::new();
        for x in &m.methods {
            if !ids.insert(x.id.as_str()) {
                return Err(StudyError::DuplicateMethod(x.id.clone()));
            }
        }
        for (i, s) in m.sessions.iter().enumerate() {
            if !m.methods.is_empty() && !ids.contains(s.method.as_str()) {
                return Err(StudyError::UnknownMethod {
                    session: i + 1,
                    method: s.method.clone(),
                });
            }
            if s.log.trim().is_empty() || s.participant.trim().is_empty() {
                return Err(StudyError::Incomplete(i + 1));
            }
        }
        if let Some(b) = &m.baseline
            && !m.methods.is_empty()
            && !ids.contains(b.as_str())
        {
            return Err(StudyError::Baseline(b.clone()));
        }
        Ok(m)
    }

    /// Writes the manifest as TOML.
    pub fn to_toml(&self) -> Result<String, StudyError> {
        Ok(toml::to_string(self)?)
    }

    /// The label of a method id.
    pub fn label(&self, id: &str) -> String {
        self.methods
            .iter()
            .find(|m| m.id == id)
            .and_then(|m| m.label.clone())
            .unwrap_or_else(|| id.to_owned())
    }

    /// A manifest for `participants` x `methods`, each session recording `trials`
    /// trials, methods ordered per participant by a balanced Latin square (Williams
    /// design; for an odd number of methods, rows are still a Latin square) or in the
    /// given order.
    pub fn plan(participants: &[String], methods: &[String], trials: u32, latin: bool) -> Self {
        let n = methods.len();
        let sessions = participants
            .iter()
            .enumerate()
            .flat_map(|(pi, p)| {
                let order: Vec<usize> = if latin && n > 0 {
                    williams_row(n, pi)
                } else {
                    (0..n).collect()
                };
                order
                    .into_iter()
                    .enumerate()
                    .map(|(k, mi)| Session {
                        participant: p.clone(),
                        method: methods[mi].clone(),
                        order: k as u32 + 1,
                        trials,
                        log: format!("logs/{p}-{}.oplog", methods[mi]),
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        Manifest {
            name: None,
            baseline: None,
            methods: methods
                .iter()
                .map(|id| MethodSpec {
                    id: id.clone(),
                    label: None,
                    klm: None,
                })
                .collect(),
            sessions,
        }
    }

    /// The participant's next trial: the first of their sessions, in task order, whose
    /// log holds fewer trials than the session records. `read_log` gives a session log's
    /// bytes (by the manifest's relative path), `None` when it does not exist yet.
    pub fn next_trial(
        &self,
        participant: &str,
        mut read_log: impl FnMut(&str) -> Option<Vec<u8>>,
    ) -> Result<NextTrial, StudyError> {
        let mut mine: Vec<&Session> = self
            .sessions
            .iter()
            .filter(|s| s.participant == participant)
            .collect();
        if mine.is_empty() {
            return Err(StudyError::NoSuchParticipant(participant.to_owned()));
        }
        mine.sort_by_key(|s| s.order);
        for s in mine {
            let recorded = match read_log(&s.log) {
                None => 0,
                Some(bytes) => trials_in(&bytes).map_err(|source| StudyError::Log {
                    participant: participant.to_owned(),
                    log: s.log.clone(),
                    source,
                })?,
            };
            if recorded < s.trials {
                return Ok(NextTrial {
                    session: s.clone(),
                    trial: recorded + 1,
                });
            }
        }
        Err(StudyError::Done(participant.to_owned()))
    }
}

/// Row `r` of a balanced Latin square of size `n` (Williams 1949): 0, 1, n-1, 2, n-2, ...
/// shifted by `r`.
fn williams_row(n: usize, r: usize) -> Vec<usize> {
    let mut base = Vec::with_capacity(n);
    let (mut lo, mut hi) = (0usize, n);
    for k in 0..n {
        if k % 2 == 0 {
            base.push(lo);
            lo += 1;
        } else {
            hi -= 1;
            base.push(hi);
        }
    }
    base.into_iter().map(|x| (x + r) % n).collect()
}

/// Trials recorded in a study log: its `trial_start` events.
pub fn trials_in(log: &[u8]) -> crate::Result<u32> {
    let log = oplog::decode_bytes(log)?;
    Ok(log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::TrialStart { .. }))
        .count() as u32)
}

/// Appends one recorded trial to a session's log: `existing` is the log so far (`None`
/// starts it with a header naming the participant, the method and `source`), `events`
/// the operator log of the trial as a program wrote it (its own header is dropped). The
/// trial is framed by `trial_start` (with `task`) and `trial_end`, and its times are
/// moved to start where the log so far ends, so times never go backwards. Returns the
/// whole new log.
pub fn append_trial(
    existing: Option<&[u8]>,
    next: &NextTrial,
    source: &str,
    task: Option<&str>,
    events: &[u8],
) -> crate::Result<Vec<u8>> {
    let trial = oplog::decode_bytes(events)?;
    let t0 = trial.events.first().map_or(0.0, |e| e.t);
    let t1 = trial.events.last().map_or(t0, |e| e.t);
    append_span(existing, next, source, task, &trial.events, (t0, t1))
}

/// Appends one trial as [`append_trial`] does, from events already decoded, over the
/// span `(t0, t1)` of the program's clock (the trial's start and end signals, which
/// may lie before the first and after the last event). Events outside the span are
/// left out, and so are the events' own `trial_start` and `trial_end` marks (a plain
/// log's segments, [`oplog::ModeSegments`]): the study's trial is the segment.
pub fn append_span(
    existing: Option<&[u8]>,
    next: &NextTrial,
    source: &str,
    task: Option<&str>,
    events: &[oplog::OpEvent],
    (t0, t1): (f64, f64),
) -> crate::Result<Vec<u8>> {
    let (mut bytes, offset) = match existing {
        Some(old) => {
            let log = oplog::decode_bytes(old)?;
            let end = log.events.last().map_or(0.0, |e| e.t);
            // Re-encode what decoded, so a cut-short last line is dropped cleanly.
            (oplog::encode(&log), end)
        }
        None => (Vec::new(), 0.0),
    };
    let header = OpLogHeader::new()
        .with_participant(next.session.participant.clone())
        .with_method(next.session.method.clone())
        .with_source(source);
    let mut w = OpLogWriter::new(&header);
    if existing.is_some() {
        // The header is already in `bytes`.
        w.take();
    }
    let t1 = t1.max(t0);
    w.push(
        offset,
        EventKind::TrialStart {
            trial: next.trial,
            task: task.map(str::to_owned),
            method: None,
        },
    )?;
    // A plain log's own segment marks (one per mode, `ModeSegments`) are left out:
    // the study's trial is the segment.
    let marks =
        |k: &EventKind| matches!(k, EventKind::TrialStart { .. } | EventKind::TrialEnd { .. });
    for e in events
        .iter()
        .filter(|e| e.t >= t0 && e.t <= t1 && !marks(&e.kind))
    {
        w.push(offset + (e.t - t0), e.kind.clone())?;
    }
    w.push(
        offset + (t1 - t0),
        EventKind::TrialEnd { trial: next.trial },
    )?;
    bytes.extend(w.take());
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study() -> Manifest {
        let ps: Vec<String> = ["P1", "P2"].iter().map(|s| s.to_string()).collect();
        let ms: Vec<String> = ["wall", "desk"].iter().map(|s| s.to_string()).collect();
        Manifest::plan(&ps, &ms, 2, true)
    }

    fn replayed(n: usize) -> Vec<u8> {
        let mut w = OpLogWriter::new(&OpLogHeader::new().with_method("carve"));
        for i in 0..n {
            w.push(0.5 + i as f64, EventKind::Button { id: 0, down: true })
                .unwrap();
            w.push(0.6 + i as f64, EventKind::Button { id: 0, down: false })
                .unwrap();
        }
        w.take()
    }

    #[test]
    fn trials_go_session_by_session_into_the_manifests_logs() {
        let m = study();
        let mut logs: std::collections::BTreeMap<String, Vec<u8>> = Default::default();
        let mut seen = Vec::new();
        for _ in 0..4 {
            let next = m.next_trial("P2", |p| logs.get(p).cloned()).unwrap();
            let old = logs.get(&next.session.log).cloned();
            let new = append_trial(
                old.as_deref(),
                &next,
                "replay",
                Some("groove"),
                &replayed(2),
            )
            .unwrap();
            seen.push((next.session.method.clone(), next.trial));
            logs.insert(next.session.log.clone(), new);
        }
        // P2's Latin-square order is desk, wall; two trials each.
        assert_eq!(
            seen,
            [
                ("desk".to_owned(), 1),
                ("desk".to_owned(), 2),
                ("wall".to_owned(), 1),
                ("wall".to_owned(), 2)
            ]
        );
        assert!(matches!(
            m.next_trial("P2", |p| logs.get(p).cloned()),
            Err(StudyError::Done(_))
        ));
        assert!(matches!(
            m.next_trial("P9", |_| None),
            Err(StudyError::NoSuchParticipant(_))
        ));
        // The log names the study's participant and method (not the program's mode),
        // frames each trial, and its times never go back.
        let log = oplog::decode_bytes(&logs["logs/P2-desk.oplog"]).unwrap();
        assert_eq!(log.header.participant.as_deref(), Some("P2"));
        assert_eq!(log.header.method.as_deref(), Some("desk"));
        let frames: Vec<(f64, String)> = log
            .events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::TrialStart { trial, task, .. } => Some((
                    e.t,
                    format!("start {trial} {}", task.as_deref().unwrap_or("")),
                )),
                EventKind::TrialEnd { trial } => Some((e.t, format!("end {trial}"))),
                _ => None,
            })
            .collect();
        let labels: Vec<&str> = frames.iter().map(|f| f.1.as_str()).collect();
        assert_eq!(
            labels,
            ["start 1 groove", "end 1", "start 2 groove", "end 2"]
        );
        crate::assert_near!(frames[1].0, 1.1, crate::tolerance::TIME_EPS);
        crate::assert_near!(frames[3].0, 2.2, crate::tolerance::TIME_EPS);
        assert_eq!(log.events.len(), 2 * (2 + 4));
    }

    #[test]
    fn a_bad_log_in_the_study_names_itself() {
        let m = study();
        let e = m
            .next_trial("P1", |_| Some(b"not a log".to_vec()))
            .unwrap_err();
        assert!(e.to_string().contains("logs/P1-wall.oplog"), "{e}");
    }

    #[test]
    fn manifest_errors() {
        assert!(matches!(
            Manifest::parse(
                "[[session]]\nparticipant='p'\nmethod='x'\nlog='l'\n[[method]]\nid='y'\n"
            ),
            Err(StudyError::UnknownMethod { session: 1, .. })
        ));
        assert!(matches!(
            Manifest::parse("baseline = 3"),
            Err(StudyError::Toml(_))
        ));
        assert!(matches!(
            Manifest::parse("[[method]]\nid='a'\n[[method]]\nid='a'\n"),
            Err(StudyError::DuplicateMethod(_))
        ));
        assert!(Manifest::parse("").unwrap().sessions.is_empty());
        let back = Manifest::parse(&study().to_toml().unwrap()).unwrap();
        assert_eq!(back, study());
    }
}
