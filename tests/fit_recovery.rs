//! `roks fit` recovers a known parameter from synthetic data with
//! *independent* noise (a different seed for the "measurement" than for the
//! fit), as it must from a real measurement.
//!
//! The unit tests in src/fit.rs use the same seed for data and fit, so the
//! misfit is exactly 0 at the truth: they test the search and the pipeline
//! exactly. Here the misfit has a noise floor and the fitted value scatters.
//! Tolerance: over five other data seeds (201-205, same settings) the fitted
//! height was 1.785, 1.835, 1.863, 1.785, 1.832 (mean 1.820, standard deviation
//! 0.034); we ask 4 standard deviations, |h - 1.8| < 0.14, on an unused seed.
//! A fit that ignored the data, or a misfit with the wrong sign convention
//! for theta_o, lands at a bound or far off (the start is 1.0).

use roks::fit::{FitOptions, FitParam, Measured, fit};
use roks::output::inplane_csv::write as inplane_csv;
use roks::scene::SceneFile;
use roks::scene::micro::MicroScene;

fn scene(height: f64) -> String {
    format!(
        "[surface]\nsize = [12.0, 12.0]\nedges = \"periodic\"\nmaterial = \"m\"\n\
         [materials.m]\nreflectance = 0.8\n\
         [[bumps]]\nshape = \"ellipsoid\"\ncount = 20\nradius = 2.5\nheight = {height:?}\nseed = 3\n\
         [light]\ntheta_deg = [30.0, 60.0]\n\
         [tally]\ninplane_step_deg = 5.0\ninplane_width_deg = 10.0\n"
    )
}

fn scene_file() -> SceneFile {
    SceneFile {
        file: "fit-recovery.toml".into(),
        dir: ".".into(),
    }
}

#[test]
fn recovers_height_from_independent_synthetic_data() {
    // The "measurement": roks's in-plane BRDF of the true scene (h = 1.8),
    // 400 000 photons per angle, seed 1007.
    let truth = MicroScene::from_str(&scene(1.8), scene_file(), "truth".into()).unwrap();
    let mut run = truth.brdf_run();
    run.photons = 400_000;
    run.seed = 1007;
    let results = run.trace_whole(&truth.surface, &|_| {});
    let measured = Measured::parse(&inplane_csv(&run, &results), "truth/inplane.csv").unwrap();

    let params = vec!["bumps[0].height=0.5:3".parse::<FitParam>().unwrap()];
    let opts = FitOptions {
        photons: 200_000,
        seed: 7,
        ..FitOptions::default()
    };
    let r = fit(&scene(1.0), &scene_file(), &params, &measured, &opts).unwrap();
    eprintln!(
        "fitted h = {:.4} (misfit {:.2e}, start {:.2e}, {} evaluations)",
        r.values[0], r.misfit, r.start_misfit, r.evaluations
    );
    assert!((r.values[0] - 1.8).abs() < 0.14, "fitted {:?}", r.values);
    assert!(
        r.misfit < 0.1 * r.start_misfit,
        "{} vs start {}",
        r.misfit,
        r.start_misfit
    );
}
