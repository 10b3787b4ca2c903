//! Output files: the CSV event table, Fitts table, tally, the Table 1/2 summary, the
//! statistics and comparisons, and the Markdown report.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use super::extract::{OpKind, Trial};
use super::klm;
use super::stats::Describe;
use super::study::{Analysis, Measure, TallyRow};

/// One row of the event table (`events.csv`), the exact columns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EventRow {
    /// Participant id.
    pub participant: String,
    /// Method id.
    pub method: String,
    /// Trial number.
    pub trial: u32,
    /// Operator letter.
    pub op: String,
    /// Start, seconds.
    pub t_start: f64,
    /// End, seconds.
    pub t_end: f64,
    /// End - start, seconds.
    pub duration: f64,
    /// Fitts amplitude, metres (P only).
    pub amplitude: Option<f64>,
    /// Target width, metres (P with a known target).
    pub width: Option<f64>,
    /// Index of difficulty, bits.
    pub id: Option<f64>,
}

/// The event rows of extracted trials.
pub fn event_rows(trials: &[Trial]) -> Vec<EventRow> {
    trials
        .iter()
        .flat_map(|t| {
            t.ops.iter().map(|o| EventRow {
                participant: t.participant.clone(),
                method: t.method.clone(),
                trial: t.trial,
                op: o.op.letter().to_owned(),
                t_start: o.t_start,
                t_end: o.t_end,
                duration: o.duration(),
                amplitude: o.fitts.map(|f| f.amplitude),
                width: o.fitts.and_then(|f| f.width),
                id: o.fitts.and_then(|f| f.id),
            })
        })
        .collect()
}

/// Tallies an event table (hand-coded or extracted).
pub fn tally_events(rows: &[EventRow]) -> Result<Vec<TallyRow>> {
    let mut out: Vec<TallyRow> = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        let op = OpKind::parse(&r.op).with_context(|| {
            format!(
                "event row {}: unknown operator {:?} (P, K, B, M, H, R)",
                i + 1,
                r.op
            )
        })?;
        let count = if op.counts_as_operation() { 1.0 } else { 0.0 };
        if !(r.duration.is_finite() && r.duration >= 0.0) {
            anyhow::bail!("event row {}: duration must be finite and >= 0", i + 1);
        }
        match out.iter_mut().find(|x| {
            x.participant == r.participant
                && x.method == r.method
                && x.trial == r.trial
                && x.op == op.letter()
        }) {
            Some(x) => {
                x.count += count;
                x.time += r.duration;
            }
            None => out.push(TallyRow {
                participant: r.participant.clone(),
                method: r.method.clone(),
                trial: r.trial,
                op: op.letter().to_owned(),
                count,
                time: r.duration,
            }),
        }
    }
    Ok(out)
}

/// Reads a CSV file of serde rows, naming the file and record on errors.
pub fn read_csv<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<Vec<T>> {
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_csv(file).with_context(|| format!("in {}", path.display()))
}

/// Parses CSV rows (header line first; `#` lines are comments; fields trimmed).
pub fn parse_csv<T: for<'de> Deserialize<'de>>(input: impl std::io::Read) -> Result<Vec<T>> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(input);
    let mut rows = Vec::new();
    for r in rdr.deserialize() {
        rows.push(r.context("bad CSV row")?);
    }
    Ok(rows)
}

/// Writes serde rows as CSV.
pub fn write_csv<T: Serialize>(path: &Path, rows: &[T], header: &[&str]) -> Result<()> {
    // Written atomically (fsio): a failure part-way leaves no partial file.
    let file = fsio::AtomicFile::create(path)?;
    let mut w = csv::Writer::from_writer(file);
    if rows.is_empty() {
        w.write_record(header)?;
    }
    for r in rows {
        w.serialize(r)?;
    }
    let file = w
        .into_inner()
        .map_err(|e| anyhow::anyhow!("cannot write {}: {}", path.display(), e.error()))?;
    file.commit()?;
    Ok(())
}

/// Column names of `events.csv`.
pub const EVENT_COLUMNS: [&str; 10] = [
    "participant",
    "method",
    "trial",
    "op",
    "t_start",
    "t_end",
    "duration",
    "amplitude",
    "width",
    "id",
];
/// Column names of a tally.
pub const TALLY_COLUMNS: [&str; 6] = ["participant", "method", "trial", "op", "count", "time"];

/// One row of `fitts.csv`.
#[derive(Debug, Clone, Serialize)]
pub struct FittsRow {
    /// Participant id.
    pub participant: String,
    /// Method id.
    pub method: String,
    /// Trial number.
    pub trial: u32,
    /// Start of the P, seconds.
    pub t_start: f64,
    /// End of the P, seconds.
    pub t_end: f64,
    /// Movement time, seconds.
    pub mt: f64,
    /// Amplitude, metres.
    pub amplitude_m: f64,
    /// Width, metres.
    pub width_m: Option<f64>,
    /// Euclidean ID, bits.
    pub id_bits: Option<f64>,
    /// Angular amplitude, radians.
    pub amplitude_rad: f64,
    /// Angular width, radians.
    pub width_rad: Option<f64>,
    /// Angular ID, bits.
    pub id_angular_bits: Option<f64>,
}

/// Column names of `fitts.csv`.
pub const FITTS_COLUMNS: [&str; 12] = [
    "participant",
    "method",
    "trial",
    "t_start",
    "t_end",
    "mt",
    "amplitude_m",
    "width_m",
    "id_bits",
    "amplitude_rad",
    "width_rad",
    "id_angular_bits",
];

/// The Fitts rows of extracted trials.
pub fn fitts_rows(trials: &[Trial]) -> Vec<FittsRow> {
    trials
        .iter()
        .flat_map(|t| {
            t.ops.iter().filter_map(|o| {
                let f = o.fitts?;
                Some(FittsRow {
                    participant: t.participant.clone(),
                    method: t.method.clone(),
                    trial: t.trial,
                    t_start: o.t_start,
                    t_end: o.t_end,
                    mt: o.duration(),
                    amplitude_m: f.amplitude,
                    width_m: f.width,
                    id_bits: f.id,
                    amplitude_rad: f.amplitude_rad,
                    width_rad: f.width_rad,
                    id_angular_bits: f.id_angular,
                })
            })
        })
        .collect()
}

fn opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

/// `summary.csv`: the paper's Tables 1 (operations) and 2 (seconds) in one file, means
/// across participants with two decimals.
pub fn summary_csv(a: &Analysis) -> String {
    let mut s = String::from("table,method");
    for op in &a.ops {
        let _ = write!(s, ",{}", op.letter());
    }
    s.push_str(",TOTAL\n");
    for (table, time) in [("operations", false), ("time_s", true)] {
        for m in &a.methods {
            let _ = write!(s, "{table},{}", csv_field(&m.label));
            let d = if time { &m.time } else { &m.count };
            for x in d {
                let _ = write!(s, ",{:.2}", x.mean);
            }
            let total = if time {
                m.total_time.mean
            } else {
                m.total_count.mean
            };
            let _ = writeln!(s, ",{total:.2}");
        }
    }
    s
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// `stats.csv`: every mean with its SD and intervals, at full precision.
pub fn stats_csv(a: &Analysis) -> String {
    let mut s = String::from(
        "method,measure,op,n,mean,sd,ci_t_lo,ci_t_hi,ci_boot_lo,ci_boot_hi,mean_op_duration_s\n",
    );
    let line =
        |s: &mut String, m: &str, measure: &str, op: &str, d: &Describe, dur: Option<f64>| {
            let _ = writeln!(
                s,
                "{},{measure},{op},{},{},{},{},{},{},{},{}",
                csv_field(m),
                d.n,
                d.mean,
                opt(d.sd),
                opt(d.ci_t.map(|c| c.0)),
                opt(d.ci_t.map(|c| c.1)),
                opt(d.ci_boot.map(|c| c.0)),
                opt(d.ci_boot.map(|c| c.1)),
                opt(dur)
            );
        };
    for m in &a.methods {
        for (k, op) in a.ops.iter().enumerate() {
            line(
                &mut s,
                &m.method,
                "operations",
                op.letter(),
                &m.count[k],
                None,
            );
            line(
                &mut s,
                &m.method,
                "time_s",
                op.letter(),
                &m.time[k],
                m.op_duration[k],
            );
        }
        line(
            &mut s,
            &m.method,
            "operations",
            "TOTAL",
            &m.total_count,
            None,
        );
        line(&mut s, &m.method, "time_s", "TOTAL", &m.total_time, None);
    }
    s
}

/// `comparisons.csv`: percentages and paired tests for every ordered pair of methods.
pub fn comparisons_csv(a: &Analysis) -> String {
    let mut s = String::from(
        "method,against,measure,percent,n_pairs,mean_diff,sd_diff,t,df,p,ci_lo,ci_hi\n",
    );
    for c in &a.comparisons {
        let p = c.paired;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            csv_field(&c.method),
            csv_field(&c.against),
            c.measure.name(),
            opt(c.percent),
            p.map(|p| p.n.to_string()).unwrap_or_default(),
            opt(p.map(|p| p.mean_diff)),
            opt(p.and_then(|p| p.sd_diff)),
            opt(p.and_then(|p| p.t)),
            p.map(|p| p.df.to_string()).unwrap_or_default(),
            opt(p.and_then(|p| p.p)),
            opt(p.and_then(|p| p.ci.map(|c| c.0))),
            opt(p.and_then(|p| p.ci.map(|c| c.1))),
        );
    }
    s
}

/// Truncates to two decimals, the paper's way of printing percentages
/// (12.8 / 165.4 = 7.7388 % is printed 7.73 %).
pub fn truncate2(x: f64) -> f64 {
    (x * 100.0 + crate::tolerance::TRUNCATE_EPS).floor() / 100.0
}

/// KLM prediction of a method, shown next to the measured time.
#[derive(Debug, Clone)]
pub struct KlmLine {
    /// Method id.
    pub method: String,
    /// Where the KLM method came from.
    pub source: String,
    /// The prediction.
    pub prediction: klm::Prediction,
}

/// Everything the Markdown report shows besides the analysis.
#[derive(Debug, Clone, Default)]
pub struct ReportContext {
    /// Study title.
    pub title: String,
    /// Lines describing the inputs and settings.
    pub inputs: Vec<String>,
    /// Warnings (missing logs, truncated tails, ...).
    pub warnings: Vec<String>,
    /// KLM predictions.
    pub klm: Vec<KlmLine>,
    /// KLM constants used, as text.
    pub constants: String,
    /// Plot files, relative to the report.
    pub plots: Vec<String>,
    /// Extra Markdown appended (the sensitivity table).
    pub appendix: String,
}

fn ms(d: &Describe) -> String {
    match d.sd {
        Some(sd) => format!("{:.2} ± {:.2}", d.mean, sd),
        None => format!("{:.2}", d.mean),
    }
}

fn ci(c: Option<(f64, f64)>) -> String {
    c.map(|(a, b)| format!("[{a:.2}, {b:.2}]"))
        .unwrap_or_else(|| "n/a".into())
}

/// The Markdown report.
pub fn markdown(a: &Analysis, cx: &ReportContext) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# {}\n",
        if cx.title.is_empty() {
            "GOMS study report"
        } else {
            &cx.title
        }
    );
    for l in &cx.inputs {
        let _ = writeln!(s, "- {l}");
    }
    s.push('\n');
    if !cx.warnings.is_empty() {
        s.push_str("## Warnings\n\n");
        for w in &cx.warnings {
            let _ = writeln!(s, "- {w}");
        }
        s.push('\n');
    }
    if a.methods.is_empty() {
        s.push_str("The study has no data yet: no trials were found.\n");
        return s;
    }
    let head = |s: &mut String| {
        let _ = write!(s, "| method | n |");
        for op in &a.ops {
            let _ = write!(s, " {} |", op.letter());
        }
        s.push_str(" TOTAL |\n|---|---|");
        for _ in &a.ops {
            s.push_str("---|");
        }
        s.push_str("---|\n");
    };
    for (title, time) in [
        (
            "Table 1: average operation counts (mean ± SD over participants)",
            false,
        ),
        ("Table 2: average execution time, seconds (mean ± SD)", true),
    ] {
        let _ = writeln!(s, "## {title}\n");
        head(&mut s);
        for m in &a.methods {
            let _ = write!(s, "| {} | {} |", m.label, m.participants.len());
            for d in if time { &m.time } else { &m.count } {
                let _ = write!(s, " {} |", ms(d));
            }
            let _ = writeln!(
                s,
                " {} |",
                ms(if time { &m.total_time } else { &m.total_count })
            );
        }
        s.push('\n');
    }
    s.push_str("## 95 % confidence intervals of the totals\n\n");
    s.push_str("| method | operations, t | operations, bootstrap | seconds, t | seconds, bootstrap |\n|---|---|---|---|---|\n");
    for m in &a.methods {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            m.label,
            ci(m.total_count.ci_t),
            ci(m.total_count.ci_boot),
            ci(m.total_time.ci_t),
            ci(m.total_time.ci_boot)
        );
    }
    s.push_str("\n## Measured seconds per operator\n\n");
    let _ = writeln!(
        s,
        "Pooled Σ time / Σ count per method, next to the KLM constants ({}).\n",
        cx.constants
    );
    let _ = write!(s, "| method |");
    for op in &a.ops {
        let _ = write!(s, " {} |", op.letter());
    }
    s.push_str("\n|---|");
    for _ in &a.ops {
        s.push_str("---|");
    }
    s.push('\n');
    for m in &a.methods {
        let _ = write!(s, "| {} |", m.label);
        for d in &m.op_duration {
            let _ = write!(
                s,
                " {} |",
                d.map(|x| format!("{x:.3}")).unwrap_or_else(|| "–".into())
            );
        }
        s.push('\n');
    }
    s.push_str("\n## Percentages\n\n");
    s.push_str("Mean total of the row method as a percentage of the column method's (ratio of the means, as the paper computes it; the paper prints them truncated to two decimals, shown in brackets).\n\n");
    for measure in [Measure::Operations, Measure::Time] {
        let _ = writeln!(
            s,
            "**{}**\n",
            if measure == Measure::Operations {
                "Operations"
            } else {
                "Time"
            }
        );
        let _ = write!(s, "| method |");
        for m in &a.methods {
            let _ = write!(s, " vs {} |", m.label);
        }
        s.push_str("\n|---|");
        for _ in &a.methods {
            s.push_str("---|");
        }
        s.push('\n');
        for row in &a.methods {
            let _ = write!(s, "| {} |", row.label);
            for col in &a.methods {
                let c = a.comparisons.iter().find(|c| {
                    c.method == row.method && c.against == col.method && c.measure == measure
                });
                let cell = c
                    .and_then(|c| c.percent)
                    .map(|p| format!("{p:.2} % ({:.2})", truncate2(p)))
                    .unwrap_or_else(|| "–".into());
                let _ = write!(s, " {cell} |");
            }
            s.push('\n');
        }
        s.push('\n');
    }
    s.push_str("## Paired comparisons (paired t over shared participants)\n\n");
    s.push_str("| method | against | measure | pairs | mean diff | 95 % CI | t | df | p |\n|---|---|---|---|---|---|---|---|---|\n");
    for c in a.comparisons.iter().filter(|c| match &a.baseline {
        Some(b) => &c.against == b,
        None => c.method < c.against,
    }) {
        if let Some(p) = c.paired {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {:.3} | {} | {} | {} | {} |",
                c.method,
                c.against,
                c.measure.name(),
                p.n,
                p.mean_diff,
                ci(p.ci),
                p.t.map(|t| format!("{t:.3}"))
                    .unwrap_or_else(|| "n/a".into()),
                p.df,
                p.p.map(|p| format!("{p:.4}"))
                    .unwrap_or_else(|| "n/a".into()),
            );
        }
    }
    if !cx.klm.is_empty() {
        let _ = writeln!(s, "\n## KLM predictions ({})\n", cx.constants);
        s.push_str("| method | KLM method | predicted s | measured mean s | operators |\n|---|---|---|---|---|\n");
        for k in &cx.klm {
            let measured = a
                .methods
                .iter()
                .find(|m| m.method == k.method)
                .map(|m| format!("{:.2}", m.total_time.mean))
                .unwrap_or_else(|| "–".into());
            let ops: Vec<String> = k
                .prediction
                .by_op
                .iter()
                .filter(|x| x.1 > 0)
                .map(|x| format!("{} {}", x.1, x.0))
                .collect();
            let _ = writeln!(
                s,
                "| {} | {} | {:.2} | {} | {} |",
                k.method,
                k.source,
                k.prediction.total,
                measured,
                ops.join(", ")
            );
        }
    }
    if !cx.plots.is_empty() {
        s.push_str("\n## Plots\n\n");
        for p in cx.plots.iter().filter(|p| p.ends_with(".svg")) {
            let _ = writeln!(s, "![{p}]({p})");
        }
    }
    s.push_str(&cx.appendix);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn tally_and_event_parsers_never_panic(body in "[a-zA-Z0-9,.#\"\n -]{0,200}") {
            let tally = format!("participant,method,trial,op,count,time\n{body}");
            if let Ok(rows) = parse_csv::<TallyRow>(tally.as_bytes()) {
                let _ = crate::goms::study::check_rows(&rows);
            }
            let events = format!("{}\n{body}", EVENT_COLUMNS.join(","));
            if let Ok(rows) = parse_csv::<EventRow>(events.as_bytes()) {
                let _ = tally_events(&rows);
            }
        }

        #[test]
        fn tally_rows_round_trip(rows in proptest::collection::vec(
            ("[a-z]{1,5}", "[a-z]{1,5}", 0u32..9, 0usize..5, 0.0f64..100.0, 0.0f64..100.0), 0..20)
        ) {
            let rows: Vec<TallyRow> = rows
                .into_iter()
                .map(|(participant, method, trial, op, count, time)| TallyRow {
                    participant,
                    method,
                    trial,
                    op: OpKind::ALL[op].letter().to_owned(),
                    count,
                    time,
                })
                .collect();
            // The writer adds the header with the first row.
            let mut w = csv::Writer::from_writer(Vec::new());
            for r in &rows {
                w.serialize(r).unwrap();
            }
            let mut text = String::from_utf8(w.into_inner().unwrap()).unwrap();
            if rows.is_empty() {
                text = TALLY_COLUMNS.join(",");
            }
            let back: Vec<TallyRow> = parse_csv(text.as_bytes()).unwrap();
            prop_assert_eq!(back, rows);
        }
    }

    #[test]
    fn truncation_matches_the_papers_printing() {
        assert_eq!(truncate2(100.0 * 12.8 / 165.4), 7.73);
        assert_eq!(truncate2(100.0 * 12.01 / 30.53), 39.33);
        assert_eq!(truncate2(12.5), 12.5);
    }

    #[test]
    fn event_table_tallies() {
        let r = |op: &str, d: f64| EventRow {
            participant: "p".into(),
            method: "m".into(),
            trial: 1,
            op: op.into(),
            t_start: 0.0,
            t_end: d,
            duration: d,
            amplitude: None,
            width: None,
            id: None,
        };
        let t = tally_events(&[r("P", 1.0), r("P", 0.5), r("K", 0.2)]).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!((t[0].count, t[0].time), (2.0, 1.5));
        assert!(tally_events(&[r("Z", 1.0)]).is_err());
        assert!(tally_events(&[r("P", -1.0)]).is_err());
    }
}
