//! `stokes.csv` and `mueller.csv`: the polarisation tables of a run with a
//! polarisation tally (`[tally] polarisation = "stokes"` or `"mueller"`).
//! Frames: every outgoing direction's Stokes reference vector is
//! `normalize(z × d)` (see [`crate::optics::polarisation`]), the incident
//! one that of the incident flight (the s axis of the plane of incidence).
//! Numbers with 10 significant digits. A spectral run has `wavelength_um`
//! (µm) after `phi_i_deg`, one block per incidence and wavelength.

use std::fmt::Write as _;

use crate::optics::polarisation::degree_of_polarisation;
use crate::output::brdf_csv::reader::shorten;
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
        PolarTally::Stokes => ("stokes.csv", STOKES_HEADER),
        PolarTally::Mueller => ("mueller.csv", MUELLER_HEADER),
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
                    match p.ratio(1 + flat, i, r.tallies.photons) {
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
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MuellerError {
    /// Line number (1 for the header).
    pub line: usize,
    /// What is wrong (one line).
    pub message: String,
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
        let header = header.strip_prefix('\u{feff}').unwrap_or(header).trim_end();
        let full = MUELLER_HEADER;
        let matrix = matrix_header();
        let spectral_of = |h: &str| super::spectral_header(h, "phi_i_deg");
        let (spectral, normalised) = if header == full {
            (false, true)
        } else if header == matrix {
            (false, false)
        } else if header == spectral_of(full) {
            (true, true)
        } else if header == spectral_of(matrix) {
            (true, false)
        } else {
            return Err(MuellerError {
                line: 1,
                message: "header is not that of mueller.csv".into(),
            });
        };
        let off = usize::from(spectral);
        let columns = off
            + if normalised {
                53
            } else {
                MUELLER_MATRIX_COLUMNS
            };
        let mut rows = Vec::new();
        let mut last_line = 1;
        for (line, l) in lines {
            last_line = line;
            let fail = |message: String| MuellerError { line, message };
            let f: Vec<&str> = l.split(',').map(str::trim).collect();
            if f.len() != columns {
                return Err(fail(format!(
                    "expected {columns} columns, found {}",
                    f.len()
                )));
            }
            let parse = |i: usize, nan_ok: bool| -> Result<f64, MuellerError> {
                f[i].parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() || (nan_ok && v.is_nan()))
                    .ok_or_else(|| {
                        fail(format!(
                            "column {}: `{}` is not a finite number",
                            i + 1,
                            shorten(f[i], 40)
                        ))
                    })
            };
            let error = |i: usize, nan_ok: bool| -> Result<f64, MuellerError> {
                let se = parse(i, nan_ok)?;
                if se < 0.0 {
                    return Err(fail(format!(
                        "column {} (a standard error): {se} must be >= 0",
                        i + 1
                    )));
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
            rows.push(MuellerRow {
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
            });
        }
        Ok(Self {
            spectral,
            rows,
            last_line,
        })
    }
}

/// The first [`MUELLER_MATRIX_COLUMNS`] columns of [`MUELLER_HEADER`].
fn matrix_header() -> &'static str {
    let end = MUELLER_HEADER
        .match_indices(',')
        .nth(MUELLER_MATRIX_COLUMNS - 1)
        .map_or(MUELLER_HEADER.len(), |(i, _)| i);
    &MUELLER_HEADER[..end]
}
