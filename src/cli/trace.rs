//! `roks trace`: trace an object scene (the macro level) and write its
//! result folder: summary.json, reflectance.csv and its plot, and the far
//! field when the scene tallies it; with `--shard I/N` one block of the
//! run's batches, its `summary.json` and `tallies.json`, for `roks merge`
//! ([`crate::output::object_tallies`]).

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::common::{TracingArgs, progress_bar, report_check};
use crate::api::{Shard, TraceJob, TraceOptions, TraceReport, load_object};
use crate::outdir::{check::result_dir, write::write_folder};

/// The options of `roks trace`.
#[derive(Args, Debug)]
#[command(
    mut_arg("photons", |a| a.help("Photons per beam position (overrides each source's `photons`)")),
    mut_arg("seed", |a| a.help("Tracing seed (overrides the scene's `seed`)")),
)]
pub struct TraceArgs {
    /// Object scene file (TOML).
    pub scene: PathBuf,
    /// The result folder, photons per beam position, seed and threads.
    #[command(flatten)]
    pub tracing: TracingArgs,
    /// Scalar transport even with Fresnel walls: each Fresnel bounce weighs
    /// (Rs + Rp) / 2, the unpolarised approximation (as [transport]
    /// polarisation = false).
    #[arg(long)]
    pub no_polarisation: bool,
    /// Wavelengths in um, carried by every photon (overrides [light]
    /// wavelengths_um): comma-separated (3,8,12) or FROM:TO:STEP (3:14:0.5).
    /// Results get a wavelength_um column and summary.json a spectrum per
    /// source.
    #[arg(long, value_parser = crate::api::values::wavelengths, allow_negative_numbers = true)]
    pub wavelengths: Option<crate::scene::WavelengthsSpec>,
    /// Trace only block I of N of the run (0-based): whole batches of 4096
    /// photons of the beam positions laid end to end. The folder holds
    /// summary.json (this block's sums) and tallies.json, for `roks merge`.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Also write DIR/report.html, the interactive report of the folder
    /// (as `roks report DIR` makes it; not for a shard: report the merged
    /// folder).
    #[arg(long)]
    pub report: bool,
    /// No progress bar and no table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `roks trace`.
///
/// # Errors
/// Bad input (scene, options, photons meeting a wall without a model or
/// starting inside a solid), or a failed write.
pub fn execute(a: TraceArgs) -> Result<(), Failure> {
    let scene = load_object(&a.scene, a.wavelengths.as_ref())?;
    let options = TraceOptions {
        photons: a.tracing.photons,
        seed: a.tracing.seed,
        no_polarisation: a.no_polarisation,
        shard: a.shard,
    };
    if a.report && a.shard.is_some() {
        return Err(Failure::Input(
            "--report: not for a shard (its folder holds no reflectance.csv); report the folder of `roks merge`".into(),
        ));
    }
    let job = TraceJob::new(&scene, &options)?;
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
    let bar = progress_bar(job.photons(), a.quiet, &scene.name);
    let traced = job.trace(&|n| bar.inc(n));
    bar.finish_and_clear();
    let traced = traced?;
    let mut files = traced.files().to_vec();
    if a.report {
        crate::report::add_trace(&out, &mut files)?;
    }
    write_folder(&out, &files, "trace")?;
    if let (false, Some((run, result))) = (a.quiet, traced.traced()) {
        eprint!("{}", TraceReport { run, result });
        eprintln!(
            "wrote {} ({:.1} s)",
            out.display(),
            traced.summary().seconds
        );
    }
    Ok(())
}
