//! `roks brdf`: the tabulated BRDF of a micro scene, a whole run or one
//! block of it (`--shard I/N`), and its result folder.

use std::path::PathBuf;

use clap::Args;

use super::Failure;
use super::args::RunArgs;
use super::common::{
    load_scene_at, progress_bar, result_dir, set_threads, stats_grid, write_folder,
};
use super::export_brdf::export_tables;
use super::parse::{integer, number};
use crate::export::brdf_formats::BrdfFormat;
use crate::micro::surface_stats::surface_stats;
use crate::output::brdf_folder::BrdfFolder;
use crate::output::summary::Surface;
use crate::output::tallies::Settings;
use crate::scene::micro::MicroScene;
use crate::shard::Shard;
use crate::tally::{PolarTally, Symmetry};
use crate::transport::brdf::{BrdfRun, IncidenceResult, Polarisation, check_incidence};
use crate::transport::launch::{Launch, check_photons};

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
    pub run: RunArgs,
    /// Incidence angles in degrees, comma-separated (overrides [light] theta_deg).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = number)]
    pub theta: Option<Vec<f64>>,
    /// Wavelengths in um, carried by every photon (overrides [light]
    /// wavelengths_um): comma-separated (0.45,0.55,0.65) or FROM:TO:STEP
    /// (0.38:0.78:0.01). Results get a wavelength_um column.
    #[arg(long, value_parser = super::parse::wavelengths, allow_negative_numbers = true)]
    pub wavelengths: Option<super::parse::Wavelengths>,
    /// Entry points (overrides [light] launch): random, or lattice (16
    /// randomly shifted R2 lattices; standard errors from their spread;
    /// photons a multiple of 16).
    #[arg(long)]
    pub launch: Option<Launch>,
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
    /// 0.38-0.78 um); see `roks export-brdf`.
    #[arg(
        long,
        value_delimiter = ',',
        ignore_case = true,
        hide_possible_values = true
    )]
    pub export: Vec<BrdfFormat>,
    /// No progress bar and no table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

impl BrdfArgs {
    /// The BRDF run of `scene` with these options applied. Each value is
    /// checked by the check the scene loader applies to the key it
    /// overrides, the message naming the option.
    ///
    /// # Errors
    /// Bad input naming the option (or the scene file, for memory).
    pub fn apply(&self, scene: &MicroScene) -> Result<BrdfRun, Failure> {
        let mut run = scene.brdf_run();
        if let Some(p) = self.run.photons {
            run.photons = p;
        }
        if let Some(s) = self.run.seed {
            run.seed = s;
        }
        if let Some(l) = self.launch {
            run.launch = l;
        }
        if let Some(s) = self.symmetry {
            run.symmetry = s;
        }
        if self.polarisation.is_some() || self.no_polarisation || self.symmetry.is_some() {
            let tally = self.polarisation.unwrap_or(scene.tally.polarisation);
            let transport = if self.no_polarisation {
                Some(false)
            } else {
                scene.transport.polarisation
            };
            run.polarisation = Polarisation::resolve(
                scene.has_fresnel(),
                transport,
                run.polarisation.incident,
                tally,
                run.symmetry,
            )
            .map_err(|(key, e)| {
                let option = match key {
                    "tally.symmetry" => "--symmetry",
                    _ if self.no_polarisation => "--no-polarisation",
                    _ => "--polarisation",
                };
                Failure::Input(format!("{option}: {e}"))
            })?;
        }
        check_photons(run.launch, run.photons)
            .map_err(|e| Failure::Input(format!("--photons: {e}")))?;
        if let Some(t) = &self.theta {
            check_incidence(t).map_err(|(_, e)| Failure::Input(format!("--theta: {e}")))?;
            run.theta_deg.clone_from(t);
        }
        scene.check_run_memory(&run)?;
        for f in &self.export {
            f.check_wavelengths(&run.wavelengths_um)
                .map_err(|e| Failure::Input(format!("--export {f}: {e}")))?;
        }
        Ok(run)
    }
}

/// Run `roks brdf`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn run(a: BrdfArgs) -> Result<(), Failure> {
    let scene = load_scene_at(
        a.scene.as_deref(),
        a.wavelengths.as_ref().map(|w| w.0.as_slice()),
    )?;
    let run = a.apply(&scene)?;
    let (rx, ry) = stats_grid(&scene, a.stats_resolution, 512, "--stats-resolution")?;
    let range = a
        .shard
        .map(|s| s.photon_range(run.photons))
        .transpose()
        .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
    set_threads(a.run.threads)?;
    let out = result_dir(a.run.out.as_deref(), &scene.source.file, &scene.name)?;

    let map = scene.surface.height_map(rx, ry);
    let stats = surface_stats(&map);
    let surface = super::plot::surface_png(&scene, &map, &stats)?;
    drop(map);
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
    let folder = BrdfFolder::trace(&scene.surface, run, settings, a.shard, &|n| bar.inc(n))
        .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
    bar.finish_and_clear();

    let mut extra = Vec::new();
    if !a.export.is_empty() {
        let table = folder.table();
        let comment = format!(
            "scene {}, {} photons per angle",
            scene.name, folder.run.photons
        );
        for (k, &f) in a.export.iter().enumerate() {
            // Each format once, in the order given.
            if !a.export[..k].contains(&f) {
                for file in export_tables(&table, f, &comment, a.quiet, "--export")? {
                    extra.push((file.file_name, file.bytes));
                }
            }
        }
    }
    let mut files = folder.files(extra);
    crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
    files.push(("surface.png".into(), surface));
    write_folder(&out, &files)?;

    if !a.quiet {
        print_table(&folder.results);
        eprintln!("wrote {} ({:.1} s)", out.display(), folder.seconds);
    }
    Ok(())
}

/// The table of results per incidence angle, on stderr (also `roks merge`).
pub fn print_table(results: &[IncidenceResult]) {
    let spectral = results.iter().any(|r| r.wavelength_um.is_some());
    let lambda = |r: &IncidenceResult| match r.wavelength_um {
        Some(w) => format!(" {w:>8}"),
        None => String::new(),
    };
    eprintln!(
        "{:>9}{} {:>12} {:>10} {:>8} {:>9} {:>12}",
        "theta_i",
        if spectral { "  lambda_um" } else { "" },
        "reflectance",
        "stderr",
        "bounces",
        "lost",
        "Msegments/s"
    );
    for r in results {
        let (refl, se) = r.reflectance();
        eprintln!(
            "{:>9.2}{} {:>12.6} {:>10.2e} {:>8.3} {:>9.2e} {:>12.2}",
            r.theta_i_deg,
            lambda(r),
            refl,
            se,
            r.mean_bounces(),
            r.lost(),
            r.segments_per_second() / 1e6
        );
    }
}

#[cfg(test)]
mod tests {
    use clap::FromArgMatches;

    use super::*;
    use crate::cli::args::{Cli, Command};

    /// The options of `roks brdf ARGS` (no scene: the default scene).
    fn args(args: &[&str]) -> BrdfArgs {
        let m = crate::cli::messages::command::<Cli>()
            .try_get_matches_from(["roks", "brdf"].iter().chain(args))
            .unwrap();
        match Cli::from_arg_matches(&m).unwrap().command {
            Command::Brdf(a) => a,
            other => panic!("{other:?}"),
        }
    }

    /// The message of the options' refusal.
    fn refusal(a: &[&str]) -> String {
        match args(a).apply(&MicroScene::default_scene()) {
            Err(Failure::Input(m)) => m,
            other => panic!("{a:?}: {other:?}"),
        }
    }

    #[test]
    fn options_override_the_scene() {
        let scene = MicroScene::default_scene();
        // No options: the scene's run.
        assert_eq!(
            format!("{:?}", args(&[]).apply(&scene).unwrap()),
            format!("{:?}", scene.brdf_run())
        );
        let run = args(&[
            "--photons",
            "4096",
            "--seed",
            "9",
            "--theta",
            "0,45",
            "--launch",
            "lattice",
            "--symmetry",
            "mirror",
        ])
        .apply(&scene)
        .unwrap();
        assert_eq!(run.photons, 4096);
        assert_eq!(run.seed, 9);
        assert_eq!(run.theta_deg, [0.0, 45.0]);
        assert_eq!(run.launch, Launch::Lattice);
        assert_eq!(run.symmetry, Symmetry::Mirror);
        let stokes = args(&["--polarisation", "stokes"]).apply(&scene).unwrap();
        assert_eq!(stokes.polarisation.tally, PolarTally::Stokes);
        assert!(stokes.polarisation.transport);
        // Formats each once, in the order given; names in any case.
        assert_eq!(
            args(&["--export", "MERL,zemax"]).export,
            [BrdfFormat::Merl, BrdfFormat::Zemax]
        );
        assert_eq!(
            args(&["--shard", "1/4"]).shard,
            Some(Shard { index: 1, count: 4 })
        );
    }

    #[test]
    fn options_are_checked_as_the_scene_keys_they_override() {
        assert_eq!(
            refusal(&["--theta", "95"]),
            "--theta: must be in [0, 90), got 95"
        );
        assert_eq!(
            refusal(&["--theta", "10,20,10"]),
            "--theta: 10 is given twice (each incidence angle once: a BRDF table holds one block per angle)"
        );
        assert_eq!(
            refusal(&["--photons", "9007199254740993"]),
            "--photons: must be at most 2^53 = 9007199254740992 (the f64 tallies cannot count more exactly), got 9007199254740993"
        );
        assert_eq!(
            refusal(&["--photons", "100", "--launch", "lattice"]),
            "--photons: must be a multiple of 16 with launch = \"lattice\", got 100"
        );
        assert_eq!(
            refusal(&["--no-polarisation", "--polarisation", "mueller"]),
            "--no-polarisation: `mueller` needs polarised transport, but [transport] polarisation = false"
        );
    }
}
