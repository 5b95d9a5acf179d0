//! The checked reader of `brdf.csv` ([`BrdfTable::load`],
//! [`BrdfTable::parse`]), and why one fails ([`BrdfTableError`]). The
//! `summary.json` and `mueller.csv` that `roks brdf` writes beside it are
//! read where those formats are written: [`BrdfTable::with_summary`] in
//! `output::summary`, [`BrdfTable::with_mueller`] in
//! [`crate::output::polar_csv`].
//!
//! # Checks
//!
//! `brdf.csv` has the header [`HEADER`] (exactly) and one row per
//! incidence and cell of the Carlson equal-solid-angle grid of `M` bands
//! (see [`CarlsonGrid`]): band `j = 1..=M` from the pole holds `4 j` cells, so
//! an incidence block has `2 M (M + 1)` rows, band by band, cells in order.
//! `phi` columns are **absolute** azimuths; the block's light azimuth is
//! `phi_i_deg`. Loading requires: the header, every block complete and in
//! grid order with the same `M`, the edge, centre and solid-angle columns
//! matching the grid of `M` bands (to 1e-6 deg or 1e-6 relative), finite
//! numbers, `0 <= theta_i_deg < 90`, non-negative fractions, BRDFs and
//! standard errors, `brdf = fraction / projected_solid_angle_sr` and
//! `brdf_stderr = fraction_stderr / projected_solid_angle_sr` (to 1e-8
//! relative: an edited row, or a file cut inside its last number, fails),
//! every fraction and each incidence's sum of fractions (its reflectance) at
//! most 1 (+1e-9 for rounding: a table may not create light), and no
//! incidence (`theta_i_deg`, `phi_i_deg`) twice. Blocks may come in any
//! order; they are sorted by `theta_i_deg`, then `phi_i_deg`.
//!
//! **Several light azimuths.** A run of several light azimuths (`[light]
//! phi_deg = [0, 90]`) writes one block per incidence angle, then azimuth
//! (then wavelength); the incidences are the `(theta_i_deg, phi_i_deg)`
//! pairs, and every angle must have exactly the azimuths of the others
//! ([`BrdfValuesError::Azimuths`]: the line of the first block of the angle
//! lacking an azimuth, or of the block of the azimuth too many, column 2).
//! A table of one block per angle (one azimuth, possibly a different one
//! per angle) reads exactly as before. The order and what a
//! table of several azimuths means: [`crate::optics::brdf_table`].
//!
//! Errors are one line naming the file, the line
//! and (where there is one) the column. The table itself, its frame and its
//! sampling: [`crate::optics::brdf_table`].
//!
//! # Spectral tables
//!
//! [`BrdfTables::parse`] also reads the `brdf.csv` of a spectral run
//! (header [`SPECTRAL_HEADER`]: `wavelength_um` as column 3, every column
//! from `band` one place later, 17 columns; error messages give the file's
//! own column numbers). A block is the rows of one incidence and one
//! wavelength; each block passes the checks above; each wavelength's
//! blocks make a table checked as a monochrome one (no incidence twice,
//! fractions summing to at most 1); and the wavelengths must be finite and
//! `> 0`, the blocks of one incidence consecutive with strictly increasing
//! wavelengths, every incidence with exactly the wavelengths of the first
//! ([`BrdfTableError::Wavelength`] names the line of the block concerned,
//! column 3, the wavelength found and the one expected or missing).
//! [`BrdfTable::parse`] keeps its monochrome contract and refuses a
//! spectral file ([`BrdfTableError::Spectral`]). The `summary.json` of a
//! spectral run ([`BrdfTables::with_summary_text`]) must list the same
//! `wavelengths_um`; each wavelength's table takes its reflectance and
//! standard error from `incidence[k].spectrum[l]`.
//!
//! # Several surface realisations
//!
//! The table of a run of several surface realisations ends every row with
//! [`PHOTON_COLUMNS`] (the photon-noise part of the standard errors); the
//! reader takes such a file, monochrome or spectral, and checks that these
//! columns are finite numbers; the table's errors are `fraction_stderr`,
//! the ensemble's.

use std::path::Path;

use thiserror::Error;

use super::{COLUMNS, HEADER, PHOTON_COLUMNS, SPECTRAL_HEADER};
use crate::optics::brdf_table::{
    BlockData, BrdfTable, BrdfTables, BrdfValuesError, MAX_FRACTION, SpectralTables, azimuth_note,
    sort_incidences,
};
use crate::tally::CarlsonGrid;

/// Zero-based column indices of a monochrome table ([`HEADER`]); a
/// spectral table ([`SPECTRAL_HEADER`]) has `wavelength_um` at
/// [`C_WAVELENGTH`] and every column from `band` on one place later
/// ([`Layout::at`]).
const C_THETA_I: usize = 0;
const C_PHI_I: usize = 1;
const C_BAND: usize = 2;
const C_CELL: usize = 3;
const C_THETA_LO: usize = 4;
const C_THETA_HI: usize = 5;
const C_PHI_LO: usize = 6;
const C_PHI_HI: usize = 7;
const C_THETA_C: usize = 8;
const C_PHI_C: usize = 9;
const C_OMEGA: usize = 10;
const C_PROJ: usize = 11;
const C_FRACTION: usize = 12;
const C_FRACTION_SE: usize = 13;
const C_BRDF: usize = 14;
const C_BRDF_SE: usize = 15;
/// Zero-based index of `wavelength_um` in a spectral table.
const C_WAVELENGTH: usize = 2;

/// The columns of a `brdf.csv`: monochrome ([`HEADER`]) or spectral
/// ([`SPECTRAL_HEADER`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    spectral: bool,
    /// [`PHOTON_COLUMNS`] end the rows (several surface realisations).
    photon: bool,
}

impl Layout {
    fn header(self) -> &'static str {
        if self.spectral {
            SPECTRAL_HEADER
        } else {
            HEADER
        }
    }

    /// Number of columns.
    fn columns(self) -> usize {
        COLUMNS + usize::from(self.spectral) + 2 * usize::from(self.photon)
    }

    /// Zero-based index in the file of the monochrome column `c`.
    fn at(self, c: usize) -> usize {
        if self.spectral && c >= C_BAND {
            c + 1
        } else {
            c
        }
    }

    /// Name of the file's column `index` (zero-based).
    fn name(self, index: usize) -> &'static str {
        let photon = if self.photon { PHOTON_COLUMNS } else { "" };
        self.header()
            .split(',')
            .chain(photon.split(',').filter(|c| !c.is_empty()))
            .nth(index)
            .unwrap_or("?")
    }

    /// 1-based number and name of the monochrome column `c`, as the file
    /// has it.
    fn column(self, c: usize) -> (usize, &'static str) {
        let i = self.at(c);
        (i + 1, self.name(i))
    }
}

/// Tolerance of the grid check: degrees for angles, relative for solid angles.
const GRID_TOL: f64 = 1e-6;

/// Relative tolerance of `brdf = fraction / projected_solid_angle_sr` (and
/// of the standard errors alike): the writer rounds each of the three to 10
/// or 13 significant digits, so a table of `roks brdf` agrees to about 1e-9.
const DERIVED_TOL: f64 = 1e-8;

/// Why a `brdf.csv` could not be loaded. Every message is one line naming
/// the file, and the line and column where there is one (lines and columns
/// are 1-based; line 1 is the header).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BrdfTableError {
    /// The file could not be read.
    #[error("{file}: cannot read: {message}")]
    Io {
        /// File name.
        file: String,
        /// The operating system's message.
        message: String,
    },
    /// The first line is not [`HEADER`] (nor, where a spectral table is
    /// accepted, [`SPECTRAL_HEADER`]).
    #[error("{file}: line 1: header must be exactly `{expected}`{spectral}, found `{found}`")]
    Header {
        /// File name.
        file: String,
        /// The expected header.
        expected: &'static str,
        /// Where a spectral table is accepted: `` or, with wavelengths,
        /// `<SPECTRAL_HEADER>` ``; else empty.
        spectral: String,
        /// What the file has (shortened to 200 characters).
        found: String,
    },
    /// A spectral table (`wavelength_um` column) where a table of one
    /// wavelength is expected.
    #[error(
        "{file}: line 1: a spectral table (column 3, wavelength_um: a block per incidence and wavelength) where a table of one wavelength is expected (header `{expected}`)"
    )]
    Spectral {
        /// File name.
        file: String,
        /// The expected header.
        expected: &'static str,
    },
    /// A row does not have 16 columns (17 in a spectral table).
    #[error("{file}: line {line}: expected {expected} columns, found {found}")]
    Columns {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// Number of columns of the header.
        expected: usize,
        /// Number of columns found.
        found: usize,
    },
    /// The wavelengths of a spectral table: not the same strictly
    /// increasing list for every incidence.
    #[error("{file}: line {line}, column 3 (wavelength_um): {message}")]
    Wavelength {
        /// File name.
        file: String,
        /// Line number (the first row of the block concerned).
        line: usize,
        /// What is wrong (one line).
        message: String,
    },
    /// A field is not a finite number (or, for `band` and `cell`, not a
    /// non-negative integer).
    #[error("{file}: line {line}, column {column} ({name}): `{text}` is not a {what}")]
    Number {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// Column number.
        column: usize,
        /// Column name.
        name: &'static str,
        /// The field (shortened to 40 characters).
        text: String,
        /// "finite number" or "non-negative integer".
        what: &'static str,
    },
    /// A number outside its allowed range.
    #[error("{file}: line {line}, column {column} ({name}): {value} {requirement}")]
    OutOfRange {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// Column number.
        column: usize,
        /// Column name.
        name: &'static str,
        /// The value.
        value: f64,
        /// What it must satisfy, e.g. "must be >= 0".
        requirement: &'static str,
    },
    /// `band` or `cell` out of the grid order of an incidence block.
    #[error(
        "{file}: line {line}, column {column} ({name}): found {found}, expected {expected} (an incidence block lists the Carlson cells band by band from the pole, cells in order)"
    )]
    Order {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// Column number.
        column: usize,
        /// Column name.
        name: &'static str,
        /// The value found.
        found: usize,
        /// The value expected.
        expected: usize,
    },
    /// An incidence block stops in the middle of a band.
    #[error(
        "{file}: line {line}: incomplete incidence block theta_i_deg = {theta_i_deg} (from line {start}): {rows} rows, a complete block of {bands} bands has {expected}"
    )]
    Incomplete {
        /// File name.
        file: String,
        /// Line of the block's last row.
        line: usize,
        /// Line of the block's first row.
        start: usize,
        /// The block's incidence angle (degrees).
        theta_i_deg: f64,
        /// Rows found.
        rows: usize,
        /// Bands of a complete block (those of the first block, if known).
        bands: usize,
        /// Rows of a complete block, `2 M (M + 1)`.
        expected: usize,
    },
    /// Two incidence blocks with different numbers of bands.
    #[error(
        "{file}: line {line}: incidence block theta_i_deg = {theta_i_deg} (from line {start}) has {bands} bands ({rows} rows) but the first block has {first_bands} ({first_rows} rows)"
    )]
    Bands {
        /// File name.
        file: String,
        /// Line of the block's last row.
        line: usize,
        /// Line of the block's first row.
        start: usize,
        /// The block's incidence angle (degrees).
        theta_i_deg: f64,
        /// Its bands.
        bands: usize,
        /// Its rows.
        rows: usize,
        /// Bands of the first block.
        first_bands: usize,
        /// Rows of the first block.
        first_rows: usize,
    },
    /// An edge or solid-angle column that does not match the Carlson grid.
    #[error(
        "{file}: line {line}, column {column} ({name}): {found} does not match the Carlson grid of {bands} bands, which has {expected}"
    )]
    Grid {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// Column number.
        column: usize,
        /// Column name.
        name: &'static str,
        /// Value in the file.
        found: f64,
        /// Value of the grid.
        expected: f64,
        /// Bands of the grid.
        bands: usize,
    },
    /// An incidence angle twice, or fractions that create light.
    #[error(transparent)]
    Table(#[from] BrdfValuesError),
    /// A column derived from others (`brdf = fraction / projected solid
    /// angle`, `brdf_stderr` alike) that does not match them: a row edited
    /// or cut short.
    #[error(
        "{file}: line {line}, column {column} ({name}): {found} is not {formula} = {expected} (an edited or truncated row?)"
    )]
    Derived {
        /// File name.
        file: String,
        /// Line number.
        line: usize,
        /// Column number.
        column: usize,
        /// Column name.
        name: &'static str,
        /// Value in the file.
        found: f64,
        /// Value from the other columns.
        expected: f64,
        /// How it is derived, e.g. `fraction / projected_solid_angle_sr`.
        formula: &'static str,
    },
    /// A `summary.json` that does not fit the table (read in
    /// `output::summary`).
    #[error("{file}: {problem}")]
    Summary {
        /// File name.
        file: String,
        /// What is wrong.
        problem: crate::output::summary::SummaryProblem,
    },
    /// A header and no data rows.
    #[error("{file}: line {line}: no data rows after the header")]
    Empty {
        /// File name.
        file: String,
        /// Last line of the file.
        line: usize,
    },
}

/// One parsed data row (the fields the table uses).
struct Row {
    line: usize,
    theta_i: f64,
    phi_i: f64,
    /// `wavelength_um` of a spectral table.
    wavelength: Option<f64>,
    band: usize,
    cell: usize,
    /// Edge, centre and solid-angle columns, by column index.
    geometry: [(usize, f64); 8],
    fraction: f64,
    fraction_se: f64,
    /// `brdf` and `brdf_stderr` as written (sr⁻¹).
    brdf: f64,
    brdf_se: f64,
}

/// Rows of one incidence block (of one wavelength, in a spectral table),
/// in file order.
struct Block {
    start: usize,
    theta_i: f64,
    phi_i: f64,
    wavelength: Option<f64>,
    rows: Vec<Row>,
}

/// The checked blocks of a `brdf.csv`, in file order, before they are
/// tables.
struct Parsed {
    layout: Layout,
    grid: CarlsonGrid,
    blocks: Vec<Block>,
}

/// At most `n` characters of `s`, with `...` when cut.
pub(crate) fn shorten(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_owned()
    } else {
        let mut t: String = s.chars().take(n).collect();
        t.push_str("...");
        t
    }
}

/// The file at `path` as text and its name for messages.
///
/// # Errors
/// [`BrdfTableError::Io`] naming the file.
pub(crate) fn read_text(path: &Path) -> Result<(String, String), BrdfTableError> {
    let name = path.display().to_string();
    match crate::limits::read_input_text_capped(path, crate::limits::max_data_bytes()) {
        Ok(text) => Ok((name, text)),
        Err(e) => Err(BrdfTableError::Io {
            file: name,
            message: e.to_string(),
        }),
    }
}

impl BrdfTable {
    /// Read and check a `brdf.csv` file.
    ///
    /// # Errors
    /// [`BrdfTableError::Io`] if it cannot be read, otherwise as
    /// [`parse`](Self::parse), naming the file by `path`.
    pub fn load(path: &Path) -> Result<Self, BrdfTableError> {
        let (name, text) = read_text(path)?;
        Self::parse(&text, &name)
    }

    /// Parse and check the text of a monochrome `brdf.csv`; `name` names
    /// the file in error messages. Blank lines are skipped, `\r\n` line
    /// ends and a byte order mark are accepted. A spectral table is refused
    /// ([`BrdfTableError::Spectral`]; read it with [`BrdfTables::parse`]).
    ///
    /// # Errors
    /// The first problem found, as a [`BrdfTableError`] naming `name`, the
    /// line and the column.
    pub fn parse(text: &str, name: &str) -> Result<Self, BrdfTableError> {
        let parsed = parse_blocks(text, name, false)?;
        monochrome(parsed, name, 0)
    }
}

impl BrdfTables {
    /// Read and check a `brdf.csv` file, monochrome or spectral.
    ///
    /// # Errors
    /// [`BrdfTableError::Io`] if it cannot be read, otherwise as
    /// [`parse`](Self::parse), naming the file by `path`.
    pub fn load(path: &Path) -> Result<Self, BrdfTableError> {
        let (name, text) = read_text(path)?;
        Self::parse(&text, &name)
    }

    /// Parse and check the text of a `brdf.csv`, monochrome ([`HEADER`]:
    /// [`BrdfTables::Monochrome`], exactly as [`BrdfTable::parse`]) or
    /// spectral ([`SPECTRAL_HEADER`]: [`BrdfTables::Spectral`]). A
    /// spectral table passes every check of a monochrome one for each
    /// wavelength, and: every block has a `wavelength_um > 0`; the blocks of
    /// one incidence (`theta_i_deg`, `phi_i_deg`) are consecutive, one per
    /// wavelength, wavelengths strictly increasing; every incidence lists
    /// the wavelengths of the first. Incidences may come in any order (they
    /// are sorted by angle), none twice.
    ///
    /// # Errors
    /// The first problem found, as a [`BrdfTableError`] naming `name`, the
    /// line and the column.
    pub fn parse(text: &str, name: &str) -> Result<Self, BrdfTableError> {
        let parsed = parse_blocks(text, name, true)?;
        if !parsed.layout.spectral {
            return Ok(Self::Monochrome(monochrome(parsed, name, 0)?));
        }
        let Parsed {
            layout,
            grid,
            blocks,
        } = parsed;
        // Consecutive blocks of one incidence.
        let mut incidences: Vec<Vec<Block>> = Vec::new();
        for b in blocks {
            match incidences.last_mut() {
                Some(group) if group[0].theta_i == b.theta_i && group[0].phi_i == b.phi_i => {
                    group.push(b);
                }
                _ => incidences.push(vec![b]),
            }
        }
        let wavelengths: Vec<f64> = incidences[0]
            .iter()
            .map(|b| b.wavelength.unwrap_or(f64::NAN))
            .collect();
        for group in &incidences {
            check_wavelengths(group, &wavelengths, name)?;
        }
        // One table per wavelength: its block of every incidence.
        let (column, _) = layout.column(C_FRACTION);
        let mut per_wavelength: Vec<Vec<Block>> =
            (0..wavelengths.len()).map(|_| Vec::new()).collect();
        for group in incidences {
            for (l, b) in group.into_iter().enumerate() {
                per_wavelength[l].push(b);
            }
        }
        let tables = per_wavelength
            .into_iter()
            .map(|blocks| {
                monochrome(
                    Parsed {
                        layout,
                        grid,
                        blocks,
                    },
                    name,
                    column,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self::Spectral(SpectralTables::new(
            wavelengths,
            tables,
            name,
        )?))
    }
}

/// Check the blocks of one incidence (`group`, consecutive in file
/// `name`): their wavelengths strictly increasing and those of the first
/// incidence (`wavelengths`, um), in order, none missing.
fn check_wavelengths(
    group: &[Block],
    wavelengths: &[f64],
    name: &str,
) -> Result<(), BrdfTableError> {
    let fail = |line: usize, message: String| BrdfTableError::Wavelength {
        file: name.to_owned(),
        line,
        message,
    };
    let list = |ws: &[f64]| {
        ws.iter()
            .map(|w| format!("{w}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let first = &group[0];
    for (k, b) in group.iter().enumerate() {
        let w = b.wavelength.unwrap_or(f64::NAN);
        if k > 0 {
            let before = group[k - 1].wavelength.unwrap_or(f64::NAN);
            // Wavelengths are finite (checked per row).
            if w <= before {
                return Err(fail(
                    b.start,
                    format!(
                        "{w} um after {before} um: the wavelengths of an incidence (theta_i_deg = {}, from line {}) must be strictly increasing",
                        first.theta_i, first.start
                    ),
                ));
            }
        }
        match wavelengths.get(k) {
            Some(&want) if want == w => {}
            Some(&want) => {
                return Err(fail(
                    b.start,
                    format!(
                        "found {w} um, expected {want} um: incidence theta_i_deg = {} (from line {}) must list the wavelengths of the first incidence ({} um), in order",
                        first.theta_i,
                        first.start,
                        list(wavelengths)
                    ),
                ));
            }
            None => {
                return Err(fail(
                    b.start,
                    format!(
                        "{w} um: incidence theta_i_deg = {} (from line {}) has more wavelengths than the first incidence ({} um)",
                        first.theta_i,
                        first.start,
                        list(wavelengths)
                    ),
                ));
            }
        }
    }
    if group.len() < wavelengths.len() {
        let last = &group[group.len() - 1];
        return Err(fail(
            last.start,
            format!(
                "incidence theta_i_deg = {} (from line {}) stops after {} um: it lacks {} um of the wavelengths of the first incidence ({} um)",
                first.theta_i,
                first.start,
                last.wavelength.unwrap_or(f64::NAN),
                list(&wavelengths[group.len()..]),
                list(wavelengths)
            ),
        ));
    }
    Ok(())
}

/// The table of checked blocks (of one wavelength): sorted by angle, then
/// light azimuth, no incidence twice, every angle with the same azimuths;
/// `fraction_column` (1-based, 0: the monochrome 13) names the
/// fraction column in an error.
fn monochrome(
    parsed: Parsed,
    name: &str,
    fraction_column: usize,
) -> Result<BrdfTable, BrdfTableError> {
    let Parsed { grid, blocks, .. } = parsed;
    let several = blocks.iter().any(|b| b.phi_i != blocks[0].phi_i);
    let mut data: Vec<BlockData> = blocks
        .iter()
        .map(|b| BlockData {
            line: b.start,
            theta_deg: b.theta_i,
            phi_i_deg: b.phi_i,
            fractions: b.rows.iter().map(|r| r.fraction).collect(),
            fraction_stderr: b.rows.iter().map(|r| r.fraction_se).collect(),
        })
        .collect();
    sort_incidences(&mut data);
    for pair in data.windows(2) {
        if (pair[0].theta_deg, pair[0].phi_i_deg) == (pair[1].theta_deg, pair[1].phi_i_deg) {
            let (a, b) = if pair[0].line < pair[1].line {
                (&pair[0], &pair[1])
            } else {
                (&pair[1], &pair[0])
            };
            return Err(BrdfValuesError::Duplicate {
                file: name.to_owned(),
                line: b.line,
                first: a.line,
                theta_i_deg: b.theta_deg,
                azimuth: azimuth_note(several, b.phi_i_deg),
            }
            .into());
        }
    }
    BrdfTable::from_checked(grid, data, name.to_owned()).map_err(|mut e| {
        if let BrdfValuesError::Sum { column, .. } = &mut e {
            if fraction_column > 0 {
                *column = fraction_column;
            }
        }
        e.into()
    })
}

/// The rows of a `brdf.csv` (monochrome, or spectral if `spectral_ok`)
/// grouped into blocks of one incidence (and wavelength), each checked:
/// grid order, complete, the first block's bands, geometry and derived
/// columns.
fn parse_blocks(text: &str, name: &str, spectral_ok: bool) -> Result<Parsed, BrdfTableError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)));
    let header = lines.next().map_or("", |(_, l)| l);
    let layout = read_layout(header, name, spectral_ok)?;
    let (blocks, last_line) = group_rows(lines, name, layout)?;

    // Every block complete, all with the first block's bands.
    let mut first: Option<(usize, usize)> = None; // (bands, rows)
    for b in &blocks {
        let (bands, rows) = check_complete(b, first, name)?;
        first.get_or_insert((bands, rows));
    }
    let bands = first.map_or(1, |(m, _)| m);
    let grid = CarlsonGrid::new(bands).ok_or_else(|| BrdfTableError::Empty {
        file: name.to_owned(),
        line: last_line,
    })?;
    for b in &blocks {
        check_geometry(b, grid, name, layout)?;
    }
    Ok(Parsed {
        layout,
        grid,
        blocks,
    })
}

/// The columns a `brdf.csv` `header` line announces (monochrome, or
/// spectral if `spectral_ok`; with the photon-noise columns of several
/// surface realisations or without).
fn read_layout(header: &str, name: &str, spectral_ok: bool) -> Result<Layout, BrdfTableError> {
    let header = header.strip_prefix('\u{feff}').unwrap_or(header).trim_end();
    let full = header;
    // Several surface realisations: the photon-noise columns at the end.
    let (header, photon) = match header
        .strip_suffix(PHOTON_COLUMNS)
        .and_then(|h| h.strip_suffix(','))
    {
        Some(h) => (h, true),
        None => (header, false),
    };
    Ok(match header {
        HEADER => Layout {
            spectral: false,
            photon,
        },
        SPECTRAL_HEADER if spectral_ok => Layout {
            spectral: true,
            photon,
        },
        SPECTRAL_HEADER => {
            return Err(BrdfTableError::Spectral {
                file: name.to_owned(),
                expected: HEADER,
            });
        }
        _ => {
            return Err(BrdfTableError::Header {
                file: name.to_owned(),
                expected: HEADER,
                spectral: if spectral_ok {
                    format!(" or, with wavelengths, `{SPECTRAL_HEADER}`")
                } else {
                    String::new()
                },
                found: shorten(full, 200),
            });
        }
    })
}

/// The data `lines` (numbered) parsed and grouped: consecutive rows with
/// the same incidence (and wavelength) make a block, each row checked to
/// be its block's next cell; with the number of the last line. No blocks
/// is an error.
fn group_rows<'a>(
    lines: impl Iterator<Item = (usize, &'a str)>,
    name: &str,
    layout: Layout,
) -> Result<(Vec<Block>, usize), BrdfTableError> {
    let mut blocks: Vec<Block> = Vec::new();
    let mut last_line = 1;
    for (line, text) in lines {
        last_line = line;
        if text.trim().is_empty() {
            continue;
        }
        let row = parse_row(text, line, name, layout)?;
        let same = blocks.last().is_some_and(|b| {
            b.theta_i == row.theta_i && b.phi_i == row.phi_i && b.wavelength == row.wavelength
        });
        if !same {
            blocks.push(Block {
                start: line,
                theta_i: row.theta_i,
                phi_i: row.phi_i,
                wavelength: row.wavelength,
                rows: Vec::new(),
            });
        }
        if let Some(b) = blocks.last_mut() {
            check_order(b, &row, name, layout)?;
            b.rows.push(row);
        }
    }
    if blocks.is_empty() {
        return Err(BrdfTableError::Empty {
            file: name.to_owned(),
            line: last_line,
        });
    }
    Ok((blocks, last_line))
}

/// The geometry columns of every row of block `b` against `grid` (to
/// [`GRID_TOL`], relative for the solid angles), and its derived columns.
fn check_geometry(
    b: &Block,
    grid: CarlsonGrid,
    name: &str,
    layout: Layout,
) -> Result<(), BrdfTableError> {
    let omega = grid.solid_angle();
    for (flat, row) in b.rows.iter().enumerate() {
        let (band, cell) = grid.band_cell(flat);
        let (mu_bot, mu_top) = grid.mu_edges(band);
        let (theta_c, phi_c) = grid.centre(band, cell);
        let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
        let proj = grid.projected_solid_angle(band, cell);
        for &(col, found) in &row.geometry {
            let (expected, relative) = match col {
                C_THETA_LO => (mu_top.acos().to_degrees(), false),
                C_THETA_HI => (mu_bot.acos().to_degrees(), false),
                C_PHI_LO => (phi_lo.to_degrees(), false),
                C_PHI_HI => (phi_hi.to_degrees(), false),
                C_THETA_C => (theta_c.to_degrees(), false),
                C_PHI_C => (phi_c.to_degrees(), false),
                C_OMEGA => (omega, true),
                _ => (proj, true),
            };
            let tol = if relative {
                GRID_TOL * expected
            } else {
                GRID_TOL
            };
            if (found - expected).abs() > tol {
                let (column, name_of) = layout.column(col);
                return Err(BrdfTableError::Grid {
                    file: name.to_owned(),
                    line: row.line,
                    column,
                    name: name_of,
                    found,
                    expected,
                    bands: grid.bands(),
                });
            }
        }
        check_derived(row, proj, name, layout)?;
    }
    Ok(())
}

/// Parse one data row.
fn parse_row(text: &str, line: usize, name: &str, layout: Layout) -> Result<Row, BrdfTableError> {
    let fields = Fields {
        fields: text.split(',').map(str::trim).collect(),
        line,
        name,
        layout,
    };
    if fields.fields.len() != layout.columns() {
        return Err(BrdfTableError::Columns {
            file: name.to_owned(),
            line,
            expected: layout.columns(),
            found: fields.fields.len(),
        });
    }
    let (v, wavelength) = fields.values()?;
    let band = fields.integer(layout.at(C_BAND))?;
    let cell = fields.integer(layout.at(C_CELL))?;
    if !(0.0..90.0).contains(&v[C_THETA_I]) {
        return Err(fields.out_of_range(C_THETA_I, v[C_THETA_I], "must be in [0, 90)"));
    }
    if let Some(w) = wavelength.filter(|w| *w <= 0.0) {
        return Err(BrdfTableError::OutOfRange {
            file: name.to_owned(),
            line,
            column: C_WAVELENGTH + 1,
            name: layout.name(C_WAVELENGTH),
            value: w,
            requirement: "must be > 0 (a vacuum wavelength in um)",
        });
    }
    for col in [C_FRACTION, C_FRACTION_SE, C_BRDF, C_BRDF_SE] {
        if v[col] < 0.0 {
            return Err(fields.out_of_range(col, v[col], "must be >= 0"));
        }
    }
    if v[C_FRACTION] > MAX_FRACTION {
        return Err(fields.out_of_range(
            C_FRACTION,
            v[C_FRACTION],
            "must be <= 1 (the share of the launched light leaving through the cell)",
        ));
    }
    Ok(Row {
        line,
        theta_i: v[C_THETA_I],
        phi_i: v[C_PHI_I],
        wavelength,
        band,
        cell,
        geometry: [
            C_THETA_LO, C_THETA_HI, C_PHI_LO, C_PHI_HI, C_THETA_C, C_PHI_C, C_OMEGA, C_PROJ,
        ]
        .map(|c| (c, v[c])),
        fraction: v[C_FRACTION],
        fraction_se: v[C_FRACTION_SE],
        brdf: v[C_BRDF],
        brdf_se: v[C_BRDF_SE],
    })
}

/// The fields of one data row of `brdf.csv` file `name` (at `line`), read
/// by column.
struct Fields<'a> {
    /// The comma-separated fields, trimmed.
    fields: Vec<&'a str>,
    /// Line number (1-based).
    line: usize,
    /// The file, for errors.
    name: &'a str,
    /// The file's columns.
    layout: Layout,
}

impl Fields<'_> {
    /// Every numeric column, each checked finite in column order: the
    /// values by monochrome column (band and cell left 0) and the
    /// wavelength of a spectral table.
    fn values(&self) -> Result<([f64; 16], Option<f64>), BrdfTableError> {
        let layout = self.layout;
        let mut v = [0.0; 16];
        let mut wavelength = None;
        for index in 0..layout.columns() {
            if index >= layout.columns() - 2 * usize::from(layout.photon) {
                // The photon-noise columns: numbers, not the table's errors.
                self.number(index)?;
                continue;
            }
            if layout.spectral && index == C_WAVELENGTH {
                wavelength = Some(self.number(index)?);
                continue;
            }
            let col = if layout.spectral && index > C_WAVELENGTH {
                index - 1
            } else {
                index
            };
            if col != C_BAND && col != C_CELL {
                v[col] = self.number(index)?;
            }
        }
        Ok((v, wavelength))
    }

    /// The finite number in the file's column `index` (0-based).
    fn number(&self, index: usize) -> Result<f64, BrdfTableError> {
        match self.fields[index].parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.not_a(index, "finite number")),
        }
    }

    /// The non-negative integer in the file's column `index` (0-based).
    fn integer(&self, index: usize) -> Result<usize, BrdfTableError> {
        self.fields[index]
            .parse::<usize>()
            .map_err(|_| self.not_a(index, "non-negative integer"))
    }

    /// The file's column `index` (0-based) is not `what`.
    fn not_a(&self, index: usize, what: &'static str) -> BrdfTableError {
        BrdfTableError::Number {
            file: self.name.to_owned(),
            line: self.line,
            column: index + 1,
            name: self.layout.name(index),
            text: shorten(self.fields[index], 40),
            what,
        }
    }

    /// Monochrome column `col`'s `value` breaks `requirement`.
    fn out_of_range(&self, col: usize, value: f64, requirement: &'static str) -> BrdfTableError {
        let (column, name_of) = self.layout.column(col);
        BrdfTableError::OutOfRange {
            file: self.name.to_owned(),
            line: self.line,
            column,
            name: name_of,
            value,
            requirement,
        }
    }
}

/// The derived columns of `row` must follow from the others: `brdf =
/// fraction / proj` and `brdf_stderr = fraction_stderr / proj` (`proj` the
/// cell's exact projected solid angle, sr) to [`DERIVED_TOL`]. This also
/// catches a last row cut short inside its last number.
fn check_derived(row: &Row, proj: f64, name: &str, layout: Layout) -> Result<(), BrdfTableError> {
    for (col, found, from, formula) in [
        (
            C_BRDF,
            row.brdf,
            row.fraction,
            "fraction / projected_solid_angle_sr",
        ),
        (
            C_BRDF_SE,
            row.brdf_se,
            row.fraction_se,
            "fraction_stderr / projected_solid_angle_sr",
        ),
    ] {
        let expected = from / proj;
        let off = (found - expected).abs();
        if off.is_nan() || off > DERIVED_TOL * expected.max(found) + 1e-300 {
            let (column, name_of) = layout.column(col);
            return Err(BrdfTableError::Derived {
                file: name.to_owned(),
                line: row.line,
                column,
                name: name_of,
                found,
                expected,
                formula,
            });
        }
    }
    Ok(())
}

/// `row` must be the next cell of `block` in grid order.
fn check_order(block: &Block, row: &Row, name: &str, layout: Layout) -> Result<(), BrdfTableError> {
    let (band, cell) = match block.rows.last() {
        None => (1, 0),
        Some(p) if p.cell + 1 >= 4 * p.band => (p.band + 1, 0),
        Some(p) => (p.band, p.cell + 1),
    };
    let err = |col: usize, found: usize, expected: usize| {
        let (column, name_of) = layout.column(col);
        BrdfTableError::Order {
            file: name.to_owned(),
            line: row.line,
            column,
            name: name_of,
            found,
            expected,
        }
    };
    if row.band != band {
        return Err(err(C_BAND, row.band, band));
    }
    if row.cell != cell {
        return Err(err(C_CELL, row.cell, cell));
    }
    Ok(())
}

/// A block in grid order is complete when its last band is; all blocks must
/// have the first block's bands. Returns `(bands, rows)`.
fn check_complete(
    block: &Block,
    first: Option<(usize, usize)>,
    name: &str,
) -> Result<(usize, usize), BrdfTableError> {
    let rows = block.rows.len();
    let last = block
        .rows
        .last()
        .map_or((1, 0, block.start), |r| (r.band, r.cell, r.line));
    let (band, cell, line) = last;
    if cell + 1 != 4 * band {
        let bands = first.map_or(band, |(m, _)| m);
        return Err(BrdfTableError::Incomplete {
            file: name.to_owned(),
            line,
            start: block.start,
            theta_i_deg: block.theta_i,
            rows,
            bands,
            expected: 2 * bands * (bands + 1),
        });
    }
    match first {
        Some((m, first_rows)) if m != band => Err(BrdfTableError::Bands {
            file: name.to_owned(),
            line,
            start: block.start,
            theta_i_deg: block.theta_i,
            bands: band,
            rows,
            first_bands: m,
            first_rows,
        }),
        _ => Ok((band, rows)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;
    use std::f64::consts::PI;

    /// One block of a test table: angle, light azimuth (degrees), fraction
    /// per flat cell.
    struct TestBlock {
        theta: f64,
        phi_i: f64,
        fractions: Vec<f64>,
    }

    /// `brdf.csv` text for `blocks` on a grid of `m` bands, written by the
    /// file's writer.
    fn csv(m: usize, blocks: &[TestBlock]) -> String {
        format!("{HEADER}\n{}", rows(m, blocks))
    }

    /// The data rows of [`csv`], without the header.
    fn rows(m: usize, blocks: &[TestBlock]) -> String {
        blocks
            .iter()
            .map(|b| super::super::rows(m, b.theta, b.phi_i, &b.fractions, 0.01))
            .collect()
    }

    fn lambertian(m: usize, albedo: f64) -> Vec<f64> {
        let g = CarlsonGrid::new(m).unwrap();
        (0..g.n_cells())
            .map(|flat| {
                let (band, cell) = g.band_cell(flat);
                albedo * g.projected_solid_angle(band, cell) / PI
            })
            .collect()
    }

    fn uniforms(rng: &mut Pcg64Mcg) -> [f64; 4] {
        [rng.random(), rng.random(), rng.random(), rng.random()]
    }

    fn err(text: &str) -> String {
        BrdfTable::parse(text, "bad.csv").unwrap_err().to_string()
    }

    /// Replace field `col` (0-based) of physical line `line` (1-based).
    fn edit(text: &str, line: usize, col: usize, value: &str) -> String {
        text.lines()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 == line {
                    let mut f: Vec<&str> = l.split(',').collect();
                    f[col] = value;
                    f.join(",")
                } else {
                    l.to_owned()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn parse_errors_name_file_line_and_column() {
        let m = 2; // 12 rows per block
        let blocks: Vec<TestBlock> = [0.0, 40.0]
            .iter()
            .map(|&theta| TestBlock {
                theta,
                phi_i: 0.0,
                fractions: lambertian(m, 0.7),
            })
            .collect();
        let good = csv(m, &blocks);
        assert!(BrdfTable::parse(&good, "good.csv").is_ok());
        let check = |e: String, needles: &[&str]| {
            assert!(!e.contains('\n'), "{e}");
            assert!(e.starts_with("bad.csv: "), "{e}");
            for n in needles {
                assert!(e.contains(n), "`{n}` not in: {e}");
            }
        };

        // Header.
        check(
            err(&good.replacen("fraction,", "fractions,", 1)),
            &["line 1", "header"],
        );
        check(err(""), &["line 1", "header"]);
        check(err(&format!("{HEADER}\n\n")), &["line 2", "no data"]);
        // Incomplete blocks: the last row of block 1 removed (line 13), or
        // the last row of the file.
        let lines: Vec<&str> = good.lines().collect();
        let mut cut = lines.clone();
        cut.remove(12);
        check(
            err(&cut.join("\n")),
            &["line 12", "incomplete", "11 rows", "has 12"],
        );
        check(
            err(&lines[..lines.len() - 1].join("\n")),
            &["line 24", "incomplete", "theta_i_deg = 40", "11 rows"],
        );
        // A missing row in the middle: out of grid order at line 6.
        let mut gap = lines.clone();
        gap.remove(5);
        check(
            err(&gap.join("\n")),
            &["line 6", "column 4 (cell)", "found 1, expected 0"],
        );
        // Block 2 with a whole band missing: band count differs.
        let short = format!("{}\n", lines[..17].join("\n"));
        check(err(&short), &["line 17", "1 bands", "first block has 2"]);
        // NaN, inf, text, negative fraction, negative stderr.
        check(
            err(&edit(&good, 5, 12, "NaN")),
            &["line 5", "column 13 (fraction)", "`NaN`"],
        );
        check(
            err(&edit(&good, 9, 14, "inf")),
            &["line 9", "column 15 (brdf)", "finite"],
        );
        check(
            err(&edit(&good, 3, 0, "abc")),
            &["line 3", "column 1 (theta_i_deg)"],
        );
        check(
            err(&edit(&good, 7, 12, "-1e-3")),
            &["line 7", "column 13 (fraction)", ">= 0"],
        );
        check(
            err(&edit(&good, 8, 13, "-1")),
            &["line 8", "column 14 (fraction_stderr)"],
        );
        check(
            err(&edit(&good, 4, 2, "-1")),
            &["line 4", "column 3 (band)", "integer"],
        );
        // Angles and columns.
        let all_90 = good.replace("\n40,", "\n90,");
        check(err(&all_90), &["line 14", "column 1", "[0, 90)"]);
        check(err(&edit(&good, 6, 15, "1,2")), &["line 6", "found 17"]);
        // Geometry that is not the grid.
        check(
            err(&edit(&good, 10, 6, "12.5")),
            &["line 10", "column 7 (phi_lo_deg)", "Carlson"],
        );
        check(
            err(&edit(&good, 2, 11, "0.3")),
            &["line 2", "column 12 (projected_solid_angle_sr)"],
        );
        // Centre columns, derived columns (an edited fraction, a last
        // number cut short), a fraction above 1, a block that creates light.
        check(
            err(&edit(&good, 3, 8, "33")),
            &["line 3", "column 9 (theta_deg)", "Carlson"],
        );
        check(
            err(&edit(&good, 4, 9, "1")),
            &["line 4", "column 10 (phi_deg)", "Carlson"],
        );
        check(
            err(&edit(&good, 5, 12, "0.9")),
            &[
                "line 5",
                "column 15 (brdf)",
                "fraction / projected_solid_angle_sr",
            ],
        );
        let last = lines[lines.len() - 1];
        let cut = format!(
            "{}\n{}",
            lines[..lines.len() - 1].join("\n"),
            &last[..last.len() - 3]
        );
        check(
            err(&cut),
            &["line 25", "column 16 (brdf_stderr)", "truncated"],
        );
        check(
            err(&edit(&good, 6, 12, "1.5")),
            &["line 6", "column 13 (fraction)", "must be <= 1"],
        );
        let bright = TestBlock {
            theta: 10.0,
            phi_i: 0.0,
            fractions: vec![0.5; 12],
        };
        let creates = format!("{good}{}", rows(m, &[bright]));
        check(
            err(&creates),
            &[
                "line 26, column 13 (fraction)",
                "theta_i_deg = 10",
                "sum to a reflectance of 6",
                "more than 1",
            ],
        );
        // Same angle at a second azimuth that the other angle lacks: an
        // incomplete table of two light azimuths, named at the first line
        // of the angle lacking it.
        let again = TestBlock {
            theta: 0.0,
            phi_i: 45.0,
            fractions: lambertian(m, 0.7),
        };
        let incomplete = format!("{good}{}", rows(m, &[again]));
        check(
            err(&incomplete),
            &[
                "bad.csv: line 14, column 2 (phi_i_deg)",
                "theta_i_deg = 40",
                "lacks light azimuth 45",
            ],
        );
        // The same incidence twice.
        let same = TestBlock {
            theta: 0.0,
            phi_i: 0.0,
            fractions: lambertian(m, 0.7),
        };
        let twice = format!("{good}{}", rows(m, &[same]));
        check(err(&twice), &["line 26", "already tabulated from line 2"]);
        // File not found.
        let e = BrdfTable::load(Path::new("/nonexistent/brdf.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/nonexistent/brdf.csv: cannot read"), "{e}");
        // Accepted variations: CRLF, BOM, unsorted blocks, trailing blanks.
        let crlf = format!("\u{feff}{}\r\n\r\n", good.trim_end().replace('\n', "\r\n"));
        assert_eq!(
            BrdfTable::parse(&crlf, "x").unwrap().thetas_deg(),
            &[0.0, 40.0]
        );
        let half = TestBlock {
            theta: 0.0,
            phi_i: 0.0,
            fractions: lambertian(m, 0.5),
        };
        let swapped = format!("{HEADER}\n{}{}", rows(m, &blocks[1..]), rows(m, &[half]));
        let t = BrdfTable::parse(&swapped, "x").unwrap();
        assert_eq!(t.thetas_deg(), &[0.0, 40.0]);
        assert!((t.reflectance(0.0) - 0.5).abs() < 1e-14);
        assert!((t.reflectance(1.0) - 0.7).abs() < 1e-14);
    }

    /// Round trip through the real writer: a short run of the default scene,
    /// `output::brdf_csv::write`, parse. The table's reflectance is the run's to
    /// 1e-9 at every tabulated angle (the exact standard errors of its
    /// `summary.json`: `output::summary`'s reader tests).
    #[test]
    fn round_trip_with_the_writer() {
        let scene = crate::scene::micro::MicroScene::default_scene();
        let mut run = scene.brdf_run();
        run.photons = 20_000;
        run.theta_deg = vec![0.0, 40.0, 80.0];
        let results = run.trace_whole(&scene.surface, &|_| {});
        let text = crate::output::brdf_csv::write(&run, &results);
        let t = BrdfTable::parse(&text, "roundtrip.csv").unwrap();
        // The table a run holds for exports is the file's, number for number.
        let held = crate::output::brdf_csv::table(&run, &results);
        let held = held.monochrome().expect("a monochrome run");
        assert_eq!(held.thetas_deg(), t.thetas_deg());
        for i in 0..3 {
            for c in 0..run.grid().n_cells() {
                assert_eq!(held.fractions(i)[c].to_bits(), t.fractions(i)[c].to_bits());
            }
            assert_eq!(held.cell_stderr(i).to_bits(), t.cell_stderr(i).to_bits());
        }
        // Through a file too.
        let path = std::env::temp_dir().join(format!("roks-brdf-table-{}.csv", std::process::id()));
        std::fs::write(&path, &text).unwrap();
        let loaded = BrdfTable::load(&path);
        let _ = std::fs::remove_file(&path);
        assert_eq!(loaded.unwrap().thetas_deg(), t.thetas_deg());
        assert_eq!(t.thetas_deg(), &[0.0, 40.0, 80.0]);
        assert_eq!(t.bands(), run.bands);
        for r in &results {
            let theta = r.theta_i_deg.to_radians();
            let (refl, _) = r.reflectance();
            assert!(
                (t.reflectance(theta) - refl).abs() < 1e-9,
                "{} vs {refl}",
                t.reflectance(theta)
            );
            // Sampling returns the reflectance as weight and a direction in a
            // cell with weight.
            let mut rng = Pcg64Mcg::seed_from_u64(1);
            for _ in 0..1000 {
                let (d, w) = t.sample(theta, uniforms(&mut rng)).unwrap();
                assert_eq!(w, t.reflectance(theta));
                assert!(t.eval(theta, d) > 0.0);
            }
        }
    }

    /// A spectral `brdf.csv` of incidences `thetas` at wavelengths `ws`
    /// (µm, in file order), written by the file's writer: a Lambertian
    /// block of albedo `0.2 + 0.1 (i + l)` (incidence `i`, wavelength `l`),
    /// standard errors 1 % of the fractions.
    fn spectral_csv(m: usize, thetas: &[f64], ws: &[f64]) -> String {
        let grid = CarlsonGrid::new(m).unwrap();
        let mut blocks = Vec::new();
        for (i, &theta) in thetas.iter().enumerate() {
            for (l, &w) in ws.iter().enumerate() {
                let f = lambertian(m, 0.2 + 0.1 * (i + l) as f64);
                let se: Vec<f64> = f.iter().map(|x| 0.01 * x).collect();
                blocks.push((theta, w, f, se));
            }
        }
        super::super::write_blocks(
            &grid,
            blocks.iter().map(|(theta, w, f, se)| super::super::Block {
                theta_i_deg: *theta,
                phi_i_deg: 0.0,
                wavelength_um: Some(*w),
                fractions: f,
                stderr: se,
            }),
        )
    }

    /// Written and read back: one table per wavelength, each the table of
    /// the monochrome file of that wavelength's blocks, number for number.
    #[test]
    fn spectral_round_trip_per_wavelength() {
        let m = 3;
        let (thetas, ws) = ([0.0, 40.0], [0.45, 0.55, 0.65]);
        let text = spectral_csv(m, &thetas, &ws);
        assert!(text.starts_with(&format!("{SPECTRAL_HEADER}\n")));
        let tables = BrdfTables::parse(&text, "s.csv").unwrap();
        let s = tables.spectral().expect("spectral");
        assert_eq!(s.wavelengths_um(), ws);
        assert_eq!(tables.wavelengths_um(), ws);
        assert_eq!(s.thetas_deg(), thetas);
        for (l, t) in s.tables().iter().enumerate() {
            let mono: Vec<TestBlock> = thetas
                .iter()
                .enumerate()
                .map(|(i, &theta)| TestBlock {
                    theta,
                    phi_i: 0.0,
                    fractions: lambertian(m, 0.2 + 0.1 * (i + l) as f64),
                })
                .collect();
            let want = BrdfTable::parse(&csv(m, &mono), "m.csv").unwrap();
            for (i, theta) in thetas.iter().enumerate() {
                assert_eq!(t.fractions(i), want.fractions(i), "wavelength {l}");
                assert_eq!(t.cell_stderr(i).to_bits(), want.cell_stderr(i).to_bits());
                let r = 0.2 + 0.1 * (i + l) as f64;
                assert!((t.reflectance(theta.to_radians()) - r).abs() < 1e-9);
            }
        }
        // A monochrome file reads as before, as BrdfTables::Monochrome.
        let mono = csv(
            m,
            &[TestBlock {
                theta: 10.0,
                phi_i: 0.0,
                fractions: lambertian(m, 0.5),
            }],
        );
        let t = BrdfTables::parse(&mono, "m.csv").unwrap();
        assert!(t.monochrome().is_some() && t.wavelengths_um().is_empty());
        // Incidences in any order (each with its wavelengths together).
        let lines: Vec<&str> = text.lines().collect();
        let per_incidence = 3 * 2 * m * (m + 1);
        let swapped = format!(
            "{}\n{}\n{}\n",
            lines[0],
            lines[1 + per_incidence..].join("\n"),
            lines[1..=per_incidence].join("\n")
        );
        let again = BrdfTables::parse(&swapped, "x").unwrap();
        assert_eq!(again.thetas_deg(), thetas);
    }

    /// The round trip through a run: a spectral run of the default scene
    /// (its reflectance 0.8 at every wavelength), `write`, parse: every
    /// wavelength is the table held for exports, and that of the
    /// monochrome run, bit for bit; its summary gives each wavelength its
    /// exact standard errors.
    #[test]
    fn spectral_round_trip_with_the_writer() {
        let scene = crate::scene::micro::MicroScene::default_scene();
        let mut run = scene.brdf_run();
        run.photons = 4096;
        run.theta_deg = vec![0.0, 50.0];
        let mono_results = run.trace_whole(&scene.surface, &|_| {});
        let mono_tables = crate::output::brdf_csv::table(&run, &mono_results);
        let mono_run = run.clone();
        run.wavelengths_um = vec![0.4, 0.5, 0.6];
        let results = run.trace_whole(&scene.surface, &|_| {});
        let text = crate::output::brdf_csv::write(&run, &results);
        let read = BrdfTables::parse(&text, "s.csv").unwrap();
        let held = crate::output::brdf_csv::table(&run, &results);
        let mono = mono_tables.monochrome().unwrap();
        for tables in [&read, &held] {
            let s = tables.spectral().unwrap();
            assert_eq!(s.wavelengths_um(), [0.4, 0.5, 0.6]);
            for t in s.tables() {
                assert_eq!(t.thetas_deg(), mono.thetas_deg());
                for i in 0..2 {
                    assert_eq!(t.fractions(i), mono.fractions(i));
                    assert_eq!(t.cell_stderr(i).to_bits(), mono.cell_stderr(i).to_bits());
                }
            }
        }
        // With its summary: per wavelength the exact standard errors.
        let stats = crate::micro::surface_stats::surface_stats(&scene.surface.height_map(8, 8));
        let description = crate::output::summary::Description::new(
            scene.content.clone(),
            "default",
            "default",
            crate::micro::Edges::Periodic,
            run.clone(),
            crate::output::summary::Surface::new(&stats, 8),
        );
        let summary = crate::output::summary::BrdfSummary::new(&description, &results, 1.0);
        let json = crate::output::summary::to_text(&summary);
        let with = read
            .clone()
            .with_summary_text(&json, "summary.json")
            .unwrap();
        for (l, t) in with.tables().iter().enumerate() {
            assert!(t.has_stated_stderr());
            for (i, r) in results.iter().skip(l).step_by(3).enumerate() {
                let (_, se) = r.reflectance();
                let got = t.reflectance_stderr(t.thetas_deg()[i].to_radians());
                assert!((got - se).abs() <= 1e-12 * se, "{got} vs {se}");
            }
        }
        // The summary of another run: wavelengths, a spectrum entry.
        let bad = |json: String, needle: &str| {
            let e = read
                .clone()
                .with_summary_text(&json, "summary.json")
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("summary.json: ") && e.contains(needle) && !e.contains('\n'),
                "{e}"
            );
        };
        let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
        v["run"]["wavelengths_um"] = serde_json::json!([0.4, 0.5, 0.65]);
        bad(v.to_string(), "wavelengths_um");
        let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
        v["incidence"][1]["spectrum"][2]["reflectance"] = serde_json::json!(0.1);
        bad(v.to_string(), "incidence[1].spectrum[2].reflectance: 0.1");
        let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
        v["incidence"][0]["spectrum"][1]["wavelength_um"] = serde_json::json!(0.55);
        bad(
            v.to_string(),
            "incidence[0].spectrum[1].wavelength_um: 0.55",
        );
        // A monochrome table with a spectral summary.
        let m = BrdfTables::parse(
            &crate::output::brdf_csv::write(&mono_run, &mono_results),
            "m.csv",
        )
        .unwrap();
        let e = m
            .with_summary_text(&json, "summary.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("summary of a spectral run"), "{e}");
    }

    #[test]
    fn spectral_errors_name_file_line_and_column() {
        let m = 1; // 4 rows per block
        let ws = [0.45, 0.55, 0.65];
        let good = spectral_csv(m, &[0.0, 30.0], &ws);
        assert!(BrdfTables::parse(&good, "good.csv").is_ok());
        let lines: Vec<&str> = good.lines().collect();
        // Lines 2-5: (0, 0.45), 6-9: (0, 0.55), 10-13: (0, 0.65),
        // 14-17: (30, 0.45), 18-21: (30, 0.55), 22-25: (30, 0.65).
        let without = |skip: std::ops::Range<usize>| -> String {
            lines
                .iter()
                .enumerate()
                .filter(|(i, _)| !skip.contains(&(i + 1)))
                .map(|(_, l)| *l)
                .collect::<Vec<_>>()
                .join("\n")
        };
        let errs = |text: &str| BrdfTables::parse(text, "bad.csv").unwrap_err().to_string();
        let check = |e: String, needles: &[&str]| {
            assert!(!e.contains('\n') && e.starts_with("bad.csv: "), "{e}");
            for n in needles {
                assert!(e.contains(n), "`{n}` not in: {e}");
            }
        };
        // A wavelength missing in the middle of the second incidence.
        check(
            errs(&without(18..22)),
            &[
                "line 18, column 3 (wavelength_um)",
                "found 0.65 um, expected 0.55 um",
                "theta_i_deg = 30",
            ],
        );
        // The last wavelength of the second incidence missing.
        check(
            errs(&without(22..26)),
            &[
                "line 18, column 3 (wavelength_um)",
                "stops after 0.55 um",
                "lacks 0.65 um",
            ],
        );
        // A wavelength missing in the first incidence: the second has more.
        check(
            errs(&without(10..14)),
            &["line 18", "more wavelengths than the first"],
        );
        // Unsorted wavelengths: blocks 0.55 and 0.65 of the first incidence
        // swapped.
        let mut swapped: Vec<&str> = lines.clone();
        swapped[5..9].copy_from_slice(&lines[9..13]);
        swapped[9..13].copy_from_slice(&lines[5..9]);
        check(
            errs(&swapped.join("\n")),
            &[
                "line 10, column 3 (wavelength_um)",
                "0.55 um after 0.65 um",
                "strictly increasing",
            ],
        );
        // The same wavelength twice in a row: one block of twice the rows.
        let twice = good.replace("\n0,0,0.55,", "\n0,0,0.45,");
        check(errs(&twice), &["line 6", "column 4 (band)"]);
        // A wavelength that is not a number, or not > 0.
        check(
            errs(&edit(&good, 7, 2, "abc")),
            &["line 7, column 3 (wavelength_um)", "`abc`"],
        );
        check(
            errs(&edit(&good, 2, 2, "-0.5")),
            &["line 2, column 3 (wavelength_um)", "must be > 0"],
        );
        // The other columns one place later: fraction is column 14.
        check(
            errs(&edit(&good, 3, 13, "-1e-3")),
            &["line 3", "column 14 (fraction)", ">= 0"],
        );
        check(
            errs(&edit(&good, 4, 3, "7")),
            &["line 4", "column 4 (band)"],
        );
        check(
            errs(&edit(&good, 5, 16, "1")),
            &["line 5", "column 17 (brdf_stderr)"],
        );
        check(
            errs(&edit(&good, 6, 15, "1,2")),
            &["line 6", "expected 17 columns, found 18"],
        );
        // An incidence twice (not consecutive).
        let again = format!("{good}{}\n", lines[1..13].join("\n"));
        check(errs(&again), &["line 26", "already tabulated from line 2"]);
        // A block that creates light names the spectral fraction column.
        let grid = CarlsonGrid::new(m).unwrap();
        let bright = super::super::write_blocks(
            &grid,
            [super::super::Block {
                theta_i_deg: 10.0,
                phi_i_deg: 0.0,
                wavelength_um: Some(0.5),
                fractions: &[0.5; 4],
                stderr: &[0.0; 4],
            }],
        );
        check(
            errs(&bright),
            &["line 2, column 14 (fraction)", "more than 1"],
        );
        // The monochrome reader refuses a spectral table; a bad header names
        // both headers where both are accepted.
        let e = BrdfTable::parse(&good, "bad.csv").unwrap_err().to_string();
        check(e, &["line 1", "a spectral table", "wavelength_um"]);
        let renamed = good.replacen("wavelength_um", "lambda_um", 1);
        check(
            errs(&renamed),
            &["line 1", "header must be exactly", "with wavelengths"],
        );
    }

    /// Rows of incidences `(theta, phi, albedo)` in the given order,
    /// written by the file's writer: a Lambertian block of that albedo
    /// times `1 + 0.5 cos(phi_cell - 2 phi_i)` (an anisotropic synthetic:
    /// each azimuth's block differs), errors 1 % of the fractions.
    fn azimuth_rows(m: usize, incidences: &[(f64, f64, f64)]) -> (String, Vec<Vec<f64>>) {
        let grid = CarlsonGrid::new(m).unwrap();
        let blocks: Vec<(f64, f64, Vec<f64>, Vec<f64>)> = incidences
            .iter()
            .map(|&(theta, phi, albedo)| {
                let f: Vec<f64> = lambertian(m, albedo)
                    .iter()
                    .enumerate()
                    .map(|(flat, v)| {
                        let (band, cell) = grid.band_cell(flat);
                        let (_, phi_c) = grid.centre(band, cell);
                        v * (1.0 + 0.5 * (phi_c - 2.0 * phi.to_radians()).cos())
                    })
                    .collect();
                let se = f.iter().map(|x| 0.01 * x).collect();
                (theta, phi, f, se)
            })
            .collect();
        let text = super::super::write_rows(
            &grid,
            blocks
                .iter()
                .map(|(theta, phi, f, se)| super::super::Block {
                    theta_i_deg: *theta,
                    phi_i_deg: *phi,
                    wavelength_um: None,
                    fractions: f,
                    stderr: se,
                }),
        );
        (text, blocks.into_iter().map(|b| b.2).collect())
    }

    /// A table of two light azimuths (0 and 90 degrees) at two angles,
    /// written in the order of `roks brdf` (angle, then azimuth) and
    /// shuffled, reads back with its incidences in that order, every
    /// fraction as written, the azimuths listed, and each azimuth's table
    /// equal to the table of that azimuth's rows alone.
    #[test]
    fn several_azimuths_round_trip() {
        let m = 4;
        let order = [
            (20.0, 0.0, 0.3),
            (20.0, 90.0, 0.4),
            (50.0, 0.0, 0.5),
            (50.0, 90.0, 0.6),
        ];
        let (rows_text, fractions) = azimuth_rows(m, &order);
        let text = format!("{HEADER}\n{rows_text}");
        let t = BrdfTable::parse(&text, "az.csv").unwrap();
        assert_eq!(t.azimuths_deg(), &[0.0, 90.0]);
        assert_eq!(t.thetas_deg(), &[20.0, 20.0, 50.0, 50.0]);
        assert_eq!(t.angles_deg(), vec![20.0, 50.0]);
        let written = |v: f64| format!("{v:.9e}").parse::<f64>().unwrap();
        for (i, &(theta, phi, _)) in order.iter().enumerate() {
            let inc = t.incidence(i);
            assert_eq!((inc.theta_deg, inc.phi_i_deg), (theta, phi));
            for (flat, &f) in fractions[i].iter().enumerate() {
                assert_eq!(t.fraction(i, flat), written(f));
            }
        }
        // Shuffled blocks read as the same table.
        let (shuffled, _) = azimuth_rows(m, &[order[3], order[0], order[2], order[1]]);
        let u = BrdfTable::parse(&format!("{HEADER}\n{shuffled}"), "az.csv").unwrap();
        for (i, o) in order.iter().enumerate() {
            assert_eq!(u.fractions(i), t.fractions(i));
            assert_eq!(u.incidence(i).phi_i_deg, o.1);
        }
        // Each azimuth alone.
        for (k, phi) in [0.0, 90.0].into_iter().enumerate() {
            let alone: Vec<_> = order.iter().copied().filter(|o| o.1 == phi).collect();
            let (rows_k, _) = azimuth_rows(m, &alone);
            let one = BrdfTable::parse(&format!("{HEADER}\n{rows_k}"), "one.csv").unwrap();
            assert_eq!(one.azimuths_deg(), &[phi]);
            let a = t.azimuth(k);
            assert_eq!(a.thetas_deg(), one.thetas_deg());
            for i in 0..2 {
                assert_eq!(a.fractions(i), one.fractions(i));
                assert_eq!(a.incidence(i).phi_i_deg, phi);
            }
            assert_eq!(a.reflectance(0.6), one.reflectance(0.6));
        }
        // The reflectance of the whole table is the azimuths' mean.
        for theta in [0.2f64, 0.6, 1.0] {
            let mean = 0.5 * (t.azimuth(0).reflectance(theta) + t.azimuth(1).reflectance(theta));
            assert!((t.reflectance(theta) - mean).abs() < 1e-15);
        }
        assert!(
            t.require_one_azimuth("x").is_err() && t.azimuth(0).require_one_azimuth("x").is_ok()
        );
        // Spectral: blocks of an incidence (angle and azimuth) at every
        // wavelength; each wavelength's table has both azimuths.
        let grid = CarlsonGrid::new(m).unwrap();
        let mut spectral = String::from(crate::output::brdf_csv::SPECTRAL_HEADER);
        spectral.push('\n');
        for (i, &(theta, phi, _)) in order.iter().enumerate() {
            for w in [0.5, 0.6] {
                let se: Vec<f64> = fractions[i].iter().map(|x| 0.01 * x).collect();
                spectral.push_str(&super::super::write_rows(
                    &grid,
                    [super::super::Block {
                        theta_i_deg: theta,
                        phi_i_deg: phi,
                        wavelength_um: Some(w),
                        fractions: &fractions[i],
                        stderr: &se,
                    }],
                ));
            }
        }
        let s = BrdfTables::parse(&spectral, "s.csv").unwrap();
        assert_eq!(s.azimuths_deg(), &[0.0, 90.0]);
        for table in s.tables() {
            assert_eq!(table.thetas_deg(), t.thetas_deg());
            for i in 0..4 {
                assert_eq!(table.fractions(i), t.fractions(i));
            }
        }
    }

    /// An angle lacking an azimuth that another has is refused, one line
    /// naming the file, the line and column 2 (phi_i_deg), whichever angle
    /// comes first.
    #[test]
    fn incomplete_azimuths_refused() {
        let m = 2; // 12 rows per block
        let (a, _) = azimuth_rows(m, &[(20.0, 0.0, 0.3), (20.0, 90.0, 0.3), (50.0, 0.0, 0.3)]);
        let e = err(&format!("{HEADER}\n{a}"));
        assert!(
            e.starts_with("bad.csv: line 26, column 2 (phi_i_deg): incidence theta_i_deg = 50")
                && e.contains("lacks light azimuth 90 deg")
                && !e.contains('\n'),
            "{e}"
        );
        let (b, _) = azimuth_rows(m, &[(20.0, 0.0, 0.3), (50.0, 0.0, 0.3), (50.0, 90.0, 0.3)]);
        let e = err(&format!("{HEADER}\n{b}"));
        assert!(
            e.starts_with("bad.csv: line 26, column 2 (phi_i_deg): incidence theta_i_deg = 50 at light azimuth 90 deg")
                && e.contains("theta_i_deg = 20 (from line 2) lacks"),
            "{e}"
        );
        // An incidence twice in a table of several azimuths names the azimuth.
        let (c, _) = azimuth_rows(m, &[(20.0, 90.0, 0.3), (20.0, 0.0, 0.3), (20.0, 90.0, 0.3)]);
        let e = err(&format!("{HEADER}\n{c}"));
        assert!(
            e.contains(
                "line 26: incidence theta_i_deg = 20, phi_i_deg = 90 already tabulated from line 2"
            ),
            "{e}"
        );
    }
}
