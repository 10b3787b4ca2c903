//! Studies: the manifest, operator tallies, and aggregation into the paper's tables.
//!
//! A study is participants x methods x trials. Every input (operator event logs, a
//! hand-coded event table, or a tally of counts and times) becomes [`TallyRow`]s: one
//! per participant, method, trial and operator, with a count and a time in seconds.
//! [`aggregate`] averages each participant's trials, then describes each method across
//! participants (mean, SD, 95 % t and bootstrap intervals), pairs methods over the
//! participants they share, and expresses totals as percentages of each other method
//! (ratio of the means, as in the paper: 12.8 / 165.4 operations = 7.74 %).

use std::collections::BTreeMap;

use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

use super::extract::{OpKind, Trial};
use super::stats::{self, Bootstrap, Describe, Paired};

pub use sculpt_core::study::{MANIFEST, Manifest};

/// Counts and time of one operator kind in one trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TallyRow {
    /// Participant id.
    pub participant: String,
    /// Method id.
    pub method: String,
    /// Trial number.
    pub trial: u32,
    /// Operator letter.
    pub op: String,
    /// Number of operators (may be fractional when the data are already means).
    pub count: f64,
    /// Seconds spent in them.
    pub time: f64,
}

/// Tallies extracted trials (one row per trial and operator kind found).
pub fn tally_trials(trials: &[Trial]) -> Vec<TallyRow> {
    let mut rows = Vec::new();
    for t in trials {
        for op in OpKind::ALL {
            let ops: Vec<_> = t.ops.iter().filter(|o| o.op == op).collect();
            if ops.is_empty() {
                continue;
            }
            rows.push(TallyRow {
                participant: t.participant.clone(),
                method: t.method.clone(),
                trial: t.trial,
                op: op.letter().to_owned(),
                count: if op.counts_as_operation() {
                    ops.len() as f64
                } else {
                    0.0
                },
                time: ops.iter().map(|o| o.duration()).sum(),
            });
        }
        if t.ops.is_empty() {
            // Keep the trial in the study with zero operators.
            rows.push(TallyRow {
                participant: t.participant.clone(),
                method: t.method.clone(),
                trial: t.trial,
                op: OpKind::P.letter().to_owned(),
                count: 0.0,
                time: 0.0,
            });
        }
    }
    rows
}

/// One method's description across participants.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodSummary {
    /// Method id.
    pub method: String,
    /// Label.
    pub label: String,
    /// Participants.
    pub participants: Vec<String>,
    /// Trials over all participants.
    pub trials: usize,
    /// Per operator kind (in [`Analysis::ops`] order): counts across participants.
    pub count: Vec<Describe>,
    /// Per operator kind: seconds across participants.
    pub time: Vec<Describe>,
    /// Total operators.
    pub total_count: Describe,
    /// Total seconds.
    pub total_time: Describe,
    /// Per participant `(id, total count, total time)`, trial means.
    pub per_participant: Vec<(String, f64, f64)>,
    /// Measured mean seconds per operator, pooled (Σ time / Σ count) per kind.
    pub op_duration: Vec<Option<f64>>,
}

/// What a comparison measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// Total operators.
    Operations,
    /// Total seconds.
    Time,
}

impl Measure {
    /// Name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Measure::Operations => "operations",
            Measure::Time => "time_s",
        }
    }
}

/// A method against another.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Method id.
    pub method: String,
    /// Reference method id.
    pub against: String,
    /// What is compared.
    pub measure: Measure,
    /// 100 x mean(method) / mean(against), when the reference mean is positive.
    pub percent: Option<f64>,
    /// Paired t comparison over shared participants, when there are any.
    pub paired: Option<Paired>,
}

/// The whole aggregated study.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Analysis {
    /// Operator kinds present, display order.
    pub ops: Vec<OpKind>,
    /// Methods in table order.
    pub methods: Vec<MethodSummary>,
    /// Every ordered pair of methods, both measures.
    pub comparisons: Vec<Comparison>,
    /// The baseline method id, when set.
    pub baseline: Option<String>,
}

/// One participant's trials of one method, per operator kind: trial means and sums
/// of `(count, seconds)`.
struct ParticipantCell {
    participant: String,
    mean: Vec<(f64, f64)>,
    trials: usize,
    sum: Vec<(f64, f64)>,
}

/// Checks tally rows and returns their operator kinds.
pub fn check_rows(rows: &[TallyRow]) -> Result<()> {
    for (i, r) in rows.iter().enumerate() {
        if OpKind::parse(&r.op).is_none() {
            bail!(
                "tally row {}: unknown operator {:?} (P, K, B, M, H)",
                i + 1,
                r.op
            );
        }
        if !(r.count.is_finite() && r.count >= 0.0 && r.time.is_finite() && r.time >= 0.0) {
            bail!(
                "tally row {}: count and time must be finite and >= 0",
                i + 1
            );
        }
    }
    Ok(())
}

/// Aggregates tallies. `order` lists method ids first in table order (others follow in
/// order of appearance); `label` names them.
pub fn aggregate(
    rows: &[TallyRow],
    order: &[String],
    label: &dyn Fn(&str) -> String,
    baseline: Option<&str>,
    boot: Bootstrap,
) -> Analysis {
    let ops: Vec<OpKind> = OpKind::ALL
        .into_iter()
        .filter(|k| rows.iter().any(|r| OpKind::parse(&r.op) == Some(*k)))
        .collect();
    let mut methods: Vec<String> = order
        .iter()
        .filter(|m| rows.iter().any(|r| &r.method == *m))
        .cloned()
        .collect();
    for r in rows {
        if !methods.contains(&r.method) {
            methods.push(r.method.clone());
        }
    }
    // (method, participant) -> trial -> op -> (count, time)
    type Cell = BTreeMap<u32, BTreeMap<OpKind, (f64, f64)>>;
    let mut cells: BTreeMap<(String, String), Cell> = BTreeMap::new();
    for r in rows {
        let Some(op) = OpKind::parse(&r.op) else {
            continue;
        };
        let e = cells
            .entry((r.method.clone(), r.participant.clone()))
            .or_default()
            .entry(r.trial)
            .or_default()
            .entry(op)
            .or_insert((0.0, 0.0));
        e.0 += r.count;
        e.1 += r.time;
    }
    // Per (method, participant): trial means per op (missing = 0).
    let means = |m: &str| -> Vec<ParticipantCell> {
        cells
            .iter()
            .filter(|((mm, _), _)| mm == m)
            .map(|((_, p), trials)| {
                let n = trials.len() as f64;
                let per_op: Vec<(f64, f64)> = ops
                    .iter()
                    .map(|k| {
                        let (c, t) = trials.values().fold((0.0, 0.0), |acc, ops| {
                            let v = ops.get(k).copied().unwrap_or((0.0, 0.0));
                            (acc.0 + v.0, acc.1 + v.1)
                        });
                        (c / n, t / n)
                    })
                    .collect();
                let sums: Vec<(f64, f64)> = ops
                    .iter()
                    .map(|k| {
                        trials.values().fold((0.0, 0.0), |acc, ops| {
                            let v = ops.get(k).copied().unwrap_or((0.0, 0.0));
                            (acc.0 + v.0, acc.1 + v.1)
                        })
                    })
                    .collect();
                ParticipantCell {
                    participant: p.clone(),
                    mean: per_op,
                    trials: trials.len(),
                    sum: sums,
                }
            })
            .collect()
    };
    let empty = Describe {
        n: 0,
        mean: 0.0,
        sd: None,
        ci_t: None,
        ci_boot: None,
    };
    let d = |xs: &[f64]| stats::describe(xs, boot).unwrap_or(empty);
    let mut summaries = Vec::new();
    for m in &methods {
        let parts = means(m);
        let col = |k: usize, time: bool| -> Vec<f64> {
            parts
                .iter()
                .map(|p| if time { p.mean[k].1 } else { p.mean[k].0 })
                .collect()
        };
        let totals: Vec<(f64, f64)> = parts
            .iter()
            .map(|p| {
                p.mean
                    .iter()
                    .fold((0.0, 0.0), |acc, v| (acc.0 + v.0, acc.1 + v.1))
            })
            .collect();
        let tc: Vec<f64> = totals.iter().map(|t| t.0).collect();
        let tt: Vec<f64> = totals.iter().map(|t| t.1).collect();
        summaries.push(MethodSummary {
            method: m.clone(),
            label: label(m),
            participants: parts.iter().map(|p| p.participant.clone()).collect(),
            trials: parts.iter().map(|p| p.trials).sum(),
            count: (0..ops.len()).map(|k| d(&col(k, false))).collect(),
            time: (0..ops.len()).map(|k| d(&col(k, true))).collect(),
            total_count: d(&tc),
            total_time: d(&tt),
            per_participant: parts
                .iter()
                .zip(&totals)
                .map(|(p, t)| (p.participant.clone(), t.0, t.1))
                .collect(),
            op_duration: (0..ops.len())
                .map(|k| {
                    let (c, t) = parts.iter().fold((0.0, 0.0), |acc, p| {
                        (acc.0 + p.sum[k].0, acc.1 + p.sum[k].1)
                    });
                    (c > 0.0).then(|| t / c)
                })
                .collect(),
        });
    }
    let mut comparisons = Vec::new();
    for a in &summaries {
        for b in &summaries {
            if a.method == b.method {
                continue;
            }
            for measure in [Measure::Operations, Measure::Time] {
                let pick = |s: &MethodSummary| match measure {
                    Measure::Operations => s.total_count.mean,
                    Measure::Time => s.total_time.mean,
                };
                let percent = (pick(b) > 0.0 && a.total_count.n > 0)
                    .then(|| 100.0 * pick(a) / pick(b))
                    .filter(|p| p.is_finite());
                let value = |s: &MethodSummary, p: &str| {
                    s.per_participant
                        .iter()
                        .find(|x| x.0 == p)
                        .map(|x| match measure {
                            Measure::Operations => x.1,
                            Measure::Time => x.2,
                        })
                };
                let (xa, xb): (Vec<f64>, Vec<f64>) = a
                    .per_participant
                    .iter()
                    .filter_map(|(p, _, _)| Some((value(a, p)?, value(b, p)?)))
                    .unzip();
                comparisons.push(Comparison {
                    method: a.method.clone(),
                    against: b.method.clone(),
                    measure,
                    percent,
                    paired: stats::paired(&xa, &xb),
                });
            }
        }
    }
    Analysis {
        ops,
        methods: summaries,
        comparisons,
        baseline: baseline.map(str::to_owned),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::EXACT_EPS;
    use std::collections::BTreeSet;

    fn row(p: &str, m: &str, trial: u32, op: &str, count: f64, time: f64) -> TallyRow {
        TallyRow {
            participant: p.into(),
            method: m.into(),
            trial,
            op: op.into(),
            count,
            time,
        }
    }

    #[test]
    fn trial_means_then_participant_stats_with_missing_zeros() {
        let rows = vec![
            row("p1", "a", 1, "P", 2.0, 2.0),
            row("p1", "a", 2, "P", 4.0, 4.0),
            row("p1", "a", 1, "M", 1.0, 1.5),
            // p1 trial 2 has no M: counts as 0, so p1's M mean is 0.5.
            row("p2", "a", 1, "P", 5.0, 6.0),
            row("p1", "b", 1, "P", 1.0, 1.0),
            row("p2", "b", 1, "P", 2.0, 3.0),
        ];
        let a = aggregate(
            &rows,
            &[],
            &|s| s.to_uppercase(),
            None,
            Bootstrap::default(),
        );
        assert_eq!(a.ops, vec![OpKind::P, OpKind::M]);
        let ma = &a.methods[0];
        assert_eq!((ma.label.as_str(), ma.trials), ("A", 3));
        // p1: P mean 3, M mean 0.5; p2: P 5, M 0.
        assert_near!(ma.count[0].mean, 4.0, EXACT_EPS);
        assert_near!(ma.count[1].mean, 0.25, EXACT_EPS);
        assert_near!(ma.total_count.mean, (3.5 + 5.0) / 2.0, EXACT_EPS);
        // Pooled P duration: (2 + 4 + 6) / (2 + 4 + 5).
        assert_near!(ma.op_duration[0].unwrap(), 12.0 / 11.0, EXACT_EPS);
        let c = a
            .comparisons
            .iter()
            .find(|c| c.method == "b" && c.against == "a" && c.measure == Measure::Operations)
            .unwrap();
        assert_near!(c.percent.unwrap(), 100.0 * 1.5 / 4.25, EXACT_EPS);
        assert_eq!(c.paired.unwrap().n, 2);
    }

    #[test]
    fn empty_study_is_empty() {
        let a = aggregate(
            &[],
            &["x".into()],
            &|s| s.into(),
            None,
            Bootstrap::default(),
        );
        assert!(a.methods.is_empty() && a.comparisons.is_empty() && a.ops.is_empty());
    }

    #[test]
    fn plan_and_manifest_round_trip() {
        let ps: Vec<String> = (1..=4).map(|i| format!("P{i}")).collect();
        let ms: Vec<String> = ["a", "b", "c", "d"].iter().map(|s| s.to_string()).collect();
        let m = Manifest::plan(&ps, &ms, 2, true);
        assert_eq!(m.sessions.len(), 16);
        // Balanced Latin square: every method once per position and per participant.
        for pos in 1..=4 {
            let at: BTreeSet<&str> = m
                .sessions
                .iter()
                .filter(|s| s.order == pos)
                .map(|s| s.method.as_str())
                .collect();
            assert_eq!(at.len(), 4);
        }
        // Williams: each method directly follows each other one exactly once.
        let mut pairs = BTreeSet::new();
        for p in &ps {
            let row: Vec<&str> = m
                .sessions
                .iter()
                .filter(|s| &s.participant == p)
                .map(|s| s.method.as_str())
                .collect();
            for w in row.windows(2) {
                assert!(pairs.insert((w[0], w[1])), "{w:?} twice");
            }
        }
        let back = Manifest::parse(&m.to_toml().unwrap()).unwrap();
        assert_eq!(back, m);
    }

    proptest::proptest! {
        #[test]
        fn manifest_parser_never_panics(s in "[a-z\\[\\]=\"'\n 0-9.]{0,120}") {
            let _ = Manifest::parse(&s);
        }
    }

    #[test]
    fn manifest_errors() {
        assert!(
            Manifest::parse(
                "[[session]]\nparticipant='p'\nmethod='x'\nlog='l'\n[[method]]\nid='y'\n"
            )
            .is_err()
        );
        assert!(Manifest::parse("baseline = 3").is_err());
        assert!(Manifest::parse("[[method]]\nid='a'\n[[method]]\nid='a'\n").is_err());
        assert!(Manifest::parse("").unwrap().sessions.is_empty());
    }
}
