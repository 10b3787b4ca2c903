//! `sculpt-tools export`: write a scene's NURBS surfaces as IGES 5.3 (targets as trimmed
//! surfaces, entity 144; stroke surfaces as entity 128).

use super::mesh::load_scene;
use crate::progress::Progress;
use anyhow::{Context, Result, bail};
use clap::Args;
use sculpt_core::formats::iges;
use sculpt_core::sculpt::view::DocumentView;
use std::path::PathBuf;

/// Arguments of `export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Scene or document file (wandsculpt-document JSON).
    #[arg(long)]
    pub scene: PathBuf,
    /// Output file: `.igs` or `.iges`.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `export`.
pub fn run(args: ExportArgs) -> Result<()> {
    let ext = args
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("igs" | "iges")) {
        bail!("--out must end in .igs or .iges: {}", args.out.display());
    }
    let mut progress = Progress::new("export", 0);
    progress.set_message("reading the scene");
    let doc = load_scene(&args.scene)?;
    progress.set_message("building trimmed surfaces");
    let surfaces = DocumentView::new().iges_surfaces(&doc);
    progress.set_message("writing IGES");
    let bytes = iges::write(&surfaces).context("writing IGES")?;
    super::io::write_file(&args.out, &bytes)?;
    progress.finish();
    let trimmed = surfaces.iter().filter(|s| s.faces.is_some()).count();
    println!(
        "{}: {} surfaces ({} trimmed), {} bytes",
        args.out.display(),
        surfaces.len(),
        trimmed,
        bytes.len()
    );
    Ok(())
}
