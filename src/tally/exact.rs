//! Floating-point numbers stored exactly in JSON result files
//! (`tallies.json`): written as decimal strings in Rust's shortest
//! round-trip form (`"0.123"`, `"1e-7"`), read back bit for bit, and only
//! finite ones accepted.
//!
//! [`Exact`] is the number as a value; the functions of this module and of
//! [`vec`](mod@vec) and [`opt_vec`] are the same codec for `#[serde(with = ...)]` on
//! fields of type `f64`, `Vec<f64>` and `Option<Vec<f64>>`. A value that is
//! not such a string is refused with "expected a number as a string"; a
//! string that reads as NaN or an infinity with "`x` is not a finite
//! number".
//!
//! Strings rather than JSON numbers: they are read by Rust's exact float
//! parser, so the round trip is exact without serde_json's
//! `float_roundtrip` feature (which would also change how every other JSON
//! number roks reads is parsed), and a number a file should not hold
//! (`"NaN"`) is still a value that can be named in a message.

use serde::de::{self, Deserializer, Unexpected, Visitor};
use serde::{Deserialize, Serialize, Serializer};

/// A finite float written as an exactly round-tripping decimal string.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Exact(pub f64);

impl From<f64> for Exact {
    fn from(x: f64) -> Self {
        Self(x)
    }
}

impl From<Exact> for f64 {
    fn from(x: Exact) -> Self {
        x.0
    }
}

impl Serialize for Exact {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{:?}", self.0))
    }
}

struct ExactVisitor;

impl Visitor<'_> for ExactVisitor {
    type Value = Exact;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a number as a string")
    }

    fn visit_str<E: de::Error>(self, s: &str) -> Result<Exact, E> {
        let x: f64 = s
            .parse()
            .map_err(|_| E::invalid_value(Unexpected::Str(s), &self))?;
        if !x.is_finite() {
            return Err(E::custom(format!("{x} is not a finite number")));
        }
        Ok(Exact(x))
    }
}

impl<'de> Deserialize<'de> for Exact {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_str(ExactVisitor)
    }
}

/// `#[serde(with = "exact")]` for an `f64`.
///
/// # Errors
/// As the serializer's.
pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    Exact(*x).serialize(s)
}

/// `#[serde(with = "exact")]` for an `f64`.
///
/// # Errors
/// If the value is not a finite number as a string.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Exact::deserialize(d).map(|x| x.0)
}

/// `#[serde(with = "exact::vec")]` for a `Vec<f64>`.
pub mod vec {
    use super::Exact;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Each number as [`Exact`].
    ///
    /// # Errors
    /// As the serializer's.
    pub fn serialize<S: Serializer>(xs: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(xs.iter().map(|&x| Exact(x)))
    }

    /// An array of [`Exact`] numbers.
    ///
    /// # Errors
    /// If it is not an array, or at the first element that is not a finite
    /// number as a string.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Vec::<Exact>::deserialize(d).map(|v| v.into_iter().map(|x| x.0).collect())
    }
}

/// `#[serde(with = "exact::opt_vec")]` for an `Option<Vec<f64>>` (`null`
/// for `None`).
pub mod opt_vec {
    use super::Exact;
    use serde::{Deserialize, Deserializer, Serializer};

    /// `null`, or each number as [`Exact`].
    ///
    /// # Errors
    /// As the serializer's.
    #[allow(clippy::ref_option)]
    pub fn serialize<S: Serializer>(xs: &Option<Vec<f64>>, s: S) -> Result<S::Ok, S::Error> {
        match xs {
            None => s.serialize_none(),
            Some(xs) => s.collect_seq(xs.iter().map(|&x| Exact(x))),
        }
    }

    /// `null` or an array of [`Exact`] numbers.
    ///
    /// # Errors
    /// As [`super::vec::deserialize`].
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
        Option::<Vec<Exact>>::deserialize(d)
            .map(|v| v.map(|v| v.into_iter().map(|x| x.0).collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_round_trip_bit_for_bit_as_shortest_strings() {
        for x in [0.1, 1e-7, 1.0 / 3.0, 5e-324, f64::MAX, -2.5, 0.0, 123_456.0] {
            let text = serde_json::to_string(&Exact(x)).unwrap();
            assert_eq!(text, format!("\"{x:?}\""));
            let back: Exact = serde_json::from_str(&text).unwrap();
            assert_eq!(back.0.to_bits(), x.to_bits(), "{x}");
        }
        assert_eq!(serde_json::to_string(&Exact(1e-7)).unwrap(), "\"1e-7\"");
        assert_eq!(serde_json::to_string(&Exact(0.5)).unwrap(), "\"0.5\"");
    }

    #[test]
    fn non_finite_and_bare_numbers_are_refused() {
        let err = |s: &str| serde_json::from_str::<Exact>(s).unwrap_err().to_string();
        assert!(err("\"NaN\"").starts_with("NaN is not a finite number"));
        assert!(err("\"inf\"").starts_with("inf is not a finite number"));
        assert!(err("0.5").contains("expected a number as a string"));
        assert!(err("\"x1\"").contains("expected a number as a string"));
    }
}
