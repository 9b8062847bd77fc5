//! Tables whose `type` key picks the variant (`[shape]` with `type = "sphere"`), read with the
//! positions of the keys inside them.
//!
//! serde reads an internally tagged enum (`#[serde(tag = "type")]`) by first buffering the whole
//! table, to find the tag wherever it sits; the buffer holds no spans, so an unknown key, a wrong
//! type or a wrong array length inside the table would point at the table's header. Instead the
//! enum derives serde's default, externally tagged form (`{ sphere = { volume = 1.0 } }`) and the
//! field holding it names [`deserialize`] in `#[serde(deserialize_with = ...)]`. That finds the
//! table `{ type = "sphere", volume = 1.0 }` in the parsed document ([`Source::parse`] lends
//! it the file's text for the duration of the parse), moves `type` out as the outer key and
//! hands the result, every span intact, to the enum's own `Deserialize`. Its error, positioned at
//! the offending key or value (an unknown tag at the `type` value), is kept for
//! [`Source::parse`], since serde's error type cannot carry a span across the field boundary.
//! Outside a [`Source::parse`] (a plain `toml::from_str` in a test) the same retagging runs on an
//! unpositioned `toml::Value`.
//!
//! [`Source::parse`]: super::Source::parse

use std::cell::RefCell;
use std::ops::Range;

use serde::de::{DeserializeOwned, Error, IntoDeserializer};
use serde::{Deserialize, Deserializer};
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// The key naming the variant.
const TAG: &str = "type";

thread_local! {
    /// The text being parsed by [`super::Source::parse`] on this thread.
    static DOCUMENT: RefCell<Option<String>> = const { RefCell::new(None) };
    /// The positioned error of the last tagged table that failed to read on this thread.
    static ERROR: RefCell<Option<Located>> = const { RefCell::new(None) };
}

/// An error inside a tagged table: its byte span in the file and its message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Located {
    /// Bytes of the file the error is about.
    pub span: Range<usize>,
    /// What is wrong, as serde or toml says it.
    pub message: String,
}

impl Located {
    fn from_toml(e: &toml::de::Error, fallback: &Range<usize>) -> Self {
        Located {
            span: e.span().unwrap_or_else(|| fallback.clone()),
            message: e.message().to_string(),
        }
    }
}

/// Runs `parse` with `text` lent to the tagged tables it reads; returns its result and the
/// positioned error of a tagged table that failed, if any.
pub(super) fn with_document<R>(text: &str, parse: impl FnOnce() -> R) -> (R, Option<Located>) {
    DOCUMENT.with(|d| *d.borrow_mut() = Some(text.to_string()));
    ERROR.with(|e| e.borrow_mut().take());
    let result = parse();
    DOCUMENT.with(|d| d.borrow_mut().take());
    (result, ERROR.with(|e| e.borrow_mut().take()))
}

/// Reads an enum of struct variants from a table whose `type` key names the variant (see the
/// module header); for `#[serde(deserialize_with = "crate::spec::tagged::deserialize")]`.
pub fn deserialize<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: DeserializeOwned,
{
    let table = Spanned::<toml::Value>::deserialize(d)?;
    let span = table.span();
    let positioned = DOCUMENT.with(|d| {
        let text = d.borrow();
        let root = DeTable::parse(text.as_deref()?).ok()?;
        let found = find(root.get_ref(), &span)?.clone();
        Some(retag_spanned(found).and_then(|v| {
            T::deserialize(v.into_deserializer()).map_err(|e| Located::from_toml(&e, &span))
        }))
    });
    match positioned {
        Some(Ok(value)) => Ok(value),
        Some(Err(e)) => {
            let message = e.message.clone();
            ERROR.with(|slot| *slot.borrow_mut() = Some(e));
            Err(D::Error::custom(message))
        }
        None => retag(table.into_inner())
            .and_then(|v| T::deserialize(v).map_err(|e| e.message().to_string()))
            .map_err(D::Error::custom),
    }
}

/// The value spanning exactly `span` in `table`, searched depth first.
fn find<'a, 'i>(table: &'a DeTable<'i>, span: &Range<usize>) -> Option<&'a Spanned<DeValue<'i>>> {
    table.values().find_map(|v| find_in(v, span))
}

fn find_in<'a, 'i>(
    value: &'a Spanned<DeValue<'i>>,
    span: &Range<usize>,
) -> Option<&'a Spanned<DeValue<'i>>> {
    if value.span() == *span && value.get_ref().as_table().is_some() {
        return Some(value);
    }
    match value.get_ref() {
        DeValue::Table(t) => find(t, span),
        DeValue::Array(a) => a.iter().find_map(|v| find_in(v, span)),
        _ => None,
    }
}

/// `{ type = "x", k = v }` as `{ x = { k = v } }`, the tag's key spanning the tag's value.
fn retag_spanned(value: Spanned<DeValue<'_>>) -> Result<Spanned<DeValue<'_>>, Located> {
    let span = value.span();
    let not_tagged = || Located {
        span: span.clone(),
        message: format!("missing key `{TAG}`"),
    };
    let DeValue::Table(mut fields) = value.into_inner() else {
        return Err(not_tagged());
    };
    let tag = fields.remove(TAG).ok_or_else(not_tagged)?;
    let tag_span = tag.span();
    let DeValue::String(name) = tag.into_inner() else {
        return Err(Located {
            span: tag_span,
            message: format!("`{TAG}` must be a string"),
        });
    };
    let mut outer = DeTable::new();
    outer.insert(
        Spanned::new(tag_span, name),
        Spanned::new(span.clone(), DeValue::Table(fields)),
    );
    Ok(Spanned::new(span, DeValue::Table(outer)))
}

/// [`retag_spanned`] on a value without spans.
fn retag(value: toml::Value) -> Result<toml::Value, String> {
    let toml::Value::Table(mut fields) = value else {
        return Err(format!("missing key `{TAG}`"));
    };
    match fields.remove(TAG) {
        Some(toml::Value::String(name)) => {
            let mut outer = toml::Table::new();
            outer.insert(name, toml::Value::Table(fields));
            Ok(toml::Value::Table(outer))
        }
        Some(_) => Err(format!("`{TAG}` must be a string")),
        None => Err(format!("missing key `{TAG}`")),
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use serde::Deserialize;

    use super::super::Source;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(rename_all = "snake_case", deny_unknown_fields)]
    enum Shape {
        Ball {
            radius: f64,
        },
        Box {
            #[serde(deserialize_with = "crate::spec::arrays::exact")]
            size: [f64; 3],
        },
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct File {
        #[serde(deserialize_with = "super::deserialize")]
        shape: Shape,
        #[serde(default)]
        part: Vec<Part>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Part {
        #[serde(deserialize_with = "super::deserialize")]
        shape: Shape,
    }

    fn parse(text: &str) -> Result<File, crate::error::InputError> {
        Source {
            path: PathBuf::from("p.toml"),
            text: text.to_string(),
        }
        .parse()
    }

    #[test]
    fn the_tag_picks_the_variant_wherever_it_sits() {
        let f = parse("[shape]\nradius = 2.0\ntype = \"ball\"\n").unwrap();
        assert_eq!(f.shape, Shape::Ball { radius: 2.0 });
        let f = parse("shape = { type = \"box\", size = [1, 2, 3] }\n").unwrap();
        assert_eq!(
            f.shape,
            Shape::Box {
                size: [1.0, 2.0, 3.0]
            }
        );
    }

    #[test]
    fn errors_inside_point_at_their_key_or_value() {
        let header = "[shape]\ntype = \"ball\"\n";
        for (body, line, col, fragment) in [
            (
                "radius = 1.0\nbogus = 1\n",
                4,
                1,
                "unknown key `bogus`; valid keys: radius",
            ),
            (
                "radius = 1.0\nradius2 = 1\n",
                4,
                1,
                "did you mean `radius`?",
            ),
            ("radius = \"x\"\n", 3, 10, "wrong type"),
            ("radius = [1.0]\n", 3, 10, "wrong type"),
            ("", 1, 1, "missing key `radius`"),
        ] {
            let e = parse(&format!("{header}{body}")).unwrap_err();
            assert_eq!(e.position, Some((line, col)), "{body}: {e}");
            assert!(e.message.contains(fragment), "{body}: {e}");
        }
        let e = parse("[shape]\ntype = \"box\"\nsize = [1, 2, 3, 4]\n").unwrap_err();
        assert_eq!(e.position, Some((3, 8)), "{e}");
        assert!(e.message.contains("expected 3 elements, found 4"), "{e}");
        let e = parse("[shape]\ntype = \"cone\"\nradius = 1.0\n").unwrap_err();
        assert_eq!(e.position, Some((2, 8)), "{e}");
        assert!(e.message.contains("unknown variant `cone`"), "{e}");
        let e = parse("[shape]\nradius = 1.0\n").unwrap_err();
        assert_eq!(e.position.map(|p| p.0), Some(1), "{e}");
        assert!(e.message.contains("missing key `type`"), "{e}");
    }

    #[test]
    fn errors_inside_tables_of_an_array_are_positioned() {
        let text = "shape = { type = \"ball\", radius = 1.0 }\n\n[[part]]\nshape = { type = \"ball\", radius = 1.0 }\n[[part]]\nshape = { type = \"ball\", radius = 1.0, extra = 2 }\n";
        let e = parse(text).unwrap_err();
        assert_eq!(e.position, Some((6, 40)), "{e}");
        assert!(e.message.contains("unknown key `extra`"), "{e}");
    }

    #[test]
    fn without_a_source_the_tag_still_picks_the_variant() {
        let f: File = toml::from_str("[shape]\ntype = \"ball\"\nradius = 3.0\n").unwrap();
        assert_eq!(f.shape, Shape::Ball { radius: 3.0 });
        let e = toml::from_str::<File>("[shape]\ntype = \"ball\"\nradius = 3.0\nx = 1\n");
        assert!(e.unwrap_err().message().contains("unknown field `x`"));
    }
}
