//! `roks brdf`: the tabulated BRDF of a micro scene, a whole run or one
//! block of it (`--shard I/N`), and its result folder.

use std::path::PathBuf;

use clap::{ArgAction, Args};

use super::Failure;
use super::common::{TracingArgs, progress_bar, report_check};
use crate::api::values::{integer, number, wavelengths};
use crate::api::{BrdfJob, BrdfOptions, BrdfReport, MicroScene, Overrides, Shard, WavelengthsSpec};
use crate::export::exporter::BrdfFormat;
use crate::outdir::{check::result_dir, write::write_folder};
use crate::tally::{PolarTally, Symmetry};
use crate::transport::launch::Launch;
use crate::transport::wavefront::Kernel;

/// The options of `roks brdf`.
#[derive(Args, Debug)]
#[command(
    mut_arg("photons", |a| a.help("Photons per incidence angle (overrides [light] photons)")),
    mut_arg("seed", |a| a.help("Tracing seed (overrides [light] seed). Same seed, same result, for any thread count")),
)]
pub struct BrdfArgs {
    /// Micro scene file (TOML); omitted: the embedded default scene.
    pub scene: Option<PathBuf>,
    /// The result folder, photons per incidence angle, seed and threads.
    #[command(flatten)]
    pub tracing: TracingArgs,
    /// Incidence angles in degrees, comma-separated (overrides [light] theta_deg).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = number, action = ArgAction::Set)]
    pub theta: Option<Vec<f64>>,
    /// Light azimuths in degrees, comma-separated, each in [0, 360) (overrides
    /// [light] phi_deg): every incidence angle is traced at each, and every
    /// result file gains the azimuth.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = number, action = ArgAction::Set)]
    pub phi: Option<Vec<f64>>,
    /// Wavelengths in um, carried by every photon (overrides [light]
    /// wavelengths_um): comma-separated (0.45,0.55,0.65) or FROM:TO:STEP
    /// (0.38:0.78:0.01). Results get a wavelength_um column.
    #[arg(long, value_parser = wavelengths, allow_negative_numbers = true)]
    pub wavelengths: Option<WavelengthsSpec>,
    /// Entry points (overrides [light] launch): random, or lattice (16
    /// randomly shifted R2 lattices; standard errors from their spread;
    /// photons a multiple of 16).
    #[arg(long)]
    pub launch: Option<Launch>,
    /// The kernel that traces the histories: scalar (one photon at a time)
    /// or wavefront (a wave of photons stage by stage, in SIMD lanes); both
    /// give the same bits.
    #[arg(long, default_value = "scalar")]
    pub kernel: Kernel,
    /// Fold mirror images in the plane of incidence into the Carlson cells
    /// (overrides [tally] symmetry): none, or mirror (only for surfaces whose
    /// statistics are mirror symmetric; halves the variance off the plane).
    #[arg(long)]
    pub symmetry: Option<Symmetry>,
    /// Polarisation tally (overrides [tally] polarisation): none, stokes
    /// (DIR/stokes.csv: the Stokes BRDF per cell for the incident state, and
    /// DIR/dop_<theta>deg.png) or mueller (DIR/mueller.csv: the Mueller-matrix
    /// BRDF per cell). Implies polarised transport.
    #[arg(long)]
    pub polarisation: Option<PolarTally>,
    /// The unpolarised approximation: the weight times (Rs + Rp)/2 at every
    /// Fresnel bounce (overrides [transport] polarisation; default: Stokes
    /// vectors through every bounce when a material is Fresnel).
    #[arg(long)]
    pub no_polarisation: bool,
    /// Height-map resolution for the surface statistics in the summary
    /// (default 512; a height field: its own grid).
    #[arg(long, value_parser = integer::<usize>)]
    pub stats_resolution: Option<usize>,
    /// Run only photon block I of N (0-based; whole batches of 4096 photons)
    /// of every incidence angle and also write DIR/tallies.json, the raw sums
    /// that `roks merge` adds up exactly.
    #[arg(long, value_name = "I/N", allow_hyphen_values = true)]
    pub shard: Option<Shard>,
    /// Also export the table, comma-separated formats: zemax (DIR/brdf.bsdf;
    /// spectral: DIR/brdf_<wavelength>um.bsdf per wavelength), merl
    /// (DIR/brdf.binary; spectral: linear sRGB, wavelengths covering
    /// 0.38-0.78 um), rgl (DIR/brdf_rgl.bsdf, Mitsuba 3 / pbrt-v4 `measured`),
    /// pbsdf (DIR/brdf.pbsdf, Mitsuba 3 `measured_polarized`; needs
    /// --polarisation mueller); see `roks export-brdf`.
    #[arg(
        long,
        value_delimiter = ',',
        ignore_case = true,
        hide_possible_values = true,
        action = ArgAction::Set
    )]
    pub export: Vec<BrdfFormat>,
    /// Also write DIR/report.html, the interactive report of the folder
    /// (as `roks report DIR` makes it).
    #[arg(long)]
    pub report: bool,
    /// No progress bar and no table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

impl BrdfArgs {
    /// The options that override scene keys, as one value.
    #[must_use]
    pub fn overrides(&self) -> Overrides {
        Overrides {
            photons: self.tracing.photons,
            seed: self.tracing.seed,
            theta_deg: self.theta.clone(),
            phi_deg: self.phi.clone(),
            wavelengths_um: self.wavelengths.clone(),
            launch: self.launch,
            symmetry: self.symmetry,
            polarisation_tally: self.polarisation,
            polarised_transport: self.no_polarisation.then_some(false),
        }
    }

    /// The scene (the embedded default without a file) with the overrides
    /// laid over its keys, built and checked once: an error at a key an
    /// option set names the option.
    ///
    /// # Errors
    /// Bad input naming the option or the scene file and key.
    pub fn scene(&self) -> Result<MicroScene, Failure> {
        Ok(crate::api::load_micro(
            self.scene.as_deref(),
            &self.overrides(),
        )?)
    }
}

/// Run `roks brdf`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: BrdfArgs) -> Result<(), Failure> {
    let mut scene = a.scene()?;
    scene.run.kernel = a.kernel;
    let run = scene.brdf_run();
    crate::export::folder::check_run(&a.export, &run)?;
    let options = BrdfOptions {
        shard: a.shard,
        stats_resolution: a.stats_resolution,
    };
    let job = BrdfJob::new(&scene, &options)?;
    crate::api::set_threads(a.tracing.threads)?;
    let file = &scene.scene_file.file;
    let out = result_dir(
        a.tracing.out.as_deref(),
        file,
        &scene.name,
        &scene.reads,
        a.tracing.force,
    )?;
    if a.tracing.check {
        report_check(file, &job.what(), a.quiet);
        return Ok(());
    }
    let photons = job.run().photon_range();
    let per_angle = photons.end - photons.start;
    let bar = progress_bar(job.photons(), a.quiet, &scene.name);
    let result = job.trace(&|n| bar.inc(n))?;
    bar.finish_and_clear();
    let folder = result.traced().expect("traced");
    let comment = crate::api::export_comment(&scene.name, per_angle);
    let exports =
        crate::export::folder::export_folder(folder, &a.export, &comment, &scene.surfaces())?;
    for line in exports.notices.iter().filter_map(|n| n.line(a.quiet)) {
        eprintln!("{line}");
    }
    let mut files = result.files(exports.named_files())?;
    if a.report {
        crate::report::add_brdf(&out, &mut files)?;
    }
    write_folder(&out, &files, "brdf")?;
    if !a.quiet {
        eprint!(
            "{}",
            BrdfReport {
                folder,
                random: result.random()
            }
        );
        eprintln!("wrote {} ({:.1} s)", out.display(), folder.seconds);
    }
    Ok(())
}
