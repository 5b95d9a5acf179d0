//! Helpers shared by the object-level (`roks trace`) integration tests:
//! build an object scene from TOML text, trace it, and read its tallies
//! with the standard errors roks itself computes.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use roks::scene::SceneFile;
use roks::scene::object::ObjectScene;
use roks::tally::{Accumulator, CarlsonGrid};
use roks::transport::object::PositionResult;

/// A fresh, empty scratch folder for this test process.
#[must_use]
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-obj-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Parse and build an object scene (relative paths from `dir`); panics with the scene error.
#[must_use]
pub fn scene(name: &str, toml: &str, dir: &Path) -> ObjectScene {
    let scene_file = SceneFile {
        file: format!("{name}.toml"),
        dir: dir.to_path_buf(),
    };
    ObjectScene::from_str(toml, scene_file, name.into())
        .unwrap_or_else(|e| panic!("scene {name}: {e}"))
}

/// Trace every beam position of the scene.
#[must_use]
pub fn run(scene: &ObjectScene) -> Vec<PositionResult> {
    scene
        .run
        .trace(
            &scene.object,
            &scene.walls,
            &scene.models,
            &scene.beams,
            &scene.photons,
            &|_| {},
        )
        .into_leaves()
}

/// Index of a named surface.
#[must_use]
pub fn surface(scene: &ObjectScene, name: &str) -> usize {
    scene
        .object
        .surface_names
        .iter()
        .position(|s| s == name)
        .unwrap_or_else(|| panic!("no surface {name}"))
}

/// (mean, stderr) of bin `bin`, with roks's own formulas.
#[must_use]
pub fn mean_se(acc: &Accumulator, bin: usize, n: u64) -> (f64, f64) {
    (acc.mean(bin, n), acc.stderr(bin, n))
}

/// (mean, stderr) of the sum over `bins` of an accumulator in which every
/// history scores at most one of those bins (a photon leaves in one
/// direction): the per-history band score is then the one cell score, so the
/// sum of its squares is the sum of the cells' `sum_sq`, and roks's own
/// stderr formula applies to the merged bin exactly.
#[must_use]
pub fn merged(acc: &Accumulator, bins: impl IntoIterator<Item = usize>, n: u64) -> (f64, f64) {
    let mut m = Accumulator::new(1);
    for b in bins {
        m.sum[0] += acc.sum[b];
        m.sum_sq[0] += acc.sum_sq[b];
    }
    (m.mean(0, n), m.stderr(0, n))
}

/// Flat hemisphere indices of the cells of `band` (1-based).
pub fn band_cells(grid: &CarlsonGrid, band: usize) -> impl Iterator<Item = usize> + '_ {
    (0..grid.cells_in_band(band)).map(move |c| grid.index(band, c))
}

/// `|got - want| <= 4 sigma`, with a message.
pub fn assert_4sigma(what: &str, got: f64, want: f64, sigma: f64) {
    assert!(sigma.is_finite(), "{what}: sigma {sigma}");
    assert!(
        (got - want).abs() <= 4.0 * sigma,
        "{what}: got {got}, expected {want}, difference {:.2} sigma (sigma {sigma:.3e})",
        (got - want) / sigma
    );
}

/// Composite Simpson rule of `f` over `[a, b]` with `n` (even) intervals.
pub fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    assert!(n % 2 == 0);
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        let w = if i % 2 == 1 { 4.0 } else { 2.0 };
        s += w * f(a + i as f64 * h);
    }
    s * h / 3.0
}

/// Upper quantile of the chi-square distribution with `k` degrees of
/// freedom at the standard-normal quantile `z` (Wilson-Hilferty; relative
/// error below 1e-3 for k >= 20).
#[must_use]
pub fn chi2_quantile(k: f64, z: f64) -> f64 {
    let c = 2.0 / (9.0 * k);
    k * (1.0 - c + z * c.sqrt()).powi(3)
}
