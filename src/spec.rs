//! Problem files: TOML into typed structs, with errors that point into the file.
//!
//! Every problem kind deserializes its file into plain structs marked
//! `#[serde(deny_unknown_fields)]`, then checks value ranges in a `validate` step. Both kinds of
//! error reach the user as one line naming `file:line:col`:
//! - serde errors (syntax, unknown key, wrong type, missing key) carry a byte span from the toml
//!   parser; unknown keys get the closest valid key as a suggestion;
//! - range errors from `validate` name a key path (`["solver", "tolerance"]`), which
//!   [`Source::error_at`] maps back to the key's position with the toml parser's spans.
//!
//! The shared `[solver]` table (a [`crate::solver::Options`], checked by [`validate_solver`]) is
//! accepted by every kind; a `[global]` table
//! ([`GlobalSpec`]) asks for a global method around the local solver.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

use crate::error::InputError;
use crate::solver::Options;

pub mod arrays;
mod check;
mod global;
pub mod overrides;
pub mod tagged;
pub use check::{is_positive, short};
pub use global::{GlobalMethodName, GlobalSpec};

/// A problem file's text, kept to point errors found after parsing back into the file.
#[derive(Debug, Clone)]
pub struct Source {
    /// The path as the user gave it.
    pub path: PathBuf,
    /// The whole file.
    pub text: String,
}

/// One step of a key path: a table key or an array index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key<'a> {
    /// A key in a table.
    Name(&'a str),
    /// An element of an array (also of an array of tables, `[[link]]`).
    Index(usize),
}

impl<'a> From<&'a str> for Key<'a> {
    fn from(name: &'a str) -> Self {
        Key::Name(name)
    }
}

impl From<usize> for Key<'_> {
    fn from(index: usize) -> Self {
        Key::Index(index)
    }
}

impl Source {
    /// Reads a problem file; a missing or unreadable file is an [`InputError`].
    pub fn read(path: &Path) -> Result<Self, InputError> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            let why = match e.kind() {
                std::io::ErrorKind::NotFound => "no such file".to_string(),
                std::io::ErrorKind::InvalidData => "not UTF-8 text".to_string(),
                _ => e.to_string(),
            };
            InputError::whole_file(path, format!("cannot read problem file: {why}"))
        })?;
        Ok(Source {
            path: path.to_path_buf(),
            text,
        })
    }

    /// Deserializes the whole file into `T`, mapping toml/serde errors to positioned messages;
    /// then rejects every float that is not finite, wherever it sits (`check`).
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T, InputError> {
        let (parsed, inside) =
            tagged::with_document(&self.text, || toml::from_str::<T>(&self.text));
        let parsed = parsed.map_err(|e| self.translate(&e, inside))?;
        check::reject_non_finite(self)?;
        Ok(parsed)
    }

    /// An error positioned at the key at `path` (its name), or at the closest enclosing table
    /// that exists in the file when the key itself is absent (a default value was used).
    pub fn error_at(&self, path: &[Key<'_>], message: impl Into<String>) -> InputError {
        let offset = self.key_offset(path).unwrap_or(0);
        InputError::at_offset(&self.path, &self.text, offset, message)
    }

    /// Byte offset of the deepest existing element along `path`.
    fn key_offset(&self, path: &[Key<'_>]) -> Option<usize> {
        let root = toml::de::DeTable::parse(&self.text).ok()?;
        let mut offset = None;
        let mut table = Some(root.get_ref());
        let mut array: Option<&toml::de::DeArray<'_>> = None;
        for key in path {
            let value = match (*key, table, array) {
                (Key::Name(name), Some(t), _) => {
                    let (k, v) = t.get_key_value(name)?;
                    offset = Some(k.span().start);
                    v
                }
                (Key::Index(i), _, Some(a)) => {
                    let v = a.get(i)?;
                    offset = Some(v.span().start);
                    v
                }
                _ => break,
            };
            table = value.get_ref().as_table();
            array = value.get_ref().as_array();
        }
        offset
    }

    /// A toml/serde error as a positioned message; `inside` is the error of a tagged table
    /// ([`tagged`]), positioned inside the table where `e` can only point at the table.
    fn translate(&self, e: &toml::de::Error, inside: Option<tagged::Located>) -> InputError {
        let offset = match inside {
            Some(l) if l.message == e.message() => l.span.start,
            _ => e.span().map_or(0, |s| s.start),
        };
        let message = tidy_message(e.message());
        InputError::at_offset(&self.path, &self.text, offset, message)
    }
}

/// Turns serde's messages into short sentences; unknown keys get a "did you mean" hint.
fn tidy_message(raw: &str) -> String {
    let raw = raw.trim().trim_end_matches('.');
    if let Some((key, valid)) = unknown_key(raw) {
        return match closest(key, &valid) {
            Some(best) => format!("unknown key `{key}`; did you mean `{best}`?"),
            None if valid.is_empty() => format!("unknown key `{key}`"),
            None => format!("unknown key `{key}`; valid keys: {}", valid.join(", ")),
        };
    }
    if let Some(rest) = raw.strip_prefix("missing field `") {
        return format!("missing key `{}", rest);
    }
    raw.replace("invalid type: ", "wrong type: found ")
        .replace('\n', " ")
}

/// The unknown key and the valid ones, from serde's message ("unknown field `k`, expected one
/// of `a`, `b`") or toml's for a table read as an enum variant ("unexpected keys in table: k,
/// available keys: a, b").
fn unknown_key(raw: &str) -> Option<(&str, Vec<&str>)> {
    if let Some(rest) = raw.strip_prefix("unknown field `") {
        let (key, expected) = rest.split_once('`')?;
        return Some((key, expected.split('`').skip(1).step_by(2).collect()));
    }
    let rest = raw.strip_prefix("unexpected keys in table: ")?;
    let (keys, valid) = rest.split_once(", available keys: ")?;
    let key = keys.split(", ").next()?;
    Some((key, valid.split(", ").filter(|k| !k.is_empty()).collect()))
}

/// The valid key nearest to `key` by edit distance, if it is plausibly a typo.
fn closest<'a>(key: &str, valid: &[&'a str]) -> Option<&'a str> {
    valid
        .iter()
        .map(|v| (edit_distance(key, v), *v))
        .filter(|(d, v)| *d <= (v.len().max(key.len()) / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, v)| v)
}

/// Levenshtein distance over characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitution = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitution.min(row[j] + 1).min(row[j + 1] + 1);
        }
    }
    row[b.len()]
}

/// Checks a `[solver]` table ([`Options::validate`]); `path` is where the table sits in the
/// file (usually `["solver"]`), so that a range error points at the offending key.
pub fn validate_solver(
    options: &Options,
    source: &Source,
    path: &[Key<'_>],
) -> Result<(), InputError> {
    options.validate().map_err(|e| {
        let mut p = path.to_vec();
        p.push(Key::Name(e.key));
        source.error_at(&p, e.message)
    })
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    use super::*;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct File {
        name: String,
        #[serde(default)]
        solver: Options,
    }

    fn source(text: &str) -> Source {
        Source {
            path: PathBuf::from("p.toml"),
            text: text.to_string(),
        }
    }

    #[test]
    fn unknown_key_suggests_the_closest() {
        let e = source("name = \"a\"\n[solver]\ntolerence = 1e-6\n")
            .parse::<File>()
            .unwrap_err();
        assert_eq!(e.position, Some((3, 1)));
        assert!(
            e.message.contains("did you mean `tolerance`"),
            "{}",
            e.message
        );
    }

    #[test]
    fn wrong_type_is_positioned() {
        let e = source("name = 3\n").parse::<File>().unwrap_err();
        assert_eq!(e.position.map(|p| p.0), Some(1));
        assert!(e.message.contains("wrong type"), "{}", e.message);
    }

    #[test]
    fn range_error_points_at_the_key() {
        let s = source("name = \"a\"\n\n[solver]\nmax_time = -1.0\n");
        let f: File = s.parse().unwrap();
        let e = validate_solver(&f.solver, &s, &[Key::Name("solver")]).unwrap_err();
        assert_eq!(e.position, Some((4, 1)));
        assert!(e.to_string().starts_with("p.toml:4:1: `max_time`"), "{e}");
    }

    #[test]
    fn edit_distance_is_levenshtein() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
    }
}
