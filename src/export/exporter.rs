//! What every BRDF export format provides ([`Exporter`]) and what an
//! export returns as values ([`Export`]: its files, its read-back checks and
//! the lines to show, [`Notice`]), so that the command line only prints
//! them and the other consumers (the Python module, a report) read them.
//!
//! A format is one module ([`super::zemax`], [`super::merl`], [`super::rgl`],
//! [`super::pbsdf`]) that implements [`Exporter`]; the registry
//! ([`BrdfFormat::exporter`] in [`super::brdf_formats`], one line per format)
//! names it.
//!
//! # Adding a format
//!
//! 1. Its module under `src/export/`, with a unit struct implementing
//!    [`Exporter`] (its name, file name, file kind, bytes, read-back check;
//!    the provided methods cover a format without spectral files, Mueller
//!    table or micro surface).
//! 2. Its variant of [`BrdfFormat`] (with its doc line), which makes it a
//!    value of `--format` and `--export`, and its line of the registry
//!    in `src/export/brdf_formats.rs` (the compiler asks for it).
//! 3. Its page in the guide (`docs/src/exports.md`).
//!
//! `roks export-brdf`, `roks brdf --export` and `roks merge --export` then
//! take it with no change to the command line. A file of a new kind needs a
//! [`FileKind`] to be told apart when `--out` exists (`src/outdir/kind.rs`).

use std::fmt::Write as _;

use thiserror::Error;

use super::resample::{FormatError, ReflectanceCheck, standard_errors};
use super::rgl::layout::LayoutError;
use crate::micro::MicroSurface;
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::optics::colour::{VISIBLE_MAX_UM, VISIBLE_MIN_UM};
use crate::outdir::kind::FileKind;
use crate::output::brdf_csv::BrdfTableError;

/// An export format of `roks export-brdf --format` and `roks brdf
/// --export` (the names in lower case); its module is named by the
/// registry ([`BrdfFormat::exporter`], in [`super::brdf_formats`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BrdfFormat {
    /// Zemax / Radiant tabular BSDF text (`brdf.bsdf`; [`super::zemax`]).
    #[value(help = None::<&str>)]
    Zemax,
    /// MERL binary (`brdf.binary`; [`super::merl`]).
    #[value(help = None::<&str>)]
    Merl,
    /// RGL measured BRDF tensor file (`brdf_rgl.bsdf`; [`super::rgl`]),
    /// read by Mitsuba 3's `measured` and pbrt-v4's `measured` materials.
    #[value(help = None::<&str>)]
    Rgl,
    /// Polarised measured BRDF tensor file (`brdf.pbsdf`; [`super::pbsdf`]),
    /// read by Mitsuba 3's `measured_polarized`; needs the run's
    /// `mueller.csv`.
    #[value(help = None::<&str>)]
    Pbsdf,
}

/// One file of an export.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportFile {
    /// Its name beside `brdf.csv` in a result folder
    /// ([`BrdfFormat::file_name`], or [`BrdfFormat::spectral_file_names`]).
    pub file_name: String,
    /// The wavelength (µm) of a spectral table's Zemax file.
    pub wavelength_um: Option<f64>,
    /// The file's bytes.
    pub bytes: Vec<u8>,
    /// The colour MERL's linear sRGB components stored as 0.
    pub clipped: Option<Clipped>,
}

/// Linear sRGB components below 0 stored as 0 by [`Merl::from_spectral`](super::merl::Merl::from_spectral).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Clipped {
    /// Number of stored values (bins times channels) that were negative.
    pub values: usize,
    /// The most negative of them (sr⁻¹; 0 if none).
    pub most_negative: f64,
}

/// Why a table cannot be exported in a format.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ExportRefusal {
    /// pbsdf (an isotropic format) of a table of several light azimuths.
    #[error(
        "the table has {count} light azimuths (phi_i_deg); the {format} format holds phi_i = 0 only: export zemax (Asymmetrical4D) or merl (their average)"
    )]
    Azimuths {
        /// The format refused.
        format: BrdfFormat,
        /// Number of light azimuths.
        count: usize,
    },
    /// RGL of a table whose light azimuths no RGL file holds
    /// ([`super::rgl::layout::Layout::of`]).
    #[error(transparent)]
    RglAzimuths(#[from] LayoutError),
    /// MERL of a spectral table whose wavelengths do not cover the visible.
    #[error(
        "the wavelengths {first}-{last} um do not cover the visible range {VISIBLE_MIN_UM}-{VISIBLE_MAX_UM} um, which the red, green and blue channels of a MERL file (linear sRGB under D65) need; export zemax (one file per wavelength) or trace wavelengths from {VISIBLE_MIN_UM} to {VISIBLE_MAX_UM} um"
    )]
    NotVisible {
        /// First wavelength (µm).
        first: f64,
        /// Last wavelength (µm).
        last: f64,
    },
    /// A pbsdf file of another number of wavelengths than 1 or 5, or of a
    /// table without its Mueller table.
    #[error(transparent)]
    Pbsdf(#[from] PbsdfRefusal),
}

/// Why a table cannot be written as a pbsdf file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PbsdfRefusal {
    /// Neither one wavelength nor five.
    #[error(
        "wavelength_um: {0} wavelengths, but Mitsuba's measured_polarized holds exactly 5 (trace 5 wavelengths, or one for a grey file)"
    )]
    Wavelengths(usize),
    /// Five wavelengths that are not distinct whole nanometres in `u16`.
    #[error(
        "wavelength_um: {0:?} um are not 5 distinct wavelengths in whole nanometres up to 65535 (the file's u16 wvls)"
    )]
    Nanometres(Vec<f64>),
    /// No Mueller table attached.
    #[error(
        "no Mueller-matrix BRDF (mueller.csv of a run with [tally] polarisation = \"mueller\")"
    )]
    NoMueller,
    /// A table of several light azimuths: the format is isotropic.
    #[error(
        "the table has {0} light azimuths (phi_i_deg); the pbsdf format holds phi_i = 0 only: export zemax (Asymmetrical4D) or merl (their average)"
    )]
    Azimuths(usize),
}

/// A Zemax grid: the steps of the azimuth and radial angles (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZemaxGrid {
    /// Azimuth step, degrees (the grid runs 0-180, or 0-360 for a table of
    /// several light azimuths).
    pub azimuth_step_deg: f64,
    /// Radial step, degrees (the grid runs 0-180).
    pub radial_step_deg: f64,
}

/// What an export of a table needs besides the format.
#[derive(Debug, Clone, Copy)]
pub struct ExportInput<'a> {
    /// The tables (for pbsdf with their Mueller tables attached).
    pub tables: &'a BrdfTables,
    /// One line for the header of the formats that have one.
    pub comment: &'a str,
    /// The option that asked for the format (`--format`, `--export`), named
    /// in a refusal.
    pub option: &'static str,
    /// The grid of a Zemax file.
    pub grid: ZemaxGrid,
    /// The micro surface's realisations whose NDF an RGL file writes (none:
    /// the uniform NDF, with a note).
    pub surfaces: &'a [&'a MicroSurface],
    /// An RGB RGL file (`export-brdf --rgb`) of a spectral run.
    pub rgb: bool,
}

impl<'a> ExportInput<'a> {
    /// `tables` with `comment`, asked for by `--format`, on the default
    /// Zemax grid, without a micro surface, not RGB.
    #[must_use]
    pub fn new(tables: &'a BrdfTables, comment: &'a str) -> Self {
        Self {
            tables,
            comment,
            option: "--format",
            grid: ZemaxGrid::default(),
            surfaces: &[],
            rgb: false,
        }
    }
}

/// A line for the user, in the order the export made it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Notice {
    /// Shown always, after `warning: `.
    Warning(String),
    /// Shown always, after `note: `.
    Note(String),
    /// Shown unless quiet, after `note: `.
    Aside(String),
    /// A line of the reflectance comparison, shown unless quiet.
    Table(String),
}

impl Notice {
    /// The line as shown on stderr, `None` when `quiet` hides it.
    #[must_use]
    pub fn line(&self, quiet: bool) -> Option<String> {
        match self {
            Self::Warning(t) => Some(format!("warning: {t}")),
            Self::Note(t) => Some(format!("note: {t}")),
            Self::Aside(t) if !quiet => Some(format!("note: {t}")),
            Self::Table(t) if !quiet => Some(t.clone()),
            Self::Aside(_) | Self::Table(_) => None,
        }
    }
}

/// The read-back check of one file (a wavelength, a channel): `what` it is
/// (`zemax (0.55 um)`, `merl (red)`) and per incidence (and light azimuth)
/// the file's reflectance beside the table's.
#[derive(Debug, Clone, PartialEq)]
pub struct Judged {
    /// The format, with the wavelength or channel.
    pub what: String,
    /// Per incidence (then light azimuth).
    pub checks: Vec<ReflectanceCheck>,
}

/// An export: its files, their read-back checks and the lines to show.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Export {
    /// The files, in order.
    pub files: Vec<ExportFile>,
    /// The checks of the files read back.
    pub checks: Vec<Judged>,
    /// Notes, the comparison tables and warnings, in order.
    pub notices: Vec<Notice>,
}

/// Why an export failed. [`is_input`](Self::is_input) tells bad input
/// (exit status 2) from a defect of a writer (exit status 1).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ExportError {
    /// A table the format cannot hold.
    #[error("{option} {format}: {refusal}")]
    Refused {
        /// The option that asked for it.
        option: &'static str,
        /// The format.
        format: BrdfFormat,
        /// Why.
        refusal: ExportRefusal,
    },
    /// A run the format cannot hold, before it is traced (`--export`).
    #[error("--export {format}: {refusal}")]
    Run {
        /// The format.
        format: BrdfFormat,
        /// Why.
        refusal: ExportRefusal,
    },
    /// A run whose light azimuths no RGL file holds (`--export rgl`).
    #[error("--export rgl: light.phi_deg (--phi): {0}")]
    RunAzimuths(LayoutError),
    /// A table whose light azimuths no RGL file holds.
    #[error(
        "{file}: column 2 (phi_i_deg, the run's light.phi_deg or --phi): {option} rgl: {reason}"
    )]
    RglAzimuths {
        /// The table's file.
        file: String,
        /// The option that asked for it.
        option: &'static str,
        /// Why.
        reason: LayoutError,
    },
    /// A pbsdf file that cannot be made of the tables.
    #[error("pbsdf: {0}")]
    Pbsdf(PbsdfRefusal),
    /// `--export pbsdf` of a run without the Mueller-matrix BRDF.
    #[error(
        "--export pbsdf: needs the Mueller-matrix BRDF: --polarisation mueller ([tally] polarisation = \"mueller\")"
    )]
    NoMueller,
    /// `export-brdf --format pbsdf` of a folder without `mueller.csv`.
    #[error(
        "{0}: not found: --format pbsdf needs the Mueller-matrix BRDF of a run with [tally] polarisation = \"mueller\" (roks brdf --polarisation mueller)"
    )]
    NoMuellerFile(String),
    /// `export-brdf` of a table (its file `file`) the format cannot hold.
    #[error("--format {format}: {file}: {reason}")]
    FileRefused {
        /// The format.
        format: BrdfFormat,
        /// The table's file, as given.
        file: String,
        /// Why.
        reason: String,
    },
    /// A `mueller.csv` that does not read or fit its BRDF table.
    #[error("{0}")]
    Mueller(String),
    /// A run's Mueller table that does not fit its BRDF table (a defect).
    #[error("{0}")]
    MuellerTable(String),
    /// A writer that could not lay out the file (a defect).
    #[error("export {format}: {error}")]
    Defect {
        /// The format.
        format: BrdfFormat,
        /// Why.
        error: LayoutError,
    },
    /// A file that does not read back (a defect of the writer).
    #[error("export {format} does not read back: {error}")]
    Unreadable {
        /// The format.
        format: BrdfFormat,
        /// The reader's error.
        error: FormatError,
    },
    /// A table (or the summary beside it) that does not read.
    #[error(transparent)]
    Table(#[from] BrdfTableError),
    /// `--grid` of a format without a grid to choose.
    #[error("--grid: only for --format zemax (the {0} grid is fixed by its format)")]
    GridOnlyZemax(BrdfFormat),
    /// `--scene` of a format that does not write the surface's NDF.
    #[error("--scene: only for --format rgl (the NDF of its micro surface)")]
    SceneOnlyRgl,
    /// `--rgb` of a format without an RGB file.
    #[error("--rgb: only for --format rgl (an RGB measured file)")]
    RgbOnlyRgl,
    /// `--rgb` of the table at the path given, not spectral over the visible.
    #[error(
        "--rgb: {0}: needs a spectral run whose wavelengths cover 0.38-0.78 um (the colour of colour.csv)"
    )]
    RgbNotVisible(String),
    /// A micro scene that does not load (its message).
    #[error("{0}")]
    Scene(String),
    /// A table whose file changed while it was read (`path`).
    #[error("{0}: changed while it was read (its header and its rows disagree on wavelength_um)")]
    Changed(String),
}

impl ExportError {
    /// Whether the error is bad input (exit status 2), not a defect.
    #[must_use]
    pub fn is_input(&self) -> bool {
        !matches!(
            self,
            Self::MuellerTable(_) | Self::Defect { .. } | Self::Unreadable { .. }
        )
    }
}

/// What every export format provides. A format is one module implementing
/// it and one line of the registry ([`BrdfFormat`]).
pub trait Exporter: Sync {
    /// The name on the command line (`--format`, `--export`).
    fn name(&self) -> &'static str;

    /// The file name `roks brdf --export` writes beside `brdf.csv`.
    fn file_name(&self) -> &'static str;

    /// The kind of file, to tell an existing one ([`crate::outdir::kind`]).
    fn file_kind(&self) -> FileKind;

    /// The file names beside a spectral `brdf.csv` of `wavelengths_um`, one
    /// per wavelength ([`BrdfFormat::spectral_file_names`]); one file for
    /// all unless the format says otherwise.
    fn spectral_file_names(&self, wavelengths_um: &[f64]) -> Vec<String> {
        vec![self.file_name().to_owned(); wavelengths_um.len()]
    }

    /// Whether tables of `wavelengths_um` (empty: monochrome) can be
    /// exported ([`BrdfFormat::check_wavelengths`]).
    ///
    /// # Errors
    /// The refusal.
    fn check_wavelengths(&self, _wavelengths_um: &[f64]) -> Result<(), ExportRefusal> {
        Ok(())
    }

    /// Whether a run of `wavelengths_um` and light azimuths `azimuths_deg`
    /// can be exported (`--export`, before it is traced).
    ///
    /// # Errors
    /// [`ExportError::Run`] or [`ExportError::RunAzimuths`].
    fn check_run(&self, wavelengths_um: &[f64], _azimuths_deg: &[f64]) -> Result<(), ExportError> {
        self.check_wavelengths(wavelengths_um)
            .map_err(|refusal| ExportError::Run {
                format: self.format(),
                refusal,
            })
    }

    /// The registry's entry of this format.
    fn format(&self) -> BrdfFormat;

    /// Whether a spectral table gives a file per wavelength (written into
    /// `export-brdf --out` as a folder).
    fn one_file_per_wavelength(&self) -> bool {
        false
    }

    /// Whether the format needs the run's Mueller-matrix BRDF
    /// (`mueller.csv`, [`BrdfTables::with_mueller`]).
    fn needs_mueller(&self) -> bool {
        false
    }

    /// The options of `roks export-brdf` that only some formats take
    /// (`--grid`, `--scene`, `--rgb`) and this one does.
    fn options(&self) -> &'static [&'static str] {
        &[]
    }

    /// Whether the file holds the micro surface's NDF
    /// ([`ExportInput::surfaces`]), so that `export-brdf` loads its scene.
    fn uses_surfaces(&self) -> bool {
        false
    }

    /// Checks of an `export-brdf` table before its Mueller table is read
    /// (`csv` names it): a table the format cannot hold at all.
    ///
    /// # Errors
    /// [`ExportError::FileRefused`] naming `csv`.
    fn check_table_file(&self, _tables: &BrdfTables, _csv: &str) -> Result<(), ExportError> {
        Ok(())
    }

    /// The file of one monochrome `table` with `comment` on `grid` (Zemax).
    ///
    /// # Errors
    /// A table the format cannot hold.
    fn table_bytes(
        &self,
        table: &BrdfTable,
        comment: &str,
        grid: ZemaxGrid,
    ) -> Result<Vec<u8>, ExportError>;

    /// The files of `input` with the notes made while writing them, not yet
    /// read back.
    ///
    /// # Errors
    /// A refusal (bad input) or a writer's defect.
    fn build(&self, input: &ExportInput<'_>) -> Result<Export, ExportError>;

    /// Read the files of `export` back and add their checks, the comparison
    /// tables and a warning per check off its table.
    ///
    /// # Errors
    /// A file that does not read back.
    fn judge(&self, input: &ExportInput<'_>, export: &mut Export) -> Result<(), ExportError>;

    /// Per incidence (and light azimuth), the reflectance of `bytes` (a file
    /// of `table` in this format) beside the table's.
    ///
    /// # Errors
    /// If the reader rejects `bytes`.
    fn check_table(
        &self,
        table: &BrdfTable,
        bytes: &[u8],
    ) -> Result<Vec<ReflectanceCheck>, FormatError>;

    /// [`build`](Self::build), then [`judge`](Self::judge).
    ///
    /// # Errors
    /// As both.
    fn export(&self, input: &ExportInput<'_>) -> Result<Export, ExportError> {
        let mut export = self.build(input)?;
        self.judge(input, &mut export)?;
        Ok(export)
    }
}

/// What would do better, per failing check: given the checks and the
/// indices of the failing ones, one text each.
pub type Remedy<'a> = dyn Fn(&[ReflectanceCheck], &[usize]) -> Vec<String> + 'a;

/// The heading of a comparison table.
pub const HEADING: &str =
    "reflectance of the file (read back, integrated over the hemisphere) vs the table";

/// One file of `format` holding all of `tables`, named by its format.
#[must_use]
pub fn one_file(format: BrdfFormat, bytes: Vec<u8>) -> ExportFile {
    ExportFile {
        file_name: format.file_name().to_owned(),
        wavelength_um: None,
        bytes,
        clipped: None,
    }
}

impl Export {
    /// An export of `files`, nothing judged yet.
    #[must_use]
    pub fn of(files: Vec<ExportFile>) -> Self {
        Self {
            files,
            ..Self::default()
        }
    }

    /// Add the check of `what` with its heading line `heading`, its table
    /// and a warning per check off the table, `remedy` giving per failing
    /// check (indices into `checks`) what would do better.
    pub fn add_check(
        &mut self,
        what: String,
        heading: Option<String>,
        checks: Vec<ReflectanceCheck>,
        remedy: &Remedy<'_>,
    ) {
        self.notices.extend(heading.map(Notice::Table));
        self.notices.extend(table_lines(&checks));
        self.notices.extend(off_warnings(&what, &checks, remedy));
        self.checks.push(Judged { what, checks });
    }

    /// [`add_check`](Self::add_check) with the usual heading,
    /// `{what}: reflectance of the file ... vs the table`.
    pub fn add_judged(&mut self, what: String, checks: Vec<ReflectanceCheck>, remedy: &Remedy<'_>) {
        let heading = format!("{what}: {HEADING}");
        self.add_check(what, Some(heading), checks, remedy);
    }
}

/// A remedy that is the same for every failing check (a fixed grid).
pub fn fixed(remedy: String) -> Box<Remedy<'static>> {
    Box::new(move |_, failing| vec![remedy.clone(); failing.len()])
}

/// A warning for every check of `what` (a format, a wavelength, a channel)
/// whose file is off its table ([`ReflectanceCheck::passes`]): the
/// difference in percent and in standard errors, and `remedy` (given the
/// indices of the failing checks, one text each).
#[must_use]
pub fn off_warnings(what: &str, check: &[ReflectanceCheck], remedy: &Remedy<'_>) -> Vec<Notice> {
    let failing: Vec<usize> = (0..check.len()).filter(|&i| !check[i].passes()).collect();
    if failing.is_empty() {
        return Vec::new();
    }
    let remedies = remedy(check, &failing);
    failing
        .iter()
        .zip(remedies)
        .map(|(&i, remedy)| {
            let c = &check[i];
            let sigmas = standard_errors(c.file - c.table, c.table_stderr);
            let phi = c
                .phi_i_deg
                .map_or(String::new(), |p| format!(", phi_i {p} deg"));
            Notice::Warning(format!(
                "{what}: theta_i {} deg{phi}: the file's reflectance {:.6} is {:+.2} % off the table's {:.6} ({sigmas}; allowed: max(1 %, 4 standard errors)); {remedy}",
                c.theta_i_deg,
                c.file,
                100.0 * (c.file / c.table - 1.0),
                c.table
            ))
        })
        .collect()
}

/// "at this incidence" (and azimuth, for a check per light azimuth).
#[must_use]
pub fn here(check: &ReflectanceCheck) -> &'static str {
    if check.phi_i_deg.is_some() {
        "at this incidence and azimuth"
    } else {
        "at this incidence"
    }
}

/// The table of a reflectance check, one line each (with a `phi_i` column
/// when the checks are per light azimuth).
#[must_use]
pub fn table_lines(check: &[ReflectanceCheck]) -> Vec<Notice> {
    let azimuths = check.iter().any(|c| c.phi_i_deg.is_some());
    let phi_head = if azimuths {
        format!(" {:>8}", "phi_i")
    } else {
        String::new()
    };
    let mut lines = vec![format!(
        "{:>9}{phi_head} {:>10} {:>10} {:>10}",
        "theta_i", "table", "file", "relative"
    )];
    for c in check {
        let phi = match (azimuths, c.phi_i_deg) {
            (true, Some(p)) => format!(" {p:>8.2}"),
            (true, None) => format!(" {:>8}", "-"),
            _ => String::new(),
        };
        // A table reflectance of 0 (an absorbing surface) has no relative error.
        let relative = if c.table != 0.0 {
            format!("{:+.2e}", c.file / c.table - 1.0)
        } else if c.file == 0.0 {
            "equal (0)".to_string()
        } else {
            "undefined (table 0)".to_string()
        };
        let mut line = String::new();
        let _ = write!(
            line,
            "{:>9.2}{phi} {:>10.6} {:>10.6} {relative:>10}",
            c.theta_i_deg, c.table, c.file
        );
        lines.push(line);
    }
    lines.into_iter().map(Notice::Table).collect()
}
