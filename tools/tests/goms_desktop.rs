//! Issue 19, desktop keys and mode switches: a display-server session fed as the
//! desktop feeds it (wand samples from the mouse, keys logged as the window logs them
//! before their commands), in plain and in study mode, then `sculpt-tools goms` on the
//! logs it wrote: keys are K operators, each mode's operators are that mode's, and a
//! study trial lands where `goms study next` said.

mod common;
use common::ok;

use std::path::Path;

use glam::DQuat;
use sculpt_core::editor::default_surface_point;
use sculpt_core::interaction::{Command as WandCommand, InteractionMode, WandEvent, WandSample};
use vr_app::config::Config;
use vr_app::session::Session;
use vr_app::study::StudyRun;

/// `tally.csv` rows `(method, trial, op, count)`.
fn tally(path: &Path) -> Vec<(String, String, String, f64)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[1].to_owned(),
                f[2].to_owned(),
                f[3].to_owned(),
                f[4].parse().unwrap_or_else(|e| panic!("{l}: {e}")),
            )
        })
        .collect()
}

fn count(rows: &[(String, String, String, f64)], method: &str, op: &str) -> f64 {
    rows.iter()
        .filter(|r| r.0 == method && r.2 == op)
        .map(|r| r.3)
        .sum()
}

/// A 1 s carve or emboss stroke across the default surface from `t0` (the left mouse
/// button held), then the wand held still for 0.5 s.
fn stroke(s: &mut Session, t0: f64, y: f64) {
    for i in 0..=150 {
        let t = t0 + i as f64 * 0.01;
        let x = -0.15 + 0.3 * (i.min(100) as f64 / 100.0);
        let p = default_surface_point(x, y);
        s.handle(&WandEvent::sample(
            t,
            WandSample::tracked(p, DQuat::IDENTITY, u32::from(i > 0 && i < 100)),
        ))
        .unwrap();
    }
}

/// A desktop key: logged as the window logs it, then its command.
fn key(s: &mut Session, t: f64, label: &str, command: WandCommand) {
    s.key(t, label);
    s.handle(&WandEvent::command(t, command)).unwrap();
}

fn session(dir: &Path) -> Session {
    let mut cfg = Config::default();
    cfg.files.dir = dir.to_path_buf();
    Session::open(&cfg).unwrap()
}

#[test]
fn desktop_keys_are_k_and_operators_follow_the_mode_switch() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("P7");
    let mut s = session(&run);
    stroke(&mut s, 0.0, 1.1);
    key(
        &mut s,
        2.0,
        "3",
        WandCommand::SetMode {
            mode: InteractionMode::EMBOSS,
        },
    );
    stroke(&mut s, 2.5, 1.2);
    key(&mut s, 4.5, "]", WandCommand::SetWidth { width: 0.02 });
    key(&mut s, 5.0, "Ctrl+Z", WandCommand::Undo);
    key(&mut s, 5.5, "Ctrl+S", WandCommand::Save);
    drop(s);
    let out = dir.path().join("report");
    let said = ok(&[
        "goms",
        "analyze",
        dir.path().to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(said.starts_with("2 trials of 2 methods"), "{said}");
    let rows = tally(&out.join("tally.csv"));
    // carve: the stroke's press and the "3" key that leaves carve mode; emboss: the
    // stroke's press and three keys. Before this, keys were no operators and every
    // operator was "carve".
    assert_eq!(count(&rows, "carve", "K"), 2.0, "{rows:?}");
    assert_eq!(count(&rows, "emboss", "K"), 4.0, "{rows:?}");
    assert_eq!(
        count(&rows, "carve", "P") + count(&rows, "emboss", "P"),
        2.0,
        "{rows:?}"
    );
}

#[test]
fn a_study_trial_recorded_by_the_display_server_is_analysed() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("s");
    let st = study.to_str().unwrap();
    ok(&[
        "goms",
        "study",
        "init",
        st,
        "--participants",
        "1",
        "--methods",
        "desk",
        "--trials",
        "2",
    ]);
    let manifest = study.join("study.toml");
    let mut s = session(&dir.path().join("run"));
    let mut run = StudyRun::open(&manifest, "P1", None).unwrap();
    run.attach(&mut s).unwrap();
    for trial in 0..2 {
        let t0 = trial as f64 * 10.0;
        let next: serde_json::Value =
            serde_json::from_str(&ok(&["goms", "study", "next", st, "--json"])).unwrap();
        assert_eq!(next["participant"], "P1");
        assert_eq!(next["trial"], trial + 1);
        assert_eq!(
            Path::new(next["log"].as_str().unwrap()),
            study.join("logs/P1-desk.oplog")
        );
        assert!(
            run.hud_line()
                .contains(&format!("trial {} of 2", trial + 1))
        );
        assert!(run.start(&mut s, t0));
        stroke(&mut s, t0 + 0.5, 1.1);
        key(&mut s, t0 + 3.0, "Ctrl+Z", WandCommand::Undo);
        key(
            &mut s,
            t0 + 3.5,
            "2",
            WandCommand::SetMode {
                mode: if trial == 0 {
                    InteractionMode::EMBOSS
                } else {
                    InteractionMode::CARVE
                },
            },
        );
        let log = run.finish(&mut s, Some(t0 + 4.0)).unwrap().unwrap();
        assert!(log.starts_with(&study), "{}", log.display());
    }
    assert!(ok(&["goms", "study", "next", st]).contains("all sessions recorded"));
    let said = ok(&["goms", "analyze", st]);
    assert!(said.starts_with("2 trials of 1 methods"), "{said}");
    let rows = tally(&study.join("report/tally.csv"));
    // Per trial: the stroke's press and two keys, all under the study's method.
    for trial in ["1", "2"] {
        let k: f64 = rows
            .iter()
            .filter(|r| r.0 == "desk" && r.1 == trial && r.2 == "K")
            .map(|r| r.3)
            .sum();
        assert_eq!(k, 3.0, "{rows:?}");
    }
}
