//! The `wandtrack` binary end to end: simulate to a log, check it, re-send it over TCP
//! byte for byte, and fit a calibration from a CSV.

use std::io::Read;
use std::process::Command;
use tracking::poselog::PoseLog;

fn wandtrack() -> Command {
    Command::new(env!("CARGO_BIN_EXE_wandtrack"))
}

#[test]
fn sim_check_and_play() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("s.toml");
    std::fs::write(
        &script,
        "wand_start = [0.0, 1.0, 0.0]\n[[step]]\nop = \"move\"\nto = [0.2, 1.0, 0.0]\nsecs = 0.5\n[[step]]\nop = \"click\"\nbutton = 0\nsecs = 0.1\n",
    )
    .unwrap();
    let log = dir.path().join("s.wslog");
    let out = wandtrack()
        .args(["sim", "--rate", "60", "--seed", "3", "--script"])
        .arg(&script)
        .arg("--log")
        .arg(&log)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = wandtrack().arg("check").arg(&log).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("DTrack frames 37"), "{text}");

    // Re-send it to a listening "display server" as fast as possible.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let reader = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut got = Vec::new();
        s.read_to_end(&mut got).unwrap();
        got
    });
    let out = wandtrack()
        .arg("play")
        .arg(&log)
        .args(["--speed", "0", "--tcp-connect", &addr.to_string()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got = reader.join().unwrap();
    let want: Vec<u8> = PoseLog::read(&log)
        .unwrap()
        .records
        .iter()
        .flat_map(|r| r.bytes.clone())
        .collect();
    assert_eq!(got, want);

    // A damaged line makes `check` fail and name the line.
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[5] = "d 0.1 broken";
    std::fs::write(&log, lines.join("\n") + "\n").unwrap();
    let out = wandtrack().arg("check").arg(&log).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("pose log line 6"));
}

#[test]
fn calibrate_from_csv() {
    let dir = tempfile::tempdir().unwrap();
    let pairs = dir.path().join("pairs.csv");
    // Tracker Z-up mm -> display Y-up m, shifted 2 m back.
    std::fs::write(
        &pairs,
        "# tx,ty,tz,wx,wy,wz\n0,0,0, 0,0,-2\n1000,0,0, 1,0,-2\n0,1000,0, 0,0,-3\n0,0,1000, 0,1,-2\n",
    )
    .unwrap();
    let out = wandtrack()
        .arg("calibrate")
        .arg(&pairs)
        .args(["--axes", "x,z,-y"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("rms residual 0.000 mm"), "{text}");
    let cal: toml::Table = toml::from_str(&text).unwrap();
    let t = cal["calibration"]["translation_m"].as_array().unwrap();
    assert!((t[2].as_float().unwrap() + 2.0).abs() < 1e-9, "{text}");
}
