//! `roks merge`: the shards of one `roks brdf --shard I/N` or `roks trace
//! --shard I/N` run summed into the result folder of the whole run (the
//! kind is the first shard's `tallies.json` format).

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::brdf::print_table;
use super::common::{check_out_dir, load_scene, write_folder};
use crate::export::brdf_formats::BrdfFormat;
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
    /// No table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks merge`.
///
/// # Errors
/// Bad input (a shard's tallies.json, shards of different runs, gaps or
/// overlaps, `--out`, memory), or a failed write.
pub fn execute(a: MergeArgs) -> Result<(), Failure> {
    check_out_dir(&a.out, "--out", &a.dirs, a.force)?;
    if object_tallies::is_trace_shard(&a.dirs[0]) {
        if !a.export.is_empty() {
            return Err(Failure::Input(
                "--export: only for shards of `roks brdf` (`roks trace` writes no table)".into(),
            ));
        }
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
    crate::export::folder::check_run(&a.export, &merged.description.run)?;
    let scene = merged.description.scene.clone();
    let photons = merged.description.run.photons;
    let folder = BrdfFolder::merged(merged);
    let comment = format!(
        "scene {}, {photons} photons per angle",
        folder.description.name
    );
    let micro = rgl_scene(&a.export, &scene);
    let surfaces = micro.as_ref().map(|s| s.surfaces()).unwrap_or_default();
    let exports = crate::export::folder::export_folder(&folder, &a.export, &comment, &surfaces)?;
    for line in exports.notices.iter().filter_map(|n| n.line(a.quiet)) {
        eprintln!("{line}");
    }
    let mut files = folder.files(exports.named_files());
    crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
    // The surface's picture comes from the micro geometry, not the sums:
    // every shard of one run drew the same one (their descriptions, with
    // the scene's content and the statistics grid, are equal).
    if let Ok(png) = std::fs::read(a.dirs[0].join("surface.png")) {
        files.push(("surface.png".into(), png));
    }
    write_folder(&a.out, &files, "merge")?;
    if !a.quiet {
        print_table(&folder);
        eprintln!("merged {n_parts} shards into {}", a.out.display());
    }
    Ok(())
}

/// The micro scene whose surfaces (every realisation) give the NDF an rgl
/// export of merged shards writes: that of the scene file `scene` the
/// shards name (the embedded default for `<default scene>`), when
/// `formats` hold rgl and the file loads; `None` otherwise.
fn rgl_scene(formats: &[BrdfFormat], scene: &str) -> Option<crate::scene::micro::MicroScene> {
    if !formats.contains(&BrdfFormat::Rgl) {
        return None;
    }
    let path = (scene != "<default scene>").then(|| std::path::Path::new(scene));
    load_scene(path).ok()
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
        .folder(&merged.result, merged.seconds, None)
        .map_err(anyhow::Error::msg)?;
    write_folder(&a.out, &files, "merge")?;
    if !a.quiet {
        super::trace::print_table(&merged.description.run, &merged.result);
        eprintln!("merged {n_parts} shards into {}", a.out.display());
    }
    Ok(())
}
