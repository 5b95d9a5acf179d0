//! `stokes.csv` and `mueller.csv`: the polarisation tables of a run with a
//! polarisation tally (`[tally] polarisation = "stokes"` or `"mueller"`).
//! Frames: every outgoing direction's Stokes reference vector is
//! `normalize(z × d)` (see [`crate::optics::polarisation`]), the incident
//! one that of the incident flight (the s axis of the plane of incidence).
//! Numbers with 10 significant digits. A spectral run has `wavelength_um`
//! (µm) after `phi_i_deg`, one block per incidence and wavelength.
//!
//! The reader of `mueller.csv` lives here too: [`MuellerFile::parse`]
//! reads the rows, and [`BrdfTable::with_mueller`] (with
//! [`BrdfTables::with_mueller`] and [`SpectralTables::with_mueller`])
//! checks them against the `brdf.csv` of the same run and attaches the
//! matrices to the table.

use std::fmt::Write as _;
use std::path::Path;

use crate::optics::brdf_table::{BrdfTable, BrdfTables, SpectralTables};
use crate::optics::polarisation::degree_of_polarisation;
use crate::outdir::file::ResultFile;
use crate::output::brdf_csv::BrdfTableError;
use crate::output::brdf_csv::reader::{read_text, shorten};
use crate::tally::{CarlsonGrid, PolarTally};
use crate::transport::brdf::{BrdfResult, BrdfRun};

/// Columns of `stokes.csv`: per incidence and Carlson cell, the Stokes BRDF
/// `s_i` (1/sr) of the reflected light for the incident state in the cell
/// direction's frame, with standard errors; `s0` equals `brdf` of
/// `brdf.csv`; `dop = sqrt(s1² + s2² + s3²) / s0` of the means (0 where
/// `s0 = 0`).
pub const STOKES_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,s0,s0_stderr,s1,s1_stderr,s2,s2_stderr,s3,s3_stderr,dop";

/// Columns of `mueller.csv`: per incidence and Carlson cell, the Mueller
/// matrix BRDF `m_ij` (1/sr, row = outgoing component `i`, column = incident
/// component `j`) with standard errors; `m00` is the BRDF for unpolarised
/// light. Then the standard errors of the 15 normalised elements
/// `m_ij / m00` (dimensionless; `mij_m00_stderr`, from each element's
/// covariance with `m00`, see [`crate::tally::PolarTallies::ratio`]),
/// `nan` where `m00 = 0` (no light: the ratio is undefined). Files of roks
/// before these columns (the first [`MUELLER_MATRIX_COLUMNS`] only) are
/// still read.
pub const MUELLER_HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_deg,phi_deg,m00,m00_stderr,m01,m01_stderr,m02,m02_stderr,m03,m03_stderr,m10,m10_stderr,m11,m11_stderr,m12,m12_stderr,m13,m13_stderr,m20,m20_stderr,m21,m21_stderr,m22,m22_stderr,m23,m23_stderr,m30,m30_stderr,m31,m31_stderr,m32,m32_stderr,m33,m33_stderr,m01_m00_stderr,m02_m00_stderr,m03_m00_stderr,m10_m00_stderr,m11_m00_stderr,m12_m00_stderr,m13_m00_stderr,m20_m00_stderr,m21_m00_stderr,m22_m00_stderr,m23_m00_stderr,m30_m00_stderr,m31_m00_stderr,m32_m00_stderr,m33_m00_stderr";

/// Columns of the matrix part of [`MUELLER_HEADER`] (up to `m33_stderr`).
pub const MUELLER_MATRIX_COLUMNS: usize = 38;

/// The polarisation table of a run with a polarisation tally: its file name
/// (`stokes.csv` or `mueller.csv`) and text; `None` without one.
#[must_use]
pub fn write(run: &BrdfRun, results: &BrdfResult) -> Option<(&'static str, String)> {
    let (name, header) = match run.polarisation.tally {
        PolarTally::None => return None,
        PolarTally::Stokes => (ResultFile::Stokes.name(), STOKES_HEADER),
        PolarTally::Mueller => (ResultFile::Mueller.name(), MUELLER_HEADER),
    };
    let k = run.polarisation.tally.components();
    let grid: CarlsonGrid = run.grid();
    let mut s = String::with_capacity(40 * (k + 1) * grid.n_cells() * results.len());
    s.push_str(&super::with_wavelength(header, "phi_i_deg", run));
    s.push('\n');
    for r in results {
        let Some(p) = &r.tallies.polar else {
            continue;
        };
        for flat in 0..grid.n_cells() {
            let (band, cell) = grid.band_cell(flat);
            let (theta, phi) = grid.centre(band, cell);
            let proj = grid.projected_solid_angle(band, cell);
            let _ = write!(s, "{},{},", r.theta_i_deg, r.phi_i_deg);
            super::write_wavelength(&mut s, r);
            let _ = write!(
                s,
                "{band},{cell},{},{}",
                theta.to_degrees(),
                phi.to_degrees()
            );
            let mut means = [0.0; 16];
            for (i, m) in means.iter_mut().enumerate().take(k) {
                let (mean, se) = r.polar(p.cell_bin(flat, i)).unwrap_or_default();
                *m = mean / proj;
                let _ = write!(s, ",{:.9e},{:.9e}", mean / proj, se / proj);
            }
            if k == 4 {
                let _ = write!(
                    s,
                    ",{:.9e}",
                    degree_of_polarisation([means[0], means[1], means[2], means[3]])
                );
            } else {
                for i in 1..k {
                    match r.polar_ratio(1 + flat, i) {
                        Some((_, se)) => {
                            let _ = write!(s, ",{se:.9e}");
                        }
                        None => s.push_str(",nan"),
                    }
                }
            }
            s.push('\n');
        }
    }
    Some((name, s))
}

/// One data row of `mueller.csv` (monochrome or spectral), as read by
/// [`MuellerFile::parse`].
#[derive(Debug, Clone, PartialEq)]
pub struct MuellerRow {
    /// Line number in the file (1-based).
    pub line: usize,
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
    /// Wavelength (µm) of a spectral file's row.
    pub wavelength_um: Option<f64>,
    /// Carlson band, as written.
    pub band: String,
    /// Cell in the band, as written.
    pub cell: String,
    /// Mueller BRDF `m_ij` (1/sr), row-major.
    pub m: [f64; 16],
    /// Standard errors of `m` (1/sr).
    pub stderr: [f64; 16],
    /// Standard errors of `m_ij / m00` (index 0 is 0; NaN where `m00 = 0`);
    /// `None` in a file without these columns.
    pub normalised_stderr: Option<[f64; 16]>,
}

/// A parsed `mueller.csv`: its rows in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct MuellerFile {
    /// The file has the `wavelength_um` column of a spectral run.
    pub spectral: bool,
    /// Data rows (blank lines skipped).
    pub rows: Vec<MuellerRow>,
    /// Number of the file's last non-blank line.
    pub last_line: usize,
}

/// Why a `mueller.csv` cannot be read: the line and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {problem}")]
pub struct MuellerError {
    /// Line number (1 for the header).
    pub line: usize,
    /// What is wrong.
    pub problem: MuellerProblem,
}

/// What is wrong with a line of a `mueller.csv` ([`MuellerError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MuellerProblem {
    /// The first line is none of the headers of `mueller.csv`.
    #[error("header is not that of mueller.csv")]
    Header,
    /// A row without the header's column count.
    #[error("expected {expected} columns, found {found}")]
    Columns {
        /// The header's columns.
        expected: usize,
        /// The row's.
        found: usize,
    },
    /// A field that is not a finite number (1-based column; the field
    /// shortened to 40 characters).
    #[error("column {column}: `{text}` is not a finite number")]
    Number {
        /// 1-based column.
        column: usize,
        /// The field.
        text: String,
    },
    /// A negative standard error.
    #[error("column {column} (a standard error): {value} must be >= 0")]
    Negative {
        /// 1-based column.
        column: usize,
        /// The value.
        value: f64,
    },
}

impl MuellerFile {
    /// Read the text of a `mueller.csv`: the header (byte-order mark and
    /// trailing blanks dropped) of a monochrome or spectral run, with or
    /// without the normalised standard errors; in every row the column
    /// count of the header, finite incidence, matrix and error numbers
    /// (normalised errors: a number or `nan`), errors `>= 0`. Blocks,
    /// grid order and the fit to a BRDF table are the caller's checks.
    ///
    /// # Errors
    /// The first line that fails, and why.
    pub fn parse(text: &str) -> Result<Self, MuellerError> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
            .filter(|(_, l)| !l.trim().is_empty());
        let header = lines.next().map_or("", |(_, l)| l);
        let (spectral, normalised) = mueller_layout(header)?;
        let mut rows = Vec::new();
        let mut last_line = 1;
        for (line, l) in lines {
            last_line = line;
            rows.push(mueller_row(line, l, spectral, normalised)?);
        }
        Ok(Self {
            spectral,
            rows,
            last_line,
        })
    }
}

/// Whether a `mueller.csv` `header` line (byte-order mark and trailing
/// blanks dropped) is that of a spectral run, and whether it has the
/// normalised standard errors.
fn mueller_layout(header: &str) -> Result<(bool, bool), MuellerError> {
    let header = header.strip_prefix('\u{feff}').unwrap_or(header).trim_end();
    let full = MUELLER_HEADER;
    let matrix = matrix_header();
    let spectral_of = |h: &str| super::spectral_header(h, "phi_i_deg");
    if header == full {
        Ok((false, true))
    } else if header == matrix {
        Ok((false, false))
    } else if header == spectral_of(full) {
        Ok((true, true))
    } else if header == spectral_of(matrix) {
        Ok((true, false))
    } else {
        Err(MuellerError {
            line: 1,
            problem: MuellerProblem::Header,
        })
    }
}

/// Data row `l` (at `line`) of a `mueller.csv` of the layout
/// [`mueller_layout`] read: the header's column count, finite incidence,
/// matrix and error numbers (normalised errors: a number or `nan`), errors
/// `>= 0`.
fn mueller_row(
    line: usize,
    l: &str,
    spectral: bool,
    normalised: bool,
) -> Result<MuellerRow, MuellerError> {
    let off = usize::from(spectral);
    let columns = off
        + if normalised {
            53
        } else {
            MUELLER_MATRIX_COLUMNS
        };
    let fail = |problem| MuellerError { line, problem };
    let f: Vec<&str> = l.split(',').map(str::trim).collect();
    if f.len() != columns {
        return Err(fail(MuellerProblem::Columns {
            expected: columns,
            found: f.len(),
        }));
    }
    let parse = |i: usize, nan_ok: bool| -> Result<f64, MuellerError> {
        f[i].parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() || (nan_ok && v.is_nan()))
            .ok_or_else(|| {
                fail(MuellerProblem::Number {
                    column: i + 1,
                    text: shorten(f[i], 40),
                })
            })
    };
    let error = |i: usize, nan_ok: bool| -> Result<f64, MuellerError> {
        let se = parse(i, nan_ok)?;
        if se < 0.0 {
            return Err(fail(MuellerProblem::Negative {
                column: i + 1,
                value: se,
            }));
        }
        Ok(se)
    };
    let mut m = [0.0; 16];
    let mut stderr = [0.0; 16];
    for k in 0..16 {
        m[k] = parse(6 + off + 2 * k, false)?;
        stderr[k] = error(7 + off + 2 * k, false)?;
    }
    let normalised_stderr = if normalised {
        let mut n = [0.0; 16];
        for (k, v) in n.iter_mut().enumerate().skip(1) {
            *v = error(MUELLER_MATRIX_COLUMNS + off + k - 1, true)?;
        }
        Some(n)
    } else {
        None
    };
    Ok(MuellerRow {
        line,
        theta_i_deg: parse(0, false)?,
        phi_i_deg: parse(1, false)?,
        wavelength_um: if spectral {
            Some(parse(2, false)?)
        } else {
            None
        },
        band: f[2 + off].to_owned(),
        cell: f[3 + off].to_owned(),
        m,
        stderr,
        normalised_stderr,
    })
}

/// The first [`MUELLER_MATRIX_COLUMNS`] columns of [`MUELLER_HEADER`].
fn matrix_header() -> &'static str {
    let end = MUELLER_HEADER
        .match_indices(',')
        .nth(MUELLER_MATRIX_COLUMNS - 1)
        .map_or(MUELLER_HEADER.len(), |(i, _)| i);
    &MUELLER_HEADER[..end]
}

/// A wavelength in a message: ` at W um`, or nothing for a monochrome table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AtWavelength(pub Option<f64>);

impl std::fmt::Display for AtWavelength {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(w) => write!(f, " at {w} um"),
            None => Ok(()),
        }
    }
}

/// Why a `mueller.csv` could not be attached to the BRDF table it is read
/// with. Every message is one line naming the file (and the line where
/// there is one; lines are 1-based, line 1 is the header).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MuellerTableError {
    /// The file could not be read ([`BrdfTableError::Io`]).
    #[error(transparent)]
    Read(#[from] BrdfTableError),
    /// The file does not fit the table.
    #[error("{file}: line {line}: {problem}")]
    Mueller {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// What is wrong.
        problem: MuellerTableProblem,
    },
}

/// Why a `mueller.csv` does not fit the BRDF table it is read with
/// ([`MuellerTableError::Mueller`] names the file and line). Angles in
/// degrees; `table` is the table's file; `at` the wavelength of a
/// spectral run's table.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MuellerTableProblem {
    /// The file cannot be parsed.
    #[error("{0}")]
    File(MuellerProblem),
    /// A monochrome file beside a spectral table.
    #[error(
        "a mueller.csv of one wavelength, but {table} is a spectral table (it needs the wavelength_um column of a spectral run's mueller.csv)"
    )]
    OneWavelength {
        /// The table's file.
        table: String,
    },
    /// A spectral file beside a monochrome table.
    #[error(
        "a spectral mueller.csv (wavelength_um column), but {table} is a table of one wavelength"
    )]
    SpectralFile {
        /// The table's file.
        table: String,
    },
    /// A row of a wavelength the table does not have (µm).
    #[error("column 3: wavelength_um = {found} is not one of the wavelengths of {table}")]
    NotAWavelength {
        /// The row's wavelength.
        found: f64,
        /// The table's file.
        table: String,
    },
    /// A block that ends before its last cell.
    #[error("incidence block theta_i_deg = {theta_i_deg}{at} ends after {found} of {cells} cells")]
    BlockEnds {
        /// The block's incidence.
        theta_i_deg: f64,
        /// Its wavelength.
        at: AtWavelength,
        /// Cells found.
        found: usize,
        /// Cells of the grid.
        cells: usize,
    },
    /// A row out of grid order.
    #[error("expected band {band}, cell {cell} (grid order)")]
    Order {
        /// The band expected.
        band: usize,
        /// The cell expected.
        cell: usize,
    },
    /// The file's last block is incomplete.
    #[error("incidence block theta_i_deg = {theta_i_deg}{at} has {found} of {cells} cells")]
    Incomplete {
        /// The block's incidence.
        theta_i_deg: f64,
        /// Its wavelength.
        at: AtWavelength,
        /// Cells found.
        found: usize,
        /// Cells of the grid.
        cells: usize,
    },
    /// Another number of blocks than the table's incidences.
    #[error("{found} incidence blocks{at}, but {table} has {expected} (a file of another run?)")]
    Blocks {
        /// Blocks found.
        found: usize,
        /// The wavelength.
        at: AtWavelength,
        /// The table's file.
        table: String,
        /// The table's incidences.
        expected: usize,
    },
    /// A tabulated incidence without a block.
    #[error(
        "no block for theta_i_deg = {theta_i_deg}, phi_i_deg = {phi_i_deg}{at} (tabulated in {table})"
    )]
    NoBlock {
        /// The incidence angle.
        theta_i_deg: f64,
        /// The light azimuth.
        phi_i_deg: f64,
        /// The wavelength.
        at: AtWavelength,
        /// The table's file.
        table: String,
    },
    /// An `m00` other than the table's BRDF.
    #[error(
        "theta_i_deg = {theta_i_deg}{at}: cell {cell}: m00 = {m00} is not the brdf {brdf} of {table}, nor is that brdf m00 + m01 s1 + m02 s2 + m03 s3 for one incident state s of every cell (a file of another run?)"
    )]
    M00 {
        /// The incidence angle.
        theta_i_deg: f64,
        /// The wavelength.
        at: AtWavelength,
        /// The flat cell index.
        cell: usize,
        /// The file's `m00`.
        m00: f64,
        /// The table's BRDF (1/sr).
        brdf: f64,
        /// The table's file.
        table: String,
    },
    /// A cell whose matrix no physical surface has
    /// ([`crate::tally::realisable::unrealisable`]).
    #[error("theta_i_deg = {theta_i_deg}{at}: cell {cell}: not a physical Mueller matrix: {why}")]
    Unrealisable {
        /// The incidence angle.
        theta_i_deg: f64,
        /// The wavelength.
        at: AtWavelength,
        /// The flat cell index.
        cell: usize,
        /// Which condition fails.
        why: String,
    },
    /// An `m00` column that reflects more than it receives.
    #[error(
        "theta_i_deg = {theta_i_deg}{at}: the m00 column adds up to a reflectance of {total} > 1"
    )]
    M00Above {
        /// The incidence angle.
        theta_i_deg: f64,
        /// The wavelength.
        at: AtWavelength,
        /// The m00 column's reflectance.
        total: f64,
    },
}

impl BrdfTables {
    /// The same tables with the Mueller-matrix BRDF of the same run
    /// (`mueller.csv` beside `brdf.csv`), see
    /// [`with_mueller_text`](Self::with_mueller_text).
    ///
    /// # Errors
    /// [`MuellerTableError::Read`] if it cannot be read, otherwise as
    /// [`with_mueller_text`](Self::with_mueller_text).
    pub fn with_mueller(self, path: &Path) -> Result<Self, MuellerTableError> {
        let (name, text) = read_text(path)?;
        self.with_mueller_text(&text, &name)
    }

    /// As [`BrdfTable::with_mueller_text`] for a monochrome table. A
    /// spectral table needs the `mueller.csv` of a spectral run
    /// (`wavelength_um` after `phi_i_deg`, one block per incidence and
    /// wavelength): each wavelength's table takes the rows of its
    /// wavelength, with the checks of the monochrome case (every incidence
    /// complete, `m00` the table's BRDF), and every row must name one of
    /// the table's wavelengths.
    ///
    /// # Errors
    /// [`MuellerTableError::Mueller`] naming the file, the line and the problem.
    pub fn with_mueller_text(self, text: &str, name: &str) -> Result<Self, MuellerTableError> {
        match self {
            Self::Monochrome(t) => Ok(Self::Monochrome(t.with_mueller_text(text, name)?)),
            Self::Spectral(s) => Ok(Self::Spectral(s.with_mueller_text(text, name)?)),
        }
    }
}

impl SpectralTables {
    /// [`BrdfTables::with_mueller`] of spectral tables.
    ///
    /// # Errors
    /// As [`BrdfTables::with_mueller`].
    pub fn with_mueller(self, path: &Path) -> Result<Self, MuellerTableError> {
        let (name, text) = read_text(path)?;
        self.with_mueller_text(&text, &name)
    }

    /// [`BrdfTables::with_mueller_text`] of spectral tables.
    ///
    /// # Errors
    /// As [`BrdfTables::with_mueller_text`].
    pub fn with_mueller_text(mut self, text: &str, name: &str) -> Result<Self, MuellerTableError> {
        let fail = |line: usize, problem| MuellerTableError::Mueller {
            file: name.to_owned(),
            line,
            problem,
        };
        let file = MuellerFile::parse(text)
            .map_err(|e| fail(e.line, MuellerTableProblem::File(e.problem)))?;
        if !file.spectral {
            return Err(fail(
                1,
                MuellerTableProblem::OneWavelength {
                    table: self.tables()[0].file().to_owned(),
                },
            ));
        }
        // One pass: each row to the table of its wavelength.
        let wavelengths = self.wavelengths_um().to_vec();
        let mut lanes: Vec<Vec<&MuellerRow>> = vec![Vec::new(); wavelengths.len()];
        for row in &file.rows {
            let at = row.wavelength_um.unwrap_or(f64::NAN);
            let lane = wavelengths.iter().position(|&w| w == at).ok_or_else(|| {
                fail(
                    row.line,
                    MuellerTableProblem::NotAWavelength {
                        found: at,
                        table: self.tables()[0].file().to_owned(),
                    },
                )
            })?;
            lanes[lane].push(row);
        }
        for ((t, &w), rows) in self.tables_mut().iter_mut().zip(&wavelengths).zip(&lanes) {
            *t = t
                .clone()
                .attach_mueller(rows, file.last_line, name, Some(w))?;
        }
        Ok(self)
    }
}

impl BrdfTable {
    /// Attach the Mueller-matrix BRDF of the same run (`mueller.csv`
    /// beside `brdf.csv`, written by `roks brdf --polarisation mueller`):
    /// [`sample_cell`](Self::sample_cell)'s cells then carry their Mueller
    /// matrix divided by `m00` ([`mueller`](Self::mueller)). Frames: those
    /// of [`crate::optics::polarisation`], rotated into the local frame of
    /// the table (light azimuth 0).
    ///
    /// # Errors
    /// [`MuellerTableError::Read`] if it cannot be read, otherwise as
    /// [`with_mueller_text`](Self::with_mueller_text).
    pub fn with_mueller(self, path: &Path) -> Result<Self, MuellerTableError> {
        let (name, text) = read_text(path)?;
        self.with_mueller_text(&text, &name)
    }

    /// As [`with_mueller`](Self::with_mueller), from the text of
    /// `mueller.csv` ([`MUELLER_HEADER`]); `name` names it in
    /// errors. Every tabulated incidence needs a complete block of rows in
    /// grid order with the table's `theta_i_deg` and `phi_i_deg`; numbers
    /// finite; `m00` within 1e-6 (relative) of the table's BRDF.
    ///
    /// # Errors
    /// [`MuellerTableError::Mueller`] naming the file, the line and the problem.
    pub fn with_mueller_text(self, text: &str, name: &str) -> Result<Self, MuellerTableError> {
        let fail = |line: usize, problem| MuellerTableError::Mueller {
            file: name.to_owned(),
            line,
            problem,
        };
        let file = MuellerFile::parse(text)
            .map_err(|e| fail(e.line, MuellerTableProblem::File(e.problem)))?;
        if file.spectral {
            return Err(fail(
                1,
                MuellerTableProblem::SpectralFile {
                    table: self.file().to_owned(),
                },
            ));
        }
        let rows: Vec<&MuellerRow> = file.rows.iter().collect();
        self.attach_mueller(&rows, file.last_line, name, None)
    }

    /// Attach the Mueller blocks of `rows` (the parsed data rows of one
    /// table, [`MuellerFile::parse`]; `last_line` the file's last) as
    /// [`with_mueller_text`](Self::with_mueller_text) describes; for the
    /// table of one wavelength of a spectral run (`wavelength =
    /// Some(wavelength_um)`, named in errors) the rows of that wavelength
    /// only.
    fn attach_mueller(
        mut self,
        rows: &[&MuellerRow],
        last_line: usize,
        name: &str,
        wavelength: Option<f64>,
    ) -> Result<Self, MuellerTableError> {
        let fail = |(line, problem)| MuellerTableError::Mueller {
            file: name.to_owned(),
            line,
            problem,
        };
        let at = AtWavelength(wavelength);
        let blocks = self.mueller_blocks(rows, last_line, at).map_err(fail)?;
        for i in 0..self.thetas_deg().len() {
            let inc = self.incidence(i);
            let block = blocks
                .iter()
                .find(|b| b.theta_i_deg == inc.theta_deg && b.phi_i_deg == inc.phi_i_deg)
                .ok_or_else(|| {
                    fail((
                        last_line,
                        MuellerTableProblem::NoBlock {
                            theta_i_deg: inc.theta_deg,
                            phi_i_deg: inc.phi_i_deg,
                            at,
                            table: self.file().to_owned(),
                        },
                    ))
                })?;
            self.attach_block(i, block, last_line, at).map_err(fail)?;
        }
        Ok(self)
    }

    /// The data `rows` of a `mueller.csv` table grouped into blocks of one
    /// incidence, each the grid's cells in order, one block per incidence
    /// of this table; or the line and problem of the first failure
    /// (`last_line`: the file's last).
    fn mueller_blocks(
        &self,
        rows: &[&MuellerRow],
        last_line: usize,
        at: AtWavelength,
    ) -> Result<Vec<MuellerBlock>, (usize, MuellerTableProblem)> {
        let n = self.grid().n_cells();
        let mut blocks: Vec<MuellerBlock> = Vec::new();
        for row in rows {
            let (line, theta, phi) = (row.line, row.theta_i_deg, row.phi_i_deg);
            if blocks.last().is_none_or(|b| b.m.len() == n) {
                blocks.push(MuellerBlock {
                    theta_i_deg: theta,
                    phi_i_deg: phi,
                    m: Vec::with_capacity(n),
                    lines: Vec::with_capacity(n),
                });
            }
            let block = blocks.last_mut().expect("pushed");
            if (theta, phi) != (block.theta_i_deg, block.phi_i_deg) {
                return Err((
                    line,
                    MuellerTableProblem::BlockEnds {
                        theta_i_deg: block.theta_i_deg,
                        at,
                        found: block.m.len(),
                        cells: n,
                    },
                ));
            }
            let (band, cell) = self.grid().band_cell(block.m.len());
            if row.band != band.to_string() || row.cell != cell.to_string() {
                return Err((line, MuellerTableProblem::Order { band, cell }));
            }
            block.m.push(row.m);
            block.lines.push(line);
        }
        if let Some(b) = blocks.last().filter(|b| b.m.len() != n) {
            return Err((
                last_line,
                MuellerTableProblem::Incomplete {
                    theta_i_deg: b.theta_i_deg,
                    at,
                    found: b.m.len(),
                    cells: n,
                },
            ));
        }
        if blocks.len() != self.thetas_deg().len() {
            return Err((
                last_line,
                MuellerTableProblem::Blocks {
                    found: blocks.len(),
                    at,
                    table: self.file().to_owned(),
                    expected: self.thetas_deg().len(),
                },
            ));
        }
        Ok(blocks)
    }

    /// Attach `block` to incidence `i`: every matrix realisable, `m00`
    /// the table's BRDF (or, for a polarised incident state, the table's
    /// fractions set from `m00`), the matrices kept normalised by `m00`;
    /// or the line and problem of the first failure.
    fn attach_block(
        &mut self,
        i: usize,
        block: &MuellerBlock,
        last_line: usize,
        at: AtWavelength,
    ) -> Result<(), (usize, MuellerTableProblem)> {
        let n = self.grid().n_cells();
        let theta_i_deg = self.incidence(i).theta_deg;
        for (flat, m) in block.m.iter().enumerate() {
            if let Some(why) = crate::tally::realisable::unrealisable(m) {
                return Err((
                    block.lines[flat],
                    MuellerTableProblem::Unrealisable {
                        theta_i_deg,
                        at,
                        cell: flat,
                        why,
                    },
                ));
            }
        }
        let brdfs: Vec<f64> = (0..n).map(|flat| self.cell_brdf(i, flat)).collect();
        match incident_state(&block.m, &brdfs) {
            Err(flat) => {
                return Err((
                    block.lines[flat],
                    MuellerTableProblem::M00 {
                        theta_i_deg,
                        at,
                        cell: flat,
                        m00: block.m[flat][0],
                        brdf: brdfs[flat],
                        table: self.file().to_owned(),
                    },
                ));
            }
            // A polarised incident state: the wall meets every state, so
            // it samples the unpolarised BRDF, m00.
            Ok(Some(_)) => {
                let fractions = (0..n)
                    .map(|flat| block.m[flat][0] * self.cell_proj(flat))
                    .collect();
                self.set_fractions(i, fractions).map_err(|total| {
                    (
                        last_line,
                        MuellerTableProblem::M00Above {
                            theta_i_deg,
                            at,
                            total,
                        },
                    )
                })?;
            }
            Ok(None) => {}
        }
        let mut normalised = Vec::with_capacity(n);
        for m in &block.m {
            normalised.push(if m[0] > 0.0 {
                m.map(|v| v / m[0])
            } else {
                [0.0; 16]
            });
        }
        self.set_mueller(i, normalised);
        Ok(())
    }
}

/// The rows of one incidence in a `mueller.csv`, while they are checked
/// against a BRDF table.
struct MuellerBlock {
    /// Angle of incidence (degrees).
    theta_i_deg: f64,
    /// Light azimuth (degrees).
    phi_i_deg: f64,
    /// The matrix of each cell so far (grid order).
    m: Vec<[f64; 16]>,
    /// The line of each.
    lines: Vec<usize>,
}

/// The incident state of the run that wrote `brdfs` (a `brdf.csv` block's
/// BRDF per cell) beside `matrices` (its `mueller.csv` block): `None` when
/// every `brdf` is `m00` (unpolarised light, within 1e-6 relative), else
/// `(s1, s2, s3)`, `|s| <= 1`, with `brdf = m00 + m01 s1 + m02 s2 + m03 s3`
/// in every cell (the BRDF of that state; least squares over the cells,
/// then each cell within 1e-6 of the sum of the absolute terms).
///
/// # Errors
/// The first cell that fits neither.
fn incident_state(matrices: &[[f64; 16]], brdfs: &[f64]) -> Result<Option<glam::DVec3>, usize> {
    let off =
        |m: &[f64; 16], brdf: f64| (m[0] - brdf).abs() > 1e-6 * brdf.abs().max(m[0].abs()) + 1e-300;
    let Some(first) = matrices.iter().zip(brdfs).position(|(m, &b)| off(m, b)) else {
        return Ok(None);
    };
    let row = |m: &[f64; 16]| glam::DVec3::new(m[1], m[2], m[3]);
    let (mut a, mut b) = (glam::DMat3::ZERO, glam::DVec3::ZERO);
    for (m, &brdf) in matrices.iter().zip(brdfs) {
        let v = row(m);
        a += glam::DMat3::from_cols(v * v.x, v * v.y, v * v.z);
        b += v * (brdf - m[0]);
    }
    // A column of zeros (no circular part) leaves its component free: the
    // small ridge sets it to 0.
    let ridge = 1e-12 * (a.x_axis.x + a.y_axis.y + a.z_axis.z) + 1e-300;
    let s = (a + glam::DMat3::from_diagonal(glam::DVec3::splat(ridge))).inverse() * b;
    if !(s.length() <= 1.0 + 1e-6) {
        return Err(first);
    }
    let fits = |m: &[f64; 16], brdf: f64| {
        let v = row(m);
        let scale = brdf.abs() + m[0].abs() + v.abs().dot(glam::DVec3::ONE);
        (m[0] + v.dot(s) - brdf).abs() <= 1e-6 * scale + 1e-300
    };
    match matrices.iter().zip(brdfs).position(|(m, &b)| !fits(m, b)) {
        Some(flat) => Err(flat),
        None => Ok(Some(s)),
    }
}
