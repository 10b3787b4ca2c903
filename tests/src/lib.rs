//! # tests
//!
//! End-to-end tests that cross crate boundaries live in `tests/tests/`. This library
//! holds only helpers shared by those tests: where the shipped data lives, and
//! replaying a shipped session through the library pipeline.
//!
//! ```
//! let dir = tests::sessions_dir();
//! assert!(dir.join("patch-carve.poselog").exists());
//! ```

use std::path::PathBuf;

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
