//! White furnace: a closed rough surface of perfectly reflecting material
//! (reflectance 1) must return every photon with weight exactly 1. Any photon
//! that leaks through a body, gets stuck, is cut by a numerical guard or the
//! bounce cap shows up as reflectance < 1 or lost > 0.
//!
//! Exact expectation: reflectance = 1 (weights are multiplied by 1.0 only, so
//! the sum of N ones is exactly N), stderr = 0, lost = 0, and all weight lands
//! in Carlson cells (every escape direction is finite and points up).

mod common;

use roks::scene::micro::{DEFAULT_SCENE, MicroScene};

const THETAS: &str = "[0.0, 30.0, 60.0, 80.0, 85.0, 89.0]";

fn check_furnace(scene: &MicroScene) {
    let results = common::run(scene);
    assert_eq!(results.len(), 6);
    for r in &results {
        let (mean, stderr) = r.reflectance();
        let what = format!("{} theta {}", scene.name, r.theta_i_deg);
        assert_eq!(r.lost(), 0.0, "{what}: lost {}", common::losses(r));
        assert_eq!(mean, 1.0, "{what}: reflectance {mean} (stderr {stderr})");
        assert_eq!(stderr, 0.0, "{what}");
        let carlson: f64 = r.tallies.carlson.sum.iter().sum();
        assert!(
            (carlson - r.tallies.photons as f64).abs() < 1e-9,
            "{what}: Carlson cells hold {carlson} of {} photons",
            r.tallies.photons
        );
        // The scene must really be rough: multiple reflections happen.
        assert!(r.mean_bounces() > 1.0, "{what}: {}", r.mean_bounces());
    }
}

/// The default scene (100 overlapping ellipsoids, periodic) made white.
#[test]
fn furnace_default_ellipsoids() {
    let white = DEFAULT_SCENE.replace("reflectance = 0.8", "reflectance = 1.0");
    assert_ne!(
        white, DEFAULT_SCENE,
        "default scene changed: update the furnace test"
    );
    let text = format!("{white}\n[transport]\nmax_bounces = 100000\n")
        .replace(
            "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
            &format!("theta_deg = {THETAS}"),
        )
        .replace("photons = 1000000", "photons = 100000");
    let scene = common::scene("furnace_default", &text);
    assert_eq!(scene.light.photons, 100_000);
    check_furnace(&scene);
}

/// Cones and ellipsoids-on-hyperboloids, circular and elliptic, densely
/// overlapping on a periodic cell.
#[test]
fn furnace_cones_and_hyperboloids() {
    let scene = common::scene(
        "furnace_mixed",
        &format!(
            r#"
[surface]
size = [20.0, 20.0]
material = "white"

[materials.white]
reflectance = 1.0

[[bumps]]
shape = "cone"
count = 40
radius = [1.5, 3.0]
radius_y = [1.0, 3.5]
height = [1.0, 4.0]
seed = 11

[[bumps]]
shape = "ellipsoid_on_hyperboloid"
count = 40
radius = [1.0, 2.0]
height = [1.0, 3.5]
cap = [0.3, 0.8]
base = [1.2, 2.0]
seed = 12

[light]
theta_deg = {THETAS}
photons = 100000
seed = 5
"#
        ),
    );
    check_furnace(&scene);
}

/// Posts (vertical walls, flat tops), paraboloids and sunken ellipsoids inside
/// reflecting side walls (the walls use the white substrate material).
#[test]
fn furnace_posts_paraboloids_reflecting_edges() {
    let scene = common::scene(
        "furnace_posts",
        &format!(
            r#"
[surface]
size = [15.0, 12.0]
edges = "reflecting"
material = "white"

[materials.white]
reflectance = 1.0

[[bumps]]
shape = "cylinder"
count = 15
radius = [0.5, 1.5]
height = [0.5, 3.0]
seed = 21

[[bumps]]
shape = "paraboloid"
count = 20
radius = [1.0, 2.5]
height = [1.0, 3.0]
seed = 22

[[bumps]]
shape = "ellipsoid"
count = 20
radius = [1.0, 2.0]
height = [0.5, 2.0]
depth = [0.0, 1.0]
seed = 23

[light]
theta_deg = {THETAS}
photons = 100000
seed = 6
"#
        ),
    );
    check_furnace(&scene);
}
