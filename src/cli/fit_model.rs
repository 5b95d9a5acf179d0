//! `roks fit-model`: an analytic BRDF model fitted to the table of a `roks
//! brdf` result folder ([`crate::fit_model`]), written as JSON with a plot
//! and, for ABg, the text of OpticStudio's ABg data dialog.
//!
//! Files (default `RESULT_DIR/fit_<model>.json`; `--out FILE` moves them
//! all): `FILE` (JSON), `FILE` with the extension `.png` (the plot) and, for
//! ABg, `FILE` with `_opticstudio.txt` in place of its extension. Each is
//! written atomically (a temporary file renamed over it), and only once
//! every fit is made. `--model all` fits every model, writes each one's
//! files and `RESULT_DIR/fit_summary.json`, the models ranked
//! ([`crate::fit_model::rank`]).
//!
//! The fits, their files and the lines printed are made by
//! [`crate::fit_model::one::Request::run`]; this module parses the options,
//! checks the outputs, writes the files and prints the lines. Every fit is
//! judged ([`crate::fit_model::warnings`], [`crate::fit_model::Judgement`]):
//! each warning is printed on stderr (quiet or not), then the verdict in
//! one line. A table no model can take (a mirror's, nothing reflected) is
//! refused with `cannot fit: ...`, exit status 2, nothing written.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::api::values::number;
use crate::fit_model::material::MaterialOptions;
use crate::fit_model::one::{ModelChoice, OutputKind, Request, RunError};
use crate::outdir::{check::check_out_file_as, kind::FileKind, write::write_file};

/// The options of `roks fit-model`.
#[derive(Args, Debug)]
pub struct FitModelArgs {
    /// Result folder of `roks brdf` (with brdf.csv and summary.json).
    pub dir: PathBuf,
    /// The model: abg, harvey (per incidence), ggx or beckmann (one
    /// roughness for all incidences, with Smith shadowing and the material's
    /// Fresnel factor), or all (every model, ranked; fit_summary.json).
    #[arg(long, ignore_case = true, hide_possible_values = true)]
    pub model: ModelChoice,
    /// Output JSON (default RESULT_DIR/fit_<model>.json); the plot is
    /// written beside it with the extension .png, OpticStudio's ABg rows
    /// with _opticstudio.txt.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace an existing output (JSON, plot, text) even when it is not that kind of fit-model output that roks
    /// wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
    /// ggx, beckmann: the material's refractive index n (with --k; default:
    /// the material of the scene named in summary.json).
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub n: Option<f64>,
    /// ggx, beckmann: the material's extinction coefficient k (with --n;
    /// default 0).
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub k: Option<f64>,
    /// ggx, beckmann: a constant reflectance instead of Fresnel.
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub reflectance: Option<f64>,
    /// A spectral table: the wavelength (µm) to fit, one of the table's.
    #[arg(long, value_parser = number, allow_negative_numbers = true)]
    pub wavelength: Option<f64>,
    /// No summary on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        match e {
            RunError::Input(m) => Self::Input(m),
            RunError::Other(e) => Self::Other(e),
        }
    }
}

/// Run `roks fit-model` ([`Request::run`]).
///
/// # Errors
/// Bad input (the result folder, its table or summary, options), a table
/// no model can be fitted to (`cannot fit: ...`, exit status 2), or a
/// failed write.
pub fn execute(a: FitModelArgs) -> Result<(), Failure> {
    let request = Request {
        dir: a.dir,
        texts: None,
        model: a.model,
        out: a.out,
        material: MaterialOptions {
            n: a.n,
            k: a.k,
            reflectance: a.reflectance,
        },
        wavelength: a.wavelength,
    };
    let inputs = request.inputs();
    for (p, kind) in request.outputs()? {
        let kind = match kind {
            OutputKind::Json => FileKind::FitJson,
            OutputKind::Png => FileKind::Png,
            OutputKind::Text => FileKind::FitText,
        };
        check_out_file_as("--out", &p, &inputs, kind, a.force)?;
    }
    let report = request.run()?;
    // All or none, for an interrupt.
    let commit = crate::interrupt::commit();
    for (path, bytes) in &report.files {
        write_file(path, bytes)?;
    }
    drop(commit);
    for line in report.lines(a.quiet) {
        eprintln!("{line}");
    }
    Ok(())
}
