//! `roks trace`: trace an object scene (the macro level) and write its
//! result folder: summary.json, reflectance.csv and its plot, and the far
//! field when the scene tallies it; with `--shard I/N` one block of the
//! run's batches, its `summary.json` and `tallies.json`, for `roks merge`
//! ([`crate::output::object_tallies`]).

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use super::Failure;
use super::common::{TracingArgs, progress_bar, result_dir, set_threads, write_folder};
use crate::output::object_tallies::{self, TraceDescription, TraceTalliesFile};
use crate::scene::object::ObjectScene;
use crate::shard::Shard;
use crate::transport::BATCH;
use crate::transport::object::{ObjectResult, ObjectRun};

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
    #[arg(long, value_parser = super::parse::wavelengths, allow_negative_numbers = true)]
    pub wavelengths: Option<crate::scene::WavelengthsSpec>,
    /// Trace only block I of N of the run (0-based): whole batches of 4096
    /// photons of the beam positions laid end to end. The folder holds
    /// summary.json (this block's sums) and tallies.json, for `roks merge`.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
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
    let scene = ObjectScene::load_at(&a.scene, a.wavelengths.as_ref()).map_err(|e| {
        let keys = [("light.wavelengths_um", "--wavelengths")];
        match crate::scene::option_error(&keys[..usize::from(a.wavelengths.is_some())], &e) {
            Some((option, message)) => Failure::Input(format!("{option}: {message}")),
            None => e.into(),
        }
    })?;
    let mut run = scene.run.clone();
    let mut photons = scene.photons.clone();
    if let Some(p) = a.tracing.photons {
        // The scene loader's check of `sources[i].photons`.
        crate::transport::launch::check_count(p)
            .map_err(|e| Failure::Input(format!("--photons: {e}")))?;
        photons.iter_mut().for_each(|n| *n = p);
    }
    if let Some(s) = a.tracing.seed {
        run.seed = s;
    }
    if a.no_polarisation {
        if run.farfield_stokes {
            return Err(Failure::Input(format!(
                "{}: tally.polarisation: \"stokes\" needs polarised transport, which --no-polarisation turns off",
                scene.scene_file.file
            )));
        }
        run.polarisation = false;
    }
    let description = TraceDescription::new(
        &scene.content,
        &scene.scene_file.file,
        &scene.name,
        &scene.object.surface_names,
        &run,
        &scene.beams,
        &photons,
        a.shard,
    );
    let blocks = description
        .blocks()
        .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
    set_threads(a.tracing.threads)?;
    let out = result_dir(
        a.tracing.out.as_deref(),
        &scene.scene_file.file,
        &scene.name,
        &scene.reads,
        a.tracing.force,
    )?;
    if a.tracing.check {
        let what = format!(
            "{} beam positions{}",
            photons.len(),
            a.shard.map_or(String::new(), |s| format!(
                ", shard {}/{}",
                s.index, s.count
            ))
        );
        super::common::report_check(&scene.scene_file.file, &what, a.quiet);
        return Ok(());
    }
    let traced = blocks.iter().zip(&photons).fold(0, |s: u64, (b, &n)| {
        s.saturating_add(((b.end * BATCH).min(n)).saturating_sub(b.start * BATCH))
    });
    let bar = progress_bar(traced, a.quiet, &scene.name);
    let clock = Instant::now();
    let nodes = run.run_nodes(
        &scene.object,
        &scene.walls,
        &scene.models,
        &scene.beams,
        &photons,
        &blocks,
        &|n| bar.inc(n),
    );
    bar.finish_and_clear();
    let seconds = clock.elapsed().as_secs_f64();
    let n_surfaces = scene.object.surface_names.len();
    let (result, tallies) = if a.shard.is_some() {
        let result = object_tallies::partial_results(&description, &nodes);
        // The file lists the leaves in order: position, then wavelength.
        let nodes = nodes.into_iter().flatten().collect();
        let file = TraceTalliesFile::new(&description, nodes, seconds);
        (result, Some(file))
    } else {
        let result = ObjectResult::roots(nodes, &|| run.tallies(n_surfaces));
        (result, None)
    };

    // A photon met a wall without a model: a scene error, before any output.
    if let Some(r) = result.iter().find(|r| r.tallies.unmodelled.0 > 0) {
        let name = &scene.object.surface_names[r.tallies.unmodelled.1];
        return Err(Failure::Input(format!(
            "{}: walls.{name}: photons hit surface `{name}` ({} of them from beam position {}), which has no model in [walls]",
            scene.scene_file.file, r.tallies.unmodelled.0, r.beam.position
        )));
    }
    if let Some((k, r)) = result
        .groups()
        .enumerate()
        .find_map(|(k, lanes)| Some((k, lanes.iter().find(|r| r.tallies.started_inside > 0)?)))
    {
        return Err(Failure::Input(format!(
            "{}: sources[{}].beam.diameter: {} photons of beam position {} started inside a solid cell",
            scene.scene_file.file, scene.beam_source[k], r.tallies.started_inside, r.beam.position
        )));
    }
    let shard = tallies.is_some();
    let mut files = description.folder(&result, seconds, tallies);
    if !shard {
        crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
    }
    write_folder(&out, &files, "trace")?;

    if !a.quiet {
        print_table(&run, &result);
        eprintln!("wrote {} ({seconds:.1} s)", out.display());
    }
    Ok(())
}

/// The table of results per beam position, on stderr (a spectral run:
/// per position and wavelength; a shard: the positions it traced).
pub(super) fn print_table(run: &ObjectRun, result: &ObjectResult) {
    let spectral = !run.wavelengths_um.is_empty();
    eprintln!(
        "{:>28}{} {:>12} {:>10} {:>9} {:>8} {:>9}",
        "beam position",
        if spectral { "  wavelength_um" } else { "" },
        "reflectance",
        "stderr",
        "missed",
        "bounces",
        "lost"
    );
    for r in result.iter().filter(|r| r.tallies.photons > 0) {
        let (refl, se) = r.reflectance();
        let n = r.tallies.photons as f64;
        let p = r.beam.position;
        eprintln!(
            "{:>28}{} {:>12.4e} {:>10.2e} {:>9.4} {:>8.3} {:>9.2e}",
            format!("({:.3}, {:.3}, {:.3})", p.x, p.y, p.z),
            r.wavelength_um
                .map_or_else(String::new, |w| format!(" {w:>14}")),
            refl,
            se,
            r.tallies.missed / n,
            r.tallies.bounces as f64 / n,
            r.tallies.lost / n
        );
    }
}
