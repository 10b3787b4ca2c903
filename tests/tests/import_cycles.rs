//! No import circles: within each crate of the workspace, the edges between source
//! files (`use crate::...`, `crate::...` paths in code and `super::...`) form no
//! cycle.
//!
//! Each file is a module (`src/a/b.rs` and `src/a/b/mod.rs` are `a::b`); a path
//! names the deepest module file its segments reach. A module using its own
//! descendants is structure (it declares them, re-exports from them), not an edge; a
//! descendant using its ancestor is one. Comments, doc links and `#[cfg(test)]`
//! modules are left out: only what the code itself imports counts. A shared type two
//! modules need lives in a leaf module below both (see `docs/architecture.md`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates' source roots, relative to the workspace root.
const CRATES: &[&str] = &[
    "sculpt-core/src",
    "tracking/src",
    "tracking/fsio/src",
    "vr-app/src",
    "replay/src",
    "tools/src",
];

type Module = Vec<String>;

/// Every `.rs` file under `dir` (crate roots and `src/bin` left to the caller).
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a file is, relative to the crate's `src`.
fn module_of(rel: &Path) -> Module {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !(stem == "mod" || (parts.is_empty() && (stem == "lib" || stem == "main"))) {
        parts.push(stem.to_owned());
    }
    parts
}

/// The code of a file without comments and without its `#[cfg(test)]` modules.
fn code_of(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("#[cfg(test)]")
            && lines
                .peek()
                .is_some_and(|next| next.trim_start().starts_with("mod "))
        {
            // Skip the test module: to the line closing it at its own indentation.
            let indent = lines.peek().map_or(0, |l| l.len() - l.trim_start().len());
            let close = format!("{}}}", " ".repeat(indent));
            for l in lines.by_ref() {
                if l == close {
                    break;
                }
            }
            continue;
        }
        let code = match line.find("//") {
            Some(at) => &line[..at],
            None => line,
        };
        out.push_str(code);
        out.push('\n');
    }
    out
}

/// The paths in `code` that start with `crate::` or `super::`, expanded over `use`
/// groups (`use crate::a::{b, c::d}` gives `crate::a::b` and `crate::a::c::d`), as
/// segment lists with the leading `crate` / `super`s kept.
fn paths_in(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes = code.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if !code.is_char_boundary(i) {
            i += 1;
            continue;
        }
        let rest = &code[i..];
        let at_word = i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_');
        if at_word && (rest.starts_with("crate::") || rest.starts_with("super::")) {
            let end = path_end(rest);
            expand(&rest[..end], &mut out);
            i += end.max(1);
        } else {
            i += 1;
        }
    }
    out
}

/// Where a path (with any `{...}` group) ends in `s`.
fn path_end(s: &str) -> usize {
    let mut depth = 0usize;
    for (k, c) in s.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => return k,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return k + 1;
                }
            }
            c if depth == 0 && !(c.is_alphanumeric() || c == '_' || c == ':') => return k,
            _ => {}
        }
    }
    s.len()
}

/// Expands one path with groups into plain segment lists.
fn expand(path: &str, out: &mut Vec<Vec<String>>) {
    let path: String = path.chars().filter(|c| !c.is_whitespace()).collect();
    match path.find('{') {
        None => out.push(
            path.split("::")
                .filter(|s| !s.is_empty())
                .map(str::to_owned)
                .collect(),
        ),
        Some(open) => {
            let prefix = &path[..open];
            let inner = path[open + 1..]
                .strip_suffix('}')
                .unwrap_or(&path[open + 1..]);
            let mut depth = 0usize;
            let mut start = 0;
            let mut items = Vec::new();
            for (k, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth = depth.saturating_sub(1),
                    ',' if depth == 0 => {
                        items.push(&inner[start..k]);
                        start = k + 1;
                    }
                    _ => {}
                }
            }
            items.push(&inner[start..]);
            for item in items.into_iter().filter(|i| !i.is_empty()) {
                let item = item.split(" as ").next().unwrap_or(item);
                if item == "self" {
                    expand(prefix.trim_end_matches("::"), out);
                } else {
                    expand(&format!("{prefix}{item}"), out);
                }
            }
        }
    }
}

/// The module file a path reaches from module `from`: its deepest prefix that is a
/// module of the crate.
fn resolve(from: &Module, path: &[String], modules: &BTreeSet<Module>) -> Option<Module> {
    let mut base: Module = Vec::new();
    let mut rest = path;
    match path.first().map(String::as_str) {
        Some("crate") => rest = &path[1..],
        Some("super") => {
            base = from.clone();
            while rest.first().map(String::as_str) == Some("super") {
                base.pop()?;
                rest = &rest[1..];
            }
        }
        _ => return None,
    }
    let mut reached = base.clone();
    let mut current = base;
    for seg in rest {
        current.push(seg.clone());
        if modules.contains(&current) {
            reached = current.clone();
        } else {
            break;
        }
    }
    Some(reached)
}

/// The strongly connected components with more than one module (Tarjan).
fn cycles(edges: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct State<'a> {
        edges: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on_stack: BTreeSet<&'a Module>,
        out: Vec<Vec<Module>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Module) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        let edges = s.edges;
        for w in edges.get(v).into_iter().flatten() {
            let Some((w, _)) = edges.get_key_value(w) else {
                continue;
            };
            if !s.index.contains_key(w) {
                visit(s, w);
                let low = s.low[v].min(s.low[w]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w) {
                let low = s.low[v].min(s.index[w]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.clone());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// The file-level import edges of the crate whose sources are in `src`.
fn crate_edges(src: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let has_lib = src.join("lib.rs").exists();
    let files: Vec<(Module, PathBuf)> = files
        .into_iter()
        .filter_map(|f| {
            let rel = f.strip_prefix(src).unwrap().to_path_buf();
            // Binaries use the library by its name, not `crate::`.
            if rel.starts_with("bin") || (has_lib && rel == Path::new("main.rs")) {
                return None;
            }
            Some((module_of(&rel), f))
        })
        .collect();
    let modules: BTreeSet<Module> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (from, file) in &files {
        let code = code_of(&std::fs::read_to_string(file).unwrap());
        let targets = edges.entry(from.clone()).or_default();
        for path in paths_in(&code) {
            if let Some(to) = resolve(from, &path, &modules)
                // A module's own descendants are its structure, not imports.
                && !to.starts_with(from)
            {
                targets.insert(to);
            }
        }
    }
    edges
}

fn name(m: &Module) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

#[test]
fn no_crate_has_an_import_circle_between_its_files() {
    let root = tests::workspace_root();
    let mut found = Vec::new();
    for krate in CRATES {
        let edges = crate_edges(&root.join(krate));
        assert!(edges.len() > 1, "{krate}: no modules found");
        for component in cycles(&edges) {
            let names: Vec<String> = component.iter().map(name).collect();
            let detail: Vec<String> = component
                .iter()
                .map(|m| {
                    let to: Vec<String> = edges[m]
                        .iter()
                        .filter(|t| component.contains(t))
                        .map(name)
                        .collect();
                    format!("{} -> {}", name(m), to.join(", "))
                })
                .collect();
            found.push(format!(
                "{krate}: {{{}}}: {}",
                names.join(", "),
                detail.join("; ")
            ));
        }
    }
    assert!(found.is_empty(), "import circles:\n{}", found.join("\n"));
}

/// The checker finds the circles it is for, and nothing in a chain.
#[test]
fn the_checker_finds_a_circle_through_use_and_super_edges() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("a")).unwrap();
    let files = [
        ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\n"),
        // a -> b by a grouped use, b -> c by a path in code.
        (
            "a/mod.rs",
            "pub mod inner;\nuse crate::{b::B, c};\n// use crate::c::Nothing;\n",
        ),
        ("a/inner.rs", "use super::super::b::B;\n"),
        ("b.rs", "pub struct B;\nfn f() { let _ = crate::c::C; }\n"),
        (
            "c.rs",
            "pub struct C;\n#[cfg(test)]\nmod tests {\n    use crate::a::A;\n}\n",
        ),
    ];
    for (path, text) in files {
        std::fs::write(src.join(path), text).unwrap();
    }
    let edges = crate_edges(src);
    assert!(cycles(&edges).is_empty(), "{edges:?}");
    // c -> a closes the circle a -> b -> c -> a.
    std::fs::write(src.join("c.rs"), "pub struct C;\nuse crate::a::inner;\n").unwrap();
    let edges = crate_edges(src);
    let found = cycles(&edges);
    assert_eq!(found.len(), 1, "{edges:?}");
    let names: Vec<String> = found[0].iter().map(name).collect();
    assert_eq!(names, ["a::inner", "b", "c"]);
}
