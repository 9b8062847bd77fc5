//! The crate's shape, checked on its source: the top-level modules import each other without a
//! circle, and no function outside tests is longer than 150 lines (docs/architecture.md).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Longest function allowed outside tests, in lines from `fn` to its closing brace.
const LONGEST_FUNCTION: usize = 150;

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).expect("readable src/") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// The source with comments, string and character literals blanked (newlines kept), so braces
/// and paths can be counted on what is code.
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |ch: char| if ch == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            loop {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
        } else if c[i] == 'r' && matches!(next, Some('"') | Some('#')) && is_raw_start(&c, i) {
            let hashes = c[i + 1..].iter().take_while(|&&h| h == '#').count();
            i += 2 + hashes;
            out.push_str(&" ".repeat(2 + hashes));
            let closes = |j: usize| c[j] == '"' && (1..=hashes).all(|h| c.get(j + h) == Some(&'#'));
            while !closes(i) {
                out.push(blank(c[i]));
                i += 1;
            }
            out.push_str(&" ".repeat(1 + hashes));
            i += 1 + hashes;
        } else if c[i] == '"' {
            out.push(' ');
            i += 1;
            while c[i] != '"' {
                let step = if c[i] == '\\' { 2 } else { 1 };
                for k in 0..step {
                    out.push(blank(c[i + k]));
                }
                i += step;
            }
            out.push(' ');
            i += 1;
        } else if c[i] == '\'' && is_char_literal(&c, i) {
            let len = if next == Some('\\') {
                c[i + 2..].iter().position(|&q| q == '\'').expect("closed") + 3
            } else {
                3
            };
            out.push_str(&" ".repeat(len));
            i += len;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// Whether `r` at `i` opens a raw string (`r"` or `r#…"`), not an identifier ending in r.
fn is_raw_start(c: &[char], i: usize) -> bool {
    let after_ident = i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_');
    let hashes = c[i + 1..].iter().take_while(|&&h| h == '#').count();
    !after_ident && c.get(i + 1 + hashes) == Some(&'"')
}

/// Whether `'` at `i` opens a character literal (`'x'`, `'\n'`) rather than a lifetime.
fn is_char_literal(c: &[char], i: usize) -> bool {
    c.get(i + 1) == Some(&'\\') || c.get(i + 2) == Some(&'\'')
}

/// The part of a file before its inline `#[cfg(test)] mod tests { … }` (by convention at the
/// end; a `#[cfg(test)] mod name;` declaring a test file does not end it).
fn before_tests(code: &str) -> &str {
    let inline = code.match_indices("#[cfg(test)]").find(|(i, _)| {
        let rest = code[i + 12..].trim_start();
        let line = rest.lines().next().unwrap_or("");
        rest.starts_with("mod ") && line.contains('{')
    });
    inline.map_or(code, |(i, _)| &code[..i])
}

/// Files that are test modules declared with `#[cfg(test)] mod name;`.
fn test_module_files(files: &[(PathBuf, String)]) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    for (path, code) in files {
        let dir = if path
            .file_name()
            .is_some_and(|f| f == "mod.rs" || f == "lib.rs")
        {
            path.parent().expect("parent").to_path_buf()
        } else {
            path.with_extension("")
        };
        let words: Vec<&str> = code.split_whitespace().collect();
        for w in words.windows(3) {
            if w[0] == "#[cfg(test)]" && w[1] == "mod" && w[2].ends_with(';') {
                let name = w[2].trim_end_matches(';');
                out.insert(dir.join(format!("{name}.rs")));
                out.insert(dir.join(name).join("mod.rs"));
            }
        }
    }
    out
}

fn sources() -> Vec<(PathBuf, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    rust_files(&src)
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).expect("readable source");
            (p, code_only(&text))
        })
        .collect()
}

/// `(lines, name, line number)` of every function in `code`, outside its tests.
fn function_lengths(code: &str) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = before_tests(code).lines().collect();
    let mut out = Vec::new();
    for (start, line) in lines.iter().enumerate() {
        let words: Vec<&str> = line
            .split(|c: char| !c.is_alphanumeric() && c != '_')
            .collect();
        let Some(at) = words.iter().position(|&w| w == "fn") else {
            continue;
        };
        let Some(name) = words[at + 1..].iter().find(|w| !w.is_empty()) else {
            continue;
        };
        let (mut depth, mut opened) = (0i64, false);
        for (end, body) in lines[start..].iter().enumerate() {
            for ch in body.chars() {
                match ch {
                    '{' => (depth, opened) = (depth + 1, true),
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            if opened && depth <= 0 || !opened && body.trim_end().ends_with(';') {
                out.push((end + 1, name.to_string(), start + 1));
                break;
            }
        }
    }
    out
}

#[test]
fn no_function_outside_tests_is_longer_than_the_limit() {
    let files = sources();
    let tests = test_module_files(&files);
    let mut long = Vec::new();
    let mut counted = 0;
    for (path, code) in files.iter().filter(|(p, _)| !tests.contains(p)) {
        for (len, name, line) in function_lengths(code) {
            counted += 1;
            if len > LONGEST_FUNCTION {
                long.push(format!("{}:{line} {name}: {len} lines", path.display()));
            }
        }
    }
    assert!(
        counted > 500,
        "only {counted} functions found: the scan is broken"
    );
    assert!(
        long.is_empty(),
        "longer than {LONGEST_FUNCTION} lines:\n{}",
        long.join("\n")
    );
}

#[test]
fn the_scan_measures_functions_and_skips_literals() {
    let code = code_only(
        "fn a() {\n    let s = \"{ not a brace\";\n    let c = '{';\n    // }\n}\nfn b<'x>(v: &'x u8) -> u8 {\n    *v\n}\n",
    );
    let lengths = function_lengths(&code);
    assert_eq!(lengths, vec![(5, "a".into(), 1), (3, "b".into(), 6)]);
}

/// Top-level module of a source file (`src/gait/sim.rs` → `gait`).
fn top_module(src: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(src).expect("under src/");
    let first = rel.components().next().expect("a component");
    let name = first.as_os_str().to_string_lossy();
    name.trim_end_matches(".rs").to_string()
}

#[test]
fn top_level_modules_import_each_other_without_a_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (path, code) in sources() {
        let from = top_module(&src, &path);
        let code = before_tests(&code);
        for (i, _) in code.match_indices("crate::") {
            let to: String = code[i + 7..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if to != from && !to.is_empty() {
                graph.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    assert!(
        graph.len() >= 8,
        "only {} modules import others",
        graph.len()
    );
    // Depth-first search for a back edge.
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = path.iter().position(|p| p == node) {
            let mut circle = path[at..].to_vec();
            circle.push(node.to_string());
            return Some(circle);
        }
        if done.contains(node) {
            return None;
        }
        path.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(circle) = visit(next, graph, path, done) {
                return Some(circle);
            }
        }
        path.pop();
        done.insert(node.to_string());
        None
    }
    let mut done = BTreeSet::new();
    for node in graph.keys() {
        let circle = visit(node, &graph, &mut Vec::new(), &mut done);
        assert!(
            circle.is_none(),
            "module circle: {}",
            circle.unwrap().join(" → ")
        );
    }
}
