//! `roks export-brdf`: the BRDF table of a `roks brdf` result folder in a
//! format other programs read (Zemax tabular BSDF, MERL binary), with the
//! reflectance of the file read back beside the table's.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::common::{check_out_file, write_file};
use crate::export::brdf_formats::{BrdfFormat, reflectance_check};
use crate::optics::brdf_table::BrdfTable;

/// The options of `roks export-brdf`.
#[derive(Args, Debug)]
pub struct ExportBrdfArgs {
    /// Result folder of `roks brdf` (with brdf.csv).
    pub dir: PathBuf,
    /// Output format: zemax or merl.
    #[arg(long, ignore_case = true, hide_possible_values = true)]
    pub format: BrdfFormat,
    /// Output file.
    #[arg(long)]
    pub out: PathBuf,
    /// No reflectance check on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks export-brdf`.
///
/// # Errors
/// Bad input (the result folder, its table or summary, `--out`), or a
/// failed write.
pub fn run(a: ExportBrdfArgs) -> Result<(), Failure> {
    let format = a.format;
    check_out_file(&a.out)?;
    let csv = a.dir.join("brdf.csv");
    if !a.dir.is_dir() {
        return Err(Failure::Input(format!(
            "{}: not a folder (expected the result folder of `roks brdf`, with brdf.csv)",
            a.dir.display()
        )));
    }
    let mut table = BrdfTable::load(&csv).map_err(|e| Failure::Input(e.to_string()))?;
    // The run's summary beside the table must describe the same run (a
    // table cut at a block boundary has lost an incidence it lists).
    let summary = a.dir.join("summary.json");
    if summary.exists() {
        table = table
            .with_summary(&summary)
            .map_err(|e| Failure::Input(e.to_string()))?;
    }
    let bytes = export_table(&table, format, &format!("from {}", csv.display()), a.quiet)?;
    write_file(&a.out, &bytes)?;
    if !a.quiet {
        eprintln!(
            "wrote {} ({format}, {} bytes)",
            a.out.display(),
            bytes.len()
        );
    }
    Ok(())
}

/// The export of `table` in `format`, with `comment` in its header where
/// the format has one; unless `quiet`, the reflectance check on stderr: the
/// file read back and integrated over the hemisphere beside the table's
/// reflectance, per incidence.
///
/// # Errors
/// The export does not read back (a defect of the writer, exit status 1).
pub fn export_table(
    table: &BrdfTable,
    format: BrdfFormat,
    comment: &str,
    quiet: bool,
) -> Result<Vec<u8>, Failure> {
    let bytes = format.export(table, comment);
    if !quiet {
        let check = reflectance_check(table, format, &bytes).map_err(|e| {
            Failure::Other(anyhow::anyhow!("export {format} does not read back: {e}"))
        })?;
        eprintln!(
            "{format}: reflectance of the file (read back, integrated over the hemisphere) vs the table"
        );
        eprintln!(
            "{:>9} {:>10} {:>10} {:>10}",
            "theta_i", "table", "file", "relative"
        );
        for c in &check {
            // A table reflectance of 0 (an absorbing surface) has no relative error.
            let relative = if c.table != 0.0 {
                format!("{:+.2e}", c.file / c.table - 1.0)
            } else if c.file == 0.0 {
                "equal (0)".to_string()
            } else {
                "undefined (table 0)".to_string()
            };
            eprintln!(
                "{:>9.2} {:>10.6} {:>10.6} {relative:>10}",
                c.theta_i_deg, c.table, c.file
            );
        }
    }
    Ok(bytes)
}
