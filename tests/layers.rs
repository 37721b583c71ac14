//! The crate's modules import one another without cycles (`docs/architecture.md`, "Layers"):
//! every `crate::`, `super::` and `self::` path of each file in `src/`, doc links included
//! (tests and plain comments left out), is resolved to the module it names, and the graph of
//! those imports must have no cycle other than between a module and its own child.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
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

/// The module path of a file (`src/a/b.rs` and `src/a/b/mod.rs` are `a::b`; `lib.rs` is "").
fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts.join("::")
}

/// The text of a file without its test module and plain comments (doc comments stay: their
/// links name modules too).
fn code_of(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .map(|l| match l.find("//") {
            Some(at) if !l[at..].starts_with("///") && !l[at..].starts_with("//!") => &l[..at],
            _ => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The paths a file's code names from the crate's root, `super::` and `self::` spelled out.
fn crate_paths(module: &str, code: &str) -> Vec<String> {
    let parts: Vec<&str> = module.split("::").filter(|p| !p.is_empty()).collect();
    let up = |n: usize| parts[..parts.len().saturating_sub(n)].join("::");
    let code = code
        .replace("super::super::", &format!("crate::{}::", up(2)))
        .replace("super::", &format!("crate::{}::", up(1)))
        .replace("self::", &format!("crate::{module}::"))
        .replace("crate::::", "crate::");
    let mut paths = Vec::new();
    let mut rest = code.as_str();
    while let Some(at) = rest.find("crate::") {
        rest = &rest[at + "crate::".len()..];
        paths.extend(expand(rest));
    }
    paths
}

/// The paths starting at `text` (just after `crate::`): `a::b`, or each item of a group
/// `a::{b, c::{d, e}}`.
fn expand(text: &str) -> Vec<String> {
    let head: String = text
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
        .collect();
    let head = head.trim_end_matches(':').to_string();
    let after = &text[head.len()..].trim_start_matches(':');
    if !after.starts_with('{') {
        return vec![head];
    }
    let mut depth = 0;
    let mut item = String::new();
    let mut items = Vec::new();
    for c in after[1..].chars() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => items.push(std::mem::take(&mut item)),
            _ => {}
        }
        if !(c == ',' && depth == 0) {
            item.push(c);
        }
    }
    items.push(item);
    let prefix = |p: String| {
        if head.is_empty() {
            p
        } else {
            format!("{head}::{p}")
        }
    };
    let mut out: Vec<String> = (!head.is_empty())
        .then(|| head.clone())
        .into_iter()
        .collect();
    for item in items {
        let item = item.trim();
        if !item.is_empty() && item != "self" {
            out.extend(expand(item).into_iter().map(prefix));
        }
    }
    out
}

/// The longest module of `modules` that `path` starts with.
fn resolve<'a>(modules: &'a BTreeSet<String>, path: &str) -> Option<&'a String> {
    let parts: Vec<&str> = path.split("::").collect();
    (1..=parts.len())
        .rev()
        .find_map(|k| modules.get(&parts[..k].join("::")))
}

/// The modules of each strongly connected component of `edges` with more than one module.
fn cycles(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    let reach = |from: &String| {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(m) = stack.pop() {
            for next in &edges[&m] {
                if seen.insert(next.clone()) {
                    stack.push(next.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, BTreeSet<String>> =
        edges.keys().map(|m| (m, reach(m))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for m in edges.keys() {
        if done.contains(m) {
            continue;
        }
        let component: Vec<String> = reached[m]
            .iter()
            .filter(|other| *other != m && reached[*other].contains(m))
            .cloned()
            .collect();
        if !component.is_empty() {
            let mut all = component;
            all.push(m.clone());
            all.sort();
            done.extend(all.iter().cloned());
            out.push(all);
        }
    }
    out
}

fn is_parent_and_child(a: &str, b: &str) -> bool {
    a.starts_with(&format!("{b}::")) || b.starts_with(&format!("{a}::"))
}

#[test]
fn modules_import_without_cycles() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeSet<String> = files.iter().map(|f| module_of(&src, f)).collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in &files {
        let module = module_of(&src, file);
        let code = code_of(&std::fs::read_to_string(file).unwrap());
        let targets = crate_paths(&module, &code)
            .iter()
            .filter_map(|p| resolve(&modules, p).cloned())
            .filter(|t| *t != module)
            .collect();
        edges.insert(module, targets);
    }
    // The check must be able to fail: the graph sees these known imports.
    assert!(edges["render"].contains("vertex"), "{:?}", edges["render"]);
    assert!(edges["accel::tribvh"].contains("geometry"));
    let bad: Vec<Vec<String>> = cycles(&edges)
        .into_iter()
        .filter(|c| !(c.len() == 2 && is_parent_and_child(&c[0], &c[1])))
        .collect();
    assert!(bad.is_empty(), "import cycles: {bad:#?}");
}

#[test]
fn a_cycle_is_found() {
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (a, b) in [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")] {
        edges.entry(a.into()).or_default().insert(b.into());
        edges.entry(b.into()).or_default();
    }
    assert_eq!(cycles(&edges), vec![vec!["a", "b", "c"]]);
    assert_eq!(
        crate_paths("x::y", "use super::z::{P, q::{R, S}};"),
        vec!["x::z", "x::z::P", "x::z::q", "x::z::q::R", "x::z::q::S"]
    );
}
