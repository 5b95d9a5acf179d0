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

mod cli_common;
mod object_common;

use std::path::Path;
use std::process::Command;

use cli_common::{CAVITY, read, summary_without_timing};
use num_complex::Complex64;
use object_common::{run, scene, scratch};
use serde_json::Value;

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
            angles
                .iter()
                .map(|&a| {
                    let (rs, rp) = rs_rp(a, n, k);
                    f(rs, rp)
                })
                .product::<f64>()
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
            assert_eq!(
                t.bounces,
                7 * t.photons,
                "{what}: every photon bounces 7 times"
            );
            assert_eq!((t.lost, t.missed), (0.0, 0.0), "{what}");
            let (refl, se) = r.reflectance();
            close(&format!("{what}: reflectance"), refl, s0, 1e-12, s0);
            assert!(se <= ZERO_VARIANCE * s0, "{what}: stderr {se}");
            let (st, st_se) = r.stokes().expect("polarised run");
            assert_eq!(st[0], refl, "{what}: S0 is the reflectance");
            close(&format!("{what}: S1"), st[1], s1, 1e-12, s0);
            close(&format!("{what}: S2"), st[2], 0.0, 1e-12, s0);
            close(&format!("{what}: S3"), st[3], 0.0, 1e-12, s0);
            assert!(
                st_se.iter().all(|&e| e <= ZERO_VARIANCE * s0),
                "{what}: {st_se:?}"
            );
        }
        // The s/p products really differ from the unpolarised product.
        let old = prod(&|s, p| 0.5 * (s + p));
        assert!(
            0.5 * (ps + pp) > 1.001 * old,
            "n {n} k {k}: {ps} {pp} {old}"
        );
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
        let text = wedge(
            alpha,
            n,
            k,
            &["\"unpolarised\"", "\"s\""],
            "polarisation = false",
        );
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
    let states = [
        "\"s\"",
        "\"p\"",
        "{ linear = 45.0 }",
        "\"right\"",
        "\"unpolarised\"",
    ];
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
                let spec =
                    glam::DVec3::new(-theta.to_radians().sin(), 0.0, theta.to_radians().cos());
                let mut probe = roks::tally::Accumulator::new(ff.n_cells());
                ff.score(&mut probe, spec, 1.0);
                let cell = probe.sum.iter().position(|&v| v == 1.0).expect("one cell");
                for (j, w) in want.iter().enumerate() {
                    close(
                        &format!("{what}: far-field S{j}"),
                        t.farfield_stokes.mean(4 * cell + j, t.photons),
                        *w,
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

/// A spherical cavity (radius 10, aperture above z = 6) with wall `model`
/// and strong roulette; one source per state; `tally`, `transport`: extra
/// lines of those tables.
fn cavity(model: &str, tally: &str, transport: &str) -> String {
    let mut sources = String::new();
    for st in [
        "\"unpolarised\"",
        "\"s\"",
        "\"right\"",
        "{ linear = 30.0 }",
        "[1.0, 0.3, -0.4, 0.5]",
    ] {
        sources.push_str(&format!(
            "[[sources]]\nbeam = {{ direction = [0.3, 0.0, -1.0], diameter = 3.0 }}\nposition = [1.0, 0.5, 9.0]\nphotons = 9000\npolarisation = {st}\n\n"
        ));
    }
    format!(
        r#"
seed = 11

{CAVITY}
[walls]
s = "wall"

[models.wall]
{model}

{sources}
[tally]
bands = 5
farfield = true
{tally}

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
        let scalar = scene("nonpol", &cavity(model, "", ""), &dir);
        assert!(!scalar.run.polarisation, "{model}: no polarising wall");
        let forced = scene(
            "nonpol-forced",
            &cavity(model, "", "polarisation = true"),
            &dir,
        );
        assert!(forced.run.polarisation);
        for (a, b) in run(&scalar).iter().zip(&run(&forced)) {
            let what = format!("{model}: {}", a.beam.polarisation.name());
            assert_eq!(a.reflectance(), b.reflectance(), "{what}");
            assert_eq!(a.tallies.reflected, b.tallies.reflected, "{what}");
            assert_eq!(a.tallies.farfield, b.tallies.farfield, "{what}");
            assert_eq!(a.tallies.missed, b.tallies.missed, "{what}");
            assert_eq!(
                (a.tallies.bounces, a.tallies.segments),
                (b.tallies.bounces, b.tallies.segments)
            );
            assert!(
                a.tallies.bounces > 3 * a.tallies.photons,
                "{what}: a multi-bounce cavity"
            );
            assert!(a.stokes().is_none());
            let (st, _) = b.stokes().unwrap();
            assert_eq!(st[0], b.reflectance().0, "{what}");
        }
    }
}

/// `roks trace SCENE --out OUT -q` plus `extra`; panics on failure.
fn trace(scene: &Path, out: &Path, extra: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .arg("trace")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .arg("-q")
        .args(extra)
        .output()
        .expect("run roks");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The sources of `dir/summary.json`.
fn sources(dir: &Path) -> Vec<Value> {
    summary_without_timing(dir)["sources"]
        .as_array()
        .unwrap()
        .clone()
}

/// Through the binary: the wedge's summary.json has the polarised products
/// and the Stokes vectors; `--no-polarisation` gives the unpolarised product
/// (the old approximation) and no Stokes keys.
#[test]
fn no_polarisation_flag_gives_the_old_approximation() {
    let (n, k, alpha) = (1.6, 0.2, 13.0);
    let angles = wedge_angles(alpha);
    let sp: Vec<(f64, f64)> = angles.iter().map(|&a| rs_rp(a, n, k)).collect();
    let ps: f64 = sp.iter().map(|v| v.0).product();
    let pp: f64 = sp.iter().map(|v| v.1).product();
    let old: f64 = sp.iter().map(|v| 0.5 * (v.0 + v.1)).product();
    let dir = scratch("wedge-cli");
    let path = dir.join("wedge.toml");
    std::fs::write(&path, wedge(alpha, n, k, &["\"unpolarised\"", "\"s\""], "")).unwrap();
    trace(&path, &dir.join("pol"), &[]);
    trace(&path, &dir.join("scalar"), &["--no-polarisation"]);
    let pol = sources(&dir.join("pol"));
    for (src, (name, want)) in pol
        .iter()
        .zip([("unpolarised", 0.5 * (ps + pp)), ("s", ps)])
    {
        let refl = src["reflectance"].as_f64().unwrap();
        close(name, refl, want, 1e-12, want);
        assert_eq!(src["polarisation"], name);
        assert_eq!(src["stokes"][0].as_f64().unwrap(), refl);
        assert_eq!(src["stokes_stderr"].as_array().unwrap().len(), 4);
    }
    for src in sources(&dir.join("scalar")) {
        close(
            "scalar",
            src["reflectance"].as_f64().unwrap(),
            old,
            1e-12,
            old,
        );
        assert!(
            src.get("stokes").is_none() && src.get("polarisation").is_none(),
            "{src}"
        );
    }
    assert!(0.5 * (ps + pp) > 1.5 * old, "{ps} {pp} {old}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Fresnel cavity with roulette, five incident states, 9000 photons each
/// (three batches): `--threads 1` and `--threads 4` write the same
/// summary.json (Stokes entries included) and the same farfield_stokes.csv
/// byte for byte. The file is consistent with the others: its `s0` is
/// farfield.csv's `brdf` digit for digit, and its cells add up (times their
/// projected solid angles) to the summary's Stokes vector.
#[test]
fn stokes_outputs_same_for_any_thread_count() {
    let dir = scratch("stokes-threads");
    let path = dir.join("cavity.toml");
    std::fs::write(
        &path,
        cavity("n = 1.2\nk = 3.0", "polarisation = \"stokes\"", ""),
    )
    .unwrap();
    let (one, four) = (dir.join("t1"), dir.join("t4"));
    trace(&path, &one, &["--threads", "1"]);
    trace(&path, &four, &["--threads", "4"]);
    assert_eq!(summary_without_timing(&one), summary_without_timing(&four));
    for f in ["farfield_stokes.csv", "farfield.csv", "reflectance.csv"] {
        assert!(
            read(&one, f) == read(&four, f),
            "{f} differs between 1 and 4 threads"
        );
    }
    let text = String::from_utf8(read(&one, "farfield_stokes.csv")).unwrap();
    let ff = String::from_utf8(read(&one, "farfield.csv")).unwrap();
    let cells = 2 * 2 * 5 * 6; // two hemispheres of 2 M (M + 1) cells, M = 5
    assert_eq!(text.lines().count(), 1 + 5 * cells);
    let srcs = sources(&one);
    let mut sums = vec![[0.0; 4]; srcs.len()];
    for (l, f) in text.lines().skip(1).zip(ff.lines().skip(1)) {
        let c: Vec<&str> = l.split(',').collect();
        let fc: Vec<&str> = f.split(',').collect();
        assert_eq!(c[..11], fc[..11], "cell columns");
        assert_eq!((c[11], c[12]), (fc[13], fc[14]), "s0 is the brdf: {l}");
        let v: Vec<f64> = c.iter().map(|x| x.parse().unwrap()).collect();
        let (src, proj) = (v[0] as usize, v[10]);
        for j in 0..4 {
            sums[src][j] += v[11 + 2 * j] * proj;
        }
        let pol = (v[13] * v[13] + v[15] * v[15] + v[17] * v[17]).sqrt();
        let dop = if v[11] > 0.0 { pol / v[11] } else { 0.0 };
        assert!((v[19] - dop).abs() <= 1e-8 * dop.max(1.0), "{l}");
        assert!(v[19] <= 1.0 + 1e-9, "DoP above 1: {l}");
    }
    for (src, sum) in srcs.iter().zip(&sums) {
        let st: Vec<f64> = src["stokes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        for j in 0..4 {
            assert!(
                (sum[j] - st[j]).abs() <= 1e-7 * st[0],
                "{j}: {sum:?} vs {st:?}"
            );
        }
        assert!(src["mean_bounces"].as_f64().unwrap() > 3.0, "{src}");
    }
    // A polarised source leaves polarised: not every S1, S2, S3 is zero.
    assert!(
        srcs[1]["stokes"][1].as_f64().unwrap().abs() > 1e-3,
        "{:?}",
        srcs[1]
    );
    let _ = std::fs::remove_dir_all(&dir);
}
