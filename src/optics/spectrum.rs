//! Functions of wavelength: measured refractive indices `n + ik` against
//! vacuum wavelength, read from files and linearly interpolated (issue 16,
//! spectral BRDFs).
//!
//! Wavelengths are in micrometres (`_um`) everywhere in the API. Two file
//! layouts are read:
//!
//! * **CSV** (the refractiveindex.info layout): optional `#` comment lines,
//!   the header line `wavelength_um,n,k`, then one row per wavelength,
//!   `wavelength_um,n,k`, wavelengths strictly increasing. Example
//!   (`scenes/materials/gold.csv`):
//!
//!   ```text
//!   # Source: P. B. Johnson and R. W. Christy, ... doi:10.1103/PhysRevB.6.4370.
//!   wavelength_um,n,k
//!   0.1879,1.28,1.188
//!   0.1916,1.32,1.203
//!   ```
//!
//! * **Mitsuba `.spd` pair**: two files `NAME.eta.spd` (n) and `NAME.k.spd`
//!   (k), each with lines `wavelength_nm value` separated by whitespace and
//!   `#` comment lines. The two files may use different wavelength grids;
//!   each is interpolated on its own.
//!
//! In both, blank lines and lines whose first non-blank character is `#`
//! are ignored anywhere; values must be finite, wavelengths `> 0`, `n ≥ 0`,
//! `k ≥ 0`. Between tabulated wavelengths n and k are interpolated linearly;
//! a wavelength outside a table is an error naming the file, never an
//! extrapolation. Nothing here panics on any input.
//!
//! The colour of a spectrum (CIE XYZ under D65, sRGB) is in [`super::colour`].

use super::material::Reflectance;
use std::path::Path;
use thiserror::Error;

/// The header line of a CSV table of `n, k` (after trimming whitespace around
/// each field).
pub const CSV_HEADER: &str = "wavelength_um,n,k";

/// Why a spectrum or a file of one was rejected, or a wavelength could not be
/// served. Every message is one line naming the file (or the scene quantity)
/// and the 1-based line or the wavelength.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpectrumError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("{file}: cannot read the file: {message}")]
    Io {
        /// The file as given.
        file: String,
        /// The operating system's message.
        message: String,
    },
    /// The name ends neither in `.csv` nor in `.eta.spd` / `.k.spd`, and no
    /// `NAME.eta.spd` exists beside it.
    #[error(
        "{file}: unknown n,k file format (expected NAME.csv with header `wavelength_um,n,k`, or the Mitsuba pair NAME.eta.spd and NAME.k.spd)"
    )]
    UnknownFormat {
        /// The file as given.
        file: String,
    },
    /// No data rows.
    #[error("{file}: no data rows")]
    Empty {
        /// The file as given.
        file: String,
    },
    /// The first line that is not blank or a comment is not the CSV header.
    #[error("{file}, line {line}: expected the header `wavelength_um,n,k`, found `{found}`")]
    Header {
        /// The file as given.
        file: String,
        /// 1-based line number.
        line: usize,
        /// The line found (trimmed).
        found: String,
    },
    /// A row with the wrong number of fields.
    #[error("{file}, line {line}: expected {expected} fields ({layout}), found {found}")]
    FieldCount {
        /// The file as given.
        file: String,
        /// 1-based line number.
        line: usize,
        /// Fields a row must have.
        expected: usize,
        /// What the fields are, e.g. `wavelength_um,n,k`.
        layout: &'static str,
        /// Fields found.
        found: usize,
    },
    /// A field that does not parse as a number.
    #[error("{file}, line {line}: field {field} `{text}` is not a number")]
    NotANumber {
        /// The file as given.
        file: String,
        /// 1-based line number (or point index for [`Spectrum::new`]).
        line: usize,
        /// 1-based field number within the line.
        field: usize,
        /// The offending text.
        text: String,
    },
    /// A value that is NaN, infinite, or below its lower bound (a wavelength
    /// must be `> 0`, n and k `≥ 0`).
    #[error("{file}, line {line}: {quantity} = {value} is not a finite number {bound}")]
    OutOfDomain {
        /// The file as given.
        file: String,
        /// 1-based line number (or point index for [`Spectrum::new`]).
        line: usize,
        /// Which quantity, e.g. `wavelength_um`, `n`, `k`.
        quantity: &'static str,
        /// The offending value (in the file's unit).
        value: f64,
        /// The bound, `> 0` or `>= 0`.
        bound: &'static str,
    },
    /// A wavelength not greater than the previous row's (decreasing or
    /// duplicated).
    #[error(
        "{file}, line {line}: wavelength {wavelength} {unit} is not greater than the previous wavelength {previous} {unit}"
    )]
    NotIncreasing {
        /// The file as given.
        file: String,
        /// 1-based line number (or point index for [`Spectrum::new`]).
        line: usize,
        /// This row's wavelength (in `unit`).
        wavelength: f64,
        /// The previous row's wavelength (in `unit`).
        previous: f64,
        /// `um` or `nm`, the file's unit.
        unit: &'static str,
    },
    /// A wavelength asked for outside the table: the scene error.
    #[error(
        "{file}: wavelength {wavelength_um} um is outside the table's range {min_um}-{max_um} um"
    )]
    OutOfRange {
        /// The file as given.
        file: String,
        /// The wavelength asked for (µm).
        wavelength_um: f64,
        /// The table's shortest wavelength (µm).
        min_um: f64,
        /// The table's longest wavelength (µm).
        max_um: f64,
    },
    /// A wavelength asked for that is NaN, infinite or not `> 0`.
    #[error("wavelength {0} um is not a finite number > 0")]
    InvalidWavelength(f64),
    /// A per-wavelength array whose length differs from the wavelengths'.
    #[error("{quantity} has {found} values for {expected} wavelengths")]
    LengthMismatch {
        /// `n` or `k`.
        quantity: &'static str,
        /// The array's length.
        found: usize,
        /// The number of wavelengths.
        expected: usize,
    },
    /// A constant or array value of n or k that is not finite and `≥ 0`.
    #[error("{quantity} = {value} is not a finite number >= 0")]
    InvalidValue {
        /// `n` or `k`.
        quantity: &'static str,
        /// The offending value.
        value: f64,
    },
}

/// A non-negative function of wavelength tabulated at strictly increasing
/// wavelengths (µm), linearly interpolated between them and undefined
/// outside them. Remembers the file it came from, for error messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    file: String,
    wavelength_um: Vec<f64>,
    value: Vec<f64>,
}

impl Spectrum {
    /// Builds a spectrum from `(wavelength_um, value)` points: wavelengths
    /// finite, `> 0` and strictly increasing; values finite and `≥ 0`. One
    /// point is allowed (the spectrum is then defined at that wavelength
    /// only). `file` names the origin in error messages.
    ///
    /// # Errors
    /// [`SpectrumError::Empty`] for no points, otherwise the first bad point
    /// with its 1-based index as `line`.
    pub fn new(file: impl Into<String>, points: &[(f64, f64)]) -> Result<Self, SpectrumError> {
        let file = file.into();
        let mut builder = Builder::new(&file, "um", 1.0);
        for (i, &(wavelength, value)) in points.iter().enumerate() {
            builder.push(i + 1, wavelength, &[("value", value)])?;
        }
        let (wavelength_um, mut columns) = builder.finish()?;
        let value = columns.pop().unwrap_or_default();
        Ok(Self {
            file,
            wavelength_um,
            value,
        })
    }

    /// The file (or name) this spectrum came from.
    #[must_use]
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The tabulated wavelengths (µm), strictly increasing, never empty.
    #[must_use]
    pub fn wavelengths_um(&self) -> &[f64] {
        &self.wavelength_um
    }

    /// The tabulated values, one per wavelength.
    #[must_use]
    pub fn values(&self) -> &[f64] {
        &self.value
    }

    /// The shortest and longest tabulated wavelengths (µm).
    #[must_use]
    pub fn range_um(&self) -> (f64, f64) {
        let min = self.wavelength_um.first().copied().unwrap_or(f64::NAN);
        let max = self.wavelength_um.last().copied().unwrap_or(f64::NAN);
        (min, max)
    }

    /// The value at `wavelength_um` (µm) by linear interpolation between the
    /// neighbouring tabulated points; exact at tabulated wavelengths. `None`
    /// outside `[min, max]` of [`Spectrum::range_um`] or for NaN.
    #[must_use]
    pub fn try_at(&self, wavelength_um: f64) -> Option<f64> {
        interpolate(&self.wavelength_um, &self.value, wavelength_um)
    }

    /// [`Spectrum::try_at`], with the errors a scene reports.
    ///
    /// # Errors
    /// [`SpectrumError::InvalidWavelength`] for a NaN, infinite or
    /// non-positive wavelength; [`SpectrumError::OutOfRange`] naming the
    /// file for one outside the table.
    pub fn at(&self, wavelength_um: f64) -> Result<f64, SpectrumError> {
        if !(wavelength_um.is_finite() && wavelength_um > 0.0) {
            return Err(SpectrumError::InvalidWavelength(wavelength_um));
        }
        self.try_at(wavelength_um).ok_or_else(|| {
            let (min_um, max_um) = self.range_um();
            SpectrumError::OutOfRange {
                file: self.file.clone(),
                wavelength_um,
                min_um,
                max_um,
            }
        })
    }

    /// Parses a Mitsuba `.spd` file: lines `wavelength_nm value`, `#`
    /// comments. Wavelengths are converted to µm (divided by 1000); values
    /// must be finite and `≥ 0`. `quantity` (`n` or `k`) names the value in
    /// error messages.
    ///
    /// # Errors
    /// The first bad line, as a [`SpectrumError`] naming `file` and the line.
    pub fn parse_spd(
        file: impl Into<String>,
        quantity: &'static str,
        text: &str,
    ) -> Result<Self, SpectrumError> {
        let file = file.into();
        let mut builder = Builder::new(&file, "nm", 1000.0);
        for (line, content) in content_lines(text) {
            let fields: Vec<&str> = content.split_whitespace().collect();
            if fields.len() != 2 {
                return Err(SpectrumError::FieldCount {
                    file,
                    line,
                    expected: 2,
                    layout: "wavelength_nm value",
                    found: fields.len(),
                });
            }
            let wavelength = parse_field(&file, line, 1, fields[0])?;
            let value = parse_field(&file, line, 2, fields[1])?;
            builder.push(line, wavelength, &[(quantity, value)])?;
        }
        let (wavelength_um, mut columns) = builder.finish()?;
        let value = columns.pop().unwrap_or_default();
        Ok(Self {
            file,
            wavelength_um,
            value,
        })
    }
}

/// A complex refractive index `n + ik` (both dimensionless) at one
/// wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nk {
    /// Real part (dimensionless, `≥ 0`).
    pub n: f64,
    /// Extinction coefficient (dimensionless, `≥ 0`).
    pub k: f64,
}

impl Nk {
    /// Unpolarised reflectance at normal incidence,
    /// `((n - 1)² + k²) / ((n + 1)² + k²)` (dimensionless).
    #[must_use]
    pub fn normal_reflectance(self) -> f64 {
        let Self { n, k } = self;
        ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k)
    }
}

impl From<Nk> for Reflectance {
    /// The per-facet Fresnel model of this index. Note that
    /// [`Reflectance::validate`] requires `n > 0`, while tables allow `n = 0`.
    fn from(nk: Nk) -> Self {
        Self::Fresnel { n: nk.n, k: nk.k }
    }
}

/// A measured `n(λ)`, `k(λ)` of one material, from a CSV table or a Mitsuba
/// `.spd` pair, linearly interpolated.
#[derive(Debug, Clone, PartialEq)]
pub struct NkSpectrum {
    n: Spectrum,
    k: Spectrum,
}

impl NkSpectrum {
    /// Reads a table by its name: `*.csv` is the CSV layout; `NAME.eta.spd`
    /// or `NAME.k.spd` is the Mitsuba pair (both files are read); any other
    /// `NAME` is the Mitsuba pair when `NAME.eta.spd` exists.
    ///
    /// # Errors
    /// [`SpectrumError::Io`], [`SpectrumError::UnknownFormat`], or the first
    /// problem in a file's contents, each naming the file.
    pub fn read(path: &Path) -> Result<Self, SpectrumError> {
        let name = path.to_string_lossy();
        if name.ends_with(".csv") {
            return Self::read_csv(path);
        }
        let stem = name
            .strip_suffix(".eta.spd")
            .or_else(|| name.strip_suffix(".k.spd"))
            .map(str::to_owned);
        match stem {
            Some(stem) => Self::read_spd_pair(Path::new(&stem)),
            None if Path::new(&format!("{name}.eta.spd")).exists() => Self::read_spd_pair(path),
            None => Err(SpectrumError::UnknownFormat {
                file: name.into_owned(),
            }),
        }
    }

    /// The files [`NkSpectrum::read`] reads for the table named `name`:
    /// `name` itself for a CSV table, else the Mitsuba pair
    /// (`NAME.eta.spd`, `NAME.k.spd`) that `NAME`, `NAME.eta.spd` or
    /// `NAME.k.spd` names. A scene hashes (and protects) each of them.
    #[must_use]
    pub fn files_of(name: &str) -> Vec<String> {
        if name.ends_with(".csv") {
            return vec![name.to_owned()];
        }
        let stem = name
            .strip_suffix(".eta.spd")
            .or_else(|| name.strip_suffix(".k.spd"))
            .unwrap_or(name);
        vec![format!("{stem}.eta.spd"), format!("{stem}.k.spd")]
    }

    /// Reads a CSV table (see [`NkSpectrum::parse_csv`]).
    ///
    /// # Errors
    /// [`SpectrumError::Io`] or a problem in its contents, naming the file.
    pub fn read_csv(path: &Path) -> Result<Self, SpectrumError> {
        let file = path.display().to_string();
        let text = read_text(path, &file)?;
        Self::parse_csv(file, &text)
    }

    /// Reads the Mitsuba pair `STEM.eta.spd` (n) and `STEM.k.spd` (k).
    ///
    /// # Errors
    /// [`SpectrumError::Io`] or a problem in either file, naming that file.
    pub fn read_spd_pair(stem: &Path) -> Result<Self, SpectrumError> {
        let stem = stem.display().to_string();
        let (eta_file, k_file) = (format!("{stem}.eta.spd"), format!("{stem}.k.spd"));
        let eta_text = read_text(Path::new(&eta_file), &eta_file)?;
        let k_text = read_text(Path::new(&k_file), &k_file)?;
        Ok(Self {
            n: Spectrum::parse_spd(eta_file, "n", &eta_text)?,
            k: Spectrum::parse_spd(k_file, "k", &k_text)?,
        })
    }

    /// Parses CSV text: `#` comment and blank lines anywhere, then the header
    /// [`CSV_HEADER`] (`wavelength_um,n,k`, whitespace around fields
    /// allowed, a UTF-8 byte-order mark ignored), then rows
    /// `wavelength_um,n,k`: wavelengths finite, `> 0`, strictly increasing;
    /// n and k finite and `≥ 0`. `file` names the text in error messages.
    ///
    /// # Errors
    /// The first problem, as a [`SpectrumError`] naming `file` and the
    /// 1-based line: a missing header, a wrong field count, a field that is
    /// not a number, NaN or infinite, a negative n or k, a wavelength not
    /// `> 0` or not greater than the previous one, no data rows.
    pub fn parse_csv(file: impl Into<String>, text: &str) -> Result<Self, SpectrumError> {
        let file = file.into();
        let mut builder = Builder::new(&file, "um", 1.0);
        let mut header_seen = false;
        for (line, content) in content_lines(text) {
            let fields: Vec<&str> = content.split(',').map(str::trim).collect();
            if !header_seen {
                if fields != ["wavelength_um", "n", "k"] {
                    return Err(SpectrumError::Header {
                        file,
                        line,
                        found: content.to_owned(),
                    });
                }
                header_seen = true;
                continue;
            }
            if fields.len() != 3 {
                return Err(SpectrumError::FieldCount {
                    file,
                    line,
                    expected: 3,
                    layout: CSV_HEADER,
                    found: fields.len(),
                });
            }
            let wavelength = parse_field(&file, line, 1, fields[0])?;
            let n = parse_field(&file, line, 2, fields[1])?;
            let k = parse_field(&file, line, 3, fields[2])?;
            builder.push(line, wavelength, &[("n", n), ("k", k)])?;
        }
        let (wavelength_um, columns) = builder.finish()?;
        let [n, k]: [Vec<f64>; 2] = columns.try_into().unwrap_or_default();
        Ok(Self {
            n: Spectrum {
                file: file.clone(),
                wavelength_um: wavelength_um.clone(),
                value: n,
            },
            k: Spectrum {
                file,
                wavelength_um,
                value: k,
            },
        })
    }

    /// Parses the Mitsuba pair from its two texts (see
    /// [`Spectrum::parse_spd`]); `eta_file` and `k_file` name them in errors.
    ///
    /// # Errors
    /// The first problem in either text, naming its file.
    pub fn parse_spd_pair(
        eta_file: impl Into<String>,
        eta_text: &str,
        k_file: impl Into<String>,
        k_text: &str,
    ) -> Result<Self, SpectrumError> {
        Ok(Self {
            n: Spectrum::parse_spd(eta_file, "n", eta_text)?,
            k: Spectrum::parse_spd(k_file, "k", k_text)?,
        })
    }

    /// n against wavelength.
    #[must_use]
    pub fn n(&self) -> &Spectrum {
        &self.n
    }

    /// k against wavelength.
    #[must_use]
    pub fn k(&self) -> &Spectrum {
        &self.k
    }

    /// The wavelengths (µm) where both n and k are defined: the overlap of
    /// their ranges (empty, min > max, when a Mitsuba pair does not overlap).
    #[must_use]
    pub fn range_um(&self) -> (f64, f64) {
        let (n_min, n_max) = self.n.range_um();
        let (k_min, k_max) = self.k.range_um();
        (n_min.max(k_min), n_max.min(k_max))
    }

    /// n and k at one wavelength (µm), each linearly interpolated.
    ///
    /// # Errors
    /// [`SpectrumError::InvalidWavelength`], or [`SpectrumError::OutOfRange`]
    /// naming the file (of n, else of k) whose table does not reach it.
    pub fn at(&self, wavelength_um: f64) -> Result<Nk, SpectrumError> {
        Ok(Nk {
            n: self.n.at(wavelength_um)?,
            k: self.k.at(wavelength_um)?,
        })
    }

    /// n and k at each of `wavelengths_um` (µm), in order.
    ///
    /// # Errors
    /// The first wavelength that [`NkSpectrum::at`] rejects.
    pub fn sample(&self, wavelengths_um: &[f64]) -> Result<Vec<Nk>, SpectrumError> {
        wavelengths_um.iter().map(|&w| self.at(w)).collect()
    }
}

/// Why the wavelengths of a spectral run are refused
/// ([`check_wavelengths`]); [`WavelengthListError::index`] names the
/// wavelength at fault.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WavelengthListError {
    /// No wavelength.
    #[error("needs at least one wavelength")]
    Empty,
    /// More wavelengths than one trace carries.
    #[error("{count} wavelengths, more than the {max} one trace carries")]
    TooMany {
        /// The wavelengths given.
        count: usize,
        /// [`MAX_WAVELENGTHS`].
        max: usize,
    },
    /// A wavelength that is not a finite number > 0.
    #[error("{value} um is not a finite number > 0")]
    NotPositive {
        /// Its index in the list.
        index: usize,
        /// The wavelength (µm).
        value: f64,
    },
    /// A wavelength not above the one before it.
    #[error(
        "{value} um is not greater than the previous {previous} um (wavelengths strictly increasing)"
    )]
    NotIncreasing {
        /// Its index in the list.
        index: usize,
        /// The wavelength (µm).
        value: f64,
        /// The wavelength before it (µm).
        previous: f64,
    },
}

impl WavelengthListError {
    /// The index of the wavelength at fault (`None`: the whole list).
    #[must_use]
    pub fn index(&self) -> Option<usize> {
        match *self {
            Self::Empty | Self::TooMany { .. } => None,
            Self::NotPositive { index, .. } | Self::NotIncreasing { index, .. } => Some(index),
        }
    }
}

/// Most wavelengths one trace carries
/// ([`crate::transport::carrier::Spectral`]): enough for the visible at 5 nm
/// (81) or the thermal infrared from 3 to 14 µm at 0.1 µm (111).
pub const MAX_WAVELENGTHS: usize = 128;

/// Check the wavelengths of a spectral run (µm): at least one, at most
/// [`MAX_WAVELENGTHS`], each finite and `> 0`,
/// strictly increasing.
///
/// # Errors
/// The first problem, as a [`WavelengthListError`].
pub fn check_wavelengths(wavelengths_um: &[f64]) -> Result<(), WavelengthListError> {
    let max = MAX_WAVELENGTHS;
    if wavelengths_um.is_empty() {
        return Err(WavelengthListError::Empty);
    }
    if wavelengths_um.len() > max {
        return Err(WavelengthListError::TooMany {
            count: wavelengths_um.len(),
            max,
        });
    }
    for (index, &value) in wavelengths_um.iter().enumerate() {
        if !(value.is_finite() && value > 0.0) {
            return Err(WavelengthListError::NotPositive { index, value });
        }
        if index > 0 && value <= wavelengths_um[index - 1] {
            return Err(WavelengthListError::NotIncreasing {
                index,
                value,
                previous: wavelengths_um[index - 1],
            });
        }
    }
    Ok(())
}

/// One of n, k given in a scene: a constant, or one value per wavelength of
/// the scene's list.
#[derive(Debug, Clone, PartialEq)]
pub enum SpectralValue {
    /// The same value at every wavelength.
    Constant(f64),
    /// One value per wavelength, aligned with the scene's wavelengths.
    PerWavelength(Vec<f64>),
}

impl SpectralValue {
    /// The value at each of `count` wavelengths.
    ///
    /// # Errors
    /// [`SpectrumError::InvalidValue`] for a value that is not finite and
    /// `≥ 0`; [`SpectrumError::LengthMismatch`] for an array whose length is
    /// not `count`. `quantity` (`n` or `k`) names it.
    pub fn sample(&self, quantity: &'static str, count: usize) -> Result<Vec<f64>, SpectrumError> {
        let values = match self {
            Self::Constant(value) => vec![*value; count],
            Self::PerWavelength(values) if values.len() == count => values.clone(),
            Self::PerWavelength(values) => {
                return Err(SpectrumError::LengthMismatch {
                    quantity,
                    found: values.len(),
                    expected: count,
                });
            }
        };
        match values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            Some(&value) => Err(SpectrumError::InvalidValue { quantity, value }),
            None => Ok(values),
        }
    }
}

/// Where a spectral material's `n + ik` comes from: the scene's `n` and `k`
/// (constants or arrays aligned with the wavelengths), or `nk = "file"`.
#[derive(Debug, Clone, PartialEq)]
pub enum NkSource {
    /// `n` and `k` given in the scene.
    Values {
        /// The real part.
        n: SpectralValue,
        /// The extinction coefficient.
        k: SpectralValue,
    },
    /// A measured table (`nk = "file"`).
    Table(NkSpectrum),
}

impl NkSource {
    /// n and k at each of `wavelengths_um` (µm, each finite and `> 0`).
    ///
    /// # Errors
    /// [`SpectrumError::InvalidWavelength`]; for values, those of
    /// [`SpectralValue::sample`]; for a table, [`SpectrumError::OutOfRange`]
    /// naming its file.
    pub fn sample(&self, wavelengths_um: &[f64]) -> Result<Vec<Nk>, SpectrumError> {
        match self {
            Self::Values { n, k } => {
                if let Some(&w) = wavelengths_um
                    .iter()
                    .find(|w| !(w.is_finite() && **w > 0.0))
                {
                    return Err(SpectrumError::InvalidWavelength(w));
                }
                let n = n.sample("n", wavelengths_um.len())?;
                let k = k.sample("k", wavelengths_um.len())?;
                Ok(n.into_iter().zip(k).map(|(n, k)| Nk { n, k }).collect())
            }
            Self::Table(table) => table.sample(wavelengths_um),
        }
    }
}

/// Linear interpolation of `values` at `at` between the neighbouring of the
/// strictly increasing `abscissae`; exact at tabulated points. `None` outside
/// `[first, last]`, for NaN, or for unequal lengths.
fn interpolate(abscissae: &[f64], values: &[f64], at: f64) -> Option<f64> {
    if abscissae.len() != values.len() {
        return None;
    }
    let (lo, hi, t) = bracket(abscissae, at)?;
    let (v0, v1) = (*values.get(lo)?, *values.get(hi)?);
    Some(if hi == lo { v0 } else { v0 + (v1 - v0) * t })
}

/// The neighbours `lo <= hi` of `at` among the strictly increasing
/// `abscissae` and the weight `t` of `hi`: the interpolated value is
/// `(1 - t) v[lo] + t v[hi]`, with `hi == lo` and `t = 0` at a tabulated
/// point. `None` outside `[first, last]` or for NaN.
pub(super) fn bracket(abscissae: &[f64], at: f64) -> Option<(usize, usize, f64)> {
    let (&first, &last) = (abscissae.first()?, abscissae.last()?);
    if !(first..=last).contains(&at) {
        return None;
    }
    // first <= at <= last, so 1 <= hi <= len.
    let hi = abscissae.partition_point(|&w| w <= at);
    let lo = hi.checked_sub(1)?;
    let w0 = *abscissae.get(lo)?;
    match abscissae.get(hi) {
        Some(&w1) if at > w0 => Some((lo, hi, (at - w0) / (w1 - w0))),
        _ => Some((lo, lo, 0.0)), // at a tabulated point (or the last one)
    }
}

/// Reads a file as UTF-8 text, naming it in the error.
fn read_text(path: &Path, file: &str) -> Result<String, SpectrumError> {
    crate::limits::read_input_text_capped(path, crate::limits::max_data_bytes()).map_err(|e| {
        SpectrumError::Io {
            file: file.to_owned(),
            message: e.to_string(),
        }
    })
}

/// The lines that are neither blank nor `#` comments, trimmed, with their
/// 1-based line numbers (a leading byte-order mark is dropped).
fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines()
        .enumerate()
        .map(|(i, raw)| (i + 1, raw.trim()))
        .filter(|(_, content)| !content.is_empty() && !content.starts_with('#'))
}

/// Parses one field as f64 (NaN and infinities parse; the builder rejects them).
fn parse_field(file: &str, line: usize, field: usize, text: &str) -> Result<f64, SpectrumError> {
    text.parse().map_err(|_| SpectrumError::NotANumber {
        file: file.to_owned(),
        line,
        field,
        text: text.to_owned(),
    })
}

/// Collects validated rows: a wavelength (in the file's unit, divided by
/// `per_um` to give µm, so 380 nm is exactly the f64 nearest 0.38) and named
/// values.
struct Builder<'a> {
    file: &'a str,
    unit: &'static str,
    per_um: f64,
    previous: Option<f64>,
    wavelength_um: Vec<f64>,
    columns: Vec<Vec<f64>>,
}

impl<'a> Builder<'a> {
    fn new(file: &'a str, unit: &'static str, per_um: f64) -> Self {
        Self {
            file,
            unit,
            per_um,
            previous: None,
            wavelength_um: Vec::new(),
            columns: Vec::new(),
        }
    }

    fn out_of_domain(
        &self,
        line: usize,
        quantity: &'static str,
        value: f64,
        bound: &'static str,
    ) -> SpectrumError {
        SpectrumError::OutOfDomain {
            file: self.file.to_owned(),
            line,
            quantity,
            value,
            bound,
        }
    }

    fn push(
        &mut self,
        line: usize,
        wavelength: f64,
        values: &[(&'static str, f64)],
    ) -> Result<(), SpectrumError> {
        let quantity = if self.unit == "nm" {
            "wavelength_nm"
        } else {
            "wavelength_um"
        };
        if !(wavelength.is_finite() && wavelength > 0.0) {
            return Err(self.out_of_domain(line, quantity, wavelength, "> 0"));
        }
        if let Some(&(name, value)) = values.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            return Err(self.out_of_domain(line, name, value, ">= 0"));
        }
        let wavelength_um = wavelength / self.per_um;
        // Also two wavelengths that differ in the file but not after scaling.
        if let (Some(previous), Some(&previous_um)) = (self.previous, self.wavelength_um.last()) {
            if wavelength <= previous || wavelength_um <= previous_um {
                return Err(SpectrumError::NotIncreasing {
                    file: self.file.to_owned(),
                    line,
                    wavelength,
                    previous,
                    unit: self.unit,
                });
            }
        }
        self.previous = Some(wavelength);
        self.wavelength_um.push(wavelength_um);
        self.columns.resize_with(values.len(), Vec::new);
        for (column, &(_, value)) in self.columns.iter_mut().zip(values) {
            column.push(value);
        }
        Ok(())
    }

    fn finish(self) -> Result<(Vec<f64>, Vec<Vec<f64>>), SpectrumError> {
        if self.wavelength_um.is_empty() {
            return Err(SpectrumError::Empty {
                file: self.file.to_owned(),
            });
        }
        Ok((self.wavelength_um, self.columns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const GOLD: &str = "scenes/materials/gold.csv";

    fn csv(text: &str) -> Result<NkSpectrum, SpectrumError> {
        NkSpectrum::parse_csv("t.csv", text)
    }

    fn message(text: &str) -> String {
        csv(text).expect_err("rejected").to_string()
    }

    fn repo_file(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(name)
    }

    #[test]
    fn parses_comments_header_rows_and_interpolates_linearly() {
        let t = csv("\u{feff}# source\n\n wavelength_um , n , k \r\n# mid comment\n0.5,1.0,2.0\n0.7,2.0,4.0\r\n1.0,2.0,1.0\n")
            .expect("valid");
        assert_eq!(t.range_um(), (0.5, 1.0));
        assert_eq!(t.n().wavelengths_um(), &[0.5, 0.7, 1.0]);
        assert_eq!(t.at(0.5), Ok(Nk { n: 1.0, k: 2.0 }));
        assert_eq!(t.at(0.7), Ok(Nk { n: 2.0, k: 4.0 }));
        assert_eq!(t.at(1.0), Ok(Nk { n: 2.0, k: 1.0 }));
        let mid = t.at(0.6).expect("inside");
        assert!((mid.n - 1.5).abs() < 1e-12 && (mid.k - 3.0).abs() < 1e-12);
        let mid = t.at(0.85).expect("inside");
        assert!((mid.n - 2.0).abs() < 1e-12 && (mid.k - 2.5).abs() < 1e-12);
        let sampled = t.sample(&[0.5, 0.6, 1.0]).expect("inside");
        assert_eq!(sampled.len(), 3);
        assert_eq!(sampled[2], Nk { n: 2.0, k: 1.0 });
    }

    #[test]
    fn one_row_is_defined_at_its_wavelength_only() {
        let t = csv("wavelength_um,n,k\n0.5,1.5,0\n").expect("valid");
        assert_eq!(t.at(0.5), Ok(Nk { n: 1.5, k: 0.0 }));
        assert_eq!(
            t.at(0.6).expect_err("outside").to_string(),
            "t.csv: wavelength 0.6 um is outside the table's range 0.5-0.5 um"
        );
    }

    #[test]
    fn rejects_malformed_tables_with_one_line_messages() {
        assert_eq!(message(""), "t.csv: no data rows");
        assert_eq!(message("# only a comment\n\n"), "t.csv: no data rows");
        assert_eq!(message("wavelength_um,n,k\n"), "t.csv: no data rows");
        assert_eq!(
            message("0.5,1,2\n"),
            "t.csv, line 1: expected the header `wavelength_um,n,k`, found `0.5,1,2`"
        );
        assert_eq!(
            message("# c\nwl,n,k\n0.5,1,2\n"),
            "t.csv, line 2: expected the header `wavelength_um,n,k`, found `wl,n,k`"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,1\n"),
            "t.csv, line 2: expected 3 fields (wavelength_um,n,k), found 2"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,1,2,3\n"),
            "t.csv, line 2: expected 3 fields (wavelength_um,n,k), found 4"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5 1 2\n"),
            "t.csv, line 2: expected 3 fields (wavelength_um,n,k), found 1"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,one,2\n"),
            "t.csv, line 2: field 2 `one` is not a number"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,,2\n"),
            "t.csv, line 2: field 2 `` is not a number"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,NaN,2\n"),
            "t.csv, line 2: n = NaN is not a finite number >= 0"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,1,inf\n"),
            "t.csv, line 2: k = inf is not a finite number >= 0"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,1,-0.1\n"),
            "t.csv, line 2: k = -0.1 is not a finite number >= 0"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,1,1e400\n"),
            "t.csv, line 2: k = inf is not a finite number >= 0"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0,1,1\n"),
            "t.csv, line 2: wavelength_um = 0 is not a finite number > 0"
        );
        assert_eq!(
            message("wavelength_um,n,k\nnan,1,1\n"),
            "t.csv, line 2: wavelength_um = NaN is not a finite number > 0"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.6,1,1\n0.5,1,1\n"),
            "t.csv, line 3: wavelength 0.5 um is not greater than the previous wavelength 0.6 um"
        );
        assert_eq!(
            message("wavelength_um,n,k\n0.5,1,1\n# dup\n0.5,1,1\n"),
            "t.csv, line 4: wavelength 0.5 um is not greater than the previous wavelength 0.5 um"
        );
        // n = 0 and k = 0 are allowed.
        assert!(csv("wavelength_um,n,k\n0.5,0,0\n").is_ok());
    }

    #[test]
    fn sampling_outside_or_at_bad_wavelengths_is_an_error() {
        let t = csv("wavelength_um,n,k\n0.4,1,1\n0.8,2,2\n").expect("valid");
        assert_eq!(
            t.sample(&[0.5, 0.9]).expect_err("outside").to_string(),
            "t.csv: wavelength 0.9 um is outside the table's range 0.4-0.8 um"
        );
        for bad in [0.0, -0.5, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(t.at(bad), Err(SpectrumError::InvalidWavelength(bad)));
        }
        assert_eq!(
            t.at(-0.5).expect_err("bad").to_string(),
            "wavelength -0.5 um is not a finite number > 0"
        );
        assert!(matches!(t.at(f64::NAN), Err(SpectrumError::InvalidWavelength(w)) if w.is_nan()));
        assert_eq!(t.n().try_at(0.3), None);
        assert_eq!(t.n().try_at(f64::NAN), None);
    }

    #[test]
    fn spd_pair_in_nanometres_on_separate_grids() {
        let eta = "# eta\n380 1.0\n400 1.0\n\n500\t2.0\n600 3.0\n";
        let k = "# k\n450 4.0\n650 6.0\n";
        let t = NkSpectrum::parse_spd_pair("Au.eta.spd", eta, "Au.k.spd", k).expect("valid");
        assert_eq!(t.range_um(), (0.45, 0.6));
        let nk = t.at(0.55).expect("inside");
        assert!((nk.n - 2.5).abs() < 1e-12 && (nk.k - 5.0).abs() < 1e-12);
        assert_eq!(
            t.at(0.42).expect_err("outside k").to_string(),
            "Au.k.spd: wavelength 0.42 um is outside the table's range 0.45-0.65 um"
        );
        assert_eq!(
            t.at(0.62).expect_err("outside n").to_string(),
            "Au.eta.spd: wavelength 0.62 um is outside the table's range 0.38-0.6 um"
        );
        assert_eq!(t.n().wavelengths_um()[0], 0.38);
        let err = |text: &str| {
            Spectrum::parse_spd("x.k.spd", "k", text)
                .expect_err("rejected")
                .to_string()
        };
        assert_eq!(err(""), "x.k.spd: no data rows");
        assert_eq!(
            err("400 1 2\n"),
            "x.k.spd, line 1: expected 2 fields (wavelength_nm value), found 3"
        );
        assert_eq!(
            err("400,1\n"),
            "x.k.spd, line 1: expected 2 fields (wavelength_nm value), found 1"
        );
        assert_eq!(
            err("500 1\n400 1\n"),
            "x.k.spd, line 2: wavelength 400 nm is not greater than the previous wavelength 500 nm"
        );
        assert_eq!(
            err("500 -1\n"),
            "x.k.spd, line 1: k = -1 is not a finite number >= 0"
        );
        assert_eq!(
            err("-500 1\n"),
            "x.k.spd, line 1: wavelength_nm = -500 is not a finite number > 0"
        );
    }

    #[test]
    fn spectrum_new_validates_points() {
        let s = Spectrum::new("pts", &[(0.5, 0.0), (1.0, 1.0)]).expect("valid");
        assert_eq!(s.try_at(0.75), Some(0.5));
        assert_eq!(s.file(), "pts");
        assert_eq!(s.values(), &[0.0, 1.0]);
        assert_eq!(
            Spectrum::new("pts", &[]),
            Err(SpectrumError::Empty { file: "pts".into() })
        );
        assert_eq!(
            Spectrum::new("pts", &[(0.4, 0.0), (0.4, 1.0)])
                .expect_err("duplicate")
                .to_string(),
            "pts, line 2: wavelength 0.4 um is not greater than the previous wavelength 0.4 um"
        );
        assert_eq!(
            Spectrum::new("pts", &[(0.4, f64::NAN)])
                .expect_err("nan")
                .to_string(),
            "pts, line 1: value = NaN is not a finite number >= 0"
        );
    }

    #[test]
    fn values_constant_or_aligned_arrays() {
        let source = NkSource::Values {
            n: SpectralValue::Constant(1.5),
            k: SpectralValue::PerWavelength(vec![0.0, 0.1]),
        };
        assert_eq!(
            source.sample(&[0.5, 0.6]),
            Ok(vec![Nk { n: 1.5, k: 0.0 }, Nk { n: 1.5, k: 0.1 }])
        );
        assert_eq!(
            source.sample(&[0.5]).expect_err("short").to_string(),
            "k has 2 values for 1 wavelengths"
        );
        assert_eq!(
            source.sample(&[0.5, -1.0]).expect_err("bad").to_string(),
            "wavelength -1 um is not a finite number > 0"
        );
        let bad = NkSource::Values {
            n: SpectralValue::Constant(-1.0),
            k: SpectralValue::Constant(0.0),
        };
        assert_eq!(
            bad.sample(&[0.5]).expect_err("bad").to_string(),
            "n = -1 is not a finite number >= 0"
        );
        let nan = SpectralValue::PerWavelength(vec![1.0, f64::NAN]);
        assert!(matches!(
            nan.sample("k", 2),
            Err(SpectrumError::InvalidValue { quantity: "k", value }) if value.is_nan()
        ));
        let nk = Nk { n: 1.5, k: 0.0 };
        assert!((nk.normal_reflectance() - 0.04).abs() < 1e-15);
        assert_eq!(
            Reflectance::from(nk),
            Reflectance::Fresnel { n: 1.5, k: 0.0 }
        );
    }

    #[test]
    fn reads_files_by_name_and_names_them_in_errors() {
        let dir = std::env::temp_dir().join(format!("roks-spectrum-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let stem = dir.join("Cu");
        std::fs::write(dir.join("Cu.eta.spd"), "400 1\n800 2\n").expect("write");
        std::fs::write(dir.join("Cu.k.spd"), "400 3\n800 4\n").expect("write");
        let by_stem = NkSpectrum::read(&stem).expect("pair by stem");
        let by_eta = NkSpectrum::read(&dir.join("Cu.eta.spd")).expect("pair by eta");
        let by_k = NkSpectrum::read(&dir.join("Cu.k.spd")).expect("pair by k");
        assert_eq!(by_stem, by_eta);
        assert_eq!(by_stem, by_k);
        assert_eq!(by_stem.range_um(), (0.4, 0.8));
        let missing = dir.join("none.csv");
        let err = NkSpectrum::read(&missing).expect_err("missing").to_string();
        assert!(
            err.starts_with(&format!("{}: cannot read the file: ", missing.display())),
            "{err}"
        );
        assert!(!err.contains('\n'));
        let unknown = dir.join("gold.txt");
        assert_eq!(
            NkSpectrum::read(&unknown).expect_err("unknown"),
            SpectrumError::UnknownFormat {
                file: unknown.display().to_string()
            }
        );
        std::fs::write(dir.join("bin.csv"), [0xff, 0xfe, 0x00]).expect("write");
        assert!(matches!(
            NkSpectrum::read(&dir.join("bin.csv")),
            Err(SpectrumError::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Every shipped table parses, its range is what scenes/materials/README.md says, and
    /// the first rows are the source's numbers.
    #[test]
    fn shipped_tables_parse_with_their_ranges() {
        let expected = [
            ("gold.csv", 49, 0.1879, 1.937),
            ("silver.csv", 49, 0.1879, 1.937),
            ("copper.csv", 49, 0.1879, 1.937),
            ("aluminium.csv", 206, 1.2399e-4, 200.0),
            ("aluminium-ir.csv", 51, 0.667, 200.0),
            ("pmma.csv", 617, 0.40, 19.942),
        ];
        for (name, rows, min, max) in expected {
            let t = NkSpectrum::read(&repo_file(&format!("scenes/materials/{name}")))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(t.n().wavelengths_um().len(), rows, "{name}");
            assert_eq!(t.range_um(), (min, max), "{name}");
        }
        let gold = NkSpectrum::read_csv(&repo_file(GOLD)).expect("gold");
        assert_eq!(gold.at(0.1879), Ok(Nk { n: 1.28, k: 1.188 }));
        assert_eq!(gold.at(1.937), Ok(Nk { n: 0.92, k: 13.78 }));
        // The infrared tables cover the thermal infrared of a radiator cavity.
        for name in ["aluminium-ir.csv", "pmma.csv", "aluminium.csv"] {
            let t =
                NkSpectrum::read_csv(&repo_file(&format!("scenes/materials/{name}"))).expect(name);
            let (min, max) = t.range_um();
            assert!(min <= 3.0 && max >= 14.0, "{name}");
        }
        // The four visible tables cover the CIE range 0.38-0.78 um.
        for name in ["gold.csv", "silver.csv", "copper.csv", "aluminium.csv"] {
            let t =
                NkSpectrum::read_csv(&repo_file(&format!("scenes/materials/{name}"))).expect(name);
            let (min, max) = t.range_um();
            assert!(min <= 0.38 && max >= 0.78, "{name}");
        }
    }

    #[test]
    fn out_of_range_message_names_the_file_as_given() {
        let gold = NkSpectrum::read_csv(Path::new(GOLD))
            .or_else(|_| {
                let text = std::fs::read_to_string(repo_file(GOLD)).expect("gold");
                NkSpectrum::parse_csv(GOLD, &text)
            })
            .expect("gold");
        assert_eq!(
            gold.at(0.15).expect_err("outside").to_string(),
            "scenes/materials/gold.csv: wavelength 0.15 um is outside the table's range 0.1879-1.937 um"
        );
    }

    #[test]
    fn a_large_table_parses() {
        let mut text = String::from("wavelength_um,n,k\n");
        for i in 1..=200_000 {
            text.push_str(&format!(
                "{},1.5,{}\n",
                f64::from(i) * 1e-4,
                f64::from(i % 7)
            ));
        }
        let t = csv(&text).expect("valid");
        assert_eq!(t.n().wavelengths_um().len(), 200_000);
        assert!(t.at(10.0).is_ok());
    }

    proptest! {
        #[test]
        fn never_panics_on_arbitrary_text(text in "\\PC*") {
            let _ = csv(&text);
            let _ = Spectrum::parse_spd("x.spd", "n", &text);
        }

        #[test]
        fn never_panics_on_table_like_text(
            rows in proptest::collection::vec(
                (
                    prop_oneof![Just("nan".to_owned()), Just("-1".to_owned()), Just(String::new()), (-1e3f64..1e3).prop_map(|v| v.to_string())],
                    prop_oneof![Just("inf".to_owned()), Just("0".to_owned()), (-10f64..10.0).prop_map(|v| v.to_string())],
                    prop_oneof![Just("x".to_owned()), (-10f64..10.0).prop_map(|v| v.to_string())],
                    0usize..4,
                ),
                0..20,
            ),
            probe in proptest::num::f64::ANY,
        ) {
            let mut text = String::from("wavelength_um,n,k\n");
            let mut spd = String::new();
            for (w, n, k, fields) in &rows {
                let all = [w.as_str(), n.as_str(), k.as_str()];
                text.push_str(&all[..(*fields).min(3)].join(","));
                text.push('\n');
                spd.push_str(&format!("{w} {n}\n"));
            }
            if let Ok(t) = csv(&text) {
                let _ = t.at(probe);
                let (min, max) = t.range_um();
                prop_assert!(min <= max);
                if let Ok(nk) = t.at(probe) {
                    prop_assert!(nk.n.is_finite() && nk.n >= 0.0 && nk.k.is_finite() && nk.k >= 0.0);
                }
            }
            if let Ok(s) = Spectrum::parse_spd("x.spd", "n", &spd) {
                let _ = s.try_at(probe);
            }
        }
    }
}
