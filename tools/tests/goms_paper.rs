//! `sculpt-tools goms paper`: the paper's multiresolution sculpting row (Kwon, Kim and
//! Chai 2006, Tables 1 and 2) beside the KLM prediction and the recorded sessions'
//! operators, each column checked against a computation of its own: the measured means
//! from `goms analyze`'s tally, the prediction from `goms klm`'s printout, the paper's
//! cells from `tests/data/paper-tables-1-2.csv`.

mod common;
use common::ok;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use common::tolerance::DECIMAL_SUM_EPS;
use sculpt_core::assert_near;

fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse().unwrap_or_else(|e| panic!("{s:?}: {e}"))
}

#[test]
fn paper_comparison_columns_match_independent_computations() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let dir = tempfile::tempdir().unwrap();
    let logs = dir.path().join("logs");
    // The recorded multiresolution sculpting sessions (not the tracking-fault ones).
    let sessions = [
        "patch-carve",
        "patch-overlaps",
        "patch-emboss",
        "patch-mask",
        "sketch-carve",
    ];
    // The same logs with their mode segment marks taken out by hand: each session is
    // then one trial for `goms analyze`, the independent computation below.
    let whole = dir.path().join("whole");
    let mut segments = 0;
    for s in sessions {
        let log = std::fs::read_to_string(data.join("operator-logs").join(s).join("operator.log"))
            .unwrap();
        let marks =
            |l: &&str| l.contains("\"ev\":\"trial_start\"") || l.contains("\"ev\":\"trial_end\"");
        segments += log
            .lines()
            .filter(|l| l.contains("\"ev\":\"trial_start\""))
            .count();
        let unmarked: String = log
            .lines()
            .filter(|l| !marks(l))
            .map(|l| format!("{l}\n"))
            .collect();
        for (root, text) in [(&logs, &log), (&whole, &unmarked)] {
            let to = root.join(s);
            std::fs::create_dir_all(&to).unwrap();
            std::fs::write(to.join("operator.log"), text).unwrap();
        }
    }
    assert!(segments > sessions.len(), "some sessions switch mode");
    let csv = dir.path().join("paper.csv");
    let said = ok(&[
        "goms",
        "paper",
        logs.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert!(said.contains("Multi-resolution sculpting"), "{said}");
    assert!(said.contains("no thinking"), "{said}");
    // Regression (issue 19): each session is one trial of the task, however many mode
    // segments its log has (a mode switch is part of the paper's task).
    assert!(
        said.contains(&format!("mean over {} trials", sessions.len())),
        "{said}"
    );
    let got: BTreeMap<String, Vec<f64>> = rows(&csv)
        .into_iter()
        .map(|r| {
            let v = r[1..]
                .iter()
                .map(|c| if c.is_empty() { f64::NAN } else { num(c) })
                .collect();
            (r[0].clone(), v)
        })
        .collect();
    let col = |op: &str, i: usize| got[op][i];

    // Measured: per operator, the tally's counts and seconds of the unmarked logs
    // summed over the trials and divided by the number of trials.
    let report = dir.path().join("report");
    ok(&[
        "goms",
        "analyze",
        whole.to_str().unwrap(),
        "-o",
        report.to_str().unwrap(),
        "--no-plots",
    ]);
    let tally = rows(&report.join("tally.csv"));
    let trials: BTreeSet<(String, String, String)> = tally
        .iter()
        .map(|r| (r[0].clone(), r[1].clone(), r[2].clone()))
        .collect();
    assert_eq!(trials.len(), sessions.len());
    let n = trials.len() as f64;
    let mut total_count = 0.0;
    let mut total_time = 0.0;
    for op in ["P", "K", "B", "M", "R"] {
        let (c, t) = tally
            .iter()
            .filter(|r| r[3] == op)
            .fold((0.0, 0.0), |a, r| (a.0 + num(&r[4]), a.1 + num(&r[5])));
        assert_near!(col(op, 1), c / n, DECIMAL_SUM_EPS, "measured {op} count");
        assert_near!(col(op, 4), t / n, DECIMAL_SUM_EPS, "measured {op} seconds");
        total_count += c / n;
        total_time += t / n;
    }
    assert_near!(col("total", 1), total_count, DECIMAL_SUM_EPS);
    // The operators tile each trial: their seconds are the mean trial length.
    assert_near!(col("total", 4), total_time, DECIMAL_SUM_EPS);

    // KLM: `goms klm` prints "  K: 2 x = 0.56 s" per operator and the total.
    let klm = ok(&["goms", "klm", "builtin:multires-sculpting"]);
    let mut klm_total = 0.0;
    for line in klm.lines().filter(|l| l.starts_with("  ")) {
        let (op, rest) = line.trim().split_once(": ").unwrap();
        let (count, secs) = rest.split_once(" x = ").unwrap();
        let secs = num(secs.trim_end_matches(" s"));
        assert_near!(col(op, 0), num(count), DECIMAL_SUM_EPS, "KLM {op}");
        assert_near!(col(op, 3), secs, DECIMAL_SUM_EPS, "KLM {op} s");
        klm_total += secs;
    }
    assert_near!(col("total", 3), klm_total, DECIMAL_SUM_EPS);

    // Paper: the sculpting rows of the tally file of Tables 1 and 2.
    let paper = rows(&data.join("paper-tables-1-2.csv"));
    let mut sums = (0.0, 0.0);
    for r in paper
        .iter()
        .filter(|r| r[1] == "Multi-resolution sculpting")
    {
        assert_near!(
            col(&r[3], 2),
            num(&r[4]),
            DECIMAL_SUM_EPS,
            "paper {} count",
            r[3]
        );
        assert_near!(
            col(&r[3], 5),
            num(&r[5]),
            DECIMAL_SUM_EPS,
            "paper {} s",
            r[3]
        );
        sums = (sums.0 + num(&r[4]), sums.1 + num(&r[5]));
    }
    assert_near!(col("total", 2), sums.0, DECIMAL_SUM_EPS);
    assert_near!(col("total", 5), sums.1, DECIMAL_SUM_EPS);
    assert!(
        col("B", 2).is_nan() && col("R", 5).is_nan(),
        "the paper has no B or R"
    );
    // The ratio printed for the total seconds.
    let pct = format!("{:.0} %", 100.0 * col("total", 4) / col("total", 5));
    assert!(
        said.lines()
            .any(|l| l.starts_with("| total") && l.ends_with(&format!("| {pct} |"))),
        "{said}"
    );
}
