//! `roks export-brdf`: the BRDF table of a `roks brdf` result folder in a
//! format other programs read (Zemax, MERL, RGL, pbsdf: the registry
//! [`crate::export::exporter::BrdfFormat`]), with the reflectance of
//! the file read back beside the table's. A spectral Zemax export is a
//! set of files, one per wavelength, with `export.json` naming the set
//! ([`crate::export::folder::ExportMarker`]), written into `--out` as a
//! folder replaced whole ([`crate::outdir`]): a kill or a full disk leaves
//! the old set or the new one, never a mix. This module parses the
//! options, calls [`crate::export::folder`] and the format's
//! [`crate::export::exporter::Exporter`], and prints what they return.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Failure;
use crate::api::values::zemax_grid;
use crate::export::exporter::Export;
use crate::export::exporter::{BrdfFormat, ZemaxGrid};
use crate::export::folder::{EXPORT_MARKER, ExportMarker, FolderExport};
use crate::outdir::check::{check_out_dir, check_out_file_as, shown};
use crate::outdir::file::ResultFile;
use crate::outdir::write::{write_file, write_folder};

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
    #[arg(long, value_name = "AZIMUTH_DEG,RADIAL_DEG", value_parser = zemax_grid)]
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

/// Run `roks export-brdf`: the checks of the folder and `--out`, then the
/// export ([`FolderExport::export`]), its notes and checks printed, and
/// its files written.
///
/// # Errors
/// Bad input (the result folder, its table or summary, `--out`, MERL of
/// wavelengths that do not cover the visible), or a failed write.
pub fn execute(a: ExportBrdfArgs) -> Result<(), Failure> {
    let request = FolderExport {
        dir: &a.dir,
        format: a.format,
        grid: a.grid,
        scene: a.scene.as_deref(),
        rgb: a.rgb,
    };
    if !a.dir.is_dir() {
        return Err(Failure::Input(format!(
            "{}: not a folder (expected the result folder of `roks brdf`, with {})",
            shown(&a.dir),
            ResultFile::Brdf
        )));
    }
    // Several files (a spectral Zemax export) go into --out as a folder.
    // `--out` is checked before the table is read, so whether the table
    // is spectral comes from its header line (the export checks it again).
    let to_folder = request.writes_folder();
    if to_folder {
        check_out_dir(&a.out, "--out", &request.inputs(), a.force)?;
    } else {
        let kind = a.format.file_kind();
        check_out_file_as("--out", &a.out, &request.inputs(), kind, a.force)?;
    }
    let export = request.export(to_folder)?;
    for line in export.notices.iter().filter_map(|n| n.line(a.quiet)) {
        eprintln!("{line}");
    }
    write(&a, &request.csv(), &export, to_folder)
}

/// Write the files of `export` of the table `csv` at `a.out`: a set of
/// files into a folder replaced whole, with its [`EXPORT_MARKER`], or one
/// file.
fn write(a: &ExportBrdfArgs, csv: &Path, export: &Export, to_folder: bool) -> Result<(), Failure> {
    let format = a.format;
    if to_folder {
        let mut written = export.named_files();
        let marker = ExportMarker::new(format, csv, export).text();
        written.push((EXPORT_MARKER.to_owned(), marker.into_bytes()));
        write_folder(&a.out, &written, "export-brdf")?;
        if !a.quiet {
            eprintln!(
                "wrote {} ({format}, {} files)",
                shown(&a.out),
                export.files.len()
            );
        }
        return Ok(());
    }
    for file in &export.files {
        write_file(&a.out, &file.bytes)?;
        if !a.quiet {
            let n = file.bytes.len();
            eprintln!("wrote {} ({format}, {n} bytes)", shown(&a.out));
        }
    }
    Ok(())
}
