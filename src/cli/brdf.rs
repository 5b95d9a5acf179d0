//! `roks brdf`: the tabulated BRDF of a micro scene, a whole run or one
//! block of it (`--shard I/N`), and its result folder.

use std::path::PathBuf;

use clap::{ArgAction, Args};

use super::Failure;
use super::common::{TracingArgs, progress_bar, result_dir, set_threads, stats_grid, write_folder};
use super::parse::{integer, number};
use crate::export::brdf_formats::BrdfFormat;
use crate::micro::surface_stats::surface_stats;
use crate::output::brdf_folder::BrdfFolder;
use crate::output::summary::{Description, Surface};
use crate::scene::WavelengthsSpec;
use crate::scene::micro::{MicroScene, Overrides};
use crate::shard::Shard;
use crate::tally::{PolarTally, Symmetry};
use crate::transport::brdf::{IncidenceResult, ShardRange};
use crate::transport::launch::Launch;

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
    #[arg(long, value_parser = super::parse::wavelengths, allow_negative_numbers = true)]
    pub wavelengths: Option<WavelengthsSpec>,
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
        super::common::load_scene_with(self.scene.as_deref(), &self.overrides())
    }
}

/// Run `roks brdf`.
///
/// # Errors
/// Bad input (scene, options, memory), or a failed write.
pub fn execute(a: BrdfArgs) -> Result<(), Failure> {
    let scene = a.scene()?;
    let mut run = scene.brdf_run();
    crate::export::folder::check_run(&a.export, &run)?;
    let (rx, ry) = stats_grid(
        &scene,
        a.stats_resolution,
        super::common::STATS_RESOLUTION,
        "--stats-resolution",
    )?;
    if let Some(s) = a.shard {
        let (first_photon, last_photon) = s
            .photon_range(run.photons)
            .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
        run.shard = Some(ShardRange {
            count: s.count,
            first_photon,
            index: s.index,
            last_photon,
        });
    }
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
            "{} incidence angles x {} light azimuths, {} photons each{}",
            run.theta_deg.len(),
            run.phi_deg.len(),
            run.photons,
            run.shard.map_or(String::new(), |s| format!(
                ", shard {}/{}",
                s.index, s.count
            ))
        );
        super::common::report_check(&scene.scene_file.file, &what, a.quiet);
        return Ok(());
    }

    let map = scene.surface.height_map(rx, ry);
    let stats = surface_stats(&map);
    let surface = super::plot::surface_png(&scene, &map, &stats)?;
    drop(map);
    let photons = run.photon_range();
    let description = Description::new(
        scene.content.clone(),
        &scene.scene_file.file,
        &scene.name,
        scene.surface.edges,
        run,
        Surface::new(&stats, rx),
    );
    let per_angle = photons.end - photons.start;
    let bar = progress_bar(
        per_angle.saturating_mul(
            (description.run.theta_deg.len() * description.run.phi_deg.len()) as u64,
        ),
        a.quiet,
        &scene.name,
    );
    let clock = std::time::Instant::now();
    let results = description
        .run
        .trace_realisations(&scene.surfaces(), photons, &|n| bar.inc(n));
    let folder = BrdfFolder::traced(description, results, clock.elapsed().as_secs_f64());
    bar.finish_and_clear();

    let comment = format!("scene {}, {per_angle} photons per angle", scene.name);
    let exports =
        crate::export::folder::export_folder(&folder, &a.export, &comment, &scene.surfaces())?;
    for line in exports.notices.iter().filter_map(|n| n.line(a.quiet)) {
        eprintln!("{line}");
    }
    let mut files = folder.files(exports.named_files());
    crate::plot::folder::add_pictures(&mut files).map_err(anyhow::Error::msg)?;
    files.push(("surface.png".into(), surface));
    write_folder(&out, &files, "brdf")?;

    if !a.quiet {
        print_results(&folder, Some(scene.random));
        eprintln!("wrote {} ({:.1} s)", out.display(), folder.seconds);
    }
    Ok(())
}

/// The table of results per incidence angle (and light azimuth, with
/// several), on stderr (also `roks merge`); with several azimuths, the
/// anisotropy figure ([`crate::tally::anisotropy`]) after it.
pub fn print_table(folder: &BrdfFolder) {
    print_results(folder, None);
}

/// [`print_table`] of a run whose surface is known to be random or not
/// (`random`, [`crate::scene::micro::MicroScene::random`]; `None`:
/// unknown, as for merged shards): the anisotropy figure of a table that
/// is anisotropic beyond its bound then says what that means
/// ([`anisotropy_note`]).
pub fn print_results(folder: &BrdfFolder, random: Option<bool>) {
    let results = &folder.results;
    let azimuths = folder.run().phi_deg.len() > 1;
    let spectral = results.iter().any(|r| r.wavelength_um.is_some());
    let lambda = |r: &IncidenceResult| {
        let mut s = String::new();
        if azimuths {
            s += &format!(" {:>7}", r.phi_i_deg);
        }
        if let Some(w) = r.wavelength_um {
            s += &format!(" {w:>8}");
        }
        s
    };
    let columns = format!(
        "{}{}",
        if azimuths { "   phi_i" } else { "" },
        if spectral { "  lambda_um" } else { "" }
    );
    eprintln!(
        "{:>9}{} {:>12} {:>10} {:>8} {:>9} {:>12}",
        "theta_i", columns, "reflectance", "stderr", "bounces", "lost", "Msegments/s"
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
    // Several surface realisations: their spread beside the photon noise.
    if results.iter().any(|r| r.realisations.len() > 1) {
        eprintln!(
            "{:>9}{} {:>12} {:>14} {:>14}  ({} realisations)",
            "theta_i",
            columns,
            "spread",
            "surface_spread",
            "monte_carlo",
            results
                .iter()
                .map(|r| r.realisations.len())
                .max()
                .unwrap_or(0)
        );
        for r in results {
            if let Some(s) = crate::output::summary::RealisationsSummary::new(&r.realisations) {
                eprintln!(
                    "{:>9.2}{} {:>12.2e} {:>14.2e} {:>14.2e}",
                    r.theta_i_deg,
                    lambda(r),
                    s.spread,
                    s.surface_spread,
                    s.monte_carlo_spread
                );
            }
        }
    }
    if let Some(a) = results.anisotropy(&folder.run().grid()) {
        let f = &a.figure;
        eprintln!(
            "anisotropy: chi2/dof {:.3} over {} cells of {} pairs of azimuths (isotropic within 4 sigma below {:.3}; p = {:.2e})",
            f.chi2_dof, f.dof, a.pair_count, f.bound, f.p_value
        );
        if let Some(note) = anisotropy_note(f, folder.run().realisations, random) {
            eprintln!("anisotropy: {note}");
        }
    }
}

/// What an anisotropy figure `f` beyond its bound means for a run of
/// `realisations` surface realisations of a surface that is random or not
/// (`random`; `None`: unknown): one realisation of a random surface is
/// anisotropic by nature (its own hills and valleys do not turn with the
/// light), and the random surface's BRDF is the mean over realisations;
/// an ensemble is judged with its own errors. `None` within the bound, and
/// for a surface known not to be random (its anisotropy is the surface's).
#[must_use]
pub fn anisotropy_note(
    f: &crate::tally::anisotropy::Figure,
    realisations: u64,
    random: Option<bool>,
) -> Option<String> {
    if f.isotropic() || random == Some(false) {
        return None;
    }
    let what = "one realisation of a random surface is anisotropic by nature (its own hills and valleys do not turn with the light), while the random surface's BRDF is the mean over realisations";
    let advice = "set [surface] realisations = R (16 or more; the tables' errors are then the ensemble's) and judge the ensemble";
    Some(match (realisations, random) {
        (1, Some(true)) => format!("{what}: {advice}"),
        (1, _) => format!(
            "if the surface is random (a gaussian height field, random bumps), {what}: {advice}"
        ),
        (r, _) => format!(
            "beyond the bound with the errors of the mean over {r} realisations: the random surface itself is anisotropic (a height field's triangles turn onto themselves only by half turns), or the realisations are too few to average its hills and valleys"
        ),
    })
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
        match args(a).scene() {
            Err(Failure::Input(m)) => m,
            other => panic!("{a:?}: {other:?}"),
        }
    }

    /// The default scene with a Fresnel material (so that polarised
    /// transport is on by default).
    fn fresnel_text() -> String {
        crate::scene::micro::DEFAULT_SCENE.replace("reflectance = 0.8", "n = 1.5\nk = 0.1")
    }

    /// [`fresnel_text`] with `[section] key = value`.
    fn with_key(section: &str, key: &str, value: toml::Value) -> MicroScene {
        let mut t: toml::Table = fresnel_text().parse().unwrap();
        t.entry(section)
            .or_insert_with(|| toml::Table::new().into())
            .as_table_mut()
            .unwrap()
            .insert(key.into(), value);
        let scene_file = crate::scene::SceneFile {
            file: "<default scene>".into(),
            dir: ".".into(),
        };
        MicroScene::from_str(&toml::to_string(&t).unwrap(), scene_file, "default".into()).unwrap()
    }

    /// Bits of a value through its JSON form (shortest round-trip floats:
    /// distinct bits, distinct text).
    fn bits<T: serde::Serialize>(x: &T) -> String {
        serde_json::to_string(x).unwrap()
    }

    /// Every option that overrides a scene key gives the run (and, traced,
    /// the tallies) of the scene with that key, bit for bit.
    #[test]
    fn every_option_is_its_scene_key() {
        use toml::Value as V;
        let list = |xs: &[f64]| V::Array(xs.iter().map(|&x| V::Float(x)).collect());
        let mut grid = toml::Table::new();
        grid.insert("from".into(), V::Float(0.4));
        grid.insert("to".into(), V::Float(0.6));
        grid.insert("step".into(), V::Float(0.1));
        let cases: Vec<(Vec<&str>, &str, &str, V)> = vec![
            (
                vec!["--photons", "5000"],
                "light",
                "photons",
                V::Integer(5000),
            ),
            (vec!["--seed", "9"], "light", "seed", V::Integer(9)),
            (
                vec!["--theta", "0,45"],
                "light",
                "theta_deg",
                list(&[0.0, 45.0]),
            ),
            (vec!["--phi", "30"], "light", "phi_deg", V::Float(30.0)),
            (
                vec!["--phi", "0,90,45"],
                "light",
                "phi_deg",
                list(&[0.0, 90.0, 45.0]),
            ),
            (
                vec!["--wavelengths", "0.45,0.55"],
                "light",
                "wavelengths_um",
                list(&[0.45, 0.55]),
            ),
            (
                vec!["--wavelengths", "0.4:0.6:0.1"],
                "light",
                "wavelengths_um",
                V::Table(grid),
            ),
            (
                vec!["--launch", "lattice"],
                "light",
                "launch",
                V::String("lattice".into()),
            ),
            (
                vec!["--symmetry", "mirror"],
                "tally",
                "symmetry",
                V::String("mirror".into()),
            ),
            (
                vec!["--polarisation", "stokes"],
                "tally",
                "polarisation",
                V::String("stokes".into()),
            ),
            (
                vec!["--no-polarisation"],
                "transport",
                "polarisation",
                V::Boolean(false),
            ),
        ];
        let dir = std::env::temp_dir().join(format!("roks-options-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("fresnel.toml");
        std::fs::write(&file, fresnel_text()).unwrap();
        let path = file.to_str().unwrap();
        let plain = args(&[path]).scene().unwrap().run;
        assert!(plain.polarisation.transport);
        for (options, section, key, value) in cases {
            let by_option = args(&[&[path], &options[..]].concat()).scene().unwrap();
            let by_key = with_key(section, key, value);
            assert_eq!(bits(&by_option.run), bits(&by_key.run), "{options:?}");
            assert_ne!(
                bits(&by_option.run),
                bits(&plain),
                "{options:?} changes nothing"
            );
            // Traced (a few photons at one angle), the same tallies.
            let trace = |scene: &MicroScene| {
                let mut run = scene.brdf_run();
                run.photons = 64;
                run.theta_deg.truncate(1);
                run.bands = 4;
                run.trace_whole(&scene.surface, &|_| {})
            };
            let (a, b) = (trace(&by_option), trace(&by_key));
            assert_eq!(a.len(), b.len());
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(bits(&x.tallies), bits(&y.tallies), "{options:?}");
            }
        }
        // No option: the scene's own run; formats each once, in the order
        // given, names in any case; the shard's block.
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            bits(&args(&[]).scene().unwrap().run),
            bits(&MicroScene::default_scene().run)
        );
        assert_eq!(
            args(&["--export", "MERL,zemax"]).export,
            [BrdfFormat::Merl, BrdfFormat::Zemax]
        );
        assert_eq!(
            args(&["--shard", "1/4"]).shard,
            Some(Shard { index: 1, count: 4 })
        );
        let stokes = args(&["--polarisation", "stokes"]).scene().unwrap().run;
        assert_eq!(stokes.polarisation.tally, PolarTally::Stokes);
        assert!(stokes.polarisation.transport);
        let mirror = args(&["--symmetry", "mirror", "--launch", "lattice"])
            .scene()
            .unwrap()
            .run;
        assert_eq!(
            (mirror.symmetry, mirror.launch),
            (Symmetry::Mirror, Launch::Lattice)
        );
    }

    #[test]
    fn options_are_checked_as_the_scene_keys_they_override() {
        assert_eq!(
            refusal(&["--theta", "95"]),
            "--theta: angle 1: must be in [0, 90), got 95"
        );
        assert_eq!(
            refusal(&["--theta", "10,20,10"]),
            "--theta: angle 3: 10 is given twice (each incidence angle once: a BRDF table holds one block per angle)"
        );
        assert_eq!(
            refusal(&["--phi", "0,360"]),
            "--phi: azimuth 2: must be in [0, 360), got 360"
        );
        assert_eq!(
            refusal(&["--phi", "90,0,90"]),
            "--phi: azimuth 3: 90 is given twice (each light azimuth once: a BRDF table holds one block per incidence and azimuth)"
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
        assert_eq!(
            refusal(&["--wavelengths", "0.5,0.4"]),
            "--wavelengths: wavelength 2: 0.4 um is not greater than the previous 0.5 um (wavelengths strictly increasing)"
        );
        assert_eq!(
            refusal(&["--wavelengths", "0.6:0.4:0.1"]),
            "--wavelengths: needs finite from <= to, got 0.6 and 0.4"
        );
    }
}
