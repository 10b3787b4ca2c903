//! Guard: tolerances are named constants of a tolerance module, not literals:
//! `sculpt_core::tolerance` for the workspace, and a crate's own `src/tolerance.rs`
//! for the tolerances only that crate (its code and tests) uses.
//!
//! Scans every `.rs` file of the workspace (outside `target/` and the crates'
//! tolerance modules) for float literals with a negative exponent (`1e-9`, `5e-3`, `0.5e-3`), the
//! form epsilons take, in code (comments are not code). A line may keep one only when
//! it says why the number is not a tolerance, in a comment `// not a tolerance:
//! <reason>` (a test input, a unit conversion) at its end or on the comment line just
//! above it, or when its file is on [`ALLOWED_FILES`] below. Physical parameters (widths, spacings, defaults) are
//! written in decimal (`0.001`) and named where they belong.

use std::path::{Path, PathBuf};

/// The marker a line carries to keep a negative-exponent literal that is no tolerance.
const MARKER: &str = "not a tolerance:";

/// Files allowed to keep such literals for now, each with the reason.
const ALLOWED_FILES: &[(&str, &str)] = &[];

/// Byte ranges of `line` that are code: the line up to its `//` comment, if any
/// (a `//` inside a string literal does not start a comment).
fn code_part(line: &str) -> (&str, &str) {
    let bytes = line.as_bytes();
    let mut in_str = false;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'\\' if in_str => i += 1,
            b'"' => in_str = !in_str,
            b'/' if !in_str && bytes.get(i + 1) == Some(&b'/') => {
                return (&line[..i], &line[i..]);
            }
            _ => {}
        }
        i += 1;
    }
    (line, "")
}

/// The negative-exponent float literals in `code`, as written.
fn negative_exponent_literals(code: &str) -> Vec<&str> {
    let b = code.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts_number = b[i].is_ascii_digit()
            && (i == 0
                || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'.'));
        if !starts_number {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'_' || b[i] == b'.') {
            i += 1;
        }
        if i < b.len()
            && (b[i] == b'e' || b[i] == b'E')
            && b.get(i + 1) == Some(&b'-')
            && b.get(i + 2).is_some_and(u8::is_ascii_digit)
        {
            i += 2;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            found.push(&code[start..i]);
        }
    }
    found
}

/// `file:line: literal` for each offending line of `text`.
fn offences(rel: &str, text: &str) -> Vec<String> {
    let marked = |comment: &str| {
        comment
            .find(MARKER)
            .is_some_and(|k| !comment[k + MARKER.len()..].trim().is_empty())
    };
    let mut out = Vec::new();
    let mut marked_above = false;
    for (n, line) in text.lines().enumerate() {
        let (code, comment) = code_part(line);
        let lits = negative_exponent_literals(code);
        if !lits.is_empty() && !marked_above && !marked(comment) {
            out.push(format!("{rel}:{}: {}", n + 1, lits.join(", ")));
        }
        marked_above = code.trim().is_empty() && marked(comment);
    }
    out
}

/// True for a crate's own tolerance module, `<crate>/src/tolerance.rs` (a directory
/// holding a `Cargo.toml`): `sculpt_core::tolerance` and, next to their users, the
/// tolerances a crate alone uses (`tracking::tolerance`). A `tolerance.rs` anywhere
/// else is scanned like any file.
fn is_tolerance_module(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n == "tolerance.rs")
        && path
            .parent()
            .filter(|src| src.file_name().is_some_and(|n| n == "src"))
            .and_then(Path::parent)
            .is_some_and(|krate| krate.join("Cargo.toml").is_file())
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if path.is_dir() {
            if name != "target" && !name.starts_with('.') {
                rust_files(&path, out);
            }
        } else if name.ends_with(".rs") && !is_tolerance_module(&path) {
            out.push(path);
        }
    }
}

#[test]
fn no_literal_tolerances_outside_the_tolerance_module() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let mut files = Vec::new();
    rust_files(root, &mut files);
    files.sort();
    assert!(
        files.len() > 50,
        "the scan found only {} files under {}",
        files.len(),
        root.display()
    );
    let mut bad = Vec::new();
    for path in &files {
        let rel = path
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if ALLOWED_FILES.iter().any(|(f, _)| *f == rel) {
            continue;
        }
        let text = std::fs::read_to_string(path).unwrap();
        bad.extend(offences(&rel, &text));
    }
    assert!(
        bad.is_empty(),
        "literal tolerances: name them in sculpt_core::tolerance (or mark a line that \
         is no tolerance with `// {MARKER} <reason>`):\n{}",
        bad.join("\n")
    );
}

/// Each crate's `src/tolerance.rs` is a tolerance module; one elsewhere is not.
#[test]
fn each_crate_may_keep_its_own_tolerance_module() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    for krate in ["sculpt-core", "tracking"] {
        let module = root.join(krate).join("src/tolerance.rs");
        assert!(module.is_file(), "{}", module.display());
        assert!(is_tolerance_module(&module), "{}", module.display());
    }
    assert!(!is_tolerance_module(
        &root.join("sculpt-core/src/sculpt/tolerance.rs")
    ));
    assert!(!is_tolerance_module(&root.join("tolerance.rs")));
}

#[test]
fn the_scan_finds_literals_in_code_only() {
    // Built at run time so this file holds no such literal itself.
    let lit = |m: &str, e: u32| format!("{m}e-{e}");
    let line = format!("    assert!(d < {});", lit("1", 9));
    assert_eq!(
        offences("x.rs", &line),
        vec![format!("x.rs:1: {}", lit("1", 9))]
    );
    let line = format!("let t = {} * w + {}f64;", lit("0.5", 3), lit("2", 4));
    assert_eq!(
        negative_exponent_literals(&line),
        [lit("0.5", 3), lit("2", 4) + "f64"]
    );
    // Comments, identifiers, positive exponents and marked lines are not offences.
    let quiet = [
        format!("// below {}", lit("1", 9)),
        format!("/// below {}", lit("1", 9)),
        "let x = POINT_EPS + v2e3 + 1e9;".to_string(),
        format!("let h = {}; // {MARKER} a test input", lit("1", 7)),
        format!("let s = \"//\"; let h = 0.5; // {}", lit("1", 3)),
    ];
    for q in &quiet {
        assert!(offences("x.rs", q).is_empty(), "{q}");
    }
    // A marker on the comment line above counts, for that line only.
    let text = format!(
        "// {MARKER} a test input\nlet h = {};\nlet k = {};",
        lit("1", 7),
        lit("1", 8)
    );
    assert_eq!(
        offences("x.rs", &text),
        vec![format!("x.rs:3: {}", lit("1", 8))]
    );
    // A marker without a reason does not count.
    let line = format!("let h = {}; // {MARKER}", lit("1", 7));
    assert_eq!(offences("x.rs", &line).len(), 1);
    // A literal after a string holding `//` is still code.
    let line = format!("let s = \"a//b\"; let e = {};", lit("1", 6));
    assert_eq!(offences("x.rs", &line).len(), 1);
}
