//! Polarised transport through 3-D objects (`roks trace`) against exact
//! Fresnel optics.
//!
//! * **A specular wedge lit across its edge.** Two Fresnel planes meet in
//!   the y axis at a half-opening angle `alpha` (the groove `|x| < z tan
//!   alpha`); a beam along `-z` in the x-z plane, off the edge. Every normal
//!   lies in the x-z plane, so every plane of incidence is that plane and
//!   the s axis is `±y` at every bounce: s and p never mix. Unfolding the
//!   wedge, the ray crosses the images of the walls at polar angles
//!   `90° - (2m + 1) alpha` for every `m >= 0` with `(2m + 1) alpha < 180°`,
//!   at the incidence angles `|90° - (2m + 1) alpha|`, wherever the beam
//!   enters. The reflectance is exactly `(prod Rs + prod Rp) / 2` for
//!   unpolarised light, `prod Rs` for an s beam (its reference vector is
//!   `+y`, the s axis) and `prod Rp` for a p beam; the scalar approximation
//!   (`[transport] polarisation = false`) gives `prod (Rs + Rp) / 2`. Every
//!   photon follows the same angles, so all of it is exact (zero variance).
//! * **A Fresnel flat plate** lit along `-omega_i` in the x-z plane: the
//!   beam's reference vector, the s axis and the exit direction's reference
//!   vector are all `-y`, so the Stokes vector of the reflected light is the
//!   Fresnel matrix times the incident one in the same frame: `(Rs, Rs, 0, 0)`
//!   for an s beam, `(a, b, c, d)` (with the retardance `c + i d = rs rp*`)
//!   for a linear 45° beam.
//! * **A non-polarising cavity** (constant and Lambertian walls): forcing
//!   polarised transport changes no reflectance, bit for bit, whatever the
//!   incident state.
//!
//! The references are computed here in complex arithmetic (textbook
//! amplitudes, `m = n + i k`, `m cos θt` the principal root of `m² - sin² θ`),
//! independently of the crate's real closed forms.

mod object_common;

use num_complex::Complex64;
use object_common::{run, scene, scratch};

/// Fresnel amplitudes `(rs, rp)` at incidence angle `deg` into `n + i k`
/// (Verdet sign of `rp`: `rp = -rs` at normal incidence).
fn amplitudes(deg: f64, n: f64, k: f64) -> (Complex64, Complex64) {
    let c = deg.to_radians().cos();
    let m = Complex64::new(n, k);
    let u = (m * m - 1.0 + c * c).sqrt();
    let ct = u / m;
    ((c - u) / (c + u), (m * c - ct) / (m * c + ct))
}

/// `(Rs, Rp)` at incidence angle `deg`.
fn rs_rp(deg: f64, n: f64, k: f64) -> (f64, f64) {
    let (rs, rp) = amplitudes(deg, n, k);
    (rs.norm_sqr(), rp.norm_sqr())
}

/// Bound on the reported standard error of a zero-variance tally of mean
/// `scale`: only the rounding of `sum_sq / N - mean²` (relative `~1e-16`)
/// is left, so the error is about `sqrt(1e-16) scale` at most.
const ZERO_VARIANCE: f64 = 1e-7;

/// `|got - want| <= tol * scale`, with a message.
fn close(what: &str, got: f64, want: f64, tol: f64, scale: f64) {
    assert!(
        (got - want).abs() <= tol * scale,
        "{what}: got {got:e}, expected {want:e} (difference {:e}, allowed {:e})",
        got - want,
        tol * scale
    );
}

/// The wedge of half-opening `alpha_deg`, Fresnel walls `n + i k`, mouth at
/// z = 20; one source per state of `states` (TOML values), a beam of
/// diameter 0.8 along -z at x = 1.5; `transport` extra `[transport]` lines.
fn wedge(alpha_deg: f64, n: f64, k: f64, states: &[&str], transport: &str) -> String {
    let (s, c) = alpha_deg.to_radians().sin_cos();
    let mut sources = String::new();
    for st in states {
        sources.push_str(&format!(
            "[[sources]]\nbeam = {{ direction = [0.0, 0.0, -1.0], diameter = 0.8 }}\nposition = [1.5, 0.0, 21.0]\nphotons = 5000\npolarisation = {st}\n\n"
        ));
    }
    format!(
        r#"
seed = 3

[quadrics]
r = {{ plane = [{c}, 0.0, {ms}, 0.0] }}
l = {{ plane = [{mc}, 0.0, {ms}, 0.0] }}
top = {{ plane = [0.0, 0.0, 1.0, 20.0] }}
bot = {{ plane = [0.0, 0.0, 1.0, -1.0] }}
px = {{ plane = [1.0, 0.0, 0.0, 30.0] }}
mx = {{ plane = [1.0, 0.0, 0.0, -30.0] }}

[[cells]]
name = "groove"
region = "-r -l -top"
fill = "void"
[[cells]]
name = "block"
region = "-px +mx +bot -top ~(-r -l)"
fill = "solid"

[walls]
r = "metal"
l = "metal"

[models.metal]
n = {n}
k = {k}

{sources}
[transport]
roulette_weight = 0.0
{transport}
"#,
        ms = -s,
        mc = -c,
    )
}

/// Incidence angles (degrees) of a ray parallel to the bisector of a wedge
/// of half-opening `alpha_deg`, from the unfolding (see the module docs).
fn wedge_angles(alpha_deg: f64) -> Vec<f64> {
    (0..)
        .map(|m| f64::from(2 * m + 1) * alpha_deg)
        .take_while(|&a| a < 180.0)
        .map(|a| (90.0 - a).abs())
        .collect()
}

const MEDIA: [(f64, f64); 3] = [(1.6, 0.2), (1.015, 6.627), (0.43, 2.455)];

/// Unpolarised, s and p beams in the wedge: the polarised products exactly;
/// the Stokes vector leaving is `(S0, S1, 0, 0)` with
/// `S1 = (prod Rs - prod Rp) / 2`, `prod Rs`, `-prod Rp`.
#[test]
fn wedge_keeps_s_and_p_apart() {
    let alpha = 13.0;
    let angles = wedge_angles(alpha);
    assert_eq!(angles.len(), 7, "{angles:?}");
    for (n, k) in MEDIA {
        let prod = |f: &dyn Fn(f64, f64) -> f64| {
            angles.iter().map(|&a| {
                let (rs, rp) = rs_rp(a, n, k);
                f(rs, rp)
            }).product::<f64>()
        };
        let (ps, pp) = (prod(&|s, _| s), prod(&|_, p| p));
        let text = wedge(alpha, n, k, &["\"unpolarised\"", "\"s\"", "\"p\""], "");
        let sc = scene("wedge", &text, &scratch("wedge"));
        assert!(sc.run.polarisation, "a Fresnel wall turns polarisation on");
        let results = run(&sc);
        let want = [(0.5 * (ps + pp), 0.5 * (ps - pp)), (ps, ps), (pp, -pp)];
        for (r, (s0, s1)) in results.iter().zip(want) {
            let what = format!("n {n} k {k}, {}", r.beam.polarisation.name());
            let t = &r.tallies;
            assert_eq!(t.unmodelled.0, 0, "{what}");
            assert_eq!(t.bounces, 7 * t.photons, "{what}: every photon bounces 7 times");
            assert_eq!((t.lost, t.missed), (0.0, 0.0), "{what}");
            let (refl, se) = r.reflectance();
            close(&format!("{what}: reflectance"), refl, s0, 1e-12, s0);
            assert!(se <= ZERO_VARIANCE * s0, "{what}: stderr {se}");
            let (st, st_se) = r.stokes().expect("polarised run");
            assert_eq!(st[0], refl, "{what}: S0 is the reflectance");
            close(&format!("{what}: S1"), st[1], s1, 1e-12, s0);
            close(&format!("{what}: S2"), st[2], 0.0, 1e-12, s0);
            close(&format!("{what}: S3"), st[3], 0.0, 1e-12, s0);
            assert!(st_se.iter().all(|&e| e <= ZERO_VARIANCE * s0), "{what}: {st_se:?}");
        }
        // The s/p products really differ from the unpolarised product.
        let old = prod(&|s, p| 0.5 * (s + p));
        assert!(0.5 * (ps + pp) > 1.001 * old, "n {n} k {k}: {ps} {pp} {old}");
    }
}

/// `[transport] polarisation = false`: the old scalar weight, the product of
/// the unpolarised reflectances (for every incident state alike), and no
/// Stokes output.
#[test]
fn wedge_without_polarisation_is_the_unpolarised_product() {
    let alpha = 13.0;
    let angles = wedge_angles(alpha);
    for (n, k) in MEDIA {
        let old: f64 = angles
            .iter()
            .map(|&a| {
                let (rs, rp) = rs_rp(a, n, k);
                0.5 * (rs + rp)
            })
            .product();
        let text = wedge(alpha, n, k, &["\"unpolarised\"", "\"s\""], "polarisation = false");
        let sc = scene("wedge-scalar", &text, &scratch("wedge-scalar"));
        assert!(!sc.run.polarisation);
        for r in run(&sc) {
            let (refl, _) = r.reflectance();
            close(&format!("n {n} k {k}"), refl, old, 1e-12, old);
            assert!(r.stokes().is_none());
        }
    }
}

/// A Fresnel plate (top face z = 0) lit along `-omega_i`, omega_i =
/// (sin t, 0, cos t), by one beam per state of `states`.
fn plate(theta_deg: f64, n: f64, k: f64, states: &[&str]) -> String {
    let (s, c) = theta_deg.to_radians().sin_cos();
    let mut sources = String::new();
    for st in states {
        sources.push_str(&format!(
            "[[sources]]\nbeam = {{ direction = [{}, 0.0, {}], diameter = 2.0 }}\nposition = [{}, 0.0, {}]\nphotons = 3000\npolarisation = {st}\n\n",
            -s,
            -c,
            10.0 * s,
            10.0 * c
        ));
    }
    format!(
        r#"
[quadrics]
top = {{ plane = [0.0, 0.0, 1.0, 0.0] }}
bot = {{ plane = [0.0, 0.0, 1.0, -1.0] }}
px = {{ plane = [1.0, 0.0, 0.0, 10.0] }}
mx = {{ plane = [1.0, 0.0, 0.0, -10.0] }}
py = {{ plane = [0.0, 1.0, 0.0, 10.0] }}
my = {{ plane = [0.0, 1.0, 0.0, -10.0] }}

[[cells]]
name = "plate"
region = "-top +bot -px +mx -py +my"
fill = "solid"

[walls]
top = "metal"

[models.metal]
n = {n}
k = {k}

{sources}
[tally]
bands = 6
farfield = true
polarisation = "stokes"

[transport]
roulette_weight = 0.0
"#
    )
}

/// One Fresnel reflection: the Stokes vector leaving is the Fresnel matrix
/// times the incident state, retardance included, to 1e-12; the far-field
/// Stokes tally (one cell: the specular direction) holds the same vector.
#[test]
fn plate_applies_the_fresnel_matrix() {
    let states = ["\"s\"", "\"p\"", "{ linear = 45.0 }", "\"right\"", "\"unpolarised\""];
    for (n, k) in MEDIA {
        for theta in [30.0, 60.0, 80.0] {
            let (rs, rp) = amplitudes(theta, n, k);
            let (big_rs, big_rp) = (rs.norm_sqr(), rp.norm_sqr());
            let z = rs * rp.conj();
            let (a, b, c, d) = (0.5 * (big_rs + big_rp), 0.5 * (big_rs - big_rp), z.re, z.im);
            // M (S0, S1, S2, S3) with M = [[a, b, 0, 0], [b, a, 0, 0], [0, 0, c, -d], [0, 0, d, c]].
            let m = |s: [f64; 4]| {
                [
                    a * s[0] + b * s[1],
                    b * s[0] + a * s[1],
                    c * s[2] - d * s[3],
                    d * s[2] + c * s[3],
                ]
            };
            let incident = [
                [1.0, 1.0, 0.0, 0.0],
                [1.0, -1.0, 0.0, 0.0],
                [1.0, 0.0, 1.0, 0.0],
                [1.0, 0.0, 0.0, 1.0],
                [1.0, 0.0, 0.0, 0.0],
            ];
            let sc = scene("plate", &plate(theta, n, k, &states), &scratch("plate"));
            let results = run(&sc);
            let ff = sc.run.farfield_grid();
            for (r, s_in) in results.iter().zip(incident) {
                let what = format!("n {n} k {k} theta {theta}: {}", r.beam.polarisation.name());
                let want = m(s_in);
                let (st, st_se) = r.stokes().expect("polarised run");
                for j in 0..4 {
                    close(&format!("{what}: S{j}"), st[j], want[j], 1e-12, 1.0);
                    assert!(st_se[j] <= ZERO_VARIANCE, "{what}: stderr {st_se:?}");
                }
                // Far field: every photon leaves along the specular direction.
                let t = &r.tallies;
                let spec = glam::DVec3::new(-theta.to_radians().sin(), 0.0, theta.to_radians().cos());
                let mut probe = roks::tally::Accumulator::new(ff.n_cells());
                ff.score(&mut probe, spec, 1.0);
                let cell = probe.sum.iter().position(|&v| v == 1.0).expect("one cell");
                for j in 0..4 {
                    close(
                        &format!("{what}: far-field S{j}"),
                        t.farfield_stokes.mean(4 * cell + j, t.photons),
                        want[j],
                        1e-12,
                        1.0,
                    );
                }
            }
            // The s beam leaves as (Rs, Rs, 0, 0); a metal makes linear 45
            // deg light elliptical (S3 = d != 0).
            if k > 1.0 {
                assert!(d.abs() > 0.05, "n {n} k {k} theta {theta}: d = {d}");
            }
            close("Rs", results[0].stokes().unwrap().0[1], big_rs, 1e-12, 1.0);
        }
    }
}

/// A spherical cavity (radius 10, aperture above z = 6) with a non-polarising
/// wall `model` and strong roulette; one source per state.
fn cavity(model: &str, transport: &str) -> String {
    let mut sources = String::new();
    for st in ["\"unpolarised\"", "\"s\"", "\"right\"", "{ linear = 30.0 }", "[1.0, 0.3, -0.4, 0.5]"] {
        sources.push_str(&format!(
            "[[sources]]\nbeam = {{ direction = [0.3, 0.0, -1.0], diameter = 3.0 }}\nposition = [1.0, 0.5, 9.0]\nphotons = 9000\npolarisation = {st}\n\n"
        ));
    }
    format!(
        r#"
seed = 11

[quadrics]
s = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = 10.0 }} }}
o = {{ sphere = {{ center = [0.0, 0.0, 0.0], r = 11.0 }} }}
cut = {{ plane = [0.0, 0.0, 1.0, 6.0] }}

[[cells]]
name = "cavity"
region = "-s -cut"
fill = "void"
[[cells]]
name = "shell"
region = "+s -o -cut"
fill = "solid"

[walls]
s = "wall"

[models.wall]
{model}

{sources}
[tally]
bands = 5
farfield = true

[transport]
roulette_weight = 0.2
{transport}
"#
    )
}

/// Non-polarising walls (constant reflectance, ideal specular + Lambertian):
/// the scene runs the scalar path by default, and forcing polarised
/// transport gives the same reflectance, far field and bounce counts bit
/// for bit, for every incident state; the Stokes intensity is the reflectance.
#[test]
fn non_polarising_scene_is_unchanged_by_polarised_transport() {
    for model in ["reflectance = 0.9", "specular = 0.5\ndiffuse = 0.4"] {
        let dir = scratch("nonpol");
        let scalar = scene("nonpol", &cavity(model, ""), &dir);
        assert!(!scalar.run.polarisation, "{model}: no polarising wall");
        let forced = scene("nonpol-forced", &cavity(model, "polarisation = true"), &dir);
        assert!(forced.run.polarisation);
        for (a, b) in run(&scalar).iter().zip(&run(&forced)) {
            let what = format!("{model}: {}", a.beam.polarisation.name());
            assert_eq!(a.reflectance(), b.reflectance(), "{what}");
            assert_eq!(a.tallies.reflected, b.tallies.reflected, "{what}");
            assert_eq!(a.tallies.farfield, b.tallies.farfield, "{what}");
            assert_eq!(a.tallies.missed, b.tallies.missed, "{what}");
            assert_eq!((a.tallies.bounces, a.tallies.segments), (b.tallies.bounces, b.tallies.segments));
            assert!(a.tallies.bounces > 3 * a.tallies.photons, "{what}: a multi-bounce cavity");
            assert!(a.stokes().is_none());
            let (st, _) = b.stokes().unwrap();
            assert_eq!(st[0], b.reflectance().0, "{what}");
        }
    }
}
