//! Spectral runs (`[light] wavelengths_um`): one trace, a weight per
//! wavelength. Checked against separate monochrome runs (bit for bit where
//! the material does not vary, statistically on a rough surface), against
//! closed forms per wavelength (a flat Fresnel substrate, V-grooves), and
//! for the run-level contract: shards merge to the whole run, any thread
//! count gives the same bytes, bad spectral input is a one-line error.

mod cli_common;
mod common;

use std::path::Path;

use num_complex::Complex64;
use roks::transport::brdf::IncidenceResult;

use cli_common::{assert_input_error, read, roks, summary_without_timing};

const DEFAULT: &str = roks::scene::micro::DEFAULT_SCENE;

/// The default scene with `material` for its material table and `extra`
/// keys in `[light]`; 20 000 photons at 30 and 60 degrees.
fn default_with(material: &str, extra: &str) -> String {
    DEFAULT
        .replace("reflectance = 0.8", material)
        .replace("[light]", &format!("[light]\n{extra}"))
        .replace("photons = 1000000", "photons = 20000")
        .replace(
            "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
            "theta_deg = [30, 60]",
        )
}

/// Fresnel `(Rs, Rp)` of vacuum | n + ik at incidence `theta` (radians),
/// textbook form in complex arithmetic (Born & Wolf §14.2).
fn fresnel_sp(theta: f64, n: f64, k: f64) -> (f64, f64) {
    let eta = Complex64::new(n, k);
    let (s, c) = theta.sin_cos();
    let eta_cos_t = (eta * eta - s * s).sqrt();
    let rs = (c - eta_cos_t) / (c + eta_cos_t);
    let rp = (eta * eta * c - eta_cos_t) / (eta * eta * c + eta_cos_t);
    (rs.norm_sqr(), rp.norm_sqr())
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
}

/// A material that does not vary with wavelength: every wavelength of the
/// spectral run is the monochrome run bit for bit (same sums, same errors),
/// for the scalar weight, Stokes vectors and Mueller columns, random and
/// lattice entry.
#[test]
fn equal_wavelengths_are_the_monochrome_run_bit_for_bit() {
    for (material, extra_tally) in [
        ("reflectance = 0.8", ""),
        ("n = 1.015\nk = 6.627", ""),
        ("n = 1.015\nk = 6.627", "polarisation = \"mueller\""),
        ("n = 1.6\nk = 0.2", "\nlaunch = \"lattice\""),
    ] {
        let (light_extra, tally) = if extra_tally.starts_with("\nlaunch") {
            (extra_tally.trim(), "")
        } else {
            ("", extra_tally)
        };
        let tally = format!("[tally]\n{tally}");
        let mono_text = default_with(material, light_extra).replace("[tally]", &tally);
        let spec_text = default_with(
            material,
            &format!("wavelengths_um = [0.4, 0.5, 0.6]\n{light_extra}"),
        )
        .replace("[tally]", &tally);
        let mono = common::run(&common::scene("mono", &mono_text));
        let spec = common::run(&common::scene("spec", &spec_text));
        assert_eq!(spec.len(), 3 * mono.len());
        for (m, lanes) in mono.iter().zip(spec.chunks(3)) {
            for (l, s) in lanes.iter().enumerate() {
                assert_eq!(s.wavelength_um, Some([0.4, 0.5, 0.6][l]));
                assert_eq!(s.theta_i_deg, m.theta_i_deg);
                assert_eq!(s.tallies, m.tallies, "{material}: lane {l}");
            }
        }
    }
}

/// A flat substrate with n, k per wavelength: every photon reflects once,
/// so each wavelength's reflectance is the unpolarised Fresnel reflectance
/// `(Rs + Rp) / 2` of its own index, to rounding, with nothing lost.
#[test]
fn flat_substrate_is_fresnel_at_every_wavelength() {
    let n = [1.5, 0.43, 0.2, 1.015];
    let k = [0.0, 2.46, 3.1, 6.627];
    let text = format!(
        "[surface]\nsize = [1.0, 1.0]\nmaterial = \"m\"\n[materials.m]\nn = {n:?}\nk = {k:?}\n[light]\ntheta_deg = [0, 30, 60, 85]\nphotons = 5000\nwavelengths_um = [0.4, 0.5, 0.6, 0.7]\n"
    );
    let results = common::run(&common::scene("flat", &text));
    for r in &results {
        let l = [0.4, 0.5, 0.6, 0.7]
            .iter()
            .position(|w| Some(*w) == r.wavelength_um)
            .unwrap();
        let (rs, rp) = fresnel_sp(r.theta_i_deg.to_radians(), n[l], k[l]);
        let (mean, _) = r.reflectance();
        assert!(
            close(mean, 0.5 * (rs + rp), 1e-12),
            "theta {} lambda {:?}: {mean} vs {}",
            r.theta_i_deg,
            r.wavelength_um,
            0.5 * (rs + rp)
        );
        assert_eq!(r.lost(), 0.0);
        assert_eq!(r.tallies.bounces, r.tallies.photons);
    }
}

/// V-grooves of 45 degree walls lit at normal incidence: every photon
/// reflects twice, at 45 degrees, in the plane of incidence (s stays s), so
/// unpolarised light leaves with `(Rs² + Rp²) / 2` of its own index at
/// each wavelength (polarised transport), exactly; with constant
/// reflectances `rho_l` per wavelength, `rho_l²`.
#[test]
fn v_grooves_have_their_closed_form_at_every_wavelength() {
    let base = common::grooves_toml(45.0, 0.0, 1.0, 20_000, 7);
    let lambdas = "wavelengths_um = [0.45, 0.55, 0.65]\n";
    let n = [0.5, 0.9, 1.6];
    let k = [2.1, 3.5, 0.2];
    let fresnel = base
        .replace("reflectance = 1.0", &format!("n = {n:?}\nk = {k:?}"))
        .replace("[light]\n", &format!("[light]\n{lambdas}"));
    let r = common::run(&common::scene("grooves_fresnel", &fresnel));
    assert_eq!(r.len(), 3);
    for (l, lane) in r.iter().enumerate() {
        let (rs, rp) = fresnel_sp(45f64.to_radians(), n[l], k[l]);
        let expect = 0.5 * (rs * rs + rp * rp);
        let (mean, _) = lane.reflectance();
        assert!(close(mean, expect, 1e-12), "lane {l}: {mean} vs {expect}");
        assert_eq!(lane.tallies.bounces, 2 * lane.tallies.photons);
    }
    let rho = [0.3, 0.6, 0.9];
    let grey = base
        .replace("reflectance = 1.0", &format!("reflectance = {rho:?}"))
        .replace("[light]\n", &format!("[light]\n{lambdas}"));
    let r = common::run(&common::scene("grooves_rho", &grey));
    for (l, lane) in r.iter().enumerate() {
        let (mean, _) = lane.reflectance();
        assert!(close(mean, rho[l] * rho[l], 1e-12), "lane {l}: {mean}");
    }
}

/// A rough Fresnel surface (the default scene's bumps, aluminium-like
/// indices per wavelength): each wavelength of one spectral trace agrees
/// with a monochrome run of its own index and another seed within 4
/// combined standard errors, in the reflectance and in every Carlson cell
/// holding at least 1 % of the light (the roulette differs: on the largest
/// weight in the spectral run).
#[test]
fn rough_surface_wavelengths_agree_with_monochrome_runs() {
    let n = [0.49, 0.96, 1.83];
    let k = [4.86, 6.69, 8.31];
    let lambdas = [0.4, 0.55, 0.7];
    let scene = common::scene(
        "spec",
        &default_with(
            &format!("n = {n:?}\nk = {k:?}"),
            &format!("wavelengths_um = {lambdas:?}\n"),
        ),
    );
    let mut run = common::brdf_run(&scene);
    run.seed = 11;
    let spec = run.trace_whole(&scene.surface, &|_| {});
    for l in 0..3 {
        let mono = common::run(&common::scene(
            "mono",
            &default_with(&format!("n = {}\nk = {}", n[l], k[l]), ""),
        ));
        for (m, s) in mono.iter().zip(spec.iter().skip(l).step_by(3)) {
            assert_eq!(s.wavelength_um, Some(lambdas[l]));
            let ((a, ea), (b, eb)) = (m.reflectance(), s.reflectance());
            let sigma = ea.hypot(eb);
            assert!(
                (a - b).abs() <= 4.0 * sigma,
                "lambda {}: {a} vs {b} ({sigma})",
                lambdas[l]
            );
            check_cells(m, s);
        }
    }
}

fn check_cells(m: &IncidenceResult, s: &IncidenceResult) {
    let cells = m.tallies.carlson.len();
    for c in 0..cells {
        let a = m.tallies.carlson.mean(c, m.tallies.photons);
        let b = s.tallies.carlson.mean(c, s.tallies.photons);
        if a.max(b) < 0.01 {
            continue;
        }
        let sigma = m.carlson_stderr(c).hypot(s.carlson_stderr(c));
        assert!(
            (a - b).abs() <= 4.0 * sigma,
            "cell {c}: {a} vs {b} ({sigma})"
        );
    }
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The whole contract through the command line: `--wavelengths`, a
/// measured table (`nk`), shards merged equal to the whole run byte for
/// byte (lattice entry and mirror symmetry included), 1 and 2 threads give
/// the same bytes.
#[test]
fn shards_threads_and_options_per_wavelength() {
    let dir = std::env::temp_dir().join(format!("roks-spectral-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let gold = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/materials/gold.csv");
    let scene = write(
        &dir,
        "gold.toml",
        &default_with(
            &format!("nk = {:?}", gold.display().to_string()),
            "launch = \"lattice\"\n",
        )
        .replace("photons = 20000", "photons = 12288")
        .replace("[tally]", "[tally]\nsymmetry = \"mirror\""),
    );
    let s = scene.to_str().unwrap();
    let out = |name: &str| dir.join(name);
    let run = |name: &str, extra: &[&str]| {
        let o = out(name);
        let mut args = vec![
            "brdf",
            s,
            "--out",
            o.to_str().unwrap(),
            "-q",
            "--wavelengths",
            "0.5,0.6,0.7",
        ];
        args.extend_from_slice(extra);
        let r = roks(&args);
        assert!(
            r.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        o
    };
    let whole = run("whole", &["--threads", "2"]);
    let one = run("one", &["--threads", "1"]);
    for f in ["brdf.csv", "inplane.csv"] {
        assert_eq!(read(&whole, f), read(&one, f), "{f}: threads");
    }
    assert_eq!(summary_without_timing(&whole), summary_without_timing(&one));
    let a = run("sh0", &["--shard", "0/2"]);
    let b = run("sh1", &["--shard", "1/2"]);
    let merged = out("merged");
    let m = roks(&[
        "merge",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
        "-q",
    ]);
    assert!(m.status.success(), "{}", String::from_utf8_lossy(&m.stderr));
    for f in ["brdf.csv", "inplane.csv"] {
        assert_eq!(read(&whole, f), read(&merged, f), "{f}: shards");
    }
    let text = String::from_utf8(read(&whole, "brdf.csv")).unwrap();
    assert!(text.starts_with("theta_i_deg,phi_i_deg,wavelength_um,band,"));
    let summary: serde_json::Value = serde_json::from_slice(&read(&whole, "summary.json")).unwrap();
    assert_eq!(
        summary["run"]["wavelengths_um"],
        serde_json::json!([0.5, 0.6, 0.7])
    );
    for inc in summary["incidence"].as_array().unwrap() {
        let spectrum = inc["spectrum"].as_array().unwrap();
        assert_eq!(spectrum.len(), 3);
        let mean: f64 = spectrum
            .iter()
            .map(|w| w["reflectance"].as_f64().unwrap())
            .sum::<f64>()
            / 3.0;
        assert!(close(inc["reflectance"].as_f64().unwrap(), mean, 1e-15));
        // Gold reflects red more than green more than blue.
        let r: Vec<f64> = spectrum
            .iter()
            .map(|w| w["reflectance"].as_f64().unwrap())
            .collect();
        assert!(r[0] < r[1] && r[1] < r[2], "{r:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad spectral input: one line naming the file and the key, exit 2, no output.
#[test]
fn bad_spectral_input_is_one_line() {
    let dir = std::env::temp_dir().join(format!("roks-spectral-bad-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let gold = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/materials/gold.csv");
    let gold = format!("{:?}", gold.display().to_string());
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "array in a monochrome scene",
            default_with("n = [1.5, 1.6]", ""),
            vec!["materials.paint.n", "needs [light] wavelengths_um"],
        ),
        (
            "wrong length",
            default_with("n = [1.5, 1.6]", "wavelengths_um = [0.4, 0.5, 0.6]"),
            vec!["materials.paint.n", "2 values for 3 wavelengths"],
        ),
        (
            "outside the table",
            default_with(&format!("nk = {gold}"), "wavelengths_um = [0.5, 2.5]"),
            vec!["materials.paint.nk", "gold.csv", "outside the table"],
        ),
        (
            "nk without wavelengths",
            default_with(&format!("nk = {gold}"), ""),
            vec!["materials.paint.nk", "needs [light] wavelengths_um"],
        ),
        (
            "decreasing",
            default_with("reflectance = 0.5", "wavelengths_um = [0.5, 0.4]"),
            vec!["light.wavelengths_um[1]", "strictly increasing"],
        ),
        (
            "bad grid",
            default_with(
                "reflectance = 0.5",
                "wavelengths_um = { from = 0.4, to = 0.7, step = 0 }",
            ),
            vec!["light.wavelengths_um", "step must be > 0"],
        ),
        (
            "too many",
            default_with(
                "reflectance = 0.5",
                "wavelengths_um = { from = 0.3, to = 2.0, step = 0.001 }",
            ),
            vec!["light.wavelengths_um", "more than the 128"],
        ),
        (
            "reflectance out of range at one wavelength",
            default_with("reflectance = [0.5, 1.5]", "wavelengths_um = [0.4, 0.5]"),
            vec!["materials.paint.reflectance[1]", "must be in [0, 1]"],
        ),
    ];
    for (case, text, expect) in cases {
        let scene = write(&dir, "bad.toml", &text);
        let out = dir.join("out");
        let o = roks(&[
            "brdf",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert_input_error(case, &o, &scene, &out, &expect);
    }
    let scene = write(&dir, "ok.toml", &default_with("reflectance = 0.5", ""));
    let out = dir.join("out");
    let o = roks(&[
        "brdf",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--wavelengths",
        "0.5,0.4",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("--wavelengths") && stderr.contains("strictly increasing"),
        "{stderr}"
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
