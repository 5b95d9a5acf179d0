//! `roks merge`: the shards of one `roks brdf --shard I/N` run summed into
//! the result folder of the whole run.

use std::path::PathBuf;

use clap::Args;

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
