//! `make-sessions DIR`: (re)generates the shipped session library
//! (`tests/data/sessions/*.poselog` and its `README.md` index) deterministically from
//! `replay::sessions`. `make-sessions --check DIR` exits non-zero when a shipped file
//! differs from what the generator writes today.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("make-sessions: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let mut check = false;
    let mut dir = None;
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--check" => check = true,
            "-h" | "--help" => {
                println!("usage: make-sessions [--check] DIR");
                return Ok(());
            }
            _ if dir.is_none() => dir = Some(PathBuf::from(arg)),
            _ => bail!("unexpected argument {arg:?} (usage: make-sessions [--check] DIR)"),
        }
    }
    let dir = dir.context("usage: make-sessions [--check] DIR")?;
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut stale = Vec::new();
    let mut files = replay::sessions::render_all()?;
    files.push((
        "README.md".into(),
        replay::sessions::index_markdown().into_bytes(),
    ));
    for (name, bytes) in files {
        let path = dir.join(&name);
        if check {
            if std::fs::read(&path).ok().as_deref() != Some(&bytes[..]) {
                stale.push(name);
            }
        } else {
            fsio::write_atomic(&path, &bytes)?;
            println!("{} ({} bytes)", path.display(), bytes.len());
        }
    }
    if !stale.is_empty() {
        bail!(
            "out of date: {} (run make-sessions {})",
            stale.join(", "),
            dir.display()
        );
    }
    Ok(())
}
