//! `roks export-brdf`: the BRDF table of a `roks brdf` result folder in a
//! format other programs read (Zemax tabular BSDF, MERL binary), with the
//! reflectance of the file read back beside the table's.
//!
//! A spectral folder (`brdf.csv` with `wavelength_um`) gives a Zemax file
//! per wavelength, written into `--out` as a folder (`--out gold`:
//! `gold/brdf_0.45um.bsdf`, `gold/brdf_0.55um.bsdf`, ..., the names of
//! `roks brdf --export zemax`, the wavelengths written with the same
//! digits so that they sort; and `gold/export.json`, which names the set),
//! all or nothing: the folder is staged and swapped in whole
//! ([`crate::outdir`]), so a kill or a full disk leaves the old set or the
//! new one, never a mix; and one colour MERL file at `--out` (its
//! wavelengths must cover the visible). See
//! [`crate::export::brdf_formats`].

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use super::common::{FileKind, check_out_dir, check_out_file, shown, write_file, write_folder};
use crate::export::brdf_formats::{
    BrdfFormat, ExportFile, ExportRefusal, ReflectanceCheck, ZemaxGrid, colour_reflectance_check,
    reflectance_check,
};
use crate::optics::brdf_table::{BrdfTable, BrdfTables};
use crate::output::brdf_folder::BrdfFolder;

/// The options of `roks export-brdf`.
#[derive(Args, Debug)]
pub struct ExportBrdfArgs {
    /// Result folder of `roks brdf` (with brdf.csv).
    pub dir: PathBuf,
    /// Output format: zemax, merl, rgl (Mitsuba 3 `measured`, pbrt-v4) or
    /// pbsdf (Mitsuba 3 `measured_polarized`; needs the folder's
    /// mueller.csv).
    #[arg(long, ignore_case = true, hide_possible_values = true)]
    pub format: BrdfFormat,
    /// Output file (spectral zemax: a folder, replaced whole, holding one
    /// file per wavelength, OUT/brdf_<wavelength>um.bsdf, the wavelengths
    /// written with the same number of digits so the names sort, and
    /// OUT/export.json naming the set).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace OUT even when it is not an export roks wrote (a file of
    /// another kind, or a folder holding files roks did not write; a folder
    /// that holds a folder, or is not a roks result, is still refused).
    #[arg(long)]
    pub force: bool,
    /// Zemax grid AZIMUTH_STEP,RADIAL_STEP in degrees (default 2,1): finer
    /// steps follow a narrow peak more closely, in a larger file.
    #[arg(long, value_name = "AZIMUTH_DEG,RADIAL_DEG", value_parser = grid)]
    pub grid: Option<ZemaxGrid>,
    /// The micro scene the folder was traced from, for the NDF of an rgl
    /// file (default: the scene summary.json names, if it is there, or the
    /// embedded default scene).
    #[arg(long, value_name = "SCENE")]
    pub scene: Option<PathBuf>,
    /// With --format rgl, a spectral run covering 0.38-0.78 um: an RGB
    /// file (field `rgb`: the linear sRGB BRDF of colour.csv, for Mitsuba's
    /// RGB variants) instead of a spectral one.
    #[arg(long)]
    pub rgb: bool,
    /// No reflectance table on stderr (a warning still says when the
    /// file's reflectance is off the table's).
    #[arg(long, short)]
    pub quiet: bool,
}

/// Why a `--grid` value was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// A step that is not a number.
    #[error(transparent)]
    Number(#[from] super::parse::ValueError),
    /// Not two steps.
    #[error("expected AZIMUTH_DEG,RADIAL_DEG, got {0:?}")]
    Form(String),
    /// A step outside (0, 90] or not dividing 180.
    #[error("each step must be in (0, 90] degrees and divide 180, got {0}")]
    Step(f64),
}

/// The value of `--grid`: two steps in degrees, each in (0, 90] and
/// dividing 180 into whole steps (to 1e-9).
fn grid(s: &str) -> Result<ZemaxGrid, GridError> {
    let steps: Vec<f64> = s
        .split(',')
        .map(|v| super::parse::number(v.trim()))
        .collect::<Result<_, _>>()?;
    let [azimuth_step_deg, radial_step_deg] = steps[..] else {
        return Err(GridError::Form(s.to_owned()));
    };
    for step in [azimuth_step_deg, radial_step_deg] {
        let n = 180.0 / step;
        if !(step > 0.0 && step <= 90.0) || (n - n.round()).abs() > 1e-9 * n {
            return Err(GridError::Step(step));
        }
    }
    Ok(ZemaxGrid {
        azimuth_step_deg,
        radial_step_deg,
    })
}

/// Run `roks export-brdf`.
///
/// # Errors
/// Bad input (the result folder, its table or summary, `--out`, MERL of
/// wavelengths that do not cover the visible), or a failed write.
pub fn execute(a: ExportBrdfArgs) -> Result<(), Failure> {
    let format = a.format;
    let csv = a.dir.join("brdf.csv");
    // The files of the result this export reads.
    let mut inputs = vec![
        csv.clone(),
        a.dir.join("summary.json"),
        a.dir.join("mueller.csv"),
    ];
    inputs.extend(a.scene.clone());
    if !a.dir.is_dir() {
        return Err(Failure::Input(format!(
            "{}: not a folder (expected the result folder of `roks brdf`, with brdf.csv)",
            shown(&a.dir)
        )));
    }
    // Several files (a spectral Zemax export) go into --out as a folder.
    // `--out` is checked before the table is read, so whether the table
    // is spectral comes from its header line (the loader checks it again).
    let folder = format == BrdfFormat::Zemax && header_is_spectral(&csv);
    if folder {
        check_out_dir(&a.out, "--out", &inputs, a.force)?;
    } else {
        check_out_file(&a.out, &inputs, format.file_kind(), a.force)?;
    }
    let mut tables = BrdfTables::load(&csv).map_err(|e| Failure::Input(e.to_string()))?;
    if folder != (format == BrdfFormat::Zemax && tables.spectral().is_some()) {
        return Err(Failure::Input(format!(
            "{}: changed while it was read (its header and its rows disagree on wavelength_um)",
            shown(&csv)
        )));
    }
    // The run's summary beside the table must describe the same run (a
    // table cut at a block boundary has lost an incidence it lists).
    let summary = a.dir.join("summary.json");
    if summary.exists() {
        tables = tables
            .with_summary(&summary)
            .map_err(|e| Failure::Input(e.to_string()))?;
    }
    format
        .check_wavelengths(tables.wavelengths_um())
        .map_err(|e| Failure::Input(format!("--format {format}: {}: {e}", shown(&csv))))?;
    if a.grid.is_some() && format != BrdfFormat::Zemax {
        return Err(Failure::Input(format!(
            "--grid: only for --format zemax (the {format} grid is fixed by its format)"
        )));
    }
    if a.scene.is_some() && format != BrdfFormat::Rgl {
        return Err(Failure::Input(
            "--scene: only for --format rgl (the NDF of its micro surface)".into(),
        ));
    }
    let azimuths = tables.azimuths_deg().len();
    if format == BrdfFormat::Pbsdf && azimuths > 1 {
        // An isotropic format: refused as docs/src/exports.md says.
        return Err(Failure::Input(format!(
            "--format {format}: {}: {}",
            shown(&csv),
            crate::export::pbsdf::PbsdfRefusal::Azimuths(azimuths)
        )));
    }
    if format == BrdfFormat::Pbsdf {
        let mueller = a.dir.join("mueller.csv");
        if !mueller.is_file() {
            return Err(Failure::Input(format!(
                "{}: not found: --format pbsdf needs the Mueller-matrix BRDF of a run with [tally] polarisation = \"mueller\" (roks brdf --polarisation mueller)",
                shown(&mueller)
            )));
        }
        tables = tables
            .with_mueller(&mueller)
            .map_err(|e| Failure::Input(e.to_string()))?;
    }
    if a.rgb && format != BrdfFormat::Rgl {
        return Err(Failure::Input(
            "--rgb: only for --format rgl (an RGB measured file)".into(),
        ));
    }
    if a.rgb
        && tables
            .spectral()
            .is_none_or(|s| crate::export::merl::srgb_tables(s).is_none())
    {
        return Err(Failure::Input(format!(
            "--rgb: {}: needs a spectral run whose wavelengths cover 0.38-0.78 um (the colour of colour.csv)",
            shown(&csv)
        )));
    }
    let comment = format!("from {}", csv.display());
    let files = if format == BrdfFormat::Pbsdf {
        export_pbsdf(&tables, a.quiet)?
    } else if format == BrdfFormat::Rgl {
        let scene = rgl_scene(a.scene.as_deref(), &summary)?;
        let surfaces = scene.as_ref().map(|s| s.surfaces()).unwrap_or_default();
        export_rgl(&tables, &comment, a.quiet, &surfaces, a.rgb)?
    } else {
        export_tables_on(
            &tables,
            format,
            &comment,
            a.quiet,
            "--format",
            a.grid.unwrap_or_default(),
        )?
    };
    if folder {
        let marker = serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "format": format.to_string(),
            "from": csv.display().to_string(),
            "files": files.iter().map(|f| f.file_name.as_str()).collect::<Vec<_>>(),
        });
        let mut written: Vec<(String, Vec<u8>)> = files
            .iter()
            .map(|f| (f.file_name.clone(), f.bytes.clone()))
            .collect();
        let text = serde_json::to_string_pretty(&marker).map_err(anyhow::Error::from)?;
        written.push((EXPORT_MARKER.to_owned(), (text + "\n").into_bytes()));
        write_folder(&a.out, &written, "export-brdf")?;
        if !a.quiet {
            eprintln!("wrote {} ({format}, {} files)", shown(&a.out), files.len());
        }
        return Ok(());
    }
    for file in &files {
        write_file(&a.out, &file.bytes)?;
        if !a.quiet {
            eprintln!(
                "wrote {} ({format}, {} bytes)",
                shown(&a.out),
                file.bytes.len()
            );
        }
    }
    Ok(())
}

impl BrdfFormat {
    /// The kind of file an export of this format is, to tell an existing
    /// one ([`crate::outdir::kind`]).
    fn file_kind(self) -> FileKind {
        match self {
            Self::Zemax => FileKind::Zemax,
            Self::Merl => FileKind::Merl,
            Self::Rgl => FileKind::Rgl,
            Self::Pbsdf => FileKind::Pbsdf,
        }
    }
}

/// Whether the `brdf.csv` at `csv` is a spectral run's: its first line is
/// [`crate::output::brdf_csv::SPECTRAL_HEADER`] (false when it cannot be
/// read: the loader then says why).
fn header_is_spectral(csv: &Path) -> bool {
    use std::io::{BufRead, Read};
    let Ok(file) = std::fs::File::open(csv) else {
        return false;
    };
    let mut line = String::new();
    // The header is short: a longer first line is not it.
    let mut reader = std::io::BufReader::new(file).take(4096);
    if reader.read_line(&mut line).is_err() {
        return false;
    }
    // With several surface realisations, the photon-noise columns follow.
    let spectral = crate::output::brdf_csv::SPECTRAL_HEADER;
    let line = line.trim_end();
    line == spectral
        || line
            .strip_prefix(spectral)
            .and_then(|r| r.strip_prefix(','))
            == Some(crate::output::brdf_csv::PHOTON_COLUMNS)
}

/// The file that names a folder of per-wavelength exports (its format,
/// table and files, and the roks version, which lets a rerun replace it).
pub const EXPORT_MARKER: &str = "export.json";

/// The micro scene whose NDF an rgl export of a result folder writes:
/// `scene` if given, else the scene that `summary` (the folder's
/// summary.json) names when that file is there (the embedded default for
/// `<default scene>`); `None` when there is none to be had.
///
/// # Errors
/// A scene that does not load.
fn rgl_scene(
    scene: Option<&Path>,
    summary: &Path,
) -> Result<Option<crate::scene::micro::MicroScene>, Failure> {
    if let Some(p) = scene {
        return super::common::load_scene(Some(p)).map(Some);
    }
    let named = std::fs::read_to_string(summary)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v.get("scene").and_then(|s| s.as_str()).map(str::to_owned));
    match named.as_deref() {
        Some("<default scene>") => super::common::load_scene(None).map(Some),
        Some(p) if Path::new(p).is_file() => {
            super::common::load_scene(Some(Path::new(p))).map(Some)
        }
        _ => Ok(None),
    }
}

/// The RGL file of `tables` ([`crate::export::rgl`]) with the NDF of
/// `surfaces`, the micro surface's realisations pooled (none: the uniform
/// NDF, with a note), read back and judged
/// like the other exports: per wavelength (one line for a monochrome
/// table, written grey; per channel for an RGB file, `rgb`, which needs
/// spectral tables covering the visible) and incidence, the file's
/// reflectance beside the table's, and a warning line where it is off.
///
/// # Errors
/// A file that does not read back (a defect of the writer, exit status 1).
pub fn export_rgl(
    tables: &BrdfTables,
    comment: &str,
    quiet: bool,
    surfaces: &[&crate::micro::MicroSurface],
    rgb: bool,
) -> Result<Vec<ExportFile>, Failure> {
    use crate::export::rgl;
    let format = BrdfFormat::Rgl;
    let layout = rgl::layout::Layout::of(tables.azimuths_deg()).map_err(|reason| {
        Failure::Input(format!(
            "{}: column 2 (phi_i_deg, the run's light.phi_deg or --phi): --format rgl: {reason}",
            tables.tables()[0].file()
        ))
    })?;
    rgl_symmetry_note(tables, &layout);
    let ndf = match surfaces {
        [_, ..] => rgl::surface_ndf(
            surfaces,
            rgl::smoothing_for(tables.tables()[0].bands()),
            !layout.is_isotropic(),
        ),
        [] => {
            eprintln!(
                "note: rgl: no micro scene (--scene) for the NDF: the uniform NDF 1/pi is written; the file's values are the same, its importance sampling follows the table alone"
            );
            rgl::Ndf::uniform()
        }
    };
    let defect = |e: crate::export::rgl::layout::LayoutError| {
        Failure::Other(anyhow::anyhow!("export {format}: {e}"))
    };
    let rgb_file = match tables.spectral().filter(|_| rgb) {
        Some(s) => rgl::Rgl::rgb_from_spectral(s, &ndf, comment).map_err(defect)?,
        None => None,
    };
    let (bytes, checks) = match &rgb_file {
        Some((file, channels)) => {
            let bytes = file.to_bytes();
            let checks = rgl::check_channels(
                &channels.iter().collect::<Vec<_>>(),
                &bytes,
                format.file_name(),
            );
            (bytes, checks)
        }
        None => {
            let bytes = rgl::Rgl::from_tables(tables, &ndf, comment)
                .map_err(defect)?
                .to_bytes();
            let checks = rgl::check(tables, &bytes, format.file_name());
            (bytes, checks)
        }
    };
    let checks = checks
        .map_err(|e| Failure::Other(anyhow::anyhow!("export {format} does not read back: {e}")))?;
    report_checks(format, tables, &checks, quiet, rgb_file.is_some());
    Ok(vec![ExportFile {
        file_name: format.file_name().to_owned(),
        wavelength_um: None,
        bytes,
        clipped: None,
    }])
}

/// The symmetry an anisotropic RGL file of `tables` assumes
/// ([`crate::export::rgl::layout`]), judged from the table: a note naming
/// the assumption, and one warning line when the table contradicts it
/// beyond its 4-sigma bound ([`crate::export::rgl::layout::symmetry_figure`]).
fn rgl_symmetry_note(tables: &BrdfTables, layout: &crate::export::rgl::layout::Layout) {
    use crate::export::rgl::layout::{Reduction, symmetry_figure};
    let assumed = match layout.reduction {
        Reduction::Isotropic | Reduction::Circle => return,
        Reduction::HalfTurn => {
            "a half turn leaves the surface unchanged (the table at 180 deg is the one at 0 turned)"
        }
        Reduction::Quadrant => {
            "the surface is mirror symmetric about the xz and yz planes (the table at 0 deg symmetric about the plane of incidence, the one at 90 deg too)"
        }
    };
    let tables: Vec<&BrdfTable> = tables.tables().iter().collect();
    let figure = symmetry_figure(&tables, layout.reduction);
    let judged = format!(
        "chi^2/dof = {:.3} over {} cell pairs, bound {:.3}",
        figure.chi2_dof, figure.dof, figure.bound
    );
    if figure.dof > 0 && !figure.isotropic() {
        eprintln!(
            "warning: rgl: the file assumes {assumed}, but the table departs from it: {judged}; trace the whole circle (0 and 180 among light.phi_deg, azimuths beyond 180) for a file that assumes nothing"
        );
    } else {
        eprintln!("note: rgl: the file assumes {assumed}; the table agrees ({judged})");
    }
}

/// Per wavelength (one line for a monochrome table) and incidence, the
/// file's reflectance beside the table's on stderr (unless `quiet`), and a
/// warning line where it is off ([`warn_off`]).
fn report_checks(
    format: BrdfFormat,
    tables: &BrdfTables,
    checks: &[Vec<ReflectanceCheck>],
    quiet: bool,
    rgb: bool,
) {
    for (k, check) in checks.iter().enumerate() {
        let what = match (rgb, tables.wavelengths_um().get(k)) {
            (true, _) => format!("{format} ({} channel)", ["red", "green", "blue"][k]),
            (false, Some(w)) => format!("{format} ({w} um)"),
            (false, None) => format.to_string(),
        };
        if !quiet {
            eprintln!(
                "{what}: reflectance of the file (read back, integrated over the hemisphere) vs the table"
            );
            print_check(check);
        }
        warn_off(&what, check, None);
    }
}

/// The pbsdf file of `tables` ([`crate::export::pbsdf`]; each table with
/// its Mueller table attached), read back and judged like the other
/// exports: the reflectance of its `m00` per wavelength and incidence. A
/// table of one wavelength is written at the five [`pbsdf::GREY_NM`]
/// wavelengths, with a note.
///
/// # Errors
/// A refusal (not 1 or 5 wavelengths, no Mueller table: exit status 2),
/// or a file that does not read back (a defect of the writer, exit status 1).
///
/// [`pbsdf::GREY_NM`]: crate::export::pbsdf::GREY_NM
pub fn export_pbsdf(tables: &BrdfTables, quiet: bool) -> Result<Vec<ExportFile>, Failure> {
    use crate::export::pbsdf;
    let format = BrdfFormat::Pbsdf;
    let file =
        pbsdf::Pbsdf::from_tables(tables).map_err(|e| Failure::Input(format!("{format}: {e}")))?;
    if tables.wavelengths_um().len() <= 1 {
        eprintln!(
            "note: pbsdf: a table of one wavelength, written at the five wavelengths {:?} nm that Mitsuba's measured_polarized holds: the same Mueller BRDF at each",
            pbsdf::GREY_NM
        );
    }
    let bytes = file.to_bytes();
    let checks = pbsdf::check(tables, &bytes, format.file_name())
        .map_err(|e| Failure::Other(anyhow::anyhow!("export {format} does not read back: {e}")))?;
    report_checks(format, tables, &checks, quiet, false);
    Ok(vec![ExportFile {
        file_name: format.file_name().to_owned(),
        wavelength_um: None,
        bytes,
        clipped: None,
    }])
}

/// Refuse `--export` formats (of `roks brdf`, `roks merge`) that cannot
/// hold a run of wavelengths `wavelengths_um` (empty: monochrome,
/// [`BrdfFormat::check_wavelengths`]) and light azimuths `azimuths_deg`
/// (pbsdf holds one, [`ExportRefusal::Azimuths`]; rgl the sets of
/// [`crate::export::rgl::layout::Layout::of`]), before any work.
///
/// # Errors
/// Bad input naming `--export` and the format (and for the azimuths
/// `light.phi_deg` and `--phi`).
pub fn check_export_formats(
    formats: &[BrdfFormat],
    wavelengths_um: &[f64],
    azimuths_deg: &[f64],
) -> Result<(), Failure> {
    let azimuths = azimuths_deg.len();
    for &f in formats {
        let refusal = if f == BrdfFormat::Rgl && azimuths > 1 {
            crate::export::rgl::layout::Layout::of(azimuths_deg)
                .map(|_| ())
                .map_err(|reason| {
                    Failure::Input(format!("--export rgl: light.phi_deg (--phi): {reason}"))
                })?;
            f.check_wavelengths(wavelengths_um)
        } else if f == BrdfFormat::Pbsdf && azimuths > 1 {
            Err(ExportRefusal::Azimuths {
                format: f,
                count: azimuths,
            })
        } else {
            f.check_wavelengths(wavelengths_um)
        };
        refusal.map_err(|e| Failure::Input(format!("--export {f}: {e}")))?;
    }
    Ok(())
}

/// The files of the `--export` formats `formats` (of `roks brdf`, `roks
/// merge`) of the result `folder`'s table, `(file name, bytes)`: each
/// format once, in the order given, with `comment` in their headers and
/// judged as [`export_tables`] judges them; an rgl file gets the NDF of
/// the micro surface's realisations `surfaces` when there are any
/// ([`export_rgl`]).
///
/// # Errors
/// As [`export_tables`].
pub fn export_formats(
    folder: &BrdfFolder,
    formats: &[BrdfFormat],
    comment: &str,
    quiet: bool,
    surfaces: &[&crate::micro::MicroSurface],
) -> Result<Vec<(String, Vec<u8>)>, Failure> {
    if formats.is_empty() {
        return Ok(Vec::new());
    }
    let tables = folder.table();
    let mut files = Vec::new();
    for (k, &format) in formats.iter().enumerate() {
        if formats[..k].contains(&format) {
            continue;
        }
        let exported = match (format, surfaces) {
            (BrdfFormat::Rgl, [_, ..]) => export_rgl(&tables, comment, quiet, surfaces, false)?,
            (BrdfFormat::Pbsdf, _) => {
                // The run's Mueller table: the text of the folder's mueller.csv.
                let (name, text) = folder
                    .polar_table()
                    .filter(|(name, _)| *name == "mueller.csv")
                    .ok_or_else(|| {
                        Failure::Input(
                            "--export pbsdf: needs the Mueller-matrix BRDF: --polarisation mueller ([tally] polarisation = \"mueller\")".into(),
                        )
                    })?;
                let tables = tables
                    .clone()
                    .with_mueller_text(text, name)
                    .map_err(|e| Failure::Other(anyhow::anyhow!("{e}")))?;
                export_pbsdf(&tables, quiet)?
            }
            _ => export_tables(&tables, format, comment, quiet, "--export")?,
        };
        files.extend(exported.into_iter().map(|f| (f.file_name, f.bytes)));
    }
    Ok(files)
}

/// The export of `tables` in `format` ([`BrdfFormat::export_tables`]), with
/// `comment` in its header where the format has one, judged: each file is
/// read back and integrated over the hemisphere beside the table's
/// reflectance, per incidence (per wavelength for spectral Zemax files, per
/// channel for a colour MERL file, with the count of clipped negative sRGB
/// components). Unless `quiet`, the comparison is printed on stderr; a
/// warning line is printed, quiet or not, for every incidence where the
/// file is off the table by more than `max(1 %, 4 standard errors)`
/// ([`ReflectanceCheck::passes`]), for a Zemax file with the coarsest
/// finer grid that makes that incidence (and light azimuth) pass, or that
/// none does. `option` names the option that asked for the format in a
/// refusal.
///
/// # Errors
/// A refusal (MERL of wavelengths not covering the visible, exit status 2)
/// or an export that does not read back (a defect of the writer, exit
/// status 1).
pub fn export_tables(
    tables: &BrdfTables,
    format: BrdfFormat,
    comment: &str,
    quiet: bool,
    option: &str,
) -> Result<Vec<ExportFile>, Failure> {
    export_tables_on(tables, format, comment, quiet, option, ZemaxGrid::default())
}

/// [`export_tables`] with Zemax files on `grid`.
///
/// # Errors
/// As [`export_tables`].
pub fn export_tables_on(
    tables: &BrdfTables,
    format: BrdfFormat,
    comment: &str,
    quiet: bool,
    option: &str,
    grid: ZemaxGrid,
) -> Result<Vec<ExportFile>, Failure> {
    let files = format
        .export_tables_on(tables, comment, grid)
        .map_err(|e| Failure::Input(format!("{option} {format}: {e}")))?;
    let unreadable = |e| Failure::Other(anyhow::anyhow!("export {format} does not read back: {e}"));
    let heading =
        "reflectance of the file (read back, integrated over the hemisphere) vs the table";
    match (tables.spectral(), format) {
        (Some(s), BrdfFormat::Merl) if s.wavelengths_um().len() > 1 => {
            let file = &files[0];
            let check = colour_reflectance_check(s, &file.bytes).map_err(unreadable)?;
            for (c, channel) in ["red", "green", "blue"].iter().enumerate() {
                let channel_check: Vec<_> = check.iter().map(|k| k[c]).collect();
                if !quiet {
                    if c == 0 {
                        eprintln!("{format}: {heading}, linear sRGB under D65");
                    }
                    eprintln!("{channel}:");
                    print_check(&channel_check);
                }
                warn_off(&format!("{format} ({channel})"), &channel_check, None);
            }
            if let Some(clip) = file.clipped.filter(|c| c.values > 0 && !quiet) {
                eprintln!(
                    "{format}: {} values had a negative linear sRGB component (out of gamut), stored as 0; the most negative {:.3e} 1/sr",
                    clip.values, clip.most_negative
                );
            }
        }
        _ => {
            if format == BrdfFormat::Merl {
                // Several light azimuths: the file is their average.
                let mean;
                let table = match tables.spectral() {
                    Some(s) => {
                        mean = s.mean();
                        &mean
                    }
                    None => &tables.tables()[0],
                };
                match crate::export::merl::azimuth_note(table) {
                    Some((true, line)) => eprintln!("warning: {line}"),
                    Some((false, line)) if !quiet => eprintln!("note: {line}"),
                    _ => {}
                }
            }
            for (file, table) in files.iter().zip(tables.tables()) {
                let bytes = &file.bytes;
                let check = reflectance_check(table, format, bytes).map_err(unreadable)?;
                let what = match file.wavelength_um {
                    Some(w) => format!("{format} ({w} um)"),
                    None => format.to_string(),
                };
                if !quiet {
                    eprintln!("{what}: {heading}");
                    print_check(&check);
                }
                let finer = |failing: &[usize]| grid.finer_per_check(table, failing);
                warn_off(
                    &what,
                    &check,
                    (format == BrdfFormat::Zemax).then_some((grid, &finer)),
                );
            }
        }
    }
    Ok(files)
}

/// A warning line on stderr for every check of `what` (a format, a
/// wavelength, a channel) whose file is off its table
/// ([`ReflectanceCheck::passes`]): the difference in percent and in
/// standard errors, and what would do better: for Zemax (`zemax`: the grid
/// used and the search for finer ones, given the indices of the failing
/// checks) per incidence (and light azimuth) the coarsest finer grid that
/// makes that block pass, or that none does; for MERL that its grid is
/// fixed.
fn warn_off(
    what: &str,
    check: &[ReflectanceCheck],
    zemax: Option<(ZemaxGrid, &dyn Fn(&[usize]) -> Vec<Option<ZemaxGrid>>)>,
) {
    let failing: Vec<usize> = (0..check.len()).filter(|&i| !check[i].passes()).collect();
    if failing.is_empty() {
        return;
    }
    let fixed = match zemax {
        Some(_) => String::new(),
        None if what.starts_with("pbsdf") => format!(
            "the pbsdf grid is fixed ({} x {} x {} nodes of theta_h, theta_d, phi_d)",
            crate::export::pbsdf::THETA_H,
            crate::export::pbsdf::THETA_D,
            crate::export::pbsdf::PHI_D
        ),
        None if what.starts_with("rgl") => format!(
            "the rgl grids are fixed ({0} x {0} samples per incidence); export zemax for a finer one",
            crate::export::rgl::SAMPLE_RES
        ),
        None => "the MERL grid is fixed by its format; export zemax for a finer one".to_string(),
    };
    let finer = zemax.map(|(grid, search)| (grid, search(&failing)));
    for (n, &i) in failing.iter().enumerate() {
        let c = &check[i];
        let here = if c.phi_i_deg.is_some() {
            "at this incidence and azimuth"
        } else {
            "at this incidence"
        };
        let remedy = match &finer {
            Some((grid, found)) => match found[n] {
                Some(g) => format!(
                    "the finer grid `--grid {},{}` of roks export-brdf passes {here}",
                    g.azimuth_step_deg, g.radial_step_deg
                ),
                None => match grid.searched().last() {
                    Some(f) => format!(
                        "no finer grid (to {},{} degrees) passes {here}: the difference is not the grid's",
                        f.azimuth_step_deg, f.radial_step_deg
                    ),
                    None => format!(
                        "the grid {},{} is as fine as the search goes ({}): no finer grid is tried",
                        grid.azimuth_step_deg,
                        grid.radial_step_deg,
                        {
                            let f = ZemaxGrid::finest_searched();
                            format!("{},{} degrees", f.azimuth_step_deg, f.radial_step_deg)
                        }
                    ),
                },
            },
            None => fixed.clone(),
        };
        let sigmas = crate::export::resample::standard_errors(c.file - c.table, c.table_stderr);
        let phi = c
            .phi_i_deg
            .map_or(String::new(), |p| format!(", phi_i {p} deg"));
        eprintln!(
            "warning: {what}: theta_i {} deg{phi}: the file's reflectance {:.6} is {:+.2} % off the table's {:.6} ({sigmas}; allowed: max(1 %, 4 standard errors)); {remedy}",
            c.theta_i_deg,
            c.file,
            100.0 * (c.file / c.table - 1.0),
            c.table
        );
    }
}

/// The table of a reflectance check on stderr (with a `phi_i` column when
/// the checks are per light azimuth).
fn print_check(check: &[ReflectanceCheck]) {
    let azimuths = check.iter().any(|c| c.phi_i_deg.is_some());
    let phi_head = if azimuths {
        format!(" {:>8}", "phi_i")
    } else {
        String::new()
    };
    eprintln!(
        "{:>9}{phi_head} {:>10} {:>10} {:>10}",
        "theta_i", "table", "file", "relative"
    );
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
        eprintln!(
            "{:>9.2}{phi} {:>10.6} {:>10.6} {relative:>10}",
            c.theta_i_deg, c.table, c.file
        );
    }
}
