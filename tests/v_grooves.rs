//! Periodic symmetric specular V-grooves, beam across the grooves: the
//! fraction of photons leaving after k reflections against Zipin (1966)
//! (REFERENCE.md table), and the reflectance with a constant wall
//! reflectance rho, `sum_k p_k rho^k`.
//!
//! Geometry: the grooves run along y. A ridge of the body `-left -right`
//! with walls of slope alpha from the horizontal,
//! `left:  -sin(a) x + cos(a) z < 0` (z < x tan a) and
//! `right:  sin(a) x + cos(a) z < 2 cos(a)` (z < (W - x) tan a),
//! fills the cell of width `W = 2 / tan(a)`, so the apex is at height 1 and
//! the groove bottoms at x = 0 = W (periodic). The light comes from
//! phi = 0, i.e. in the x-z plane, across the grooves; the y period is
//! irrelevant (photons never move in y).
//!
//! The same grooves as a height field (a text map of `nx` columns, the apex
//! and the groove bottoms on grid vertices, so the triangulated field IS the
//! grooves) test the height-field traversal: flights cross many squares,
//! skip mip nodes, wrap across the cell and bounce between facets.

mod common;

use roks::scene::micro::MicroScene;
use roks::transport::brdf::IncidenceResult;

/// One row of the Zipin table: wall slope, incidence, and the fractions of
/// photons leaving after k bounces (every k not listed has fraction 0).
struct Case {
    alpha_deg: f64,
    theta_deg: f64,
    fractions: Vec<(usize, f64)>,
}

fn cases() -> Vec<Case> {
    let s3 = 3f64.sqrt();
    let case = |alpha_deg, theta_deg, fractions: &[(usize, f64)]| Case {
        alpha_deg,
        theta_deg,
        fractions: fractions.to_vec(),
    };
    vec![
        // alpha <= 30 at normal incidence: one bounce only.
        case(20.0, 0.0, &[(1, 1.0)]),
        // 2 cos(2 alpha) = 0.68404 leave after one bounce.
        case(35.0, 0.0, &[(1, 0.68404), (2, 0.31596)]),
        case(45.0, 0.0, &[(2, 1.0)]),
        // tan(alpha) = sqrt 2.
        case(
            2f64.sqrt().atan().to_degrees(),
            0.0,
            &[(2, 8.0 / 9.0), (3, 1.0 / 9.0)],
        ),
        case(60.0, 0.0, &[(3, 1.0)]),
        case(45.0, 30.0, &[(1, 1.0 / s3), (2, 1.0 - 1.0 / s3)]),
        case(60.0, 45.0, &[(1, (s3 - 1.0) / 2.0), (2, (3.0 - s3) / 2.0)]),
        case(50.0, 20.0, &[(1, 0.18479), (2, 0.81521)]),
        case(65.0, 10.0, &[(3, 0.68907), (4, 0.31093)]),
    ]
}

const PHOTONS: u64 = 200_000;

/// The `[light]` table: `PHOTONS` from `theta_deg` across the grooves.
fn light(theta_deg: f64) -> String {
    format!(
        "\n[light]\ntheta_deg = [{theta_deg:?}]\nphi_deg = 0.0\nphotons = {PHOTONS}\nseed = 7\n"
    )
}

/// The V-groove scene for wall slope `alpha_deg` with constant wall reflectance `rho`.
fn grooves(alpha_deg: f64, theta_deg: f64, rho: f64) -> MicroScene {
    common::scene(
        &format!("grooves_{alpha_deg}"),
        &common::grooves_toml(alpha_deg, theta_deg, rho, PHOTONS, 7),
    )
}

fn trace(alpha_deg: f64, theta_deg: f64, rho: f64) -> IncidenceResult {
    let scene = grooves(alpha_deg, theta_deg, rho);
    // The apex is at height 1 (up to the max-height search's tiny pad).
    assert!(
        (scene.surface.max_height - 1.0).abs() < 1e-6,
        "apex {}",
        scene.surface.max_height
    );
    common::run(&scene).remove(0)
}

/// With rho = 1 the weight left after k bounces, per photon, is the fraction
/// p_k of photons leaving after k bounces. Each measured fraction must be
/// within 4 binomial standard errors sqrt(p (1 - p) / N) of the Zipin value;
/// where the table says 0 or 1 that error is 0 and the match must be exact.
#[test]
fn bounce_fractions_match_zipin() {
    for c in cases() {
        let r = trace(c.alpha_deg, c.theta_deg, 1.0);
        let what = format!("alpha {} theta {}", c.alpha_deg, c.theta_deg);
        assert_zipin_fractions(&c, &r, &what);
    }
}

/// Nothing lost, and the weight leaving after k bounces (rho = 1: the photon
/// fraction) within 4 binomial standard errors of the Zipin fraction.
fn assert_zipin_fractions(c: &Case, r: &IncidenceResult, what: &str) {
    assert_eq!(r.lost(), 0.0, "{what}: {}", common::losses(r));
    let n = r.tallies.photons as f64;
    for (k, &w) in r.tallies.by_bounces.iter().enumerate() {
        let p = c
            .fractions
            .iter()
            .find(|&&(kk, _)| kk == k)
            .map_or(0.0, |&(_, p)| p);
        let measured = w / n;
        let sigma = (p * (1.0 - p) / n).sqrt();
        assert!(
            (measured - p).abs() <= 4.0 * sigma,
            "{what}: {k} bounces: measured {measured}, Zipin {p} (sigma {sigma})"
        );
    }
}

/// With a constant wall reflectance rho = 0.5 a photon leaving after k bounces
/// carries rho^k, so the reflectance is sum_k p_k rho^k (Zipin fractions),
/// within 4 reported standard errors (for the exact rows the reported error
/// is ~0 and the match is to rounding). Also, per bounce count, the weight
/// is exactly rho^k times the photon count of the rho = 1 run with the same
/// seed (same paths).
#[test]
fn reflectance_with_constant_rho_is_sum_of_powers() {
    let rho = 0.5_f64;
    for c in cases() {
        let what = format!("alpha {} theta {}", c.alpha_deg, c.theta_deg);
        let grey = trace(c.alpha_deg, c.theta_deg, rho);
        let white = trace(c.alpha_deg, c.theta_deg, 1.0);
        let expect: f64 = c
            .fractions
            .iter()
            .map(|&(k, p)| p * rho.powi(k as i32))
            .sum();
        let (mean, stderr) = grey.reflectance();
        // 1e-12: rounding of the sum when the reported error is zero.
        assert!(
            (mean - expect).abs() <= 4.0 * stderr + 1e-12,
            "{what}: reflectance {mean} +- {stderr}, expected {expect}"
        );
        for (k, (&g, &w)) in grey
            .tallies
            .by_bounces
            .iter()
            .zip(&white.tallies.by_bounces)
            .enumerate()
        {
            assert!(
                (g - w * rho.powi(k as i32)).abs() <= 1e-12 * w,
                "{what}: {k} bounces: weight {g} vs {w} photons"
            );
        }
    }
}

/// The grooves as a height field of `nx` columns (even) and 4 rows: vertex
/// `i` at `x = i W / nx` has height `2 min(i, nx - i) / nx` (exact decimals),
/// the apex (height 1) at `i = nx / 2`, the bottoms at `i = 0` (= `nx`).
fn grooves_field(alpha_deg: f64, theta_deg: f64, nx: usize) -> MicroScene {
    let width = 2.0 / alpha_deg.to_radians().tan();
    let row: Vec<String> = (0..nx)
        .map(|i| format!("{:?}", 2.0 * i.min(nx - i) as f64 / nx as f64))
        .collect();
    let map = std::env::temp_dir().join(format!(
        "roks-it-{}-grooves-{alpha_deg}-{nx}.txt",
        std::process::id()
    ));
    std::fs::write(&map, format!("{}\n", row.join(" ")).repeat(4)).unwrap();
    common::scene(
        &format!("grooves_field_{alpha_deg}"),
        &format!(
            r#"
[surface]
size = [{width:?}, 1.0]
material = "wall"
heightfield = {{ file = {:?} }}

[materials.wall]
reflectance = 1.0
{}"#,
            map.display().to_string(),
            light(theta_deg)
        ),
    )
}

/// The height-field grooves, with the grooves on 2 and on 16 grid columns,
/// leave after k bounces in the Zipin fractions (4 binomial sigma; exact
/// where the table says 0 or 1), with nothing lost.
#[test]
fn height_field_grooves_match_zipin() {
    for nx in [2, 16] {
        for c in cases() {
            let scene = grooves_field(c.alpha_deg, c.theta_deg, nx);
            assert_eq!(scene.surface.max_height, 1.0);
            let r = common::run(&scene).remove(0);
            let what = format!("{nx} columns, alpha {} theta {}", c.alpha_deg, c.theta_deg);
            assert_zipin_fractions(&c, &r, &what);
        }
    }
}
