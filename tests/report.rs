//! `roks report` and `--report` without a browser (the page itself is
//! tested in headless Chromium by `tests/report_browser.rs`):
//! * the report of a merged folder is byte for byte the report of the
//!   whole run, for `roks brdf` and `roks trace` shards;
//! * `roks report DIR` writes the same file as `--report` did;
//! * `--report` adds `report.html` and changes no other file;
//! * output safety: a report.html roks did not write is kept (refused
//!   without `--force`), one roks wrote is replaced, `--out` elsewhere.

mod cli_common;

use std::path::{Path, PathBuf};

use cli_common::{read, roks};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-report-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(args: &[&str]) {
    let out = roks(args);
    assert!(
        out.status.success(),
        "roks {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

#[test]
fn the_report_of_merged_shards_is_the_whole_runs() {
    let t = tmp("merge");
    let s = |p: &str| t.join(p).display().to_string();
    let brdf = [
        "brdf",
        "--photons",
        "8192",
        "--theta",
        "0,50",
        "--phi",
        "0,90",
        "--stats-resolution",
        "32",
        "-q",
        "--report",
        "--out",
    ];
    ok(&[&brdf[..], &[&s("whole")]].concat());
    for i in 0..2 {
        let shard = format!("{i}/2");
        ok(&[&brdf[..], &[&s(&format!("s{i}")), "--shard", &shard]].concat());
    }
    ok(&[
        "merge",
        &s("s1"),
        &s("s0"),
        "--out",
        &s("merged"),
        "--report",
        "-q",
    ]);
    let whole = read(&t.join("whole"), "report.html");
    assert!(whole.starts_with(b"<!DOCTYPE html>\n<!-- roks report -->\n"));
    assert!(
        whole == read(&t.join("merged"), "report.html"),
        "the merged folder's report differs from the whole run's"
    );
    // A shard's report is another one (its block of photons).
    assert!(whole != read(&t.join("s0"), "report.html"));

    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cylinder-cavity.toml");
    let scene = scene.display().to_string();
    let trace = ["trace", &scene, "--photons", "8192", "-q", "--out"];
    ok(&[&trace[..], &[&s("twhole"), "--report"]].concat());
    for i in 0..2 {
        let shard = format!("{i}/2");
        ok(&[&trace[..], &[&s(&format!("t{i}")), "--shard", &shard]].concat());
    }
    ok(&[
        "merge",
        &s("t0"),
        &s("t1"),
        "--out",
        &s("tmerged"),
        "--report",
        "-q",
    ]);
    assert!(
        read(&t.join("twhole"), "report.html") == read(&t.join("tmerged"), "report.html"),
        "the merged trace's report differs from the whole run's"
    );
    // A shard of `roks trace` has no table to report.
    let out = roks(&[&trace[..], &[&s("t9"), "--shard", "0/2", "--report"]].concat());
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        "roks: --report: not for a shard (its folder holds no reflectance.csv); report the folder of `roks merge`\n"
    );
    std::fs::remove_dir_all(&t).unwrap();
}

#[test]
fn roks_report_writes_what_report_wrote_and_keeps_foreign_files() {
    let t = tmp("cli");
    let (a, b) = (t.join("a"), t.join("b"));
    let (sa, sb) = (a.display().to_string(), b.display().to_string());
    let run = [
        "brdf",
        "--photons",
        "4096",
        "--theta",
        "30",
        "--polarisation",
        "mueller",
        "--stats-resolution",
        "32",
        "-q",
        "--out",
    ];
    ok(&[&run[..], &[&sa, "--report"]].concat());
    ok(&[&run[..], &[&sb]].concat());
    // --report adds report.html and changes no other file.
    let mut with = names(&a);
    with.retain(|n| n != "report.html");
    assert_eq!(with, names(&b));
    for n in names(&b)
        .iter()
        .filter(|n| *n != "summary.json" && *n != ".roks-files.json")
    {
        assert!(read(&a, n) == read(&b, n), "{n} differs with --report");
    }
    // A report.html in the folder that roks did not write is kept.
    std::fs::write(b.join("report.html"), "notes\n").unwrap();
    let out = roks(&["report", &sb]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(b.join("report.html")).unwrap(),
        "notes\n"
    );
    std::fs::remove_file(b.join("report.html")).unwrap();
    // `roks report` makes the same file of the written folder.
    ok(&["report", &sb, "-q"]);
    assert!(read(&a, "report.html") != Vec::<u8>::new());
    let (ra, rb) = (read(&a, "report.html"), read(&b, "report.html"));
    // The two runs differ only in their times, which a report leaves out.
    assert!(ra == rb, "roks report differs from --report");
    // Again: roks's own report is replaced.
    ok(&["report", &sb, "-q"]);
    // --out elsewhere; a file there roks did not write is kept.
    let other = t.join("other.html");
    std::fs::write(&other, "<html>mine</html>\n").unwrap();
    let so = other.display().to_string();
    let out = roks(&["report", &sb, "--out", &so]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(&other).unwrap(),
        "<html>mine</html>\n"
    );
    assert!(String::from_utf8_lossy(&out.stderr).starts_with(&format!("roks: --out: {so}: ")));
    ok(&["report", &sb, "--out", &so, "--force", "-q"]);
    assert!(read(&t, "other.html") == rb);
    // Not a result folder: one line, exit status 2.
    let out = roks(&["report", &t.display().to_string()]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    std::fs::remove_dir_all(&t).unwrap();
}

/// The data a report holds (script#roks-data: gzip, then base64).
fn report_data(html: &[u8]) -> serde_json::Value {
    use std::io::Read as _;
    let html = String::from_utf8_lossy(html);
    let start = html.find("id=\"roks-data\">").unwrap() + "id=\"roks-data\">".len();
    let text = &html[start..start + html[start..].find('<').unwrap()];
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut bytes = Vec::new();
    let (mut acc, mut bits) = (0u32, 0);
    for c in text.trim().bytes().filter(|&c| c != b'=') {
        acc = (acc << 6) | ABC.iter().position(|&a| a == c).unwrap() as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            bytes.push((acc >> bits) as u8);
        }
    }
    let mut json = String::new();
    flate2::read::GzDecoder::new(&bytes[..])
        .read_to_string(&mut json)
        .unwrap();
    serde_json::from_str(&json).unwrap()
}

/// The report's entry of the fit file `name`.
fn fit_entry<'a>(data: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    data["products"]["fits"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["name"] == name)
        .unwrap_or_else(|| panic!("no {name} in the report"))
}

/// `|a - b| <= rel |b|`, said.
fn close(a: f64, b: f64, rel: f64, what: &str) {
    assert!((a - b).abs() <= rel * b.abs(), "{what}: {a} vs {b}");
}

/// The report `data` of the folder `dir` draws the model of its fit file
/// `name` at the wavelength of index `lane`: at the cells of the fit's
/// `largest_residuals` its values are the fit's `model` (to the report's 6
/// significant digits), and per incidence they integrate (Σ value x
/// projected solid angle) to the fit's `reflectance[].model`.
fn agrees_with_the_fit(dir: &Path, data: &serde_json::Value, name: &str, lane: usize) {
    let csv = String::from_utf8(read(dir, "brdf.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let [nt, np, nl, nc]: [usize; 4] = serde_json::from_value(data["shape"].clone()).unwrap();
    assert_eq!(rows.len(), nt * np * nl * nc);
    let thetas: Vec<f64> = serde_json::from_value(data["theta"].clone()).unwrap();
    let digits = 5e-6 * (1.0 + 1e-12);
    let doc: serde_json::Value = serde_json::from_slice(&read(dir, name)).unwrap();
    let f = fit_entry(data, name);
    let o = &f["overlay"];
    assert!(o.is_object(), "{name} is not drawn: {}", f["not_drawn"]);
    assert_eq!(o["lane"], lane, "{name}");
    let fitted: Vec<usize> = serde_json::from_value(o["theta"].clone()).unwrap();
    let cells: Vec<f64> = serde_json::from_value(o["cells"].clone()).unwrap();
    assert_eq!(cells.len(), fitted.len() * nc);
    // The rows of brdf.csv of incidence i at the fit's wavelength, and the
    // report's values there.
    let block = |i: usize| {
        let b = (i * np * nl + lane) * nc;
        &rows[b..b + nc]
    };
    let model = |i: usize| {
        let q = fitted.iter().position(|&x| x == i).unwrap();
        &cells[q * nc..(q + 1) * nc]
    };
    let mut checked = 0;
    for fit in doc["fits"].as_array().unwrap() {
        for r in fit["largest_residuals"].as_array().unwrap() {
            let ti = r["theta_i_deg"].as_f64().unwrap();
            let i = thetas.iter().position(|&x| x == ti).unwrap();
            let flat = block(i)
                .iter()
                .position(|row| {
                    row[col("band")] == r["band"].as_f64().unwrap()
                        && row[col("cell")] == r["cell"].as_f64().unwrap()
                })
                .unwrap();
            // The fit's table value: this cell's (the block is right).
            let table = r["table"].as_f64().unwrap();
            close(block(i)[flat][col("brdf")], table, 1e-8, name);
            close(model(i)[flat], r["model"].as_f64().unwrap(), digits, name);
            checked += 1;
        }
        for r in fit["reflectance"].as_array().unwrap() {
            let ti = r["theta_i_deg"].as_f64().unwrap();
            let i = thetas.iter().position(|&x| x == ti).unwrap();
            let sum: f64 = (0..nc)
                .map(|k| model(i)[k] * block(i)[k][col("projected_solid_angle_sr")])
                .sum();
            close(sum, r["model"].as_f64().unwrap(), 1e-5, name);
        }
    }
    assert!(checked >= 10, "{name}: {checked} cells checked");
}

/// The fitted models the report draws over their table are the models the
/// fit evaluated ([`agrees_with_the_fit`]): ABg and GGX (its material the
/// default scene's, rebuilt) of a monochrome table, and ABg of a spectral
/// table at its second wavelength; `largest_residuals[].model` is the
/// fit's own cell average at its own parameters. ABg edited to g = 0 is
/// the constant A / (B + 1) in every cell and in-plane bin, exactly. A fit
/// document whose table is not this folder's is not drawn, and the report
/// says why.
#[test]
fn fitted_models_are_drawn_as_the_fit_evaluates_them() {
    let t = tmp("models");
    // A small run of the default scene into `t/name`, with `extra` options.
    let traced = |name: &str, extra: &[&str]| {
        let d = t.join(name);
        let s = d.display().to_string();
        let mut args = vec!["brdf", "--photons", "8192", "--theta", "0,40"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--stats-resolution", "32", "-q", "--out", &s]);
        ok(&args);
        (d, s)
    };
    let (d, s) = traced("run", &[]);
    ok(&["fit-model", &s, "--model", "abg", "-q"]);
    // GGX's material: the default scene's substrate, rebuilt by the report.
    ok(&["fit-model", &s, "--model", "ggx", "-q"]);
    ok(&["report", &s, "-q"]);
    let data = report_data(&read(&d, "report.html"));
    let nc = data["shape"][3].as_u64().unwrap() as usize;
    // Rounding to 6 significant digits: at most half a unit of the sixth.
    let digits = 5e-6 * (1.0 + 1e-12);
    for name in ["fit_abg.json", "fit_ggx.json"] {
        agrees_with_the_fit(&d, &data, name, 0);
    }
    // ABg at g = 0: A / (B + 1) everywhere, cells and in-plane bins.
    let mut doc: serde_json::Value = serde_json::from_slice(&read(&d, "fit_abg.json")).unwrap();
    for fit in doc["fits"].as_array_mut().unwrap() {
        fit["parameters"][2]["value"] = serde_json::json!(0.0);
    }
    let (a0, b0) = (
        doc["fits"][0]["parameters"][0]["value"].as_f64().unwrap(),
        doc["fits"][0]["parameters"][1]["value"].as_f64().unwrap(),
    );
    std::fs::write(d.join("fit_abg.json"), doc.to_string()).unwrap();
    ok(&["report", &s, "-q"]);
    let data = report_data(&read(&d, "report.html"));
    let o = &fit_entry(&data, "fit_abg.json")["overlay"];
    let cells: Vec<f64> = serde_json::from_value(o["cells"].clone()).unwrap();
    let inplane: Vec<f64> = serde_json::from_value(o["inplane"].clone()).unwrap();
    let nin = inplane.len() / 2;
    assert_eq!(nin, data["inplane"]["brdf"].as_array().unwrap().len() / 2);
    for (k, v) in cells[..nc].iter().chain(&inplane[..nin]).enumerate() {
        close(*v, a0 / (b0 + 1.0), digits, &format!("g = 0, value {k}"));
    }
    // The fit of another table (its reflectance is not this one's).
    doc["fits"][0]["reflectance"][0]["table"] = serde_json::json!(0.5);
    std::fs::write(d.join("fit_abg.json"), doc.to_string()).unwrap();
    ok(&["report", &s, "-q"]);
    let data = report_data(&read(&d, "report.html"));
    let f = fit_entry(&data, "fit_abg.json");
    assert!(f["overlay"].is_null());
    let why = f["not_drawn"].as_str().unwrap();
    assert!(
        why.starts_with("fitted to a table of reflectance 0.5 at θi = 0°; this one's is "),
        "{why}"
    );
    assert!(fit_entry(&data, "fit_ggx.json")["overlay"].is_object());

    // A spectral table fitted at its second wavelength: drawn there.
    let (d, s) = traced("spectral", &["--wavelengths", "0.4,0.5,0.6"]);
    ok(&[
        "fit-model",
        &s,
        "--model",
        "abg",
        "--wavelength",
        "0.5",
        "-q",
    ]);
    ok(&["report", &s, "-q"]);
    agrees_with_the_fit(
        &d,
        &report_data(&read(&d, "report.html")),
        "fit_abg.json",
        1,
    );
    std::fs::remove_dir_all(&t).unwrap();
}
