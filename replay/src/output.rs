//! Writing a replay's outcome into its output directory.
//!
//! | file | what | deterministic |
//! |---|---|---|
//! | `scene.json` | the final document (`wandsculpt-document` JSON) | yes |
//! | `scene.obj`, `scene.stl`, `scene.glb`, `scene.ply` | the sculpted mesh at final detail; OBJ, GLB and PLY with the painted vertex colours once anything is painted ([`sculpt_core::paint`]) | yes |
//! | `scene.igs` | IGES 5.3: every NURBS surface (targets and stroke surfaces) | yes |
//! | `operator.log` | the operator event log (`wandsculpt-oplog` JSON lines) | yes |
//! | `metrics.json` | [`Metrics`](crate::pipeline::Metrics) | yes |
//! | `timing.json` | [`Timing`](crate::pipeline::Timing): wall-clock apply times, speed | no |

use std::path::{Path, PathBuf};

use sculpt_core::formats::{MeshFormat, iges};
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;

use crate::error::{Error, Result};
use crate::pipeline::Outcome;

/// Files that must come out byte-identical from identical inputs.
pub const DETERMINISTIC_FILES: &[&str] = &[
    "scene.json",
    "scene.obj",
    "scene.stl",
    "scene.glb",
    "scene.ply",
    "scene.igs",
    "operator.log",
    "metrics.json",
];

/// Vertices closer than this (metres) are welded in the exported meshes.
pub const WELD_TOLERANCE: f32 = sculpt_core::tolerance::EXPORT_WELD_EPS;

/// Writes every output file into `dir` (created if needed); returns the paths.
///
/// Every file is built in memory first and the set is then written atomically
/// ([`fsio::write_all_atomic`]: temporary files in `dir`, fsync, rename), so a failure
/// (a full disk, an export error) leaves no new or partial file. The one exception
/// keeps the work: when the sculpting layer fails to tessellate the final mesh,
/// `scene.json` alone is written (atomically) and the error names it.
pub fn write_outputs(outcome: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
    vr_app::session::create_output_dir(dir).map_err(|source| Error::Io {
        path: dir.display().to_string(),
        source,
    })?;
    let doc = &outcome.document;
    let scene = doc.to_json();
    let welded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        doc.mesh(Detail::Final).welded(WELD_TOLERANCE)
    }));
    let Ok(mut welded) = welded else {
        let written = dir.join("scene.json");
        fsio::write_atomic(&written, &scene)?;
        return Err(Error::Tessellation { written });
    };
    // Solid targets' meshes beside the surfaces' (issue 35).
    doc.append_solid_meshes(&mut welded);
    let mut files: Vec<(&str, Vec<u8>)> = vec![("scene.json", scene)];
    let colours = doc.vertex_colours(&welded, sculpt_core::paint::UNPAINTED);
    for (name, format) in [
        ("scene.obj", MeshFormat::Obj),
        ("scene.stl", MeshFormat::Stl),
        ("scene.glb", MeshFormat::Glb),
    ] {
        let bytes = format
            .write_coloured(&welded, colours.as_deref())
            .map_err(|source| Error::Export { file: name, source })?;
        files.push((name, bytes));
    }
    let ply = sculpt_core::formats::ply::write(&welded, colours.as_deref()).map_err(|source| {
        Error::Export {
            file: "scene.ply",
            source,
        }
    })?;
    files.push(("scene.ply", ply));
    let iges =
        iges::write(&DocumentView::new().iges_surfaces(doc)).map_err(|source| Error::Export {
            file: "scene.igs",
            source,
        })?;
    files.push(("scene.igs", iges));
    files.push(("operator.log", outcome.oplog.clone()));
    files.push(("metrics.json", pretty(&outcome.metrics)?.into_bytes()));
    files.push(("timing.json", pretty(&outcome.timing)?.into_bytes()));
    let files: Vec<(PathBuf, Vec<u8>)> = files
        .into_iter()
        .map(|(name, bytes)| (dir.join(name), bytes))
        .collect();
    fsio::write_all_atomic(&files)?;
    Ok(files.into_iter().map(|(path, _)| path).collect())
}

/// Pretty JSON with a final newline.
fn pretty<T: serde::Serialize>(value: &T) -> Result<String> {
    let mut s = serde_json::to_string_pretty(value).map_err(Error::Encode)?;
    s.push('\n');
    Ok(s)
}
