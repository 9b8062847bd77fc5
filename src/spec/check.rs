//! The shared validation vocabulary: range checks that name a key path and point at it.
//!
//! Every problem kind validates its parsed file with these checks, so one kind of mistake reads
//! the same in every file: `` `margin` must be ≥ 0, got -1 `` at the key's `file:line:col`.
//! Each check takes the key path of the value ([`Key`] steps from the file's root); the message
//! names the path's last key. Two more checks run on the raw document before deserializing
//! ([`reject_non_finite`]): every float must be finite, wherever it sits.
//!
//! Sizes derived from the input (joints a ground structure would generate, integration steps,
//! mesh faces) are bounded before any work or allocation with [`Source::within_limit`], whose
//! message names the key, the estimate and the limit.

use toml::de::{DeTable, DeValue};

use super::{Key, Source};
use crate::error::InputError;

/// `v > 0` and finite.
pub fn is_positive(v: f64) -> bool {
    v > 0.0 && v.is_finite()
}

/// The last table key along `path` (the name a message quotes).
fn key_name<'a>(path: &[Key<'a>]) -> &'a str {
    path.iter()
        .rev()
        .find_map(|k| match k {
            Key::Name(n) => Some(*n),
            Key::Index(_) => None,
        })
        .unwrap_or("value")
}

impl Source {
    /// `v` must be finite (not NaN, not ±∞).
    pub fn finite(&self, path: &[Key<'_>], v: f64) -> Result<(), InputError> {
        if v.is_finite() {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(path, format!("`{key}` must be finite, got {v}")))
    }

    /// Every element of `vs` must be finite.
    pub fn finite_all(&self, path: &[Key<'_>], vs: &[f64]) -> Result<(), InputError> {
        vs.iter().try_for_each(|v| self.finite(path, *v))
    }

    /// `ok` must hold, or the error is `message` at `path`: the check the named ones reduce
    /// to, for conditions they do not cover.
    pub fn ensure(
        &self,
        path: &[Key<'_>],
        ok: bool,
        message: impl FnOnce() -> String,
    ) -> Result<(), InputError> {
        if ok {
            return Ok(());
        }
        Err(self.error_at(path, message()))
    }

    /// Every element of `vs` must be finite; the message names the key only (a vector).
    pub fn finite_vector(&self, path: &[Key<'_>], vs: &[f64]) -> Result<(), InputError> {
        let key = key_name(path);
        self.ensure(path, vs.iter().all(|v| v.is_finite()), || {
            format!("`{key}` must be finite")
        })
    }

    /// `v` must be positive and finite, a quantity in `unit` (`` `mass` must be positive kg ``).
    pub fn positive_quantity(
        &self,
        path: &[Key<'_>],
        v: f64,
        unit: &str,
    ) -> Result<(), InputError> {
        let key = key_name(path);
        self.ensure(path, is_positive(v), || {
            format!("`{key}` must be positive {unit}, got {v}")
        })
    }

    /// `[lo, hi]` must be finite with `lo < hi`.
    pub fn ordered_pair(&self, path: &[Key<'_>], [lo, hi]: [f64; 2]) -> Result<(), InputError> {
        let key = key_name(path);
        self.ensure(path, lo < hi && lo.is_finite() && hi.is_finite(), || {
            format!("`{key}` must be finite with lower < upper, got [{lo}, {hi}]")
        })
    }

    /// `v` must be positive and finite.
    pub fn positive(&self, path: &[Key<'_>], v: f64) -> Result<(), InputError> {
        if is_positive(v) {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(
            path,
            format!("`{key}` must be positive and finite, got {v}"),
        ))
    }

    /// `v` must be finite and ≥ 0.
    pub fn non_negative(&self, path: &[Key<'_>], v: f64) -> Result<(), InputError> {
        if v.is_finite() && v >= 0.0 {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(path, format!("`{key}` must be ≥ 0, got {v}")))
    }

    /// `v` must lie in the closed interval `[lo, hi]`.
    pub fn in_range(&self, path: &[Key<'_>], v: f64, lo: f64, hi: f64) -> Result<(), InputError> {
        if (lo..=hi).contains(&v) {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(path, format!("`{key}` must be in [{lo}, {hi}], got {v}")))
    }

    /// A count must be at least `min`.
    pub fn at_least(&self, path: &[Key<'_>], n: usize, min: usize) -> Result<(), InputError> {
        if n >= min {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(path, format!("`{key}` must be at least {min}")))
    }

    /// A count must lie in `lo..=hi`.
    pub fn count_in(
        &self,
        path: &[Key<'_>],
        n: usize,
        lo: usize,
        hi: usize,
    ) -> Result<(), InputError> {
        if (lo..=hi).contains(&n) {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(
            path,
            format!("`{key}` must be between {lo} and {hi}, got {n}"),
        ))
    }

    /// A size derived from the input (`estimate` `what`, computed in floating point so it
    /// cannot overflow) must not exceed `limit`; checked before the work is done or the memory
    /// allocated. NaN estimates are over every limit.
    pub fn within_limit(
        &self,
        path: &[Key<'_>],
        estimate: f64,
        limit: f64,
        what: &str,
    ) -> Result<(), InputError> {
        if estimate <= limit {
            return Ok(());
        }
        let key = key_name(path);
        Err(self.error_at(
            path,
            format!(
                "`{key}` would generate {} {what}; limit {}",
                short(estimate),
                short(limit)
            ),
        ))
    }
}

/// A number in short scientific form: `8e18`, `1.5e6`, `inf`.
pub fn short(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let s = format!("{x:.1e}");
    s.replace(".0e", "e")
}

/// Rejects every float in the document that is NaN or infinite (`nan`, `inf`, or a literal too
/// large for f64 such as `1e999`), positioned at the value and naming its key.
pub fn reject_non_finite(source: &Source) -> Result<(), InputError> {
    let Ok(root) = DeTable::parse(&source.text) else {
        // Syntax errors are reported, positioned, by the deserializer.
        return Ok(());
    };
    walk_table(source, root.get_ref())
}

fn walk_table(source: &Source, table: &DeTable<'_>) -> Result<(), InputError> {
    for (key, value) in table.iter() {
        walk_value(source, value, key.get_ref())?;
    }
    Ok(())
}

fn walk_value(
    source: &Source,
    value: &toml::Spanned<DeValue<'_>>,
    name: &str,
) -> Result<(), InputError> {
    match value.get_ref() {
        DeValue::Float(f) => {
            let x: f64 = f.as_str().replace('_', "").parse().unwrap_or(f64::NAN);
            if x.is_finite() {
                Ok(())
            } else {
                Err(InputError::at_offset(
                    &source.path,
                    &source.text,
                    value.span().start,
                    format!("`{name}` must be finite, got {}", f.as_str()),
                ))
            }
        }
        DeValue::Array(items) => items
            .iter()
            .try_for_each(|item| walk_value(source, item, name)),
        DeValue::Table(t) => walk_table(source, t),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    fn source(text: &str) -> Source {
        Source {
            path: PathBuf::from("p.toml"),
            text: text.to_string(),
        }
    }

    #[test]
    fn non_finite_floats_are_rejected_at_their_value() {
        for bad in ["nan", "+inf", "-inf", "1e999"] {
            let s = source(&format!("a = 1.0\n[t]\nxs = [[0.0, {bad}]]\n"));
            let e = reject_non_finite(&s).unwrap_err();
            assert_eq!(e.position, Some((3, 13)), "{bad}: {e}");
            assert!(e.message.starts_with("`xs` must be finite"), "{e}");
        }
        assert!(reject_non_finite(&source("a = 1.5e300\nb = -0.0\n")).is_ok());
    }

    #[test]
    fn checks_name_the_last_key_and_point_at_it() {
        let s = source("[ground]\nmargin = -1.0\n");
        let path = [Key::Name("ground"), Key::Name("margin")];
        let e = s.non_negative(&path, -1.0).unwrap_err();
        assert_eq!(e.to_string(), "p.toml:2:1: `margin` must be ≥ 0, got -1");
        assert!(s.positive(&path, f64::NAN).is_err());
        assert!(s.positive(&path, 1.0).is_ok());
        assert!(s.in_range(&path, 0.5, 0.0, 1.0).is_ok());
        assert!(s.in_range(&path, f64::NAN, 0.0, 1.0).is_err());
        let e = s
            .within_limit(&path, 8e18, 1e6, "candidate joints")
            .unwrap_err();
        assert_eq!(
            e.message,
            "`margin` would generate 8e18 candidate joints; limit 1e6"
        );
        assert!(s.within_limit(&path, f64::NAN, 1e6, "joints").is_err());
        let e = s.positive_quantity(&path, 0.0, "kg").unwrap_err();
        assert_eq!(e.message, "`margin` must be positive kg, got 0");
        let e = s.ordered_pair(&path, [1.0, 0.5]).unwrap_err();
        assert_eq!(
            e.message,
            "`margin` must be finite with lower < upper, got [1, 0.5]"
        );
        assert!(s.ordered_pair(&path, [0.0, f64::INFINITY]).is_err());
        assert!(s.ordered_pair(&path, [-1.0, 1.0]).is_ok());
        let e = s.finite_vector(&path, &[0.0, f64::NAN]).unwrap_err();
        assert_eq!(e.message, "`margin` must be finite");
    }
}
