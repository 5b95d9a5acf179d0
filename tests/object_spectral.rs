//! Spectral object traces (`roks trace` with `[light] wavelengths_um`):
//! one path, a weight per wavelength, every tally per wavelength.
//!
//! * **The same model at every wavelength** (a micro descent into the
//!   radiator's Z-302 stand-in, Fresnel, ideal specular + Lambertian walls;
//!   scalar and polarised transport): every wavelength's tallies equal the
//!   monochrome run's bit for bit (reflected, missed, absorbed per surface,
//!   lost, far field, Stokes, counts).
//! * **A specular wedge with a different `n + i k` per wavelength**: each
//!   wavelength's reflectance is the closed-form product of its Fresnel
//!   reflectances (see `tests/object_polarisation.rs` for the unfolding),
//!   s and p beams and the unpolarised approximation alike, to 1e-12.
//! * **Energy balance per wavelength**: absorbed (per surface) + reflected +
//!   missed + lost = 1 to rounding without Russian roulette (each history
//!   conserves its weight at every wavelength), and within four standard
//!   errors with it.
//! * **Determinism**: the files of a spectral run are the same byte for
//!   byte for 1, 2 and 4 threads; their layout (the `wavelength_um`
//!   columns, `summary.json`'s `spectrum`) as documented.
//! * **Bad input**: one line, exit status 2, nothing written.
//!
//! The references are computed here in complex arithmetic, independently of
//! the crate's real closed forms.

mod cli_common;
mod object_common;

use std::path::{Path, PathBuf};

use cli_common::{CAVITY, assert_input_error, read, roks, summary_without_timing};
use num_complex::Complex64;
use object_common::{run, scene, scratch};
use roks::scene::SceneFile;
use roks::scene::object::ObjectScene;
use roks::transport::object::PositionResult;

/// The repository's `scenes/` folder.
fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// An object scene from `text` with relative paths from `dir`, at
/// `wavelengths` (`None`: the text's own).
fn scene_at(name: &str, text: &str, dir: &Path, wavelengths: Option<&[f64]>) -> ObjectScene {
    let scene_file = SceneFile {
        file: format!("{name}.toml"),
        dir: dir.to_path_buf(),
    };
    let wavelengths = wavelengths.map(|w| roks::scene::WavelengthsSpec::List(w.to_vec()));
    ObjectScene::from_str_at(text, scene_file, name.into(), wavelengths.as_ref())
        .unwrap_or_else(|e| panic!("scene {name}: {e}"))
}

/// Each wavelength of `spectral` (position-major) equals the position of
/// `mono` bit for bit.
fn assert_lanes_equal(
    what: &str,
    mono: &[PositionResult],
    spectral: &[PositionResult],
    lanes: &[f64],
) {
    assert_eq!(spectral.len(), mono.len() * lanes.len(), "{what}");
    for (k, m) in mono.iter().enumerate() {
        assert!(m.wavelength_um.is_none());
        for (l, &w) in lanes.iter().enumerate() {
            let s = &spectral[k * lanes.len() + l];
            assert_eq!(s.wavelength_um, Some(w), "{what}");
            assert_eq!(s.beam.position, m.beam.position, "{what}");
            assert_eq!(
                s.tallies, m.tallies,
                "{what}: position {k}, {w} um differs from the monochrome run"
            );
        }
    }
}

/// A spherical cavity (radius 10, aperture above z = 6) with wall `model`,
/// `sources` beams (unpolarised, s, right), `extra` lines at the end.
fn cavity(model: &str, sources: usize, roulette: f64, extra: &str) -> String {
    let mut s = String::new();
    for st in ["\"unpolarised\"", "\"s\"", "\"right\""]
        .iter()
        .take(sources)
    {
        s.push_str(&format!(
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

{s}
[transport]
roulette_weight = {roulette}

{extra}
"#
    )
}

const LANES: [f64; 3] = [0.45, 0.55, 0.65];

/// A model that is the same at every wavelength: every lane is the
/// monochrome run bit for bit, for Fresnel (polarised and scalar), ideal
/// specular + Lambertian and micro-descent walls, with far-field and
/// Stokes tallies.
#[test]
fn the_same_model_at_every_wavelength_is_the_monochrome_run_bit_for_bit() {
    let dir = scratch("spectral-same");
    let tally = "[tally]\nbands = 5\nfarfield = true\n";
    let stokes = "[tally]\nbands = 5\nfarfield = true\npolarisation = \"stokes\"\n";
    for (model, extra) in [
        ("n = 1.2\nk = 3.0", stokes),
        ("n = 1.2\nk = 3.0", tally),
        ("specular = 0.5\ndiffuse = 0.4", tally),
        ("reflectance = 0.8", tally),
    ] {
        let text = cavity(model, 3, 0.2, extra);
        let mono = scene_at("same", &text, &dir, None);
        let spectral = scene_at("same", &text, &dir, Some(&LANES));
        assert_eq!(spectral.run.wavelengths_um, LANES);
        let mut runs = vec![(mono.clone(), spectral.clone())];
        if mono.run.polarisation && !mono.run.farfield_stokes {
            // And the scalar approximation of the same walls.
            let (mut a, mut b) = (mono, spectral);
            a.run.polarisation = false;
            b.run.polarisation = false;
            runs.push((a, b));
        }
        for (a, b) in runs {
            let what = format!("{model} (polarised {})", a.run.polarisation);
            let (ra, rb) = (run(&a), run(&b));
            assert!(ra.iter().all(|r| r.tallies.bounces > 2 * r.tallies.photons));
            assert_lanes_equal(&what, &ra, &rb, &LANES);
        }
    }
    // Micro descents into the radiator's walls (Fresnel n = 1.6, k = 0.2 at
    // every wavelength: the micro scene loaded at the object's wavelengths).
    let text = std::fs::read_to_string(scenes().join("radiator.toml")).unwrap();
    for polarised in [true, false] {
        let mut mono = scene_at("radiator", &text, &scenes(), None);
        let mut spectral = scene_at("radiator", &text, &scenes(), Some(&LANES));
        for s in [&mut mono, &mut spectral] {
            s.beams.truncate(3);
            s.photons = vec![700; 3];
            s.run.polarisation = polarised;
        }
        let (ra, rb) = (run(&mono), run(&spectral));
        assert!(ra.iter().all(|r| r.tallies.bounces > 2 * r.tallies.photons));
        assert_lanes_equal(
            &format!("radiator (polarised {polarised})"),
            &ra,
            &rb,
            &LANES,
        );
    }
}

/// Fresnel amplitudes `(rs, rp)` at incidence angle `deg` into `n + i k`.
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

/// The wedge of `tests/object_polarisation.rs` (half-opening `alpha_deg`,
/// mouth at z = 20, beam along -z at x = 1.5) with walls `model`, one
/// source per state, wavelengths `lanes`; `transport` extra lines.
fn wedge(alpha_deg: f64, model: &str, states: &[&str], lanes: &[f64], transport: &str) -> String {
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
{model}

{sources}
[light]
wavelengths_um = {lanes:?}

[transport]
roulette_weight = 0.0
{transport}
"#,
        ms = -s,
        mc = -c,
    )
}

/// Incidence angles (degrees) in a wedge of half-opening `alpha_deg`.
fn wedge_angles(alpha_deg: f64) -> Vec<f64> {
    (0..)
        .map(|m| f64::from(2 * m + 1) * alpha_deg)
        .take_while(|&a| a < 180.0)
        .map(|a| (90.0 - a).abs())
        .collect()
}

/// `|got - want| <= tol * scale`, with a message.
fn close(what: &str, got: f64, want: f64, tol: f64, scale: f64) {
    assert!(
        (got - want).abs() <= tol * scale,
        "{what}: got {got:e}, expected {want:e} (difference {:e}, allowed {:e})",
        got - want,
        tol * scale
    );
}

/// A different `n + i k` per wavelength in the wedge: per wavelength the
/// products of the Fresnel reflectances (unpolarised `(prod Rs + prod Rp) /
/// 2`, s `prod Rs`, p `prod Rp`, S1 accordingly; the scalar approximation
/// `prod (Rs + Rp) / 2`), and the absorbed shares of the two walls close the
/// balance, to 1e-12.
#[test]
fn a_wedge_with_n_and_k_per_wavelength_is_the_closed_form_at_each() {
    let alpha = 13.0;
    let angles = wedge_angles(alpha);
    assert_eq!(angles.len(), 7);
    let media = [(1.6, 0.2), (1.015, 6.627), (0.43, 2.455)];
    let model = "n = [1.6, 1.015, 0.43]\nk = [0.2, 6.627, 2.455]";
    let states = ["\"unpolarised\"", "\"s\"", "\"p\""];
    let dir = scratch("spectral-wedge");
    for scalar in [false, true] {
        let transport = if scalar { "polarisation = false" } else { "" };
        let sc = scene(
            "wedge",
            &wedge(alpha, model, &states, &LANES, transport),
            &dir,
        );
        assert_eq!(sc.run.polarisation, !scalar);
        let results = run(&sc);
        assert_eq!(results.len(), states.len() * LANES.len());
        for (i, r) in results.iter().enumerate() {
            let (state, l) = (i / LANES.len(), i % LANES.len());
            let (n, k) = media[l];
            assert_eq!(r.wavelength_um, Some(LANES[l]));
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
            let (s0, s1) = if scalar {
                (prod(&|s, p| 0.5 * (s + p)), 0.0)
            } else {
                [(0.5 * (ps + pp), 0.5 * (ps - pp)), (ps, ps), (pp, -pp)][state]
            };
            let what = format!("scalar {scalar}, {}, {} um", states[state], LANES[l]);
            let t = &r.tallies;
            assert_eq!(t.bounces, 7 * t.photons, "{what}");
            assert_eq!((t.lost, t.missed), (0.0, 0.0), "{what}");
            let (refl, se) = r.reflectance();
            close(&format!("{what}: reflectance"), refl, s0, 1e-12, s0);
            assert!(se <= 1e-7 * s0, "{what}: stderr {se}");
            if let Some((st, _)) = r.stokes() {
                assert_eq!(st[0], refl, "{what}");
                close(&format!("{what}: S1"), st[1], s1, 1e-12, s0);
                close(&format!("{what}: S2"), st[2], 0.0, 1e-12, s0);
            } else {
                assert!(scalar);
            }
            let n_ph = t.photons;
            let absorbed: f64 = (0..t.absorbed.len())
                .map(|b| t.absorbed.mean(b, n_ph))
                .sum();
            close(
                &format!("{what}: balance"),
                absorbed + refl,
                1.0,
                1e-12,
                1.0,
            );
        }
        // The wavelengths really differ.
        let r: Vec<f64> = results[..3].iter().map(|r| r.reflectance().0).collect();
        assert!(r[1] > 2.0 * r[0] && r[1] > 1.2 * r[2], "{r:?}");
    }
}

/// Per wavelength: the mean per photon of absorbed (all surfaces),
/// reflected, missed and lost, and the sum of their standard errors (a
/// bound of the standard error of their sum: the triangle inequality of
/// standard deviations; missed and lost count no errors and are 0 here).
fn balance(r: &PositionResult) -> (f64, f64) {
    let t = &r.tallies;
    let n = t.photons;
    let (refl, se) = r.reflectance();
    let mut total = refl + t.missed / n as f64 + t.lost / n as f64;
    let mut err = se;
    for b in 0..t.absorbed.len() {
        total += t.absorbed.mean(b, n);
        err += t.absorbed.stderr(b, n);
    }
    (total, err)
}

/// Energy balance per wavelength with measured spectra (aluminium and PMMA
/// in the thermal infrared): exact to rounding without roulette (Fresnel
/// walls; micro descents into rough aluminium), within four standard errors
/// with it.
#[test]
fn every_wavelength_balances() {
    let lanes = [3.0, 5.8, 9.0, 12.5];
    let dir = scratch("spectral-balance");
    let materials = scenes().join("materials");
    for file in ["aluminium-ir.csv", "pmma.csv"] {
        let model = format!("nk = \"{}\"", materials.join(file).display());
        for roulette in [0.0, 0.2] {
            let sc = scene_at(
                "balance",
                &cavity(&model, 1, roulette, ""),
                &dir,
                Some(&lanes),
            );
            let results = run(&sc);
            let spread: Vec<f64> = results.iter().map(|r| r.reflectance().0).collect();
            assert!(spread.iter().any(|&r| r != spread[0]), "{file}: {spread:?}");
            for r in &results {
                let what = format!("{file}, roulette {roulette}, {:?} um", r.wavelength_um);
                let (total, err) = balance(r);
                assert_eq!(r.tallies.lost, 0.0, "{what}");
                if roulette == 0.0 {
                    close(&what, total, 1.0, 1e-12, 1.0);
                } else {
                    assert!(err > 0.0, "{what}");
                    close(&what, total, 1.0, 4.0 * err, 1.0);
                }
            }
        }
    }
    // Micro descents into rough aluminium, no roulette anywhere.
    let text = std::fs::read_to_string(scenes().join("radiator-spectral-aluminium.toml"))
        .unwrap()
        .replace("roulette_weight = 1e-9", "roulette_weight = 0.0");
    let mut sc = scene_at("radiator-al", &text, &scenes(), Some(&lanes));
    sc.beams.truncate(2);
    sc.photons = vec![300; 2];
    let results = run(&sc);
    assert_eq!(results.len(), 2 * lanes.len());
    for r in &results {
        let what = format!("rough aluminium radiator, {:?} um", r.wavelength_um);
        assert!(
            r.tallies.bounces > 10 * r.tallies.photons,
            "{what}: a deep cavity"
        );
        close(&what, balance(r).0, 1.0, 1e-11, 1.0);
    }
}

/// `roks trace SCENE --out OUT -q` plus `extra`; panics on failure.
fn trace(scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "trace",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    args.extend_from_slice(extra);
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Through the binary, a spectral run with Stokes far-field tallies: the
/// same files for 1, 2 and 4 threads byte for byte; `--wavelengths`
/// overrides `[light]`; the layout: `wavelength_um` after the position
/// columns, rows position-major then wavelength; `summary.json` per source
/// a `spectrum` whose entries have `emissivity = 1 - reflectance - missed`
/// and whose mean is the source's own reflectance.
#[test]
fn spectral_files_are_the_same_for_any_thread_count() {
    let dir = scratch("spectral-cli");
    let path = dir.join("cavity.toml");
    let text = cavity(
        "n = [1.2, 0.9, 0.5]\nk = [3.0, 4.0, 6.0]",
        2,
        0.2,
        "[tally]\nbands = 3\nfarfield = true\npolarisation = \"stokes\"\n\n[light]\nwavelengths_um = [0.45, 0.55, 0.65]\n",
    );
    std::fs::write(&path, text).unwrap();
    let outs: Vec<PathBuf> = ["1", "2", "4"]
        .iter()
        .map(|t| {
            let out = dir.join(format!("t{t}"));
            trace(&path, &out, &["--threads", t]);
            out
        })
        .collect();
    for out in &outs[1..] {
        assert_eq!(
            summary_without_timing(&outs[0]),
            summary_without_timing(out)
        );
        for f in ["reflectance.csv", "farfield.csv", "farfield_stokes.csv"] {
            assert!(
                read(&outs[0], f) == read(out, f),
                "{f} differs with threads"
            );
        }
    }
    let refl = String::from_utf8(read(&outs[0], "reflectance.csv")).unwrap();
    let lines: Vec<&str> = refl.lines().collect();
    assert_eq!(
        lines[0],
        "x,y,z,wavelength_um,reflectance,reflectance_stderr"
    );
    assert_eq!(lines.len(), 1 + 2 * 3);
    let lambdas: Vec<&str> = lines[1..]
        .iter()
        .map(|l| l.split(',').nth(3).unwrap())
        .collect();
    assert_eq!(lambdas, ["0.45", "0.55", "0.65", "0.45", "0.55", "0.65"]);
    let ff = String::from_utf8(read(&outs[0], "farfield.csv")).unwrap();
    assert!(ff.starts_with("source,wavelength_um,band,cell,"));
    let cells = 2 * 2 * 3 * 4; // two hemispheres of 2 M (M + 1) cells, M = 3
    assert_eq!(ff.lines().count(), 1 + 2 * 3 * cells);
    let st = String::from_utf8(read(&outs[0], "farfield_stokes.csv")).unwrap();
    assert!(st.starts_with("source,wavelength_um,band,cell,"));
    // The far field of each wavelength adds up to its reflectance.
    let summary = summary_without_timing(&outs[0]);
    assert_eq!(
        summary["wavelengths_um"],
        serde_json::json!([0.45, 0.55, 0.65])
    );
    let sources = summary["sources"].as_array().unwrap();
    assert_eq!(sources.len(), 2);
    let mut ff_sums = [0.0; 6];
    for l in ff.lines().skip(1) {
        let c: Vec<&str> = l.split(',').collect();
        let (src, lambda): (usize, f64) = (c[0].parse().unwrap(), c[1].parse().unwrap());
        let lane = LANES.iter().position(|&w| w == lambda).unwrap();
        ff_sums[src * 3 + lane] += c[12].parse::<f64>().unwrap();
    }
    for (i, s) in sources.iter().enumerate() {
        let spectrum = s["spectrum"].as_array().unwrap();
        assert_eq!(spectrum.len(), 3);
        let mut mean = 0.0;
        for (l, w) in spectrum.iter().enumerate() {
            let f = |k: &str| w[k].as_f64().unwrap_or_else(|| panic!("{k} in {w}"));
            assert_eq!(f("wavelength_um"), LANES[l]);
            // (serde_json reads numbers to within an ulp, not exactly.)
            let emissivity = 1.0 - f("reflectance") - f("missed");
            close("emissivity", f("emissivity"), emissivity, 1e-15, 1.0);
            let (a, ae) = (
                w["absorbed"]["s"].as_f64().unwrap(),
                w["absorbed_stderr"]["s"].as_f64().unwrap(),
            );
            let total = a + f("reflectance") + f("missed") + f("lost");
            close(
                "balance",
                total,
                1.0,
                4.0 * (ae + f("reflectance_stderr")),
                1.0,
            );
            assert!(w["stokes"].as_array().unwrap().len() == 4);
            close(
                "far field sum",
                ff_sums[i * 3 + l],
                f("reflectance"),
                1e-8,
                1.0,
            );
            mean += f("reflectance") / 3.0;
        }
        close("mean", s["reflectance"].as_f64().unwrap(), mean, 1e-15, 1.0);
    }
    // --wavelengths replaces [light] wavelengths_um.
    let two = dir.join("two");
    let path2 = dir.join("cavity2.toml");
    let gold = format!("nk = \"{}\"", scenes().join("materials/gold.csv").display());
    std::fs::write(
        &path2,
        cavity(&gold, 1, 0.2, "[light]\nwavelengths_um = [0.5]\n"),
    )
    .unwrap();
    trace(&path2, &two, &["--wavelengths", "0.5:0.7:0.1"]);
    let s = summary_without_timing(&two);
    assert_eq!(s["wavelengths_um"], serde_json::json!([0.5, 0.6, 0.7]));
    let spectrum: Vec<f64> = s["sources"][0]["spectrum"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["reflectance"].as_f64().unwrap())
        .collect();
    // Gold reflects more in the red than in the green.
    assert!(spectrum[2] > spectrum[0], "{spectrum:?}");
}

/// Bad spectral input to `roks trace`: one line naming the file and key,
/// exit status 2, nothing written.
#[test]
fn bad_spectral_input_is_one_line() {
    let dir = scratch("spectral-bad");
    let micro_spectral = dir.join("micro.toml");
    std::fs::write(
        &micro_spectral,
        "[surface]\nsize = [4.0, 4.0]\nedges = \"periodic\"\nmaterial = \"m\"\n[materials.m]\nn = [1.5, 1.6]\n[light]\nwavelengths_um = [0.5, 0.6]\n",
    )
    .unwrap();
    let table = dir.join("brdf.csv");
    std::fs::write(
        &table,
        format!("{}\n", roks::output::brdf_csv::SPECTRAL_HEADER),
    )
    .unwrap();
    // A spectral table (a flat surface of n = 1.5 and 1.6), and one with a
    // broken mueller.csv beside it.
    let o = roks(&[
        "brdf",
        micro_spectral.to_str().unwrap(),
        "--theta",
        "0,40",
        "--photons",
        "1000",
        "--out",
        dir.join("tab").to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::create_dir_all(dir.join("tabm")).unwrap();
    std::fs::copy(dir.join("tab/brdf.csv"), dir.join("tabm/brdf.csv")).unwrap();
    std::fs::write(dir.join("tabm/mueller.csv"), "not read\n").unwrap();
    let nk = scenes().join("materials/gold.csv");
    let cases: Vec<(&str, String, Vec<&str>, &[&str])> = vec![
        (
            "n array without wavelengths",
            cavity("n = [1.5, 1.6]", 1, 0.2, ""),
            vec!["models.wall.n", "[light] wavelengths_um"],
            &[],
        ),
        (
            "n array of the wrong length",
            cavity(
                "n = [1.5, 1.6]",
                1,
                0.2,
                "[light]\nwavelengths_um = [0.5, 0.6, 0.7]\n",
            ),
            vec!["models.wall.n", "2 values for 3 wavelengths"],
            &[],
        ),
        (
            "nk without wavelengths",
            cavity(&format!("nk = \"{}\"", nk.display()), 1, 0.2, ""),
            vec!["models.wall.nk", "[light] wavelengths_um"],
            &[],
        ),
        (
            "nk outside its table",
            cavity(
                &format!("nk = \"{}\"", nk.display()),
                1,
                0.2,
                "[light]\nwavelengths_um = [5.0]\n",
            ),
            vec!["models.wall.nk", "gold.csv"],
            &[],
        ),
        (
            "a micro-scene key in [light]",
            cavity("reflectance = 0.5", 1, 0.2, "[light]\ntheta_deg = [0]\n"),
            vec!["theta_deg"],
            &[],
        ),
        (
            "bad wavelengths",
            cavity(
                "reflectance = 0.5",
                1,
                0.2,
                "[light]\nwavelengths_um = [0.6, 0.5]\n",
            ),
            vec!["light.wavelengths_um"],
            &[],
        ),
        (
            "a spectral micro scene in a monochrome object",
            cavity("micro = \"micro.toml\"", 1, 0.2, ""),
            vec!["models.wall.micro", "[light] wavelengths_um"],
            &[],
        ),
        (
            "a spectral brdf table in a monochrome object",
            cavity("brdf = \"tab/brdf.csv\"", 1, 0.2, ""),
            vec![
                "models.wall.brdf",
                "spectral table",
                "monochrome",
                "0.5, 0.6",
            ],
            &[],
        ),
        (
            "a wavelength the spectral table does not have",
            cavity(
                "brdf = \"tab/brdf.csv\"",
                1,
                0.2,
                "[light]\nwavelengths_um = [0.5, 0.55]\n",
            ),
            vec!["models.wall.brdf", "no table at 0.55 um"],
            &[],
        ),
        (
            "a spectral table with a mueller.csv that is not one beside it",
            cavity(
                "brdf = \"tabm/brdf.csv\"",
                1,
                0.2,
                "[light]\nwavelengths_um = [0.5]\n",
            ),
            vec!["models.wall.brdf", "mueller.csv", "header"],
            &[],
        ),
        (
            "an empty spectral table",
            cavity(
                "brdf = \"brdf.csv\"",
                1,
                0.2,
                "[light]\nwavelengths_um = [0.5]\n",
            ),
            vec!["models.wall.brdf", "brdf.csv"],
            &[],
        ),
    ];
    for (case, text, expect, extra) in cases {
        let scene = dir.join("bad.toml");
        std::fs::write(&scene, text).unwrap();
        let out = dir.join("out");
        let mut args = vec![
            "trace",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ];
        args.extend_from_slice(extra);
        assert_input_error(case, &roks(&args), &scene, &out, &expect);
    }
    // A bad --wavelengths is clap's one line (exit 2).
    let scene = dir.join("ok.toml");
    std::fs::write(&scene, cavity("reflectance = 0.5", 1, 0.2, "")).unwrap();
    let o = roks(&[
        "trace",
        scene.to_str().unwrap(),
        "--wavelengths",
        "0.5,abc",
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

/// A rough wall whose material differs between wavelengths (micro descents
/// into rough aluminium in the radiator, Ordal's n + ik at 3 and 12 µm): each
/// wavelength of one spectral trace agrees with a monochrome trace of that
/// wavelength's n + ik (an independent seed) within four combined standard
/// errors, reflectance and absorbed share alike.
#[test]
fn a_rough_spectral_wall_agrees_with_monochrome_runs_statistically() {
    let lanes = [3.0, 12.0];
    let dir = scratch("spectral-vs-mono");
    let nk = roks::optics::spectrum::NkSpectrum::read(&scenes().join("materials/aluminium-ir.csv"))
        .unwrap()
        .sample(&lanes)
        .unwrap();
    let object =
        std::fs::read_to_string(scenes().join("radiator-spectral-aluminium.toml")).unwrap();
    let micro =
        std::fs::read_to_string(scenes().join("radiator-spectral-aluminium-micro.toml")).unwrap();
    let beams = |mut s: ObjectScene| {
        s.beams.truncate(2);
        s.photons = vec![2000; 2];
        s
    };
    let spectral = run(&beams(scene_at("al", &object, &scenes(), Some(&lanes))));
    assert_eq!(spectral.len(), 2 * lanes.len());
    for (l, nk) in nk.iter().enumerate() {
        let micro_l = micro
            .replace(
                "nk = \"materials/aluminium-ir.csv\"",
                &format!("n = {:?}\nk = {:?}", nk.n, nk.k),
            )
            .replace(
                "wavelengths_um = { from = 3.0, to = 14.0, step = 0.5 }\n",
                "",
            );
        assert_ne!(micro_l, micro);
        std::fs::write(dir.join(format!("micro-{l}.toml")), micro_l).unwrap();
        let object_l = object
            .replace(
                "radiator-spectral-aluminium-micro.toml",
                &format!("micro-{l}.toml"),
            )
            .replace("seed = 1", "seed = 2")
            .replace("wavelengths_um = { from = 3.0, to = 14.0, step = 0.5 }", "");
        let mono = run(&beams(scene_at("al-mono", &object_l, &dir, None)));
        assert!(mono[0].wavelength_um.is_none());
        for (k, m) in mono.iter().enumerate() {
            let s = &spectral[k * lanes.len() + l];
            assert_eq!(s.wavelength_um, Some(lanes[l]));
            let what = format!("position {k}, {} um", lanes[l]);
            let ((rs, es), (rm, em)) = (s.reflectance(), m.reflectance());
            assert!(es > 0.0 && em > 0.0);
            close(
                &format!("{what}: reflectance"),
                rs,
                rm,
                4.0 * es.hypot(em),
                1.0,
            );
            let n = (s.tallies.photons, m.tallies.photons);
            for b in 0..s.tallies.absorbed.len() {
                let (a, ae) = (
                    s.tallies.absorbed.mean(b, n.0),
                    s.tallies.absorbed.stderr(b, n.0),
                );
                let (c, ce) = (
                    m.tallies.absorbed.mean(b, n.1),
                    m.tallies.absorbed.stderr(b, n.1),
                );
                close(
                    &format!("{what}: absorbed[{b}]"),
                    a,
                    c,
                    4.0 * ae.hypot(ce),
                    1.0,
                );
            }
        }
    }
    // The two wavelengths really differ by more than the noise.
    let (r3, e3) = spectral[0].reflectance();
    let (r12, e12) = spectral[1].reflectance();
    assert!((r3 - r12).abs() > 4.0 * e3.hypot(e12), "{r3} {r12}");
}

/// `roks brdf` of micro scene `scene` (`None`: the default scene) at
/// `theta` (degrees, comma separated): its monochrome `brdf.csv`, in
/// `dir/name`.
fn micro_table(scene: Option<&str>, dir: &Path, name: &str, theta: &str) -> PathBuf {
    let out = dir.join(name);
    let scene = scene.map(|s| scenes().join(s).to_str().unwrap().to_owned());
    let mut args: Vec<&str> = vec!["brdf"];
    args.extend(scene.as_deref());
    args.extend([
        "--theta",
        theta,
        "--photons",
        "20000",
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out.join("brdf.csv")
}

/// A spectral `brdf.csv` in `dir/name` made of monochrome tables (on one
/// grid at the same incidences): at wavelength `lanes[l].0` the table at
/// `lanes[l].1` with every fraction, BRDF and standard error times
/// `lanes[l].2` (a power of two, so exactly).
fn spectral_table(dir: &Path, name: &str, lanes: &[(f64, &Path, f64)]) -> PathBuf {
    let rows: Vec<Vec<Vec<String>>> = lanes
        .iter()
        .map(|(_, p, _)| {
            let text = std::fs::read_to_string(p).unwrap();
            let mut lines = text.lines();
            assert_eq!(lines.next(), Some(roks::output::brdf_csv::HEADER));
            lines
                .map(|l| l.split(',').map(str::to_owned).collect())
                .collect()
        })
        .collect();
    let mut out = format!("{}\n", roks::output::brdf_csv::SPECTRAL_HEADER);
    // Blocks of one incidence are consecutive; each is repeated per wavelength.
    let first = &rows[0];
    let mut start = 0;
    while start < first.len() {
        let end = start
            + first[start..]
                .iter()
                .take_while(|r| r[..2] == first[start][..2])
                .count();
        for ((w, _, c), rows) in lanes.iter().zip(&rows) {
            for r in &rows[start..end] {
                assert_eq!(r[..2], first[start][..2], "same incidences");
                let mut cols = r.clone();
                for v in &mut cols[12..16] {
                    *v = format!("{:e}", c * v.parse::<f64>().unwrap());
                }
                cols.insert(2, w.to_string());
                out.push_str(&cols.join(","));
                out.push('\n');
            }
        }
        start = end;
    }
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("brdf.csv"), out).unwrap();
    d.join("brdf.csv")
}

/// A spectral BRDF table as an object wall (each wavelength its own table,
/// directions sampled from their mean, lane `l` weighed by `f_l / f_mean`):
/// * every wavelength holding the same table: each lane is the monochrome
///   table's run bit for bit (the mean of two equal tables is the table,
///   so the path and every factor are the same numbers), also for the
///   object's wavelengths a subset of the table's;
/// * tables in proportion `c_l` on a flat plate lit once at the table's one
///   incidence: lane `l` reflects exactly `c_l R` with `R` the table's sum
///   of fractions (no variance), to 1e-12, and absorbs the rest;
/// * two different tables (the default scene's and the Z-302 stand-in's) in
///   the cavity: each lane agrees with the monochrome run of its own table
///   (another seed) within four combined standard errors, reflectance and
///   absorbed share, and the two lanes differ by more than that.
#[test]
fn a_spectral_brdf_table_wall_weighs_each_wavelength_by_its_table() {
    let dir = scratch("spectral-table-wall");
    let mono_csv = micro_table(None, &dir, "mono", "0,30,60");
    let same = spectral_table(
        &dir,
        "same",
        &[(0.5, &mono_csv, 1.0), (0.6, &mono_csv, 1.0)],
    );
    let model = |p: &Path| format!("brdf = \"{}\"", p.display());
    let extra = "[tally]\nbands = 5\nfarfield = true\n";
    let mono_csv_cavity = mono_csv.clone();
    let mono = run(&scene_at(
        "t",
        &cavity(&model(&mono_csv), 2, 0.2, extra),
        &dir,
        None,
    ));
    assert!(
        mono.iter()
            .all(|r| r.tallies.bounces > 2 * r.tallies.photons)
    );
    for lanes in [&[0.5, 0.6][..], &[0.6][..]] {
        let text = cavity(&model(&same), 2, 0.2, extra);
        let spectral = run(&scene_at("t", &text, &dir, Some(lanes)));
        assert_lanes_equal("equal tables", &mono, &spectral, lanes);
    }

    // One incidence, three wavelengths in proportion 1 : 1/2 : 1/4.
    let one = scratch("spectral-table-plate");
    let mono_csv = micro_table(None, &one, "mono", "30");
    let r: f64 = std::fs::read_to_string(&mono_csv)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(12).unwrap().parse::<f64>().unwrap())
        .sum();
    assert!(r > 0.5 && r < 1.0, "{r}");
    let c = [(0.4, 1.0), (0.5, 0.5), (0.6, 0.25)];
    let scaled: Vec<(f64, &Path, f64)> =
        c.iter().map(|&(w, c)| (w, mono_csv.as_path(), c)).collect();
    let prop = spectral_table(&one, "prop", &scaled);
    let (s, co) = (30_f64.to_radians().sin(), 30_f64.to_radians().cos());
    let plate = format!(
        "seed = 5\n[quadrics]\ntop = {{ plane = [0.0, 0.0, 1.0, 0.0] }}\n[[cells]]\nname = \"slab\"\nregion = \"-top\"\nfill = \"solid\"\n[walls]\ntop = \"wall\"\n[models.wall]\n{}\n[[sources]]\nbeam = {{ direction = [{s:?}, 0.0, {:?}], diameter = 1.0 }}\nposition = [0.0, 0.0, 5.0]\nphotons = 3000\n",
        model(&prop),
        -co
    );
    let lanes: Vec<f64> = c.iter().map(|l| l.0).collect();
    let res = run(&scene_at("plate", &plate, &one, Some(&lanes)));
    assert_eq!(res.len(), 3);
    for (res, (w, c)) in res.iter().zip(c) {
        assert_eq!(res.wavelength_um, Some(w));
        let (got, _) = res.reflectance();
        close(&format!("plate at {w} um"), got, c * r, 1e-12, 1.0);
        let n = res.tallies.photons;
        let absorbed: f64 = (0..res.tallies.absorbed.len())
            .map(|b| res.tallies.absorbed.mean(b, n))
            .sum();
        close(
            &format!("plate at {w} um: absorbed"),
            absorbed,
            1.0 - c * r,
            1e-12,
            1.0,
        );
    }

    // Two different tables, against monochrome runs of each.
    let z302 = micro_table(Some("z302-micro.toml"), &dir, "z302", "0,30,60");
    let two = spectral_table(
        &dir,
        "two",
        &[(0.5, &mono_csv_cavity, 1.0), (0.6, &z302, 1.0)],
    );
    let spectral = run(&scene_at(
        "two",
        &cavity(&model(&two), 1, 0.2, ""),
        &dir,
        Some(&[0.5, 0.6]),
    ));
    for (l, table) in [&mono_csv_cavity, &z302].into_iter().enumerate() {
        let text = cavity(&model(table), 1, 0.2, "").replace("seed = 11", "seed = 12");
        let mono = run(&scene_at("one", &text, &dir, None));
        let s = &spectral[l];
        let m = &mono[0];
        let what = format!("table {l}");
        let ((rs, es), (rm, em)) = (s.reflectance(), m.reflectance());
        assert!(es > 0.0 && em > 0.0, "{what}");
        close(
            &format!("{what}: reflectance"),
            rs,
            rm,
            4.0 * es.hypot(em),
            1.0,
        );
        let n = (s.tallies.photons, m.tallies.photons);
        let a = (
            s.tallies.absorbed.mean(0, n.0),
            s.tallies.absorbed.stderr(0, n.0),
        );
        let b = (
            m.tallies.absorbed.mean(0, n.1),
            m.tallies.absorbed.stderr(0, n.1),
        );
        close(
            &format!("{what}: absorbed"),
            a.0,
            b.0,
            4.0 * a.1.hypot(b.1),
            1.0,
        );
    }
    let ((r0, e0), (r1, e1)) = (spectral[0].reflectance(), spectral[1].reflectance());
    assert!((r0 - r1).abs() > 4.0 * e0.hypot(e1), "{r0} {r1}");
}

/// A spectral `mueller.csv` in `dir/name` beside `brdf.csv` (made by
/// [`spectral_table`] from the same monochrome tables): at wavelength
/// `lanes[l].0` the monochrome `mueller.csv` at `lanes[l].1`, or with
/// `lanes[l].2` only its `m00` (the BRDF of a depolarising wall: every
/// other element and standard error 0).
fn spectral_mueller(dir: &Path, name: &str, lanes: &[(f64, &Path, bool)]) -> PathBuf {
    let header = roks::output::polar_csv::MUELLER_HEADER;
    let rows: Vec<Vec<Vec<String>>> = lanes
        .iter()
        .map(|(_, p, _)| {
            let text = std::fs::read_to_string(p).unwrap();
            let mut lines = text.lines();
            assert_eq!(lines.next(), Some(header));
            lines
                .map(|l| l.split(',').map(str::to_owned).collect())
                .collect()
        })
        .collect();
    let mut out = format!(
        "{}\n",
        header.replacen("phi_i_deg,", "phi_i_deg,wavelength_um,", 1)
    );
    let first = &rows[0];
    let mut start = 0;
    while start < first.len() {
        let end = start
            + first[start..]
                .iter()
                .take_while(|r| r[..2] == first[start][..2])
                .count();
        for ((w, _, m00_only), rows) in lanes.iter().zip(&rows) {
            for r in &rows[start..end] {
                let mut cols = r.clone();
                if *m00_only {
                    for v in &mut cols[7..] {
                        *v = "0".into();
                    }
                }
                cols.insert(2, w.to_string());
                out.push_str(&cols.join(","));
                out.push('\n');
            }
        }
        start = end;
    }
    let path = dir.join(name).join("mueller.csv");
    std::fs::write(&path, out).unwrap();
    path
}

/// A spectral BRDF table with its run's spectral `mueller.csv` as an
/// object wall: each wavelength is transferred by the Mueller matrix of its
/// own table in the cell chosen. A polarising table (the default bumps in
/// aluminium, n = 1.015 + 6.627i; 3 beams: unpolarised, s and right
/// circular), without Russian roulette:
/// * the same table and Mueller table at two wavelengths: each lane is the
///   monochrome run of the table with its `mueller.csv` bit for bit;
/// * the same table at two wavelengths, the first with its Mueller table
///   and the second with only `m00` (a depolarising table): both lanes
///   follow the same path (equal fractions), and lane 0 agrees with the
///   monochrome Mueller run, lane 1 with the monochrome run of the table
///   without `mueller.csv` (a depolarising wall), to 1e-12 relative: a
///   wall's local history is scaled to the brightest lane and back, so only
///   that rounding separates them, while the two monochrome runs differ by
///   far more (checked), so the matrices are the lanes' own.
///
/// A spectral `mueller.csv` that does not fit (a monochrome file, a
/// wavelength the table lacks, a file cut short) is one line naming it.
#[test]
fn a_spectral_mueller_table_wall_transfers_each_wavelength_by_its_matrix() {
    let dir = scratch("spectral-mueller-wall");
    let al = dir.join("al.toml");
    let text = std::fs::read_to_string(scenes().join("default.toml")).unwrap();
    assert!(text.contains("reflectance = 0.8"));
    std::fs::write(
        &al,
        text.replace("reflectance = 0.8", "n = 1.015\nk = 6.627"),
    )
    .unwrap();
    let mono_dir = dir.join("mono");
    let o = roks(&[
        "brdf",
        al.to_str().unwrap(),
        "--theta",
        "0,30,60",
        "--photons",
        "20000",
        "--polarisation",
        "mueller",
        "--out",
        mono_dir.to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (mono_csv, mono_mueller) = (mono_dir.join("brdf.csv"), mono_dir.join("mueller.csv"));
    // The same table without its mueller.csv: a depolarising wall.
    let plain = dir.join("plain");
    std::fs::create_dir_all(&plain).unwrap();
    std::fs::copy(&mono_csv, plain.join("brdf.csv")).unwrap();
    let model = |p: &Path| format!("brdf = \"{}\"", p.display());
    let extra = "[tally]\nbands = 5\nfarfield = true\n";
    let with = run(&scene_at(
        "w",
        &cavity(&model(&mono_csv), 3, 0.0, extra),
        &dir,
        None,
    ));
    let without = run(&scene_at(
        "p",
        &cavity(&model(&plain.join("brdf.csv")), 3, 0.0, extra),
        &dir,
        None,
    ));
    let lanes = [0.5, 0.6];
    // The table at both wavelengths, the second lane's Mueller table
    // reduced to m00 when `m00_only`; traced at both.
    let traced = |name: &str, m00_only: bool| {
        let table = spectral_table(&dir, name, &[(0.5, &mono_csv, 1.0), (0.6, &mono_csv, 1.0)]);
        spectral_mueller(
            &dir,
            name,
            &[(0.5, &mono_mueller, false), (0.6, &mono_mueller, m00_only)],
        );
        run(&scene_at(
            name,
            &cavity(&model(&table), 3, 0.0, extra),
            &dir,
            Some(&lanes),
        ))
    };
    assert_lanes_equal(
        "equal Mueller tables",
        &with,
        &traced("same", false),
        &lanes,
    );

    let spectral = traced("both", true);
    assert_eq!(spectral.len(), 2 * with.len());
    let rel = |a: f64, b: f64| (a - b).abs() / a.abs().max(b.abs()).max(1e-300);
    let sums = |t: &roks::transport::object::ObjectTallies| -> Vec<f64> {
        let mut v = t.reflected.sum.clone();
        v.extend(&t.absorbed.sum);
        v.extend(&t.farfield.sum);
        v
    };
    for (k, (w, p)) in with.iter().zip(&without).enumerate() {
        let (a, b) = (sums(&w.tallies), sums(&p.tallies));
        let apart = a
            .iter()
            .zip(&b)
            .map(|(a, b)| rel(*a, *b))
            .fold(0.0, f64::max);
        assert!(
            apart > 1e-6,
            "position {k}: polarisation changes the cavity ({apart})"
        );
        for (l, mono) in [w, p].into_iter().enumerate() {
            let s = &spectral[2 * k + l];
            assert_eq!(s.wavelength_um, Some(lanes[l]));
            assert_eq!(
                (s.tallies.bounces, s.tallies.segments),
                (mono.tallies.bounces, mono.tallies.segments)
            );
            let (mut got, mut want) = (sums(&s.tallies), sums(&mono.tallies));
            if l == 0 {
                got.extend(&s.tallies.stokes.sum);
                want.extend(&mono.tallies.stokes.sum);
            } else {
                // Depolarised at every wall (the scalar monochrome run has
                // no Stokes tally).
                let st = &s.tallies.stokes.sum;
                assert_eq!(st[0], s.tallies.reflected.sum[0]);
                assert_eq!(st[1..], [0.0; 3], "position {k}, lane 1");
            }
            assert_eq!(got.len(), want.len());
            for (i, (g, m)) in got.iter().zip(&want).enumerate() {
                assert!(
                    rel(*g, *m) <= 1e-12 || (g - m).abs() < 1e-12,
                    "position {k}, lane {l}, sum {i}: {g} against {m}"
                );
            }
        }
    }

    // Spectral Mueller files that do not fit: one line naming the file.
    let good = std::fs::read_to_string(dir.join("both/mueller.csv")).unwrap();
    let cut: String = good
        .lines()
        .take(good.lines().count() / 2)
        .map(|l| format!("{l}\n"))
        .collect();
    let cases = [
        (
            "a monochrome mueller.csv beside a spectral table",
            std::fs::read_to_string(&mono_mueller).unwrap(),
            vec!["mueller.csv", "line 1", "one wavelength"],
        ),
        (
            "a wavelength the table lacks",
            good.replacen(",0.6,", ",0.7,", 1),
            vec!["mueller.csv", "wavelength_um = 0.7"],
        ),
        (
            "a file cut short",
            cut,
            vec!["mueller.csv", "incidence block"],
        ),
    ];
    for (case, text, expect) in cases {
        let bad = dir.join("bad");
        std::fs::create_dir_all(&bad).unwrap();
        std::fs::copy(dir.join("both/brdf.csv"), bad.join("brdf.csv")).unwrap();
        std::fs::write(bad.join("mueller.csv"), text).unwrap();
        let scene = dir.join("bad.toml");
        std::fs::write(
            &scene,
            cavity(
                "brdf = \"bad/brdf.csv\"",
                1,
                0.2,
                "[light]\nwavelengths_um = [0.5, 0.6]\n",
            ),
        )
        .unwrap();
        let out = dir.join("out");
        let o = roks(&[
            "trace",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        let mut expect = expect;
        expect.insert(0, "models.wall.brdf");
        assert_input_error(case, &o, &scene, &out, &expect);
    }
}
