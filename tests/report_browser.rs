//! The interactive report (`report.html`) in a real browser: Debian's
//! headless `chromium`, driven by `playwright-core` (pinned in
//! tests/report/package.json and package-lock.json, installed by `npm ci`
//! in tests/report) through `tests/report/check.mjs`.
//!
//! Seven folders are made with this build's `roks` (few photons): a
//! monochrome run, a spectral one (with colour.csv), a Mueller one with an
//! ABg fit, an ensemble of two surface realisations, a run at two light
//! azimuths (the anisotropy figure), an object trace with its far field,
//! and a spectral object trace (23 wavelengths). For each report.html,
//! opened from the file: no console error, no request but the file itself,
//! every view drawn (and screenshotted into the folder this test prints),
//! and, after another incidence, azimuth and wavelength are picked, the
//! hovered cell's value and standard error equal to brdf.csv's as printed.
//! The Mueller folder's ABg model is drawn over its table: dashed in the
//! in-plane curves in the table's colour, and in the hemisphere map, where
//! hovering the cell of fit_abg.json's largest residual shows the model
//! value fit-model wrote for it; its m00 map is on a log scale. The
//! spectral trace's beam view draws summary.json's spectra against the
//! wavelength.
//!
//! Without node, chromium or tests/report/node_modules the test says why
//! and passes, unless `ROKS_REQUIRE_BROWSER=1` (set by .ci/run) makes that
//! a failure.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::json;

fn ok(args: &[&str]) {
    let out = cli_common::roks(args);
    assert!(
        out.status.success(),
        "roks {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Why the browser test cannot run here, if it cannot.
fn missing(tests: &Path, chromium: &str) -> Option<String> {
    if Command::new("node").arg("--version").output().is_err() {
        return Some("node is not installed".into());
    }
    if !Path::new(chromium).is_file() {
        return Some(format!(
            "{chromium} is not installed (apt-get install chromium)"
        ));
    }
    if !tests.join("node_modules/playwright-core").is_dir() {
        return Some(format!(
            "{}/node_modules has no playwright-core (npm ci there)",
            tests.display()
        ));
    }
    None
}

#[test]
fn every_view_draws_offline_and_shows_the_tables_digits() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tests = root.join("tests/report");
    let chromium = std::env::var("ROKS_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if let Some(why) = missing(&tests, &chromium) {
        assert!(
            std::env::var("ROKS_REQUIRE_BROWSER").as_deref() != Ok("1"),
            "ROKS_REQUIRE_BROWSER=1 but {why}"
        );
        eprintln!("report_browser: skipped: {why}");
        return;
    }
    let t = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("report-browser");
    let _ = std::fs::remove_dir_all(&t);
    std::fs::create_dir_all(&t).unwrap();
    let dir = |n: &str| t.join(n).display().to_string();
    let micro = [
        "--photons",
        "4096",
        "--stats-resolution",
        "32",
        "-q",
        "--report",
    ];
    ok(&[
        &["brdf", "--theta", "0,60", "--out", &dir("mono")],
        &micro[..],
    ]
    .concat());
    let spectral = ["brdf", "--theta", "0,45", "--wavelengths", "0.38:0.78:0.1"];
    ok(&[&spectral[..], &["--out", &dir("spectral")], &micro[..]].concat());
    let mueller = ["brdf", "--theta", "20,50", "--polarisation", "mueller"];
    ok(&[&mueller[..], &["--out", &dir("mueller")], &micro[..]].concat());
    ok(&["fit-model", &dir("mueller"), "--model", "abg", "-q"]);
    ok(&["report", &dir("mueller"), "-q"]);
    let ensemble = t.join("ensemble.toml");
    std::fs::write(
        &ensemble,
        "name = \"bumps-ensemble\"\n[surface]\nsize = [20.0, 20.0]\nmaterial = \"m\"\nrealisations = 2\n\
         [materials.m]\nreflectance = 0.8\n[[bumps]]\nshape = \"ellipsoid\"\ncount = 12\n\
         radius = [1.5, 3.0]\nheight = [1.0, 3.0]\nseed = 1\n[light]\ntheta_deg = [0, 60]\n\
         photons = 8192\nseed = 4\n[tally]\nbands = 8\n",
    )
    .unwrap();
    let e = ensemble.display().to_string();
    ok(&[
        "brdf",
        &e,
        "--out",
        &dir("realisations"),
        "--stats-resolution",
        "32",
        "-q",
        "--report",
    ]);
    let azimuths = ["brdf", "--theta", "0,40", "--phi", "0,90"];
    ok(&[&azimuths[..], &["--out", &dir("azimuths")], &micro[..]].concat());
    let scene = root
        .join("scenes/cylinder-cavity.toml")
        .display()
        .to_string();
    ok(&[
        "trace",
        &scene,
        "--photons",
        "4096",
        "--out",
        &dir("trace"),
        "-q",
        "--report",
    ]);
    let radiator = root
        .join("scenes/radiator-spectral.toml")
        .display()
        .to_string();
    ok(&[
        "trace",
        &radiator,
        "--photons",
        "1024",
        "--out",
        &dir("trace-spectral"),
        "-q",
        "--report",
    ]);

    let common = [
        "description",
        "reflectance-table",
        "surface",
        "hemisphere",
        "lobe",
        "inplane",
        "bounces",
        "products",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> { [&common[..], extra].concat() };
    let shots = t.join("screenshots");
    let spec = json!({
        "shots": shots,
        "folders": [
            { "name": "mono", "dir": dir("mono"), "views": with(&[]), "hover": true },
            { "name": "spectral", "dir": dir("spectral"), "views": with(&["spectrum"]), "hover": true },
            { "name": "mueller", "dir": dir("mueller"), "views": with(&["polarisation"]), "hover": true, "fit": "abg", "mueller": true },
            { "name": "realisations", "dir": dir("realisations"), "views": with(&["spread"]), "hover": true },
            { "name": "azimuths", "dir": dir("azimuths"), "views": with(&["spread"]), "hover": true },
            { "name": "trace", "dir": dir("trace"), "views": ["description", "beam", "absorbed", "farfield"], "hover": false },
            { "name": "trace-spectral", "dir": dir("trace-spectral"), "views": ["description", "beam", "absorbed", "farfield"], "hover": false, "spectral_trace": true },
        ],
    });
    let spec_file = t.join("spec.json");
    std::fs::write(&spec_file, spec.to_string()).unwrap();
    println!("report_browser: screenshots in {}", shots.display());
    let clock = std::time::Instant::now();
    let out = Command::new("node")
        .arg(tests.join("check.mjs"))
        .arg(&spec_file)
        .env("ROKS_CHROMIUM", &chromium)
        .output()
        .expect("run node");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    println!(
        "report_browser: {:.1} s in the browser",
        clock.elapsed().as_secs_f64()
    );
    assert!(
        out.status.success(),
        "check.mjs failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Each folder's line, with the hovered cell equal to brdf.csv's.
    for name in [
        "mono",
        "spectral",
        "mueller",
        "realisations",
        "azimuths",
        "trace",
        "trace-spectral",
    ] {
        assert!(
            stdout.contains(&format!("{{\"folder\":\"{name}\",\"bytes\"")),
            "no result for {name}"
        );
    }
    assert_eq!(stdout.matches("\"hover\":{\"cell\"").count(), 5);
    // The model hovered in the Mueller folder, the spectra of the trace.
    assert_eq!(stdout.matches("\"model\":{\"cell\"").count(), 1);
    assert_eq!(stdout.matches("\"model\":{\"positions\"").count(), 1);
    // The mueller folder's fit is drawn over its table.
    assert!(shots.join("mueller-products.png").is_file());
}
