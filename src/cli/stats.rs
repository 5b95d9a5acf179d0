//! `roks stats`: the surface statistics of a micro scene, as text or JSON
//! on standard output.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::common::print_stdout;
use crate::api::values::integer;
use crate::api::{Overrides, STATS_RESOLUTION, StatsReport, load_micro, stats_grid};
use crate::micro::surface_stats::surface_stats;
use crate::outdir::{check::check_out_file_as, kind::FileKind, write::write_file};
use crate::output::summary::Surface;

/// The options of `roks stats`.
#[derive(Args, Debug)]
pub struct StatsArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    pub scene: Option<PathBuf>,
    /// Height-map samples per side of the cell (default 512, as `roks brdf`
    /// writes in summary.json; a height
    /// field: its own grid, whose vertex heights are used exactly).
    #[arg(long, value_parser = integer::<usize>)]
    pub resolution: Option<usize>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Also draw the height map with its statistics into this PNG file.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Replace an existing --png file even when it is not a PNG that roks
    /// wrote (see docs/src/output-safety.md).
    #[arg(long)]
    pub force: bool,
}

/// Run `roks stats`. With `[surface] realisations = R > 1` the statistics
/// are those of realisation 0 (the scene's own surface) only: the text
/// says so in one line, the JSON does not.
///
/// # Errors
/// Bad input (scene, `--resolution`), or a failed write to stdout.
pub fn execute(a: StatsArgs) -> Result<(), Failure> {
    let scene = load_micro(a.scene.as_deref(), &Overrides::default())?;
    if let Some(path) = &a.png {
        check_out_file_as("--png", path, &scene.reads, FileKind::Png, a.force)?;
    }
    let grid = stats_grid(&scene, a.resolution, STATS_RESOLUTION, "--resolution")?;
    let map = scene.surface.height_map(grid.0, grid.1);
    let stats = surface_stats(&map);
    if let Some(path) = &a.png {
        write_file(path, &crate::plot::surface_png(&scene, &map, &stats)?)?;
    }
    drop(map);
    if a.json {
        let v = Surface::new(&stats, grid.0);
        let json = serde_json::to_string_pretty(&v).map_err(anyhow::Error::from)?;
        return print_stdout(&format!("{json}\n"));
    }
    let report = StatsReport {
        scene: &scene,
        stats: &stats,
        grid,
    };
    print_stdout(&report.to_string())
}
