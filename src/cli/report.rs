//! `roks report`: the interactive report of a result folder of `roks
//! brdf`, `roks trace` or `roks merge`, one HTML file
//! (`DIR/report.html`, or `--out FILE`), made by [`crate::report`].

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::outdir::check::check_out_file_as;
use crate::outdir::file::ResultFile;
use crate::outdir::kind::FileKind;
use crate::outdir::write::write_file;

/// The options of `roks report`.
#[derive(Args, Debug)]
pub struct ReportArgs {
    /// The result folder (of `roks brdf`, `roks trace` or `roks merge`).
    pub dir: PathBuf,
    /// The report file (default: DIR/report.html). An existing file is
    /// replaced only when it is a report roks wrote (or with --force).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the file at --out even when roks did not write it.
    #[arg(long)]
    pub force: bool,
    /// Nothing on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks report`.
///
/// # Errors
/// Bad input (a folder that is not a result, `--out`), or a failed write.
pub fn execute(a: ReportArgs) -> Result<(), Failure> {
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| ResultFile::Report.path_in(&a.dir));
    // The folder's files are the report's inputs (an earlier report is not
    // read: it is replaced).
    let inputs: Vec<PathBuf> = std::fs::read_dir(&a.dir)
        .map(|d| {
            d.filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| n != ResultFile::Report.name())
                })
                .collect()
        })
        .unwrap_or_default();
    check_out_file_as("--out", &out, &inputs, FileKind::Report, a.force)?;
    let html = crate::report::of_dir(&a.dir)?;
    write_file(&out, html.as_bytes())?;
    if !a.quiet {
        eprintln!("wrote {} ({} bytes)", out.display(), html.len());
    }
    Ok(())
}
