//! The value parsers of the options (clap's `value_parser`), from the
//! library: [`crate::api::values`].

pub use crate::api::values::{
    Given, NotInteger, Unsigned, ValueError, exact_integer, integer, number, positive, wavelengths,
};
