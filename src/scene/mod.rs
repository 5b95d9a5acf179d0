//! Scene files (TOML): what users write, checked before anything runs.
//!
//! Every error is one line naming the file and the key, e.g.
//! `scenes/x.toml: bumps[0].shape: unknown variant `blob`, expected one of ...`.
//! The binary turns a [`SceneError`] into exit status 2 before any output is
//! written. Pieces shared by micro and macro scenes (named quadrics,
//! materials, ranges) live here; [`micro`] holds the micro scene.

pub mod keys;
pub mod micro;
pub mod object;
pub mod source;

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use crate::num::Num;

use glam::DVec3;
use serde::Deserialize;

use crate::geometry::body::{Aabb, Body, MAX_SURFACES};
use crate::geometry::quadric::Quadric;
use crate::geometry::region;
use crate::optics::material::{AngleTable, Reflectance};
use crate::optics::polarisation::Incident;

/// A problem with a scene file: which file, which key, what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneError {
    /// The scene file (or `<default>` for the embedded scene).
    pub file: String,
    /// Dotted key path, e.g. `bumps[0].radius` (empty for syntax errors).
    pub key: String,
    /// What is wrong (one line).
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}: {}", self.file, self.message)
        } else {
            write!(f, "{}: {}: {}", self.file, self.key, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

/// Where a scene came from: the file name for messages and the folder for relative paths.
#[derive(Debug, Clone)]
pub struct SceneFile {
    /// Name used in messages.
    pub file: String,
    /// Folder that relative paths in the scene (tables, micro scenes) are read from.
    pub dir: PathBuf,
}

impl SceneFile {
    /// A scene read from `path`.
    #[must_use]
    pub fn from_path(path: &Path) -> Self {
        Self {
            file: path.display().to_string(),
            dir: path
                .parent()
                .map_or_else(|| PathBuf::from("."), Path::to_path_buf),
        }
    }

    /// An error at `key`.
    #[must_use]
    pub fn error(&self, key: impl Into<String>, message: impl fmt::Display) -> SceneError {
        SceneError {
            file: self.file.clone(),
            key: key.into(),
            message: one_line(&message.to_string()),
        }
    }

    /// The files `files` (`(key, path relative to the scene's folder)`:
    /// the list a scene's [`Content`] hashes) as reached from the working
    /// folder: what the scene reads, which no output may replace
    /// ([`crate::outdir::check::check_kept`]).
    #[must_use]
    pub fn paths(&self, files: &[(String, String)]) -> Vec<PathBuf> {
        files.iter().map(|(_, f)| self.dir.join(f)).collect()
    }

    /// Refuse at `key` when `bytes`, the estimate for `what` (e.g. "periodic
    /// ghost copies"), exceed the memory limit ([`crate::limits`]).
    pub fn check_memory(&self, key: &str, what: &str, bytes: u64) -> Result<(), SceneError> {
        crate::limits::check(what, bytes).map_err(|e| self.error(key, e))
    }
}

/// What a scene is made of, so that runs are told apart by content and
/// not by the path they were given: the SHA-256 of the scene text and of
/// every file it reads (n, k tables, angle tables, height maps), each
/// named by the key that names the file.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Content {
    /// SHA-256 (lower-case hex) of each file the scene reads, by its key
    /// (`materials.gold.nk`, `materials.paint.table[1]`,
    /// `surface.heightfield.file`).
    pub files: BTreeMap<String, String>,
    /// SHA-256 (lower-case hex) of the scene text.
    pub scene_sha256: String,
}

impl Content {
    /// The content of the scene `text` of `scene_file` that reads `files`
    /// (`(key, path relative to the scene's folder)`).
    ///
    /// # Errors
    /// A file that cannot be read, at its key.
    pub fn of(
        scene_file: &SceneFile,
        text: &str,
        files: &[(String, String)],
    ) -> Result<Self, SceneError> {
        let files = files
            .iter()
            .zip(scene_file.paths(files))
            .map(|((key, _), path)| {
                sha256_file(&path).map(|h| (key.clone(), h)).map_err(|e| {
                    scene_file.error(key, format!("{}: cannot read: {e}", path.display()))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            files,
            scene_sha256: hex(&sha2::Sha256::digest(text.as_bytes())),
        })
    }
}

use sha2::Digest as _;

/// Lower-case hex of `bytes`.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 (lower-case hex) of the file at `path`, read in blocks of 1 MiB.
fn sha256_file(path: &Path) -> std::io::Result<String> {
    use std::io::Read as _;
    crate::limits::require_regular(path)?;
    let mut file = std::fs::File::open(path)?;
    let mut hasher = sha2::Sha256::new();
    let mut buf = vec![0; 1 << 20];
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hex(&hasher.finalize()))
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `error` of a scene that did not parse, or, when `text` is a valid TOML
/// table holding the top-level key `marker` of the other kind of scene
/// (micro or object), a message saying so (`what`), at that key.
pub(crate) fn other_kind(text: &str, marker: &str, error: SceneError, what: &str) -> SceneError {
    match text.parse::<toml::Table>() {
        Ok(t) if t.contains_key(marker) => SceneError {
            key: marker.into(),
            message: format!("this is {what}"),
            ..error
        },
        _ => error,
    }
}

/// Deserialize `text` as `T`, reporting the key path of the first problem.
pub fn parse_toml<T: serde::de::DeserializeOwned>(
    scene_file: &SceneFile,
    text: &str,
) -> Result<T, SceneError> {
    let line_of = |span: Option<std::ops::Range<usize>>| {
        span.map(|s| {
            text.as_bytes()[..s.start.min(text.len())]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1
        })
    };
    let de = toml::Deserializer::parse(text).map_err(|e| {
        let at = line_of(e.span()).map_or(String::new(), |l| format!("line {l}: "));
        scene_file.error("", format!("{at}invalid TOML: {}", e.message()))
    })?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let key = if key == "." { String::new() } else { key };
        let inner = e.inner();
        let at = line_of(inner.span()).map_or(String::new(), |l| format!(" (line {l})"));
        scene_file.error(key, format!("{}{at}", inner.message()))
    })
}

/// The scene's name, which is also its result folder `out/NAME`: the
/// `name` key, or else `fallback` (the file stem); an error at `name` unless
/// it is one plain folder name (see [`crate::outdir::check_name`]). Refused
/// rather than mapped to a safe name: a mapped name would write where the
/// user did not say, and two names could map to one folder.
pub fn scene_name(
    scene_file: &SceneFile,
    given: Option<String>,
    fallback: String,
) -> Result<String, SceneError> {
    let from_file = given.is_none();
    let name = given.unwrap_or(fallback);
    match crate::outdir::check_name(&name) {
        None => Ok(name),
        Some(why) if from_file => Err(scene_file.error(
            "name",
            format!("not given, and the file name does not make one: {why}; set name = \"...\""),
        )),
        Some(why) => Err(scene_file.error("name", why)),
    }
}

/// The command-line option of `keys` (`(scene key, option)` pairs: the
/// keys the options replaced) that set the key of `e`, and `e`'s message
/// for it, with the position in the option's list for a listed value
/// (`light.theta_deg[2]` is `--theta: angle 3: ...`); `None` when `e`
/// concerns a key the scene file set.
#[must_use]
pub fn option_error(
    keys: &[(&'static str, &'static str)],
    e: &SceneError,
) -> Option<(&'static str, String)> {
    keys.iter().find_map(|&(key, option)| {
        let rest = e.key.strip_prefix(key)?;
        if rest.is_empty() {
            return Some((option, e.message.clone()));
        }
        let i: usize = rest.strip_prefix('[')?.strip_suffix(']')?.parse().ok()?;
        let what = match key {
            "light.theta_deg" => "angle",
            "light.phi_deg" => "azimuth",
            _ => "wavelength",
        };
        Some((option, format!("{what} {}: {}", i + 1, e.message)))
    })
}

/// Read a scene file to a string; a missing file is a scene error.
pub fn read_scene_text(path: &Path) -> Result<String, SceneError> {
    crate::limits::read_text_capped(path, crate::limits::MAX_SCENE_BYTES).map_err(|e| SceneError {
        file: path.display().to_string(),
        key: String::new(),
        message: format!("cannot read: {e}"),
    })
}

/// The two kinds of scene file, told apart by their tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneKind {
    /// A rough surface (`[surface]`, [`micro::MicroScene`]): `roks brdf`.
    Micro,
    /// A 3-D object of zones (`[[cells]]`, [`object::ObjectScene`]): `roks trace`.
    Object,
}

impl SceneKind {
    /// The kind of the scene `text`: an object scene has the top-level key
    /// `cells`; anything else, also text that is not TOML (left to the micro
    /// loader's messages), is a micro scene.
    #[must_use]
    pub fn of_text(text: &str) -> Self {
        match text.parse::<toml::Table>() {
            Ok(t) if t.contains_key("cells") => Self::Object,
            _ => Self::Micro,
        }
    }
}

/// The kind of the scene file at `path` ([`SceneKind::of_text`]), for the
/// commands that take either kind.
///
/// # Errors
/// The file cannot be read (the loaders' message).
pub fn kind(path: &Path) -> Result<SceneKind, SceneError> {
    read_scene_text(path).map(|text| SceneKind::of_text(&text))
}

/// A number, or a `[lo, hi]` range sampled uniformly.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Range {
    /// A fixed value.
    One(f64),
    /// Uniform in `[lo, hi]`.
    Two([f64; 2]),
}

impl Range {
    /// `(lo, hi)`.
    #[must_use]
    pub fn bounds(&self) -> (f64, f64) {
        match *self {
            Self::One(v) => (v, v),
            Self::Two([a, b]) => (a, b),
        }
    }

    /// Check finite, `lo <= hi`, and `lo > min` (or `>=` when `inclusive`).
    pub fn check(
        &self,
        scene_file: &SceneFile,
        key: &str,
        min: f64,
        inclusive: bool,
    ) -> Result<(), SceneError> {
        let (lo, hi) = self.bounds();
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(scene_file.error(key, "must be finite"));
        }
        if lo > hi {
            return Err(
                scene_file.error(key, format!("range [{}, {}] is reversed", Num(lo), Num(hi)))
            );
        }
        let ok = if inclusive { lo >= min } else { lo > min };
        if !ok {
            let rel = if inclusive { ">=" } else { ">" };
            return Err(
                scene_file.error(key, format!("must be {rel} {}, got {}", Num(min), Num(lo)))
            );
        }
        Ok(())
    }

    /// A value for uniform `u` in `[0, 1)`.
    #[must_use]
    pub fn at(&self, u: f64) -> f64 {
        let (lo, hi) = self.bounds();
        lo + (hi - lo) * u
    }
}

/// A named surface in `[quadrics]`: exactly one constructor key.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum QuadricSpec {
    /// `a x + b y + c z - d`.
    Plane([f64; 4]),
    /// `A x² + B y² + C z² + D xy + E yz + F xz + G x + H y + J z + K`.
    Quadric([f64; 10]),
    /// Sphere: `|p - center|² - r²`.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius (> 0).
        r: f64,
    },
    /// Axis-aligned ellipsoid.
    Ellipsoid {
        /// Centre.
        center: [f64; 3],
        /// Semi-axes (> 0).
        semi_axes: [f64; 3],
    },
    /// Cylinder along x through `center` (default origin).
    CylinderX(CylinderSpec),
    /// Cylinder along y.
    CylinderY(CylinderSpec),
    /// Cylinder along z.
    CylinderZ(CylinderSpec),
    /// Double cone along x: `rho² - t2 (x - apex_x)²`.
    ConeX(ConeSpec),
    /// Double cone along y.
    ConeY(ConeSpec),
    /// Double cone along z.
    ConeZ(ConeSpec),
    /// Paraboloid of revolution about z: `rho² - k (z - vertex_z)`.
    ParaboloidZ {
        /// Vertex.
        vertex: [f64; 3],
        /// `k`: positive opens upward.
        k: f64,
    },
}

/// Parameters of an axis cylinder.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CylinderSpec {
    /// Radius (> 0).
    pub r: f64,
    /// A point on the axis (default the origin).
    #[serde(default)]
    pub center: [f64; 3],
}

/// Parameters of an axis cone.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ConeSpec {
    /// Apex.
    pub apex: [f64; 3],
    /// tan² of the half-angle (> 0).
    pub t2: f64,
}

impl QuadricSpec {
    /// The surface, or an error at `key`.
    pub fn build(&self, scene_file: &SceneFile, key: &str) -> Result<Quadric, SceneError> {
        let v = |a: [f64; 3]| DVec3::from_array(a);
        let positive = |x: f64, what: &str| {
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(scene_file.error(
                    format!("{key}.{what}"),
                    format!("must be > 0, got {}", Num(x)),
                ))
            }
        };
        let q = match self {
            Self::Plane([a, b, c, d]) => {
                if *a == 0.0 && *b == 0.0 && *c == 0.0 {
                    return Err(
                        scene_file.error(format!("{key}.plane"), "normal (a, b, c) is zero")
                    );
                }
                Quadric::plane(*a, *b, *c, *d)
            }
            Self::Quadric(c) => {
                if c[..9].iter().all(|&x| x == 0.0) {
                    return Err(scene_file.error(
                        format!("{key}.quadric"),
                        "all non-constant coefficients are zero",
                    ));
                }
                Quadric::general(*c)
            }
            Self::Sphere { center, r } => Quadric::sphere(v(*center), positive(*r, "r")?),
            Self::Ellipsoid { center, semi_axes } => {
                for (i, s) in semi_axes.iter().enumerate() {
                    positive(*s, &format!("semi_axes[{i}]"))?;
                }
                Quadric::ellipsoid(v(*center), v(*semi_axes))
            }
            Self::CylinderX(c) => Quadric::cylinder(0, v(c.center), positive(c.r, "r")?),
            Self::CylinderY(c) => Quadric::cylinder(1, v(c.center), positive(c.r, "r")?),
            Self::CylinderZ(c) => Quadric::cylinder(2, v(c.center), positive(c.r, "r")?),
            Self::ConeX(c) => Quadric::cone(0, v(c.apex), positive(c.t2, "t2")?),
            Self::ConeY(c) => Quadric::cone(1, v(c.apex), positive(c.t2, "t2")?),
            Self::ConeZ(c) => Quadric::cone(2, v(c.apex), positive(c.t2, "t2")?),
            Self::ParaboloidZ { vertex, k } => {
                if !(k.is_finite() && *k != 0.0) {
                    return Err(scene_file.error(format!("{key}.k"), "must be finite and non-zero"));
                }
                Quadric {
                    origin: v(*vertex),
                    coef: [1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -k, 0.0],
                }
            }
        };
        if q.coef
            .iter()
            .chain(q.origin.to_array().iter())
            .any(|x| !x.is_finite())
        {
            return Err(scene_file.error(key, "coefficients must be finite"));
        }
        Ok(q)
    }
}

/// A number, or one number per wavelength of a spectral scene.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(
    untagged,
    expecting = "a number, or an array of numbers (one per wavelength)"
)]
pub enum Values {
    /// The same at every wavelength.
    One(f64),
    /// One per wavelength of `[light] wavelengths_um`.
    Many(Vec<f64>),
}

impl From<f64> for Values {
    fn from(v: f64) -> Self {
        Self::One(v)
    }
}

/// A file, or one file per wavelength of a spectral scene.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(
    untagged,
    expecting = "a file name, or an array of file names (one per wavelength)"
)]
pub enum Files {
    /// The same at every wavelength.
    One(String),
    /// One per wavelength of `[light] wavelengths_um`.
    Many(Vec<String>),
}

/// `[light] wavelengths_um`: a list (µm), or an even grid `{ from, to, step }`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(
    untagged,
    deny_unknown_fields,
    expecting = "an array of wavelengths in um, or { from = .., to = .., step = .. } (no other key)"
)]
pub enum WavelengthsSpec {
    /// The wavelengths (µm), strictly increasing.
    List(Vec<f64>),
    /// `from, from + step, ...` up to `to` (included when it falls on the grid).
    Grid {
        /// First wavelength (µm).
        from: f64,
        /// Last wavelength (µm), at most.
        to: f64,
        /// Spacing (µm).
        step: f64,
    },
}

/// Why a grid of wavelengths (`{ from, to, step }`) cannot be expanded, or
/// the wavelengths of a list or grid are refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WavelengthsError {
    /// A step that is not finite and > 0.
    #[error("step must be > 0, got {}", Num(*.0))]
    Step(f64),
    /// Bounds that are not finite with `from <= to`.
    #[error("needs finite from <= to, got {} and {}", Num(*from), Num(*to))]
    Bounds {
        /// The first wavelength (µm).
        from: f64,
        /// The last wavelength (µm).
        to: f64,
    },
    /// More wavelengths than one trace carries.
    #[error("gives {count} wavelengths, more than the {max} one trace carries")]
    TooMany {
        /// The wavelengths the grid gives.
        count: f64,
        /// [`crate::optics::spectrum::MAX_WAVELENGTHS`].
        max: usize,
    },
    /// The wavelengths of the list or grid refused
    /// ([`WavelengthsSpec::resolve`]).
    #[error(transparent)]
    List(#[from] crate::optics::spectrum::WavelengthListError),
}

impl WavelengthsError {
    /// The index of the wavelength at fault (`None`: the whole key).
    #[must_use]
    pub fn index(&self) -> Option<usize> {
        match self {
            Self::List(e) => e.index(),
            _ => None,
        }
    }
}

impl WavelengthsSpec {
    /// The wavelengths (µm): the list, or the grid's points rounded to
    /// 1e-9 µm (so that `0.38 + 3 * 0.01` is written `0.41`), not yet
    /// checked (a micro scene checks them with its run,
    /// [`crate::transport::brdf::BrdfRun::check`]).
    ///
    /// # Errors
    /// [`WavelengthsError`], for the key: a bad grid.
    pub fn expand(&self) -> Result<Vec<f64>, WavelengthsError> {
        Ok(match *self {
            Self::List(ref v) => v.clone(),
            Self::Grid { from, to, step } => {
                if !(step.is_finite() && step > 0.0) {
                    return Err(WavelengthsError::Step(step));
                }
                if !(from.is_finite() && to.is_finite() && to >= from) {
                    return Err(WavelengthsError::Bounds { from, to });
                }
                let count = ((to - from) / step * (1.0 + 1e-12)).floor() + 1.0;
                let max = crate::optics::spectrum::MAX_WAVELENGTHS;
                if count > max as f64 {
                    return Err(WavelengthsError::TooMany { count, max });
                }
                (0..count as usize)
                    .map(|i| ((from + i as f64 * step) * 1e9).round() / 1e9)
                    .collect()
            }
        })
    }

    /// [`WavelengthsSpec::expand`], checked by
    /// [`crate::optics::spectrum::check_wavelengths`].
    ///
    /// # Errors
    /// A bad grid, or [`WavelengthsError::List`] (its
    /// [`WavelengthsError::index`] names the wavelength at fault).
    pub fn resolve(&self) -> Result<Vec<f64>, WavelengthsError> {
        let values = self.expand()?;
        crate::optics::spectrum::check_wavelengths(&values)?;
        Ok(values)
    }
}

/// A material: exactly one of `reflectance`, `n` (+ `k`), `nk`, `table`.
/// In a spectral scene each may vary with wavelength: `reflectance`, `n`
/// and `k` as arrays aligned with `[light] wavelengths_um`, `table` as an
/// array of files, `nk` a measured `n, k` table (CSV `wavelength_um,n,k` or
/// a Mitsuba `.spd` pair, [`crate::optics::spectrum`]) sampled at the
/// scene's wavelengths.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Constant per-bounce reflectance in [0, 1].
    pub reflectance: Option<Values>,
    /// Real part of the complex refractive index (Fresnel).
    pub n: Option<Values>,
    /// Imaginary part (extinction coefficient, default 0).
    pub k: Option<Values>,
    /// A measured n, k table against wavelength (relative to the scene file).
    pub nk: Option<String>,
    /// CSV of reflectance vs incidence angle in degrees (relative to the scene file).
    pub table: Option<Files>,
}

impl MaterialSpec {
    /// The files this material reads, `(key, path relative to the scene's
    /// folder)`, its keys under `key`: an n, k table and angle tables.
    #[must_use]
    pub fn files(&self, key: &str) -> Vec<(String, String)> {
        let mut files = Vec::new();
        if let Some(f) = &self.nk {
            // A Mitsuba pair is two files: n under `nk`, k under `nk.k`.
            let read = crate::optics::spectrum::NkSpectrum::files_of(f);
            for (file, suffix) in read.into_iter().zip(["", ".k"]) {
                files.push((format!("{key}.nk{suffix}"), file));
            }
        }
        match &self.table {
            Some(Files::One(f)) => files.push((format!("{key}.table"), f.clone())),
            Some(Files::Many(fs)) => files.extend(
                fs.iter()
                    .enumerate()
                    .map(|(i, f)| (format!("{key}.table[{i}]"), f.clone())),
            ),
            None => {}
        }
        files
    }

    /// The reflectance model at `wavelengths_um` (empty: a monochrome
    /// scene), or an error at `key`: one model, or for a model that varies
    /// with wavelength [`Reflectance::Spectral`].
    pub fn build(
        &self,
        scene_file: &SceneFile,
        key: &str,
        wavelengths_um: &[f64],
    ) -> Result<Reflectance, SceneError> {
        let given = [
            self.reflectance.is_some(),
            self.n.is_some(),
            self.nk.is_some(),
            self.table.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() != 1 {
            return Err(scene_file.error(
                key,
                "give exactly one of `reflectance`, `n` (with `k`), `nk`, `table`",
            ));
        }
        if self.k.is_some() && self.n.is_none() {
            return Err(scene_file.error(format!("{key}.k"), "`k` needs `n`"));
        }
        let lanes = wavelengths_um.len();
        let models: Vec<Reflectance> = if let Some(r) = &self.reflectance {
            let values = per_lane(scene_file, key, "reflectance", r, lanes)?;
            if let Some((l, r)) = values
                .iter()
                .enumerate()
                .find(|(_, r)| !(0.0..=1.0).contains(*r))
            {
                return Err(scene_file.error(
                    lane_key(key, "reflectance", r_is_many(self.reflectance.as_ref()), l),
                    format!("must be in [0, 1], got {}", Num(*r)),
                ));
            }
            values.into_iter().map(Reflectance::Constant).collect()
        } else if let Some(n) = &self.n {
            self.fresnel(scene_file, key, n, lanes)?
        } else if let Some(file) = &self.nk {
            measured_nk(scene_file, key, file, wavelengths_um)?
        } else {
            self.angle_tables(scene_file, key, lanes)?
        };
        Ok(spectral_model(models))
    }

    /// The Fresnel models of `n` (and `k`, default 0) per wavelength, for
    /// `lanes` wavelengths (0: monochrome), n > 0 and k >= 0 checked.
    fn fresnel(
        &self,
        scene_file: &SceneFile,
        key: &str,
        n: &Values,
        lanes: usize,
    ) -> Result<Vec<Reflectance>, SceneError> {
        let ns = per_lane(scene_file, key, "n", n, lanes)?;
        let k = self.k.as_ref().unwrap_or(&Values::One(0.0));
        let ks = per_lane(scene_file, key, "k", k, lanes)?;
        let many_n = r_is_many(self.n.as_ref());
        let many_k = r_is_many(self.k.as_ref());
        for (l, (&n, &k)) in ns.iter().zip(&ks).enumerate() {
            if !(n.is_finite() && n > 0.0) {
                return Err(scene_file.error(
                    lane_key(key, "n", many_n, l),
                    format!("must be > 0, got {}", Num(n)),
                ));
            }
            if !(k.is_finite() && k >= 0.0) {
                return Err(scene_file.error(
                    lane_key(key, "k", many_k, l),
                    format!("must be >= 0, got {}", Num(k)),
                ));
            }
        }
        Ok(ns
            .into_iter()
            .zip(ks)
            .map(|(n, k)| Reflectance::Fresnel { n, k })
            .collect())
    }

    /// The angle-table models of `table` per wavelength (one file, read
    /// once, for every one of `lanes` wavelengths, or one file each).
    fn angle_tables(
        &self,
        scene_file: &SceneFile,
        key: &str,
        lanes: usize,
    ) -> Result<Vec<Reflectance>, SceneError> {
        let files = match self.table.as_ref() {
            Some(Files::One(f)) => vec![f.clone(); lanes.max(1)],
            Some(Files::Many(_)) if lanes == 0 => {
                return Err(scene_file.error(
                    format!("{key}.table"),
                    "an array (one file per wavelength) needs [light] wavelengths_um",
                ));
            }
            Some(Files::Many(fs)) if fs.len() != lanes => {
                return Err(scene_file.error(
                    format!("{key}.table"),
                    format!("has {} files for {lanes} wavelengths", fs.len()),
                ));
            }
            Some(Files::Many(fs)) => fs.clone(),
            None => Vec::new(),
        };
        let many = matches!(self.table, Some(Files::Many(_)));
        let mut models: Vec<Reflectance> = Vec::with_capacity(files.len());
        for (l, file) in files.iter().enumerate() {
            // The same file at every wavelength is read once.
            if l > 0 && !many {
                models.push(models[0].clone());
                continue;
            }
            let at = lane_key(key, "table", many, l);
            let path = scene_file.dir.join(file);
            let text =
                crate::limits::read_input_text_capped(&path, crate::limits::max_data_bytes())
                    .map_err(|e| {
                        scene_file.error(&at, format!("cannot read {}: {e}", path.display()))
                    })?;
            let table = AngleTable::parse_csv(&text)
                .map_err(|e| scene_file.error(&at, format!("{}: {e}", path.display())))?;
            models.push(Reflectance::Table(table));
        }
        Ok(models)
    }
}

/// Material key `key.name`'s value per wavelength, for `lanes`
/// wavelengths: an array has one each (it needs wavelengths), one value
/// stands for all (or is the one value of a monochrome scene).
fn per_lane(
    scene_file: &SceneFile,
    key: &str,
    name: &str,
    v: &Values,
    lanes: usize,
) -> Result<Vec<f64>, SceneError> {
    match v {
        Values::One(x) => Ok(vec![*x; lanes.max(1)]),
        Values::Many(_) if lanes == 0 => Err(scene_file.error(
            format!("{key}.{name}"),
            "an array (one value per wavelength) needs [light] wavelengths_um",
        )),
        Values::Many(xs) if xs.len() != lanes => Err(scene_file.error(
            format!("{key}.{name}"),
            format!("has {} values for {lanes} wavelengths", xs.len()),
        )),
        Values::Many(xs) => Ok(xs.clone()),
    }
}

/// The Fresnel models of material `key`'s measured n, k table `file`
/// (relative to the scene's folder) sampled at `wavelengths_um`, which it
/// needs; n > 0 checked.
fn measured_nk(
    scene_file: &SceneFile,
    key: &str,
    file: &str,
    wavelengths_um: &[f64],
) -> Result<Vec<Reflectance>, SceneError> {
    let at = format!("{key}.nk");
    if wavelengths_um.is_empty() {
        return Err(scene_file.error(
            at,
            "a measured n, k table needs [light] wavelengths_um to sample it at",
        ));
    }
    let path = scene_file.dir.join(file);
    let table = crate::optics::spectrum::NkSpectrum::read(&path)
        .map_err(|e| scene_file.error(&at, e.to_string()))?;
    let nks = table
        .sample(wavelengths_um)
        .map_err(|e| scene_file.error(&at, e.to_string()))?;
    let mut models = Vec::with_capacity(wavelengths_um.len());
    for (nk, w) in nks.into_iter().zip(wavelengths_um) {
        if nk.n <= 0.0 {
            return Err(scene_file.error(
                &at,
                format!(
                    "{}: n = {} at {} um: the Fresnel model needs n > 0",
                    path.display(),
                    Num(nk.n),
                    Num(*w)
                ),
            ));
        }
        models.push(Reflectance::from(nk));
    }
    Ok(models)
}

/// Whether a value was given as an array.
fn r_is_many(v: Option<&Values>) -> bool {
    matches!(v, Some(Values::Many(_)))
}

/// The key of lane `l` of `name` under `key`: `key.name[l]` for an array.
fn lane_key(key: &str, name: &str, many: bool, l: usize) -> String {
    if many {
        format!("{key}.{name}[{l}]")
    } else {
        format!("{key}.{name}")
    }
}

/// One model per wavelength as one model: the model itself when every
/// wavelength has the same (also for a monochrome scene), else
/// [`Reflectance::Spectral`].
#[must_use]
pub fn spectral_model(mut models: Vec<Reflectance>) -> Reflectance {
    if models.len() <= 1 || models.iter().all(|m| *m == models[0]) {
        return models.swap_remove(0);
    }
    Reflectance::Spectral(std::sync::Arc::new(
        crate::optics::material::SpectralModel::new(models),
    ))
}

/// Build every material of a `[materials]` table; returns names and models in order.
pub fn build_materials(
    scene_file: &SceneFile,
    specs: &BTreeMap<String, MaterialSpec>,
    wavelengths_um: &[f64],
) -> Result<(Vec<String>, Vec<Reflectance>), SceneError> {
    let mut names = Vec::new();
    let mut models = Vec::new();
    for (name, spec) in specs {
        models.push(spec.build(scene_file, &format!("materials.{name}"), wavelengths_um)?);
        names.push(name.clone());
    }
    Ok((names, models))
}

/// Index of material `name`, or an error at `key`.
pub fn material_index(
    scene_file: &SceneFile,
    names: &[String],
    name: &str,
    key: &str,
) -> Result<usize, SceneError> {
    names.iter().position(|n| n == name).ok_or_else(|| {
        let known = if names.is_empty() {
            "none defined".to_string()
        } else {
            names.join(", ")
        };
        scene_file.error(key, format!("unknown material `{name}` (known: {known})"))
    })
}

/// A body over the named quadrics its region expression uses (micro bodies and
/// object cells): the region over the used surfaces in order of appearance, and
/// their indices into `names`. `key` names the region in messages. `names`
/// must be sorted (the keys of `[quadrics]`, a `BTreeMap`): each term is
/// looked up by binary search, and parsing stops at the first surface
/// beyond [`MAX_SURFACES`], so loading is linear in the expression (at most
/// [`region::MAX_TERMS`] terms).
pub fn region_body(
    scene_file: &SceneFile,
    key: &str,
    expr: &str,
    names: &[String],
    quadrics: &[Quadric],
    material: usize,
) -> Result<(Body, Vec<usize>), SceneError> {
    debug_assert!(names.is_sorted(), "region_body: names must be sorted");
    let mut used: Vec<usize> = Vec::new();
    let mut unknown = None;
    let mut too_many = false;
    let parsed = region::parse(expr, |name| {
        let Ok(g) = names.binary_search_by(|n| n.as_str().cmp(name)) else {
            unknown.get_or_insert_with(|| name.to_string());
            return None;
        };
        if let Some(u) = used.iter().position(|&u| u == g) {
            return Some(u);
        }
        if used.len() == MAX_SURFACES {
            too_many = true;
            return None;
        }
        used.push(g);
        Some(used.len() - 1)
    });
    let region = parsed.map_err(|e| {
        let msg = match &unknown {
            Some(name) => format!("unknown surface `{name}` (not in [quadrics])"),
            None if too_many => {
                format!("uses more than {MAX_SURFACES} surfaces, the most one body may have")
            }
            None => e.to_string(),
        };
        scene_file.error(key, msg)
    })?;
    let surfaces = used.iter().map(|&g| quadrics[g]).collect();
    Ok((
        Body::new(surfaces, region, Aabb::EVERYTHING, material),
        used,
    ))
}

/// A polarisation state as written in scene files (`[light] polarisation`,
/// `[[sources]] polarisation`):
///
/// ```toml
/// polarisation = "unpolarised"     # default; or "s", "p", "right", "left"
/// polarisation = { linear = 30.0 } # linear at 30 deg from the reference vector (s) toward p
/// polarisation = [1.0, 0.0, 0.6, 0.8]   # a Stokes vector (S0 > 0, DoP <= 1; scaled to S0 = 1)
/// ```
///
/// Frames and signs: [`crate::optics::polarisation`].
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(
    untagged,
    deny_unknown_fields,
    expecting = "a state name (unpolarised, s, p, right, left), { linear = deg } (no other key), or a Stokes vector [S0, S1, S2, S3]"
)]
pub enum PolarisationSpec {
    /// A named state.
    Name(String),
    /// `{ linear = angle_deg }`.
    Linear {
        /// Angle from the reference vector (degrees).
        linear: f64,
    },
    /// A Stokes vector.
    Stokes([f64; 4]),
}

impl PolarisationSpec {
    /// The incident state, or an error at `key`.
    pub fn build(&self, scene_file: &SceneFile, key: &str) -> Result<Incident, SceneError> {
        let state = match self {
            Self::Name(n) => match n.as_str() {
                "unpolarised" | "unpolarized" | "natural" => Incident::Unpolarised,
                "s" => Incident::S,
                "p" => Incident::P,
                "right" => Incident::Right,
                "left" => Incident::Left,
                other => {
                    return Err(scene_file.error(
                        key,
                        format!(
                            "unknown state `{other}` (known: unpolarised, s, p, right, left, {{ linear = deg }}, [S0, S1, S2, S3])"
                        ),
                    ));
                }
            },
            Self::Linear { linear } => Incident::Linear(*linear),
            Self::Stokes(s) => Incident::Stokes(*s),
        };
        state.validate().map_err(|e| scene_file.error(key, e))?;
        Ok(state)
    }
}

#[cfg(test)]
mod tests {
    use super::SceneKind;

    #[test]
    fn scene_kinds() {
        let object = "[quadrics]\ns = { sphere = { center = [0.0, 0.0, 0.0], r = 1.0 } }\n[[cells]]\nregion = \"-s\"\n";
        assert_eq!(SceneKind::of_text(object), SceneKind::Object);
        assert_eq!(
            SceneKind::of_text("[surface]\nsize = [1.0, 1.0]\n"),
            SceneKind::Micro
        );
        // Not TOML: the micro loader says what is wrong.
        assert_eq!(SceneKind::of_text("[[cells]\n"), SceneKind::Micro);
        // A key named `cells` inside a table is not the object's cells.
        assert_eq!(
            SceneKind::of_text("[surface]\ncells = 3\n"),
            SceneKind::Micro
        );
        let missing = std::path::Path::new("/nonexistent/roks-scene.toml");
        let e = super::kind(missing).unwrap_err();
        assert!(e.message.starts_with("cannot read"), "{e}");
    }
}
