//! End-to-end tests of `sculpt-tools goms`, running the real binary.

mod common;
use common::{ok, tools};

use std::path::Path;
use std::process::Command;

use common::tolerance::{DECIMAL_SUM_EPS, TRUNCATE_EPS};
use sculpt_core::assert_near;
use sculpt_core::tolerance::TIME_EPS;

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// Parses a CSV file into rows of fields (no quoting in the files checked here).
fn csv(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect()
}

/// A layout and arithmetic check, not a reproduction of the study: the paper's own
/// table cells go in as a tally, and the harness must lay them out and sum them exactly
/// as Tables 1 and 2 print them, and compute the paper's percentages from them.
#[test]
fn paper_tables_layout_and_arithmetic_check() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    ok(&[
        "goms",
        "summarize",
        "--tally",
        &data("paper-tables-1-2.csv"),
        "--out",
        out.to_str().unwrap(),
        "--klm",
        "Multi-resolution sculpting=builtin:multires-sculpting",
    ]);
    // Table 1 and Table 2, cell by cell, as the paper prints them.
    let summary = csv(&out.join("summary.csv"));
    assert_eq!(summary[0], ["table", "method", "P", "K", "M", "TOTAL"]);
    let want: [(&str, &str, [f64; 4]); 6] = [
        (
            "operations",
            "Multi-surface modeling",
            [69.8, 82.2, 13.4, 165.4],
        ),
        ("operations", "Trimming modeling", [14.6, 16.0, 5.0, 35.6]),
        (
            "operations",
            "Multi-resolution sculpting",
            [3.0, 7.4, 2.4, 12.8],
        ),
        (
            "time_s",
            "Multi-surface modeling",
            [50.03, 37.65, 12.94, 100.62],
        ),
        ("time_s", "Trimming modeling", [10.87, 10.68, 8.98, 30.53]),
        (
            "time_s",
            "Multi-resolution sculpting",
            [3.73, 4.58, 3.7, 12.01],
        ),
    ];
    for (row, (table, method, cells)) in summary[1..].iter().zip(want) {
        assert_eq!((row[0].as_str(), row[1].as_str()), (table, method));
        let got: Vec<f64> = row[2..].iter().map(|x| x.parse().unwrap()).collect();
        assert_near!(got.as_slice(), cells.as_slice(), DECIMAL_SUM_EPS);
    }
    assert_eq!(summary.len(), 7);

    // Percentages: sculpting against the two Maya methods, ratio of the means.
    let comps = csv(&out.join("comparisons.csv"));
    let pct = |against: &str, measure: &str| -> f64 {
        comps
            .iter()
            .find(|r| r[0] == "Multi-resolution sculpting" && r[1] == against && r[2] == measure)
            .unwrap()[3]
            .parse()
            .unwrap()
    };
    let ops_ms = pct("Multi-surface modeling", "operations");
    let ops_tr = pct("Trimming modeling", "operations");
    let t_ms = pct("Multi-surface modeling", "time_s");
    let t_tr = pct("Trimming modeling", "time_s");
    assert_near!(ops_ms, 100.0 * 12.8 / 165.4, DECIMAL_SUM_EPS);
    assert_near!(ops_tr, 100.0 * 12.8 / 35.6, DECIMAL_SUM_EPS);
    assert_near!(t_ms, 100.0 * 12.01 / 100.62, DECIMAL_SUM_EPS);
    assert_near!(t_tr, 100.0 * 12.01 / 30.53, DECIMAL_SUM_EPS);
    // The paper prints percentages truncated to two decimals: 7.73 % and 39.33 % are
    // reproduced exactly that way.
    let trunc = |x: f64| (x * 100.0 + TRUNCATE_EPS).floor() / 100.0;
    assert_eq!(trunc(ops_ms), 7.73);
    assert_eq!(trunc(t_tr), 39.33);
    // The paper's other two figures do not follow from its own tables: 12.8 / 35.6 is
    // 35.955 % (printed 35.85 %) and 12.01 / 100.62 is 11.936 % (printed 12.01 %, the
    // sculpting time in seconds). The harness reports what the tables give.
    assert_eq!(trunc(ops_tr), 35.95);
    assert_eq!(trunc(t_ms), 11.93);

    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("7.74 % (7.73)"), "{report}");
    assert!(report.contains("39.34 % (39.33)"));
    // The task-analysis KLM (2 M, 2 K, 2 P, 2 B: 5.66 s) next to the measured 12.01 s.
    assert!(
        report
            .contains("| Multi-resolution sculpting | builtin:multires-sculpting | 5.66 | 12.01 |"),
        "{report}"
    );
    for f in [
        "operations_by_method",
        "time_by_method",
        "participants_time",
    ] {
        let svg = std::fs::read_to_string(out.join(format!("{f}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.contains("Multi-resolution sculpting"));
        let png = std::fs::read(out.join(format!("{f}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    }
}

#[test]
fn klm_builtins_and_textbook_sums() {
    let out = ok(&["goms", "klm", "builtin:multires-sculpting"]);
    // 2 M + 2 K + 2 P + 2 B with CMN constants, average typist: 2.70 + 0.56 + 2.20 + 0.20.
    assert!(out.contains("Multiresolution sculpting: 5.66 s"), "{out}");
    let out = ok(&[
        "goms",
        "klm",
        "--mental",
        "kieras",
        "--typist",
        "skilled",
        "builtin:maya-trimming",
    ]);
    // 23 P + 24 K + 2 B + 14 M: 25.30 + 4.80 + 0.20 + 16.80.
    assert!(out.contains("Maya trimming modeling: 47.10 s"), "{out}");
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("menu.klm");
    std::fs::write(&f, "name: menu pick\nH P B B P B B H \"1234\" K.tv\n").unwrap();
    let out = ok(&["goms", "klm", "--place-m", "--explain", f.to_str().unwrap()]);
    // 2 H + 3 M + 2 P + 4 B + 5 K = 0.80 + 4.05 + 2.20 + 0.40 + 1.40.
    assert!(out.contains("menu pick: 8.85 s"), "{out}");
    assert!(out.contains("H M P B B M P B B H K K K K M K"), "{out}");
    assert!(out.contains("deleted by rule 1"));
    // A drag with ordinary spacing: no M before its sweep.
    std::fs::write(&f, "name: drags\n(P B P B) * 2\n").unwrap();
    let out = ok(&["goms", "klm", "--place-m", "--explain", f.to_str().unwrap()]);
    assert!(out.contains("M P B P B M P B P B"), "{out}");
    let listed = ok(&["goms", "methods"]);
    assert_eq!(listed.lines().count(), 3);
}

#[test]
fn malformed_inputs_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bad.oplog");
    std::fs::write(
        &log,
        "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n{\"t\":0.1,\"ev\":\"undo\"}\n{\"t\":oops}\n{\"t\":0.3,\"ev\":\"redo\"}\n",
    )
    .unwrap();
    let out = tools(&["goms", "extract", log.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.oplog") && err.contains("line 3"), "{err}");

    let study = dir.path().join("study");
    std::fs::create_dir(&study).unwrap();
    std::fs::copy(&log, study.join("x.oplog")).unwrap();
    let out = tools(&["goms", "analyze", study.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("line 3"));

    // With --skip-bad the bad log is left out, with a warning, and the report of the
    // good one is written (a study of no trial at all would be an error).
    std::fs::write(
        study.join("y.oplog"),
        "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n{\"t\":0.1,\"ev\":\"button\",\"id\":0,\"down\":true}\n{\"t\":0.2,\"ev\":\"button\",\"id\":0,\"down\":false}\n",
    )
    .unwrap();
    let out = tools(&["goms", "analyze", study.to_str().unwrap(), "--skip-bad"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("left out"));
    let report = std::fs::read_to_string(study.join("report/report.md")).unwrap();
    assert!(report.contains("left out") && report.contains("line 3"));

    let klm = dir.path().join("m.klm");
    std::fs::write(&klm, "P K\nP Q\n").unwrap();
    let out = tools(&["goms", "klm", klm.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("method line 2, column 3"));

    let tally = dir.path().join("t.csv");
    std::fs::write(
        &tally,
        "participant,method,trial,op,count,time\np,m,1,P,x,1\n",
    )
    .unwrap();
    let out = tools(&["goms", "summarize", "--tally", tally.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("t.csv"));

    let out = tools(&[
        "goms",
        "analyze",
        study.to_str().unwrap(),
        "--v-off",
        "1",
        "--v-on",
        "0.5",
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("v-off"));
}

#[test]
fn truncated_last_line_is_a_warning_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("cut.oplog");
    std::fs::write(
        &log,
        "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n{\"t\":0.1,\"ev\":\"button\",\"id\":0,\"down\":true}\n{\"t\":0.2,\"ev\":\"button\",\"id\":0,\"down\":false}\n{\"t\":0.3,\"ev\":\"butt",
    )
    .unwrap();
    let out = tools(&["goms", "extract", log.to_str().unwrap()]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("cut short"));
    let table = String::from_utf8(out.stdout).unwrap();
    assert_eq!(
        table.lines().next().unwrap(),
        "participant,method,trial,op,t_start,t_end,duration,amplitude,width,id"
    );
    assert_eq!(table.lines().filter(|l| l.contains(",K,")).count(), 1);
}

/// Regression (issue 19): a directory with no trial printed "0 trials" and exited 0.
#[test]
fn regression_a_directory_with_no_trial_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    // Not a log by its name: nothing is read.
    std::fs::write(dir.path().join("notes.log"), "x").unwrap();
    let out = tools(&["goms", "analyze", dir.path().to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no trial to analyse"), "{err}");
    assert!(!dir.path().join("report/report.md").exists());
    // A log with a header and no event is no trial either.
    std::fs::write(
        dir.path().join("operator.log"),
        "{\"format\":\"wandsculpt-oplog\",\"version\":1}\n",
    )
    .unwrap();
    let out = tools(&["goms", "analyze", dir.path().to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("1 operator logs found"));
}

/// Per trial of an `events.csv`: `(participant, method, trial)`, its operators' `(op,
/// start, end)` in file order.
type TrialOps = ((String, String, String), Vec<(String, f64, f64)>);

fn trials_of(events: &[Vec<String>]) -> Vec<TrialOps> {
    let mut out: Vec<TrialOps> = Vec::new();
    for r in &events[1..] {
        let key = (r[0].clone(), r[1].clone(), r[2].clone());
        let op = (r[3].clone(), r[4].parse().unwrap(), r[5].parse().unwrap());
        match out.last_mut() {
            Some((k, ops)) if *k == key => ops.push(op),
            _ => out.push((key, vec![op])),
        }
    }
    out
}

/// A log's trials as the log itself marks them, read as plain JSON lines (not by the
/// harness): per `trial_start`, its method (else the header's), trial number, start
/// time and end time: its `trial_end`'s, or the last event's when the log ends first
/// (a plain session's last mode segment).
fn marked_trials(path: &Path) -> Vec<(String, String, f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().map(|l| {
        serde_json::from_str::<serde_json::Value>(l).unwrap_or_else(|e| panic!("{l}: {e}"))
    });
    let header = lines.next().unwrap();
    let mut out = Vec::new();
    let mut open: Option<(String, String, f64)> = None;
    let mut last = 0.0;
    for v in lines {
        let t = v["t"].as_f64().unwrap();
        match v["ev"].as_str().unwrap() {
            "trial_start" => {
                assert!(
                    open.is_none(),
                    "{}: a trial starts inside one",
                    path.display()
                );
                let method = v["method"].as_str().or(header["method"].as_str());
                open = Some((method.unwrap().to_owned(), v["trial"].to_string(), t));
            }
            "trial_end" => {
                let (m, n, t0) = open.take().expect("trial_end without trial_start");
                assert_eq!(n, v["trial"].to_string(), "{}", path.display());
                out.push((m, n, t0, t));
            }
            _ => {}
        }
        last = t;
    }
    if let Some((m, n, t0)) = open {
        out.push((m, n, t0, last));
    }
    out
}

/// Checks that the operators of `ops` follow each other without gap or overlap and
/// that their seconds sum to the trial's length as its log marks it.
fn assert_operators_fill(trial: &str, ops: &[(String, f64, f64)], marked: (f64, f64)) {
    for w in ops.windows(2) {
        assert_eq!(w[0].2, w[1].1, "{trial}: {w:?}");
    }
    let sum: f64 = ops.iter().map(|o| o.2 - o.1).sum();
    assert_near!(
        sum,
        marked.1 - marked.0,
        TIME_EPS,
        "{trial}: operator seconds"
    );
    assert_near!(ops[0].1, marked.0, TIME_EPS, "{trial}: first operator");
}

/// The operator logs `replay` wrote for every recorded session: found by their name
/// (`operator.log`, one directory down), each mode segment of a session one trial under
/// its mode, and in every trial the operators follow each other without gap or overlap,
/// so their seconds sum to the segment's length as the log marks it.
#[test]
fn analyze_reads_the_operator_logs_of_every_recorded_session() {
    let dir = tempfile::tempdir().unwrap();
    let logs = data("operator-logs");
    let mut sessions: Vec<String> = std::fs::read_dir(&logs)
        .unwrap()
        .filter_map(|e| {
            let e = e.unwrap();
            e.path()
                .join("operator.log")
                .exists()
                .then(|| e.file_name().to_string_lossy().into_owned())
        })
        .collect();
    sessions.sort();
    assert!(sessions.len() >= 12, "{sessions:?}");
    // The trials the logs mark, session by session (the harness reads them sorted).
    let mut marked = Vec::new();
    for s in &sessions {
        for (m, n, t0, t1) in marked_trials(&Path::new(&logs).join(s).join("operator.log")) {
            marked.push(((s.clone(), m, n), (t0, t1)));
        }
    }
    assert!(
        marked.len() > sessions.len(),
        "some session switches mode: {marked:?}"
    );
    let out = dir.path().join("r");
    let said = ok(&["goms", "analyze", &logs, "-o", out.to_str().unwrap()]);
    assert!(
        said.starts_with(&format!("{} trials", marked.len())),
        "{said}"
    );
    let events = csv(&out.join("events.csv"));
    let trials = trials_of(&events);
    let keys: Vec<_> = trials.iter().map(|t| t.0.clone()).collect();
    let want: Vec<_> = marked.iter().map(|m| m.0.clone()).collect();
    assert_eq!(keys, want);
    for (((participant, method, trial), ops), (_, span)) in trials.iter().zip(&marked) {
        assert_operators_fill(&format!("{participant} {method} {trial}"), ops, *span);
    }
    // Each recorded stroke is a press: every session has a K, and no K is longer than
    // its keystroke window (0.2 s by default), however long the button was held.
    for s in &sessions {
        let ks: Vec<f64> = trials
            .iter()
            .filter(|t| t.0.0 == *s)
            .flat_map(|t| t.1.iter().filter(|o| o.0 == "K").map(|o| o.2 - o.1))
            .collect();
        assert!(!ks.is_empty(), "{s}");
        assert!(
            ks.iter().all(|&k| k <= 0.2 + DECIMAL_SUM_EPS),
            "{s}: {ks:?}"
        );
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("sum to its length"), "{report}");
}

#[test]
fn study_mode_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("s");
    let s = study.to_str().unwrap();
    ok(&[
        "goms",
        "study",
        "init",
        s,
        "--participants",
        "3",
        "--methods",
        "wall,desk",
        "--trials",
        "2",
        "--baseline",
        "desk",
        "--name",
        "Demo study",
    ]);
    let next = ok(&["goms", "study", "next", s, "--json"]);
    let v: serde_json::Value = serde_json::from_str(&next).unwrap();
    assert_eq!(v["participant"], "P1");
    assert_eq!(v["trials"], 2);
    let status = ok(&["goms", "study", "status", s]);
    assert_eq!(status.matches("pending").count(), 6);
    ok(&["goms", "study", "simulate", s, "--steps", "3"]);
    let status = ok(&["goms", "study", "status", s]);
    assert_eq!(
        status.matches("recorded (2/2 trials;").count(),
        6,
        "{status}"
    );
    assert!(ok(&["goms", "study", "next", s]).contains("all sessions recorded"));
    let out = dir.path().join("out");
    ok(&[
        "goms",
        "analyze",
        s,
        "--out",
        out.to_str().unwrap(),
        "--sensitivity",
        "--trace",
        "P2/desk/2",
    ]);
    let events = csv(&out.join("events.csv"));
    assert_eq!(
        events[0],
        [
            "participant",
            "method",
            "trial",
            "op",
            "t_start",
            "t_end",
            "duration",
            "amplitude",
            "width",
            "id"
        ]
    );
    assert!(events.len() > 20);
    let summary = csv(&out.join("summary.csv"));
    // Manifest order: wall, desk; both tables.
    assert_eq!(summary.len(), 5);
    assert_eq!(
        (summary[1][1].as_str(), summary[2][1].as_str()),
        ("wall", "desk")
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.starts_with("# Demo study"));
    assert!(report.contains("Sensitivity"));
    assert!(out.join("gantt_P2_desk_2.png").exists());
    assert!(out.join("speed_P2_desk_2.svg").exists());
    let sens = std::fs::read_to_string(out.join("sensitivity.csv")).unwrap();
    assert!(sens.lines().count() > 10);

    // The event table goes back in as hand-coded data and gives the same Table 1.
    let again = dir.path().join("again");
    ok(&[
        "goms",
        "summarize",
        "--events",
        out.join("events.csv").to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
        "--order",
        "wall,desk",
        "--no-plots",
    ]);
    let s2 = csv(&again.join("summary.csv"));
    assert_eq!(s2[1..3], summary[1..3]);
}

#[test]
fn repeated_trial_numbers_are_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let h =
        "{\"format\":\"wandsculpt-oplog\",\"version\":1,\"participant\":\"P1\",\"method\":\"m\"}\n";
    let trial = |t: f64| {
        format!(
            "{{\"t\":{t},\"ev\":\"trial_start\",\"trial\":1}}\n{{\"t\":{},\"ev\":\"button\",\"id\":0,\"down\":true}}\n{{\"t\":{},\"ev\":\"button\",\"id\":0,\"down\":false}}\n{{\"t\":{},\"ev\":\"trial_end\",\"trial\":1}}\n",
            t + 0.5,
            t + 0.6,
            t + 1.0
        )
    };
    std::fs::write(
        dir.path().join("a.oplog"),
        format!("{h}{}{}", trial(0.0), trial(2.0)),
    )
    .unwrap();
    let out = tools(&[
        "goms",
        "analyze",
        dir.path().to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("trial 1 more than once"));
    // Both trials' presses land in trial 1: Table 1 shows 2 K for the one trial (R, the
    // time around the presses, has seconds but no count).
    let summary = csv(&dir.path().join("report/summary.csv"));
    assert_eq!(summary[0][..5], ["table", "method", "K", "R", "TOTAL"]);
    assert_eq!(summary[1][..5], ["operations", "m", "2.00", "0.00", "2.00"]);
}

/// Regression (issue 19): `goms study status | head` panicked on the closed pipe.
#[test]
fn regression_a_closed_pipe_ends_the_output_quietly() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s");
    let s = s.to_str().unwrap();
    // Enough sessions that the listing outgrows a pipe's buffer (64 KiB).
    ok(&[
        "goms",
        "study",
        "init",
        s,
        "--participants",
        "1500",
        "--methods",
        "wall,desk",
    ]);
    let mut child = Command::new(env!("CARGO_BIN_EXE_sculpt-tools"))
        .args(["goms", "study", "status", s])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    // The reader is dropped here: the pipe is closed with most of the listing unread.
    assert!(first.starts_with("participant"), "{first}");
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.status.success(), "{err}");
}

/// The `replay` binary beside this one, built first if the workspace has not built it.
fn replay_bin() -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_BIN_EXE_sculpt-tools"))
        .parent()
        .unwrap();
    let bin = dir.join(format!("replay{}", std::env::consts::EXE_SUFFIX));
    if !bin.exists() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "-p", "replay", "--bin", "replay"])
            .status()
            .unwrap();
        assert!(status.success(), "building replay");
    }
    assert!(bin.exists(), "{}", bin.display());
    bin
}

/// Regression: the committed operator logs went stale when `replay`'s log began to
/// follow mode switches (one segment per mode, commit c6e31bc), and every test reading
/// them kept passing on the old logs. Every recorded session but the minute-long soak
/// has a fixture, and replaying it with today's `replay` (as
/// `tools/tests/data/operator-logs/README.md` says) writes that fixture byte for byte:
/// the log holds no wall-clock or run-dependent field.
#[test]
fn regression_operator_log_fixtures_are_what_replay_writes_now() {
    let sessions = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions");
    let fixtures = Path::new(&data("operator-logs")).to_path_buf();
    let names = |dir: &Path, keep: &dyn Fn(&Path) -> Option<String>| {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| keep(&e.unwrap().path()))
            .collect();
        v.sort();
        v
    };
    let recorded = names(&sessions, &|p| {
        let stem = p.file_stem()?.to_string_lossy().into_owned();
        (p.extension()? == "poselog" && stem != "soak-60s").then_some(stem)
    });
    let fixed = names(&fixtures, &|p| {
        p.is_dir()
            .then(|| p.file_name().unwrap().to_string_lossy().into_owned())
    });
    assert_eq!(fixed, recorded, "one fixture per recorded session");
    let dir = tempfile::tempdir().unwrap();
    for name in &recorded {
        let out = dir.path().join(name);
        let run = Command::new(replay_bin())
            .arg(sessions.join(format!("{name}.poselog")))
            .arg("--out")
            .arg(&out)
            .arg("-q")
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let now = std::fs::read_to_string(out.join("operator.log")).unwrap();
        let committed = std::fs::read_to_string(fixtures.join(name).join("operator.log")).unwrap();
        if now != committed {
            let (i, (a, b)) = now
                .lines()
                .zip(committed.lines())
                .enumerate()
                .find(|(_, (a, b))| a != b)
                .unwrap_or((0, ("(one log is a prefix of the other)", "")));
            panic!(
                "{name}: the committed operator.log is stale (regenerate it with the loop in \
                 tools/tests/data/operator-logs/README.md); line {}:\n  replay: {a}\n  committed: {b}",
                i + 1
            );
        }
    }
}

/// Issue 19's done-when: a study of three simulated participants, `study init`, every
/// trial recorded by `replay --study` from a recorded session into the log the manifest
/// names, then `goms analyze` writes the report and plots with no copying by hand, and
/// every trial's operator times sum to the trial's length.
#[test]
fn study_of_three_participants_recorded_by_replay() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s");
    let manifest = s.join("study.toml");
    ok(&[
        "goms",
        "study",
        "init",
        s.to_str().unwrap(),
        "--participants",
        "3",
        "--methods",
        "sculpt",
        "--trials",
        "2",
    ]);
    let sessions = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions");
    let recorded = [
        "patch-carve",
        "patch-overlaps",
        "sketch-carve",
        "patch-emboss",
        "patch-mask",
        "patch-carve-jitter",
    ];
    let replay = |participant: &str, session: &str| {
        Command::new(replay_bin())
            .arg(sessions.join(format!("{session}.poselog")))
            .args([
                "--study",
                manifest.to_str().unwrap(),
                "--participant",
                participant,
                "-q",
            ])
            .output()
            .unwrap()
    };
    for (i, session) in recorded.iter().enumerate() {
        let participant = format!("P{}", i / 2 + 1);
        let out = replay(&participant, session);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(
            said.contains(&format!("trial {} of 2", i % 2 + 1)),
            "{said}"
        );
    }
    // Every trial of P1 is recorded: a third is refused.
    let out = replay("P1", "patch-carve");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("every trial"));
    // Every participant's session shows both its trials recorded.
    let status = ok(&["goms", "study", "status", s.to_str().unwrap()]);
    for p in ["P1", "P2", "P3"] {
        let line = status
            .lines()
            .find(|l| l.split('\t').next() == Some(p))
            .unwrap_or_else(|| panic!("no status line for {p}:\n{status}"));
        assert!(line.contains("recorded (2/2 trials"), "{line}");
    }

    let said = ok(&["goms", "analyze", s.to_str().unwrap(), "--trace", "all"]);
    assert!(said.starts_with("6 trials of 1 methods"), "{said}");
    let report = s.join("report");
    for f in [
        "report.md",
        "summary.csv",
        "time_by_method.png",
        "gantt_P3_sculpt_2.png",
        "speed_P1_sculpt_1.svg",
    ] {
        assert!(report.join(f).exists(), "{f}");
    }
    let events = csv(&report.join("events.csv"));
    let trials = trials_of(&events);
    let keys: Vec<_> = trials.iter().map(|t| t.0.clone()).collect();
    let want: Vec<_> = (1..=3)
        .flat_map(|p| (1..=2).map(move |t| (format!("P{p}"), "sculpt".into(), t.to_string())))
        .collect();
    assert_eq!(keys, want);
    // Each trial's operator seconds are its trial_end - trial_start in the log.
    for ((participant, method, trial), ops) in &trials {
        let log = s.join(format!("logs/{participant}-{method}.oplog"));
        let marked = marked_trials(&log);
        assert_eq!(marked.len(), 2, "{}", log.display());
        let (.., t0, t1) = marked
            .iter()
            .find(|m| m.1 == *trial)
            .unwrap_or_else(|| panic!("{participant} trial {trial} not in its log"));
        assert!(t1 > t0, "{participant} trial {trial}: {t0} .. {t1}");
        assert_operators_fill(&format!("{participant} trial {trial}"), ops, (*t0, *t1));
    }
    // The log itself says who, what and which trial.
    let log = std::fs::read_to_string(s.join("logs/P2-sculpt.oplog")).unwrap();
    let header = log.lines().next().unwrap();
    assert!(
        header.contains("\"participant\":\"P2\"") && header.contains("\"method\":\"sculpt\""),
        "{header}"
    );
}
