//! The parameters of a fit: TOML key paths into the scene ([`KeyPath`])
//! with bounds ([`FitParam`], written `key=lo:hi`).

use std::fmt;
use std::str::FromStr;

use thiserror::Error;
use toml::{Table, Value};

use super::FitError;

// ---------------------------------------------------------------- key paths

/// One step of a key path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Segment {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A TOML key path such as `bumps[0].height[1]` or `materials.z302.n`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyPath {
    /// The steps, starting with a key.
    pub segments: Vec<Segment>,
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.segments.iter().enumerate() {
            match s {
                Segment::Key(k) if i == 0 => write!(f, "{k}")?,
                Segment::Key(k) => write!(f, ".{k}")?,
                Segment::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// Why a text is not a key path ([`KeyPath`]'s `FromStr`).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum KeyPathError {
    /// No key where one is due.
    #[error("expected a key at position {position} of `{path}`")]
    ExpectedKey {
        /// 1-based position.
        position: usize,
        /// The path as given.
        path: String,
    },
    /// `[` without `]`.
    #[error("unclosed `[` in `{0}`")]
    Unclosed(String),
    /// An index that is not a whole number.
    #[error("bad index `[{digits}]` in `{path}`")]
    Index {
        /// The text between the brackets.
        digits: String,
        /// The path as given.
        path: String,
    },
    /// A character that is neither key, `.` nor `[`.
    #[error(
        "unexpected `{found}` at position {position} of `{path}` (keys are A-Z a-z 0-9 _ -, joined by `.`, with `[i]` indices)"
    )]
    Unexpected {
        /// The character.
        found: String,
        /// 1-based position.
        position: usize,
        /// The path as given.
        path: String,
    },
    /// An empty path.
    #[error("empty key")]
    Empty,
    /// A path ending with `.`.
    #[error("`{0}` ends with `.`")]
    TrailingDot(String),
}

/// Why a key path leads to no number of a scene table ([`KeyPath::get`],
/// [`KeyPath::get_number`]); `done` is the part of the path that was found.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum KeyError {
    /// A path that does not start with a key.
    #[error("a key path starts with a key")]
    NoFirstKey,
    /// No such key at the top level.
    #[error("no key `{key}` at the top level (keys: {keys})")]
    NoTopKey {
        /// The key.
        key: String,
        /// The keys there are.
        keys: String,
    },
    /// No such key in a table.
    #[error("no key `{key}` in `{done}` (keys: {keys})")]
    NoKey {
        /// The key.
        key: String,
        /// The table's path.
        done: String,
        /// The keys there are.
        keys: String,
    },
    /// An index past the end of an array.
    #[error("index [{index}] out of range: `{done}` has {len} element{}", if *len == 1 { "" } else { "s" })]
    OutOfRange {
        /// The index.
        index: usize,
        /// The array's path.
        done: String,
        /// Its length.
        len: usize,
    },
    /// A key into a value that is not a table.
    #[error("`{done}` is {found}, not a table (no key `{key}`)")]
    NotTable {
        /// The value's path.
        done: String,
        /// What it is, e.g. "a float".
        found: &'static str,
        /// The key.
        key: String,
    },
    /// An index into a value that is not an array.
    #[error("`{done}` is {found}, not an array (no index [{index}])")]
    NotArray {
        /// The value's path.
        done: String,
        /// What it is.
        found: &'static str,
        /// The index.
        index: usize,
    },
    /// A `[lo, hi]` range, of which one end is to be fitted.
    #[error("is a range [{lo}, {hi}]; fit one end: {path}[0] or {path}[1]")]
    Range {
        /// The range's path.
        path: String,
        /// Its first element as written.
        lo: String,
        /// Its second element.
        hi: String,
    },
    /// A value that is not a number.
    #[error("is {0}, not a number")]
    NotANumber(&'static str),
}

/// Bounds `lo:hi` of a fitted parameter that cannot be searched.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum BoundsError {
    /// A bound that is not finite.
    #[error("bounds must be finite")]
    NotFinite,
    /// `lo >= hi`.
    #[error("bounds {lo}:{hi} must have lo < hi")]
    NotOrdered {
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
}

impl FromStr for KeyPath {
    type Err = KeyPathError;

    fn from_str(s: &str) -> Result<Self, KeyPathError> {
        let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        let b = s.as_bytes();
        let mut segments = Vec::new();
        let mut i = 0;
        let mut expect_key = true;
        while i < b.len() {
            if expect_key {
                let start = i;
                while i < b.len() && bare(b[i] as char) {
                    i += 1;
                }
                if i == start {
                    return Err(KeyPathError::ExpectedKey {
                        position: start + 1,
                        path: s.to_owned(),
                    });
                }
                segments.push(Segment::Key(s[start..i].to_string()));
                expect_key = false;
            } else if b[i] == b'.' {
                i += 1;
                expect_key = true;
            } else if b[i] == b'[' {
                let close = s[i..]
                    .find(']')
                    .ok_or_else(|| KeyPathError::Unclosed(s.to_owned()))?;
                let digits = &s[i + 1..i + close];
                let n = digits.parse::<usize>().map_err(|_| KeyPathError::Index {
                    digits: digits.to_owned(),
                    path: s.to_owned(),
                })?;
                segments.push(Segment::Index(n));
                i += close + 1;
            } else {
                return Err(KeyPathError::Unexpected {
                    found: s[i..=i].to_owned(),
                    position: i + 1,
                    path: s.to_owned(),
                });
            }
        }
        if expect_key {
            return Err(if s.is_empty() {
                KeyPathError::Empty
            } else {
                KeyPathError::TrailingDot(s.to_owned())
            });
        }
        Ok(Self { segments })
    }
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::String(_) => "a string",
        Value::Integer(_) => "an integer",
        Value::Float(_) => "a float",
        Value::Boolean(_) => "a boolean",
        Value::Datetime(_) => "a datetime",
        Value::Array(_) => "an array",
        Value::Table(_) => "a table",
    }
}

fn keys_of(t: &Table) -> String {
    if t.is_empty() {
        "none".to_string()
    } else {
        t.keys().cloned().collect::<Vec<_>>().join(", ")
    }
}

impl KeyPath {
    /// The value at this path.
    ///
    /// # Errors
    /// A [`KeyError`] naming the first step that fails.
    pub fn get<'a>(&self, root: &'a Table) -> Result<&'a Value, KeyError> {
        let mut segs = self.segments.iter();
        let Some(Segment::Key(first)) = segs.next() else {
            return Err(KeyError::NoFirstKey);
        };
        let mut here = root.get(first).ok_or_else(|| KeyError::NoTopKey {
            key: first.clone(),
            keys: keys_of(root),
        })?;
        let mut done = first.clone();
        for seg in segs {
            here = match (seg, here) {
                (Segment::Key(k), Value::Table(t)) => {
                    let v = t.get(k).ok_or_else(|| KeyError::NoKey {
                        key: k.clone(),
                        done: done.clone(),
                        keys: keys_of(t),
                    })?;
                    done.push('.');
                    done.push_str(k);
                    v
                }
                (Segment::Index(n), Value::Array(a)) => {
                    let len = a.len();
                    let v = a.get(*n).ok_or_else(|| KeyError::OutOfRange {
                        index: *n,
                        done: done.clone(),
                        len,
                    })?;
                    done.push_str(&format!("[{n}]"));
                    v
                }
                (Segment::Key(k), v) => {
                    return Err(KeyError::NotTable {
                        done,
                        found: type_name(v),
                        key: k.clone(),
                    });
                }
                (Segment::Index(n), v) => {
                    return Err(KeyError::NotArray {
                        done,
                        found: type_name(v),
                        index: *n,
                    });
                }
            };
        }
        Ok(here)
    }

    /// As [`get`](Self::get), mutably.
    ///
    /// # Errors
    /// As [`get`](Self::get).
    pub fn get_mut<'a>(&self, root: &'a mut Table) -> Result<&'a mut Value, KeyError> {
        self.get(root)?;
        let mut segs = self.segments.iter();
        let Some(Segment::Key(first)) = segs.next() else {
            unreachable!("checked by get")
        };
        let mut here = root.get_mut(first).expect("checked by get");
        for seg in segs {
            here = match (seg, here) {
                (Segment::Key(k), Value::Table(t)) => t.get_mut(k).expect("checked by get"),
                (Segment::Index(n), Value::Array(a)) => &mut a[*n],
                _ => unreachable!("checked by get"),
            };
        }
        Ok(here)
    }

    /// The number at this path (integers are read as floats).
    ///
    /// # Errors
    /// As [`get`](Self::get), or a value that is not a number.
    pub fn get_number(&self, root: &Table) -> Result<f64, KeyError> {
        number_of(self, self.get(root)?)
    }

    /// Write `value` (as a float) at this path; the old value must be a number.
    ///
    /// # Errors
    /// As [`get_number`](Self::get_number).
    pub fn set_number(&self, root: &mut Table, value: f64) -> Result<(), KeyError> {
        let v = self.get_mut(root)?;
        number_of(self, v)?;
        *v = Value::Float(value);
        Ok(())
    }
}

fn number_of(path: &KeyPath, v: &Value) -> Result<f64, KeyError> {
    match v {
        Value::Float(x) => Ok(*x),
        Value::Integer(i) => Ok(*i as f64),
        Value::Array(a) if a.len() == 2 && a.iter().all(|x| x.is_float() || x.is_integer()) => {
            Err(KeyError::Range {
                path: path.to_string(),
                lo: a[0].to_string(),
                hi: a[1].to_string(),
            })
        }
        other => Err(KeyError::NotANumber(type_name(other))),
    }
}

/// Scene keys whose two-element arrays are `[lo, hi]` ranges (inside `bumps[i]`).
const RANGE_KEYS: [&str; 6] = ["radius", "radius_y", "height", "depth", "cap", "base"];

/// If `path` addresses one end of a range, the path of the range itself.
pub(super) fn range_parent(path: &KeyPath) -> Option<KeyPath> {
    let s = &path.segments;
    let n = s.len();
    if n >= 2
        && matches!(s[n - 1], Segment::Index(0 | 1))
        && matches!(&s[n - 2], Segment::Key(k) if RANGE_KEYS.contains(&k.as_str()))
    {
        Some(KeyPath {
            segments: s[..n - 1].to_vec(),
        })
    } else {
        None
    }
}

// ---------------------------------------------------------------- parameters

/// A fitted parameter: a key path into the scene and its bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct FitParam {
    /// The key path as given, e.g. `bumps[0].height[1]`.
    pub key: String,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound (> `lo`).
    pub hi: f64,
}

impl FromStr for FitParam {
    type Err = FitError;

    /// `key=lo:hi`, e.g. `materials.z302.n=1:3`.
    fn from_str(spec: &str) -> Result<Self, FitError> {
        let err = |m: String| FitError::Param {
            spec: spec.to_string(),
            message: m,
        };
        let (key, bounds) = spec
            .split_once('=')
            .ok_or_else(|| err("expected key=lo:hi".into()))?;
        let key = key.trim();
        key.parse::<KeyPath>().map_err(|e| err(e.to_string()))?;
        let (lo, hi) = bounds
            .split_once(':')
            .ok_or_else(|| err("expected bounds lo:hi after `=`".into()))?;
        let num = |t: &str| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| err(format!("bound `{}` is not a number", t.trim())))
        };
        let p = Self {
            key: key.to_string(),
            lo: num(lo)?,
            hi: num(hi)?,
        };
        p.check().map_err(|e| err(e.to_string()))?;
        Ok(p)
    }
}

impl FitParam {
    pub(super) fn check(&self) -> Result<(), BoundsError> {
        if !(self.lo.is_finite() && self.hi.is_finite()) {
            return Err(BoundsError::NotFinite);
        }
        if self.lo >= self.hi {
            return Err(BoundsError::NotOrdered {
                lo: self.lo,
                hi: self.hi,
            });
        }
        Ok(())
    }

    /// The value at unit coordinate `x` (clamped into [0, 1]).
    #[must_use]
    pub fn value_at(&self, x: f64) -> f64 {
        let x = x.clamp(0.0, 1.0);
        if x == 1.0 {
            self.hi
        } else {
            self.lo + x * (self.hi - self.lo)
        }
    }

    /// The unit coordinate of `v` (not clamped).
    #[must_use]
    pub fn unit(&self, v: f64) -> f64 {
        (v - self.lo) / (self.hi - self.lo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Table {
        toml::from_str(text).unwrap()
    }

    fn path(s: &str) -> KeyPath {
        s.parse().unwrap()
    }

    // ------------------------------------------------------------ key paths

    #[test]
    fn key_path_syntax() {
        let p = path("bumps[0].height[1]");
        assert_eq!(
            p.segments,
            vec![
                Segment::Key("bumps".into()),
                Segment::Index(0),
                Segment::Key("height".into()),
                Segment::Index(1)
            ]
        );
        assert_eq!(p.to_string(), "bumps[0].height[1]");
        assert_eq!(path("materials.z302.n").to_string(), "materials.z302.n");
        for bad in [
            "", "a.", ".a", "a..b", "a[", "a[x]", "a[-1]", "a b", "[0]", "a.[0]",
        ] {
            assert!(bad.parse::<KeyPath>().is_err(), "`{bad}` should not parse");
        }
    }

    #[test]
    fn key_path_get_and_set_nested() {
        let mut t = table(
            "x = 1\n[a.b]\nc = 2.5\nd = [1.0, 2.0]\n[[arr]]\nv = 3.0\n[[arr]]\nv = 4\nw = [[1.0, 2.0], [3.0, 5.0]]\n",
        );
        assert_eq!(path("x").get_number(&t), Ok(1.0));
        assert_eq!(path("a.b.c").get_number(&t), Ok(2.5));
        assert_eq!(path("a.b.d[1]").get_number(&t), Ok(2.0));
        assert_eq!(path("arr[0].v").get_number(&t), Ok(3.0));
        assert_eq!(path("arr[1].v").get_number(&t), Ok(4.0)); // integer read as float
        assert_eq!(path("arr[1].w[1][1]").get_number(&t), Ok(5.0));

        path("a.b.c").set_number(&mut t, -7.25).unwrap();
        path("a.b.d[0]").set_number(&mut t, 0.5).unwrap();
        path("arr[1].v")
            .set_number(&mut t, 1.8000488281250009)
            .unwrap();
        path("arr[1].w[0][1]").set_number(&mut t, 9.0).unwrap();
        // Through text and back, bit for bit.
        let back = table(&t.to_string());
        assert_eq!(path("a.b.c").get_number(&back), Ok(-7.25));
        assert_eq!(path("a.b.d[0]").get_number(&back), Ok(0.5));
        assert_eq!(path("a.b.d[1]").get_number(&back), Ok(2.0));
        assert_eq!(path("arr[1].v").get_number(&back), Ok(1.8000488281250009));
        assert_eq!(path("arr[0].v").get_number(&back), Ok(3.0));
        assert_eq!(path("arr[1].w[0][1]").get_number(&back), Ok(9.0));
        assert_eq!(path("x").get_number(&back), Ok(1.0));
    }

    #[test]
    fn key_path_errors() {
        let mut t = table("s = \"text\"\n[a.b]\nc = 2.5\nr = [1.0, 2.0]\n[[arr]]\nv = 3.0\n");
        let err = |p: &str| path(p).get_number(&t).unwrap_err().to_string();
        assert_eq!(err("zz"), "no key `zz` at the top level (keys: a, arr, s)");
        assert_eq!(err("a.x.c"), "no key `x` in `a` (keys: b)");
        assert_eq!(err("a.b.cc"), "no key `cc` in `a.b` (keys: c, r)");
        assert_eq!(
            err("arr[1].v"),
            "index [1] out of range: `arr` has 1 element"
        );
        assert_eq!(err("arr[0].w"), "no key `w` in `arr[0]` (keys: v)");
        assert_eq!(
            err("a.b.c.d"),
            "`a.b.c` is a float, not a table (no key `d`)"
        );
        assert_eq!(err("a[0]"), "`a` is a table, not an array (no index [0])");
        assert_eq!(err("s"), "is a string, not a number");
        assert_eq!(err("a.b"), "is a table, not a number");
        assert_eq!(
            err("a.b.r"),
            "is a range [1.0, 2.0]; fit one end: a.b.r[0] or a.b.r[1]"
        );
        assert!(path("a.b.r[2]").set_number(&mut t, 1.0).is_err());
        assert!(path("s").set_number(&mut t, 1.0).is_err());
        // Failed sets leave the table unchanged.
        assert_eq!(
            t,
            table("s = \"text\"\n[a.b]\nc = 2.5\nr = [1.0, 2.0]\n[[arr]]\nv = 3.0\n")
        );
    }

    #[test]
    fn fit_param_parse() {
        let p: FitParam = "bumps[0].height[1]=0.5:5".parse().unwrap();
        assert_eq!(
            (p.key.as_str(), p.lo, p.hi),
            ("bumps[0].height[1]", 0.5, 5.0)
        );
        let p: FitParam = " materials.z302.k = -1e-3 : 1 ".parse().unwrap();
        assert_eq!(
            (p.key.as_str(), p.lo, p.hi),
            ("materials.z302.k", -1e-3, 1.0)
        );
        assert_eq!(p.value_at(0.0), -1e-3);
        assert_eq!(p.value_at(1.0), 1.0);
        assert_eq!(p.value_at(2.0), 1.0);
        for (bad, msg) in [
            ("height", "expected key=lo:hi"),
            ("height=1", "expected bounds lo:hi after `=`"),
            ("height=a:2", "bound `a` is not a number"),
            ("height=2:1", "bounds 2:1 must have lo < hi"),
            ("height=1:1", "bounds 1:1 must have lo < hi"),
            ("height=1:inf", "bounds must be finite"),
            ("a..b=1:2", "expected a key at position 3 of `a..b`"),
        ] {
            let e = bad.parse::<FitParam>().unwrap_err();
            assert_eq!(e.to_string(), format!("--param {bad}: {msg}"));
        }
    }
}
