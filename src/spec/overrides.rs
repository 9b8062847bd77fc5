//! `--set key.path=value`: command-line overrides of problem-file values, applied to the file's
//! text before it is parsed, so that an overridden value is deserialized and validated exactly
//! like one written in the file.
//!
//! Each override is a splice of the text: an existing `key = value` is rewritten in place; a key
//! the file does not have is inserted into its table (after the table's header, inside an
//! inline table's braces, at the top of the file for a root key, or under a new header at the
//! end for a table the file only implies). The value's type comes from TOML syntax
//! (`--set solver.max_iterations=300` is an integer, `=3.0` a float, `=[0, 1]` an array); a
//! bare word that is not a TOML value (`--set solver.qp=sparse`) is taken as a string.
//!
//! [`Edited::relocate`] maps an error positioned in the edited text back to the file: an
//! error inside a splice names the `--set` argument instead of a line and column
//! (`--set shape.resoluton=8: unknown key `resoluton`; did you mean `resolution`?`); any other
//! position is moved back to the file's own line and column.

use std::path::Path;

use toml::de::{DeTable, DeValue};

use super::Source;
use crate::error::{InputError, line_col};

/// One `--set key.path=value` argument, parsed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Override {
    /// The argument as given, e.g. `shape.resolution=8`.
    pub argument: String,
    /// The key path's steps (`shape`, `resolution`); a number indexes an array.
    keys: Vec<String>,
    /// The value as TOML text (a bare word quoted as a string).
    value: String,
}

impl std::str::FromStr for Override {
    type Err = String;

    /// Parses `key.path=value`; the message says what is malformed.
    fn from_str(argument: &str) -> Result<Self, String> {
        let (path, value) = argument
            .split_once('=')
            .ok_or("expected key.path=value, e.g. solver.max_iterations=300")?;
        let keys: Vec<String> = path.trim().split('.').map(str::to_string).collect();
        let bare = |k: &String| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        };
        if let Some(bad) = keys.iter().find(|k| !bare(k)) {
            return Err(format!(
                "`{bad}` is not a key: keys are letters, digits, `_` and `-`, joined by `.`"
            ));
        }
        Ok(Override {
            argument: argument.to_string(),
            keys,
            value: toml_value(value.trim())?,
        })
    }
}

impl Override {
    /// How errors inside this override's splice are labelled: `--set key.path=value`.
    pub fn label(&self) -> String {
        format!("--set {}", self.argument)
    }
}

/// `text` as a TOML value: itself when it is one, quoted when it is a bare word.
fn toml_value(text: &str) -> Result<String, String> {
    if toml::from_str::<toml::Table>(&format!("v = {text}")).is_ok() {
        return Ok(text.to_string());
    }
    let word = text.starts_with(|c: char| c.is_alphabetic())
        && text
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | '/'));
    if word {
        Ok(toml::Value::String(text.to_string()).to_string())
    } else {
        Err(format!(
            "`{text}` is not a TOML value (strings with spaces or symbols need quotes: '\"…\"')"
        ))
    }
}

/// A problem file's text with overrides spliced in, and the map back to the file.
#[derive(Debug, Clone)]
pub struct Edited {
    /// The edited file: parse and validate this.
    pub source: Source,
    /// The file as written.
    original: String,
    /// The splices in the order they were made, each in the text as it was then.
    splices: Vec<Splice>,
}

/// `removed` bytes at `at` replaced by `inserted` bytes, for the override labelled `label`;
/// `new_key` is the first key it added to its table, if it added one.
#[derive(Debug, Clone)]
struct Splice {
    at: usize,
    removed: usize,
    inserted: usize,
    label: String,
    new_key: Option<String>,
}

/// Applies `overrides` in order (a later one wins over an earlier one of the same key). A key
/// path that cannot be placed (through a value that is not a table, past an array's end, or a
/// table given a plain value) is an error naming the `--set` argument.
pub fn apply(source: Source, overrides: &[Override]) -> Result<Edited, InputError> {
    let mut edited = Edited {
        original: source.text.clone(),
        source,
        splices: Vec::new(),
    };
    for o in overrides {
        let fail = |message: String| InputError::whole_file(Path::new(&o.label()), message);
        let text = &edited.source.text;
        // A file that does not parse is reported, positioned, by the kind's own parse.
        let Ok(root) = DeTable::parse(text) else {
            return Ok(edited);
        };
        let (at, removed, insert, new_key) = place(text, root.get_ref(), o).map_err(fail)?;
        let mut text = text.clone();
        text.replace_range(at..at + removed, &insert);
        edited.source.text = text;
        edited.splices.push(Splice {
            at,
            removed,
            inserted: insert.len(),
            label: o.label(),
            new_key,
        });
    }
    Ok(edited)
}

/// Where `o` goes in `text`: the byte offset, the bytes it replaces, the text it inserts and
/// the key it adds to a table (if it adds one).
type Placement = (usize, usize, String, Option<String>);

fn place(text: &str, root: &DeTable<'_>, o: &Override) -> Result<Placement, String> {
    let mut table = root;
    let mut table_span: Option<std::ops::Range<usize>> = None;
    let mut walked: Vec<&str> = Vec::new();
    let mut keys = o.keys.iter().map(String::as_str).peekable();
    while let Some(key) = keys.next() {
        let Some((k, v)) = table.get_key_value(key) else {
            // The rest of the path is new: insert it into the deepest existing table.
            let rest: Vec<&str> = std::iter::once(key).chain(keys).collect();
            return insert(text, table_span, &walked, &rest, &o.value)
                .map(|(at, removed, line)| (at, removed, line, Some(key.to_string())));
        };
        walked.push(key);
        let mut value = v;
        let mut start = k.span().start;
        // Array steps: `link.0.mass`.
        while let DeValue::Array(items) = value.get_ref() {
            let Some(index) = keys.peek().and_then(|s| s.parse::<usize>().ok()) else {
                break;
            };
            keys.next();
            value = items.get(index).ok_or_else(|| {
                format!(
                    "`{}` has {} element(s), numbered from 0",
                    walked.join("."),
                    items.len()
                )
            })?;
            walked.push(o.keys[walked.len()].as_str());
            start = value.span().start;
        }
        if keys.peek().is_none() {
            return replace(text, value, start, walked.len(), o)
                .map(|(at, removed, line)| (at, removed, line, None));
        }
        match value.get_ref() {
            DeValue::Table(t) => {
                table = t;
                table_span = Some(value.span());
            }
            _ => return Err(format!("`{}` is not a table", walked.join("."))),
        }
    }
    Err("empty key path".into())
}

/// Replaces an existing value (from its key, `start`, to the value's end) by the override's.
fn replace(
    text: &str,
    value: &toml::Spanned<DeValue<'_>>,
    start: usize,
    depth: usize,
    o: &Override,
) -> Result<(usize, usize, String), String> {
    let span = value.span();
    let written_as_header = |v: &toml::Spanned<DeValue<'_>>| {
        matches!(v.get_ref(), DeValue::Table(_)) && !text[v.span()].starts_with('{')
    };
    let table_of_headers = match value.get_ref() {
        DeValue::Array(items) => items.iter().any(written_as_header),
        _ => written_as_header(value),
    };
    if table_of_headers {
        let path = o.keys.join(".");
        return Err(format!(
            "`{path}` is a table: set its keys ({path}.KEY=VALUE)"
        ));
    }
    let is_element = o.keys[depth - 1].parse::<usize>().is_ok() && start == span.start;
    let key_text = if is_element {
        String::new()
    } else {
        format!("{} = ", o.keys[depth - 1])
    };
    Ok((start, span.end - start, format!("{key_text}{}", o.value)))
}

/// Inserts `rest = value` into the table at `table_span` (the root when `None`), whose path
/// from the root is `walked`.
fn insert(
    text: &str,
    table_span: Option<std::ops::Range<usize>>,
    walked: &[&str],
    rest: &[&str],
    value: &str,
) -> Result<(usize, usize, String), String> {
    if let Some(index) = rest.iter().find(|k| k.parse::<usize>().is_ok()) {
        return Err(format!(
            "no element {index} to set in `{}`",
            walked.join(".")
        ));
    }
    let line = format!("{} = {value}", rest.join("."));
    let newline = if text.ends_with('\n') { "" } else { "\n" };
    let Some(span) = table_span else {
        // A root key at the top; a new table under its own header at the end (a dotted key
        // at the top would define the table, and a later `--set` into it could not add a
        // header for it).
        return Ok(match rest.split_last() {
            Some((last, tables)) if !tables.is_empty() => (
                text.len(),
                0,
                format!("{newline}[{}]\n{last} = {value}\n", tables.join(".")),
            ),
            _ => (0, 0, format!("{line}\n")),
        });
    };
    let opening = &text[span.clone()];
    if opening.starts_with('{') {
        let empty = opening[1..opening.len() - 1].trim().is_empty();
        let separator = if empty { " " } else { ", " };
        return Ok((span.start + 1, 0, format!(" {line}{separator}")));
    }
    if opening.starts_with('[') {
        // After the header line `[table]` / `[[array]]`.
        return Ok(match text[span.end..].find('\n') {
            Some(i) => (span.end + i + 1, 0, format!("{line}\n")),
            None => (text.len(), 0, format!("\n{line}\n")),
        });
    }
    // A table the file only implies (by a sub-table's header or dotted keys): its own header.
    if walked.iter().any(|k| k.parse::<usize>().is_ok()) {
        return Err(format!(
            "cannot add a key to `{}` from the command line; write it in the file",
            walked.join(".")
        ));
    }
    let header = format!("{newline}[{}]\n{line}\n", walked.join("."));
    let dotted = format!("{}.{line}\n", walked.join("."));
    // A table defined by dotted keys (`solver.qp = …` at the root) cannot take a header; a
    // dotted key at the top of the file adds to it.
    let parses = |at: usize, insert: &str| {
        let mut edited = text.to_string();
        edited.insert_str(at, insert);
        DeTable::parse(&edited).is_ok()
    };
    if !parses(text.len(), &header) && parses(0, &dotted) {
        return Ok((0, 0, dotted));
    }
    Ok((text.len(), 0, header))
}

impl Edited {
    /// `error` as the user should see it: positions in the edited text moved back to the file,
    /// an error inside a splice, or about an unknown key a splice added (which some tables
    /// report at the table, not the key), naming its `--set` argument. Other errors pass
    /// unchanged.
    pub fn relocate(&self, error: InputError) -> InputError {
        let Some((line, col)) = error.position else {
            return error;
        };
        if self.splices.is_empty() || error.file != self.source.path {
            return error;
        }
        let added = |s: &&Splice| {
            s.new_key
                .as_ref()
                .is_some_and(|k| error.message.starts_with(&format!("unknown key `{k}`")))
        };
        if let Some(s) = self.splices.iter().rev().find(added) {
            return InputError::whole_file(Path::new(&s.label), error.message);
        }
        let mut offset = offset_of(&self.source.text, line, col);
        for s in self.splices.iter().rev() {
            if offset >= s.at + s.inserted {
                offset = offset - s.inserted + s.removed;
            } else if offset >= s.at && s.inserted > 0 {
                return InputError::whole_file(Path::new(&s.label), error.message);
            }
        }
        let (line, col) = line_col(&self.original, offset);
        InputError {
            position: Some((line, col)),
            ..error
        }
    }
}

/// Byte offset of 1-based `line` and character `col` in `text` (the inverse of [`line_col`]).
fn offset_of(text: &str, line: usize, col: usize) -> usize {
    let line_start: usize = text
        .split_inclusive('\n')
        .take(line - 1)
        .map(str::len)
        .sum();
    text[line_start..]
        .char_indices()
        .nth(col - 1)
        .map_or(text.len(), |(i, _)| line_start + i)
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    fn edit(text: &str, args: &[&str]) -> Result<String, String> {
        let overrides: Vec<Override> = args.iter().map(|a| a.parse().unwrap()).collect();
        let source = Source {
            path: PathBuf::from("p.toml"),
            text: text.to_string(),
        };
        apply(source, &overrides)
            .map(|e| e.source.text)
            .map_err(|e| e.to_string())
    }

    const FILE: &str = "name = \"a\"\n[solver]\nmax_iterations = 3\n[[link]]\nm = 1\nt = { a = 1 }\n[x.y]\nz = 1\n";

    fn parsed(text: &str) -> toml::Table {
        toml::from_str(text).unwrap_or_else(|e| panic!("{e}\n{text}"))
    }

    #[test]
    fn values_replace_or_join_their_table() {
        let t = parsed(
            &edit(
                FILE,
                &[
                    "solver.max_iterations=300",
                    "solver.qp=sparse",
                    "link.0.m=2.5",
                    "link.0.t.b=[1, 2]",
                    "x.w=true",
                    "seed=4",
                    "x.y.z=-1",
                ],
            )
            .unwrap(),
        );
        assert_eq!(t["solver"]["max_iterations"].as_integer(), Some(300));
        assert_eq!(t["solver"]["qp"].as_str(), Some("sparse"));
        assert_eq!(t["link"][0]["m"].as_float(), Some(2.5));
        assert_eq!(t["link"][0]["t"]["a"].as_integer(), Some(1));
        assert_eq!(t["link"][0]["t"]["b"].as_array().map(Vec::len), Some(2));
        assert_eq!(t["x"]["w"].as_bool(), Some(true));
        assert_eq!(t["x"]["y"]["z"].as_integer(), Some(-1));
        assert_eq!(t["seed"].as_integer(), Some(4));
    }

    #[test]
    fn a_missing_table_is_created_and_a_later_override_wins() {
        let t = parsed(&edit("name = \"a\"\n", &["solver.tolerance=1e-3", "name=b"]).unwrap());
        assert_eq!(t["solver"]["tolerance"].as_float(), Some(1e-3));
        assert_eq!(t["name"].as_str(), Some("b"));
        let t = parsed(&edit("g = [0, -9.81, 0]\n", &["g.1=-1.6", "g.1=-3.7"]).unwrap());
        assert_eq!(t["g"][1].as_float(), Some(-3.7));
    }

    #[test]
    fn several_keys_join_a_table_the_file_lacks_or_defines_by_dotted_keys() {
        let args = [
            "solver.qp=sparse",
            "solver.hessian=lbfgs",
            "a.b.c=1",
            "a.b.d=2",
        ];
        let t = parsed(&edit("name = \"a\"\n[[link]]\nm = 1\n", &args).unwrap());
        assert_eq!(t["solver"]["qp"].as_str(), Some("sparse"));
        assert_eq!(t["solver"]["hessian"].as_str(), Some("lbfgs"));
        assert_eq!(t["a"]["b"]["d"].as_integer(), Some(2));
        assert_eq!(t["link"][0]["m"].as_integer(), Some(1));
        let t = parsed(&edit("solver.qp = \"dense\"\n[x]\n", &["solver.hessian=exact"]).unwrap());
        assert_eq!(t["solver"]["qp"].as_str(), Some("dense"));
        assert_eq!(t["solver"]["hessian"].as_str(), Some("exact"));
    }

    #[test]
    fn impossible_paths_name_the_argument() {
        for (arg, message) in [
            ("name.x=1", "--set name.x=1: `name` is not a table"),
            ("link.3.m=1", "--set link.3.m=1: `link` has 1 element(s)"),
            ("solver=1", "--set solver=1: `solver` is a table"),
        ] {
            let e = edit(FILE, &[arg]).unwrap_err();
            assert!(e.starts_with(message), "{e}");
        }
        assert!("solver".parse::<Override>().is_err());
        assert!("a..b=1".parse::<Override>().is_err());
        assert!("a=[1,".parse::<Override>().is_err());
    }

    #[test]
    fn errors_are_relocated_to_the_file_or_the_argument() {
        let source = Source {
            path: PathBuf::from("p.toml"),
            text: "name = \"a\"\n[solver]\nmax_iterations = 3\nbad = 1\n".into(),
        };
        let set: Override = "zeta=1".parse().unwrap();
        let edited = apply(source, &[set]).unwrap();
        // `zeta = 1` went in as a new first line: line 5 of the edited text is line 4 of the file.
        let at = |line, col| InputError {
            file: PathBuf::from("p.toml"),
            position: Some((line, col)),
            message: "m".into(),
        };
        assert_eq!(edited.relocate(at(5, 1)).to_string(), "p.toml:4:1: m");
        assert_eq!(edited.relocate(at(1, 3)).to_string(), "--set zeta=1: m");
    }
}
