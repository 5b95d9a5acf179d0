//! The lattice launch (`[light] launch = "lattice"`, `--launch lattice`):
//! unbiased against exact values, its standard errors from the replicate
//! spread, and reproducible like the random launch (threads, shards).
//!
//! * V-grooves with constant wall reflectance: the reflectance is exactly
//!   `sum_k p_k rho^k` with the Zipin fractions `p_k` (closed forms only);
//!   the lattice estimate must lie within 4 of its own (replicate) standard
//!   errors, which are far smaller than the random launch's, so the check is
//!   much sharper than the random one in `tests/v_grooves.rs`.
//! * The white furnace on a rough Gaussian field: reflectance exactly 1 with
//!   a standard error of exactly 0 (every replicate sums to its photons).
//! * The default scene: the lattice and random estimates of the same
//!   reflectance and Carlson cells agree within their combined errors.
//! * The CLI: 1 and 2 threads give the same bytes; shards merge to the
//!   single run exactly; a photon count that is not a multiple of 16 is an
//!   input error.

mod cli_common;
mod common;

use std::path::{Path, PathBuf};

use cli_common::{read, roks, summary_without_timing};
use roks::scene::micro::DEFAULT_SCENE;
use roks::transport::brdf::IncidenceResult;
use roks::transport::launch::{Launch, REPLICATES};

fn run(toml: &str, launch: Launch) -> Vec<IncidenceResult> {
    let scene = common::scene("lattice", toml);
    let mut run = common::brdf_run(&scene);
    run.launch = launch;
    run.trace_whole(&scene.surface, &|_| {}).into_leaves()
}

#[test]
fn v_groove_reflectance_is_exact_within_replicate_errors() {
    let rho = 0.5_f64;
    let s3 = 3f64.sqrt();
    let p35 = 2.0 * 70f64.to_radians().cos();
    // (wall angle, incidence, exact Zipin fractions (bounces, p)).
    let cases = [
        (35.0, 0.0, vec![(1, p35), (2, 1.0 - p35)]),
        (
            2f64.sqrt().atan().to_degrees(),
            0.0,
            vec![(2, 8.0 / 9.0), (3, 1.0 / 9.0)],
        ),
        (45.0, 30.0, vec![(1, 1.0 / s3), (2, 1.0 - 1.0 / s3)]),
        (
            60.0,
            45.0,
            vec![(1, (s3 - 1.0) / 2.0), (2, (3.0 - s3) / 2.0)],
        ),
    ];
    for (alpha, theta, fractions) in cases {
        let what = format!("alpha {alpha} theta {theta}");
        let expect: f64 = fractions.iter().map(|&(k, p)| p * rho.powi(k)).sum();
        let toml = common::grooves_toml(alpha, theta, rho, 65_536, 7);
        let lattice = run(&toml, Launch::Lattice).remove(0);
        let random = run(&toml, Launch::Random).remove(0);
        let (mean, se) = lattice.reflectance();
        let (_, se_random) = random.reflectance();
        assert!(
            (mean - expect).abs() <= 4.0 * se,
            "{what}: lattice reflectance {mean} +- {se}, exact {expect}"
        );
        // The check is sharp: the lattice error is well below the random one.
        assert!(
            se > 0.0 && se < 0.25 * se_random,
            "{what}: lattice {se}, random {se_random}"
        );
    }
}

#[test]
fn furnace_on_a_rough_field_has_zero_replicate_error() {
    let toml = r#"
[surface]
size = [16.0, 16.0]
material = "white"
heightfield = { gaussian = { sigma = 1.0, tau = 2.0 }, resolution = 64, seed = 5 }

[materials.white]
reflectance = 1.0

[light]
theta_deg = [0.0, 60.0, 85.0]
photons = 16384
seed = 2
"#;
    for r in run(toml, Launch::Lattice) {
        assert_eq!(r.lost(), 0.0, "theta {}", r.theta_i_deg);
        assert_eq!(r.reflectance(), (1.0, 0.0), "theta {}", r.theta_i_deg);
        let reps = r.tallies.replicates.as_ref().expect("replicate sums");
        assert_eq!(reps.count as u64, REPLICATES);
        let per = (r.tallies.photons / REPLICATES) as f64;
        assert!(reps.reflected.iter().all(|&s| s == per));
    }
}

/// Lattice and random runs of the default scene estimate the same numbers:
/// reflectance within 4 combined standard errors, and the Carlson cells'
/// chi² per cell below its p = 1e-4 point (Wilson–Hilferty).
#[test]
fn default_scene_lattice_agrees_with_random() {
    let toml = DEFAULT_SCENE
        .replace("photons = 1000000", "photons = 131072")
        .replace(
            "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
            "theta_deg = [30, 70]",
        )
        .replace("bands = 32", "bands = 8");
    assert_ne!(toml, DEFAULT_SCENE, "the replacements must apply");
    let lattice = run(&toml, Launch::Lattice);
    let random = run(&toml, Launch::Random);
    assert_eq!(lattice.len(), 2);
    for (l, r) in lattice.iter().zip(&random) {
        let what = format!("theta {}", l.theta_i_deg);
        let ((ml, sl), (mr, sr)) = (l.reflectance(), r.reflectance());
        assert!(
            (ml - mr).abs() <= 4.0 * sl.hypot(sr),
            "{what}: lattice {ml} +- {sl}, random {mr} +- {sr}"
        );
        let n = l.tallies.photons;
        let (mut chi2, mut dof) = (0.0, 0_usize);
        for c in 0..l.tallies.carlson.len() {
            let var = l.carlson_stderr(c).powi(2) + r.carlson_stderr(c).powi(2);
            // Cells with at least 25 photons' worth per replicate: below
            // that a replicate's sum is a small count and its spread a poor
            // estimate of the variance.
            if r.tallies.carlson.sum[c] >= 25.0 * REPLICATES as f64 && var > 0.0 {
                let d = l.tallies.carlson.mean(c, n) - r.tallies.carlson.mean(c, n);
                chi2 += d * d / var;
                dof += 1;
            }
        }
        assert!(dof > 50, "{what}: {dof} cells");
        // Wilson–Hilferty: chi²/dof at p = 1e-4 is about (1 - 2/(9k) + 3.72 sqrt(2/(9k)))³.
        let k = dof as f64;
        let a = 2.0 / (9.0 * k);
        let limit = (1.0 - a + 3.72 * a.sqrt()).powi(3);
        // The lattice's replicate variances have 15 degrees of freedom; a
        // t-like tail inflates chi² by up to (K - 1)/(K - 3) = 15/13.
        let limit = limit * 15.0 / 13.0;
        assert!(
            chi2 / k < limit,
            "{what}: chi²/dof {} over {dof} cells, limit {limit}",
            chi2 / k
        );
    }
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-lattice-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn brdf(out: &Path, launch: &str, extra: &[&str]) {
    let mut args = vec![
        "brdf",
        "-q",
        "--launch",
        launch,
        "--photons",
        "40000",
        "--theta",
        "0,60",
        "--seed",
        "3",
        "--stats-resolution",
        "64",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn lattice_runs_are_reproducible_across_threads_and_shards() {
    let root = scratch("repro");
    let (one, two) = (root.join("t1"), root.join("t2"));
    brdf(&one, "lattice", &["--threads", "1"]);
    brdf(&two, "lattice", &["--threads", "2"]);
    for f in ["brdf.csv", "inplane.csv"] {
        assert!(read(&one, f) == read(&two, f), "{f}: 1 vs 2 threads");
    }
    let summary = summary_without_timing(&one);
    assert_eq!(summary, summary_without_timing(&two));
    assert_eq!(summary["run"]["launch"], "lattice");
    // Three shards merged: the same bytes as the single run.
    let shards: Vec<PathBuf> = (0..3).map(|i| root.join(format!("s{i}"))).collect();
    for (i, d) in shards.iter().enumerate() {
        brdf(d, "lattice", &["--shard", &format!("{i}/3")]);
    }
    let merged = root.join("merged");
    let mut args = vec!["merge", "-q"];
    args.extend(shards.iter().map(|d| d.to_str().unwrap()));
    args.extend(["--out", merged.to_str().unwrap()]);
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["brdf.csv", "inplane.csv"] {
        assert!(read(&one, f) == read(&merged, f), "{f}: merged shards");
    }
    assert_eq!(summary, summary_without_timing(&merged));
    // A different launch is a different run: the standard errors differ.
    let random = root.join("random");
    brdf(&random, "random", &[]);
    assert!(read(&one, "brdf.csv") != read(&random, "brdf.csv"));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn photons_not_a_multiple_of_the_replicates_is_an_input_error() {
    let root = scratch("bad");
    let out = root.join("out");
    let o = roks(&[
        "brdf",
        "-q",
        "--launch",
        "lattice",
        "--photons",
        "1000001",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("--photons") && err.contains("16"), "{err}");
    assert!(!out.exists());
}
