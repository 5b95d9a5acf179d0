//! Numbers in messages ([`Num`]): below every module that writes a
//! message with a number in it (`scene`, `tally`, `transport`), so that none
//! of them imports another for it.

use std::fmt;

/// A number as messages show it: at most 12 significant digits (so that
/// `0.6 + 0.7` shows as 1.3, not 1.2999999999999998), in exponent form when
/// very large or small (1e-300, not three hundred digits), `NaN`, `inf`.
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if !x.is_finite() {
            return write!(f, "{x}");
        }
        let r: f64 = format!("{x:.11e}").parse().unwrap_or(x);
        if r == 0.0 || (1e-4..1e12).contains(&r.abs()) {
            write!(f, "{r}")
        } else {
            write!(f, "{r:e}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Num;

    #[test]
    fn numbers_in_messages() {
        let show = |x: f64| Num(x).to_string();
        assert_eq!(show(0.6 + 0.7), "1.3");
        assert_eq!(show(1e-300), "1e-300");
        assert_eq!(show(-1e300), "-1e300");
        assert_eq!(show(2.5), "2.5");
        assert_eq!(show(-10.0), "-10");
        assert_eq!(show(0.0), "0");
        assert_eq!(show(1.23456789012345e20), "1.23456789012e20");
        assert_eq!(show(5e-324), "5e-324");
        assert_eq!(show(f64::NAN), "NaN");
        assert_eq!(show(f64::NEG_INFINITY), "-inf");
    }
}
