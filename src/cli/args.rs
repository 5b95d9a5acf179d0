//! The command line's arguments: the subcommands. Each command's own
//! options live in its module; the options the tracing commands share
//! ([`super::common::TracingArgs`]) in `common`.
//!
//! The doc comments of the items deriving clap's traits are the help text
//! of `roks --help` and `roks <command> --help`.

use clap::{Parser, Subcommand};

use super::{
    brdf, export_brdf, export_heightfield, export_mesh, fit, fit_model, merge, plot, render,
    report, stats, trace,
};

/// Monte Carlo reflection of light from rough surfaces (geometric optics), after ROKS-RG.
///
/// A rough surface is modelled explicitly: a substrate with bumps bounded by
/// planes and quadrics, in which photons reflect specularly as often as the
/// geometry makes them. Scene files are TOML; see `scenes/` and docs/src/scene-reference.md.
#[derive(Parser, Debug)]
#[command(name = "roks", version, about, long_about)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands of `roks`.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate the tabulated BRDF of a micro scene (default: the embedded scene).
    ///
    /// Writes DIR/summary.json (reflectance per incidence with standard
    /// errors, losses, speed, surface statistics), DIR/brdf.csv (Carlson grid),
    /// DIR/inplane.csv (plane of incidence), its pictures (see `roks plot`:
    /// inplane.png, reflectance.png, hemisphere_<theta>deg.png, ...), the
    /// picture of the surface DIR/surface.png and, with --export, the
    /// exported tables. DIR defaults to
    /// out/<scene name>/.
    Brdf(brdf::BrdfArgs),
    /// Print the surface statistics of a micro scene: RMS height sigma,
    /// autocorrelation length tau, sigma/tau, RMS slope, heights (and with
    /// --png FILE, draw the height map with them, as surface.png of `roks
    /// brdf`). With [surface] realisations = R > 1: of realisation 0 only.
    Stats(stats::StatsArgs),
    /// Trace a 3-D object of quadric cells with rough walls (the macro level).
    ///
    /// Writes DIR/summary.json (per beam position: reflectance with standard
    /// error, missed, absorbed per surface, bounces, losses; with polarised
    /// transport the Stokes vector of the reflected light), DIR/reflectance.csv
    /// (x,y,z,reflectance,reflectance_stderr) and, with [tally] farfield = true,
    /// DIR/farfield.csv (and DIR/farfield_stokes.csv with [tally]
    /// polarisation = "stokes"), and DIR/reflectance.png (reflectance against
    /// beam position; a spectral run: against wavelength, per beam
    /// position). DIR defaults to out/<scene name>/.
    Trace(trace::TraceArgs),
    /// Fit micro-scene parameters to a measured in-plane BRDF.
    ///
    /// MEASURED is a CSV with header theta_i_deg,theta_o_deg,brdf (optionally
    /// brdf_stderr), theta_o signed (positive on the specular side), like the
    /// inplane.csv of `roks brdf`. Each --param KEY=LO:HI names a number in the
    /// scene by its TOML key path (e.g. bumps[0].height, bumps[0].radius[1],
    /// materials.paint.n) and its bounds. Nelder-Mead on the log misfit with a
    /// fixed seed (common random numbers). Writes DIR/fit.json, DIR/fitted.toml
    /// and DIR/fit_inplane.csv (default DIR: out/<scene name>-fit/).
    Fit(fit::FitArgs),
    /// Write the top surface of a micro scene as a triangulated height field
    /// over one period (binary PLY, as Mitsuba's `ply` shape reads it).
    ///
    /// Heights are sampled at (N+1) x (N+1) vertices; for periodic cells the
    /// last row and column repeat the first exactly, so tiled copies are
    /// seamless. Coordinates are float32 (Mitsuba's precision).
    ExportMesh(export_mesh::ExportMeshArgs),
    /// Write the heights of a micro scene as a height map file, for
    /// `heightfield = { file = ..., pixel = ... }` (a height-field scene: its
    /// own vertex heights; a scene of bumps: heights sampled at the vertices
    /// of an N x N grid).
    ///
    /// OUT's extension picks the format: .exr (one f32 channel Y) or .txt
    /// (text grid, shortest exact decimals). Row j of the file is y = j pixel.
    /// The scene line to load it is printed on stderr.
    ExportHeightfield(export_heightfield::ExportHeightfieldArgs),
    /// Render a radiance map of a micro or an object scene to OpenEXR (plus a PNG preview).
    ///
    /// A micro scene: an orthographic camera whose footprint is exactly one
    /// period of the substrate looks from --view. An object scene (one with
    /// [[cells]]): a pinhole camera (--camera, --look-at, --up, --fov), the
    /// disc's light sampled at table and Lambertian walls, and a background of
    /// 1e-3 unless --background. The light is a small bright disc (radiance 1,
    /// angular radius --disc) toward --light. Pixel values are radiance in
    /// units of the disc's. Writes OUT (EXR: linear radiance, scanline, ZIP,
    /// f32 RGB) and OUT with the extension .png (preview: --tonemap, --exposure).
    Render(render::RenderArgs),
    /// Merge the shards of one `roks brdf --shard I/N` run into one result.
    ///
    /// Reads DIR/tallies.json of every shard folder, checks they come from the
    /// same run (scene, seed, settings) and that their photon ranges are
    /// disjoint and cover the run, sums them in shard order and writes
    /// OUT/brdf.csv, OUT/inplane.csv, OUT/summary.json and OUT/tallies.json,
    /// exactly as the single run would (only timings differ), and their
    /// pictures (see `roks plot`).
    Merge(merge::MergeArgs),
    /// Export the BRDF table of a `roks brdf` result folder for other programs.
    ///
    /// Reads RESULT_DIR/brdf.csv and writes OUT in FORMAT: `zemax` (Zemax /
    /// Radiant tabular BSDF text, as OpticStudio's tabular BSDF scatter model
    /// reads it: BRDF in 1/sr about the specular direction, TIS per angle of
    /// incidence) or `merl` (MERL binary, 90 x 90 x 180 half/difference-angle
    /// bins, three equal channels). Prints the file's reflectance, read back
    /// and integrated over the hemisphere, beside the table's. Both hold
    /// intensity only (the BRDF for the run's incident state; their formats
    /// cannot hold polarisation: mueller.csv stays beside brdf.csv).
    ExportBrdf(export_brdf::ExportBrdfArgs),
    /// Fit an analytic BRDF model to the table of a `roks brdf` result folder.
    ///
    /// Weighted least squares with the table's standard errors: ABg or
    /// Harvey-Shack (stray-light programs) per incidence, GGX or Beckmann
    /// with Smith shadowing and the material's Fresnel factor (renderers)
    /// for all incidences at once. Writes RESULT_DIR/fit_<model>.json
    /// (parameters with standard errors, chi2/dof, largest residuals),
    /// fit_<model>.png (table and fit in and across the plane of incidence)
    /// and, for ABg, fit_abg_opticstudio.txt (OpticStudio's ABg data rows).
    FitModel(fit_model::FitModelArgs),
    /// Redraw every picture of a result folder from its files.
    ///
    /// Reads DIR/summary.json and the tables beside it (brdf.csv,
    /// inplane.csv, stokes.csv, mueller.csv, colour.csv) and writes into DIR:
    /// a micro folder's hemisphere_<theta>deg.png, inplane.png,
    /// reflectance.png (against incidence), dop_<theta>deg.png,
    /// mueller_<theta>deg.png and mueller_stderr_<theta>deg.png, and
    /// colour_<theta>deg.png (those its tables allow), and surface.png when
    /// the scene file still gives the run's surface; an object folder's
    /// reflectance.png. Works on shard and merged folders alike.
    Plot(plot::PlotArgs),
    /// Write the interactive report of a result folder: one HTML file.
    ///
    /// Reads the result folder DIR of `roks brdf`, `roks trace` or `roks
    /// merge` and writes DIR/report.html (or --out FILE): the run, its
    /// tables and pictures as interactive plots (Plotly.js, inside the
    /// file), opened offline in any current browser. See
    /// docs/src/report.md.
    Report(report::ReportArgs),
}

impl Command {
    /// The command's name on the command line (`brdf`, `fit-model`, ...).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Brdf(_) => "brdf",
            Self::Stats(_) => "stats",
            Self::Trace(_) => "trace",
            Self::Fit(_) => "fit",
            Self::ExportMesh(_) => "export-mesh",
            Self::ExportHeightfield(_) => "export-heightfield",
            Self::Render(_) => "render",
            Self::Merge(_) => "merge",
            Self::ExportBrdf(_) => "export-brdf",
            Self::FitModel(_) => "fit-model",
            Self::Plot(_) => "plot",
            Self::Report(_) => "report",
        }
    }
}
