//! Diffuse spherical cavity (`roks trace`, ideal Lambertian walls).
//!
//! A sphere of radius R with Lambertian walls of reflectance rho, the cap
//! above the plane z = h cut away as the aperture. The aperture's share of the
//! sphere's area is f = 2 pi R (R - h) / (4 pi R^2) = (R - h) / (2 R). In a
//! sphere, the light diffusely reflected by any wall element falls on the
//! sphere uniformly by area, so after every reflection a share f leaves
//! through the aperture whatever was lit first: the cavity reflectance is
//! rho f sum_k (rho (1 - f))^k = rho f / (1 - rho (1 - f)) exactly
//! (shared/REFERENCE.md, "Cavities and spheres (exact)"). The rest is
//! absorbed by the wall: absorbed = 1 - reflectance, missed = 0, lost = 0.

mod object_common;

use object_common::{assert_4sigma, run, scene, surface};

/// The cavity scene: radius 10, aperture plane z = h, beam `beam` (TOML).
fn cavity(rho: f64, h: f64, beam: &str, photons: u64, roulette: f64) -> String {
    format!(
        r#"
seed = 5

[quadrics]
s = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = 10.0 }} }}
o = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = 11.0 }} }}
cut = {{ plane = [0.0, 0.0, 1.0, {h}] }}

[[cells]]
name = "cavity"
region = "-s -cut"
fill = "void"
[[cells]]
name = "shell"
region = "+s -o -cut"
fill = "solid"

[walls]
s = "paint"

[models.paint]
diffuse = {rho}

[[sources]]
{beam}
photons = {photons}

[transport]
roulette_weight = {roulette}
"#
    )
}

/// rho f / (1 - rho (1 - f)) with f = (R - h) / (2 R).
fn expected(rho: f64, h: f64) -> f64 {
    let f = (10.0 - h) / 20.0;
    rho * f / (1.0 - rho * (1.0 - f))
}

fn check(rho: f64, h: f64, beam: &str, roulette: f64) {
    let what = format!("rho {rho}, h {h}, roulette {roulette}");
    let sc = scene(
        "cavity",
        &cavity(rho, h, beam, 500_000, roulette),
        ".".as_ref(),
    );
    let results = run(&sc);
    assert_eq!(results.len(), 1);
    let r = &results[0];
    let t = &r.tallies;
    let n = t.photons;
    assert_eq!(n, 500_000);
    assert_eq!(
        t.unmodelled.0, 0,
        "{what}: photons hit a surface without model"
    );
    assert_eq!(t.missed, 0.0, "{what}: every photon enters the cavity");
    assert_eq!(t.lost, 0.0, "{what}");
    let want = expected(rho, h);
    let (refl, se) = r.reflectance();
    assert_4sigma(&format!("{what}: reflectance"), refl, want, se);
    let s = surface(&sc, "s");
    let (abs, abs_se) = (t.absorbed.mean(s, n), t.absorbed.stderr(s, n));
    assert_4sigma(&format!("{what}: absorbed"), abs, 1.0 - want, abs_se);
    // Nothing else absorbs.
    for (i, name) in sc.object.surface_names.iter().enumerate() {
        if i != s {
            assert_eq!(t.absorbed.sum[i], 0.0, "{what}: absorbed on {name}");
        }
    }
    if roulette == 0.0 {
        // No Russian roulette: every history ends reflected or absorbed with
        // its weight split exactly, so the two add up to 1 (to rounding).
        assert!(
            (refl + abs - 1.0).abs() < 1e-9,
            "{what}: reflected {refl} + absorbed {abs} != 1"
        );
    }
    // Light really bounces around inside (not a one-reflection shortcut).
    assert!(t.bounces as f64 / n as f64 > 1.5, "{what}");
}

/// rho 0.5, aperture 20 % of the sphere; beam straight down through the
/// aperture from open space above it; no roulette.
#[test]
fn diffuse_sphere_cavity_half_reflecting_wide_aperture() {
    check(
        0.5,
        6.0,
        "beam = { direction = [0.0, 0.0, -1.0], diameter = 2.0 }\nposition = [0.0, 0.0, 7.0]",
        0.0,
    );
}

/// rho 0.9, aperture 10 %; oblique beam starting inside the void zone; no roulette.
#[test]
fn diffuse_sphere_cavity_bright_oblique_beam_inside() {
    check(
        0.9,
        8.0,
        "beam = { direction = [0.3, 0.2, -1.0], diameter = 3.0 }\nposition = [0.0, 0.0, 7.0]",
        0.0,
    );
}

/// rho 0.98, aperture 5 % (about 14 reflections per photon); with the
/// default Russian roulette, which must not bias the reflectance or the
/// absorbed share.
#[test]
fn diffuse_sphere_cavity_near_blackbody_with_roulette() {
    check(
        0.98,
        9.0,
        "beam = { direction = [0.0, 0.0, -1.0], diameter = 2.0 }\nposition = [0.0, 0.0, 12.0]",
        0.01,
    );
}
