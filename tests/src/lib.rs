//! # tests
//!
//! End-to-end tests that cross crate boundaries live in `tests/tests/`. This library
//! holds only helpers shared by those tests: where the shipped data lives, replaying a
//! shipped session through the library pipeline, and running the `replay` and
//! `wandsculpt` programs (offline, and as a tracking server).
//!
//! ```
//! let dir = tests::sessions_dir();
//! assert!(dir.join("patch-carve.poselog").exists());
//! ```

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

pub mod tolerance;

use replay::config::ReplayConfig;
use replay::pipeline::{Outcome, default_document, replay_log};

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `tests/data/sessions/`: the shipped pose logs.
pub fn sessions_dir() -> PathBuf {
    workspace_root().join("tests/data/sessions")
}

/// The two real Open Brush recordings: the copies in `tests/data/openbrush/`, or the
/// originals in `../shared/data/openbrush/` beside the workspace.
pub fn openbrush_file(name: &str) -> PathBuf {
    let local = workspace_root().join("tests/data/openbrush").join(name);
    if local.exists() {
        local
    } else {
        workspace_root().join("../shared/data/openbrush").join(name)
    }
}

/// Replays a shipped session from the default surface with the default config.
pub fn replay_session(name: &str) -> Outcome {
    let path = sessions_dir().join(format!("{name}.poselog"));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    replay_log(
        &bytes,
        &ReplayConfig::default(),
        default_document(),
        name,
        false,
        None,
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A workspace binary, built now (a no-op when it is fresh) with the profile this test
/// was built with (`test`, or `release` under `cargo test --release`), so an e2e test
/// never runs a stale program. Build every binary a test needs *before* starting any
/// process that waits on another: the first build can take minutes on a CI machine. `package` and `bin` name
/// it as in `cargo build -p PACKAGE --bin BIN`.
pub fn workspace_bin(package: &str, bin: &str) -> PathBuf {
    // target/<profile>/deps/<test exe>
    let exe = std::env::current_exe().expect("the test's own path");
    let profile_dir = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("a test exe lives in target/<profile>/deps")
        .to_path_buf();
    let release = profile_dir.file_name().is_some_and(|n| n == "release");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.current_dir(workspace_root())
        .args(["build", "--quiet", "-p", package, "--bin", bin]);
    // The profile `cargo test` used for this exe, so the build reuses its artifacts
    // instead of compiling the workspace again at another optimisation level.
    cmd.args(["--profile", if release { "release" } else { "test" }]);
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("cargo build -p {package} --bin {bin}: {e}"));
    assert!(
        status.success(),
        "cargo build -p {package} --bin {bin} failed"
    );
    let path = profile_dir.join(format!("{bin}{}", std::env::consts::EXE_SUFFIX));
    assert!(path.exists(), "{} was not built", path.display());
    path
}

/// A child process that is killed (by its own pid) and reaped when dropped, so a
/// failing test leaves nothing running.
#[derive(Debug)]
pub struct ChildGuard(pub std::process::Child);

impl ChildGuard {
    /// Spawns `cmd`.
    pub fn spawn(cmd: &mut std::process::Command) -> Self {
        Self(cmd.spawn().unwrap_or_else(|e| panic!("spawn {cmd:?}: {e}")))
    }

    /// Waits for the process to exit within `timeout`; kills it and panics otherwise.
    pub fn wait_for(
        &mut self,
        what: &str,
        timeout: std::time::Duration,
    ) -> std::process::ExitStatus {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if let Some(status) = self.0.try_wait().expect("try_wait") {
                return status;
            }
            if std::time::Instant::now() > deadline {
                let _ = self.0.kill();
                let _ = self.0.wait();
                panic!("{what} did not finish within {timeout:?}");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// The `replay` and `wandsculpt` programs, built once per test process before any of
/// them starts: a `replay --serve` waiting for its client must never wait on a
/// compiler.
#[derive(Debug)]
pub struct Bins {
    /// `replay`.
    pub replay: PathBuf,
    /// `wandsculpt`, the display server.
    pub wandsculpt: PathBuf,
}

/// The programs (see [`Bins`]).
pub fn bins() -> &'static Bins {
    static BINS: std::sync::OnceLock<Bins> = std::sync::OnceLock::new();
    BINS.get_or_init(|| Bins {
        replay: workspace_bin("replay", "replay"),
        wandsculpt: workspace_bin("vr-app", "wandsculpt"),
    })
}

/// The shipped pose log of session `name`.
pub fn session_log(name: &str) -> PathBuf {
    sessions_dir().join(format!("{name}.poselog"))
}

/// `replay SESSION ARGS.. --out DIR -q`: the offline document's bytes.
pub fn replay_offline(name: &str, dir: &Path, args: &[&std::ffi::OsStr]) -> Vec<u8> {
    let status = Command::new(&bins().replay)
        .arg(session_log(name))
        .args(args)
        .arg("--out")
        .arg(dir)
        .arg("-q")
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "replay {name} --out {}", dir.display());
    std::fs::read(dir.join("scene.json")).unwrap()
}

/// `replay SESSION --serve tcp://127.0.0.1:0 --wait WAIT --speed SPEED`, and the
/// address it listens on. Its output is drained, so its closing summary never meets a
/// closed pipe.
pub fn serve_tcp(name: &str, speed: f64, wait: Duration) -> (ChildGuard, String) {
    let mut child = ChildGuard::spawn(
        Command::new(&bins().replay)
            .arg(session_log(name))
            .args(["--serve", "tcp://127.0.0.1:0", "-q"])
            .args(["--wait", &wait.as_secs().to_string()])
            .args(["--speed", &speed.to_string()])
            .stdout(Stdio::piped()),
    );
    let mut stdout = BufReader::new(child.0.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    std::thread::spawn(move || std::io::copy(&mut stdout, &mut std::io::sink()));
    let addr = line
        .trim()
        .strip_prefix("listening on tcp://")
        .unwrap_or_else(|| panic!("replay said {line:?}"))
        .to_string();
    (child, addr)
}
