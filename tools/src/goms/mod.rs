//! The GOMS / KLM timing-study harness behind `sculpt-tools goms`.
//!
//! - [`extract`]: operator event logs ([`sculpt_core::oplog`]) to timed P, K/B and M
//!   operators with Fitts measures;
//! - [`klm`]: Keystroke-Level Model predictions from a small method text format, with
//!   Card, Moran and Newell's M-placement rules and the paper's three methods built in;
//! - [`study`]: manifests, tallies and aggregation into the paper's Tables 1 and 2;
//! - [`stats`]: mean, SD, t and bootstrap intervals, paired t tests;
//! - [`report`]: CSV and Markdown outputs; [`plot`]: SVG and PNG plots;
//! - this module: the pipelines the subcommands run (study directory in, report out).

pub mod extract;
pub mod klm;
pub mod paper;
pub mod plot;
pub mod report;
pub mod stats;
pub mod study;
pub mod synth;
pub mod text;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use sculpt_core::oplog::{self, OpLog};

use extract::{ExtractConfig, Trial};
use stats::Bootstrap;
use study::{Analysis, Manifest, TallyRow};

/// Reads and decodes one operator event log, naming the file on errors.
pub fn load_log(path: &Path) -> Result<OpLog> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    oplog::decode_bytes(&bytes)
        .with_context(|| format!("{} is not a valid operator log", path.display()))
}

/// A log of a study, with who and what it records.
#[derive(Debug, Clone)]
pub struct StudyLog {
    /// Participant id (manifest, else header, else file stem).
    pub participant: String,
    /// Method id (manifest, else header, else `unknown`).
    pub method: String,
    /// Whether the manifest names the log (its method then holds for every trial;
    /// otherwise a trial that names its method, a segment after a mode switch, keeps it).
    pub from_manifest: bool,
    /// The decoded log.
    pub log: OpLog,
}

/// A study directory's manifest (if any), its logs, and warnings.
#[derive(Debug, Clone, Default)]
pub struct StudyInput {
    /// The manifest, when the directory has `study.toml`.
    pub manifest: Option<Manifest>,
    /// Logs found.
    pub logs: Vec<StudyLog>,
    /// Missing or truncated logs.
    pub warnings: Vec<String>,
}

/// The file name `wandsculpt` and `replay` give the operator log in a session or output
/// directory.
pub const OPLOG_FILE: &str = "operator.log";
/// The extension of operator logs named otherwise (`study simulate`, hand-made logs).
pub const OPLOG_EXT: &str = "oplog";

/// Whether a file is an operator log by its name: [`OPLOG_FILE`] or `*.`[`OPLOG_EXT`].
pub fn is_log_name(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n == OPLOG_FILE)
        || path.extension().is_some_and(|e| e == OPLOG_EXT)
}

fn find_logs(dir: &Path, skip: Option<&Path>, out: &mut Vec<PathBuf>, depth: usize) -> Result<()> {
    if depth > 16 {
        return Ok(());
    }
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for p in entries {
        if skip.is_some_and(|s| p == s) {
            continue;
        }
        if p.is_dir() {
            find_logs(&p, skip, out, depth + 1)?;
        } else if is_log_name(&p) {
            out.push(p);
        }
    }
    Ok(())
}

/// Reads a study directory: the sessions of `study.toml`, or every operator log below
/// it ([`is_log_name`]: `operator.log` as the programs write it, or `*.oplog`) (except under `skip`, the output directory). A log that does not decode is
/// an error, or with `skip_bad` a warning and left out.
pub fn read_study(dir: &Path, skip: Option<&Path>, skip_bad: bool) -> Result<StudyInput> {
    if !dir.is_dir() {
        bail!("{} is not a directory", dir.display());
    }
    let mut input = StudyInput::default();
    let manifest_path = dir.join(study::MANIFEST);
    let mut sessions: Vec<(PathBuf, Option<(String, String)>)> = Vec::new();
    if manifest_path.exists() {
        let text = std::fs::read_to_string(&manifest_path)
            .with_context(|| format!("cannot read {}", manifest_path.display()))?;
        let m =
            Manifest::parse(&text).with_context(|| format!("in {}", manifest_path.display()))?;
        for s in &m.sessions {
            let p = dir.join(&s.log);
            if p.exists() {
                sessions.push((p, Some((s.participant.clone(), s.method.clone()))));
            } else {
                input.warnings.push(format!(
                    "session {} / {} has no log yet ({})",
                    s.participant, s.method, s.log
                ));
            }
        }
        input.manifest = Some(m);
    } else {
        let mut paths = Vec::new();
        find_logs(dir, skip, &mut paths, 0)?;
        sessions.extend(paths.into_iter().map(|p| (p, None)));
    }
    for (path, who) in sessions {
        let log = match load_log(&path) {
            Ok(log) => log,
            Err(e) if skip_bad => {
                input.warnings.push(format!("left out: {e:#}"));
                continue;
            }
            Err(e) => return Err(e),
        };
        if log.truncated_tail {
            input.warnings.push(format!(
                "{}: the last line was cut short and was dropped",
                path.display()
            ));
        }
        // An `operator.log` is named by its directory (a session or replay output).
        let named_by = if path.file_name().is_some_and(|n| n == OPLOG_FILE) {
            path.parent().and_then(|d| d.file_name())
        } else {
            path.file_stem()
        };
        let stem = named_by
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let from_manifest = who.is_some();
        let (participant, method) = match who {
            Some((p, m)) => {
                if log.header.participant.as_ref().is_some_and(|h| h != &p)
                    || log.header.method.as_ref().is_some_and(|h| h != &m)
                {
                    input.warnings.push(format!(
                        "{}: header names {:?} / {:?}; the manifest's {p} / {m} is used",
                        path.display(),
                        log.header.participant.as_deref().unwrap_or(""),
                        log.header.method.as_deref().unwrap_or("")
                    ));
                }
                (p, m)
            }
            None => (
                log.header.participant.clone().unwrap_or(stem),
                log.header
                    .method
                    .clone()
                    .unwrap_or_else(|| "unknown".into()),
            ),
        };
        input.logs.push(StudyLog {
            participant,
            method,
            from_manifest,
            log,
        });
    }
    Ok(input)
}

/// Extracts the trials of every log of a study.
pub fn extract_all(logs: &[StudyLog], cfg: &ExtractConfig) -> Vec<Trial> {
    logs.iter()
        .flat_map(|l| {
            let mut trials = extract::extract(&l.log, cfg, &l.participant, &l.method);
            for t in &mut trials {
                // The manifest (or the fallback naming) decides; without a manifest a
                // trial naming its method (a plain session's mode segment) keeps it.
                t.participant.clone_from(&l.participant);
                if l.from_manifest {
                    t.method.clone_from(&l.method);
                }
            }
            trials
        })
        .collect()
}

/// Aggregates tallies with the manifest's method order, labels and baseline.
pub fn aggregate_with(
    rows: &[TallyRow],
    manifest: Option<&Manifest>,
    order: &[String],
    baseline: Option<&str>,
    boot: Bootstrap,
) -> Analysis {
    let mut ids: Vec<String> = manifest
        .map(|m| m.methods.iter().map(|x| x.id.clone()).collect())
        .unwrap_or_default();
    ids.extend(order.iter().cloned());
    let label = |id: &str| manifest.map_or_else(|| id.to_owned(), |m| m.label(id));
    let baseline = baseline.or(manifest.and_then(|m| m.baseline.as_deref()));
    study::aggregate(rows, &ids, &label, baseline, boot)
}

/// Multipliers applied to each threshold by the sensitivity report.
pub const SENSITIVITY_FACTORS: [f64; 5] = [0.5, 0.75, 1.0, 1.5, 2.0];

/// The sensitivity report: each threshold scaled by [`SENSITIVITY_FACTORS`] with the
/// others at their configured values; per setting, each method's mean P, K (or B), M
/// counts and total time. Returns `(csv, markdown)`.
pub fn sensitivity(
    logs: &[StudyLog],
    base: &ExtractConfig,
    manifest: Option<&Manifest>,
) -> (String, String) {
    type Setter = fn(&mut ExtractConfig, f64);
    let params: [(&str, f64, Setter); 5] = [
        ("smooth_sigma_s", base.smooth_sigma_s, |c, v| {
            c.smooth_sigma_s = v
        }),
        ("v_on", base.v_on, |c, v| c.v_on = v),
        ("v_off", base.v_off, |c, v| c.v_off = v),
        ("min_amplitude", base.min_amplitude, |c, v| {
            c.min_amplitude = v
        }),
        ("m_pause_s", base.m_pause_s, |c, v| c.m_pause_s = v),
    ];
    let mut csv = String::from("parameter,value,factor,method,P,K,B,M,total_time_s\n");
    let mut md = String::from(
        "\n## Sensitivity to the extraction thresholds\n\nEach threshold scaled with the others at their values; mean operators per participant (trial means).\n\n| parameter | value | method | P | K | B | M | time s |\n|---|---|---|---|---|---|---|---|\n",
    );
    for (name, value, set) in params {
        for f in SENSITIVITY_FACTORS {
            let mut cfg = *base;
            set(&mut cfg, value * f);
            if cfg.validate().is_err() {
                continue;
            }
            let rows = study::tally_trials(&extract_all(logs, &cfg));
            let a = aggregate_with(&rows, manifest, &[], None, Bootstrap { reps: 0, seed: 0 });
            for m in &a.methods {
                let get = |k: extract::OpKind| {
                    a.ops
                        .iter()
                        .position(|o| *o == k)
                        .map_or(0.0, |i| m.count[i].mean)
                };
                use extract::OpKind::{B, K, M, P};
                let _ = writeln!(
                    csv,
                    "{name},{},{f},{},{},{},{},{},{}",
                    value * f,
                    m.method,
                    get(P),
                    get(K),
                    get(B),
                    get(M),
                    m.total_time.mean
                );
                let _ = writeln!(
                    md,
                    "| {name}{} | {:.4} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
                    if f == 1.0 { " (set)" } else { "" },
                    value * f,
                    m.label,
                    get(P),
                    get(K),
                    get(B),
                    get(M),
                    m.total_time.mean
                );
            }
        }
    }
    (csv, md)
}
