//! Parsers of the values a user types (the command line's options, through
//! clap's `value_parser`; any other front end alike): exact integers and
//! finite reals, each refusal a message naming what is accepted and what
//! was given.
//!
//! * Integer options ([`integer`], [`positive`]) take digits, or an exact
//!   decimal with an exponent as people write large counts: `1e6`, `2.5e3`,
//!   `1E+9` are 1000000, 2500, 1000000000. Values that are not whole
//!   numbers (`1.5`, `1e-3`) and values beyond the option's type are
//!   refused, never rounded.
//! * Real options ([`number`]) take any finite decimal (`inf` and `nan` are
//!   refused).

/// Unsigned integer types of the integer options.
pub trait Unsigned: TryFrom<u64> {
    /// The largest value of the type.
    const MAX: u64;
}

impl Unsigned for u32 {
    const MAX: u64 = u32::MAX as u64;
}

impl Unsigned for u64 {
    const MAX: u64 = u64::MAX;
}

impl Unsigned for usize {
    const MAX: u64 = usize::MAX as u64;
}

/// Why a text is not an exact unsigned integer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotInteger {
    /// Not a decimal number at all (or empty).
    NotANumber,
    /// A negative number.
    Negative,
    /// A number with a fractional part (`1.5`, `1e-3`).
    NotWhole,
    /// Larger than `u64::MAX`.
    TooLarge,
}

/// The exact value of `s` as an unsigned integer: digits with an optional
/// fraction and exponent, `[+]D[.D][(e|E)[+|-]D]`, whose value is a whole
/// number (`2.5e3` is 2500; `1.5` is [`NotInteger::NotWhole`]).
pub fn exact_integer(s: &str) -> Result<u64, NotInteger> {
    if let Some(rest) = s.strip_prefix('-') {
        return Err(if exact_integer(rest) == Err(NotInteger::NotANumber) {
            NotInteger::NotANumber
        } else {
            NotInteger::Negative
        });
    }
    let body = s.strip_prefix('+').unwrap_or(s);
    let (mantissa, exponent) = match body.find(['e', 'E']) {
        Some(i) => (&body[..i], Some(&body[i + 1..])),
        None => (body, None),
    };
    let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let digits = |t: &str| t.bytes().all(|b| b.is_ascii_digit());
    if int.len() + frac.len() == 0 || !digits(int) || !digits(frac) {
        return Err(NotInteger::NotANumber);
    }
    // The exponent, saturated far beyond any u64 (a longer one changes nothing).
    let exp: i64 = match exponent {
        None => 0,
        Some(e) => {
            let (neg, d) = match e.as_bytes().first() {
                Some(b'-') => (true, &e[1..]),
                Some(b'+') => (false, &e[1..]),
                _ => (false, e),
            };
            if d.is_empty() || !digits(d) {
                return Err(NotInteger::NotANumber);
            }
            let v = d.trim_start_matches('0');
            let v: i64 = if v.len() > 6 {
                1_000_000
            } else {
                v.parse().unwrap_or(0)
            };
            if neg { -v } else { v }
        }
    };
    let mut m: u128 = 0;
    for b in int.bytes().chain(frac.bytes()) {
        m = m
            .checked_mul(10)
            .and_then(|m| m.checked_add(u128::from(b - b'0')))
            .ok_or(NotInteger::TooLarge)?;
    }
    if m == 0 {
        return Ok(0);
    }
    let e = exp - frac.len() as i64;
    let v = if e >= 0 {
        u32::try_from(e)
            .ok()
            .and_then(|e| 10_u128.checked_pow(e))
            .and_then(|p| m.checked_mul(p))
            .ok_or(NotInteger::TooLarge)?
    } else {
        // m < 2^128 < 10^39: a divisor 10^39 or more leaves a fraction.
        let p = u32::try_from(-e)
            .ok()
            .and_then(|k| 10_u128.checked_pow(k))
            .ok_or(NotInteger::NotWhole)?;
        if m % p != 0 {
            return Err(NotInteger::NotWhole);
        }
        m / p
    };
    u64::try_from(v).map_err(|_| NotInteger::TooLarge)
}

/// The text a value parser was given, as its messages show it: `` `s` ``,
/// or "an empty value".
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Given(pub String);

impl std::fmt::Display for Given {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_empty() {
            f.write_str("an empty value")
        } else {
            write!(f, "`{}`", self.0)
        }
    }
}

/// Why a value parser refused an option's value (the option's name is
/// added by clap, or by the caller).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ValueError {
    /// Not an integer at all.
    #[error("expected an integer >= {min} (digits, or exact forms like 1e6 or 2.5e3), got {given}")]
    NotAnInteger {
        /// The smallest value allowed.
        min: u64,
        /// What was given.
        given: Given,
    },
    /// An integer below `min` (or negative).
    #[error("must be an integer >= {min} (digits, or exact forms like 1e6 or 2.5e3), got {given}")]
    TooSmall {
        /// The smallest value allowed.
        min: u64,
        /// What was given.
        given: Given,
    },
    /// A number with a fractional part.
    #[error(
        "must be an integer >= {min} (digits, or exact forms like 1e6 or 2.5e3), got {given} (not a whole number)"
    )]
    NotWhole {
        /// The smallest value allowed.
        min: u64,
        /// What was given.
        given: Given,
    },
    /// An integer beyond the option's type.
    #[error("must be at most {max}, got {given}")]
    TooLarge {
        /// The largest value allowed.
        max: u64,
        /// What was given.
        given: Given,
    },
    /// Not a number (or empty).
    #[error("expected a number, got {0}")]
    NotANumber(Given),
    /// `inf` or `nan`.
    #[error("must be a finite number, got {0}")]
    NotFinite(Given),
    /// `--wavelengths` in neither form.
    #[error("expected W1,W2,... or FROM:TO:STEP (um), got `{0}`")]
    WavelengthsForm(String),
}

/// An integer of at least `min` and at most `T::MAX`, with the message
/// saying what is allowed.
fn at_least<T: Unsigned>(s: &str, min: u64) -> Result<T, ValueError> {
    let given = || Given(s.to_owned());
    let too_large = || ValueError::TooLarge {
        max: T::MAX,
        given: given(),
    };
    let v = exact_integer(s).map_err(|why| match why {
        NotInteger::NotANumber => ValueError::NotAnInteger {
            min,
            given: given(),
        },
        NotInteger::Negative => ValueError::TooSmall {
            min,
            given: given(),
        },
        NotInteger::NotWhole => ValueError::NotWhole {
            min,
            given: given(),
        },
        NotInteger::TooLarge => too_large(),
    })?;
    if v < min {
        return Err(ValueError::TooSmall {
            min,
            given: given(),
        });
    }
    if v > T::MAX {
        return Err(too_large());
    }
    T::try_from(v).map_err(|_| too_large())
}

/// Value parser of integer options that may be 0 (`--seed`, `--scan`, ...).
///
/// # Errors
/// A [`ValueError`] naming what is allowed and what was given.
pub fn integer<T: Unsigned>(s: &str) -> Result<T, ValueError> {
    at_least(s, 0)
}

/// Value parser of integer options that must be at least 1 (`--photons`,
/// `--threads`, `--size`, ...).
///
/// # Errors
/// A [`ValueError`] naming what is allowed and what was given.
pub fn positive<T: Unsigned>(s: &str) -> Result<T, ValueError> {
    at_least(s, 1)
}

/// Value parser of real options: a finite decimal number.
///
/// # Errors
/// A [`ValueError`] naming what is allowed and what was given.
pub fn number(s: &str) -> Result<f64, ValueError> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(ValueError::NotFinite(Given(s.to_owned()))),
        Err(_) => Err(ValueError::NotANumber(Given(s.to_owned()))),
    }
}

/// `--wavelengths`: comma-separated wavelengths in µm (`0.45,0.55,0.65`)
/// or an even grid `FROM:TO:STEP` (`0.38:0.78:0.01`), read into the value
/// of `[light] wavelengths_um` it overrides; the scene checks it as it
/// checks that key.
///
/// # Errors
/// A value that is not a number, or neither form.
pub fn wavelengths(s: &str) -> Result<crate::scene::WavelengthsSpec, ValueError> {
    use crate::scene::WavelengthsSpec;
    match s.split(':').collect::<Vec<_>>().as_slice() {
        [from, to, step] => Ok(WavelengthsSpec::Grid {
            from: number(from)?,
            to: number(to)?,
            step: number(step)?,
        }),
        [_] => Ok(WavelengthsSpec::List(
            s.split(',').map(number).collect::<Result<Vec<_>, _>>()?,
        )),
        _ => Err(ValueError::WavelengthsForm(s.to_owned())),
    }
}

/// Why a `--grid` value ([`zemax_grid`]) was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// A step that is not a number.
    #[error(transparent)]
    Number(#[from] ValueError),
    /// Not two steps.
    #[error("expected AZIMUTH_DEG,RADIAL_DEG, got {0:?}")]
    Form(String),
    /// A step outside (0, 90] or not dividing 180.
    #[error("each step must be in (0, 90] degrees and divide 180, got {0}")]
    Step(f64),
}

/// A Zemax grid `AZIMUTH_DEG,RADIAL_DEG` (`roks export-brdf --grid`): two
/// steps in degrees, each in (0, 90] and dividing 180 into whole steps
/// (to 1e-9).
///
/// # Errors
/// [`GridError`].
pub fn zemax_grid(s: &str) -> Result<crate::export::exporter::ZemaxGrid, GridError> {
    let steps: Vec<f64> = s
        .split(',')
        .map(|v| number(v.trim()))
        .collect::<Result<_, _>>()?;
    let [azimuth_step_deg, radial_step_deg] = steps[..] else {
        return Err(GridError::Form(s.to_owned()));
    };
    crate::export::exporter::ZemaxGrid::new(azimuth_step_deg, radial_step_deg)
        .map_err(GridError::Step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_integers() {
        for (s, v) in [
            ("0", 0),
            ("42", 42),
            ("+7", 7),
            ("1e6", 1_000_000),
            ("1E+9", 1_000_000_000),
            ("2.5e3", 2500),
            ("2.50e1", 25),
            ("100e-2", 1),
            ("0e99999999999", 0),
            ("0.0", 0),
            ("1e18", 1_000_000_000_000_000_000),
            ("18446744073709551615", u64::MAX),
            ("1.8446744073709551615e19", u64::MAX),
            ("007", 7),
        ] {
            assert_eq!(exact_integer(s), Ok(v), "{s}");
        }
        for (s, why) in [
            ("", NotInteger::NotANumber),
            ("a", NotInteger::NotANumber),
            ("1e", NotInteger::NotANumber),
            ("e5", NotInteger::NotANumber),
            (".", NotInteger::NotANumber),
            ("1,000", NotInteger::NotANumber),
            (" 1", NotInteger::NotANumber),
            ("inf", NotInteger::NotANumber),
            ("0x10", NotInteger::NotANumber),
            ("-x", NotInteger::NotANumber),
            ("-1", NotInteger::Negative),
            ("-1e6", NotInteger::Negative),
            ("1.5", NotInteger::NotWhole),
            ("1e-3", NotInteger::NotWhole),
            ("1e-99999999", NotInteger::NotWhole),
            ("18446744073709551616", NotInteger::TooLarge),
            ("1e20", NotInteger::TooLarge),
            ("1e99999999", NotInteger::TooLarge),
            (
                "9999999999999999999999999999999999999999999",
                NotInteger::TooLarge,
            ),
        ] {
            assert_eq!(exact_integer(s), Err(why), "{s}");
        }
    }

    #[test]
    fn parser_messages() {
        assert_eq!(integer::<u64>("1e6"), Ok(1_000_000));
        assert_eq!(positive::<u32>("16"), Ok(16));
        assert_eq!(
            integer::<u64>("-1").unwrap_err().to_string(),
            "must be an integer >= 0 (digits, or exact forms like 1e6 or 2.5e3), got `-1`"
        );
        assert_eq!(
            positive::<usize>("0").unwrap_err().to_string(),
            "must be an integer >= 1 (digits, or exact forms like 1e6 or 2.5e3), got `0`"
        );
        assert_eq!(
            positive::<u32>("5e9").unwrap_err().to_string(),
            "must be at most 4294967295, got `5e9`"
        );
        assert!(
            positive::<u64>("1.5")
                .unwrap_err()
                .to_string()
                .contains("whole number")
        );
        assert!(
            integer::<u64>("")
                .unwrap_err()
                .to_string()
                .ends_with("got an empty value")
        );
        assert_eq!(number("-2.5"), Ok(-2.5));
        assert_eq!(
            number("a").unwrap_err().to_string(),
            "expected a number, got `a`"
        );
        assert_eq!(
            number("").unwrap_err().to_string(),
            "expected a number, got an empty value"
        );
        assert_eq!(
            number("inf").unwrap_err().to_string(),
            "must be a finite number, got `inf`"
        );
        assert!(number("1e400").is_err());
    }
}
