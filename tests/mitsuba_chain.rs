//! The Python package's tests (`python/tests`, pytest) in the test suite,
//! with the roks binary cargo built (`ROKS_BIN`):
//!
//! * the Mitsuba 3 cross-checks, one pytest run per file of tests marked
//!   `mitsuba` (so they run in parallel): the independent tracer's exact
//!   flat-plane, Fresnel and V-groove values (`test_mitsuba_brdf.py`); the
//!   small whole chain (`test_crosscheck.py`: `roks export-mesh` -> Mitsuba
//!   tracer and `path` renders vs `roks brdf` / `roks render` on exact
//!   V-grooves, with the report's verdict PASS, and FAIL when Mitsuba's rho
//!   is off by 2 %); the `roks_table` BSDF plugin (`test_roks_bsdf.py`, with
//!   its polarised end-to-end check: `roks brdf --polarisation mueller` on a
//!   flat Al substrate against Mitsuba's polarised `conductor`); the
//!   polarised cross-check (`test_mitsuba_polarised.py`: the polarised
//!   Mitsuba tracer, built on Mitsuba's own Mueller matrices, against exact
//!   flat-plane and V-groove matrices, then `roks brdf --polarisation
//!   mueller|stokes` against it on a Gaussian height field); the plugin
//!   with spectral tables (`test_roks_table_colour.py`: grey = monochrome,
//!   gold's RGB = roks's colour.csv, spectra at Mitsuba's wavelengths); the spectral
//!   cross-check (`test_spectral_mitsuba.py`: a Gaussian field of gold,
//!   roks with Mitsuba's own Au n, k against the tracer in
//!   `llvm_ad_spectral_polarized` and `llvm_ad_spectral` with Mitsuba's
//!   conductor spectra, reflectance per wavelength and XYZ per cell); the
//!   variant choice (`test_mitsuba_setup.py`: an LLVM that aborts the
//!   process is caught in a child process and the tools fall back to
//!   scalar); pbrt-v4's `MeasuredBxDF` (our numpy port,
//!   `roks_tools.pbrt_measured`) against Mitsuba's `measured` on the
//!   exported RGL files (`test_pbrt_measured.py`);
//! * every other Python test in one run (`-m "not mitsuba"`: every scene
//!   in scenes/ run small and every file of its folder read, the readers'
//!   refusal of bad bytes, the Carlson grid, microfacet theory, the colour
//!   of a flat gold mirror against colour-science, pbrt-v4's evaluation
//!   of the RGL export per cell and its refusals).
//!
//! Each test runs once: a file with `mitsuba` tests is listed in
//! [`MITSUBA_FILES`] (checked), its other tests go to the second run.
//!
//! They need the project's Python environment (`scripts/setup_venv.sh`:
//! `.venv` with mitsuba 3.9.1, drjit 1.5.0, pytest and the package
//! `roks_tools`; `ROKS_PYTHON` overrides the interpreter). Without it these
//! tests print why and pass, unless `ROKS_REQUIRE_MITSUBA=1` (set by
//! `.ci/run`, which installs the environment), where a missing environment
//! is a failure.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The files under `python/tests` holding tests marked `mitsuba`.
const MITSUBA_FILES: [&str; 10] = [
    "test_crosscheck.py",
    "test_mitsuba_brdf.py",
    "test_mitsuba_polarised.py",
    "test_mitsuba_setup.py",
    "test_pbrt_measured.py",
    "test_pbsdf.py",
    "test_rgl.py",
    "test_roks_bsdf.py",
    "test_roks_table_colour.py",
    "test_spectral_mitsuba.py",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The Python with mitsuba, pytest and roks_tools, or None (after saying
/// why) when it may be skipped.
fn python() -> Option<PathBuf> {
    let py = std::env::var_os("ROKS_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".venv/bin/python"));
    let ok = py.exists()
        && Command::new(&py)
            .args([
                "-c",
                "import mitsuba, drjit, numpy, matplotlib, pytest, roks_tools, roks._native",
            ])
            .output()
            .is_ok_and(|o| o.status.success());
    let required = std::env::var("ROKS_REQUIRE_MITSUBA").is_ok_and(|v| v == "1");
    if ok {
        Some(py)
    } else if required {
        panic!(
            "ROKS_REQUIRE_MITSUBA=1 but {} cannot import mitsuba, pytest, roks_tools and roks: run scripts/setup_venv.sh",
            py.display()
        );
    } else {
        eprintln!(
            "mitsuba_chain: skipped: {} cannot import mitsuba, pytest, roks_tools and roks (run scripts/setup_venv.sh)",
            py.display()
        );
        None
    }
}

/// `python -m pytest TARGET -m MARKS` in the repository, with this build's roks.
fn pytest(py: &Path, target: &str, marks: &str) {
    let o = Command::new(py)
        .args([
            "-m",
            "pytest",
            target,
            "-m",
            marks,
            "-q",
            "-p",
            "no:cacheprovider",
        ])
        .env("ROKS_BIN", env!("CARGO_BIN_EXE_roks"))
        .current_dir(root())
        .output()
        .expect("start python");
    assert!(
        o.status.success(),
        "pytest {target} -m '{marks}' failed ({}):\n{}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn mitsuba_file(file: &str) {
    if let Some(py) = python() {
        pytest(&py, &format!("python/tests/{file}"), "mitsuba");
    }
}

#[test]
fn mitsuba_tracer_exact_checks() {
    mitsuba_file("test_mitsuba_brdf.py");
}

#[test]
fn whole_chain_on_exact_v_grooves() {
    mitsuba_file("test_crosscheck.py");
}

#[test]
fn mitsuba_variant_falls_back_instead_of_aborting() {
    mitsuba_file("test_mitsuba_setup.py");
}

#[test]
fn mitsuba_roks_table_plugin() {
    mitsuba_file("test_roks_bsdf.py");
}

#[test]
fn mitsuba_polarised_cross_check() {
    mitsuba_file("test_mitsuba_polarised.py");
}

#[test]
fn mitsuba_roks_table_plugin_in_colour() {
    mitsuba_file("test_roks_table_colour.py");
}

#[test]
fn mitsuba_spectral_cross_check() {
    mitsuba_file("test_spectral_mitsuba.py");
}

#[test]
fn mitsuba_measured_plugin_loads_rgl_files() {
    mitsuba_file("test_rgl.py");
}

#[test]
fn pbrt_measured_port_agrees_with_mitsuba_measured() {
    mitsuba_file("test_pbrt_measured.py");
}

#[test]
fn mitsuba_measured_polarized_plugin_loads_pbsdf_files() {
    mitsuba_file("test_pbsdf.py");
}

#[test]
fn python_package_tests() {
    if let Some(py) = python() {
        pytest(&py, "python/tests", "not mitsuba");
    }
}

/// Every file with `mitsuba` tests is run above, so none is left out.
#[test]
fn every_mitsuba_test_file_is_listed() {
    let mut found: Vec<String> = std::fs::read_dir(root().join("python/tests"))
        .expect("python/tests")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "py"))
        .filter(|p| {
            std::fs::read_to_string(p)
                .expect("read test file")
                .contains("pytest.mark.mitsuba")
        })
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    found.sort();
    assert_eq!(found, MITSUBA_FILES, "update MITSUBA_FILES");
}
