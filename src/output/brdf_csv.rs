//! `brdf.csv`: the BRDF of a run tabulated on its Carlson grid, one row per
//! incidence and cell. This module owns the file: its columns
//! ([`HEADER`]), its one writer ([`write()`] for a run, [`write_blocks`] for
//! any fractions, e.g. a synthetic table in a test) and its reader
//! ([`read`], [`parse`]: a checked [`BrdfTable`]; [`read_tables`],
//! [`BrdfTables::parse`]: monochrome or spectral, [`BrdfTables`]; the checks and
//! their errors are in [`reader`], the table and its sampling in
//! [`crate::optics::brdf_table`]).
//!
//! # Columns
//!
//! `theta_i_deg`, `phi_i_deg`: the incidence (degrees, shortest round-trip
//! form); `band`, `cell`: the Carlson cell (band `1..=M` from the pole,
//! cell `0..4 band`); `theta_lo_deg`, `theta_hi_deg`, `phi_lo_deg`,
//! `phi_hi_deg`: its edges, `theta_deg`, `phi_deg` its centre (degrees,
//! absolute azimuths); `solid_angle_sr`, `projected_solid_angle_sr` (sr,
//! 13 significant digits); `fraction`, `fraction_stderr`: weight leaving
//! through the cell per launched photon and its standard error; `brdf`,
//! `brdf_stderr`: the same per projected solid angle (sr⁻¹); these four
//! with 10 significant digits.
//!
//! With several surface realisations (`[surface] realisations = R > 1`)
//! `fraction_stderr` and `brdf_stderr` are the standard errors of the
//! ensemble mean, from the spread between the realisations (`R - 1`
//! degrees of freedom, `stderr_dof` in `summary.json`; see
//! [`crate::transport::brdf::Ensemble`]), and two more columns end every
//! row ([`PHOTON_COLUMNS`]): `fraction_stderr_photon` and
//! `brdf_stderr_photon`, the photon noise alone. A run of one surface has
//! no such columns.
//!
//! A spectral run (`[light] wavelengths_um`) has one more column,
//! `wavelength_um` (µm, shortest round-trip form), right after `phi_i_deg`
//! ([`SPECTRAL_HEADER`]): one block per incidence and wavelength,
//! incidence-major, wavelengths in the run's order (strictly increasing). A
//! monochrome run's file has no such column. It reads back as one
//! [`BrdfTable`] per wavelength ([`read_tables`]: a
//! [`BrdfTables::Spectral`]); [`read`] and [`parse`] take monochrome files
//! only, as before.

use std::fmt::Write as _;
use std::path::Path;

use crate::optics::brdf_table::{BrdfTable, BrdfTables, SpectralTables};
use crate::outdir::file::ResultFile;
use crate::tally::CarlsonGrid;
use crate::transport::brdf::{BrdfResult, BrdfRun, IncidenceResult};

pub mod reader;

pub use reader::BrdfTableError;

/// Columns of `brdf.csv`.
pub const HEADER: &str = "theta_i_deg,phi_i_deg,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,fraction,fraction_stderr,brdf,brdf_stderr";

/// Columns of a spectral run's `brdf.csv`: [`HEADER`] with `wavelength_um`
/// after `phi_i_deg`.
pub const SPECTRAL_HEADER: &str = "theta_i_deg,phi_i_deg,wavelength_um,band,cell,theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,theta_deg,phi_deg,solid_angle_sr,projected_solid_angle_sr,fraction,fraction_stderr,brdf,brdf_stderr";

/// The columns that end the header of a run of several surface
/// realisations (after `brdf_stderr`): the standard errors from the
/// photons alone.
pub const PHOTON_COLUMNS: &str = "fraction_stderr_photon,brdf_stderr_photon";

/// The name of column `i` (0-based) of [`HEADER`].
///
/// # Panics
/// If `i` is not a column.
#[must_use]
pub fn column(i: usize) -> &'static str {
    HEADER.split(',').nth(i).expect("a column of brdf.csv")
}

/// Number of columns.
pub const COLUMNS: usize = 16;

/// One incidence of a table: its angles (degrees) and per flat Carlson cell
/// the fraction and its standard error.
#[derive(Debug, Clone, Copy)]
pub struct Block<'a> {
    /// Incidence polar angle (degrees).
    pub theta_i_deg: f64,
    /// Light azimuth (degrees).
    pub phi_i_deg: f64,
    /// Wavelength (µm) of a spectral run's block.
    pub wavelength_um: Option<f64>,
    /// Fraction per flat cell.
    pub fractions: &'a [f64],
    /// Standard error of each fraction.
    pub stderr: &'a [f64],
}

/// The rows (no header) of `blocks` on `grid`, in the number format of
/// the file.
///
/// # Panics
/// If a block does not have one fraction and one standard error per cell.
#[must_use]
pub fn write_rows<'a>(grid: &CarlsonGrid, blocks: impl IntoIterator<Item = Block<'a>>) -> String {
    write_rows_photon(grid, blocks, None)
}

/// [`write_rows`], each row ending with [`PHOTON_COLUMNS`] when `photon`
/// gives, per block, the photon-noise standard error of each fraction.
fn write_rows_photon<'a>(
    grid: &CarlsonGrid,
    blocks: impl IntoIterator<Item = Block<'a>>,
    photon: Option<&[Vec<f64>]>,
) -> String {
    let omega = grid.solid_angle();
    let mut s = String::new();
    for (i, b) in blocks.into_iter().enumerate() {
        let photon = photon.map(|p| &p[i]);
        assert_eq!(b.fractions.len(), grid.n_cells(), "one fraction per cell");
        assert_eq!(b.stderr.len(), grid.n_cells(), "one stderr per cell");
        s.reserve(200 * grid.n_cells());
        for flat in 0..grid.n_cells() {
            let (band, cell) = grid.band_cell(flat);
            let (mu_bot, mu_top) = grid.mu_edges(band);
            let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
            let (theta, phi) = grid.centre(band, cell);
            let proj = grid.projected_solid_angle(band, cell);
            let (f, fe) = (b.fractions[flat], b.stderr[flat]);
            let _ = write!(s, "{},{},", b.theta_i_deg, b.phi_i_deg);
            if let Some(w) = b.wavelength_um {
                let _ = write!(s, "{w},");
            }
            let _ = write!(
                s,
                "{band},{cell},{},{},{},{},{},{},{omega:.12e},{proj:.12e},{f:.9e},{fe:.9e},{:.9e},{:.9e}",
                mu_top.acos().to_degrees(),
                mu_bot.acos().to_degrees(),
                phi_lo.to_degrees(),
                phi_hi.to_degrees(),
                theta.to_degrees(),
                phi.to_degrees(),
                f / proj,
                fe / proj,
            );
            if let Some(p) = photon {
                let _ = write!(s, ",{:.9e},{:.9e}", p[flat], p[flat] / proj);
            }
            s.push('\n');
        }
    }
    s
}

/// The whole file of `blocks` on `grid`: [`HEADER`] (or
/// [`SPECTRAL_HEADER`] when the blocks have wavelengths) and [`write_rows`].
#[must_use]
pub fn write_blocks<'a>(grid: &CarlsonGrid, blocks: impl IntoIterator<Item = Block<'a>>) -> String {
    let mut blocks = blocks.into_iter().peekable();
    let spectral = blocks.peek().is_some_and(|b| b.wavelength_um.is_some());
    let header = if spectral { SPECTRAL_HEADER } else { HEADER };
    format!("{header}\n{}", write_rows(grid, blocks))
}

/// Per incidence result: the fractions and their standard errors.
fn fractions<'a>(
    run: &BrdfRun,
    results: impl IntoIterator<Item = &'a IncidenceResult>,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let cells = run.grid().n_cells();
    results
        .into_iter()
        .map(|r| {
            let n = r.tallies.photons;
            (0..cells)
                .map(|flat| (r.tallies.carlson.mean(flat, n), r.carlson_stderr(flat)))
                .unzip()
        })
        .collect()
}

/// `brdf.csv` of a run's `results` (its leaves in file order: a
/// [`BrdfResult`], or some of its leaves).
#[must_use]
pub fn write<'a>(
    run: &BrdfRun,
    results: impl IntoIterator<Item = &'a IncidenceResult> + Copy,
) -> String {
    let f = fractions(run, results);
    let blocks = results
        .into_iter()
        .zip(&f)
        .map(|(r, (fractions, stderr))| Block {
            theta_i_deg: r.theta_i_deg,
            phi_i_deg: r.phi_i_deg,
            wavelength_um: r.wavelength_um,
            fractions,
            stderr,
        });
    if run.realisations <= 1 {
        return write_blocks(&run.grid(), blocks);
    }
    // Several realisations: the photon noise after the ensemble's errors.
    let grid = run.grid();
    let photon: Vec<Vec<f64>> = results
        .into_iter()
        .map(|r| {
            (0..grid.n_cells())
                .map(|c| r.carlson_stderr_photon(c))
                .collect()
        })
        .collect();
    let header = if run.wavelengths_um.is_empty() {
        HEADER
    } else {
        SPECTRAL_HEADER
    };
    format!(
        "{header},{PHOTON_COLUMNS}\n{}",
        write_rows_photon(&grid, blocks, Some(&photon))
    )
}

/// The synthetic rows (no header) of one incidence `theta_i_deg`,
/// `phi_i_deg` (degrees) given by its `fractions` per flat cell of the
/// Carlson grid of `bands` bands, with `fraction_stderr = stderr_ratio *
/// fraction` (e.g. an analytic BRDF in a test).
///
/// # Panics
/// If `bands` is 0 or `fractions` does not have one value per cell.
#[must_use]
pub fn rows(
    bands: usize,
    theta_i_deg: f64,
    phi_i_deg: f64,
    fractions: &[f64],
    stderr_ratio: f64,
) -> String {
    let grid = CarlsonGrid::new(bands).expect("bands must be > 0");
    let stderr: Vec<f64> = fractions.iter().map(|f| stderr_ratio * f).collect();
    write_rows(
        &grid,
        [Block {
            theta_i_deg,
            phi_i_deg,
            wavelength_um: None,
            fractions,
            stderr: &stderr,
        }],
    )
}

/// Read and check `brdf.csv` at `path` (see [`BrdfTable::load`]).
///
/// # Errors
/// If it cannot be read or fails a check, naming the file.
pub fn read(path: &Path) -> Result<BrdfTable, BrdfTableError> {
    BrdfTable::load(path)
}

/// Parse and check the text of a `brdf.csv`, `name` naming it in messages
/// (see [`BrdfTable::parse`]).
///
/// # Errors
/// The first problem found, naming `name`, the line and the column.
pub fn parse(text: &str, name: &str) -> Result<BrdfTable, BrdfTableError> {
    BrdfTable::parse(text, name)
}

/// Read and check a monochrome or spectral `brdf.csv` at `path` (see
/// [`BrdfTables::load`]).
///
/// # Errors
/// If it cannot be read or fails a check, naming the file.
pub fn read_tables(path: &Path) -> Result<BrdfTables, BrdfTableError> {
    BrdfTables::load(path)
}

/// The tables of a run's `results` as its `brdf.csv` holds them (numbers
/// rounded as written), without writing or parsing the file: what
/// [`read_tables`] of the run's folder gives. A monochrome run gives
/// [`BrdfTables::Monochrome`], a spectral one a table per wavelength.
///
/// # Panics
/// If the results are not a valid table (a run's always are).
#[must_use]
pub fn table(run: &BrdfRun, results: &BrdfResult) -> BrdfTables {
    if run.wavelengths_um.is_empty() {
        return BrdfTables::Monochrome(lane_table(run, results.lane(0)));
    }
    let tables = (0..run.wavelengths_um.len())
        .map(|l| lane_table(run, results.lane(l)))
        .collect();
    BrdfTables::Spectral(
        SpectralTables::new(run.wavelengths_um.clone(), tables, ResultFile::Brdf.name())
            .expect("a run's wavelengths are strictly increasing"),
    )
}

/// The table of `results` (one wavelength's), numbers rounded as
/// `brdf.csv` writes them.
fn lane_table<'a>(run: &BrdfRun, results: impl Iterator<Item = &'a IncidenceResult>) -> BrdfTable {
    let results: Vec<&IncidenceResult> = results.collect();
    // The file's rounding of each number: 10 significant digits.
    let written = |x: f64| -> f64 {
        format!("{x:.9e}")
            .parse()
            .expect("a number written by the file's format reads back")
    };
    let blocks = fractions(run, results.iter().copied())
        .into_iter()
        .zip(&results)
        .map(|((f, e), r)| {
            (
                r.theta_i_deg,
                r.phi_i_deg,
                f.into_iter().map(written).collect::<Vec<_>>(),
                e.into_iter().map(written).collect::<Vec<_>>(),
            )
        })
        .collect();
    BrdfTable::from_blocks(run.grid(), blocks, ResultFile::Brdf.name())
        .expect("a run's results are a table")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_has_the_columns() {
        assert_eq!(HEADER.split(',').count(), COLUMNS);
        assert_eq!(column(0), "theta_i_deg");
        assert_eq!(column(12), "fraction");
        assert_eq!(column(15), "brdf_stderr");
    }

    /// The table of several surface realisations: the photon-noise
    /// columns end every row; the reader takes the file, with the errors of
    /// `fraction_stderr` (the ensemble's), and refuses a photon column that
    /// is not a number, naming it.
    #[test]
    fn photon_columns_read_back() {
        let f = [0.1, 0.2, 0.3, 0.4];
        let rows: String = rows(1, 30.0, 0.0, &f, 0.5)
            .lines()
            .map(|l| format!("{l},1.0e-3,2.0e-3\n"))
            .collect();
        let text = format!("{HEADER},{PHOTON_COLUMNS}\n{rows}");
        let table = parse(&text, "t.csv").unwrap();
        assert_eq!(table.fraction_stderrs(0), [0.05, 0.1, 0.15, 0.2]);
        let bad = text.replacen("1.0e-3", "x", 1);
        let e = parse(&bad, "t.csv").unwrap_err().to_string();
        assert!(
            e.contains("line 2") && e.contains("fraction_stderr_photon"),
            "{e}"
        );
        // A photon column too few: the row is refused.
        let short = text.replacen(",2.0e-3", "", 1);
        assert!(parse(&short, "t.csv").is_err());
    }

    #[test]
    fn rows_are_in_the_file_format() {
        let grid = CarlsonGrid::new(1).unwrap();
        let f = [0.1, 0.2, 0.3, 0.4];
        let text = rows(1, 30.0, 0.0, &f, 0.5);
        let first = text.lines().next().unwrap();
        let cols: Vec<&str> = first.split(',').collect();
        assert_eq!(cols.len(), COLUMNS);
        assert_eq!(&cols[..4], ["30", "0", "1", "0"]);
        assert_eq!(cols[12], "1.000000000e-1");
        assert_eq!(cols[13], "5.000000000e-2");
        let proj = grid.projected_solid_angle(1, 0);
        assert_eq!(cols[11], format!("{proj:.12e}"));
        assert_eq!(cols[14], format!("{:.9e}", 0.1 / proj));
        // The reader takes what the writer writes.
        let table = parse(&format!("{HEADER}\n{text}"), "t.csv").unwrap();
        assert!((table.reflectance(30f64.to_radians()) - 1.0).abs() < 1e-12);
    }
}
