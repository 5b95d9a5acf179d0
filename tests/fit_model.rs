//! `roks fit-model`: each model fitted to a synthetic `brdf.csv` made from
//! the model itself (known parameters, Gaussian noise of the stated
//! `brdf_stderr`) gives its parameters back within 4 of its stated
//! standard errors and chi²/dof within 4 sqrt(2/dof) of 1; GGX and
//! Beckmann fitted to the table of a Gaussian height field traced by `roks
//! brdf` land near the RMS slope `roks stats` reports, the multiple
//! scattering shown; bad input is one line and exit status 2.

mod cli_common;

use std::path::{Path, PathBuf};

use cli_common::roks;
use roks::fit_model::{Model, abg::Abg, harvey::Harvey, microfacet, synthetic};
use roks::output::brdf_csv::{Block, write_blocks};
use roks::tally::CarlsonGrid;
use serde_json::Value;

/// A fresh folder under the target's temporary directory.
fn folder(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("fit_model-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Write the synthetic table of `model` into `dir/brdf.csv` (no summary).
fn write_table(
    dir: &Path,
    model: &dyn Model,
    q_of: impl Fn(usize) -> Vec<f64>,
    thetas: &[f64],
    bands: usize,
    seed: u64,
) {
    let blocks = synthetic(model, q_of, thetas, bands, 0.03, seed);
    let grid = CarlsonGrid::new(bands).unwrap();
    let text = write_blocks(
        &grid,
        blocks.iter().map(|(t, p, f, e)| Block {
            theta_i_deg: *t,
            phi_i_deg: *p,
            wavelength_um: None,
            fractions: f,
            stderr: e,
        }),
    );
    std::fs::write(dir.join("brdf.csv"), text).unwrap();
}

/// Run `roks fit-model` and read its JSON; every warning of the JSON is a
/// line `warning: ...` of stderr, and there are no others.
fn fit(dir: &Path, args: &[&str]) -> Value {
    fit_and_stderr(dir, args).0
}

/// [`fit`], with its stderr.
fn fit_and_stderr(dir: &Path, args: &[&str]) -> (Value, String) {
    let mut all = vec!["fit-model", dir.to_str().unwrap()];
    all.extend_from_slice(args);
    let o = roks(&all);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {stderr}");
    eprintln!("{stderr}");
    let model = args[1];
    let v: Value =
        serde_json::from_slice(&std::fs::read(dir.join(format!("fit_{model}.json"))).unwrap())
            .unwrap();
    let lines: Vec<&str> = stderr
        .lines()
        .filter_map(|l| l.strip_prefix("warning: "))
        .collect();
    let warnings: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert_eq!(lines, warnings, "{stderr}");
    (v, stderr)
}

/// Every reflectance verdict of `v` recomputed from the numbers it
/// reports: `ok` exactly when `|table - model| <= max(1 % of table, 4
/// table_stderr)`; returns the verdicts.
fn verdicts(v: &Value) -> Vec<bool> {
    let mut out = Vec::new();
    for f in v["fits"].as_array().unwrap() {
        for r in f["reflectance"].as_array().unwrap() {
            let n = |k: &str| r[k].as_f64().unwrap();
            let (table, model, se) = (n("table"), n("model"), n("table_stderr"));
            let allowed = (0.01 * table).max(4.0 * se);
            assert_eq!(n("tolerance"), allowed, "{r}");
            let ok = r["ok"].as_bool().unwrap();
            assert_eq!(ok, (table - model).abs() <= allowed, "{r}");
            out.push(ok);
        }
    }
    out
}

/// Every fit's parameters within 4 standard errors of `truth(k)` (fit `k`)
/// and chi²/dof within 4 sqrt(2/dof) of 1; a table the model represents
/// passes every judgement: every reflectance `ok`, every fit converged, no
/// warning.
fn check(v: &Value, truth: impl Fn(usize) -> Vec<f64>) {
    assert!(verdicts(v).iter().all(|&ok| ok), "{}", v["fits"]);
    assert_eq!(
        v["warnings"].as_array().unwrap().len(),
        0,
        "{}",
        v["warnings"]
    );
    assert!(
        v["verdict"].as_str().unwrap().contains(": ok: "),
        "{}",
        v["verdict"]
    );
    for (k, f) in v["fits"].as_array().unwrap().iter().enumerate() {
        assert_eq!(f["converged"], true, "fit {k}: {}", f["termination"]);
        for (p, t) in f["parameters"].as_array().unwrap().iter().zip(truth(k)) {
            let (value, se) = (p["value"].as_f64().unwrap(), p["stderr"].as_f64().unwrap());
            assert!(
                se > 0.0 && (value - t).abs() < 4.0 * se,
                "fit {k} {}: {value} +- {se}, true {t}",
                p["name"]
            );
        }
        let (c, dof) = (
            f["chi2_per_dof"].as_f64().unwrap(),
            f["dof"].as_f64().unwrap(),
        );
        assert!(
            (c - 1.0).abs() < 4.0 * (2.0 / dof).sqrt(),
            "fit {k}: chi2/dof {c}"
        );
    }
}

#[test]
fn abg_gives_back_its_parameters_per_incidence() {
    let dir = folder("abg");
    let thetas = [0.0, 30.0, 60.0];
    // Different parameters per incidence: each is fitted on its own.
    let truth = |i: usize| {
        vec![
            0.01 * (1.0 + 0.5 * i as f64),
            0.004 * (1.0 + i as f64),
            1.6 + 0.2 * i as f64,
        ]
    };
    let internal = |i: usize| {
        let t = truth(i);
        vec![t[0].ln(), t[1].ln(), t[2]]
    };
    write_table(&dir, &Abg, internal, &thetas, 16, 11);
    let (v, stderr) = fit_and_stderr(&dir, &["--model", "abg"]);
    assert_eq!(v["fits"].as_array().unwrap().len(), 3);
    check(&v, truth);
    // The verdict in one line, and in OpticStudio's comments.
    assert!(
        stderr.contains(&format!("verdict: {}\n", v["verdict"].as_str().unwrap())),
        "{stderr}"
    );
    // The dialogs' forms: OpticStudio's rows (one per angle) and FRED's set.
    let rows = v["opticstudio"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[1]["angle_deg"], 30.0);
    assert_eq!(v["fred"]["abg"]["from_theta_i_deg"], 30.0);
    assert_eq!(
        v["fred"]["abg"]["acoef"],
        v["fits"][1]["parameters"][0]["value"]
    );
    let text = std::fs::read_to_string(dir.join("fit_abg_opticstudio.txt")).unwrap();
    let data: Vec<&str> = text.lines().filter(|l| !l.starts_with('!')).collect();
    assert_eq!(data.len(), 3, "{text}");
    let a: f64 = data[2].split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!((a / truth(2)[0] - 1.0).abs() < 0.1, "{text}");
    assert!(data.iter().all(|l| l.ends_with(" ok")), "{text}");
    assert!(
        text.contains("! Verdict abg: ok: ") && !text.contains("WARNING"),
        "{text}"
    );
    let png = std::fs::read(dir.join("fit_abg.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn harvey_shack_gives_back_its_parameters() {
    let dir = folder("harvey");
    let truth = |i: usize| {
        vec![
            4.0 / (1.0 + i as f64),
            0.05 * (1.0 + i as f64),
            -2.5 + 0.3 * i as f64,
        ]
    };
    let internal = |i: usize| {
        let t = truth(i);
        vec![t[0].ln(), t[1].ln(), t[2]]
    };
    write_table(&dir, &Harvey, internal, &[10.0, 50.0], 16, 12);
    let v = fit(&dir, &["--model", "harvey", "--quiet"]);
    check(&v, truth);
    assert!(v["fred"]["harvey_shack"]["S"].as_f64().unwrap() < 0.0);
}

#[test]
fn microfacet_models_give_back_alpha() {
    for (name, dist, alpha, material, args) in [
        (
            "ggx",
            microfacet::Distribution::Ggx,
            0.3,
            roks::optics::material::Reflectance::Constant(0.9),
            vec!["--reflectance", "0.9"],
        ),
        (
            "beckmann",
            microfacet::Distribution::Beckmann,
            0.2,
            roks::optics::material::Reflectance::Fresnel { n: 1.015, k: 6.627 },
            vec!["--n", "1.015", "--k", "6.627"],
        ),
    ] {
        let dir = folder(name);
        let model = microfacet::Microfacet {
            distribution: dist,
            material,
        };
        let a: f64 = alpha;
        write_table(&dir, &model, |_| vec![a.ln()], &[0.0, 30.0, 60.0], 16, 13);
        let mut all = vec!["--model", name];
        all.extend(args.iter().copied());
        let v = fit(&dir, &all);
        check(&v, |_| vec![alpha]);
        assert!(
            v["material"].as_str().unwrap().starts_with("--"),
            "{}",
            v["material"]
        );
    }
}

/// A Gaussian height field (sigma 0.3, tau 3: alpha = 2 sigma / tau = 0.2
/// for the ensemble, 16 correlation lengths across the period) traced by
/// `roks brdf`, then fitted, the material taken from the scene its
/// summary.json names. Beckmann's alpha is by definition the RMS slope
/// `sqrt(<|grad h|²>)`, the `rms_slope` of `roks stats` (for this
/// realisation 0.197; its table's second moment at normal incidence,
/// `sqrt(Σ f tan²(theta_o/2) / Σ f)`, gives 0.198): the fit lands within 10 %
/// of it (0.183 measured: one realisation's slopes are not exactly Gaussian,
/// and the weighted fit follows the lobe's core, where the errors are
/// smallest). GGX has no RMS slope (its slope variance is infinite); its
/// tails (r^-4 in slope) put light where a Gaussian surface has none, which
/// the fit pays for by a narrower core: GGX's alpha is below Beckmann's
/// (0.102 measured) and its chi²/dof far above (177 against 13). The
/// light scattered more than once, which neither model holds, is printed
/// per incidence (table minus model reflectance).
#[test]
fn microfacet_fits_to_a_gaussian_field_land_near_its_rms_slope() {
    let dir = folder("gaussian");
    let out = trace(
        &dir,
        r#"name = "field"
[surface]
size = [48.0, 48.0]
edges = "periodic"
material = "al"
heightfield = { gaussian = { sigma = 0.3, tau = 3.0 }, resolution = 256, seed = 7 }
[materials.al]
n = 1.015
k = 6.627
[light]
theta_deg = [0, 20, 40, 60]
phi_deg = 0.0
photons = 200000
seed = 1
[tally]
bands = 24
"#,
    );
    let scene = dir.join("scene.toml");
    let o = roks(&[
        "stats",
        scene.to_str().unwrap(),
        "--json",
        "--resolution",
        "192",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats: Value = serde_json::from_slice(&o.stdout).unwrap();
    let slope = stats["rms_slope"].as_f64().unwrap();
    let mut fitted = Vec::new();
    for model in ["beckmann", "ggx"] {
        let v = fit(&out, &["--model", model]);
        let f = &v["fits"][0];
        let alpha = f["parameters"][0]["value"].as_f64().unwrap();
        let chi2 = f["chi2_per_dof"].as_f64().unwrap();
        eprintln!(
            "{model}: alpha {alpha:.4} +- {:.4}, rms_slope {slope:.4}, chi2/dof {chi2:.2}",
            f["parameters"][0]["stderr"].as_f64().unwrap(),
        );
        // The material from the scene summary.json names.
        assert!(
            v["material"]
                .as_str()
                .unwrap()
                .contains("n = 1.015, k = 6.627"),
            "{}",
            v["material"]
        );
        for r in f["reflectance"].as_array().unwrap() {
            eprintln!(
                "  theta_i {:>3}: table {:.4} model {:.4} difference {:+.4} chi2/cell {:.2}",
                r["theta_i_deg"],
                r["table"].as_f64().unwrap(),
                r["model"].as_f64().unwrap(),
                r["difference"].as_f64().unwrap(),
                r["chi2_per_cell"].as_f64().unwrap()
            );
        }
        fitted.push((alpha, chi2));
    }
    let ((beckmann, chi2_b), (ggx, chi2_g)) = (fitted[0], fitted[1]);
    assert!(
        (beckmann / slope - 1.0).abs() < 0.10,
        "beckmann: alpha {beckmann} vs rms slope {slope}"
    );
    assert!(
        ggx < beckmann && chi2_g > chi2_b,
        "ggx {ggx} ({chi2_g}), beckmann {beckmann} ({chi2_b})"
    );
}

#[test]
fn bad_input_is_one_line_and_status_2() {
    let dir = folder("bad");
    write_table(
        &dir,
        &Abg,
        |_| vec![0.01f64.ln(), 0.01f64.ln(), 2.0],
        &[0.0],
        4,
        1,
    );
    let d = dir.to_str().unwrap();
    let missing = dir.join("nothing");
    for (args, needles) in [
        (
            vec!["fit-model", missing.to_str().unwrap(), "--model", "abg"],
            vec!["nothing", "not a folder"],
        ),
        (
            vec!["fit-model", d, "--model", "ggx"],
            vec!["--model ggx", "material", "--n"],
        ),
        (
            vec!["fit-model", d, "--model", "abg", "--n", "1.5"],
            vec!["--n", "only ggx and beckmann"],
        ),
        (
            vec!["fit-model", d, "--model", "ggx", "--reflectance", "1.5"],
            vec!["--reflectance", "[0, 1]"],
        ),
        (
            vec!["fit-model", d, "--model", "ggx", "--n", "1.5", "--k", "-1"],
            vec!["--k", ">= 0"],
        ),
        (
            vec!["fit-model", d, "--model", "abg", "--wavelength", "0.5"],
            vec!["--wavelength", "one wavelength"],
        ),
        (vec!["fit-model", d, "--model", "phong"], vec!["--model"]),
        (
            vec!["fit-model", d, "--model", "all", "--out", "x.json"],
            vec!["--out", "--model all", "give --out with one model"],
        ),
    ] {
        let o = roks(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: {stderr}");
        for n in needles {
            assert!(stderr.contains(n), "{args:?}: `{n}` not in {stderr}");
        }
    }
    // A corrupt table names the file and the line; nothing is written.
    let text = std::fs::read_to_string(dir.join("brdf.csv")).unwrap();
    std::fs::write(dir.join("brdf.csv"), text.replacen(",1,0,", ",1,7,", 1)).unwrap();
    let o = roks(&["fit-model", d, "--model", "abg"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("brdf.csv") && stderr.contains("line 2"),
        "{stderr}"
    );
    assert!(!dir.join("fit_abg.json").exists());
}

/// `roks brdf` of `scene` (TOML text, written to `dir/scene.toml`) into
/// `dir/out`; the result folder.
fn trace(dir: &Path, scene: &str) -> PathBuf {
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    let out = dir.join("out");
    let o = roks(&[
        "brdf",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// The rough aluminium field of issue 42 (n 1.2, k 7.26, Gaussian sigma 1,
/// tau 5), small: ABg is a model of polished surfaces and misses most of
/// the wide lobe's light (its TIS 16 % below the table's at 0 degrees and
/// 37 % at 75 with 10^5 photons per angle), so its verdicts are false
/// there, each named in a warning on stderr and in OpticStudio's comments.
/// `--model all` ranks Beckmann above ABg. The verdict is judged against
/// the table's standard error the run states (`summary.json`'s
/// `reflectance_stderr`), recomputed here from the numbers written.
#[test]
fn fits_of_a_rough_aluminium_field_are_judged_and_ranked() {
    let dir = folder("al-field");
    let out = trace(
        &dir,
        r#"name = "al-rough"
[surface]
size = [32.0, 32.0]
edges = "periodic"
material = "al"
heightfield = { gaussian = { sigma = 1.0, tau = 5.0 }, resolution = 128, seed = 3 }
[materials.al]
n = 1.2
k = 7.26
[light]
theta_deg = [0, 40, 75]
phi_deg = 0.0
photons = 20000
seed = 1
[tally]
bands = 16
"#,
    );
    let summary: Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let stated: Vec<f64> = summary["incidence"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["reflectance_stderr"].as_f64().unwrap())
        .collect();
    let (v, stderr) = fit_and_stderr(&out, &["--model", "abg"]);
    let ok = verdicts(&v);
    for (f, se) in v["fits"].as_array().unwrap().iter().zip(&stated) {
        assert_eq!(f["reflectance"][0]["table_stderr"].as_f64().unwrap(), *se);
    }
    // ABg off at normal and grazing incidence.
    assert!(!ok[0] && !ok[2], "{ok:?}: {stderr}");
    let warnings: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    for (k, theta) in [(0, 0), (2, 75)] {
        assert!(!ok[k]);
        assert!(
            warnings.iter().any(|w| w.starts_with(&format!(
                "abg: theta_i {theta} deg: the model's reflectance"
            )) && w.ends_with("allowed: max(1 %, 4 standard errors))")),
            "{warnings:?}"
        );
    }
    assert!(stderr.contains("verdict: abg: NOT OK: "), "{stderr}");
    let text = std::fs::read_to_string(out.join("fit_abg_opticstudio.txt")).unwrap();
    assert!(text.contains("! WARNING abg: theta_i 0 deg: "), "{text}");
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('!')).collect();
    assert!(
        rows[0].ends_with(" OFF") && rows[2].ends_with(" OFF"),
        "{text}"
    );
    assert!(v["fred"]["verdict"].as_str().unwrap().starts_with("OFF: "));

    // Every model, ranked: Beckmann (one alpha, the field's slopes) above
    // ABg; each model's files written; the ranking in fit_summary.json in
    // the order of the rule: no warning first, then fewer incidences off,
    // then fewer fits not converged, then chi2/dof.
    let o = roks(&["fit-model", out.to_str().unwrap(), "--model", "all"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    eprintln!("{stderr}");
    let s: Value =
        serde_json::from_slice(&std::fs::read(out.join("fit_summary.json")).unwrap()).unwrap();
    let ranking = s["ranking"].as_array().unwrap();
    let names: Vec<&str> = ranking
        .iter()
        .map(|r| r["model"].as_str().unwrap())
        .collect();
    assert_eq!(names.len(), 4, "{s}");
    let at = |m: &str| names.iter().position(|n| *n == m).unwrap();
    assert!(at("beckmann") < at("abg"), "{names:?}");
    let key = |r: &Value| {
        (
            !r["passes"].as_bool().unwrap(),
            r["incidences"].as_u64().unwrap() - r["incidences_ok"].as_u64().unwrap(),
            r["not_converged"].as_u64().unwrap(),
            r["chi2_per_dof"].as_f64().unwrap(),
        )
    };
    for w in ranking.windows(2) {
        assert!(key(&w[0]) <= key(&w[1]), "{s}");
    }
    for m in ["abg", "harvey", "ggx", "beckmann"] {
        let f: Value =
            serde_json::from_slice(&std::fs::read(out.join(format!("fit_{m}.json"))).unwrap())
                .unwrap();
        let r = &ranking[at(m)];
        assert_eq!(
            r["warnings"].as_u64().unwrap() as usize,
            f["warnings"].as_array().unwrap().len()
        );
        let ok = verdicts(&f);
        assert_eq!(
            r["incidences_ok"].as_u64().unwrap() as usize,
            ok.iter().filter(|&&x| x).count()
        );
        assert!(out.join(format!("fit_{m}.png")).exists());
    }
    assert!(
        stderr.contains(&s["advice"].as_str().unwrap().to_string()),
        "{stderr}"
    );
    assert!(stderr.contains("rank model"), "{stderr}");
    same_fit_from_values(&out, &stderr);
}

/// The fit of a result given as values (its `brdf.csv` and `summary.json`
/// as text, nothing read from a folder: a result traced in-process, as the
/// Python module fits it) is `roks fit-model DIR --model all`'s (whose
/// stderr is `cli_stderr`), byte for byte: each model's JSON but for its
/// `table` (the bare `brdf.csv`), each plot, OpticStudio's rows but for
/// their name (the scene's `name`, no folder), and every line but the
/// `wrote` one.
fn same_fit_from_values(out: &Path, cli_stderr: &str) {
    use roks::fit_model::material::MaterialOptions;
    use roks::fit_model::one::{ModelChoice, Request, TableTexts};
    let text = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
    let request = Request {
        dir: PathBuf::new(),
        texts: Some(TableTexts {
            csv: text("brdf.csv"),
            summary: Some(text("summary.json")),
        }),
        model: ModelChoice::All,
        out: None,
        material: MaterialOptions::default(),
        wavelength: None,
    };
    let report = request.run().unwrap();
    let files: std::collections::BTreeMap<String, &[u8]> = report
        .files
        .iter()
        .map(|(p, b)| (p.display().to_string(), b.as_slice()))
        .collect();
    let table = |dir: &Path| {
        let csv = dir.join("brdf.csv").display().to_string();
        format!("\"table\": {}", serde_json::to_string(&csv).unwrap())
    };
    for m in ["abg", "harvey", "ggx", "beckmann"] {
        let cli = text(&format!("fit_{m}.json")).replace(&table(out), &table(Path::new("")));
        let given = std::str::from_utf8(files[&format!("fit_{m}.json")]).unwrap();
        assert!(given.contains("\"table\": \"brdf.csv\""), "{given}");
        assert_eq!(given, cli, "fit_{m}.json");
        let png = std::fs::read(out.join(format!("fit_{m}.png"))).unwrap();
        assert!(
            files[&format!("fit_{m}.png")] == png.as_slice(),
            "fit_{m}.png"
        );
    }
    // Named after the folder by the CLI, after the scene's `name` when
    // given as values (no folder).
    let summary: serde_json::Value = serde_json::from_str(&text("summary.json")).unwrap();
    let scene = summary["name"].as_str().unwrap();
    assert_ne!(scene, out.file_name().unwrap().to_str().unwrap());
    let name = format!("! Name {}\n", out.file_name().unwrap().to_str().unwrap());
    let cli = text("fit_abg_opticstudio.txt").replace(&name, &format!("! Name {scene}\n"));
    assert_eq!(
        std::str::from_utf8(files["fit_abg_opticstudio.txt"]).unwrap(),
        cli
    );
    let not_wrote = |l: &&str| !l.starts_with("wrote ");
    let given: Vec<&str> = report.lines(false).iter().map(String::as_str).collect();
    let given: Vec<&str> = given.into_iter().filter(not_wrote).collect();
    let cli: Vec<&str> = cli_stderr.lines().filter(not_wrote).collect();
    assert_eq!(given, cli);
    assert!(files.contains_key("fit_summary.json"));
}

/// A flat mirror's table (all the light in the specular cell, or the four
/// cells meeting at the pole) has no lobe: every model, and `--model all`,
/// refuses it in one line `cannot fit: ...` naming the incidence, exit
/// status 2, and writes nothing.
#[test]
fn a_mirror_cannot_be_fitted() {
    let dir = folder("mirror");
    let out = trace(
        &dir,
        r#"name = "mirror"
[surface]
size = [10.0, 10.0]
material = "al"
[materials.al]
n = 1.2
k = 7.26
[light]
theta_deg = [0, 30, 60]
photons = 2000
seed = 1
[tally]
bands = 8
"#,
    );
    let before: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    for model in ["abg", "harvey", "ggx", "beckmann", "all"] {
        let o = roks(&["fit-model", out.to_str().unwrap(), "--model", model]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{model}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{model}: {stderr}");
        assert!(
            stderr.starts_with("roks: cannot fit: ")
                && stderr.contains("theta_i 0 deg: all the light")
                && stderr.contains("a mirror's reflection"),
            "{model}: {stderr}"
        );
        let after: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(after, before, "{model}: a file written");
    }
}
