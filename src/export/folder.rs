//! Exports of a result folder of `roks brdf` (or `roks merge`): the
//! checks of `--export` before a run ([`check_run`]), the files of its
//! `--export` formats ([`export_folder`]), and for `roks export-brdf` the
//! table of the folder's files in a format with its options
//! ([`FolderExport`]: [`read_table`], [`with_mueller_file`], [`rgl_scene`])
//! and the marker of a set of files ([`ExportMarker`]). Each returns values (files, checks, lines to show,
//! [`Export`]) or an [`ExportError`]; the command line prints them.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::exporter::{BrdfFormat, Export, ExportError, ExportInput, ZemaxGrid};
use crate::micro::MicroSurface;
use crate::optics::brdf_table::BrdfTables;
use crate::outdir::file::ResultFile;
use crate::output::brdf_folder::BrdfFolder;
use crate::output::summary::BrdfSummary;
use crate::scene::SceneError;
use crate::scene::micro::MicroScene;
use crate::tally::PolarTally;
use crate::transport::brdf::BrdfRun;

/// Refuse `--export` formats (of `roks brdf`, `roks merge`) that cannot
/// hold `run`: its wavelengths ([`BrdfFormat::check_wavelengths`]) and
/// light azimuths (pbsdf holds one; rgl the sets of
/// [`super::rgl::layout::Layout::of`]), and a format that needs the
/// Mueller-matrix BRDF of a run that does not tally it; before any work.
///
/// # Errors
/// Bad input naming `--export` and the format (and for the azimuths
/// `light.phi_deg` and `--phi`).
pub fn check_run(formats: &[BrdfFormat], run: &BrdfRun) -> Result<(), ExportError> {
    for f in formats {
        f.exporter().check_run(&run.wavelengths_um, &run.phi_deg)?;
    }
    let mueller = run.polarisation.tally == PolarTally::Mueller;
    if !mueller && formats.iter().any(|f| f.exporter().needs_mueller()) {
        return Err(ExportError::NoMueller);
    }
    Ok(())
}

/// The export of `folder`'s table in the `--export` formats `formats` (of
/// `roks brdf`, `roks merge`): each format once, in the order given, with
/// `comment` in their headers, read back and judged; an rgl file gets the
/// NDF of the micro surface's realisations `surfaces` (none: the uniform
/// one, with a note); a pbsdf file the folder's Mueller table.
///
/// # Errors
/// A refusal (bad input) or a writer's defect ([`ExportError::is_input`]).
pub fn export_folder(
    folder: &BrdfFolder,
    formats: &[BrdfFormat],
    comment: &str,
    surfaces: &[&MicroSurface],
) -> Result<Export, ExportError> {
    let mut all = Export::default();
    if formats.is_empty() {
        return Ok(all);
    }
    let tables = folder.table();
    let mut with_mueller = None;
    for (k, &format) in formats.iter().enumerate() {
        if formats[..k].contains(&format) {
            continue;
        }
        let exporter = format.exporter();
        let tables = if exporter.needs_mueller() {
            &*with_mueller.get_or_insert(mueller_tables(folder, &tables)?)
        } else {
            &tables
        };
        let input = ExportInput {
            option: "--export",
            surfaces,
            ..ExportInput::new(tables, comment)
        };
        let export = exporter.export(&input)?;
        all.files.extend(export.files);
        all.checks.extend(export.checks);
        all.notices.extend(export.notices);
    }
    Ok(all)
}

/// `tables` with the run's Mueller table (the text of `folder`'s
/// `mueller.csv`) attached.
fn mueller_tables(folder: &BrdfFolder, tables: &BrdfTables) -> Result<BrdfTables, ExportError> {
    if folder.run().polarisation.tally != PolarTally::Mueller {
        return Err(ExportError::NoMueller);
    }
    let (name, text) = folder.polar_table().ok_or(ExportError::NoMueller)?;
    tables
        .clone()
        .with_mueller_text(text, name)
        .map_err(|e| ExportError::MuellerTable(e.to_string()))
}

impl Export {
    /// The files as `(name, bytes)`, in order.
    #[must_use]
    pub fn named_files(&self) -> Vec<(String, Vec<u8>)> {
        self.files
            .iter()
            .map(|f| (f.file_name.clone(), f.bytes.clone()))
            .collect()
    }
}

/// The file that names a folder of per-wavelength exports (its format,
/// table and files, and the roks version, which lets a rerun replace it).
pub const EXPORT_MARKER: &str = ResultFile::Export.name();

/// The content of [`EXPORT_MARKER`] (its keys in this order).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ExportMarker {
    /// The files of the set, in order.
    pub files: Vec<String>,
    /// The format's name.
    pub format: String,
    /// The table exported, as given.
    pub from: String,
    /// The roks version that wrote it.
    pub version: String,
}

impl ExportMarker {
    /// The marker of the files `export` of `format` made from `from`.
    #[must_use]
    pub fn new(format: BrdfFormat, from: &Path, export: &Export) -> Self {
        Self {
            files: export.files.iter().map(|f| f.file_name.clone()).collect(),
            format: format.to_string(),
            from: from.display().to_string(),
            version: env!("CARGO_PKG_VERSION").to_owned(),
        }
    }

    /// The file's text: pretty JSON and a newline.
    #[must_use]
    pub fn text(&self) -> String {
        serde_json::to_string_pretty(self).expect("strings serialise") + "\n"
    }
}

/// What `roks export-brdf` asks of a result folder: the export of its
/// table in `format` with the format's options.
#[derive(Debug, Clone, Copy)]
pub struct FolderExport<'a> {
    /// The result folder of `roks brdf` (with `brdf.csv`).
    pub dir: &'a Path,
    /// The format.
    pub format: BrdfFormat,
    /// `--grid` (Zemax).
    pub grid: Option<ZemaxGrid>,
    /// `--scene`: the micro scene of the NDF (RGL).
    pub scene: Option<&'a Path>,
    /// `--rgb`: an RGB file (RGL).
    pub rgb: bool,
}

impl FolderExport<'_> {
    /// The table, `brdf.csv`.
    #[must_use]
    pub fn csv(&self) -> PathBuf {
        self.dir.join(ResultFile::Brdf.name())
    }

    /// The files of the result this export reads (`--out` must not be one).
    #[must_use]
    pub fn inputs(&self) -> Vec<PathBuf> {
        let mut inputs = vec![self.csv(), self.summary(), self.mueller()];
        inputs.extend(self.scene.map(Path::to_path_buf));
        inputs
    }

    /// The run's summary, `summary.json`.
    fn summary(&self) -> PathBuf {
        self.dir.join(ResultFile::Summary.name())
    }

    /// The run's Mueller table, `mueller.csv`.
    fn mueller(&self) -> PathBuf {
        self.dir.join(ResultFile::Mueller.name())
    }

    /// Whether the export is a set of files ([`writes_folder`]).
    #[must_use]
    pub fn writes_folder(&self) -> bool {
        writes_folder(self.format, &self.csv())
    }

    /// The export, read back and judged; `folder` is what
    /// [`writes_folder`](Self::writes_folder) said before (the table must
    /// still agree).
    ///
    /// # Errors
    /// Bad input (the table, its summary or Mueller table, an option the
    /// format does not take, a scene that does not load, a table the format
    /// cannot hold) or a writer's defect.
    pub fn export(&self, folder: bool) -> Result<Export, ExportError> {
        let (format, csv, summary) = (self.format, self.csv(), self.summary());
        let tables = read_table(&csv, &summary, format, folder)?;
        let takes = |option| format.exporter().options().contains(&option);
        if self.grid.is_some() && !takes("--grid") {
            return Err(ExportError::GridOnlyZemax(format));
        }
        if self.scene.is_some() && !takes("--scene") {
            return Err(ExportError::SceneOnlyRgl);
        }
        let tables = with_mueller_for(format, tables, &csv, &self.mueller())?;
        if self.rgb && !takes("--rgb") {
            return Err(ExportError::RgbOnlyRgl);
        }
        let colour = |s| super::merl::srgb_tables(s).is_some();
        if self.rgb && !tables.spectral().is_some_and(colour) {
            return Err(ExportError::RgbNotVisible(csv.display().to_string()));
        }
        let scene = scene_for(format, self.scene, &summary)
            .map_err(|e| ExportError::Scene(e.to_string()))?;
        let surfaces = scene.as_ref().map(|s| s.surfaces()).unwrap_or_default();
        let comment = format!("from {}", csv.display());
        let input = ExportInput {
            grid: self.grid.unwrap_or_default(),
            surfaces: &surfaces,
            rgb: self.rgb,
            ..ExportInput::new(&tables, &comment)
        };
        format.exporter().export(&input)
    }
}

/// Whether the `brdf.csv` at `csv` is a spectral run's: its first line is
/// [`crate::output::brdf_csv::SPECTRAL_HEADER`] (false when it cannot be
/// read: the loader then says why).
#[must_use]
pub fn header_is_spectral(csv: &Path) -> bool {
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

/// Whether an export of `format` of the table at `csv` is a set of files
/// (a folder): a format with a file per wavelength of a spectral table
/// (told from the header line, [`header_is_spectral`]).
#[must_use]
pub fn writes_folder(format: BrdfFormat, csv: &Path) -> bool {
    format.exporter().one_file_per_wavelength() && header_is_spectral(csv)
}

/// The table at `csv` for an export of `format`, with the standard errors
/// of `summary` (the folder's `summary.json`) when that file is there;
/// `folder` is what [`writes_folder`] said of it before.
///
/// # Errors
/// A table or summary that does not read or fit, a table that changed
/// while it was read, or one of wavelengths the format cannot hold.
pub fn read_table(
    csv: &Path,
    summary: &Path,
    format: BrdfFormat,
    folder: bool,
) -> Result<BrdfTables, ExportError> {
    let mut tables = BrdfTables::load(csv)?;
    if folder != (format.exporter().one_file_per_wavelength() && tables.spectral().is_some()) {
        return Err(ExportError::Changed(csv.display().to_string()));
    }
    // The run's summary beside the table must describe the same run (a
    // table cut at a block boundary has lost an incidence it lists).
    if summary.exists() {
        tables = tables.with_summary(summary)?;
    }
    format
        .check_wavelengths(tables.wavelengths_um())
        .map_err(|e| ExportError::FileRefused {
            format,
            file: csv.display().to_string(),
            reason: e.to_string(),
        })?;
    Ok(tables)
}

/// `tables` with the Mueller table of the `mueller.csv` at `path`.
///
/// # Errors
/// [`ExportError::NoMuellerFile`] when there is none, or one that does not
/// read or fit the tables.
pub fn with_mueller_file(tables: BrdfTables, path: &Path) -> Result<BrdfTables, ExportError> {
    if !path.is_file() {
        return Err(ExportError::NoMuellerFile(path.display().to_string()));
    }
    tables
        .with_mueller(path)
        .map_err(|e| ExportError::Mueller(e.to_string()))
}

/// `tables` (read from `csv`) ready for an export of `format`: checked
/// ([`Exporter::check_table_file`](super::exporter::Exporter::check_table_file))
/// and, for a format that needs it, with the Mueller table of the
/// `mueller.csv` at `mueller` ([`with_mueller_file`]).
///
/// # Errors
/// A table the format cannot hold, or as [`with_mueller_file`].
pub fn with_mueller_for(
    format: BrdfFormat,
    tables: BrdfTables,
    csv: &Path,
    mueller: &Path,
) -> Result<BrdfTables, ExportError> {
    let exporter = format.exporter();
    exporter.check_table_file(&tables, &csv.display().to_string())?;
    if exporter.needs_mueller() {
        return with_mueller_file(tables, mueller);
    }
    Ok(tables)
}

/// The micro scene of an export of `format` that writes the micro
/// surface's NDF ([`Exporter::uses_surfaces`](super::exporter::Exporter::uses_surfaces)):
/// [`rgl_scene`]; `None` for the other formats.
///
/// # Errors
/// As [`rgl_scene`].
pub fn scene_for(
    format: BrdfFormat,
    scene: Option<&Path>,
    summary: &Path,
) -> Result<Option<MicroScene>, SceneError> {
    if format.exporter().uses_surfaces() {
        return rgl_scene(scene, summary);
    }
    Ok(None)
}

/// The micro scene whose NDF an rgl export of a result folder writes:
/// `scene` if given, else the scene that `summary` (the folder's
/// summary.json, read through [`BrdfSummary`]) names when that file is
/// there (the embedded default for `<default scene>`); `None` when there
/// is none to be had.
///
/// # Errors
/// A scene that does not load.
pub fn rgl_scene(scene: Option<&Path>, summary: &Path) -> Result<Option<MicroScene>, SceneError> {
    if let Some(p) = scene {
        return MicroScene::load(p).map(Some);
    }
    let named = summary
        .exists()
        .then(|| BrdfSummary::read(summary).ok())
        .flatten()
        .map(|s| s.scene);
    match named.as_deref() {
        Some(crate::scene::source::DEFAULT_SCENE) => Ok(Some(MicroScene::default_scene())),
        Some(p) if Path::new(p).is_file() => MicroScene::load(Path::new(p)).map(Some),
        _ => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The marker's text is the one `serde_json::json!` made before it was
    /// a struct: its keys sorted, pretty, a newline.
    #[test]
    fn marker_text_is_that_of_the_json_object() {
        let marker = ExportMarker {
            files: vec!["brdf_0.45um.bsdf".into(), "brdf_0.55um.bsdf".into()],
            format: "zemax".into(),
            from: "run/brdf.csv".into(),
            version: env!("CARGO_PKG_VERSION").into(),
        };
        let json = serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "format": "zemax",
            "from": "run/brdf.csv",
            "files": ["brdf_0.45um.bsdf", "brdf_0.55um.bsdf"],
        });
        let want = serde_json::to_string_pretty(&json).unwrap() + "\n";
        assert_eq!(marker.text(), want);
    }
}
