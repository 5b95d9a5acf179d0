//! A flat Fresnel substrate (no bumps): every photon reflects exactly once,
//! specularly, with the unpolarised Fresnel reflectance of the incidence
//! angle. Checked against a textbook complex-arithmetic Fresnel written here
//! (independent of `roks::optics`) and against the published R(0) of Al.

mod common;

use std::f64::consts::TAU;

/// Al at 0.55 um (Rakic 1995, interpolated; REFERENCE.md): n + ik.
const AL_N: f64 = 1.015;
const AL_K: f64 = 6.627;

/// Carlson cell (flat index) holding the direction with polar angle `theta`
/// and azimuth `phi` (radians), from the grid's definition (Carlson 1976,
/// REFERENCE.md), not from `roks::tally`: band j holds
/// `1 - j(j+1)/K <= mu < 1 - (j-1)j/K`, `K = M(M+1)`; its 4j cells are
/// centred on `phi = c 2pi/(4j)`; band j starts at flat index `2j(j-1)`.
fn carlson_cell(bands: usize, theta: f64, phi: f64) -> usize {
    let k = (bands * (bands + 1)) as f64;
    let mu = theta.cos();
    let j = (1..=bands)
        .find(|&j| mu >= 1.0 - (j * (j + 1)) as f64 / k)
        .expect("upper hemisphere");
    let n = 4 * j;
    let c = (phi.rem_euclid(TAU) / (TAU / n as f64) + 0.5).floor() as usize % n;
    2 * j * (j - 1) + c
}

fn flat_al_scene(thetas: &[f64], phi_deg: f64) -> roks::scene::micro::MicroScene {
    common::scene("flat_al", &substrate_text(thetas, phi_deg))
}

/// The TOML of the flat Al substrate lit from `thetas` at azimuth `phi_deg`.
fn substrate_text(thetas: &[f64], phi_deg: f64) -> String {
    let thetas: Vec<String> = thetas.iter().map(|t| format!("{t:?}")).collect();
    format!(
        r#"
[surface]
size = [1.0, 1.0]
material = "al"

[materials.al]
n = {AL_N:?}
k = {AL_K:?}

[light]
theta_deg = [{}]
phi_deg = {phi_deg:?}
photons = 5000
seed = 3

[tally]
bands = 32
"#,
        thetas.join(", ")
    )
}

/// The textbook formula itself reproduces the published R(0) = 0.9154 of Al
/// (REFERENCE.md) to 4 decimals, so the comparison below is against the right
/// physics and not just against a copy of `roks::optics`.
#[test]
fn textbook_fresnel_matches_published_al_normal_incidence() {
    let r0 = common::fresnel_textbook(0.0, AL_N, AL_K);
    assert!((r0 - 0.9154).abs() < 5e-5, "R(0) = {r0}");
    // Normal incidence closed form ((n-1)² + k²) / ((n+1)² + k²).
    let closed = ((AL_N - 1.0).powi(2) + AL_K.powi(2)) / ((AL_N + 1.0).powi(2) + AL_K.powi(2));
    assert!((r0 - closed).abs() < 1e-15);
}

/// Directional-hemispherical reflectance of the flat Al substrate equals the
/// exact Fresnel reflectance to 1e-12 at 0..89.99 deg: one reflection per photon,
/// all with the same weight, so the reported standard error is ~0 and nothing
/// is lost. R(0) reproduces 0.9154 (REFERENCE.md) to 4 decimals.
///
/// The reported standard error of identical scores is 0 in exact arithmetic;
/// the one-pass formula `sum_sq/N - mean²` leaves a rounding residue of at most
/// ~`N eps mean²` in the variance, i.e. a stderr below `sqrt(eps) mean` ≈ 1.5e-8,
/// which is what is asserted (observed: ~5e-9 at 45 deg).
#[test]
fn flat_fresnel_reflectance_is_exact() {
    let thetas = [
        0.0, 10.0, 20.0, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0, 89.0, 89.9, 89.99,
    ];
    let scene = flat_al_scene(&thetas, 30.0);
    let results = common::run(&scene);
    for r in &results {
        assert_exact_fresnel(r);
        let (mean, stderr) = r.reflectance();
        assert!(
            stderr <= f64::EPSILON.sqrt() * mean,
            "theta {}: stderr {stderr}",
            r.theta_i_deg
        );
        assert_eq!(r.tallies.by_bounces[1], r.tallies.reflected.sum[0]);
        if r.theta_i_deg == 0.0 {
            assert!((mean - 0.9154).abs() < 5e-5, "R(0) = {mean}");
        }
    }
}

/// Reflectance equal to the textbook Fresnel reflectance to 1e-12, nothing
/// lost, exactly one reflection per photon.
fn assert_exact_fresnel(r: &roks::transport::brdf::IncidenceResult) {
    let theta = r.theta_i_deg;
    let expect = common::fresnel_textbook(theta.to_radians(), AL_N, AL_K);
    let (mean, _) = r.reflectance();
    assert!(
        (mean - expect).abs() < 1e-12,
        "theta {theta}: reflectance {mean}, exact Fresnel {expect}"
    );
    assert_eq!(r.lost(), 0.0, "theta {theta}: {}", common::losses(r));
    assert_eq!(r.tallies.bounces, r.tallies.photons, "theta {theta}");
}

/// All reflected weight lands in the one Carlson cell that holds the mirror
/// direction `(-sin t cos p, -sin t sin p, cos t)`; every other cell is empty.
/// At normal incidence the mirror direction is the pole, where the azimuth is
/// undefined: by roks's convention the weight is shared equally among the four
/// cells of band 1 (flat indices 0-3).
#[test]
fn flat_reflection_lands_in_the_specular_carlson_cell() {
    let phi_deg = 30.0_f64;
    let thetas = [0.0, 10.0, 25.0, 40.0, 55.0, 70.0, 85.0];
    let scene = flat_al_scene(&thetas, phi_deg);
    let results = common::run(&scene);
    let bands = scene.run.bands;
    for r in &results {
        let total = r.tallies.reflected.sum[0];
        let hit: Vec<usize> = (0..r.tallies.carlson.len())
            .filter(|&c| r.tallies.carlson.sum[c] != 0.0)
            .collect();
        if r.theta_i_deg == 0.0 {
            assert_eq!(hit, vec![0, 1, 2, 3], "normal incidence: cells hit {hit:?}");
            for &c in &hit {
                let share = r.tallies.carlson.sum[c];
                assert!(
                    (share - 0.25 * total).abs() <= 1e-12 * total,
                    "cell {c}: {share} of {total}"
                );
            }
        } else {
            assert_eq!(hit.len(), 1, "theta {}: cells hit {hit:?}", r.theta_i_deg);
            assert_eq!(r.tallies.carlson.sum[hit[0]], total);
            let want = carlson_cell(
                bands,
                r.theta_i_deg.to_radians(),
                (phi_deg + 180.0).to_radians(),
            );
            assert_eq!(hit[0], want, "theta {}", r.theta_i_deg);
        }
    }
}

/// A height field of zeros (a 4 x 4 text map) is the flat substrate: exact
/// Fresnel reflectance to 1e-12 at 0-89 degrees, one reflection per photon,
/// and the very same tallies, bit for bit, as the flat substrate scene
/// (same photons, same normal, same arithmetic); both count one
/// intersection test per flight.
#[test]
fn flat_height_field_is_the_flat_substrate() {
    let thetas = [0.0, 10.0, 30.0, 45.0, 60.0, 80.0, 89.0];
    let map = std::env::temp_dir().join(format!("roks-it-{}-zeros.txt", std::process::id()));
    std::fs::write(&map, "0 0 0 0\n".repeat(4)).unwrap();
    let substrate = flat_al_scene(&thetas, 30.0);
    let text = substrate_text(&thetas, 30.0).replace(
        "size = [1.0, 1.0]",
        &format!(
            "heightfield = {{ file = {:?}, pixel = 0.25 }}",
            map.display().to_string()
        ),
    );
    let field = common::scene("flat_field", &text);
    assert!(field.surface.heightfield().is_some());
    let (a, b) = (common::run(&substrate), common::run(&field));
    for (s, f) in a.iter().zip(&b) {
        assert_exact_fresnel(f);
        // The work counters: each flight tests the substrate's one quadric,
        // or the one square of the field under it.
        // Two flights per photon: down to the surface and up out of the cell.
        for t in [&s.tallies, &f.tallies] {
            assert_eq!(t.segments, 2 * t.photons, "theta {}", f.theta_i_deg);
            assert_eq!(t.intersection_tests, t.segments, "theta {}", f.theta_i_deg);
        }
        assert_eq!(
            f.tallies.carlson.sum, s.tallies.carlson.sum,
            "theta {}",
            f.theta_i_deg
        );
        assert_eq!(
            f.tallies.inplane.sum, s.tallies.inplane.sum,
            "theta {}",
            f.theta_i_deg
        );
    }
}
