//! Fixed-length arrays in problem files hold exactly their length.
//!
//! serde reads a `[T; N]` by taking its first N elements and ignores any more, so
//! `gravity = [0, -9.81, 0, 5]` would pass for `[0, -9.81, 0]`. Fields of fixed length name one
//! of these functions in `#[serde(deserialize_with = ...)]`; a wrong length is a positioned
//! error: `expected 3 elements, found 4`.

use serde::de::{Deserialize, Deserializer, Error};

/// A `[T; N]` read from a sequence of exactly N elements.
struct Exact<T, const N: usize>([T; N]);

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Exact<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let items = Vec::<T>::deserialize(d)?;
        let found = items.len();
        items
            .try_into()
            .map(Exact)
            .map_err(|_| D::Error::custom(format!("expected {N} elements, found {found}")))
    }
}

/// `[T; N]`, exactly N elements.
pub fn exact<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Exact::deserialize(d).map(|e| e.0)
}

/// `Option<[T; N]>`, exactly N elements when present (pair with `#[serde(default)]`).
pub fn exact_opt<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<Exact<T, N>>::deserialize(d).map(|o| o.map(|e| e.0))
}

/// `Vec<[T; N]>`, every element exactly N long.
pub fn exact_vec<'de, D, T, const N: usize>(d: D) -> Result<Vec<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Vec::<Exact<T, N>>::deserialize(d).map(|v| v.into_iter().map(|e| e.0).collect())
}

/// `Option<Vec<[T; N]>>`, every element exactly N long (pair with `#[serde(default)]`).
pub fn exact_opt_vec<'de, D, T, const N: usize>(d: D) -> Result<Option<Vec<[T; N]>>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<Vec<Exact<T, N>>>::deserialize(d)
        .map(|o| o.map(|v| v.into_iter().map(|e| e.0).collect()))
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    struct File {
        #[serde(deserialize_with = "super::exact")]
        g: [f64; 3],
        #[serde(default, deserialize_with = "super::exact_opt")]
        o: Option<[f64; 2]>,
        #[serde(default, deserialize_with = "super::exact_vec")]
        v: Vec<[f64; 2]>,
    }

    #[test]
    fn extra_and_missing_elements_are_errors() {
        let ok: File = toml::from_str("g = [0, -9.81, 0]\nv = [[1, 2]]\n").unwrap();
        assert_eq!(ok.g, [0.0, -9.81, 0.0]);
        assert_eq!(ok.o, None);
        assert_eq!(ok.v, [[1.0, 2.0]]);
        for bad in [
            "g = [0, -9.81, 0, 5]",
            "g = [0, 1]",
            "g = [0, 1, 2]\no = [1, 2, 3]",
            "g = [0, 1, 2]\nv = [[1, 2], [1, 2, 3]]",
        ] {
            let e = toml::from_str::<File>(bad).unwrap_err();
            assert!(e.message().contains("elements, found"), "{bad}: {e}");
            assert!(e.span().is_some(), "{bad}");
        }
    }
}
