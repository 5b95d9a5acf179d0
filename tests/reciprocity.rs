//! Helmholtz reciprocity of the in-plane BRDF of a random periodic surface:
//! f(omega_i -> omega_o) = f(omega_o -> omega_i). It holds exactly for the
//! cell-averaged BRDF of any fixed geometry with specular facets and an
//! angle-symmetric per-bounce reflectance (here a constant rho = 0.8), so
//! equality within 4 combined reported standard errors is the test.
//!
//! Conventions: the light is at `omega_i = (sin t cos p, sin t sin p, cos t)`;
//! the in-plane tally for azimuth p has horizontal axis `u = (-cos p, -sin p, 0)`,
//! so the in-plane angle +b is the direction `(-sin b cos p, -sin b sin p, cos b)`
//! = toward_light(b, p + 180) and -b is toward_light(b, p). Hence the exact
//! reciprocal pairs are
//! * backward side: BRDF(a, p=0 -> -b) = BRDF(b, p=0 -> -a);
//! * forward side:  BRDF(a, p=0 -> +b) = BRDF(b, p=180 -> +a).
//!
//! Bin averaging: bins are 6 deg wide in the plane and 6 deg across
//! (`inplane_step_deg = 6`, `inplane_width_deg = 6`, bin centres at multiples
//! of 6 degrees), and every incidence angle used is a bin centre, so both sides of
//! a pair average f over the same-shaped window centred on the exact
//! reciprocal directions. The difference of the two averages is then second
//! order in the bin width, ~(0.105 rad)² / 24 f'' ≈ 5e-4 f''/f relative,
//! far below the ~2 % statistical error of each value.

mod common;

use roks::scene::micro::MicroScene;
use roks::tally::InPlaneTally;
use roks::transport::brdf::IncidenceResult;

fn scene(phi_deg: f64, thetas: &[f64]) -> MicroScene {
    let thetas: Vec<String> = thetas.iter().map(|t| format!("{t:?}")).collect();
    common::scene(
        "reciprocity",
        &format!(
            r#"
[surface]
size = [10.0, 10.0]
material = "paint"

[materials.paint]
reflectance = 0.8

[[bumps]]
shape = "ellipsoid"
count = 10
radius = [1.5, 2.5]
height = [1.0, 3.0]
seed = 31

[[bumps]]
shape = "cone"
count = 6
radius = [1.0, 2.0]
radius_y = [0.7, 2.0]
height = [1.0, 2.5]
seed = 32

[light]
theta_deg = [{}]
phi_deg = {phi_deg:?}
photons = 1000000
seed = 9

[tally]
inplane_step_deg = 6.0
inplane_width_deg = 6.0
"#,
            thetas.join(", ")
        ),
    )
}

/// In-plane BRDF (1/sr) and its standard error at the bin centred on `theta_o_deg`.
fn brdf_at(r: &IncidenceResult, tally: &InPlaneTally, theta_o_deg: f64) -> (f64, f64) {
    let bin = (0..tally.n_bins())
        .find(|&b| tally.centre_deg(b) == theta_o_deg)
        .unwrap_or_else(|| panic!("no in-plane bin centred on {theta_o_deg}"));
    let n = r.tallies.photons;
    let proj = tally.projected_solid_angle(bin);
    (
        r.tallies.inplane.mean(bin, n) / proj,
        r.tallies.inplane.stderr(bin, n) / proj,
    )
}

#[test]
fn inplane_brdf_is_reciprocal() {
    // Bin centres (multiples of 6 degrees).
    let thetas = [12.0, 24.0, 36.0, 48.0, 66.0];
    let fwd_thetas = [48.0, 66.0];
    let s0 = scene(0.0, &thetas);
    let s180 = scene(180.0, &fwd_thetas);
    let (run0, run180) = (common::brdf_run(&s0), common::brdf_run(&s180));
    let (t0, t180) = (run0.inplane(), run180.inplane());
    let r0 = run0.trace_whole(&s0.surface, &|_| {}).into_leaves();
    let r180 = run180.trace_whole(&s180.surface, &|_| {}).into_leaves();
    let at = |rs: &[IncidenceResult], theta: f64| -> usize {
        rs.iter().position(|r| r.theta_i_deg == theta).unwrap()
    };

    // (label, BRDF one way, BRDF the other way)
    let mut pairs = Vec::new();
    // Backward side: (a, 0 -> -b) and (b, 0 -> -a).
    for (i, &a) in thetas.iter().enumerate() {
        for &b in &thetas[i + 1..] {
            let x = brdf_at(&r0[at(&r0, a)], &t0, -b);
            let y = brdf_at(&r0[at(&r0, b)], &t0, -a);
            pairs.push((format!("({a}, 0 -> -{b}) vs ({b}, 0 -> -{a})"), x, y));
        }
    }
    // Forward side: (a, 0 -> +b) and (b, 180 -> +a), b != a (not the specular peak).
    for &b in &fwd_thetas {
        for &a in thetas.iter().filter(|&&a| a != b) {
            let x = brdf_at(&r0[at(&r0, a)], &t0, b);
            let y = brdf_at(&r180[at(&r180, b)], &t180, a);
            pairs.push((format!("({a}, 0 -> +{b}) vs ({b}, 180 -> +{a})"), x, y));
        }
    }
    assert_eq!(pairs.len(), 18);
    for (label, (x, sx), (y, sy)) in &pairs {
        let combined = (sx * sx + sy * sy).sqrt();
        println!("{label}: {:+.2} sigma", (x - y) / combined);
        // A meaningful comparison: values resolved to better than 10 %.
        assert!(
            *sx < 0.1 * x && *sy < 0.1 * y,
            "{label}: {x} +- {sx}, {y} +- {sy}"
        );
        assert!(
            (x - y).abs() <= 4.0 * combined,
            "{label}: {x} +- {sx} vs {y} +- {sy} ({:.1} sigma)",
            (x - y).abs() / combined
        );
    }
}
