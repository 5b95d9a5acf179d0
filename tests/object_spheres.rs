//! Convex spheres in a wide parallel beam (`roks trace`): the reflected
//! share, and the far field against the exact phase functions of a specular
//! and of a Lambertian sphere (shared/REFERENCE.md, "Cavities and spheres
//! (exact)").
//!
//! A beam of diameter D > 2 R centred on a sphere of radius R hits it with
//! probability (R / (D/2))^2 (uniform start points on the beam's disc); a
//! convex sphere reflects every photon once, so the reflectance is that share
//! times the single-reflection albedo, and the rest is `missed`.

mod object_common;

use std::f64::consts::PI;

use object_common::{assert_4sigma, band_cells, chi2_quantile, merged, run, scene, simpson};

/// Unit sphere at the origin, beam of diameter 3 along `dir` whose axis
/// passes through the centre, wall model `model` (TOML body), `bands` bands.
fn sphere_scene(model: &str, dir: [f64; 3], photons: u64, bands: usize) -> String {
    let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let pos = dir.map(|c| -5.0 * c / len);
    format!(
        r#"
seed = 3

[quadrics]
s = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = 1.0 }} }}

[[cells]]
name = "ball"
region = "-s"
fill = "solid"

[walls]
s = "m"

[models.m]
{model}

[[sources]]
beam = {{ direction = {dir:?}, diameter = 3.0 }}
position = {pos:?}
photons = {photons}

[tally]
bands = {bands}
farfield = true
"#
    )
}

/// Hit probability of the beam: (R / (D/2))^2 = (1 / 1.5)^2.
const HIT: f64 = 4.0 / 9.0;

/// Specular sphere of constant reflectance rho = 0.7: reflectance
/// rho (R / (D/2))^2 = 0.7 * 4/9, the rest missed; the far field is
/// isotropic (a parallel beam on a mirror sphere scatters with the cosine of
/// the scattering angle uniform), so each of the 4 K cells of the
/// full-sphere grid (each pi/K sr) expects reflectance / (4 K). Checked per
/// cell within 4 sigma and by a chi-square over all 80 cells (bands = 4).
#[test]
fn specular_sphere_isotropic_far_field() {
    let rho = 0.7;
    let n_ph = 1_000_000;
    // An oblique beam, so that the grid's axis is not a symmetry axis.
    let sc = scene(
        "spec",
        &sphere_scene("reflectance = 0.7", [1.0, 2.0, -2.0], n_ph, 4),
        ".".as_ref(),
    );
    let r = &run(&sc)[0];
    let t = &r.tallies;
    assert_eq!(t.photons, n_ph);
    assert_eq!(t.unmodelled.0, 0);
    assert_eq!(t.lost, 0.0);
    let want = rho * HIT;
    let (refl, se) = r.reflectance();
    assert_4sigma("reflectance", refl, want, se);
    // Missed photons carry weight 1 each: missed + reflected / rho = photons.
    let hits = t.reflected.sum[0] / rho;
    assert!(
        (t.missed + hits - n_ph as f64).abs() < 1e-6,
        "missed {} + hits {hits} != {n_ph}",
        t.missed
    );
    // One reflection per hit, never more (convex).
    assert_eq!(t.bounces as f64, hits.round());

    let ff = sc.run.farfield_grid();
    let grid = ff.grid;
    assert_eq!(grid.n_cells(), 40);
    let cells = ff.n_cells();
    assert_eq!(t.farfield.len(), cells);
    let per_cell = want * grid.solid_angle() / (4.0 * PI);
    assert!((per_cell * cells as f64 - want).abs() < 1e-15);
    let mut chi2 = 0.0;
    for c in 0..cells {
        let (f, fe) = (t.farfield.mean(c, n_ph), t.farfield.stderr(c, n_ph));
        assert_4sigma(&format!("far-field cell {c}"), f, per_cell, fe);
        chi2 += ((f - per_cell) / fe).powi(2);
    }
    // The sum over all cells is the reflectance (every escape is tallied).
    let total: f64 = t.farfield.sum.iter().sum();
    assert!((total - t.reflected.sum[0]).abs() < 1e-6 * total);
    // Chi-square with 80 degrees of freedom, upper quantile at z = 4
    // (p ~ 3e-5).
    let limit = chi2_quantile(cells as f64, 4.0);
    assert!(
        chi2 < limit,
        "chi-square {chi2} over {cells} cells (limit {limit})"
    );
}

/// Unpolarised Fresnel reflectance of a dielectric of index `n` (k = 0) at
/// incidence cosine `c`, from the textbook formulas (independent of roks).
fn fresnel_dielectric(n: f64, c: f64) -> f64 {
    let s2 = 1.0 - c * c;
    let ct = (1.0 - s2 / (n * n)).max(0.0).sqrt();
    let rs = ((c - n * ct) / (c + n * ct)).powi(2);
    let rp = ((n * c - ct) / (n * c + ct)).powi(2);
    0.5 * (rs + rp)
}

/// Specular sphere with Fresnel reflectance (n = 1.5): a ray of impact
/// parameter b = R sin(theta) meets the sphere at incidence theta, and b^2
/// is uniform over the lit disc, so the reflectance is
/// (R / (D/2))^2 * 2 * integral of R(theta) sin theta cos theta dtheta over
/// [0, pi/2] (REFERENCE.md), integrated here by Simpson's rule.
#[test]
fn fresnel_sphere_total_reflectance() {
    let n_ph = 1_000_000;
    let sc = scene(
        "fresnel",
        &sphere_scene("n = 1.5", [0.0, 0.0, -1.0], n_ph, 2),
        ".".as_ref(),
    );
    let r = &run(&sc)[0];
    assert_eq!(r.tallies.unmodelled.0, 0);
    assert_eq!(r.tallies.lost, 0.0);
    let albedo = 2.0
        * simpson(
            |t| fresnel_dielectric(1.5, t.cos()) * t.sin() * t.cos(),
            0.0,
            PI / 2.0,
            20_000,
        );
    // Sanity of the integral: normal incidence gives 0.04, the hemispherical
    // albedo of n = 1.5 is about 0.0918.
    assert!((fresnel_dielectric(1.5, 1.0) - 0.04).abs() < 1e-15);
    assert!((albedo - 0.0918).abs() < 5e-4, "{albedo}");
    let (refl, se) = r.reflectance();
    assert_4sigma("Fresnel sphere reflectance", refl, HIT * albedo, se);
}

/// The Lambert-sphere phase function (8 / 3 pi)(sin a + (pi - a) cos a).
fn lambert_phase(a: f64) -> f64 {
    8.0 / (3.0 * PI) * (a.sin() + (PI - a) * a.cos())
}

/// Lambertian sphere (diffuse = 0.9) in a wide beam along -z: the reflectance
/// is 0.9 (R / (D/2))^2 and the far field follows the Lambert-sphere phase
/// function p(a), a = angle between +z (back to the source) and the outgoing
/// direction, normalised so that p / (4 pi) integrates to 1 over the sphere
/// (checked numerically below; p(0) = 8/3). A cell of the full-sphere grid
/// between polar angles a1 < a2 (from +z) and of azimuth width dphi expects
/// reflectance * dphi / (4 pi) * integral of p(a) sin a da over [a1, a2]
/// (Simpson's rule). bands = 6: 168 cells, each within 4 sigma, plus the 12
/// band totals (exact stderr from the cells' sums of squares) and a
/// chi-square over all cells.
#[test]
fn lambertian_sphere_phase_function() {
    let rho = 0.9;
    let n_ph = 1_000_000;
    let sc = scene(
        "lambert",
        &sphere_scene("diffuse = 0.9", [0.0, 0.0, -1.0], n_ph, 6),
        ".".as_ref(),
    );
    let r = &run(&sc)[0];
    let t = &r.tallies;
    assert_eq!(t.unmodelled.0, 0);
    assert_eq!(t.lost, 0.0);
    let want = rho * HIT;
    let (refl, se) = r.reflectance();
    assert_4sigma("reflectance", refl, want, se);

    // Normalisation of the phase function, numerically:
    // (1 / 4 pi) * 2 pi * integral of p(a) sin a da = 1.
    let norm = 0.5 * simpson(|a| lambert_phase(a) * a.sin(), 0.0, PI, 20_000);
    assert!((norm - 1.0).abs() < 1e-10, "phase function norm {norm}");
    assert!((lambert_phase(0.0) - 8.0 / 3.0).abs() < 1e-15);

    let ff = sc.run.farfield_grid();
    let grid = ff.grid;
    let half = grid.n_cells();
    let share = |a1: f64, a2: f64, dphi: f64| {
        dphi / (4.0 * PI) * simpson(|a| lambert_phase(a) * a.sin(), a1, a2, 400)
    };
    let mut sum_expected = 0.0;
    let mut chi2 = 0.0;
    for c in 0..2 * half {
        let lower = c >= half;
        let (band, cell) = grid.band_cell(c % half);
        let (mu_bot, mu_top) = grid.mu_edges(band);
        let (phi_lo, phi_hi) = grid.phi_edges(band, cell);
        // Polar angles from +z: the mirror cell below spans pi - theta.
        let (a1, a2) = if lower {
            (PI - mu_bot.acos(), PI - mu_top.acos())
        } else {
            (mu_top.acos(), mu_bot.acos())
        };
        let expect = want * share(a1, a2, phi_hi - phi_lo);
        sum_expected += expect;
        let (f, fe) = (t.farfield.mean(c, n_ph), t.farfield.stderr(c, n_ph));
        assert_4sigma(
            &format!(
                "cell {c} (band {band}{}, cell {cell})",
                if lower { " below" } else { "" }
            ),
            f,
            expect,
            fe,
        );
        chi2 += ((f - expect) / fe).powi(2);
    }
    assert!(
        (sum_expected - want).abs() < 1e-9,
        "expected cell shares sum to {sum_expected}, not {want}"
    );
    let limit = chi2_quantile((2 * half) as f64, 4.0);
    assert!(
        chi2 < limit,
        "chi-square {chi2} over {} cells (limit {limit})",
        2 * half
    );

    // Band totals (both hemispheres): sharper than single cells.
    for band in 1..=grid.bands() {
        let (mu_bot, mu_top) = grid.mu_edges(band);
        for lower in [false, true] {
            let offset = if lower { half } else { 0 };
            let (f, fe) = merged(
                &t.farfield,
                band_cells(&grid, band).map(|c| c + offset),
                n_ph,
            );
            let (a1, a2) = if lower {
                (PI - mu_bot.acos(), PI - mu_top.acos())
            } else {
                (mu_top.acos(), mu_bot.acos())
            };
            let expect = want * share(a1, a2, 2.0 * PI);
            assert_4sigma(&format!("band {band} lower {lower}"), f, expect, fe);
        }
    }
}
