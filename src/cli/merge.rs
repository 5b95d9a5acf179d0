//! `roks merge`: the shards of one `roks brdf --shard I/N` or `roks trace
//! --shard I/N` run summed into the result folder of the whole run (the
//! kind is the first shard's `tallies.json` format).

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use crate::api::merge::{self, MergeError, ShardKind};
use crate::api::{BrdfReport, TraceReport};
use crate::export::exporter::BrdfFormat;
use crate::outdir::{check::check_out_dir, write::write_folder};

/// The options of `roks merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Shard result folders (each with tallies.json), in any order.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Output folder, replaced whole (an existing one must be empty or a roks
    /// result).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace the output folder even when it holds files roks did not
    /// write (they are deleted; a folder that holds a folder, or is not a
    /// roks result, is still refused).
    #[arg(long)]
    pub force: bool,
    /// Also export the merged table, as `roks brdf --export` does for the
    /// whole run (comma-separated: zemax, merl, rgl; the same files). An
    /// rgl file takes the NDF of the micro scene the shards name, when that
    /// file is there (else the uniform NDF, with a note).
    #[arg(
        long,
        value_delimiter = ',',
        ignore_case = true,
        hide_possible_values = true,
        action = clap::ArgAction::Set
    )]
    pub export: Vec<BrdfFormat>,
    /// Also write OUT/report.html, the interactive report of the merged
    /// folder (the same file as the whole run's `--report`).
    #[arg(long)]
    pub report: bool,
    /// No table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks merge`: the library merges ([`crate::api::merge`]), this
/// adds the exports, writes the folder and prints.
///
/// # Errors
/// Bad input (a shard's tallies.json, shards of different runs, gaps or
/// overlaps, `--out`, memory), or a failed write.
pub fn execute(a: MergeArgs) -> Result<(), Failure> {
    check_out_dir(&a.out, "--out", &a.dirs, a.force)?;
    if ShardKind::of(&a.dirs[0]) == ShardKind::Trace {
        if !a.export.is_empty() {
            return Err(Failure::Input(
                "--export: only for shards of `roks brdf` (`roks trace` writes no table)".into(),
            ));
        }
        return merge_trace(&a);
    }
    let merged = merge::merge_brdf(&a.dirs)?;
    let folder = &merged.folder;
    crate::export::folder::check_run(&a.export, &folder.description.run)?;
    let micro = merged.rgl_scene(&a.export);
    let surfaces = micro.as_ref().map(|s| s.surfaces()).unwrap_or_default();
    let comment = merged.export_comment();
    let exports = crate::export::folder::export_folder(folder, &a.export, &comment, &surfaces)?;
    for line in exports.notices.iter().filter_map(|n| n.line(a.quiet)) {
        eprintln!("{line}");
    }
    let mut files = merged
        .files(exports.named_files())
        .map_err(anyhow::Error::msg)?;
    if a.report {
        crate::report::add_brdf(&a.out, &mut files)?;
    }
    write_folder(&a.out, &files, "merge")?;
    if !a.quiet {
        let random = None;
        eprint!("{}", BrdfReport { folder, random });
        eprintln!("merged {} shards into {}", merged.shards, a.out.display());
    }
    Ok(())
}

/// A merge's failure: bad input (exit status 2), or a picture that cannot
/// be made.
impl From<MergeError> for Failure {
    fn from(e: MergeError) -> Self {
        match e {
            MergeError::Input(e) => e.into(),
            MergeError::Picture(e) => anyhow::Error::msg(e).into(),
        }
    }
}

/// `roks merge` of `roks trace` shards: the folder of the single run.
fn merge_trace(a: &MergeArgs) -> Result<(), Failure> {
    let merged = merge::merge_trace(&a.dirs)?;
    let mut files = merged.files().map_err(anyhow::Error::msg)?;
    if a.report {
        crate::report::add_trace(&a.out, &mut files)?;
    }
    write_folder(&a.out, &files, "merge")?;
    if !a.quiet {
        let m = &merged.merged;
        let (run, result) = (&m.description.run, &m.results);
        eprint!("{}", TraceReport { run, result });
        eprintln!("merged {} shards into {}", merged.shards, a.out.display());
    }
    Ok(())
}
