//! Fitting a micro scene to a measured in-plane BRDF (`roks fit`).
//!
//! The paper (Klass et al. 2014, validation 3) fitted the Z-302 micro geometry
//! so that the computed BRDF of a flat Z-302 layer matched measured BRDFs at
//! 30 and 60 degrees incidence. This module does that for any micro scene:
//! it adjusts chosen numbers of the scene file until the scene's in-plane
//! BRDF matches a measured one.
//!
//! # Inputs
//! * The micro scene as TOML text, with its [`SceneFile`] (file name for
//!   messages, folder for relative paths such as reflectance tables).
//! * The measured in-plane BRDF ([`Measured`]): a CSV with the header
//!   `theta_i_deg,theta_o_deg,brdf` and optionally a fourth column
//!   `brdf_stderr`; `theta_o_deg` is signed exactly like roks's own
//!   `inplane.csv` (positive on the specular side, negative toward the light),
//!   so an `inplane.csv` is itself a valid measured file. A measurement at
//!   several light azimuths has the column `phi_i_deg` (degrees, in
//!   `[0, 360)`) after `theta_i_deg`, as `inplane.csv` of a run of several
//!   azimuths has; without it the scene must trace one azimuth (its
//!   `[light] phi_deg`), since nothing says which azimuth a row was
//!   measured at.
//! * The parameters ([`FitParam`], written `key=lo:hi`): TOML key paths into
//!   the scene with bounds, e.g. `bumps[0].radius=1:4`,
//!   `materials.z302.n=1:3`, `materials.z302.k=0:1`. A key whose value is a
//!   range `[lo, hi]` is fitted one end at a time, `bumps[0].height[1]=0.5:5`
//!   (a whole range cannot be one parameter: fix it to `[h, h]` to fit a
//!   single height). Keys are bare TOML keys (`A-Z a-z 0-9 _ -`) joined by
//!   `.` with `[i]` array indices.
//!
//! # Method
//! 1. **Model.** The parameter values are written into the parsed TOML table
//!    (as floats), and the scene is rebuilt from the table's text with
//!    [`MicroScene::from_str`], so every check of the scene file applies. The
//!    scene's [`BrdfRun`](crate::transport::brdf::BrdfRun) is run at only the
//!    distinct measured incidence angles (and, with a `phi_i_deg` column,
//!    the distinct measured light azimuths, every angle at every azimuth;
//!    each row is compared with the curve of its own incidence and
//!    azimuth), with [`FitOptions::photons`] photons
//!    and the **fixed** seed [`FitOptions::seed`]. The in-plane BRDF of each
//!    bin is `inplane.mean(bin, n) / projected_solid_angle(bin)`, and the
//!    model value at a measured `theta_o` is the linear interpolation between
//!    the two nearest bin centres (beyond the outermost centres, the outermost
//!    bin's value). The in-plane bins are the scene's `[tally]
//!    inplane_step_deg` and `inplane_width_deg`, unless
//!    [`FitOptions::inplane_step_deg`] / [`FitOptions::inplane_width_deg`]
//!    override them. **The bins must hold enough photons**: the misfit is
//!    only useful where the model noise is small against the change being
//!    fitted. With 30 000 photons per angle, 1 degree x 1 degree bins hold a
//!    few photons each and the misfit of a 20-bump test scene is pure noise
//!    0.01 away from the true height; 5 degree x 10 degree bins (~100 photons
//!    each) give a misfit that falls steadily to 0 at the truth. Raise the
//!    photons (cost linear) or widen the bins (cost: angular resolution, and
//!    the detector then averages out of the plane), and compare like with
//!    like: the measurement's own detector size is the natural choice.
//! 2. **Common random numbers.** With the seed fixed, photon `n` starts at the
//!    same point with the same random stream at every parameter value, so
//!    the misfit changes only through the geometry and the materials: it is a
//!    (piecewise) smooth function of the parameters instead of a fresh
//!    Monte Carlo draw at every evaluation, and a direct search can converge
//!    on it. The fitted values are then the best values *for this sample of
//!    photons*; their Monte Carlo uncertainty can be judged by refitting with
//!    other seeds.
//! 3. **Misfit.** The mean over the measured points of
//!    `(ln(model + eps) - ln(measured + eps))^2`, `eps = 1e-3 * max measured
//!    BRDF`. BRDFs span decades (a specular peak over a diffuse floor); a
//!    linear least-squares misfit would fit the peak and ignore the rest. The
//!    log weighs relative errors equally everywhere; `eps` keeps empty model
//!    bins and zero measurements finite and stops values 1000 times below the
//!    peak (mostly noise) from dominating. The measured `brdf_stderr` is
//!    read but not used as a weight.
//!
//!    **Values the scene rejects** (a reversed range `lo > hi`, `cap > 1`,
//!    `n <= 0`, a radius of 0, ...). Before any photon is traced, the scene
//!    is built at the start point and at both bounds of every parameter
//!    (the others at their start values); a rejection there is an error
//!    naming `--param`, the key and the scene's reason, since the bounds
//!    themselves are wrong. Points the search can still meet are
//!    combinations (two ends of one range crossing): they have an infinite
//!    misfit and are recorded with the scene's reason in
//!    [`FitResult::rejected`] (in `fit.json`: `"misfit": null` beside
//!    `"rejected": reason`), a constraint of the search, not a failure.
//! 4. **Search.** Nelder-Mead (reflection 1, expansion 2, contraction 1/2,
//!    shrink 1/2) in the unit cube: parameter `j` is `lo_j + x_j (hi_j -
//!    lo_j)`. Simplex vertices may leave the cube; the model is evaluated at
//!    the clamped point and the squared distance outside the cube is added as
//!    a penalty, which keeps the simplex from collapsing onto a face and
//!    pulls it back. The start is the scene's current values, clamped into
//!    the bounds; the initial simplex steps each coordinate by 10 % of its
//!    range (away from the nearer bound). The search stops when the spread of
//!    the misfit over the simplex is at most [`FitOptions::tolerance`] and the
//!    simplex fits in a box of [`FitOptions::x_tolerance`] (in units of each
//!    range), or after [`FitOptions::max_evaluations`] model runs. Repeated
//!    points are not rerun. [`FitResult::at_bounds`] flags parameters that
//!    ended on a bound, within `x_tolerance` (the optimum may lie beyond it).
//!
//! # Limitations
//! * Only numbers can be fitted; integer keys (`count`, `seed`) are written
//!   as floats and the scene rejects them.
//! * The fitted scene text ([`Problem::apply`]) is re-serialised from the
//!   TOML table: comments and formatting of the original file are lost.
//! * The misfit is piecewise constant on a fine scale (a photon changes bin
//!   or bounce count discontinuously). Nelder-Mead copes, but gradients would
//!   not; the minimum found is local.

use std::fmt;
use std::str::FromStr;

use thiserror::Error;
use toml::{Table, Value};

use crate::scene::micro::MicroScene;
use crate::scene::{SceneError, SceneFile};
use crate::tally::InPlaneTally;

/// Why a fit cannot run. Every message is one line naming the file, the
/// `roks fit` option (`--param`, `--photons`, ...) and the scene key.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    /// The scene file is invalid (at its current values).
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// A parameter key path does not lead to a number in the scene.
    #[error("{file}: --param {key}: {message}")]
    Key {
        /// Scene file.
        file: String,
        /// The key path as given.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A parameter specification `key=lo:hi` is malformed.
    #[error("--param {spec}: {message}")]
    Param {
        /// The specification as given.
        spec: String,
        /// What is wrong.
        message: String,
    },
    /// The measured BRDF file is malformed.
    #[error("{file}: line {line}: {message}")]
    Measured {
        /// Measured file name.
        file: String,
        /// Line number (1-based; 0: the file as a whole).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A parameter's bounds (or the start point) reach values the scene
    /// rejects: found before the fit by building the scene at both bounds of
    /// every parameter (the others at their start values) and at the start.
    #[error("{file}: --param {spec}: {at}, the scene is invalid: {reason}")]
    Infeasible {
        /// Scene file.
        file: String,
        /// The parameter as given, `key=lo:hi`, or all of them for the start.
        spec: String,
        /// Where, e.g. `at bumps[0].radius = 0`.
        at: String,
        /// The scene's objection: key and message (see [`reason`]).
        reason: String,
    },
    /// A bad fit option.
    #[error("{option}: {message}")]
    Options {
        /// The `roks fit` command-line option that sets it, e.g. `--photons`.
        option: String,
        /// What is wrong.
        message: String,
    },
}

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
fn range_parent(path: &KeyPath) -> Option<KeyPath> {
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
    fn check(&self) -> Result<(), BoundsError> {
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

// ---------------------------------------------------------------- measured

/// A measured in-plane BRDF.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// `(theta_i_deg, theta_o_deg, brdf, brdf_stderr)`, in file order.
    pub points: Vec<(f64, f64, f64, Option<f64>)>,
    /// The light azimuth of every point (degrees, in `[0, 360)`, in file
    /// order) when the file has the column `phi_i_deg`; `None`: the
    /// points are at the scene's one light azimuth.
    pub phi_i_deg: Option<Vec<f64>>,
}

impl Measured {
    /// Parse a CSV with header `theta_i_deg,theta_o_deg,brdf[,brdf_stderr]`,
    /// or with `phi_i_deg` after `theta_i_deg` (the header of `inplane.csv`
    /// of a run of several light azimuths) (blank lines and `#` comments
    /// allowed). `name` is used in messages.
    pub fn parse(text: &str, name: &str) -> Result<Self, FitError> {
        let err = |line: usize, message: String| FitError::Measured {
            file: name.to_string(),
            line,
            message,
        };
        // (columns, whether column 2 is phi_i_deg)
        let mut ncols: Option<(usize, bool)> = None;
        let mut points = Vec::new();
        let mut azimuths = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.trim_start_matches('\u{feff}').trim();
            if content.is_empty() || content.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = content.split(',').map(str::trim).collect();
            let Some((n, with_phi)) = ncols else {
                let three = ["theta_i_deg", "theta_o_deg", "brdf"];
                let with_phi = fields.get(1) == Some(&"phi_i_deg");
                let rest: Vec<&str> = if with_phi {
                    std::iter::once(fields[0])
                        .chain(fields[2..].iter().copied())
                        .collect()
                } else {
                    fields.clone()
                };
                let ok = rest[..] == three
                    || (rest.len() == 4 && rest[..3] == three && rest[3] == "brdf_stderr");
                if !ok {
                    return Err(err(
                        line,
                        format!(
                            "header must be `theta_i_deg,theta_o_deg,brdf` or `theta_i_deg,theta_o_deg,brdf,brdf_stderr` (with `phi_i_deg` after `theta_i_deg` for several light azimuths), got `{content}`"
                        ),
                    ));
                }
                ncols = Some((fields.len(), with_phi));
                continue;
            };
            if fields.len() != n {
                return Err(err(
                    line,
                    format!("expected {n} fields, found {}", fields.len()),
                ));
            }
            let mut all = [0.0; 5];
            for (j, f) in fields.iter().enumerate() {
                all[j] = f
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        err(
                            line,
                            format!("field {} `{f}` is not a finite number", j + 1),
                        )
                    })?;
            }
            // `v`: theta_i, theta_o, brdf, brdf_stderr, without phi_i.
            let mut v = [0.0; 4];
            if with_phi {
                let phi = all[1];
                if !(0.0..360.0).contains(&phi) {
                    return Err(err(
                        line,
                        format!("phi_i_deg must be in [0, 360), got {phi}"),
                    ));
                }
                azimuths.push(phi);
                v[0] = all[0];
                v[1..n - 1].copy_from_slice(&all[2..n]);
            } else {
                v[..n].copy_from_slice(&all[..n]);
            }
            let n = if with_phi { n - 1 } else { n };
            if !(0.0..90.0).contains(&v[0]) {
                return Err(err(
                    line,
                    format!("theta_i_deg must be in [0, 90), got {}", v[0]),
                ));
            }
            if !(-90.0..=90.0).contains(&v[1]) {
                return Err(err(
                    line,
                    format!("theta_o_deg must be in [-90, 90], got {}", v[1]),
                ));
            }
            if v[2] < 0.0 {
                return Err(err(line, format!("brdf must be >= 0, got {}", v[2])));
            }
            if n == 4 && v[3] < 0.0 {
                return Err(err(line, format!("brdf_stderr must be >= 0, got {}", v[3])));
            }
            points.push((v[0], v[1], v[2], (n == 4).then_some(v[3])));
        }
        let Some((_, with_phi)) = ncols else {
            return Err(err(0, "empty file (no header)".into()));
        };
        if points.is_empty() {
            return Err(err(0, "no data rows".into()));
        }
        if points.iter().all(|p| p.2 == 0.0) {
            return Err(err(0, "every brdf is 0".into()));
        }
        Ok(Self {
            points,
            phi_i_deg: with_phi.then_some(azimuths),
        })
    }

    /// The distinct light azimuths (degrees) of a file with `phi_i_deg`, in
    /// order of first appearance; `None` without the column.
    #[must_use]
    pub fn azimuths(&self) -> Option<Vec<f64>> {
        let phi = self.phi_i_deg.as_ref()?;
        let mut out: Vec<f64> = Vec::new();
        for &p in phi {
            if !out.contains(&p) {
                out.push(p);
            }
        }
        Some(out)
    }

    /// The distinct incidence angles, in order of first appearance.
    #[must_use]
    pub fn incidence_angles(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for p in &self.points {
            if !out.contains(&p.0) {
                out.push(p.0);
            }
        }
        out
    }
}

// ---------------------------------------------------------------- options, result

/// How to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Photons per incidence angle and evaluation.
    pub photons: u64,
    /// Tracing seed, the same at every evaluation (common random numbers).
    pub seed: u64,
    /// Most model runs.
    pub max_evaluations: usize,
    /// Stop when the misfit spread over the simplex is at most this ...
    pub tolerance: f64,
    /// ... and the simplex fits in a box this wide in every unit coordinate
    /// (a fraction of each parameter's range).
    pub x_tolerance: f64,
    /// Restarts from the best point after convergence (stops early when a
    /// restart gains less than `tolerance`).
    pub restarts: usize,
    /// In-plane bin width (degrees, must divide 180); `None`: the scene's.
    pub inplane_step_deg: Option<f64>,
    /// In-plane detector full width out of the plane (degrees); `None`: the scene's.
    pub inplane_width_deg: Option<f64>,
    /// Points per parameter of the coarse global scan that picks the
    /// simplex's starting point (0 or 1: none). At most 256 points in all:
    /// fewer per parameter when needed, none when even 2 per parameter are
    /// more (9 parameters or more).
    pub scan: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            photons: 200_000,
            seed: 1,
            max_evaluations: 200,
            tolerance: 1e-6,
            x_tolerance: 1e-3,
            restarts: 3,
            inplane_step_deg: None,
            inplane_width_deg: None,
            scan: 8,
        }
    }
}

/// Where a parameter ended relative to its bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// Strictly inside.
    Inside,
    /// At the lower bound.
    Lower,
    /// At the upper bound.
    Upper,
}

/// The outcome of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitResult {
    /// Best parameter values, in the order of the parameters.
    pub values: Vec<f64>,
    /// Misfit at `values`.
    pub misfit: f64,
    /// Start values (the scene's, clamped into the bounds).
    pub start: Vec<f64>,
    /// Misfit at `start`.
    pub start_misfit: f64,
    /// Model runs made.
    pub evaluations: usize,
    /// True if the tolerances were met (false: `max_evaluations` ran out).
    pub converged: bool,
    /// Per parameter: did it end on a bound (within `x_tolerance` of its range)?
    pub at_bounds: Vec<Bound>,
    /// Every model run: parameter values and misfit (infinite: rejected by the scene).
    pub history: Vec<(Vec<f64>, f64)>,
    /// The runs of `history` the scene rejected: their index in `history`
    /// and the reason ([`reason`]: key and message). Only combinations of
    /// parameters can be rejected (each bound alone is checked up front).
    pub rejected: Vec<(usize, String)>,
    /// Model in-plane BRDF at `values`, one per measured point.
    pub model: Vec<f64>,
}

// ---------------------------------------------------------------- the problem

/// A prepared fit: the parsed scene, parameters and measurement.
#[derive(Debug, Clone)]
pub struct Problem {
    table: Table,
    scene_file: SceneFile,
    name: String,
    params: Vec<FitParam>,
    paths: Vec<KeyPath>,
    measured: Measured,
    thetas: Vec<f64>,
    /// The measured light azimuths (degrees), traced instead of the
    /// scene's; `None`: the scene's one azimuth.
    phis: Option<Vec<f64>>,
    eps: f64,
    opts: FitOptions,
}

/// Called after every model run of a fit with `(evaluation, values, misfit,
/// rejected)`: the 1-based evaluation number, the parameter values, the
/// misfit (infinite when rejected) and why the scene rejected the values.
pub type Observer<'a> = dyn FnMut(usize, &[f64], f64, Option<&str>) + 'a;

/// Why a point cannot be evaluated: its parameter values make the scene invalid.
#[derive(Debug, Clone, PartialEq)]
pub struct Infeasible(pub FitError);

/// The scene's objection to a point, as `key: message` (the file is the
/// fit's scene; a line number, which would count lines of the rewritten
/// table rather than of the user's file, is left out).
#[must_use]
pub fn reason(e: &FitError) -> String {
    match e {
        FitError::Scene(s) => {
            let m = s.message.as_str();
            let m = match m.rfind(" (line ") {
                Some(i) if m.ends_with(')') => &m[..i],
                _ => m,
            };
            if s.key.is_empty() {
                m.to_string()
            } else {
                format!("{}: {m}", s.key)
            }
        }
        FitError::Key { key, message, .. } => format!("{key}: {message}"),
        other => other.to_string(),
    }
}

impl Problem {
    /// Check everything: the scene builds, every key leads to a number, the
    /// bounds and the options are valid.
    pub fn new(
        scene_text: &str,
        scene_file: &SceneFile,
        params: &[FitParam],
        measured: &Measured,
        opts: &FitOptions,
    ) -> Result<Self, FitError> {
        let name = std::path::Path::new(&scene_file.file)
            .file_stem()
            .map_or_else(|| "fit".to_string(), |s| s.to_string_lossy().into_owned());
        // The scene as given must be valid (this also reports TOML syntax errors).
        let scene = MicroScene::from_str(scene_text, scene_file.clone(), name.clone())?;
        // A measured in-plane BRDF is one curve per incidence angle: the
        // model must be one too, so one wavelength at most.
        let wavelengths = scene.brdf_run().wavelengths_um.len();
        if wavelengths > 1 {
            return Err(FitError::Scene(scene_file.error(
                "light.wavelengths_um",
                format!(
                    "roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces {wavelengths} wavelengths: fit one wavelength at a time ([light] wavelengths_um = [W])"
                ),
            )));
        }
        // A measurement without azimuths is one curve per incidence angle:
        // the model must be one too, so one light azimuth.
        let azimuths = scene.brdf_run().phi_deg.len();
        if azimuths > 1 && measured.phi_i_deg.is_none() {
            return Err(FitError::Scene(scene_file.error(
                "light.phi_deg",
                format!(
                    "roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces {azimuths} light azimuths and the measurement has no phi_i_deg column: give each row's azimuth (column phi_i_deg after theta_i_deg, as inplane.csv of such a run has) or fit one azimuth ([light] phi_deg = P)"
                ),
            )));
        }
        // The model traces the scene's own surface (realisation 0) only.
        let realisations = scene.brdf_run().realisations;
        if realisations > 1 {
            return Err(FitError::Scene(scene_file.error(
                "surface.realisations",
                format!(
                    "roks fit traces one surface, but the scene has {realisations} realisations: fit with realisations = 1"
                ),
            )));
        }
        let table: Table = toml::from_str(scene_text)
            .map_err(|e| scene_file.error("", format!("invalid TOML: {}", e.message())))?;
        let opt = |option: &str, message: String| FitError::Options {
            option: option.into(),
            message,
        };
        if params.is_empty() {
            return Err(opt("--param", "give at least one parameter".into()));
        }
        let mut paths = Vec::new();
        for p in params {
            let key_err = |message: &dyn std::fmt::Display| FitError::Key {
                file: scene_file.file.clone(),
                key: p.key.clone(),
                message: message.to_string(),
            };
            p.check().map_err(|m| FitError::Param {
                spec: format!("{}={}:{}", p.key, p.lo, p.hi),
                message: m.to_string(),
            })?;
            let path: KeyPath = p.key.parse().map_err(|e| key_err(&e))?;
            path.get_number(&table).map_err(|e| key_err(&e))?;
            if paths.contains(&path) {
                return Err(key_err(&"given twice"));
            }
            paths.push(path);
        }
        if let Err(e) = crate::transport::launch::check_count(opts.photons) {
            return Err(opt("--photons", e.to_string()));
        }
        if opts.max_evaluations == 0 {
            return Err(opt("--max-evals", "must be > 0".into()));
        }
        if opts.tolerance.is_nan() || opts.tolerance < 0.0 {
            return Err(opt(
                "--tolerance",
                format!("must be >= 0, got {}", opts.tolerance),
            ));
        }
        if opts.x_tolerance.is_nan() || opts.x_tolerance < 0.0 {
            return Err(opt(
                "--x-tolerance",
                format!("must be >= 0, got {}", opts.x_tolerance),
            ));
        }
        if let Some(s) = opts.inplane_step_deg {
            if InPlaneTally::new(s, 0.5, 0.0).is_none() {
                return Err(opt(
                    "--inplane-step",
                    format!(
                        "must divide 180 into at most {} bins (a step of at least 0.01 deg), got {s}",
                        crate::tally::inplane::MAX_BINS
                    ),
                ));
            }
        }
        if let Some(w) = opts.inplane_width_deg {
            if let Some(e) = InPlaneTally::width_error(w) {
                return Err(opt("--inplane-width", e.to_string()));
            }
        }
        let max = measured.points.iter().map(|p| p.2).fold(0.0, f64::max);
        if measured.points.is_empty() || max <= 0.0 || max.is_nan() {
            return Err(FitError::Measured {
                file: "measured".into(),
                line: 0,
                message: "no positive brdf values".into(),
            });
        }
        let problem = Self {
            table,
            scene_file: scene_file.clone(),
            name,
            params: params.to_vec(),
            paths,
            measured: measured.clone(),
            thetas: measured.incidence_angles(),
            phis: measured.azimuths(),
            eps: 1e-3 * max,
            opts: opts.clone(),
        };
        problem.check_bounds()?;
        Ok(problem)
    }

    /// Refuse bounds the scene rejects, before any photon is traced: the
    /// scene is built (every check of the scene file, no tracing) at the
    /// start point, and at both bounds of every parameter with the others at
    /// their start values. What the search can still meet is a combination
    /// (two ends of one range crossing, say); such points are recorded with
    /// their reason in [`FitResult::rejected`].
    fn check_bounds(&self) -> Result<(), FitError> {
        let start = self.start();
        let infeasible = |spec: String, at: String, e: Infeasible| FitError::Infeasible {
            file: self.scene_file.file.clone(),
            spec,
            at,
            reason: reason(&e.0),
        };
        if let Err(e) = self.build(&start) {
            let spec = self
                .params
                .iter()
                .map(|p| format!("{}={}:{}", p.key, p.lo, p.hi))
                .collect::<Vec<_>>()
                .join(" --param ");
            let at = self
                .params
                .iter()
                .zip(&start)
                .map(|(p, v)| format!("{} = {v}", p.key))
                .collect::<Vec<_>>()
                .join(", ");
            return Err(infeasible(
                spec,
                format!("at the start ({at}: the scene's values clamped into the bounds)"),
                e,
            ));
        }
        for (j, p) in self.params.iter().enumerate() {
            for v in [p.lo, p.hi] {
                let mut values = start.clone();
                values[j] = v;
                if let Err(e) = self.build(&values) {
                    return Err(infeasible(
                        format!("{}={}:{}", p.key, p.lo, p.hi),
                        format!("at {} = {v}", p.key),
                        e,
                    ));
                }
            }
        }
        Ok(())
    }

    /// The start point: the scene's current values clamped into the bounds.
    fn start(&self) -> Vec<f64> {
        self.params
            .iter()
            .zip(self.current())
            .map(|(p, v)| p.value_at(p.unit(v).clamp(0.0, 1.0)))
            .collect()
    }

    /// The scene with `values` written in (built and checked, not traced).
    fn build(&self, values: &[f64]) -> Result<MicroScene, Infeasible> {
        let text = self.table_with(values)?.to_string();
        MicroScene::from_str(&text, self.scene_file.clone(), self.name.clone())
            .map_err(|e| Infeasible(e.into()))
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &[FitParam] {
        &self.params
    }

    /// The scene's current values of the parameters (not clamped).
    #[must_use]
    pub fn current(&self) -> Vec<f64> {
        self.paths
            .iter()
            .map(|p| p.get_number(&self.table).expect("checked in new"))
            .collect()
    }

    /// `eps` of the log misfit: 1e-3 of the largest measured BRDF.
    #[must_use]
    pub fn eps(&self) -> f64 {
        self.eps
    }

    /// The scene table with `values` written in; ranges touched must stay `lo <= hi`.
    fn table_with(&self, values: &[f64]) -> Result<Table, Infeasible> {
        assert_eq!(values.len(), self.paths.len(), "one value per parameter");
        let mut t = self.table.clone();
        for (path, &v) in self.paths.iter().zip(values) {
            path.set_number(&mut t, v).expect("checked in new");
        }
        for path in &self.paths {
            if let Some(range) = range_parent(path) {
                let v = range.get_mut(&mut t).expect("checked in new");
                if let Value::Array(a) = v {
                    let num = |x: &Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
                    if let (Some(lo), Some(hi)) = (a.first().and_then(num), a.get(1).and_then(num))
                    {
                        if lo > hi {
                            return Err(Infeasible(FitError::Scene(self.scene_file.error(
                                range.to_string(),
                                format!("range [{lo}, {hi}] is reversed"),
                            ))));
                        }
                    }
                }
            }
        }
        Ok(t)
    }

    /// The scene text with `values` written in (comments and layout are not kept).
    pub fn apply(&self, values: &[f64]) -> Result<String, FitError> {
        self.table_with(values)
            .map(|t| t.to_string())
            .map_err(|e| e.0)
    }

    /// The model in-plane BRDF at every measured point, for `values`.
    pub fn model(&self, values: &[f64]) -> Result<Vec<f64>, Infeasible> {
        let scene = self.build(values)?;
        let mut run = scene.brdf_run();
        run.theta_deg.clone_from(&self.thetas);
        if let Some(phis) = &self.phis {
            run.phi_deg = crate::transport::brdf::Azimuths(phis.clone());
        }
        run.photons = self.opts.photons;
        run.seed = self.opts.seed;
        run.shard = None;
        if let Some(s) = self.opts.inplane_step_deg {
            run.inplane_step_deg = s;
        }
        if let Some(w) = self.opts.inplane_width_deg {
            run.inplane_width_deg = w;
        }
        let results = run.trace_whole(&scene.surface, &|_| {});
        let tally = run.inplane();
        let centres: Vec<f64> = (0..tally.n_bins()).map(|b| tally.centre_deg(b)).collect();
        // The curve of incidence `i` and light azimuth `a` (the result is
        // nested incidence x azimuth x wavelength; one wavelength).
        let curve = |i: usize, a: usize| -> Vec<f64> {
            let r = results.leaf(i, a, 0);
            let n = r.tallies.photons;
            (0..tally.n_bins())
                .map(|b| r.tallies.inplane.mean(b, n) / tally.projected_solid_angle(b))
                .collect()
        };
        let curves: Vec<Vec<Vec<f64>>> = (0..results.incidence.len())
            .map(|i| {
                (0..results.incidence[i].azimuth.len())
                    .map(|a| curve(i, a))
                    .collect()
            })
            .collect();
        Ok(self
            .measured
            .points
            .iter()
            .enumerate()
            .map(|(p, &(ti, to, _, _))| {
                let i = self
                    .thetas
                    .iter()
                    .position(|&t| t == ti)
                    .expect("distinct angles");
                let a = match (&self.phis, &self.measured.phi_i_deg) {
                    (Some(phis), Some(phi)) => phis
                        .iter()
                        .position(|&q| q == phi[p])
                        .expect("distinct azimuths"),
                    _ => 0,
                };
                interpolate(&centres, &curves[i][a], to)
            })
            .collect())
    }

    /// The log misfit of a model curve against the measurement.
    #[must_use]
    pub fn misfit_of(&self, model: &[f64]) -> f64 {
        let sum: f64 = self
            .measured
            .points
            .iter()
            .zip(model)
            .map(|(p, &m)| {
                let d = (m + self.eps).ln() - (p.2 + self.eps).ln();
                d * d
            })
            .sum();
        sum / self.measured.points.len() as f64
    }

    /// The misfit at `values` (infinite where the scene rejects them).
    #[must_use]
    pub fn misfit(&self, values: &[f64]) -> f64 {
        self.model(values)
            .map_or(f64::INFINITY, |m| self.misfit_of(&m))
    }

    /// Nelder-Mead from the scene's current values (see the module doc).
    pub fn fit(&self) -> Result<FitResult, FitError> {
        self.fit_observed(&mut |_, _, _, _| {})
    }

    /// As [`fit`](Self::fit), calling `observe(evaluation, values, misfit,
    /// rejected)` after every model run (`rejected`: why the scene rejected
    /// the values, the misfit then infinite).
    pub fn fit_observed(&self, observe: &mut Observer<'_>) -> Result<FitResult, FitError> {
        let d = self.params.len();
        let x0: Vec<f64> = self
            .params
            .iter()
            .zip(self.current())
            .map(|(p, v)| p.unit(v).clamp(0.0, 1.0))
            .collect();
        let to_values = |x: &[f64]| -> Vec<f64> {
            self.params
                .iter()
                .zip(x)
                .map(|(p, &u)| p.value_at(u))
                .collect()
        };
        let start = to_values(&x0);
        // The start must be a valid scene: its rejection is the user's error.
        let start_model = self.model(&start).map_err(|e| e.0)?;
        let start_misfit = self.misfit_of(&start_model);
        let mut history: Vec<(Vec<f64>, f64)> = vec![(start.clone(), start_misfit)];
        observe(1, &start, start_misfit, None);
        let mut rejected: Vec<(usize, String)> = Vec::new();

        let max_evals = self.opts.max_evaluations;
        let calls = std::cell::Cell::new(0_usize);
        // f on unconstrained unit coordinates: misfit at the clamped point + penalty.
        let mut f = |x: &[f64], history: &mut Vec<(Vec<f64>, f64)>| -> f64 {
            calls.set(calls.get() + 1);
            let outside: f64 = x.iter().map(|&u| (u - u.clamp(0.0, 1.0)).powi(2)).sum();
            let values = to_values(x);
            let g = match history.iter().find(|(v, _)| *v == values) {
                Some((_, g)) => *g,
                None => {
                    let (g, why) = match self.model(&values) {
                        Ok(m) => (self.misfit_of(&m), None),
                        Err(e) => (f64::INFINITY, Some(reason(&e.0))),
                    };
                    history.push((values.clone(), g));
                    observe(history.len(), &values, g, why.as_deref());
                    if let Some(why) = why {
                        rejected.push((history.len() - 1, why));
                    }
                    g
                }
            };
            g + outside
        };

        let order = |s: &mut Vec<(Vec<f64>, f64)>| {
            s.sort_by(|a, b| a.1.total_cmp(&b.1));
        };
        let mut converged;
        let mut restarts_done = 0;
        let mut simplex: Vec<(Vec<f64>, f64)>;
        let (mut from, mut from_misfit) = (x0.clone(), start_misfit);
        // A coarse global scan first: the misfit is rough on a fine scale (it is
        // piecewise constant in the photon paths), so a simplex started far
        // from the minimum can stall in a local one. Start from the best of a
        // stratified grid of `scan` points per parameter (at most 256 in all).
        let m = scan_points(self.opts.scan, d);
        if m > 1 {
            let total = m.pow(d as u32);
            for k in 0..total {
                let mut rem = k;
                let x: Vec<f64> = (0..d)
                    .map(|_| {
                        let i = rem % m;
                        rem /= m;
                        (i as f64 + 0.5) / m as f64
                    })
                    .collect();
                let fx = f(&x, &mut history);
                if fx < from_misfit {
                    (from, from_misfit) = (x, fx);
                }
            }
        }
        loop {
            // A fresh simplex: 10 % of each range, away from the nearer bound.
            simplex = vec![(from.clone(), from_misfit)];
            for j in 0..d {
                let mut x = from.clone();
                x[j] += if from[j] + 0.1 <= 1.0 { 0.1 } else { -0.1 };
                let fx = f(&x, &mut history);
                simplex.push((x, fx));
            }
            converged = false;
            loop {
                order(&mut simplex);
                let spread = simplex[d].1 - simplex[0].1;
                let size = simplex
                    .iter()
                    .flat_map(|(x, _)| x.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
                    .fold(0.0, f64::max);
                if (spread <= self.opts.tolerance && size <= self.opts.x_tolerance) || size < 1e-12
                {
                    converged = true;
                    break;
                }
                if history.len() >= max_evals || calls.get() >= 20 * max_evals + 100 {
                    break;
                }
                let centroid: Vec<f64> = (0..d)
                    .map(|j| simplex[..d].iter().map(|(x, _)| x[j]).sum::<f64>() / d as f64)
                    .collect();
                let worst = simplex[d].clone();
                let along = |t: f64| -> Vec<f64> {
                    centroid
                        .iter()
                        .zip(&worst.0)
                        .map(|(c, w)| c + t * (c - w))
                        .collect()
                };
                let xr = along(1.0);
                let fr = f(&xr, &mut history);
                if fr < simplex[0].1 {
                    let xe = along(2.0);
                    let fe = f(&xe, &mut history);
                    simplex[d] = if fe < fr { (xe, fe) } else { (xr, fr) };
                    continue;
                }
                if fr < simplex[d - 1].1 {
                    simplex[d] = (xr, fr);
                    continue;
                }
                let (xc, fc, accept) = if fr < worst.1 {
                    let xc = along(0.5);
                    let fc = f(&xc, &mut history);
                    let ok = fc <= fr;
                    (xc, fc, ok)
                } else {
                    let xc = along(-0.5);
                    let fc = f(&xc, &mut history);
                    let ok = fc < worst.1;
                    (xc, fc, ok)
                };
                if accept {
                    simplex[d] = (xc, fc);
                    continue;
                }
                let best = simplex[0].0.clone();
                for v in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> = best
                        .iter()
                        .zip(&v.0)
                        .map(|(b, x)| b + 0.5 * (x - b))
                        .collect();
                    let fx = f(&x, &mut history);
                    *v = (x, fx);
                }
            }
            order(&mut simplex);
            // Restart from the best point: Nelder-Mead can stall on a
            // degenerate simplex; a restart that gains nothing confirms it.
            let improved = simplex[0].1 < from_misfit - self.opts.tolerance;
            if !converged || restarts_done >= self.opts.restarts || (restarts_done > 0 && !improved)
            {
                break;
            }
            restarts_done += 1;
            from = simplex[0].0.iter().map(|u| u.clamp(0.0, 1.0)).collect();
            let values = to_values(&from);
            from_misfit = history
                .iter()
                .find(|(v, _)| *v == values)
                .map_or(simplex[0].1, |h| h.1);
        }
        order(&mut simplex);
        let values = to_values(&simplex[0].0);
        let misfit = history
            .iter()
            .find(|(v, _)| *v == values)
            .map_or(simplex[0].1, |h| h.1);
        let model = self.model(&values).map_err(|e| e.0)?;
        // Within the stopping box of a bound counts as on it.
        let near = self.opts.x_tolerance.max(1e-9);
        let at_bounds = self
            .params
            .iter()
            .zip(&values)
            .map(|(p, &v)| {
                let u = p.unit(v);
                if u <= near {
                    Bound::Lower
                } else if u >= 1.0 - near {
                    Bound::Upper
                } else {
                    Bound::Inside
                }
            })
            .collect();
        Ok(FitResult {
            values,
            misfit,
            start,
            start_misfit,
            evaluations: history.len(),
            converged,
            at_bounds,
            history,
            rejected,
            model,
        })
    }
}

/// Points per parameter of the coarse scan for `scan` requested and `d`
/// parameters: the largest `m <= scan` with `m^d <= 256` points in all, at
/// least 2; 0 (no scan) when `scan < 2`, `d = 0` or even `2^d` exceeds 256.
fn scan_points(scan: usize, d: usize) -> usize {
    if d == 0 {
        return 0;
    }
    let fits = |m: usize| {
        u32::try_from(d)
            .ok()
            .and_then(|d| m.checked_pow(d))
            .is_some_and(|t| t <= 256)
    };
    (2..=scan.min(256)).rev().find(|&m| fits(m)).unwrap_or(0)
}

/// Linear interpolation of per-bin values `bins` at signed in-plane angle
/// `theta_o` between the bin centres `centres` (increasing); constant beyond
/// the outermost centres.
fn interpolate(centres: &[f64], bins: &[f64], theta_o: f64) -> f64 {
    let n = bins.len();
    if theta_o <= centres[0] {
        return bins[0];
    }
    if theta_o >= centres[n - 1] {
        return bins[n - 1];
    }
    // First centre above theta_o: in 1..n.
    let hi = centres.partition_point(|&c| c <= theta_o);
    let lo = hi - 1;
    let t = (theta_o - centres[lo]) / (centres[hi] - centres[lo]);
    if t == 0.0 {
        bins[lo]
    } else {
        (1.0 - t) * bins[lo] + t * bins[hi]
    }
}

/// Fit `params` of the micro scene `scene_text` to `measured` (see the module doc).
pub fn fit(
    scene_text: &str,
    scene_file: &SceneFile,
    params: &[FitParam],
    measured: &Measured,
    opts: &FitOptions,
) -> Result<FitResult, FitError> {
    Problem::new(scene_text, scene_file, params, measured, opts)?.fit()
}

/// The misfit at `values` of `params` (infinite where the scene rejects them).
pub fn misfit(
    scene_text: &str,
    scene_file: &SceneFile,
    params: &[FitParam],
    values: &[f64],
    measured: &Measured,
    opts: &FitOptions,
) -> Result<f64, FitError> {
    let p = Problem::new(scene_text, scene_file, params, measured, opts)?;
    if values.len() != params.len() {
        return Err(FitError::Options {
            option: "values".into(),
            message: format!("{} values for {} parameters", values.len(), params.len()),
        });
    }
    Ok(p.misfit(values))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::inplane_csv::write as inplane_csv;

    fn scene_file() -> SceneFile {
        SceneFile {
            file: "test.toml".into(),
            dir: ".".into(),
        }
    }

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

    #[test]
    fn scan_points_stay_within_256() {
        assert_eq!(scan_points(8, 1), 8);
        assert_eq!(scan_points(8, 2), 8);
        assert_eq!(scan_points(8, 3), 6);
        assert_eq!(scan_points(8, 8), 2);
        assert_eq!(scan_points(8, 9), 0);
        assert_eq!(scan_points(1, 1), 0);
        assert_eq!(scan_points(0, 1), 0);
        assert_eq!(scan_points(8, 0), 0);
        // Huge requests: no overflow, no count-down loop.
        assert_eq!(scan_points(usize::MAX, 1), 256);
        assert_eq!(scan_points(usize::MAX, 4), 4);
        assert_eq!(scan_points(usize::MAX, 100), 0);
    }

    #[test]
    fn interpolation_between_centres() {
        let c = [-88.75, -85.0, -80.0, 0.0, 88.75];
        let b = [1.0, 2.0, 4.0, 8.0, 16.0];
        assert_eq!(interpolate(&c, &b, -90.0), 1.0);
        assert_eq!(interpolate(&c, &b, -88.75), 1.0);
        assert_eq!(interpolate(&c, &b, -85.0), 2.0);
        assert_eq!(interpolate(&c, &b, -82.5), 3.0);
        assert_eq!(interpolate(&c, &b, -40.0), 6.0);
        assert_eq!(interpolate(&c, &b, 0.0), 8.0);
        assert_eq!(interpolate(&c, &b, 90.0), 16.0);
    }

    // ------------------------------------------------------------ measured file

    #[test]
    fn measured_parse() {
        let m = Measured::parse(
            "# Z-302 at 10.6 um\ntheta_i_deg,theta_o_deg,brdf\n30,-10,0.5\n\n30, 25.5 ,1e-2\n60,80,0\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(
            m.points,
            vec![
                (30.0, -10.0, 0.5, None),
                (30.0, 25.5, 0.01, None),
                (60.0, 80.0, 0.0, None)
            ]
        );
        assert_eq!(m.incidence_angles(), vec![30.0, 60.0]);
        let m = Measured::parse(
            "theta_i_deg,theta_o_deg,brdf,brdf_stderr\n0,0,1,0.1\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(m.points, vec![(0.0, 0.0, 1.0, Some(0.1))]);
        assert_eq!(m.phi_i_deg, None);
        // The columns of inplane.csv of a run of several light azimuths.
        let m = Measured::parse(
            "theta_i_deg,phi_i_deg,theta_o_deg,brdf,brdf_stderr\n30,0,5,1,0.1\n30,90,5,2,0.2\n60,90,-5,3,0.3\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(
            m.points,
            vec![
                (30.0, 5.0, 1.0, Some(0.1)),
                (30.0, 5.0, 2.0, Some(0.2)),
                (60.0, -5.0, 3.0, Some(0.3))
            ]
        );
        assert_eq!(m.phi_i_deg, Some(vec![0.0, 90.0, 90.0]));
        assert_eq!(m.azimuths(), Some(vec![0.0, 90.0]));
        let m = Measured::parse(
            "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n0,45,0,1\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(m.points, vec![(0.0, 0.0, 1.0, None)]);
        assert_eq!(m.phi_i_deg, Some(vec![45.0]));

        let h = "theta_i_deg,theta_o_deg,brdf\n";
        for (text, msg) in [
            ("", "z.csv: line 0: empty file (no header)"),
            (
                "theta_i,theta_o,brdf\n30,0,1\n",
                "z.csv: line 1: header must be",
            ),
            ("30,0,1\n", "z.csv: line 1: header must be"),
            (h, "z.csv: line 0: no data rows"),
            (
                &format!("{h}30,0,abc\n"),
                "z.csv: line 2: field 3 `abc` is not a finite number",
            ),
            (
                &format!("{h}30,0,NaN\n"),
                "z.csv: line 2: field 3 `NaN` is not a finite number",
            ),
            (
                &format!("{h}30,0\n"),
                "z.csv: line 2: expected 3 fields, found 2",
            ),
            (
                &format!("{h}30,0,1,0.1\n"),
                "z.csv: line 2: expected 3 fields, found 4",
            ),
            (
                &format!("{h}90,0,1\n"),
                "z.csv: line 2: theta_i_deg must be in [0, 90), got 90",
            ),
            (
                &format!("{h}-5,0,1\n"),
                "z.csv: line 2: theta_i_deg must be in [0, 90), got -5",
            ),
            (
                &format!("{h}30,95,1\n"),
                "z.csv: line 2: theta_o_deg must be in [-90, 90], got 95",
            ),
            (
                &format!("{h}30,0,1\n30,5,-0.1\n"),
                "z.csv: line 3: brdf must be >= 0, got -0.1",
            ),
            (&format!("{h}30,0,0\n"), "z.csv: line 0: every brdf is 0"),
            (
                "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n30,360,0,1\n",
                "z.csv: line 2: phi_i_deg must be in [0, 360), got 360",
            ),
            (
                "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n30,0,1\n",
                "z.csv: line 2: expected 4 fields, found 3",
            ),
            (
                "theta_i_deg,theta_o_deg,phi_i_deg,brdf\n30,0,0,1\n",
                "z.csv: line 1: header must be",
            ),
            (
                "theta_i_deg,theta_o_deg,brdf,brdf_stderr\n30,0,1,-1\n",
                "z.csv: line 2: brdf_stderr must be >= 0, got -1",
            ),
        ] {
            let e = Measured::parse(text, "z.csv").unwrap_err().to_string();
            assert!(e.starts_with(msg), "`{text}`: got `{e}`, want `{msg}...`");
            assert!(!e.contains('\n'), "one line: {e}");
        }
    }

    // ------------------------------------------------------------ the fit

    /// 20 ellipsoid bumps of radius `r` and height `h` on a 12 x 12 periodic
    /// cell; `material` is the body of `[materials.m]`. The in-plane tally is
    /// 5 degree bins with a 10 degree detector: with 30 000 photons per angle
    /// that is ~100 photons per bin, enough for a misfit that falls steadily
    /// toward the truth (1 degree bins hold a few photons each and the misfit
    /// is noise a few hundredths away from the true value).
    fn scene(material: &str, h: &str, r: f64) -> String {
        format!(
            "[surface]\nsize = [12.0, 12.0]\nedges = \"periodic\"\nmaterial = \"m\"\n\
             [materials.m]\n{material}\n\
             [[bumps]]\nshape = \"ellipsoid\"\ncount = 20\nradius = {r:?}\nheight = {h}\nseed = 3\n\
             [light]\ntheta_deg = [0.0]\n\
             [tally]\ninplane_step_deg = 5.0\ninplane_width_deg = 10.0\n"
        )
    }

    const PHOTONS: u64 = 30_000;

    fn opts() -> FitOptions {
        FitOptions {
            photons: PHOTONS,
            seed: 7,
            ..FitOptions::default()
        }
    }

    /// The "measurement": roks's own `inplane.csv` of the true scene at 30
    /// and 60 degrees (same photons and seed as the fit), read back and
    /// sampled every 5 degrees from -80 to 80 by linear interpolation between
    /// its rows (independent of the fit's model code).
    fn measured_from(truth: &str) -> Measured {
        let scene = MicroScene::from_str(truth, scene_file(), "truth".into()).unwrap();
        let mut run = scene.brdf_run();
        run.theta_deg = vec![30.0, 60.0];
        run.photons = PHOTONS;
        run.seed = 7;
        let results = run.trace_whole(&scene.surface, &|_| {});
        let csv = inplane_csv(&run, &results);
        let rows: Vec<[f64; 4]> = csv
            .lines()
            .skip(1)
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|f| f.parse().unwrap()).collect();
                [v[0], v[1], v[2], v[3]]
            })
            .collect();
        // Linear interpolation between the CSV rows around `to`.
        let at = |ti: f64, to: f64| {
            let curve: Vec<&[f64; 4]> = rows.iter().filter(|r| r[0] == ti).collect();
            let k = curve.iter().position(|r| r[1] >= to).unwrap();
            if curve[k][1] == to {
                return curve[k][2];
            }
            let (a, b) = (curve[k - 1], curve[k]);
            let t = (to - a[1]) / (b[1] - a[1]);
            a[2] + t * (b[2] - a[2])
        };
        let mut text = String::from("theta_i_deg,theta_o_deg,brdf\n");
        for ti in [30.0, 60.0] {
            for k in -16..=16 {
                let to = 5.0 * f64::from(k);
                text.push_str(&format!("{ti},{to},{:e}\n", at(ti, to)));
            }
        }
        let m = Measured::parse(&text, "synthetic.csv").unwrap();
        assert_eq!(m.points.len(), 66);
        // Not a trivial measurement: the curve spans a decade or more.
        let (lo, hi) = m.points.iter().fold((f64::INFINITY, 0.0_f64), |(a, b), p| {
            (a.min(p.2), b.max(p.2))
        });
        assert!(hi > 10.0 * lo.max(1e-3 * hi), "flat curve {lo} .. {hi}");
        m
    }

    const PAINT: &str = "reflectance = 0.8";

    #[test]
    fn misfit_at_the_true_parameters_is_zero() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let params: Vec<FitParam> = vec![
            "bumps[0].height[1]=1:3".parse().unwrap(),
            "bumps[0].radius=1:4".parse().unwrap(),
        ];
        let probe = Measured {
            points: vec![
                (30.0, 0.0, 1.0, None),
                (60.0, 7.0, 1.0, None),
                (60.0, 89.0, 1.0, None),
            ],
            phi_i_deg: None,
        };
        // Model points from the fit's own model; then the misfit there is exactly 0.
        let p = Problem::new(&truth, &scene_file(), &params, &probe, &opts()).unwrap();
        assert_eq!(p.current(), vec![1.8, 2.5]);
        let model = p.model(&[1.8, 2.5]).unwrap();
        assert!(model.iter().all(|&b| b > 0.0), "{model:?}");
        let m = Measured {
            points: probe
                .points
                .iter()
                .zip(&model)
                .map(|(q, &b)| (q.0, q.1, b, None))
                .collect(),
            phi_i_deg: None,
        };
        let zero = misfit(&truth, &scene_file(), &params, &[1.8, 2.5], &m, &opts()).unwrap();
        assert_eq!(zero, 0.0);
        let off = misfit(&truth, &scene_file(), &params, &[1.7, 2.5], &m, &opts()).unwrap();
        assert!(off > 1e-4, "{off}");
        // Against roks's own inplane.csv route (9-digit CSV values): 0 to rounding.
        let m = measured_from(&truth);
        let p = Problem::new(&truth, &scene_file(), &params, &m, &opts()).unwrap();
        let near_zero = p.misfit(&[1.8, 2.5]);
        assert!(near_zero < 1e-15, "{near_zero}");
        // The model at every measured point, to the CSV's 9 digits.
        let model = p.model(&[1.8, 2.5]).unwrap();
        for (q, b) in m.points.iter().zip(&model) {
            assert!((b - q.2).abs() <= 1e-8 * q.2.max(1e-12), "{q:?} vs {b}");
        }
    }

    /// A scene of two light azimuths (issue 42): each measured row is
    /// compared with the curve of its own incidence and azimuth. The
    /// measurement is roks's own `inplane.csv` of the true scene at 30 and
    /// 60 degrees and azimuths 0 and 90 (its `phi_i_deg` column; same
    /// photons and seed as the fit), read whole: the misfit at the truth is
    /// 0 to the CSV's 9 digits, and the model at every row is that row.
    /// Each azimuth draws its own photons, so a row compared with another
    /// azimuth's or incidence's curve would differ. A measurement without
    /// azimuths cannot say which curve a row belongs to: refused.
    #[test]
    fn two_azimuths_compare_each_row_with_its_own_block() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5).replace(
            "[light]\ntheta_deg = [0.0]\n",
            "[light]\ntheta_deg = [0.0]\nphi_deg = [0.0, 90.0]\n",
        );
        let s = MicroScene::from_str(&truth, scene_file(), "truth".into()).unwrap();
        let mut run = s.brdf_run();
        assert_eq!(run.phi_deg.len(), 2);
        run.theta_deg = vec![30.0, 60.0];
        run.photons = PHOTONS;
        run.seed = 7;
        let results = run.trace_whole(&s.surface, &|_| {});
        let csv = inplane_csv(&run, &results);
        assert!(csv.starts_with("theta_i_deg,phi_i_deg,"), "{}", &csv[..60]);
        let m = Measured::parse(&csv, "truth/inplane.csv").unwrap();
        assert_eq!(m.azimuths(), Some(vec![0.0, 90.0]));
        let params: Vec<FitParam> = vec!["bumps[0].radius=1:4".parse().unwrap()];
        let p = Problem::new(&truth, &scene_file(), &params, &m, &opts()).unwrap();
        let model = p.model(&[2.5]).unwrap();
        let mut differ = 0;
        for (q, b) in m.points.iter().zip(&model) {
            assert!((b - q.2).abs() <= 1e-8 * q.2.max(1e-12), "{q:?} vs {b}");
            differ += usize::from(q.2 > 0.0 && (b - q.2).abs() > 1e-3 * q.2);
        }
        assert_eq!(differ, 0);
        let near_zero = p.misfit(&[2.5]);
        assert!(near_zero < 1e-15, "{near_zero}");
        // The blocks differ from each other (other photons, other angle):
        // a row read against another block's curve would show.
        let n = m.points.len() / 4;
        let block = |k: usize| &m.points[k * n..(k + 1) * n];
        let apart = |a: &[(f64, f64, f64, Option<f64>)], b: &[(f64, f64, f64, Option<f64>)]| {
            a.iter()
                .zip(b)
                .filter(|(x, y)| (x.2 - y.2).abs() > 1e-6 * x.2.max(y.2))
                .count()
        };
        assert!(apart(block(1), block(2)) > n / 2, "(30, 90) vs (60, 0)");
        assert!(apart(block(0), block(1)) > n / 2, "(30, 0) vs (30, 90)");
        // The measured azimuths are traced, whatever the scene's.
        let one = truth.replace("phi_deg = [0.0, 90.0]", "phi_deg = 45.0");
        let p = Problem::new(&one, &scene_file(), &params, &m, &opts()).unwrap();
        assert!(p.misfit(&[2.5]) < 1e-15);
        // Without phi_i_deg: refused, naming the key.
        let rows = Measured {
            points: m.points.clone(),
            phi_i_deg: None,
        };
        let e = Problem::new(&truth, &scene_file(), &params, &rows, &opts()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.toml: light.phi_deg: roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces 2 light azimuths and the measurement has no phi_i_deg column: give each row's azimuth (column phi_i_deg after theta_i_deg, as inplane.csv of such a run has) or fit one azimuth ([light] phi_deg = P)"
        );
    }

    #[test]
    fn infeasible_points_have_infinite_misfit() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let m = Measured {
            points: vec![(30.0, 0.0, 1.0, None)],
            phi_i_deg: None,
        };
        // Each bound alone is valid (with the other end at its start value),
        // but the two ends can cross.
        let params: Vec<FitParam> = vec![
            "bumps[0].height[0]=0.5:1.6".parse().unwrap(),
            "bumps[0].height[1]=1.3:3".parse().unwrap(),
        ];
        let p = Problem::new(&truth, &scene_file(), &params, &m, &opts()).unwrap();
        // hi < lo: a reversed range.
        assert_eq!(p.misfit(&[1.5, 1.4]), f64::INFINITY);
        let e = p.apply(&[1.5, 1.4]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.toml: bumps[0].height: range [1.5, 1.4] is reversed"
        );
        assert_eq!(reason(&e), "bumps[0].height: range [1.5, 1.4] is reversed");
        assert!(p.misfit(&[1.4, 1.4]).is_finite());
        // Values the scene itself rejects.
        let r: FitParam = "materials.m.reflectance=0:1".parse().unwrap();
        let p = Problem::new(&truth, &scene_file(), &[r], &m, &opts()).unwrap();
        assert_eq!(p.misfit(&[1.5]), f64::INFINITY);
        assert!(matches!(
            p.model(&[1.5]),
            Err(Infeasible(FitError::Scene(_)))
        ));
        // The fitted scene text carries the value.
        let text = p.apply(&[0.25]).unwrap();
        let back = MicroScene::from_str(&text, scene_file(), "x".into()).unwrap();
        assert_eq!(back.surface.materials.len(), 1);
        assert_eq!(
            path("materials.m.reflectance").get_number(&table(&text)),
            Ok(0.25)
        );
    }

    #[test]
    fn problem_errors_name_file_and_key() {
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let m = Measured {
            points: vec![(30.0, 0.0, 1.0, None)],
            phi_i_deg: None,
        };
        let new = |spec: &str| {
            let p: FitParam = spec.parse().unwrap();
            Problem::new(&truth, &scene_file(), &[p], &m, &opts())
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            new("bumps[0].hieght=1:2"),
            "test.toml: --param bumps[0].hieght: no key `hieght` in `bumps[0]` (keys: count, height, radius, seed, shape)"
        );
        assert_eq!(
            new("bumps[1].height=1:2"),
            "test.toml: --param bumps[1].height: index [1] out of range: `bumps` has 1 element"
        );
        assert_eq!(
            new("bumps[0].shape=1:2"),
            "test.toml: --param bumps[0].shape: is a string, not a number"
        );
        assert_eq!(
            new("bumps[0].height=1:2"),
            "test.toml: --param bumps[0].height: is a range [1.0, 1.8]; fit one end: bumps[0].height[0] or bumps[0].height[1]"
        );
        // Bounds the scene rejects, found by building it at both bounds.
        assert_eq!(
            new("bumps[0].radius=0:3"),
            "test.toml: --param bumps[0].radius=0:3: at bumps[0].radius = 0, the scene is invalid: bumps[0].radius: must be > 0, got 0"
        );
        assert_eq!(
            new("bumps[0].height[1]=0.5:3"),
            "test.toml: --param bumps[0].height[1]=0.5:3: at bumps[0].height[1] = 0.5, the scene is invalid: bumps[0].height: range [1, 0.5] is reversed"
        );
        assert_eq!(
            new("materials.m.reflectance=0.5:1.5"),
            "test.toml: --param materials.m.reflectance=0.5:1.5: at materials.m.reflectance = 1.5, the scene is invalid: materials.m.reflectance: must be in [0, 1], got 1.5"
        );
        // A spectral scene: one model curve per angle and wavelength, where
        // the measurement has one per angle; one wavelength is fine.
        let spectral = |w: &str| {
            let text = truth.replace("[light]\n", &format!("[light]\nwavelengths_um = {w}\n"));
            let p: FitParam = "bumps[0].radius=1:3".parse().unwrap();
            Problem::new(&text, &scene_file(), &[p], &m, &opts()).map(|_| ())
        };
        assert_eq!(
            spectral("[0.45, 0.65]").unwrap_err().to_string(),
            "test.toml: light.wavelengths_um: roks fit compares one in-plane curve per incidence angle with the measurement, but the scene traces 2 wavelengths: fit one wavelength at a time ([light] wavelengths_um = [W])"
        );
        assert!(spectral("[0.55]").is_ok());
        let bad_scene = truth.replace("\"ellipsoid\"", "\"blob\"");
        let p: FitParam = "bumps[0].radius=1:2".parse().unwrap();
        let e = Problem::new(
            &bad_scene,
            &scene_file(),
            std::slice::from_ref(&p),
            &m,
            &opts(),
        )
        .unwrap_err();
        assert!(matches!(e, FitError::Scene(_)));
        assert!(
            e.to_string()
                .starts_with("test.toml: bumps[0].shape: unknown variant `blob`"),
            "{e}"
        );
        let e =
            Problem::new(&truth, &scene_file(), &[p.clone(), p.clone()], &m, &opts()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.toml: --param bumps[0].radius: given twice"
        );
        let e = Problem::new(&truth, &scene_file(), &[], &m, &opts()).unwrap_err();
        assert_eq!(e.to_string(), "--param: give at least one parameter");
        let o = FitOptions {
            inplane_step_deg: Some(7.0),
            ..opts()
        };
        let e = Problem::new(&truth, &scene_file(), &[p], &m, &o).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--inplane-step: must divide 180 into at most 18000 bins (a step of at least 0.01 deg), got 7"
        );
    }

    #[test]
    fn recovers_one_height() {
        // Same seed for data and fit: this tests the search and the pipeline
        // exactly (a wrong key path, interpolation or bound mapping misses
        // the exact zero), not the statistics; tests/fit_recovery.rs fits
        // data with independent noise.
        // Truth h = 1.8; start at 1.0 in bounds 0.5:3. With common random
        // numbers the misfit is exactly 0 at h = 1.8 and already ~1e-3 at
        // 1.8 -+ 0.001-0.01 (a scan of this scene), rising steadily to 0.9 at
        // h = 1.0; the search stops on a simplex 1e-3 of the range wide
        // (0.0025 in h). So h must come back to a few thousandths: we ask 0.01
        // (0.6 %).
        let truth = scene(PAINT, "1.8", 2.5);
        let m = measured_from(&truth);
        let start = scene(PAINT, "1.0", 2.5);
        let params = vec!["bumps[0].height=0.5:3".parse::<FitParam>().unwrap()];
        let clock = std::time::Instant::now();
        let r = fit(&start, &scene_file(), &params, &m, &opts()).unwrap();
        eprintln!(
            "one height: {:?} misfit {:.2e} (start {:.2e}) in {} runs, {:.2} s",
            r.values,
            r.misfit,
            r.start_misfit,
            r.evaluations,
            clock.elapsed().as_secs_f64()
        );
        assert_eq!(r.start, vec![1.0]);
        assert!(r.start_misfit > 0.1, "{}", r.start_misfit);
        assert!(r.converged);
        assert!((r.values[0] - 1.8).abs() < 0.01, "{:?}", r.values);
        assert!(r.misfit < 1e-4, "{}", r.misfit);
        assert_eq!(r.at_bounds, vec![Bound::Inside]);
        assert_eq!(r.evaluations, r.history.len());
        assert!(r.evaluations <= FitOptions::default().max_evaluations);
        assert_eq!(r.model.len(), m.points.len());
        // The best point is the least misfit of the history.
        let least = r.history.iter().map(|h| h.1).fold(f64::INFINITY, f64::min);
        assert_eq!(r.misfit, least);
    }

    #[test]
    fn recovers_one_end_of_a_range() {
        // height = [1.2, 2.2]; fit the top end from 1.5 in 1.2:3 (bounds
        // below 1.2 would reverse the range: refused before the fit).
        let truth = scene(PAINT, "[1.2, 2.2]", 2.5);
        let m = measured_from(&truth);
        let start = scene(PAINT, "[1.2, 1.5]", 2.5);
        let params = vec!["bumps[0].height[1]=1.2:3".parse::<FitParam>().unwrap()];
        let r = fit(&start, &scene_file(), &params, &m, &opts()).unwrap();
        eprintln!(
            "range end: {:?} misfit {:.2e} in {} runs",
            r.values, r.misfit, r.evaluations
        );
        assert!((r.values[0] - 2.2).abs() < 0.01, "{:?}", r.values);
        assert!(r.misfit < 1e-4, "{}", r.misfit);
    }

    #[test]
    fn rejected_points_are_recorded_with_their_reason() {
        // Both ends of the height range: each bound is valid with the other
        // end at its start (1.0 and 1.8), but the scan meets points where the
        // ends cross. They are recorded with the scene's reason, not dropped.
        let truth = scene(PAINT, "[1.0, 1.8]", 2.5);
        let m = measured_from(&truth);
        let params: Vec<FitParam> = vec![
            "bumps[0].height[0]=0.5:1.75".parse().unwrap(),
            "bumps[0].height[1]=1.1:3".parse().unwrap(),
        ];
        let o = FitOptions {
            photons: 2000,
            scan: 4,
            max_evaluations: 20,
            restarts: 0,
            ..opts()
        };
        let mut seen = Vec::new();
        let r = Problem::new(&truth, &scene_file(), &params, &m, &o)
            .unwrap()
            .fit_observed(&mut |k, _, g, why| seen.push((k, g, why.map(str::to_string))))
            .unwrap();
        assert!(!r.rejected.is_empty());
        assert!(r.misfit.is_finite());
        for (k, why) in &r.rejected {
            let (v, g) = &r.history[*k];
            assert!(v[0] > v[1], "{v:?}");
            assert_eq!(*g, f64::INFINITY);
            assert_eq!(
                *why,
                format!("bumps[0].height: range [{}, {}] is reversed", v[0], v[1])
            );
            assert_eq!(seen[*k], (k + 1, f64::INFINITY, Some(why.clone())));
        }
        // Every infinite misfit of the history is a recorded rejection.
        let infinite = r.history.iter().filter(|h| h.1.is_infinite()).count();
        assert_eq!(infinite, r.rejected.len());
    }

    #[test]
    fn recovers_height_and_refractive_index() {
        // Fresnel dielectric n = 1.5 (k = 0), h = 1.8; start n = 1.2, h = 1.0.
        // Same argument as for one height; n's range 1.05:3 gives a stopping
        // box of 0.002 in n: ask 1 % for both.
        let truth = scene("n = 1.5\nk = 0.0", "1.8", 2.5);
        let m = measured_from(&truth);
        let start = scene("n = 1.2\nk = 0.0", "1.0", 2.5);
        let params: Vec<FitParam> = vec![
            "bumps[0].height=0.5:3".parse().unwrap(),
            "materials.m.n=1.05:3".parse().unwrap(),
        ];
        let clock = std::time::Instant::now();
        let r = fit(&start, &scene_file(), &params, &m, &opts()).unwrap();
        eprintln!(
            "height and n: {:?} misfit {:.2e} (start {:.2e}) in {} runs, {:.2} s",
            r.values,
            r.misfit,
            r.start_misfit,
            r.evaluations,
            clock.elapsed().as_secs_f64()
        );
        assert!(r.converged);
        assert!((r.values[0] - 1.8).abs() < 0.018, "{:?}", r.values);
        assert!((r.values[1] - 1.5).abs() < 0.015, "{:?}", r.values);
        assert!(r.misfit < 1e-4, "{}", r.misfit);
        assert_eq!(r.at_bounds, vec![Bound::Inside, Bound::Inside]);
    }

    #[test]
    fn reports_bounds() {
        // The truth (h = 1.8) lies above the bounds 0.5:1.5: the fit ends on
        // the upper bound and says so.
        let truth = scene(PAINT, "1.8", 2.5);
        let m = measured_from(&truth);
        let params = vec!["bumps[0].height=0.5:1.5".parse::<FitParam>().unwrap()];
        let start = scene(PAINT, "1.0", 2.5);
        let o = FitOptions {
            restarts: 0,
            ..opts()
        };
        let r = fit(&start, &scene_file(), &params, &m, &o).unwrap();
        assert_eq!(r.at_bounds, vec![Bound::Upper], "{:?}", r.values);
        assert!(
            r.values[0] >= 1.5 - 1e-3 * 1.0 && r.values[0] <= 1.5,
            "{:?}",
            r.values
        );
    }
}
