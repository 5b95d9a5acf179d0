//! Reproducibility of `roks brdf`: photon n uses the random stream (seed, n)
//! and batch tallies are summed in batch order, so the output files must be
//! byte-identical for any thread count (summary.json identical except the
//! wall-clock fields `seconds` and `segments_per_second`), and a different
//! seed must give different results.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::Command;

use cli_common::{read, summary_without_timing};
use serde_json::Value;

const SCENE: &str = r#"
name = "repro"

[surface]
size = [10.0, 10.0]
material = "paint"

[materials.paint]
reflectance = 0.8

[[bumps]]
shape = "ellipsoid"
count = 12
radius = [1.5, 2.5]
height = [0.5, 2.5]
seed = 3

[light]
theta_deg = [0, 45]
photons = 1000

[tally]
bands = 8
"#;

/// A fresh, empty scratch folder for this test process.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-it-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run `roks brdf` (quiet) and return the output folder.
fn brdf(scene: &Path, out: &Path, threads: usize, seed: u64) -> PathBuf {
    // 40 000 photons = 10 batches of 4096, so two threads really share the work.
    let status = Command::new(env!("CARGO_BIN_EXE_roks"))
        .arg("brdf")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args([
            "--photons",
            "40000",
            "--theta",
            "0,30,75",
            "--stats-resolution",
            "64",
            "-q",
        ])
        .args([
            "--seed",
            &seed.to_string(),
            "--threads",
            &threads.to_string(),
        ])
        .status()
        .expect("run roks");
    assert!(status.success(), "roks brdf failed: {status}");
    out.to_path_buf()
}

/// Byte-identical brdf.csv and inplane.csv, and summary.json but for timings.
fn assert_same_run(one: &Path, two: &Path) {
    for f in ["brdf.csv", "inplane.csv"] {
        assert!(
            read(one, f) == read(two, f),
            "{f} differs between 1 and 2 threads"
        );
    }
    assert_eq!(
        summary_without_timing(one),
        summary_without_timing(two),
        "summary.json differs between 1 and 2 threads"
    );
}

#[test]
fn same_seed_same_bytes_for_any_thread_count() {
    let dir = scratch("repro");
    let scene = dir.join("repro.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let one = brdf(&scene, &dir.join("t1"), 1, 17);
    let two = brdf(&scene, &dir.join("t2"), 2, 17);
    let other = brdf(&scene, &dir.join("seed18"), 2, 18);

    assert_same_run(&one, &two);
    let s1 = summary_without_timing(&one);
    // The timing fields really were there (and nothing else was stripped).
    let raw: Value = serde_json::from_slice(&read(&one, "summary.json")).unwrap();
    assert!(raw["seconds"].is_number());
    assert!(raw["incidence"][0]["segments_per_second"].is_number());
    assert_eq!(s1["incidence"].as_array().map(Vec::len), Some(3));
    assert_eq!(s1["run"]["seed"], 17);
    assert_eq!(s1["incidence"][0]["photons"], 40000);

    // Another seed: other photons, other tallies.
    assert!(
        read(&one, "brdf.csv") != read(&other, "brdf.csv"),
        "brdf.csv does not depend on the seed"
    );
    assert_ne!(
        s1["incidence"][0]["reflectance"],
        summary_without_timing(&other)["incidence"][0]["reflectance"],
        "reflectance does not depend on the seed"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same for a height-field scene (a Gaussian field traced by the mip walk).
#[test]
fn height_field_same_bytes_for_any_thread_count() {
    let dir = scratch("repro-field");
    let scene = dir.join("field.toml");
    std::fs::write(
        &scene,
        r#"
[surface]
size = [16.0, 16.0]
material = "paint"
heightfield = { gaussian = { sigma = 1.0, tau = 3.0 }, resolution = 64, seed = 2 }

[materials.paint]
reflectance = 0.8

[tally]
bands = 8
"#,
    )
    .unwrap();
    let one = brdf(&scene, &dir.join("t1"), 1, 17);
    let two = brdf(&scene, &dir.join("t2"), 2, 17);
    assert_same_run(&one, &two);
    let _ = std::fs::remove_dir_all(&dir);
}
