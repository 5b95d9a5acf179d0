//! The Mitsuba 3 cross-check chain in the test suite: the Python
//! checks of the independent tracer (`scripts/test_mitsuba_brdf.py`: exact
//! flat-plane, Fresnel and V-groove values) and the small whole chain
//! (`scripts/test_crosscheck.py`: `roks export-mesh` -> Mitsuba tracer and
//! `path` renders vs `roks brdf` / `roks render` on exact V-grooves, with the
//! markdown report's verdict PASS, and FAIL when Mitsuba's rho is off by 2 %),
//! the `roks_table` BSDF plugin (`scripts/test_roks_bsdf.py`, with its
//! polarised end-to-end check: `roks brdf --polarisation mueller` on a flat
//! Al substrate against Mitsuba's polarised `conductor`), and the polarised
//! cross-check (`scripts/test_mitsuba_polarised.py`: the polarised Mitsuba
//! tracer, built on Mitsuba's own Mueller matrices, against exact
//! flat-plane and V-groove matrices, then `roks brdf --polarisation
//! mueller|stokes` against it on a Gaussian height field, aluminium and
//! 1.6 + 0.2i).
//!
//! They need the project's Python environment (`scripts/setup_venv.sh`,
//! `.venv` with mitsuba 3.9.1 and drjit 1.5.0; `ROKS_PYTHON` overrides the
//! interpreter). Without it these tests print why and pass, unless
//! `ROKS_REQUIRE_MITSUBA=1` (set by `.ci/run`, which installs the
//! environment), where a missing environment is a failure.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The Python with mitsuba, or None (after saying why) when it may be skipped.
fn python() -> Option<PathBuf> {
    let py = std::env::var_os("ROKS_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".venv/bin/python"));
    let ok = py.exists()
        && Command::new(&py)
            .args(["-c", "import mitsuba, drjit, numpy, matplotlib"])
            .output()
            .is_ok_and(|o| o.status.success());
    let required = std::env::var("ROKS_REQUIRE_MITSUBA").is_ok_and(|v| v == "1");
    if ok {
        Some(py)
    } else if required {
        panic!(
            "ROKS_REQUIRE_MITSUBA=1 but {} cannot import mitsuba: run scripts/setup_venv.sh",
            py.display()
        );
    } else {
        eprintln!(
            "mitsuba_chain: skipped: {} cannot import mitsuba (run scripts/setup_venv.sh)",
            py.display()
        );
        None
    }
}

fn run(py: &Path, script: &str, args: &[&str]) {
    let o = Command::new(py)
        .arg(root().join("scripts").join(script))
        .args(args)
        .current_dir(root())
        .output()
        .expect("start python");
    assert!(
        o.status.success(),
        "{script} failed ({}):\n{}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn mitsuba_tracer_exact_checks() {
    if let Some(py) = python() {
        run(&py, "test_mitsuba_brdf.py", &[]);
    }
}

#[test]
fn whole_chain_on_exact_v_grooves() {
    if let Some(py) = python() {
        run(
            &py,
            "test_crosscheck.py",
            &["--roks", env!("CARGO_BIN_EXE_roks")],
        );
    }
}

#[test]
fn mitsuba_roks_table_plugin() {
    if let Some(py) = python() {
        run(
            &py,
            "test_roks_bsdf.py",
            &["--roks", env!("CARGO_BIN_EXE_roks")],
        );
    }
}

#[test]
fn mitsuba_polarised_cross_check() {
    if let Some(py) = python() {
        run(
            &py,
            "test_mitsuba_polarised.py",
            &["--roks", env!("CARGO_BIN_EXE_roks")],
        );
    }
}
