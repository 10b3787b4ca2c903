//! `sculpt-tools goms ...`: the GOMS / KLM timing-study harness (see `docs/goms.md`,
//! `docs/cli/sculpt-tools.md` and `docs/formats/goms-files.md` for every subcommand,
//! flag and file format).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};

/// `println!` that returns a write error instead of panicking, so a closed pipe
/// (`goms study status | head`) ends the command quietly (see `main`).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}

use crate::goms::extract::{ExtractConfig, KMode};
use crate::goms::klm::{self, Constants, MentalConstant, Typist};
use crate::goms::report::{self, EventRow, KlmLine, ReportContext};
use crate::goms::stats::Bootstrap;
use crate::goms::study::{self, Manifest, TallyRow};
use crate::goms::{self as g, plot};

/// `goms` arguments.
#[derive(Debug, Args)]
pub struct GomsArgs {
    #[command(subcommand)]
    cmd: GomsCmd,
}

#[derive(Debug, Subcommand)]
enum GomsCmd {
    /// Extract operators from operator event logs into a CSV event table.
    Extract(ExtractArgs),
    /// Analyse a study directory: events, tallies, Tables 1/2, statistics, plots, report.
    Analyze(AnalyzeArgs),
    /// Aggregate a tally or event table CSV (hand-coded or exported) into the report.
    Summarize(SummarizeArgs),
    /// Predict execution times with the Keystroke-Level Model.
    Klm(KlmArgs),
    /// List the built-in KLM methods, or print one.
    Methods {
        /// Built-in id to print.
        id: Option<String>,
    },
    /// Study mode: plan a study, see what is recorded, and get the next session.
    #[command(subcommand)]
    Study(StudyCmd),
    /// A method's KLM prediction, measured trials and the paper's Tables 1 and 2 side
    /// by side.
    Paper(PaperArgs),
}

#[derive(Debug, Args)]
struct PaperArgs {
    /// Directory of operator logs (a study, or any operator.log / *.oplog below it);
    /// every trial in it is taken as a trial of the method, a plain `wandsculpt` or
    /// `replay` session as one trial (its mode segments joined).
    dir: PathBuf,
    /// The paper's row: multires, trimming or multi-surface.
    #[arg(long, default_value = "multires")]
    paper: String,
    /// The KLM method to predict with (`builtin:<id>` or a file).
    #[arg(long, default_value = "builtin:multires-sculpting")]
    klm: String,
    /// Only the trials of this method id (default: all).
    #[arg(long)]
    method: Option<String>,
    /// Also write the comparison as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
    #[command(flatten)]
    thresholds: Thresholds,
    #[command(flatten)]
    constants: KlmConstants,
}

/// Extraction thresholds (see `docs/goms.md` for the rules).
#[derive(Debug, Clone, Args)]
struct Thresholds {
    /// Gaussian smoothing of the wand speed, seconds (0 = none).
    #[arg(long, default_value_t = 0.025)]
    smooth_sigma: f64,
    /// Movement onset speed, m/s.
    #[arg(long, default_value_t = 0.10)]
    v_on: f64,
    /// Movement offset speed, m/s (at most --v-on).
    #[arg(long, default_value_t = 0.04)]
    v_off: f64,
    /// Smallest excursion of a P from its start, metres.
    #[arg(long, default_value_t = 0.02)]
    min_amplitude: f64,
    /// Shortest pause counted as M, seconds (also the longest still gap inside one P).
    #[arg(long, default_value_t = 1.0)]
    m_pause: f64,
    /// Pose samples further apart than this start a new run, seconds.
    #[arg(long, default_value_t = 0.1)]
    gap: f64,
    /// How a press + release counts: one K, or B + B.
    #[arg(long, value_enum, default_value_t = KMode::K)]
    k_mode: KMode,
    /// The keystroke window a press owns as its K, seconds (each B owns half).
    #[arg(long, default_value_t = 0.2)]
    k_window: f64,
    /// Target width for Fitts' ID when the log names no target, metres.
    #[arg(long)]
    default_width: Option<f64>,
}

impl Thresholds {
    fn config(&self) -> Result<ExtractConfig> {
        let c = ExtractConfig {
            smooth_sigma_s: self.smooth_sigma,
            v_on: self.v_on,
            v_off: self.v_off,
            min_amplitude: self.min_amplitude,
            m_pause_s: self.m_pause,
            gap_s: self.gap,
            k_mode: self.k_mode,
            k_window_s: self.k_window,
            default_width: self.default_width,
        };
        c.validate().map_err(anyhow::Error::msg)?;
        Ok(c)
    }
}

/// KLM constant choice.
#[derive(Debug, Clone, Args)]
struct KlmConstants {
    /// M constant: Card-Moran-Newell 1.35 s or Kieras 1.20 s.
    #[arg(long, value_enum, default_value_t = MentalConstant::Cmn)]
    mental: MentalConstant,
    /// K constant: average non-secretary 0.28 s or skilled 0.20 s.
    #[arg(long, value_enum, default_value_t = Typist::Average)]
    typist: Typist,
}

impl KlmConstants {
    fn constants(&self) -> Constants {
        Constants::standard(self.typist, self.mental)
    }

    fn describe(&self) -> String {
        let c = self.constants();
        format!(
            "K {:.2} s, B {:.2} s, P {:.2} s, H {:.2} s, M {:.2} s",
            c.k, c.b, c.p, c.h, c.m
        )
    }
}

/// Statistics settings.
#[derive(Debug, Clone, Args)]
struct StatArgs {
    /// Bootstrap resamples for the percentile intervals (0 = off).
    #[arg(long, default_value_t = 2000)]
    bootstrap: usize,
    /// Bootstrap seed (fixed, so reports are reproducible).
    #[arg(long, default_value_t = 0x5eed_2006)]
    seed: u64,
    /// Baseline method id for the paired comparisons in the report.
    #[arg(long)]
    baseline: Option<String>,
    /// Do not draw plots.
    #[arg(long)]
    no_plots: bool,
}

impl StatArgs {
    fn boot(&self) -> Bootstrap {
        Bootstrap {
            reps: self.bootstrap.min(1_000_000),
            seed: self.seed,
        }
    }
}

#[derive(Debug, Args)]
struct ExtractArgs {
    /// Operator event logs.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Event table to write (default: standard output).
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Also write the Fitts table (both IDs) here.
    #[arg(long)]
    fitts: Option<PathBuf>,
    /// Participant id for logs whose header names none.
    #[arg(long, default_value = "unknown")]
    participant: String,
    /// Method id for logs whose header names none.
    #[arg(long, default_value = "unknown")]
    method: String,
    #[command(flatten)]
    thresholds: Thresholds,
}

#[derive(Debug, Args)]
struct AnalyzeArgs {
    /// Study directory (with study.toml, or any *.oplog files below it).
    dir: PathBuf,
    /// Output directory (default: `<dir>/report`).
    #[arg(short, long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    thresholds: Thresholds,
    #[command(flatten)]
    stats: StatArgs,
    #[command(flatten)]
    klm: KlmConstants,
    /// Also write the sensitivity report over the thresholds.
    #[arg(long)]
    sensitivity: bool,
    /// Trials to draw Gantt and speed plots for: `first`, `all`, or PARTICIPANT/METHOD/TRIAL.
    #[arg(long, default_value = "first")]
    trace: String,
    /// Leave out logs that do not decode (listed as warnings) instead of failing.
    #[arg(long)]
    skip_bad: bool,
}

#[derive(Debug, Args)]
struct SummarizeArgs {
    /// Tally CSV: participant,method,trial,op,count,time.
    #[arg(long, conflicts_with = "events", required_unless_present = "events")]
    tally: Option<PathBuf>,
    /// Event table CSV: participant,method,trial,op,t_start,t_end,duration,amplitude,width,id.
    #[arg(long)]
    events: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long, default_value = "goms-report")]
    out: PathBuf,
    /// Method ids in table order (comma-separated); others follow in order of appearance.
    #[arg(long, value_delimiter = ',')]
    order: Vec<String>,
    /// Report title.
    #[arg(long)]
    title: Option<String>,
    /// KLM prediction to show next to a method's measured time: `METHOD=builtin:<id>` or
    /// METHOD=path/to/method.klm (repeatable).
    #[arg(long, value_name = "METHOD=SOURCE")]
    klm: Vec<String>,
    #[command(flatten)]
    klm_constants: KlmConstants,
    #[command(flatten)]
    stats: StatArgs,
}

#[derive(Debug, Args)]
struct KlmArgs {
    /// Method files, or `builtin:<id>` (see `goms methods`).
    #[arg(required = true)]
    methods: Vec<String>,
    #[command(flatten)]
    constants: KlmConstants,
    /// Place the M operators by Card, Moran and Newell's rules 0-4 (written Ms are dropped).
    #[arg(long)]
    place_m: bool,
    /// Show the operator sequence and each rule decision.
    #[arg(long)]
    explain: bool,
}

#[derive(Debug, Subcommand)]
enum StudyCmd {
    /// Create a study directory with a manifest (participants x methods, task order).
    Init {
        /// Study directory to create.
        dir: PathBuf,
        /// Number of participants (named P1, P2, ...).
        #[arg(long)]
        participants: usize,
        /// Method ids, comma-separated.
        #[arg(long, value_delimiter = ',', required = true)]
        methods: Vec<String>,
        /// Trials per session.
        #[arg(long, default_value_t = 1)]
        trials: u32,
        /// Task order: a balanced Latin square, or the given order for everyone.
        #[arg(long, value_enum, default_value_t = Order::Latin)]
        order: Order,
        /// Baseline method id.
        #[arg(long)]
        baseline: Option<String>,
        /// Study name.
        #[arg(long)]
        name: Option<String>,
    },
    /// List the sessions and whether their logs are recorded.
    Status {
        /// Study directory.
        dir: PathBuf,
    },
    /// Fill the pending sessions with synthetic logs from the scripted wand (a demo of
    /// the pipeline without hardware; logs say `source: synthetic`).
    Simulate {
        /// Study directory.
        dir: PathBuf,
        /// Seed of the scripts.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Scripted actions per trial for the first method; each later method in the
        /// manifest gets half as many again (so the methods differ).
        #[arg(long, default_value_t = 6)]
        steps: usize,
    },
    /// Print the next trial to record: the first session, in manifest order, with
    /// fewer trials in its log than it asks for (participant, method, order, trial,
    /// trials, log path).
    Next {
        /// Study directory.
        dir: PathBuf,
        /// Print JSON instead of a tab-separated line.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Order {
    Latin,
    Fixed,
}

/// Runs a `goms` subcommand.
pub fn run(args: GomsArgs) -> Result<()> {
    match args.cmd {
        GomsCmd::Extract(a) => extract(a),
        GomsCmd::Analyze(a) => analyze(a),
        GomsCmd::Summarize(a) => summarize(a),
        GomsCmd::Klm(a) => klm_cmd(a),
        GomsCmd::Methods { id } => methods(id),
        GomsCmd::Study(s) => study_cmd(s),
        GomsCmd::Paper(a) => paper_cmd(a),
    }
}

fn paper_cmd(a: PaperArgs) -> Result<()> {
    use crate::goms::paper;
    let cfg = a.thresholds.config()?;
    let Some(row) = paper::row(&a.paper) else {
        bail!(
            "--paper {:?}: the paper's rows are multires, trimming and multi-surface",
            a.paper
        );
    };
    let text = klm_text(&a.klm, Path::new("."))?;
    let m = klm::parse_method(&text).with_context(|| format!("KLM method {}", a.klm))?;
    let prediction = klm::predict(&m.steps, &a.constants.constants());
    let mut input = g::read_study(&a.dir, None, false)?;
    // A plain session is one trial of the task, its mode segments joined.
    for l in &mut input.logs {
        l.log = paper::whole_session(&l.log);
    }
    let trials: Vec<_> = g::extract_all(&input.logs, &cfg)
        .into_iter()
        .filter(|t| a.method.as_ref().is_none_or(|m| *m == t.method))
        .collect();
    if trials.is_empty() {
        bail!("{}: no trial to compare", a.dir.display());
    }
    let mut sources: std::collections::BTreeMap<String, usize> = Default::default();
    for l in &input.logs {
        let s = l
            .log
            .header
            .source
            .clone()
            .unwrap_or_else(|| "unnamed".into());
        *sources.entry(s).or_default() += 1;
    }
    let sources: Vec<String> = sources
        .iter()
        .map(|(s, n)| format!("{n} logs written by {s}"))
        .collect();
    let c = paper::compare(row, &prediction, &trials);
    say!("{}", c.markdown(&a.klm, &sources.join(", ")));
    if let Some(path) = &a.csv {
        write(path, &c.csv())?;
    }
    Ok(())
}

fn extract(a: ExtractArgs) -> Result<()> {
    let cfg = a.thresholds.config()?;
    let mut trials = Vec::new();
    for p in &a.logs {
        let log = g::load_log(p)?;
        if log.truncated_tail {
            eprintln!(
                "warning: {}: the last line was cut short and was dropped",
                p.display()
            );
        }
        trials.extend(g::extract::extract(&log, &cfg, &a.participant, &a.method));
    }
    let rows = report::event_rows(&trials);
    match &a.out {
        Some(path) => report::write_csv(path, &rows, &report::EVENT_COLUMNS)?,
        None => {
            let mut w = csv::Writer::from_writer(std::io::stdout());
            if rows.is_empty() {
                w.write_record(report::EVENT_COLUMNS)?;
            }
            for r in &rows {
                w.serialize(r)?;
            }
            w.flush()?;
        }
    }
    if let Some(path) = &a.fitts {
        report::write_csv(path, &report::fitts_rows(&trials), &report::FITTS_COLUMNS)?;
    }
    Ok(())
}

fn write(path: &Path, text: &str) -> Result<()> {
    super::io::write_file(path, text.as_bytes())
}

/// Writes the files every report has; returns the plot files (relative names).
fn write_common(
    out: &Path,
    rows: &[TallyRow],
    a: &study::Analysis,
    no_plots: bool,
) -> Result<Vec<String>> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    report::write_csv(&out.join("tally.csv"), rows, &report::TALLY_COLUMNS)?;
    write(&out.join("summary.csv"), &report::summary_csv(a))?;
    write(&out.join("stats.csv"), &report::stats_csv(a))?;
    write(&out.join("comparisons.csv"), &report::comparisons_csv(a))?;
    let mut plots = Vec::new();
    if !no_plots {
        for f in plot::study_plots(out, a)? {
            plots.push(rel(out, &f));
        }
    }
    Ok(plots)
}

fn rel(base: &Path, p: &Path) -> String {
    p.strip_prefix(base)
        .unwrap_or(p)
        .to_string_lossy()
        .into_owned()
}

fn analyze(a: AnalyzeArgs) -> Result<()> {
    let cfg = a.thresholds.config()?;
    let out = a.out.clone().unwrap_or_else(|| a.dir.join("report"));
    let input = g::read_study(&a.dir, Some(&out), a.skip_bad)?;
    let manifest = input.manifest.as_ref();
    let trials = g::extract_all(&input.logs, &cfg);
    if trials.is_empty() {
        let mut msg = format!(
            "{}: no trial to analyse ({} operator logs found; a study reads the logs its \
             study.toml names, otherwise every {} and *.{} file below the directory)",
            a.dir.display(),
            input.logs.len(),
            g::OPLOG_FILE,
            g::OPLOG_EXT
        );
        for w in &input.warnings {
            msg.push_str("\n  ");
            msg.push_str(w);
        }
        bail!(msg);
    }
    // Every second of a trial is in exactly one operator (extract.rs); a trial that does
    // not tile is a bug in the extraction, and the analysis stops rather than report it.
    for t in &trials {
        t.check_tiling().map_err(|e| {
            anyhow::anyhow!(
                "{} / {} trial {}: operators do not add up to the trial time: {e}",
                t.participant,
                t.method,
                t.trial
            )
        })?;
    }
    let mut warnings = input.warnings.clone();
    let mut seen = std::collections::BTreeSet::new();
    for t in &trials {
        if !seen.insert((&t.participant, &t.method, t.trial)) {
            warnings.push(format!(
                "{} / {} has trial {} more than once; its operators are added up as one trial",
                t.participant, t.method, t.trial
            ));
        }
    }
    let rows = study::tally_trials(&trials);
    let analysis = g::aggregate_with(
        &rows,
        manifest,
        &[],
        a.stats.baseline.as_deref(),
        a.stats.boot(),
    );
    let mut plots = write_common(&out, &rows, &analysis, a.stats.no_plots)?;
    report::write_csv(
        &out.join("events.csv"),
        &report::event_rows(&trials),
        &report::EVENT_COLUMNS,
    )?;
    report::write_csv(
        &out.join("fitts.csv"),
        &report::fitts_rows(&trials),
        &report::FITTS_COLUMNS,
    )?;
    if !a.stats.no_plots {
        let chosen: Vec<&g::extract::Trial> = match a.trace.as_str() {
            "first" => trials.iter().take(1).collect(),
            "all" => trials.iter().collect(),
            spec => {
                let parts: Vec<&str> = spec.split('/').collect();
                let &[p, m, t] = parts.as_slice() else {
                    bail!("--trace wants first, all or PARTICIPANT/METHOD/TRIAL, got {spec:?}");
                };
                let t: u32 = t
                    .parse()
                    .with_context(|| format!("--trace trial {t:?} is not a number"))?;
                let found: Vec<_> = trials
                    .iter()
                    .filter(|x| x.participant == p && x.method == m && x.trial == t)
                    .collect();
                if found.is_empty() {
                    bail!("--trace {spec}: no such trial in the study");
                }
                found
            }
        };
        for t in chosen {
            for f in plot::trial_plots(&out, t, &cfg)? {
                plots.push(rel(&out, &f));
            }
        }
    }
    let mut cx = ReportContext {
        title: manifest
            .and_then(|m| m.name.clone())
            .unwrap_or_else(|| "GOMS study report".into()),
        warnings: warnings.clone(),
        constants: a.klm.describe(),
        plots,
        ..Default::default()
    };
    cx.inputs.push(format!(
        "study: {} ({} logs, {} trials)",
        a.dir.display(),
        input.logs.len(),
        trials.len()
    ));
    cx.inputs.push(format!(
        "thresholds: smoothing σ {} s, v_on {} m/s, v_off {} m/s, min amplitude {} m, M pause {} s, gap {} s, buttons as {} ({} s window per press)",
        cfg.smooth_sigma_s,
        cfg.v_on,
        cfg.v_off,
        cfg.min_amplitude,
        cfg.m_pause_s,
        cfg.gap_s,
        match cfg.k_mode {
            KMode::K => "K (one per press)",
            KMode::Bb => "B + B (press, release)",
        },
        cfg.k_window_s
    ));
    cx.inputs.push(format!(
        "operator times: every trial's operators (R included) tile it, so each trial's \
         operator seconds sum to its length ({:.2} s over {} trials)",
        trials.iter().map(|t| t.duration()).sum::<f64>(),
        trials.len()
    ));
    cx.inputs.push(format!(
        "bootstrap: {} resamples, seed {}",
        a.stats.bootstrap, a.stats.seed
    ));
    if let Some(m) = manifest {
        for spec in &m.methods {
            if let Some(src) = &spec.klm {
                cx.klm.push(klm_line(&spec.id, src, &a.dir, &a.klm)?);
            }
        }
    }
    if a.sensitivity {
        let (csv, md) = g::sensitivity(&input.logs, &cfg, manifest);
        write(&out.join("sensitivity.csv"), &csv)?;
        cx.appendix = md;
    }
    write(&out.join("report.md"), &report::markdown(&analysis, &cx))?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    say!(
        "{} trials of {} methods -> {}",
        trials.len(),
        analysis.methods.len(),
        out.display()
    );
    Ok(())
}

fn summarize(a: SummarizeArgs) -> Result<()> {
    let (rows, source) = match (&a.tally, &a.events) {
        (Some(t), _) => {
            let rows: Vec<TallyRow> = report::read_csv(t)?;
            study::check_rows(&rows).with_context(|| format!("in {}", t.display()))?;
            (rows, t)
        }
        (None, Some(e)) => {
            let events: Vec<EventRow> = report::read_csv(e)?;
            (
                report::tally_events(&events).with_context(|| format!("in {}", e.display()))?,
                e,
            )
        }
        (None, None) => bail!("give --tally or --events"),
    };
    let analysis = g::aggregate_with(
        &rows,
        None,
        &a.order,
        a.stats.baseline.as_deref(),
        a.stats.boot(),
    );
    let plots = write_common(&a.out, &rows, &analysis, a.stats.no_plots)?;
    let mut klm_lines = Vec::new();
    for spec in &a.klm {
        let (method, src) = spec
            .split_once('=')
            .with_context(|| format!("--klm wants METHOD=SOURCE, got {spec:?}"))?;
        klm_lines.push(klm_line(method, src, Path::new("."), &a.klm_constants)?);
    }
    let cx = ReportContext {
        title: a
            .title
            .clone()
            .unwrap_or_else(|| "GOMS study report".into()),
        inputs: vec![
            format!("data: {}", source.display()),
            format!(
                "bootstrap: {} resamples, seed {}",
                a.stats.bootstrap, a.stats.seed
            ),
        ],
        constants: a.klm_constants.describe(),
        klm: klm_lines,
        plots,
        ..Default::default()
    };
    write(&a.out.join("report.md"), &report::markdown(&analysis, &cx))?;
    say!("{} methods -> {}", analysis.methods.len(), a.out.display());
    Ok(())
}

fn klm_text(src: &str, base: &Path) -> Result<String> {
    if let Some(id) = src.strip_prefix("builtin:") {
        let b = klm::builtin(id).with_context(|| {
            let ids: Vec<&str> = klm::BUILTINS.iter().map(|b| b.id).collect();
            format!("no built-in method {id:?} (have {})", ids.join(", "))
        })?;
        return Ok(b.text.to_owned());
    }
    let p = base.join(src);
    std::fs::read_to_string(&p).with_context(|| format!("cannot read KLM method {}", p.display()))
}

/// The KLM prediction of one method for the report.
fn klm_line(method: &str, src: &str, base: &Path, c: &KlmConstants) -> Result<KlmLine> {
    let text = klm_text(src, base)?;
    let m = klm::parse_method(&text).with_context(|| format!("KLM method {src}"))?;
    Ok(KlmLine {
        method: method.to_owned(),
        source: src.to_owned(),
        prediction: klm::predict(&m.steps, &c.constants()),
    })
}

fn klm_cmd(a: KlmArgs) -> Result<()> {
    let c = a.constants.constants();
    say!("constants: {}", a.constants.describe());
    for src in &a.methods {
        let text = klm_text(src, Path::new("."))?;
        let method = klm::parse_method(&text).with_context(|| format!("in {src}"))?;
        let steps = if a.place_m {
            let (placed, decisions) = klm::place_mentals(&method.steps);
            if a.explain {
                let base: Vec<_> = method.steps.iter().filter(|s| s.op != klm::Op::M).collect();
                for (i, d) in decisions {
                    let what = match d {
                        klm::MDecision::Kept => "kept".to_owned(),
                        klm::MDecision::Deleted(r) => format!("deleted by rule {r}"),
                    };
                    say!(
                        "  M before step {} ({} on line {}): {what}",
                        i + 1,
                        base[i].op.letter(),
                        base[i].line
                    );
                }
            }
            placed
        } else {
            method.steps.clone()
        };
        let p = klm::predict(&steps, &c);
        let name = if method.name.is_empty() {
            src.as_str()
        } else {
            &method.name
        };
        say!("{name}: {:.2} s", p.total);
        for (l, n, t) in p.by_op.iter().filter(|x| x.1 > 0) {
            say!("  {l}: {n} x = {t:.2} s");
        }
        if a.explain {
            say!("  sequence: {}", klm::format_steps(&steps));
        }
    }
    Ok(())
}

fn methods(id: Option<String>) -> Result<()> {
    match id {
        Some(id) => say!(
            "{}",
            klm_text(&format!("builtin:{id}"), Path::new("."))?.trim_end()
        ),
        None => {
            for b in klm::BUILTINS {
                let name = klm::parse_method(b.text)
                    .map(|m| m.name)
                    .unwrap_or_default();
                say!("builtin:{}\t{name}", b.id);
            }
        }
    }
    Ok(())
}

fn study_cmd(s: StudyCmd) -> Result<()> {
    match s {
        StudyCmd::Init {
            dir,
            participants,
            methods,
            trials,
            order,
            baseline,
            name,
        } => {
            let path = dir.join(study::MANIFEST);
            if path.exists() {
                bail!("{} exists; not overwriting a study", path.display());
            }
            if participants == 0 || participants > 10_000 || methods.is_empty() {
                bail!("a study needs 1 to 10000 participants and at least one method");
            }
            let ps: Vec<String> = (1..=participants).map(|i| format!("P{i}")).collect();
            let mut m = Manifest::plan(&ps, &methods, trials.max(1), matches!(order, Order::Latin));
            m.baseline = baseline;
            m.name = name;
            let text = m.to_toml()?;
            Manifest::parse(&text)?;
            std::fs::create_dir_all(dir.join("logs"))
                .with_context(|| format!("cannot create {}", dir.display()))?;
            write(&path, &text)?;
            say!(
                "{} sessions planned in {}",
                m.sessions.len(),
                path.display()
            );
        }
        StudyCmd::Status { dir } => {
            let m = read_manifest(&dir)?;
            say!("participant\tmethod\torder\ttrials\tstatus\tlog");
            for s in &m.sessions {
                let p = dir.join(&s.log);
                let status = if !p.exists() {
                    "pending".to_owned()
                } else {
                    match g::load_log(&p) {
                        Ok(log) => {
                            use crate::goms::extract::OpKind;
                            let trials =
                                g::extract::extract(&log, &ExtractConfig::default(), "", "");
                            let count = |k| trials.iter().map(|t| t.count(k)).sum::<usize>();
                            format!(
                                "recorded ({}/{} trials; P {} K {} M {} at default thresholds)",
                                trials.len(),
                                s.trials,
                                count(OpKind::P),
                                count(OpKind::K),
                                count(OpKind::M)
                            )
                        }
                        Err(e) => format!("bad: {e:#}"),
                    }
                };
                say!(
                    "{}\t{}\t{}\t{}\t{status}\t{}",
                    s.participant,
                    s.method,
                    s.order,
                    s.trials,
                    s.log
                );
            }
        }
        StudyCmd::Simulate { dir, seed, steps } => {
            let m = read_manifest(&dir)?;
            let mut written = 0;
            for (i, s) in m.sessions.iter().enumerate() {
                let path = dir.join(&s.log);
                if path.exists() {
                    continue;
                }
                let mi = m.methods.iter().position(|x| x.id == s.method).unwrap_or(0);
                let header = sculpt_core::oplog::OpLogHeader::new()
                    .with_participant(s.participant.clone())
                    .with_method(s.method.clone())
                    .with_source("synthetic");
                let session_seed = seed.wrapping_mul(1000).wrapping_add(i as u64);
                let mut script =
                    g::synth::Script::new(session_seed, glam::DVec3::new(0.0, 1.2, -0.4), &header);
                let n = (steps + steps * mi / 2).clamp(1, 10_000);
                for trial in 1..=s.trials.min(1000) {
                    script.trial(trial, true);
                    g::synth::random_steps(&mut script, session_seed * 7919 + u64::from(trial), n);
                    script.trial(trial, false);
                }
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent)
                        .with_context(|| format!("cannot create {}", parent.display()))?;
                }
                super::io::write_file(&path, &script.finish().0)?;
                written += 1;
            }
            say!("{written} synthetic sessions written");
        }
        StudyCmd::Next { dir, json } => {
            let m = read_manifest(&dir)?;
            // The first session, in manifest order, with fewer trials recorded than it
            // asks for: the trial `replay --study` and `wandsculpt --study` record next.
            let mut next = None;
            for s in &m.sessions {
                let log = dir.join(&s.log);
                let recorded = match std::fs::read(&log) {
                    Ok(bytes) => sculpt_core::study::trials_in(&bytes)
                        .with_context(|| format!("reading {}", log.display()))?,
                    Err(_) => 0,
                };
                if recorded < s.trials {
                    next = Some((s, recorded + 1, log));
                    break;
                }
            }
            match next {
                Some((s, trial, log)) => {
                    if json {
                        say!(
                            "{}",
                            serde_json::json!({
                                "participant": s.participant,
                                "method": s.method,
                                "order": s.order,
                                "trial": trial,
                                "trials": s.trials,
                                "log": log,
                            })
                        );
                    } else {
                        say!(
                            "{}\t{}\t{}\t{}/{}\t{}",
                            s.participant,
                            s.method,
                            s.order,
                            trial,
                            s.trials,
                            log.display()
                        );
                    }
                }
                None => say!("all sessions recorded"),
            }
        }
    }
    Ok(())
}

fn read_manifest(dir: &Path) -> Result<Manifest> {
    let p = dir.join(study::MANIFEST);
    let text =
        std::fs::read_to_string(&p).with_context(|| format!("cannot read {}", p.display()))?;
    Manifest::parse(&text).with_context(|| format!("in {}", p.display()))
}
