//! The `roks` command line.
//!
//! Exit status: 0 success; 2 bad input (scene file or arguments: one line on
//! stderr naming the file and key, nothing written); 1 other failures (I/O).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressState, ProgressStyle};

use roks::export::brdf_formats::BrdfFormat;
use roks::micro::surface_stats::surface_stats;
use roks::optics::brdf_table::BrdfTable;
use roks::output;
use roks::output::brdf_folder::BrdfFolder;
use roks::output::summary::{self, FitSummary, Surface, TraceSummary};
use roks::output::tallies::{self, Settings};
use roks::scene::SceneError;
use roks::scene::micro::MicroScene;
use roks::scene::object::ObjectScene;
use roks::shard::Shard;

/// Monte Carlo reflection of light from rough surfaces (geometric optics), after ROKS-RG.
///
/// A rough surface is modelled explicitly: a substrate with bumps bounded by
/// planes and quadrics, in which photons reflect specularly as often as the
/// geometry makes them. Scene files are TOML; see `scenes/` and the README.
#[derive(Parser, Debug)]
#[command(name = "roks", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Generate the tabulated BRDF of a micro scene (default: the embedded scene).
    ///
    /// Writes DIR/summary.json (reflectance per incidence with standard
    /// errors, losses, speed, surface statistics), DIR/brdf.csv (Carlson grid),
    /// DIR/inplane.csv (plane of incidence), DIR/inplane.png (in-plane curves),
    /// DIR/hemisphere_<theta>deg.png (equal-area map of the BRDF per incidence)
    /// and, with --export, DIR/brdf.bsdf and DIR/brdf.binary. DIR defaults to
    /// out/<scene name>/.
    Brdf(BrdfArgs),
    /// Print the surface statistics of a micro scene: RMS height sigma,
    /// autocorrelation length tau, sigma/tau, RMS slope, heights.
    Stats(StatsArgs),
    /// Trace a 3-D object of quadric cells with rough walls (the macro level).
    ///
    /// Writes DIR/summary.json (per beam position: reflectance with standard
    /// error, missed, absorbed per surface, bounces, losses; with polarised
    /// transport the Stokes vector of the reflected light), DIR/reflectance.csv
    /// (x,y,z,reflectance,reflectance_stderr) and, with [tally] farfield = true,
    /// DIR/farfield.csv (and DIR/farfield_stokes.csv with [tally]
    /// polarisation = "stokes"). DIR defaults to out/<scene name>/.
    Trace(TraceArgs),
    /// Fit micro-scene parameters to a measured in-plane BRDF.
    ///
    /// MEASURED is a CSV with header theta_i_deg,theta_o_deg,brdf (optionally
    /// brdf_stderr), theta_o signed (positive on the specular side), like the
    /// inplane.csv of `roks brdf`. Each --param KEY=LO:HI names a number in the
    /// scene by its TOML key path (e.g. bumps[0].height, bumps[0].radius[1],
    /// materials.paint.n) and its bounds. Nelder-Mead on the log misfit with a
    /// fixed seed (common random numbers). Writes DIR/fit.json, DIR/fitted.toml
    /// and DIR/fit_inplane.csv (default DIR: out/<scene name>-fit/).
    Fit(FitArgs),
    /// Write the top surface of a micro scene as a triangulated height field
    /// over one period (binary PLY, as Mitsuba's `ply` shape reads it).
    ///
    /// Heights are sampled at (N+1) x (N+1) vertices; for periodic cells the
    /// last row and column repeat the first exactly, so tiled copies are
    /// seamless. Coordinates are float32 (Mitsuba's precision).
    ExportMesh(ExportMeshArgs),
    /// Write the heights of a micro scene as a height map file, for
    /// `heightfield = { file = ..., pixel = ... }` (a height-field scene: its
    /// own vertex heights; a scene of bumps: heights sampled at the vertices
    /// of an N x N grid).
    ///
    /// OUT's extension picks the format: .exr (one f32 channel Y) or .txt
    /// (text grid, shortest exact decimals). Row j of the file is y = j pixel.
    /// The scene line to load it is printed on stderr.
    ExportHeightfield(ExportHeightfieldArgs),
    /// Render a radiance map of a micro scene to OpenEXR (plus a PNG preview).
    ///
    /// An orthographic camera whose footprint is exactly one period of the
    /// substrate looks from --view; the light is a small bright disc (radiance
    /// 1, angular radius --disc) in the scene's first incidence direction
    /// ([light] theta_deg[0], phi_deg) or --light. Pixel values are radiance in
    /// units of the disc's. Writes OUT (EXR: scanline, ZIP, f32 RGB) and OUT
    /// with the extension .png (tone-mapped preview).
    Render(RenderArgs),
    /// Merge the shards of one `roks brdf --shard I/N` run into one result.
    ///
    /// Reads DIR/tallies.json of every shard folder, checks they come from the
    /// same run (scene, seed, settings) and that their photon ranges are
    /// disjoint and cover the run, sums them in shard order and writes
    /// OUT/brdf.csv, OUT/inplane.csv, OUT/summary.json and OUT/tallies.json,
    /// exactly as the single run would (only timings differ).
    Merge(MergeArgs),
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
    ExportBrdf(ExportBrdfArgs),
}

#[derive(Args, Debug)]
struct ExportBrdfArgs {
    /// Result folder of `roks brdf` (with brdf.csv).
    dir: PathBuf,
    /// Output format: zemax or merl.
    #[arg(long)]
    format: String,
    /// Output file.
    #[arg(long)]
    out: PathBuf,
    /// No reflectance check on stderr.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct MergeArgs {
    /// Shard result folders (each with tallies.json), in any order.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Output folder, replaced whole (an existing one must be empty or a roks
    /// result).
    #[arg(long)]
    out: PathBuf,
    /// No table on stderr.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// Micro or object scene file (TOML; an object scene has [[cells]]);
    /// omitted: the embedded default micro scene.
    scene: Option<PathBuf>,
    /// Output EXR file.
    #[arg(long)]
    out: PathBuf,
    /// View direction THETA,PHI in degrees (toward the camera).
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], value_parser = roks::cli::number)]
    view: Vec<f64>,
    /// Light direction THETA,PHI in degrees (default: the scene's first incidence).
    #[arg(long, value_delimiter = ',', value_parser = roks::cli::number)]
    light: Option<Vec<f64>>,
    /// Angular radius of the light disc (degrees).
    #[arg(long, default_value_t = 5.0, value_parser = roks::cli::number)]
    disc: f64,
    /// Radiance of a uniform background outside the disc, in the disc's units
    /// (default 0: black; a small value shows walls the disc leaves dark).
    #[arg(long, default_value_t = 0.0, value_parser = roks::cli::number)]
    background: f64,
    /// Image size W,H in pixels.
    #[arg(long, value_delimiter = ',', default_values_t = [512, 512], value_parser = roks::cli::positive::<usize>)]
    size: Vec<usize>,
    /// Samples per pixel.
    #[arg(long, default_value_t = 16, value_parser = roks::cli::positive::<u32>)]
    spp: u32,
    /// Seed.
    #[arg(long, default_value_t = 1, value_parser = roks::cli::integer::<u64>)]
    seed: u64,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = roks::cli::positive::<usize>)]
    threads: Option<usize>,
    /// Object scenes: pinhole camera position X,Y,Z (default: on the first
    /// beam's axis, 2.5 beam-sweep lengths before its start, at least 50 units).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_parser = roks::cli::number)]
    camera: Option<Vec<f64>>,
    /// Object scenes: point the camera looks at X,Y,Z (default: the first
    /// beam's start point moved 100 units along the beam).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_parser = roks::cli::number)]
    look_at: Option<Vec<f64>>,
    /// Object scenes: up direction X,Y,Z of the image.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_values_t = [0.0, 1.0, 0.0], value_parser = roks::cli::number)]
    up: Vec<f64>,
    /// Object scenes: vertical field of view (degrees).
    #[arg(long, default_value_t = 40.0, value_parser = roks::cli::number)]
    fov: f64,
}

#[derive(Args, Debug)]
struct ExportMeshArgs {
    /// Micro or object scene file (TOML; an object scene has [[cells]]);
    /// omitted: the embedded default micro scene.
    scene: Option<PathBuf>,
    /// Output PLY file.
    #[arg(long)]
    out: PathBuf,
    /// Grid cells per side of the period (default 512; a height-field scene
    /// writes its own grid and triangles, and only accepts its own
    /// resolution); for object scenes, voxels along the longest side of
    /// --bounds (default 512).
    #[arg(long, value_parser = roks::cli::integer::<usize>)]
    resolution: Option<usize>,
    /// Object scenes (required there): the box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX
    /// whose solid walls are meshed (solids cut by it are capped).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_parser = roks::cli::number)]
    bounds: Option<Vec<f64>>,
}

#[derive(Args, Debug)]
struct ExportHeightfieldArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// Output file: .exr (one f32 channel Y) or .txt (text grid, exact).
    #[arg(long)]
    out: PathBuf,
    /// Vertices per side for a scene of bumps (default 512); a height-field
    /// scene writes its own grid and only accepts its own resolution.
    #[arg(long, value_parser = roks::cli::integer::<usize>)]
    resolution: Option<usize>,
}

#[derive(Args, Debug)]
struct FitArgs {
    /// Micro scene file (TOML) whose parameters are adjusted.
    scene: PathBuf,
    /// Measured in-plane BRDF (CSV: theta_i_deg,theta_o_deg,brdf[,brdf_stderr]).
    measured: PathBuf,
    /// A parameter to fit: KEY=LO:HI (repeat for several).
    #[arg(long = "param", required = true, value_name = "KEY=LO:HI")]
    params: Vec<String>,
    /// Photons per incidence angle per evaluation.
    #[arg(long, default_value_t = 200_000, value_parser = roks::cli::positive::<u64>)]
    photons: u64,
    /// Seed (fixed through the fit).
    #[arg(long, default_value_t = 1, value_parser = roks::cli::integer::<u64>)]
    seed: u64,
    /// Most model evaluations.
    #[arg(long, default_value_t = 200, value_parser = roks::cli::positive::<usize>)]
    max_evals: usize,
    /// Stop when the misfit spread of the simplex is below this.
    #[arg(long, default_value_t = 1e-6, value_parser = roks::cli::number)]
    tolerance: f64,
    /// ... and the simplex is narrower than this fraction of each range.
    #[arg(long, default_value_t = 1e-3, value_parser = roks::cli::number)]
    x_tolerance: f64,
    /// Restarts from the best point.
    #[arg(long, default_value_t = 3, value_parser = roks::cli::integer::<usize>)]
    restarts: usize,
    /// Points per parameter of the coarse scan before the simplex (0: none).
    #[arg(long, default_value_t = 8, value_parser = roks::cli::integer::<usize>)]
    scan: usize,
    /// In-plane bin width for the model (degrees; wider bins, less noise).
    #[arg(long, value_parser = roks::cli::number)]
    inplane_step: Option<f64>,
    /// In-plane detector width out of the plane (degrees).
    #[arg(long, value_parser = roks::cli::number)]
    inplane_width: Option<f64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = roks::cli::positive::<usize>)]
    threads: Option<usize>,
    /// Output folder (default: out/<scene name>-fit/), replaced whole (an
    /// existing one must be empty or a roks result).
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct TraceArgs {
    /// Object scene file (TOML).
    scene: PathBuf,
    /// Output folder (default: out/<scene name>/), replaced whole by the run
    /// (an existing one must be empty or a roks result).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Photons per beam position (overrides each source's `photons`).
    #[arg(long, value_parser = roks::cli::positive::<u64>)]
    photons: Option<u64>,
    /// Tracing seed (overrides the scene's `seed`).
    #[arg(long, value_parser = roks::cli::integer::<u64>)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = roks::cli::positive::<usize>)]
    threads: Option<usize>,
    /// Scalar transport even with Fresnel walls: each Fresnel bounce weighs
    /// (Rs + Rp) / 2, the unpolarised approximation (as [transport]
    /// polarisation = false).
    #[arg(long)]
    no_polarisation: bool,
    /// No progress bar and no table on stderr.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct BrdfArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// Output folder (default: out/<scene name>/), replaced whole by the run
    /// (an existing one must be empty or a roks result).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Photons per incidence angle (overrides [light] photons).
    #[arg(long, value_parser = roks::cli::positive::<u64>)]
    photons: Option<u64>,
    /// Tracing seed (overrides [light] seed). Same seed, same result, for any thread count.
    #[arg(long, value_parser = roks::cli::integer::<u64>)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = roks::cli::positive::<usize>)]
    threads: Option<usize>,
    /// Incidence angles in degrees, comma-separated (overrides [light] theta_deg).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = roks::cli::number)]
    theta: Option<Vec<f64>>,
    /// Entry points (overrides [light] launch): random, or lattice (16
    /// randomly shifted R2 lattices; standard errors from their spread;
    /// photons a multiple of 16).
    #[arg(long, value_parser = ["random", "lattice"])]
    launch: Option<String>,
    /// Fold mirror images in the plane of incidence into the Carlson cells
    /// (overrides [tally] symmetry): none, or mirror (only for surfaces whose
    /// statistics are mirror symmetric; halves the variance off the plane).
    #[arg(long, value_parser = ["none", "mirror"])]
    symmetry: Option<String>,
    /// Polarisation tally (overrides [tally] polarisation): none, stokes
    /// (DIR/stokes.csv: the Stokes BRDF per cell for the incident state, and
    /// DIR/dop_<theta>deg.png) or mueller (DIR/mueller.csv: the Mueller-matrix
    /// BRDF per cell). Implies polarised transport.
    #[arg(long, value_parser = ["none", "stokes", "mueller"])]
    polarisation: Option<String>,
    /// The unpolarised approximation: the weight times (Rs + Rp)/2 at every
    /// Fresnel bounce (overrides [transport] polarisation; default: Stokes
    /// vectors through every bounce when a material is Fresnel).
    #[arg(long)]
    no_polarisation: bool,
    /// Height-map resolution for the surface statistics in the summary
    /// (default 512; a height field: its own grid).
    #[arg(long, value_parser = roks::cli::integer::<usize>)]
    stats_resolution: Option<usize>,
    /// Run only photon block I of N (0-based; whole batches of 4096 photons)
    /// of every incidence angle and also write DIR/tallies.json, the raw sums
    /// that `roks merge` adds up exactly.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Also export the table, comma-separated formats: zemax (DIR/brdf.bsdf),
    /// merl (DIR/brdf.binary); see `roks export-brdf`.
    #[arg(long, value_delimiter = ',')]
    export: Vec<String>,
    /// No progress bar and no table on stderr.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct StatsArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// Height-map samples per side of the cell (default 1024; a height
    /// field: its own grid, whose vertex heights are used exactly).
    #[arg(long, value_parser = roks::cli::integer::<usize>)]
    resolution: Option<usize>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Failures, by exit status.
enum Failure {
    /// Bad input: exit 2.
    Input(String),
    /// Anything else: exit 1.
    Other(anyhow::Error),
}

impl From<SceneError> for Failure {
    fn from(e: SceneError) -> Self {
        Self::Input(e.to_string())
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Self::Other(e)
    }
}

fn main() -> ExitCode {
    let cli = match roks::cli::parse::<Cli>() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    if let Err(e) = roks::limits::max_memory() {
        eprintln!("roks: {e}");
        return ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Brdf(a) => brdf(a),
        Command::Stats(a) => stats(a),
        Command::Trace(a) => trace(a),
        Command::Fit(a) => fit(a),
        Command::ExportMesh(a) => export_mesh(a),
        Command::ExportHeightfield(a) => export_heightfield(a),
        Command::Render(a) => render(a),
        Command::Merge(a) => merge(a),
        Command::ExportBrdf(a) => export_brdf(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(msg)) => {
            eprintln!("roks: {msg}");
            ExitCode::from(2)
        }
        Err(Failure::Other(e)) => {
            eprintln!("roks: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn load_scene(path: Option<&Path>) -> Result<MicroScene, Failure> {
    Ok(match path {
        Some(p) => MicroScene::load(p)?,
        None => MicroScene::default_scene(),
    })
}

fn set_threads(threads: Option<usize>) -> Result<(), Failure> {
    if let Some(t) = threads {
        // Each worker reserves a 2 MiB stack (rayon's default).
        let bytes = roks::limits::product(&[t as u64, 2 << 20]);
        check_memory(
            "--threads",
            &format!("the stacks of {t} worker threads"),
            bytes,
        )?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| Failure::Other(e.into()))?;
    }
    Ok(())
}

/// Parse export format names (`--export`, `--format`).
fn parse_formats(names: &[String], option: &str) -> Result<Vec<BrdfFormat>, Failure> {
    let mut formats: Vec<BrdfFormat> = Vec::new();
    for n in names {
        let f = n
            .parse::<BrdfFormat>()
            .map_err(|e| Failure::Input(format!("{option}: {e}")))?;
        if !formats.contains(&f) {
            formats.push(f);
        }
    }
    Ok(formats)
}

/// The export of `table` in `format` (with the reflectance check on stderr
/// unless `quiet`).
fn export_table(
    table: &BrdfTable,
    format: BrdfFormat,
    comment: &str,
    quiet: bool,
) -> Result<Vec<u8>, Failure> {
    let bytes = format.export(table, comment);
    if !quiet {
        let check =
            roks::export::brdf_formats::reflectance_check(table, format, &bytes).map_err(|e| {
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

fn export_brdf(a: ExportBrdfArgs) -> Result<(), Failure> {
    let format = parse_formats(std::slice::from_ref(&a.format), "--format")?[0];
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
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    }
    output::write_atomic(&a.out, &bytes)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", a.out.display()))?;
    if !a.quiet {
        eprintln!(
            "wrote {} ({format}, {} bytes)",
            a.out.display(),
            bytes.len()
        );
    }
    Ok(())
}

fn brdf(a: BrdfArgs) -> Result<(), Failure> {
    let exports = parse_formats(&a.export, "--export")?;
    let scene = load_scene(a.scene.as_deref())?;
    let mut run = scene.brdf_run();
    if let Some(p) = a.photons {
        run.photons = p;
    }
    if let Some(s) = a.seed {
        run.seed = s;
    }
    if let Some(l) = &a.launch {
        run.launch = roks::transport::launch::Launch::from_name(l).expect("clap checked the name");
    }
    if let Some(s) = &a.symmetry {
        run.symmetry = roks::tally::Symmetry::from_name(s).expect("clap checked the name");
    }
    if a.polarisation.is_some() || a.no_polarisation || a.symmetry.is_some() {
        let tally = a
            .polarisation
            .as_deref()
            .map_or(scene.tally.polarisation, |p| {
                roks::tally::PolarTally::from_name(p).expect("clap checked the name")
            });
        let transport = if a.no_polarisation {
            Some(false)
        } else {
            scene.transport.polarisation
        };
        run.polarisation = roks::transport::brdf::Polarisation::resolve(
            scene.has_fresnel(),
            transport,
            run.polarisation.incident,
            tally,
            run.symmetry,
        )
        .map_err(|(key, e)| {
            let option = match key {
                "tally.symmetry" => "--symmetry",
                _ if a.no_polarisation => "--no-polarisation",
                _ => "--polarisation",
            };
            Failure::Input(format!("{option}: {e}"))
        })?;
    }
    roks::transport::launch::check_photons(run.launch, run.photons)
        .map_err(|e| Failure::Input(format!("--photons: {e}")))?;
    if let Some(t) = &a.theta {
        if t.is_empty() {
            return Err(Failure::Input("--theta: needs at least one angle".into()));
        }
        if let Some(bad) = t
            .iter()
            .find(|t| !(t.is_finite() && (0.0..90.0).contains(*t)))
        {
            return Err(Failure::Input(format!(
                "--theta: angles must be in [0, 90), got {bad}"
            )));
        }
        if let Some((_, t)) = roks::scene::micro::first_repeat(t) {
            return Err(Failure::Input(format!(
                "--theta: {t} is given twice (each incidence angle once)"
            )));
        }
        run.theta_deg.clone_from(t);
    }
    scene.check_run_memory(&run)?;
    let (rx, ry) = stats_grid(&scene, a.stats_resolution, 512, "--stats-resolution")?;
    let shard = a
        .shard
        .as_deref()
        .map(|s| {
            s.parse::<Shard>()
                .map_err(|e| Failure::Input(format!("--shard: {e}")))
        })
        .transpose()?;
    let range = shard
        .map(|s| s.photon_range(run.photons))
        .transpose()
        .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
    set_threads(a.threads)?;
    let out = result_dir(a.out.as_deref(), &scene.source.file, &scene.name)?;

    let stats = surface_stats(&scene.surface.height_map(rx, ry));
    let edges = format!("{:?}", scene.surface.edges).to_lowercase();
    let settings = Settings::new(
        &scene.source.file,
        &scene.name,
        &edges,
        &run,
        Surface::new(&stats, rx),
    );
    let block_photons = range.map_or(run.photons, |(first, last)| last - first);
    let bar = progress_bar(
        block_photons.saturating_mul(run.theta_deg.len() as u64),
        a.quiet,
        &scene.name,
    );
    let folder = BrdfFolder::trace(&scene.surface, run, settings, shard, &|n| bar.inc(n))
        .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
    bar.finish_and_clear();

    let mut extra = folder.images(&scene.name).map_err(Failure::Other)?;
    if !exports.is_empty() {
        let table = folder.table();
        for &f in &exports {
            let comment = format!(
                "scene {}, {} photons per angle",
                scene.name, folder.run.photons
            );
            extra.push((
                f.file_name().to_owned(),
                export_table(&table, f, &comment, a.quiet)?,
            ));
        }
    }
    write_outputs(&out, &folder.files(extra))?;

    if !a.quiet {
        print_brdf_table(&folder.results);
        eprintln!("wrote {} ({:.1} s)", out.display(), folder.seconds);
    }
    Ok(())
}

fn print_brdf_table(results: &[roks::transport::brdf::IncidenceResult]) {
    eprintln!(
        "{:>9} {:>12} {:>10} {:>8} {:>9} {:>12}",
        "theta_i", "reflectance", "stderr", "bounces", "lost", "Msegments/s"
    );
    for r in results {
        let (refl, se) = r.reflectance();
        eprintln!(
            "{:>9.2} {:>12.6} {:>10.2e} {:>8.3} {:>9.2e} {:>12.2}",
            r.theta_i_deg,
            refl,
            se,
            r.mean_bounces(),
            r.lost(),
            r.segments_per_second() / 1e6
        );
    }
}

fn merge(a: MergeArgs) -> Result<(), Failure> {
    check_out_dir(&a.out, "--out")?;
    let parts = a
        .dirs
        .iter()
        .map(|d| tallies::read_shard(d))
        .collect::<Result<Vec<_>, _>>()?;
    let n_parts = parts.len();
    let merged = tallies::merge_shards(parts)?;
    roks::limits::check("the merged tallies and tables", merged.run.memory_bytes()).map_err(
        |e| {
            Failure::Input(format!(
                "{}: {}: settings.bands: {e}",
                a.dirs[0].display(),
                tallies::TALLIES_FILE
            ))
        },
    )?;
    let folder = BrdfFolder::merged(merged);
    write_outputs(&a.out, &folder.files(Vec::new()))?;
    if !a.quiet {
        print_brdf_table(&folder.results);
        eprintln!("merged {n_parts} shards into {}", a.out.display());
    }
    Ok(())
}

fn progress_bar(total: u64, quiet: bool, name: &str) -> ProgressBar {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} {msg} [{bar:30}] {human_pos}/{human_len} photons, {rate}, eta {eta}",
        )
        .expect("valid template")
        .with_key("rate", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = match photon_rate(s) {
                Some(r) => write!(w, "{}/s", indicatif::HumanCount(r as u64)),
                None => write!(w, "?/s"),
            };
        })
        .with_key("eta", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
            // Photons still to trace at the run's mean rate so far (unknown
            // until the first batch is done), however long that is.
            let left = s.len().unwrap_or(0).saturating_sub(s.pos());
            let _ = match photon_rate(s) {
                Some(r) => write!(
                    w,
                    "{:#}",
                    indicatif::HumanDuration(std::time::Duration::from_secs_f64(
                        (left as f64 / r).min(1e15)
                    ))
                ),
                None => write!(w, "?"),
            };
        })
        .progress_chars("=> "),
    );
    bar.set_message(name.to_string());
    bar
}

/// Photons per second over the run so far (`None` before the first batch).
fn photon_rate(s: &ProgressState) -> Option<f64> {
    let secs = s.elapsed().as_secs_f64();
    (s.pos() > 0 && secs > 0.0).then(|| s.pos() as f64 / secs)
}

/// Write the result folder `out` whole: staged beside it, then swapped in
/// (see [`roks::outdir`]); a reader never sees old and new files mixed.
fn write_outputs<N: AsRef<str>, B: AsRef<[u8]>>(
    out: &Path,
    files: &[(N, B)],
) -> Result<(), Failure> {
    let files: Vec<(&str, &[u8])> = files
        .iter()
        .map(|(n, b)| (n.as_ref(), b.as_ref()))
        .collect();
    roks::outdir::write_folder(out, &files)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", out.display()))?;
    Ok(())
}

/// The result folder: `given` (`--out`), or `out/<name>` (named in messages
/// by the scene file's `name` key), checked before any work is done.
fn result_dir(given: Option<&Path>, scene_file: &str, name: &str) -> Result<PathBuf, Failure> {
    let (out, key) = match given {
        Some(p) => (p.to_path_buf(), "--out".to_string()),
        None => (Path::new("out").join(name), format!("{scene_file}: name")),
    };
    check_out_dir(&out, &key)?;
    Ok(out)
}

/// Check a result folder before any work is done; `key` names it in the
/// message (`--out`, or `SCENE: name` for the default out/NAME).
fn check_out_dir(out: &Path, key: &str) -> Result<(), Failure> {
    roks::outdir::check_folder(out)
        .map_err(|e| Failure::Input(format!("{key}: {}: {e}", out.display())))
}

/// Check an output file (`--out`) before any work is done.
fn check_out_file(out: &Path) -> Result<(), Failure> {
    roks::outdir::check_file(out)
        .map_err(|e| Failure::Input(format!("--out: {}: {e}", out.display())))
}

/// Reflectance vs beam position, one curve per `[[sources]]` entry; the x axis
/// is the distance of the beam axis from the first position of its source.
fn reflectance_plot(
    scene: &ObjectScene,
    results: &[roks::transport::object::PositionResult],
) -> roks::plot::LinePlot {
    use roks::plot::{LinePlot, Series};
    let mut series: Vec<Series> = Vec::new();
    for (k, r) in results.iter().enumerate() {
        let src = scene.beam_source[k];
        let first = scene.beams[scene
            .beam_source
            .iter()
            .position(|&s| s == src)
            .unwrap_or(0)]
        .position;
        if series.len() <= src {
            series.resize_with(src + 1, || Series {
                label: String::new(),
                points: Vec::new(),
            });
            series[src].label = format!("source {src} (beam {} mm)", r.beam.diameter);
        }
        let (refl, se) = r.reflectance();
        series[src]
            .points
            .push(((r.beam.position - first).length(), refl, 2.0 * se));
    }
    let positive = results.iter().all(|r| r.reflectance().0 > 0.0);
    let spread = results
        .iter()
        .map(|r| r.reflectance().0)
        .fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
    LinePlot {
        title: format!(
            "{}: reflectance vs beam position (error bars: 2 standard errors)",
            scene.name
        ),
        x_label: "beam axis offset from the first position (scene units)".into(),
        y_label: "reflectance (fraction of the beam's flux)".into(),
        log_y: positive && spread.1 > 20.0 * spread.0,
        series,
    }
}

fn trace(a: TraceArgs) -> Result<(), Failure> {
    let scene = ObjectScene::load(&a.scene)?;
    let mut run = scene.run.clone();
    let mut photons = scene.photons.clone();
    if let Some(p) = a.photons {
        if let Some(e) = roks::transport::launch::photons_beyond_tallies(p) {
            return Err(Failure::Input(format!("--photons: {e}")));
        }
        photons.iter_mut().for_each(|n| *n = p);
    }
    if let Some(s) = a.seed {
        run.seed = s;
    }
    if a.no_polarisation {
        if run.farfield_stokes {
            return Err(Failure::Input(format!(
                "{}: tally.polarisation: \"stokes\" needs polarised transport, which --no-polarisation turns off",
                scene.source.file
            )));
        }
        run.polarisation = false;
    }
    set_threads(a.threads)?;
    let out = result_dir(a.out.as_deref(), &scene.source.file, &scene.name)?;
    let bar = progress_bar(
        photons.iter().fold(0, |a: u64, &b| a.saturating_add(b)),
        a.quiet,
        &scene.name,
    );
    let clock = Instant::now();
    let results = run.run(
        &scene.object,
        &scene.walls,
        &scene.models,
        &scene.beams,
        &photons,
        &|n| bar.inc(n),
    );
    bar.finish_and_clear();
    let seconds = clock.elapsed().as_secs_f64();

    // A photon met a wall without a model: a scene error, before any output.
    if let Some(r) = results.iter().find(|r| r.tallies.unmodelled.0 > 0) {
        let name = &scene.object.surface_names[r.tallies.unmodelled.1];
        return Err(Failure::Input(format!(
            "{}: walls.{name}: photons hit surface `{name}` ({} of them from beam position {}), which has no model in [walls]",
            scene.source.file, r.tallies.unmodelled.0, r.beam.position
        )));
    }
    if let Some((k, r)) = results
        .iter()
        .enumerate()
        .find(|(_, r)| r.tallies.started_inside > 0)
    {
        return Err(Failure::Input(format!(
            "{}: sources[{}].beam.diameter: {} photons of beam position {} started inside a solid cell",
            scene.source.file, scene.beam_source[k], r.tallies.started_inside, r.beam.position
        )));
    }
    let summary = TraceSummary::new(
        &scene.source.file,
        &scene.name,
        run.seed,
        &results,
        &scene.object.surface_names,
        seconds,
    );
    let text = summary::to_text(&summary);
    let refl = output::object_csv::reflectance_csv(&results);
    let png = reflectance_plot(&scene, &results)
        .to_png(900, 560)
        .map_err(Failure::Other)?;
    let farfield = run
        .farfield
        .then(|| output::object_csv::farfield_csv(&run, &results));
    let farfield_stokes = run
        .tallies_farfield_stokes()
        .then(|| output::object_csv::farfield_stokes_csv(&run, &results));
    let mut files: Vec<(&str, &[u8])> = vec![
        ("reflectance.csv", refl.as_bytes()),
        ("reflectance.png", &png),
    ];
    if let Some(f) = &farfield {
        files.push(("farfield.csv", f.as_bytes()));
    }
    if let Some(f) = &farfield_stokes {
        files.push(("farfield_stokes.csv", f.as_bytes()));
    }
    files.push(("summary.json", text.as_bytes()));
    write_outputs(&out, &files)?;

    if !a.quiet {
        eprintln!(
            "{:>28} {:>12} {:>10} {:>9} {:>8} {:>9}",
            "beam position", "reflectance", "stderr", "missed", "bounces", "lost"
        );
        for r in &results {
            let (refl, se) = r.reflectance();
            let n = r.tallies.photons as f64;
            let p = r.beam.position;
            eprintln!(
                "{:>28} {:>12.4e} {:>10.2e} {:>9.4} {:>8.3} {:>9.2e}",
                format!("({:.3}, {:.3}, {:.3})", p.x, p.y, p.z),
                refl,
                se,
                r.tallies.missed / n,
                r.tallies.bounces as f64 / n,
                r.tallies.lost / n
            );
        }
        eprintln!("wrote {} ({seconds:.1} s)", out.display());
    }
    Ok(())
}

fn fit(a: FitArgs) -> Result<(), Failure> {
    use roks::fit::{FitOptions, FitParam, Measured, Problem};
    let input = |e: roks::fit::FitError| Failure::Input(e.to_string());
    let text = roks::scene::read_scene_text(&a.scene)?;
    let source = roks::scene::Source::from_path(&a.scene);
    let measured_text = std::fs::read_to_string(&a.measured)
        .map_err(|e| Failure::Input(format!("{}: cannot read: {e}", a.measured.display())))?;
    let measured =
        Measured::parse(&measured_text, &a.measured.display().to_string()).map_err(input)?;
    let params = a
        .params
        .iter()
        .map(|p| p.parse::<FitParam>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(input)?;
    let opts = FitOptions {
        photons: a.photons,
        seed: a.seed,
        max_evaluations: a.max_evals,
        tolerance: a.tolerance,
        x_tolerance: a.x_tolerance,
        restarts: a.restarts,
        inplane_step_deg: a.inplane_step,
        inplane_width_deg: a.inplane_width,
        scan: a.scan,
    };
    set_threads(a.threads)?;
    let problem = Problem::new(&text, &source, &params, &measured, &opts).map_err(input)?;
    let name = a
        .scene
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("{name}-fit")));
    check_out_dir(&out, "--out")?;
    let quiet = a.quiet;
    let result = problem
        .fit_observed(&mut |k, values, misfit, rejected| {
            if !quiet {
                match rejected {
                    Some(why) => {
                        eprintln!("evaluation {k:>4}: rejected by the scene at {values:?}: {why}");
                    }
                    None => eprintln!("evaluation {k:>4}: misfit {misfit:.6e} at {values:?}"),
                }
            }
        })
        .map_err(input)?;
    let fitted = problem.apply(&result.values).map_err(input)?;
    let summary = FitSummary::new(
        &source.file,
        &a.measured.display().to_string(),
        a.seed,
        a.photons,
        &params,
        &result,
    );
    let mut csv = String::from("theta_i_deg,theta_o_deg,measured,model\n");
    for ((ti, to, b, _), m) in measured.points.iter().zip(&result.model) {
        csv.push_str(&format!("{ti},{to},{b:.9e},{m:.9e}\n"));
    }
    let text = summary::to_text(&summary);
    write_outputs(
        &out,
        &[
            ("fit_inplane.csv", csv.as_bytes()),
            ("fitted.toml", fitted.as_bytes()),
            ("fit.json", text.as_bytes()),
        ],
    )?;
    if !quiet {
        for (i, p) in params.iter().enumerate() {
            eprintln!(
                "{} = {:.6} (start {:.6}, bounds {}:{})",
                p.key, result.values[i], result.start[i], p.lo, p.hi
            );
        }
        eprintln!(
            "misfit {:.3e} (start {:.3e}), {} evaluations; wrote {}",
            result.misfit,
            result.start_misfit,
            result.evaluations,
            out.display()
        );
    }
    Ok(())
}

/// The height-map grid for statistics: `requested` (checked), or the
/// height field's own grid, or `default`.
fn stats_grid(
    scene: &MicroScene,
    requested: Option<usize>,
    default: usize,
    option: &str,
) -> Result<(usize, usize), Failure> {
    match (requested, scene.surface.heightfield()) {
        (Some(r), _) if r < 2 => Err(Failure::Input(format!("{option}: must be >= 2"))),
        (Some(r), _) => {
            let what = format!("the statistics of a {r} x {r} height map");
            check_memory(option, &what, scene.surface.stats_memory_bytes(r, r))?;
            Ok((r, r))
        }
        (None, Some(f)) => Ok((f.nx, f.ny)),
        (None, None) => Ok((default, default)),
    }
}

/// Refuse `option` when `bytes`, the estimate for `what`, exceed the memory
/// limit ([`roks::limits`]).
fn check_memory(option: &str, what: &str, bytes: u64) -> Result<(), Failure> {
    roks::limits::check(what, bytes).map_err(|e| Failure::Input(format!("{option}: {e}")))
}

/// A height-field scene's own grid, refusing any other `--resolution`.
fn own_grid(scene: &MicroScene, resolution: Option<usize>) -> Result<(), Failure> {
    match (scene.surface.heightfield(), resolution) {
        (Some(f), Some(r)) if (r, r) != (f.nx, f.ny) => Err(Failure::Input(format!(
            "--resolution: {}: a height field is written on its own {} x {} grid, got {r}",
            scene.source.file, f.nx, f.ny
        ))),
        _ => Ok(()),
    }
}

/// Write `bytes` to `path`, creating its folder.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    }
    output::write_atomic(path, bytes)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    Ok(())
}

fn export_mesh(a: ExportMeshArgs) -> Result<(), Failure> {
    if let Some(path) = a.scene.as_deref().filter(|p| is_object_scene(p)) {
        return export_object_mesh(&a, path);
    }
    let resolution = a.resolution.unwrap_or(512);
    if !(1..=roks::export::MAX_CELLS_PER_SIDE).contains(&resolution) {
        return Err(Failure::Input(format!(
            "--resolution: must be in 1..={}, got {resolution}",
            roks::export::MAX_CELLS_PER_SIDE,
        )));
    }
    let scene = load_scene(a.scene.as_deref())?;
    own_grid(&scene, a.resolution)?;
    let n = scene
        .surface
        .heightfield()
        .map_or((resolution, resolution), |f| (f.nx, f.ny));
    check_memory(
        "--resolution",
        &format!("a mesh of {} x {} grid squares", n.0, n.1),
        roks::export::mesh_memory_bytes(n.0, n.1),
    )?;
    check_out_file(&a.out)?;
    let mesh = match scene.surface.heightfield() {
        Some(field) => roks::export::field_mesh(field),
        None => roks::export::height_field_mesh(&scene.surface, resolution),
    };
    write_file(&a.out, &roks::export::write_ply(&mesh))?;
    eprintln!(
        "wrote {} ({} vertices, {} triangles, one {} x {} period)",
        a.out.display(),
        mesh.vertices.len(),
        mesh.faces.len(),
        scene.surface.size.x,
        scene.surface.size.y
    );
    Ok(())
}

fn export_heightfield(a: ExportHeightfieldArgs) -> Result<(), Failure> {
    use roks::micro::heightfield_io::{self, Format, HeightGrid};
    let format = Format::of(&a.out);
    if format == Format::Png {
        return Err(Failure::Input(
            "--out: PNG height maps are read, not written; use .exr or .txt".into(),
        ));
    }
    let scene = load_scene(a.scene.as_deref())?;
    own_grid(&scene, a.resolution)?;
    check_out_file(&a.out)?;
    let ext = a
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("exr" | "txt")) {
        return Err(Failure::Input(format!(
            "--out: the extension picks the format, .exr or .txt; got `{}`",
            a.out.display()
        )));
    }
    let grid = match scene.surface.heightfield() {
        Some(f) => HeightGrid {
            nx: f.nx,
            ny: f.ny,
            h: f.h.clone(),
        },
        None => {
            let n = a.resolution.unwrap_or(512);
            if !(2..=16384).contains(&n) {
                return Err(Failure::Input(format!(
                    "--resolution: must be in 2..=16384, got {n}"
                )));
            }
            // Heights (8 bytes) and the file (up to 24 bytes of text) per vertex.
            let bytes = roks::limits::product(&[n as u64, n as u64, 32]);
            check_memory("--resolution", &format!("a {n} x {n} height map"), bytes)?;
            let s = scene.surface.size;
            let mut scratch = roks::micro::Scratch::new(&scene.surface);
            let h: Vec<f64> = (0..n * n)
                .map(|k| {
                    let (i, j) = ((k % n) as f64, (k / n) as f64);
                    scene.surface.height_at(
                        s.x * (i / n as f64),
                        s.y * (j / n as f64),
                        &mut scratch,
                    )
                })
                .collect();
            HeightGrid { nx: n, ny: n, h }
        }
    };
    let size = scene.surface.size;
    let (px, py) = (size.x / grid.nx as f64, size.y / grid.ny as f64);
    let comment = format!(
        "roks height map of {}: {} x {} vertices, pitch {px:?} x {py:?} (length units); row j is y = j * pitch",
        scene.source.file, grid.nx, grid.ny
    );
    let bytes = heightfield_io::write(&grid, format, &comment).map_err(|e| anyhow::anyhow!(e))?;
    write_file(&a.out, &bytes)?;
    let file = a
        .out
        .file_name()
        .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    let keys = if px == py {
        format!("heightfield = {{ file = {file:?}, pixel = {px:?} }}")
    } else {
        format!(
            "size = [{:?}, {:?}]\nheightfield = {{ file = {file:?} }}",
            size.x, size.y
        )
    };
    eprintln!(
        "wrote {} ({} x {} heights); load it with, in [surface]:\n{keys}",
        a.out.display(),
        grid.nx,
        grid.ny
    );
    Ok(())
}

fn render(a: RenderArgs) -> Result<(), Failure> {
    use roks::render::RenderSettings;
    for (name, n) in [
        ("--view", a.view.len()),
        ("--size", a.size.len()),
        ("--light", a.light.as_ref().map_or(2, Vec::len)),
    ] {
        if n != 2 {
            return Err(Failure::Input(format!(
                "{name}: give two comma-separated values"
            )));
        }
    }
    let (w, h) = (a.size[0] as u64, a.size[1] as u64);
    check_memory(
        "--size",
        &format!("a {w} x {h} image (radiance, EXR and PNG)"),
        roks::render::image_memory_bytes(w, h),
    )?;
    check_out_file(&a.out)?;
    let png = a.out.with_extension("png");
    if png == a.out {
        return Err(Failure::Input(format!(
            "--out: {}: is the name of the PNG preview; give the EXR file (OUT.exr, beside which OUT.png is written)",
            a.out.display()
        )));
    }
    check_out_file(&png)?;
    if let Some(path) = a.scene.as_deref().filter(|p| is_object_scene(p)) {
        return render_object(&a, path);
    }
    let scene = load_scene(a.scene.as_deref())?;
    let (light_theta, light_phi) = match &a.light {
        Some(l) => (l[0], l[1]),
        None => (scene.light.theta_deg[0], scene.light.phi_deg),
    };
    let settings = RenderSettings {
        width: a.size[0],
        height: a.size[1],
        spp: a.spp,
        view_theta_deg: a.view[0],
        view_phi_deg: a.view[1],
        light_theta_deg: light_theta,
        light_phi_deg: light_phi,
        light_radius_deg: a.disc,
        light_radiance: 1.0,
        background_radiance: a.background,
        seed: a.seed,
    };
    settings.validate().map_err(Failure::Input)?;
    set_threads(a.threads)?;
    let (img, losses) = roks::render::render(&scene.surface, &settings);
    let paths = (settings.width * settings.height) as u64 * u64::from(settings.spp);
    write_images(&a.out, &img, losses.lost, paths)
}

/// Whether a scene file describes an object (has `[[cells]]`); unreadable or
/// malformed files are left to the micro loader's error messages.
fn is_object_scene(path: &Path) -> bool {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.parse::<toml::Table>().ok())
        .is_some_and(|t| t.contains_key("cells"))
}

/// `roks render` of an object scene: a pinhole camera view.
fn render_object(a: &RenderArgs, path: &Path) -> Result<(), Failure> {
    use roks::render::{PinholeCamera, RenderSettings};
    let scene = ObjectScene::load(path)?;
    for (name, v) in [("--camera", &a.camera), ("--look-at", &a.look_at)] {
        if v.as_ref().is_some_and(|v| v.len() != 3) {
            return Err(Failure::Input(format!(
                "{name}: give three comma-separated values"
            )));
        }
    }
    if a.up.len() != 3 {
        return Err(Failure::Input(
            "--up: give three comma-separated values".into(),
        ));
    }
    let beam = scene.beams[0];
    let v3 = |v: &Vec<f64>| glam::DVec3::new(v[0], v[1], v[2]);
    let sweep = scene
        .beams
        .iter()
        .map(|b| (b.position - beam.position).length())
        .fold(0.0_f64, f64::max);
    let look_at = a
        .look_at
        .as_ref()
        .map_or(beam.position + 100.0 * beam.direction, v3);
    let position = a
        .camera
        .as_ref()
        .map_or(beam.position - (2.5 * sweep).max(50.0) * beam.direction, v3);
    let camera = PinholeCamera {
        position,
        look_at,
        up: v3(&a.up),
        fov_deg: a.fov,
    };
    let (light_theta, light_phi) = match &a.light {
        Some(l) => (l[0], l[1]),
        None => {
            // Toward the light: against the first beam.
            let t = -beam.direction;
            (
                t.z.clamp(-1.0, 1.0).acos().to_degrees(),
                t.y.atan2(t.x).to_degrees(),
            )
        }
    };
    let settings = RenderSettings {
        width: a.size[0],
        height: a.size[1],
        spp: a.spp,
        light_theta_deg: light_theta,
        light_phi_deg: light_phi,
        light_radius_deg: a.disc,
        light_radiance: 1.0,
        background_radiance: a.background,
        seed: a.seed,
        ..RenderSettings::default()
    };
    settings
        .validate()
        .and_then(|()| camera.validate())
        .map_err(|e| Failure::Input(format!("{}: {e}", scene.source.file)))?;
    if scene
        .object
        .solids
        .iter()
        .any(|s| s.body.contains(camera.position))
    {
        return Err(Failure::Input(format!(
            "{}: --camera: the camera position {} lies inside a solid cell",
            scene.source.file, camera.position
        )));
    }
    set_threads(a.threads)?;
    let (img, losses) = roks::render::render_object(&scene, &camera, &settings);
    if losses.unmodelled > 0 {
        return Err(Failure::Input(format!(
            "{}: walls: {} camera paths hit a surface without a model in [walls]",
            scene.source.file, losses.unmodelled
        )));
    }
    let paths = (settings.width * settings.height) as u64 * u64::from(settings.spp);
    write_images(&a.out, &img, losses.lost, paths)
}

/// Write `img` as OUT (EXR) and OUT.png (preview), and report the mean and
/// the `lost` camera paths (caps, guards, edge walls, micro descents). Each
/// file is replaced atomically, the EXR first: a reader sees each old or
/// new, and for an instant (or after a kill between the two) a new EXR
/// beside the old PNG.
fn write_images(
    out: &Path,
    img: &roks::render::Image,
    lost: u64,
    paths: u64,
) -> Result<(), Failure> {
    if lost > 0 {
        eprintln!(
            "roks: render: {lost} of {paths} camera paths lost (bounce cap, numerical guard, absorbing edge or micro descent); they add 0"
        );
    }
    use roks::render::{write_exr, write_png_preview};
    let exr = write_exr(img).map_err(|e| anyhow::anyhow!("{e}"))?;
    let png = write_png_preview(img).map_err(|e| anyhow::anyhow!("{e}"))?;
    let png_path = out.with_extension("png");
    for (path, bytes) in [(out, &exr), (png_path.as_path(), &png)] {
        write_file(path, bytes)?;
    }
    let mean = img.rgb.iter().map(|p| f64::from(p[0])).sum::<f64>() / img.rgb.len() as f64;
    eprintln!(
        "wrote {} and {} (mean radiance {mean:.4} of the disc's)",
        out.display(),
        png_path.display()
    );
    Ok(())
}

/// `roks export-mesh` of an object scene: its solid walls in a box.
fn export_object_mesh(a: &ExportMeshArgs, path: &Path) -> Result<(), Failure> {
    use roks::export::object_mesh::{MAX_VOXELS_PER_SIDE, object_mesh};
    let scene = ObjectScene::load(path)?;
    let Some(b) = a.bounds.as_ref().filter(|b| b.len() == 6) else {
        return Err(Failure::Input(format!(
            "{}: --bounds: an object scene needs the box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX to mesh",
            scene.source.file
        )));
    };
    let resolution = a.resolution.unwrap_or(512);
    if !(1..=MAX_VOXELS_PER_SIDE).contains(&resolution) {
        return Err(Failure::Input(format!(
            "--resolution: must be in 1..={MAX_VOXELS_PER_SIDE} for object scenes, got {resolution}"
        )));
    }
    let lo = glam::DVec3::new(b[0], b[1], b[2]);
    let hi = glam::DVec3::new(b[3], b[4], b[5]);
    if lo.is_finite() && hi.is_finite() && (hi - lo).min_element() > 0.0 {
        let bytes = roks::export::object_mesh::memory_bytes(lo, hi, resolution);
        let what = format!("the voxel grid of resolution {resolution} over --bounds");
        check_memory("--resolution", &what, bytes)?;
    }
    check_out_file(&a.out)?;
    let mesh = object_mesh(&scene.object, lo, hi, resolution)
        .map_err(|e| Failure::Input(format!("{}: --bounds: {e}", scene.source.file)))?;
    if mesh.faces.is_empty() {
        return Err(Failure::Input(format!(
            "{}: --bounds: no solid wall inside the box {lo} .. {hi}",
            scene.source.file
        )));
    }
    write_file(&a.out, &roks::export::write_ply(&mesh))?;
    eprintln!(
        "wrote {} ({} vertices, {} triangles: the solid walls of {} in the box)",
        a.out.display(),
        mesh.vertices.len(),
        mesh.faces.len(),
        scene.name
    );
    Ok(())
}

fn stats(a: StatsArgs) -> Result<(), Failure> {
    let scene = load_scene(a.scene.as_deref())?;
    let (r, ry) = stats_grid(&scene, a.resolution, 1024, "--resolution")?;
    let s = surface_stats(&scene.surface.height_map(r, ry));
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
    let _ = writeln!(out, "scene            {}", scene.source.file);
    let _ = writeln!(
        out,
        "cell             {} x {} ({:?} edges)",
        size.x, size.y, scene.surface.edges
    );
    let _ = writeln!(out, "height map       {r} x {ry}");
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

/// Write `text` to standard output; a closed pipe (`roks stats | head`) is a
/// clean end, not an error.
fn print_stdout(text: &str) -> Result<(), Failure> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::Other(
            anyhow::anyhow!("cannot write to standard output: {e}"),
        )),
        _ => Ok(()),
    }
}
