//! Helpers shared by the physics-validation integration tests: build a micro
//! scene from TOML text and trace it with the settings the scene asks for.
#![allow(dead_code)]

use num_complex::Complex64;
use roks::scene::SceneFile;
use roks::scene::micro::MicroScene;
use roks::transport::brdf::{BrdfRun, IncidenceResult};

/// Parse and build a micro scene from TOML text (panics with the scene error).
#[must_use]
pub fn scene(name: &str, toml: &str) -> MicroScene {
    let scene_file = SceneFile {
        file: format!("{name}.toml"),
        dir: ".".into(),
    };
    MicroScene::from_str(toml, scene_file, name.into())
        .unwrap_or_else(|e| panic!("scene {name}: {e}"))
}

/// The run described by the scene's `[light]`, `[tally]` and `[transport]`.
///
/// With `ROKS_TEST_LAUNCH=lattice` in the environment every physics test
/// runs with the lattice launch instead (photons rounded up to a multiple of
/// 16): the exact tests then check that the lattice is unbiased too.
#[must_use]
pub fn brdf_run(scene: &MicroScene) -> BrdfRun {
    let mut run = scene_run(scene);
    if std::env::var("ROKS_TEST_LAUNCH").as_deref() == Ok("lattice") {
        run.launch = roks::transport::launch::Launch::Lattice;
        run.photons = run
            .photons
            .next_multiple_of(roks::transport::launch::REPLICATES);
    }
    run
}

fn scene_run(scene: &MicroScene) -> BrdfRun {
    scene.brdf_run()
}

/// Trace every incidence angle of the scene.
#[must_use]
pub fn run(scene: &MicroScene) -> Vec<IncidenceResult> {
    brdf_run(scene)
        .trace_whole(&scene.surface, &|_| {})
        .into_leaves()
}

/// Lost weight broken down, for messages.
#[must_use]
pub fn losses(r: &IncidenceResult) -> String {
    let t = &r.tallies;
    format!(
        "walls {}, cap {} ({} histories), numeric {} ({} histories)",
        t.lost_walls, t.lost_cap, t.capped_histories, t.lost_numeric, t.numeric_histories
    )
}

/// Unpolarised reflectance of the interface vacuum | n + ik at incidence
/// `theta` (radians), textbook form (Born & Wolf §14.2) in complex arithmetic:
/// `rs = (cos i - eta cos t) / (cos i + eta cos t)`,
/// `rp = (eta² cos i - eta cos t) / (eta² cos i + eta cos t)`, with
/// `eta cos t = sqrt(eta² - sin² i)` (principal branch: the wave decays into the metal).
pub fn fresnel_textbook(theta: f64, n: f64, k: f64) -> f64 {
    let eta = Complex64::new(n, k);
    let (s, c) = theta.sin_cos();
    let eta_cos_t = (eta * eta - s * s).sqrt();
    let rs = (c - eta_cos_t) / (c + eta_cos_t);
    let rp = (eta * eta * c - eta_cos_t) / (eta * eta * c + eta_cos_t);
    0.5 * (rs.norm_sqr() + rp.norm_sqr())
}

/// Periodic symmetric V-grooves running along y, lit across them (in the
/// x-z plane), walls of slope `alpha_deg` from the horizontal and constant
/// reflectance `rho`. A ridge of the body `-left -right`,
/// `left: -sin(a) x + cos(a) z < 0` (z < x tan a) and
/// `right: sin(a) x + cos(a) z < 2 cos(a)` (z < (W - x) tan a),
/// fills the cell of width `W = 2 / tan(a)`, so the apex is at height 1 and
/// the groove bottoms at x = 0 = W (periodic).
#[must_use]
pub fn grooves_toml(alpha_deg: f64, theta_deg: f64, rho: f64, photons: u64, seed: u64) -> String {
    let a = alpha_deg.to_radians();
    let (s, c) = a.sin_cos();
    let width = 2.0 / a.tan();
    format!(
        r#"
[surface]
size = [{width:?}, 1.0]
edges = "periodic"
material = "wall"

[materials.wall]
reflectance = {rho:?}

[quadrics]
left = {{ plane = [{:?}, 0.0, {c:?}, 0.0] }}
right = {{ plane = [{s:?}, 0.0, {c:?}, {:?}] }}

[[bodies]]
region = "-left -right"

[light]
theta_deg = [{theta_deg:?}]
phi_deg = 0.0
photons = {photons}
seed = {seed}
"#,
        -s,
        2.0 * c
    )
}
