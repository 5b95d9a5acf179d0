//! `roks merge`: the shards of one `roks brdf --shard I/N` or `roks trace
//! --shard I/N` run summed into the result folder of the whole run (the
//! kind is the first shard's `tallies.json` format).

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::brdf::print_table;
use super::common::{check_out_dir, write_folder};
use crate::output::brdf_folder::BrdfFolder;
use crate::output::object_tallies;
use crate::output::tallies::{self, TALLIES_FILE};

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
    /// No table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks merge`.
///
/// # Errors
/// Bad input (a shard's tallies.json, shards of different runs, gaps or
/// overlaps, `--out`, memory), or a failed write.
pub fn run(a: MergeArgs) -> Result<(), Failure> {
    check_out_dir(&a.out, "--out")?;
    super::common::check_kept("--out", &[super::common::Written::Folder(&a.out)], &a.dirs)?;
    if object_tallies::is_trace_shard(&a.dirs[0]) {
        return merge_trace(&a);
    }
    let parts = a
        .dirs
        .iter()
        .map(|d| tallies::read_shard(d))
        .collect::<Result<Vec<_>, _>>()?;
    let n_parts = parts.len();
    let merged = tallies::merge_shards(parts)?;
    let bytes = merged.description.run.memory_bytes();
    crate::limits::check("the merged tallies and tables", bytes).map_err(|e| {
        Failure::Input(format!(
            "{}: {TALLIES_FILE}: description.run.bands: {e}",
            a.dirs[0].display(),
        ))
    })?;
    let folder = BrdfFolder::merged(merged);
    let mut files = folder.files(Vec::new());
    crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
    write_folder(&a.out, &files)?;
    if !a.quiet {
        print_table(&folder.results);
        eprintln!("merged {n_parts} shards into {}", a.out.display());
    }
    Ok(())
}

/// `roks merge` of `roks trace` shards: the folder of the single run.
fn merge_trace(a: &MergeArgs) -> Result<(), Failure> {
    let parts = a
        .dirs
        .iter()
        .map(|d| object_tallies::read_shard(d))
        .collect::<Result<Vec<_>, _>>()?;
    let n_parts = parts.len();
    let merged = object_tallies::merge_shards(parts)?;
    let files = merged
        .description
        .folder(&merged.results, merged.seconds, None)
        .map_err(anyhow::Error::msg)?;
    write_folder(&a.out, &files)?;
    if !a.quiet {
        super::trace::print_table(&merged.description.run, &merged.results);
        eprintln!("merged {n_parts} shards into {}", a.out.display());
    }
    Ok(())
}
