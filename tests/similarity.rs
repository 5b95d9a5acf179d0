//! Similarity: geometric optics has no length scale, so scaling every length
//! of a scene (cell size, bump radii and heights, quadric constants) by 1e-3,
//! 1e3, 1e-9 or 1e9 must leave the reflectance and the Carlson BRDF unchanged, with no
//! photon lost. Ratios (cap, base, plane normals) are not lengths and stay.
//!
//! Expectations, two levels:
//! * statistical (the physics): each scaled result agrees with the unscaled
//!   one within 4 combined reported standard errors;
//! * exact (the code): with the same seed each photon starts at the same
//!   point in cell units and follows the same path up to rounding, as long as
//!   no tolerance in the tracer is an absolute length. A photon whose path
//!   changes moves the reflectance by ~1/N = 1e-5 relative, so agreement to
//!   1e-9 relative (observed: ~2e-15) says every path stayed the same. The
//!   same bound is applied to every Carlson cell (relative to the total).

mod common;

use roks::transport::brdf::IncidenceResult;

/// The default scene (ellipsoids, constant rho = 0.8) with lengths times `l`.
fn ellipsoids(l: f64) -> String {
    let x = |v: f64| format!("{:?}", v * l);
    format!(
        r#"
[surface]
size = [{}, {}]
material = "paint"

[materials.paint]
reflectance = 0.8

[[bumps]]
shape = "ellipsoid"
count = 100
radius = [{}, {}]
height = [{}, {}]
seed = 1

[light]
theta_deg = [0.0, 40.0, 80.0]
photons = 100000
seed = 2

[tally]
bands = 8
"#,
        x(30.0),
        x(30.0),
        x(2.5),
        x(3.5),
        x(0.8),
        x(4.8)
    )
}

/// Fresnel Al (weights depend on every local angle), cones,
/// ellipsoids-on-hyperboloids, an explicit sphere and a tilted plane floor,
/// with lengths times `l`.
fn mixed(l: f64) -> String {
    let x = |v: f64| format!("{:?}", v * l);
    format!(
        r#"
[surface]
size = [{}, {}]
material = "al"

[materials.al]
n = 1.015
k = 6.627

[[bumps]]
shape = "cone"
count = 15
radius = [{}, {}]
height = [{}, {}]
seed = 41

[[bumps]]
shape = "ellipsoid_on_hyperboloid"
count = 15
radius = [{}, {}]
height = [{}, {}]
cap = [0.3, 0.7]
base = [1.3, 1.8]
seed = 42

[quadrics]
ball = {{ sphere = {{ center = [{}, {}, {}], r = {} }} }}
tilt = {{ plane = [0.1, 0.05, 1.0, {}] }}

[[bodies]]
region = "-ball"

[[bodies]]
region = "-tilt"

[light]
theta_deg = [0.0, 40.0, 80.0]
phi_deg = 20.0
photons = 100000
seed = 2

[tally]
bands = 8
"#,
        x(12.0),
        x(10.0),
        x(1.0),
        x(2.0),
        x(1.0),
        x(3.0),
        x(0.8),
        x(1.5),
        x(1.0),
        x(2.5),
        x(6.0),
        x(5.0),
        x(-0.5),
        x(2.0),
        x(0.5)
    )
}

fn compare(name: &str, base: &[IncidenceResult], scaled: &[IncidenceResult], l: f64) {
    assert_eq!(base.len(), scaled.len());
    for (a, b) in base.iter().zip(scaled) {
        let what = format!("{name} x{l:e} theta {}", a.theta_i_deg);
        assert_eq!(a.lost(), 0.0, "{what}: unscaled {}", common::losses(a));
        assert_eq!(b.lost(), 0.0, "{what}: scaled {}", common::losses(b));
        let (ra, sa) = a.reflectance();
        let (rb, sb) = b.reflectance();
        let combined = (sa * sa + sb * sb).sqrt();
        assert!(
            combined > 0.0,
            "{what}: no statistical error to compare with"
        );
        assert!(
            (ra - rb).abs() <= 4.0 * combined,
            "{what}: reflectance {ra} +- {sa} vs {rb} +- {sb}"
        );
        assert!(
            (ra - rb).abs() <= 1e-9 * ra,
            "{what}: reflectance {ra} vs {rb}: relative {:e}",
            (ra - rb) / ra
        );
        let n = a.tallies.photons;
        for c in 0..a.tallies.carlson.len() {
            let (fa, ea) = (a.tallies.carlson.mean(c, n), a.tallies.carlson.stderr(c, n));
            let (fb, eb) = (b.tallies.carlson.mean(c, n), b.tallies.carlson.stderr(c, n));
            assert!(
                (fa - fb).abs() <= 4.0 * (ea * ea + eb * eb).sqrt() + 1e-9 * ra,
                "{what}: cell {c}: {fa} +- {ea} vs {fb} +- {eb}"
            );
            assert!(
                (fa - fb).abs() <= 1e-9 * ra,
                "{what}: cell {c}: {fa} vs {fb}"
            );
        }
    }
}

fn check_scale_invariance(name: &str, text: fn(f64) -> String) {
    let base = common::run(&common::scene(name, &text(1.0)));
    assert!(
        base.iter().all(|r| r.mean_bounces() > 1.0),
        "{name}: not rough"
    );
    for l in [1e-3, 1e3, 1e-9, 1e9] {
        let scaled = common::run(&common::scene(name, &text(l)));
        compare(name, &base, &scaled, l);
    }
}

/// Constant reflectance: only the number of bounces matters.
#[test]
fn scale_invariance_ellipsoids() {
    check_scale_invariance("ellipsoids", ellipsoids);
}

/// Fresnel reflectance and explicit quadric bodies (sphere, plane constant).
#[test]
fn scale_invariance_mixed_fresnel() {
    check_scale_invariance("mixed", mixed);
}
