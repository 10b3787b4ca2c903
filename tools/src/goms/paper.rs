//! The paper's Tables 1 and 2 (Kwon, Kim and Chai 2006, section 6) next to a KLM
//! prediction and measured sessions (`sculpt-tools goms paper`).
//!
//! The paper measured five skilled users and prints, per method, the mean number of
//! operators (Table 1) and their mean seconds (Table 2) for P (pointing), K (key or
//! button down) and M (mental preparation). [`compare`] lays a KLM prediction of a
//! method and the mean over measured trials beside one of its rows, operator by
//! operator. It only does arithmetic: what the comparison means depends on what the
//! trials are (see `docs/goms.md`: scripted sessions have no thinking pauses).

use sculpt_core::oplog::{EventKind, OpLog};

use super::extract::{OpKind, Trial};
use super::klm::Prediction;

/// The header `source`s of the programs that cut a plain session's log into one
/// segment per interaction mode (`sculpt_core::oplog::ModeSegments`): the display
/// server and `replay`.
pub const SEGMENTING_SOURCES: [&str; 2] = ["wandsculpt", "replay"];

/// Whether `log` is one plain session of `wandsculpt` or `replay` (not a study's): its
/// source is one of [`SEGMENTING_SOURCES`] and its header names no participant (a
/// study's logs always name theirs). Its `trial_start`/`trial_end` marks are then the
/// mode segments, not trials.
pub fn is_plain_session(log: &OpLog) -> bool {
    log.header.participant.is_none()
        && log
            .header
            .source
            .as_deref()
            .is_some_and(|s| SEGMENTING_SOURCES.contains(&s))
}

/// One plain session as one trial of the paper's task: the log without its mode
/// segment marks, so that it extracts as a single trial from its first event to its
/// last (the header's method, the start mode). The paper times the whole task, its
/// mode switches included (their presses are among its K), so a switch does not cut
/// the trial; `goms analyze` keeps the segments apart instead, each under its mode.
/// Other logs come back as they are.
pub fn whole_session(log: &OpLog) -> OpLog {
    let mut out = log.clone();
    if is_plain_session(log) {
        out.events.retain(|e| {
            !matches!(
                e.kind,
                EventKind::TrialStart { .. } | EventKind::TrialEnd { .. }
            )
        });
    }
    out
}

/// One row of the paper's Tables 1 and 2: a method's mean operator counts and seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperRow {
    /// The method as the paper names it.
    pub method: &'static str,
    /// Table 1: mean P, K, M counts.
    pub count: [f64; 3],
    /// Table 1's printed TOTAL.
    pub count_total: f64,
    /// Table 2: mean P, K, M seconds.
    pub seconds: [f64; 3],
    /// Table 2's printed TOTAL.
    pub seconds_total: f64,
}

/// The paper's operators, in its column order.
pub const PAPER_OPS: [OpKind; 3] = [OpKind::P, OpKind::K, OpKind::M];

/// Tables 1 and 2 as printed (the same cells as `tools/tests/data/paper-tables-1-2.csv`).
pub const TABLES: [PaperRow; 3] = [
    PaperRow {
        method: "Multi-surface modeling",
        count: [69.8, 82.2, 13.4],
        count_total: 165.4,
        seconds: [50.03, 37.65, 12.94],
        seconds_total: 100.62,
    },
    PaperRow {
        method: "Trimming modeling",
        count: [14.6, 16.0, 5.0],
        count_total: 35.6,
        seconds: [10.87, 10.68, 8.98],
        seconds_total: 30.53,
    },
    PaperRow {
        method: "Multi-resolution sculpting",
        count: [3.0, 7.4, 2.4],
        count_total: 12.8,
        seconds: [3.73, 4.58, 3.7],
        seconds_total: 12.01,
    },
];

/// The row of a method id: `multi-surface`, `trimming` or `multires` (the paper's names
/// work too).
pub fn row(id: &str) -> Option<&'static PaperRow> {
    let id = id.to_ascii_lowercase();
    TABLES.iter().find(|r| {
        let name = r.method.to_ascii_lowercase();
        name == id
            || (id.starts_with("multi-surface") && name.starts_with("multi-surface"))
            || (id.starts_with("trimming") && name.starts_with("trimming"))
            || (id.starts_with("multires") && name.starts_with("multi-resolution"))
    })
}

/// One line of the comparison: an operator kind (or the total).
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// `P`, `K`, `B`, `M`, `R` or `total`.
    pub op: String,
    /// KLM count and seconds.
    pub klm: (f64, f64),
    /// Mean count and seconds over the measured trials.
    pub measured: (f64, f64),
    /// The paper's count and seconds (`None` for operators it does not count).
    pub paper: Option<(f64, f64)>,
}

/// The comparison of one method.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// The paper's row.
    pub paper: PaperRow,
    /// Trials measured.
    pub trials: usize,
    /// P, K, B, M, R, then the total (operations without R; seconds with it, the trial
    /// length).
    pub lines: Vec<Line>,
}

/// Lays `prediction` and the mean over `trials` beside the paper's `row`. An operator
/// kind missing from a trial counts 0 there; the measured total seconds is the mean
/// trial length (R included), its total count the operators other than R.
pub fn compare(row: &PaperRow, prediction: &Prediction, trials: &[Trial]) -> Comparison {
    let n = trials.len().max(1) as f64;
    let kinds = [OpKind::P, OpKind::K, OpKind::B, OpKind::M, OpKind::R];
    let mut lines: Vec<Line> = kinds
        .iter()
        .map(|&k| {
            let klm = prediction
                .by_op
                .iter()
                .find(|(l, _, _)| *l == k.letter())
                .map_or((0.0, 0.0), |&(_, c, s)| (c as f64, s));
            // R has seconds but no count, as in the harness's Table 1.
            let count: usize = if k.counts_as_operation() {
                trials.iter().map(|t| t.count(k)).sum()
            } else {
                0
            };
            let secs: f64 = trials
                .iter()
                .flat_map(|t| t.ops.iter().filter(|o| o.op == k))
                .map(|o| o.duration())
                .fold(0.0, |a, b| a + b);
            let paper = PAPER_OPS
                .iter()
                .position(|&p| p == k)
                .map(|i| (row.count[i], row.seconds[i]));
            Line {
                op: k.letter().to_owned(),
                klm,
                measured: (count as f64 / n, secs / n),
                paper,
            }
        })
        .collect();
    let total = |f: &dyn Fn(&Line) -> (f64, f64)| {
        lines
            .iter()
            .map(|l| {
                let (c, s) = f(l);
                let counted = OpKind::parse(&l.op).is_some_and(OpKind::counts_as_operation);
                (if counted { c } else { 0.0 }, s)
            })
            .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
    };
    let klm = total(&|l| l.klm);
    let measured = (
        total(&|l| l.measured).0,
        trials.iter().map(Trial::duration).fold(0.0, |a, b| a + b) / n,
    );
    lines.push(Line {
        op: "total".into(),
        klm,
        measured,
        paper: Some((row.count_total, row.seconds_total)),
    });
    Comparison {
        paper: *row,
        trials: trials.len(),
        lines,
    }
}

fn cell(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |v| format!("{v:.2}"))
}

fn percent(a: f64, b: Option<f64>) -> String {
    match b {
        Some(b) if b > 0.0 => format!("{:.0} %", 100.0 * a / b),
        _ => "-".into(),
    }
}

impl Comparison {
    /// The comparison as a Markdown table with the notes that say what it is.
    pub fn markdown(&self, klm_source: &str, sources: &str) -> String {
        let mut s = format!(
            "# {}: KLM, measured and the paper\n\n\
             Paper: Kwon, Kim and Chai (2006), Tables 1 and 2, means over five skilled \
             users. KLM: `{klm_source}`. Measured: mean over {} trials ({sources}).\n\n\
             | operator | KLM count | measured count | paper count | KLM s | measured s | paper s | measured / paper s |\n\
             |---|---|---|---|---|---|---|---|\n",
            self.paper.method, self.trials
        );
        for l in &self.lines {
            s.push_str(&format!(
                "| {} | {:.2} | {:.2} | {} | {:.2} | {:.2} | {} | {} |\n",
                l.op,
                l.klm.0,
                l.measured.0,
                cell(l.paper.map(|p| p.0)),
                l.klm.1,
                l.measured.1,
                cell(l.paper.map(|p| p.1)),
                percent(l.measured.1, l.paper.map(|p| p.1)),
            ));
        }
        s.push_str(
            "\nThe paper counts P, K and M only: B (button edges, `--k-mode bb`) and R \
             (waiting, holding still: time no operator accounts for) have no column there. \
             The totals count operators without R; the measured total seconds is the mean \
             trial length, R included.\n",
        );
        let m = self.lines.iter().find(|l| l.op == "M");
        if m.is_some_and(|m| m.measured.0 == 0.0) {
            s.push_str(
                "\nNo measured M: these trials have no still pause of `--m-pause` seconds or \
                 more. Scripted sessions (the recorded sessions of `tests/data/sessions`, \
                 made by the tracker simulator; `goms study simulate`) have no thinking \
                 pauses and no menu, so they time the pipeline, not people: they do not \
                 reproduce the paper's measured row.\n",
            );
        }
        s
    }

    /// The comparison as CSV: `op,klm_count,measured_count,paper_count,klm_s,measured_s,paper_s`,
    /// full precision, paper cells empty where the paper has none.
    pub fn csv(&self) -> String {
        let mut s = "op,klm_count,measured_count,paper_count,klm_s,measured_s,paper_s\n".to_owned();
        let opt = |v: Option<f64>| v.map_or_else(String::new, |v| v.to_string());
        for l in &self.lines {
            s.push_str(&format!(
                "{},{},{},{},{},{},{}\n",
                l.op,
                l.klm.0,
                l.measured.0,
                opt(l.paper.map(|p| p.0)),
                l.klm.1,
                l.measured.1,
                opt(l.paper.map(|p| p.1)),
            ));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::DECIMAL_SUM_EPS;
    use sculpt_core::assert_near;

    /// The tables as printed: each TOTAL is the sum of its row (to the paper's two
    /// decimals).
    #[test]
    fn the_tables_totals_are_their_rows_sums() {
        for r in &TABLES {
            assert_near!(r.count.iter().sum::<f64>(), r.count_total, DECIMAL_SUM_EPS);
            assert_near!(
                r.seconds.iter().sum::<f64>(),
                r.seconds_total,
                DECIMAL_SUM_EPS
            );
        }
        assert_eq!(row("multires").unwrap().count_total, 12.8);
        assert_eq!(row("Trimming modeling").unwrap().seconds_total, 30.53);
        assert!(row("nope").is_none());
    }

    /// Regression (issue 19, after `replay` began to cut its log at each mode switch):
    /// `goms paper` took every mode segment of a recorded session as a trial of the
    /// paper's task, so a session that switched mode counted as several short trials
    /// and the means over trials shrank. A plain session is one trial, its segments
    /// joined; a study's log (it names its participant) keeps its trials.
    #[test]
    fn regression_a_plain_sessions_mode_segments_are_one_trial_of_the_task() {
        use crate::goms::extract::{ExtractConfig, extract};
        let body = "{\"t\":0,\"ev\":\"trial_start\",\"trial\":1,\"method\":\"carve\"}\n\
                    {\"t\":0,\"ev\":\"pose\",\"p\":[0,1,0],\"q\":[0,0,0,1]}\n\
                    {\"t\":0.3,\"ev\":\"button\",\"id\":1,\"down\":true}\n\
                    {\"t\":0.3,\"ev\":\"trial_end\",\"trial\":1}\n\
                    {\"t\":0.3,\"ev\":\"trial_start\",\"trial\":1,\"method\":\"emboss\"}\n\
                    {\"t\":0.3,\"ev\":\"mode\",\"mode\":\"emboss\"}\n\
                    {\"t\":0.4,\"ev\":\"button\",\"id\":1,\"down\":false}\n\
                    {\"t\":2,\"ev\":\"pose\",\"p\":[0,1,0],\"q\":[0,0,0,1]}\n";
        let log = |header: &str| {
            sculpt_core::oplog::decode(&format!(
                "{{\"format\":\"wandsculpt-oplog\",\"version\":1,\"method\":\"carve\",{header}}}\n{body}"
            ))
            .unwrap()
        };
        let cfg = ExtractConfig::default();
        let plain = log("\"source\":\"replay\"");
        assert!(is_plain_session(&plain));
        assert_eq!(extract(&plain, &cfg, "s", "m").len(), 2, "two segments");
        let whole = extract(&whole_session(&plain), &cfg, "s", "m");
        assert_eq!(whole.len(), 1);
        assert_eq!((whole[0].t0, whole[0].t1), (0.0, 2.0));
        assert_eq!(whole[0].method, "carve");
        assert_eq!(whole[0].count(OpKind::K), 1);
        // A study's log, or one no segmenting program wrote, keeps its trials.
        for header in [
            "\"source\":\"replay\",\"participant\":\"P1\"",
            "\"source\":\"synthetic\"",
        ] {
            let l = log(header);
            assert!(!is_plain_session(&l), "{header}");
            assert_eq!(whole_session(&l), l, "{header}");
        }
    }
}
