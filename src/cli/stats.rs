//! `roks stats`: the surface statistics of a micro scene, as text or JSON
//! on standard output.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::common::{load_scene, print_stdout, stats_grid};
use super::parse::integer;
use crate::micro::surface_stats::surface_stats;
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
    let scene = load_scene(a.scene.as_deref())?;
    if let Some(path) = &a.png {
        super::common::check_out_file_as(
            "--png",
            path,
            &scene.reads,
            super::common::FileKind::Png,
            a.force,
        )?;
    }
    let (r, ry) = stats_grid(
        &scene,
        a.resolution,
        super::common::STATS_RESOLUTION,
        "--resolution",
    )?;
    let map = scene.surface.height_map(r, ry);
    let s = surface_stats(&map);
    if let Some(path) = &a.png {
        let png = crate::plot::surface_png(&scene, &map, &s).map_err(Failure::Other)?;
        super::common::write_file(path, &png)?;
    }
    drop(map);
    let mut out = String::new();
    if a.json {
        let v = Surface::new(&s, r);
        let _ = writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&v).map_err(anyhow::Error::from)?
        );
        return print_stdout(&out);
    }
    let size = scene.surface.size;
    let _ = writeln!(out, "scene            {}", scene.scene_file.file);
    let _ = writeln!(
        out,
        "cell             {} x {} ({:?} edges)",
        size.x, size.y, scene.surface.edges
    );
    let _ = writeln!(out, "height map       {r} x {ry}");
    let realisations = scene.run.realisations;
    if realisations > 1 {
        let _ = writeln!(
            out,
            "realisations     {realisations}: statistics of realisation 0 (the scene's own seed) only"
        );
    }
    let _ = writeln!(
        out,
        "sigma            {:.6}   RMS height about the mean",
        s.sigma
    );
    match s.tau_undefined {
        None => {
            let _ = writeln!(
                out,
                "tau              {:.6}   lag where the radial autocorrelation falls to 1/e",
                s.tau
            );
            let _ = writeln!(out, "sigma_over_tau   {:.6}", s.sigma_over_tau);
        }
        Some(why) => {
            let _ = writeln!(out, "tau              {why}");
            let _ = writeln!(out, "sigma_over_tau   undefined (tau is undefined)");
        }
    }
    let _ = writeln!(
        out,
        "rms_slope        {:.6}   sqrt(mean |grad h|^2)",
        s.rms_slope
    );
    let _ = writeln!(out, "mean_height      {:.6}", s.mean);
    let _ = writeln!(out, "max_height       {:.6}", s.max_height);
    let _ = writeln!(out, "min_height       {:.6}", s.min_height);
    let (global, per_cell) = scene.surface.acceleration_stats();
    let _ = writeln!(
        out,
        "solids           {} ({} tested per flight, {:.1} per grid cell)",
        scene.surface.solids().len(),
        global,
        per_cell
    );
    print_stdout(&out)
}
