//! Shared input and output: files or stdin (`-`), surface JSON, numeric CSV lines.
//! Every output file is written atomically through [`fsio`]: a failed run (a full
//! disk) leaves no partial or new file.

use std::io::{self, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::volume::{Volume, VolumeError};

/// Largest input `read_input` reads (bytes, 1 GiB). A larger file is refused from its
/// size before it is read, and stdin is cut there, so memory is bounded by this cap.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Reads a whole input: the file at `path`, or stdin when `path` is `-`, at most
/// [`MAX_INPUT_BYTES`].
pub fn read_input(path: &Path) -> Result<String> {
    let bytes = if path == Path::new("-") {
        let mut bytes = Vec::new();
        io::stdin()
            .take(MAX_INPUT_BYTES + 1)
            .read_to_end(&mut bytes)
            .context("<stdin>: cannot read")?;
        if bytes.len() as u64 > MAX_INPUT_BYTES {
            bail!("<stdin>: more than the {MAX_INPUT_BYTES} bytes an input may have");
        }
        bytes
    } else {
        fsio::read_capped(path, MAX_INPUT_BYTES)?
    };
    String::from_utf8(bytes).with_context(|| format!("{}: not UTF-8 text", display_name(path)))
}

/// Fails when more than one input is stdin (`-`): stdin can be read only once.
pub fn check_one_stdin(paths: &[&Path]) -> Result<()> {
    if paths.iter().filter(|p| **p == Path::new("-")).count() > 1 {
        bail!("only one input can be read from stdin ('-')");
    }
    Ok(())
}

/// The name used in messages for an input path.
pub fn display_name(path: &Path) -> String {
    if path == Path::new("-") {
        "<stdin>".to_string()
    } else {
        path.display().to_string()
    }
}

/// Reads a surface in the JSON schema of `sculpt_core::nurbs`; errors name the file
/// and, for text that is not JSON or not the schema, the line and column; a surface
/// the schema allows but that is invalid names the entry instead (knots in which
/// direction, control point `[i][j]`).
pub fn read_surface(path: &Path) -> Result<NurbsSurface> {
    let text = read_input(path)?;
    NurbsSurface::from_json(&text).map_err(|e| match e {
        sculpt_core::Error::Json(json) => {
            let msg = json.to_string();
            // serde_json appends " at line L column C"; we put the position in front.
            let msg = msg.split(" at line ").next().unwrap_or(&msg).to_string();
            anyhow::anyhow!(
                "{}:{}:{}: invalid surface: {msg}",
                display_name(path),
                json.line(),
                json.column()
            )
        }
        e => anyhow::anyhow!("{}: invalid surface: {e}", display_name(path)),
    })
}

/// Reads a volume file; errors name the file (and for JSON errors the line and column).
pub fn read_volume(path: &Path) -> Result<Volume> {
    let text = read_input(path)?;
    Volume::from_json(&text).map_err(|e| match e {
        VolumeError::Json(json) => {
            let msg = json.to_string();
            let msg = msg.split(" at line ").next().unwrap_or(&msg).to_string();
            anyhow::anyhow!(
                "{}:{}:{}: invalid volume: {msg}",
                display_name(path),
                json.line(),
                json.column()
            )
        }
        e => anyhow::anyhow!("{}: invalid volume: {e}", display_name(path)),
    })
}

/// Parses CSV lines of exactly `N` finite numbers. Blank lines and lines starting with
/// `#` are skipped, and so is a first line that is exactly the column `header`
/// (e.g. `u,v`). Errors name the file and the 1-based line.
pub fn read_rows<const N: usize>(path: &Path, header: &str) -> Result<Vec<[f64; N]>> {
    let text = read_input(path)?;
    let name = display_name(path);
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if rows.is_empty() && line.replace(' ', "").eq_ignore_ascii_case(header) {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != N {
            bail!(
                "{name}:{}: expected {N} comma-separated numbers ({header}), found {} fields",
                i + 1,
                fields.len()
            );
        }
        let mut row = [0.0; N];
        for (slot, field) in row.iter_mut().zip(&fields) {
            let value: f64 = field.parse().map_err(|_| {
                anyhow::anyhow!("{name}:{}: {} is not a number", i + 1, quote(field))
            })?;
            if !value.is_finite() {
                bail!("{name}:{}: {} is not a finite number", i + 1, quote(field));
            }
            *slot = value;
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The most characters of input an error message quotes.
pub const QUOTE_MAX_CHARS: usize = 40;

/// Input quoted for an error message: `'text'`, cut to its first [`QUOTE_MAX_CHARS`]
/// characters (`'text...' (N bytes)`) so a 200 MB line never becomes a 200 MB message.
pub fn quote(text: &str) -> String {
    match text.char_indices().nth(QUOTE_MAX_CHARS) {
        None => format!("'{text}'"),
        Some((cut, _)) => format!("'{}...' ({} bytes)", &text[..cut], text.len()),
    }
}

/// An output: a file written atomically ([`fsio::AtomicFile`]: it appears whole when
/// [`finish_output`] commits it, and not at all if the run fails first), or stdout.
#[derive(Debug)]
pub enum Output {
    /// A file, committed by [`finish_output`].
    File(fsio::AtomicFile),
    /// Standard output.
    Stdout(BufWriter<io::StdoutLock<'static>>),
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Self::File(f) => f.write(buf),
            Self::Stdout(w) => w.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Self::File(f) => f.flush(),
            Self::Stdout(w) => w.flush(),
        }
    }
}

/// The output: the file `out` (written atomically), or stdout.
pub fn open_output(out: Option<&PathBuf>) -> Result<Output> {
    Ok(match out {
        Some(path) => Output::File(fsio::AtomicFile::create(path)?),
        None => Output::Stdout(BufWriter::new(io::stdout().lock())),
    })
}

/// Writes a whole output file atomically (temporary file, fsync, rename): on failure
/// (a full disk) nothing new is left and the error names the file.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(fsio::write_atomic(path, bytes)?)
}

/// Writes one CSV line of numbers (shortest round-trip formatting).
pub fn write_row(out: &mut dyn Write, values: &[f64]) -> io::Result<()> {
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            out.write_all(b",")?;
        }
        write!(out, "{v}")?;
    }
    out.write_all(b"\n")
}

/// Finishes the output: a file is synced and renamed into place, stdout flushed;
/// errors name the output.
pub fn finish_output(out: Output, name: Option<&PathBuf>) -> Result<()> {
    match out {
        Output::File(f) => Ok(f.commit()?),
        Output::Stdout(mut w) => w.flush().with_context(|| match name {
            Some(p) => format!("{}: cannot write", p.display()),
            None => "<stdout>: cannot write".to_string(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Regression (issue 15, item 7): a 200 MB CSV line gave a 200 MB error message,
    /// quoting the whole field. The quote is now cut to a short prefix with the size.
    #[test]
    fn a_huge_csv_field_is_quoted_by_a_short_prefix() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.csv");
        let field = "9".repeat(5 << 20) + "x";
        std::fs::write(&path, format!("{field},1\n")).unwrap();
        let msg = read_rows::<2>(&path, "u,v").unwrap_err().to_string();
        assert!(msg.len() < 200, "{} bytes of message", msg.len());
        assert!(msg.contains("huge.csv:1:"), "{msg}");
        assert!(msg.contains(&format!("({} bytes)", field.len())), "{msg}");
        assert_eq!(quote("1.5e"), "'1.5e'");
    }

    fn parse<const N: usize>(text: &str) -> Result<Vec<[f64; N]>> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.csv");
        std::fs::write(&path, text).unwrap();
        read_rows::<N>(&path, "x,y,z")
    }

    #[test]
    fn header_comments_and_blank_lines() {
        let rows = parse::<3>("x,y,z\n# c\n\n1,2,3\n 4 , 5 ,6 \n").unwrap();
        assert_eq!(rows, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        let err = parse::<3>("1,2,3\nx,y,z\n").unwrap_err().to_string();
        assert!(err.contains(":2: 'x' is not a number"), "{err}");
    }

    proptest! {
        /// Any text gives rows of finite numbers or a one-line error naming a line.
        #[test]
        fn csv_reader_never_panics(text in "[-0-9.,eEnaif# \\n]{0,120}") {
            match parse::<3>(&text) {
                Ok(rows) => prop_assert!(rows.iter().flatten().all(|v| v.is_finite())),
                Err(e) => {
                    let msg = format!("{e:#}");
                    prop_assert!(!msg.contains('\n'));
                    prop_assert!(msg.contains("in.csv:"));
                }
            }
        }
    }
}
