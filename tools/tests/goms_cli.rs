//! End-to-end tests of `sculpt-tools goms`, running the real binary.

use std::path::Path;
use std::process::{Command, Output};

use sculpt_core::assert_near;
use sculpt_core::tolerance::{DECIMAL_SUM_EPS, TRUNCATE_EPS};

fn tools(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sculpt-tools"))
        .args(args)
        .output()
        .expect("sculpt-tools runs")
}

fn ok(args: &[&str]) -> String {
    let out = tools(args);
    assert!(
        out.status.success(),
        "sculpt-tools {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

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

#[test]
fn golden_paper_tables_and_percentages() {
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
    // KLM (3 P, 7 K, 2 M: 7.96 s) next to the measured 12.01 s.
    assert!(
        report
            .contains("| Multi-resolution sculpting | builtin:multires-sculpting | 7.96 | 12.01 |"),
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
    // 3 P + 7 K + 2 M with CMN constants, average typist: 3.30 + 1.96 + 2.70.
    assert!(out.contains("Multiresolution sculpting: 7.96 s"), "{out}");
    let out = ok(&[
        "goms",
        "klm",
        "--mental",
        "kieras",
        "--typist",
        "skilled",
        "builtin:maya-trimming",
    ]);
    // 15 P + 16 K + 5 M: 16.50 + 3.20 + 6.00.
    assert!(out.contains("Maya trimming modeling: 25.70 s"), "{out}");
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("menu.klm");
    std::fs::write(&f, "name: menu pick\nH P B B P B B H \"1234\" K.tv\n").unwrap();
    let out = ok(&["goms", "klm", "--place-m", "--explain", f.to_str().unwrap()]);
    // 2 H + 3 M + 2 P + 4 B + 5 K = 0.80 + 4.05 + 2.20 + 0.40 + 1.40.
    assert!(out.contains("menu pick: 8.85 s"), "{out}");
    assert!(out.contains("H M P B B M P B B H K K K K M K"), "{out}");
    assert!(out.contains("deleted by rule 1"));
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

    // With --skip-bad the bad log is left out, with a warning, and the report is written.
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

#[test]
fn empty_study_gives_an_empty_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&[
        "goms",
        "analyze",
        dir.path().to_str().unwrap(),
        "--sensitivity",
    ]);
    assert!(out.contains("0 trials"));
    let report = std::fs::read_to_string(dir.path().join("report/report.md")).unwrap();
    assert!(report.contains("no data yet"));
    let summary = std::fs::read_to_string(dir.path().join("report/summary.csv")).unwrap();
    assert_eq!(summary.trim(), "table,method,TOTAL");
    let events = std::fs::read_to_string(dir.path().join("report/events.csv")).unwrap();
    assert_eq!(events.lines().count(), 1);
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
    // Both trials' presses land in trial 1: Table 1 shows 2 K for the one trial.
    let summary = csv(&dir.path().join("report/summary.csv"));
    assert_eq!(summary[1][..4], ["operations", "m", "2.00", "2.00"]);
}
