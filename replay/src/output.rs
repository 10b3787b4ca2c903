//! Writing a replay's outcome into its output directory.
//!
//! | file | what | deterministic |
//! |---|---|---|
//! | `scene.json` | the final document (`wandsculpt-document` JSON) | yes |
//! | `scene.obj`, `scene.stl`, `scene.glb` | the sculpted mesh at final detail | yes |
//! | `scene.igs` | IGES 5.3: every NURBS surface (targets and stroke surfaces) | yes |
//! | `operator.log` | the operator event log (`wandsculpt-oplog` JSON lines) | yes |
//! | `metrics.json` | [`Metrics`](crate::pipeline::Metrics) | yes |
//! | `timing.json` | [`Timing`](crate::pipeline::Timing): wall-clock apply times, speed | no |

use std::path::{Path, PathBuf};

use sculpt_core::formats::{MeshFormat, iges};
use sculpt_core::sculpt::tessellate::Detail;

use crate::error::{Error, Result};
use crate::pipeline::Outcome;

/// Files that must come out byte-identical from identical inputs.
pub const DETERMINISTIC_FILES: &[&str] = &[
    "scene.json",
    "scene.obj",
    "scene.stl",
    "scene.glb",
    "scene.igs",
    "operator.log",
    "metrics.json",
];

/// Vertices closer than this (metres) are welded in the exported meshes.
pub const WELD_TOLERANCE: f32 = sculpt_core::tolerance::EXPORT_WELD_EPS;

fn write(dir: &Path, name: &str, bytes: &[u8], out: &mut Vec<PathBuf>) -> Result<()> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    out.push(path);
    Ok(())
}

/// Writes every output file into `dir` (created if needed); returns the paths.
pub fn write_outputs(outcome: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
    vr_app::session::create_output_dir(dir).map_err(|source| Error::Io {
        path: dir.display().to_string(),
        source,
    })?;
    let mut files = Vec::new();
    let doc = &outcome.document;
    write(dir, "scene.json", &doc.to_json(), &mut files)?;
    // scene.json is already on disk: a failure in the sculpting layer's tessellation
    // loses no work and is reported as an error, not a crash.
    let welded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        doc.mesh(Detail::Final).welded(WELD_TOLERANCE)
    }))
    .map_err(|_| Error::Tessellation {
        written: dir.join("scene.json"),
    })?;
    for (name, format) in [
        ("scene.obj", MeshFormat::Obj),
        ("scene.stl", MeshFormat::Stl),
        ("scene.glb", MeshFormat::Glb),
    ] {
        let bytes = format
            .write(&welded)
            .map_err(|source| Error::Export { file: name, source })?;
        write(dir, name, &bytes, &mut files)?;
    }
    let iges = iges::write(&doc.iges_surfaces()).map_err(|source| Error::Export {
        file: "scene.igs",
        source,
    })?;
    write(dir, "scene.igs", &iges, &mut files)?;
    write(dir, "operator.log", &outcome.oplog, &mut files)?;
    write(
        dir,
        "metrics.json",
        pretty(&outcome.metrics)?.as_bytes(),
        &mut files,
    )?;
    write(
        dir,
        "timing.json",
        pretty(&outcome.timing)?.as_bytes(),
        &mut files,
    )?;
    Ok(files)
}

/// Pretty JSON with a final newline.
fn pretty<T: serde::Serialize>(value: &T) -> Result<String> {
    let mut s = serde_json::to_string_pretty(value).map_err(Error::Encode)?;
    s.push('\n');
    Ok(s)
}
