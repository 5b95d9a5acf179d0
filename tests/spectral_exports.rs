//! Exports of spectral BRDF tables (`roks brdf --export`, `roks
//! export-brdf` of a spectral folder): Zemax one `Monochrome` file per
//! wavelength, equal to the monochrome export for a material constant in
//! wavelength; MERL channels the linear sRGB of the BRDF under D65, exactly
//! the monochrome channels times the sRGB of the D65 white for a grey
//! material, and the colour of gold's Fresnel reflectance in the specular
//! bin of a flat gold mirror; MERL of wavelengths not covering the visible
//! refused (exit 2, one line naming the option, nothing written).

mod cli_common;
mod common;

use std::path::{Path, PathBuf};

use glam::DVec3;
use roks::export::exporter::BrdfFormat;
use roks::export::merl::{self, Merl};
use roks::export::zemax::wavelength_comment;
use roks::optics::brdf_table::BrdfTables;
use roks::optics::colour::{d65_white_xyz, srgb8, xyz_d65, xyz_to_linear_srgb};
use roks::optics::spectrum::NkSpectrum;
use roks::output::brdf_csv;
use roks::tally::CarlsonGrid;

use cli_common::{assert_input_error, brdf_quiet, roks};

const DEFAULT: &str = roks::scene::micro::DEFAULT_SCENE;

/// The default scene (reflectance 0.8) with `extra` keys in `[light]`,
/// 4096 photons at `thetas`.
fn default_with(extra: &str, thetas: &str) -> String {
    DEFAULT
        .replace("[light]", &format!("[light]\n{extra}"))
        .replace("photons = 1000000", "photons = 4096")
        .replace(
            "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
            &format!("theta_deg = [{thetas}]"),
        )
}

/// The tables of a traced scene, as its `brdf.csv` holds them.
fn tables(name: &str, toml: &str) -> BrdfTables {
    let scene = common::scene(name, toml);
    let run = common::brdf_run(&scene);
    let results = run.trace_whole(&scene.surface, &|_| {});
    brdf_csv::table(&run, &results)
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-spexport-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The text without its `#` comment lines.
fn without_comments(b: &[u8]) -> String {
    String::from_utf8_lossy(b)
        .lines()
        .filter(|l| !l.starts_with('#'))
        .collect::<Vec<_>>()
        .join("\n")
}

/// A material constant in wavelength: each wavelength's table is the
/// monochrome table, so its Zemax file is the monochrome file byte for
/// byte (same comment), and `export_tables` names it
/// `brdf_<wavelength>um.bsdf` with the wavelength in its comment.
#[test]
fn zemax_of_a_constant_material_is_the_monochrome_export() {
    let mono = tables("mono", &default_with("", "0, 45"));
    let spec = tables(
        "spec",
        &default_with("wavelengths_um = [0.45, 0.55, 0.65]", "0, 45"),
    );
    let mono_t = mono.monochrome().unwrap();
    let want = BrdfFormat::Zemax.export(mono_t, "c").unwrap();
    let s = spec.spectral().unwrap();
    for t in s.tables() {
        assert!(BrdfFormat::Zemax.export(t, "c").unwrap() == want);
    }
    let files = BrdfFormat::Zemax.export_tables(&spec, "c").unwrap();
    let names: Vec<&str> = files.iter().map(|f| f.file_name.as_str()).collect();
    assert_eq!(
        names,
        ["brdf_0.45um.bsdf", "brdf_0.55um.bsdf", "brdf_0.65um.bsdf"]
    );
    for (f, w) in files.iter().zip([0.45, 0.55, 0.65]) {
        assert_eq!(f.wavelength_um, Some(w));
        assert!(
            f.bytes
                == BrdfFormat::Zemax
                    .export(mono_t, &wavelength_comment("c", w))
                    .unwrap()
        );
        let text = String::from_utf8_lossy(&f.bytes);
        assert!(text.contains(&format!("# c; wavelength {w} um\n")), "{w}");
        assert!(text.contains("\nSpectralContent  Monochrome\n"));
        assert_eq!(without_comments(&f.bytes), without_comments(&want));
    }
    // Monochrome: the one file of before.
    let files = BrdfFormat::Zemax.export_tables(&mono, "c").unwrap();
    assert_eq!(files.len(), 1);
    assert_eq!(files[0].file_name, "brdf.bsdf");
    assert!(files[0].bytes == want);
}

/// Through the binary: `roks brdf --export zemax` of the spectral scene
/// writes one file per wavelength, each the monochrome run's `brdf.bsdf`
/// but for the comment; `roks export-brdf` of the spectral folder writes
/// `OUT` with `_<wavelength>um` before the extension, the library's
/// export of the folder's tables; MERL of the visible written by both
/// commands is the same file.
#[test]
fn spectral_folders_export_through_the_binary() {
    let dir = scratch("cli");
    let mono_scene = dir.join("mono.toml");
    let spec_scene = dir.join("spec.toml");
    let vis_scene = dir.join("vis.toml");
    std::fs::write(&mono_scene, default_with("", "0, 45")).unwrap();
    std::fs::write(
        &spec_scene,
        default_with("wavelengths_um = [0.45, 0.55, 0.65]", "0, 45"),
    )
    .unwrap();
    std::fs::write(
        &vis_scene,
        default_with(
            "wavelengths_um = { from = 0.38, to = 0.78, step = 0.1 }",
            "0, 45",
        ),
    )
    .unwrap();
    let (mono, spec, vis) = (dir.join("mono"), dir.join("spec"), dir.join("vis"));
    for (scene, out, export) in [
        (&mono_scene, &mono, "zemax"),
        (&spec_scene, &spec, "zemax"),
        (&vis_scene, &vis, "merl"),
    ] {
        let o = roks(&["brdf", s(scene), "--out", s(out), "--export", export, "-q"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let want = std::fs::read(mono.join("brdf.bsdf")).unwrap();
    assert!(!spec.join("brdf.bsdf").exists());
    for w in ["0.45", "0.55", "0.65"] {
        let got = std::fs::read(spec.join(format!("brdf_{w}um.bsdf"))).unwrap();
        assert_eq!(without_comments(&got), without_comments(&want), "{w}");
        assert!(String::from_utf8_lossy(&got).contains(&format!("; wavelength {w} um\n")));
    }
    // export-brdf of the spectral folder: the files into --out as a folder,
    // named as roks brdf --export names them, and export.json.
    let out = dir.join("x").join("gold");
    let o = roks(&[
        "export-brdf",
        s(&spec),
        "--format",
        "zemax",
        "--out",
        s(&out),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("zemax (0.55 um): reflectance of the file"),
        "{stderr}"
    );
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            ".roks-files.json",
            "brdf_0.45um.bsdf",
            "brdf_0.55um.bsdf",
            "brdf_0.65um.bsdf",
            "export.json"
        ]
    );
    let csv = spec.join("brdf.csv");
    let t = BrdfTables::load(&csv)
        .unwrap()
        .with_summary(&spec.join("summary.json"))
        .unwrap();
    let library = BrdfFormat::Zemax
        .export_tables(&t, &format!("from {}", csv.display()))
        .unwrap();
    for (f, w) in library.iter().zip(["0.45", "0.55", "0.65"]) {
        let written = std::fs::read(out.join(format!("brdf_{w}um.bsdf"))).unwrap();
        assert!(written == f.bytes, "{w}");
    }
    // MERL of the visible: the same file from both commands, and the
    // library's colour export of the table.
    let again = dir.join("again.binary");
    let o = roks(&[
        "export-brdf",
        s(&vis),
        "--format",
        "merl",
        "--out",
        s(&again),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("linear sRGB") && stderr.contains("blue:"),
        "{stderr}"
    );
    let written = std::fs::read(vis.join("brdf.binary")).unwrap();
    assert!(written == std::fs::read(&again).unwrap());
    let t = BrdfTables::load(&vis.join("brdf.csv")).unwrap();
    let (m, clipped) = Merl::from_spectral(t.spectral().unwrap()).unwrap();
    assert_eq!(clipped.values, 0);
    assert!(written == m.to_bytes());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A grey material (reflectance 0.8 at every wavelength, 0.38-0.78 µm):
/// every wavelength's table is the monochrome table, so channel `c` of
/// every bin is `Σ_l (M w_l)_c f = (M Σ_l w_l)_c f` with `Σ_l w_l` the
/// XYZ of the perfect white reflector: the monochrome value times
/// `xyz_to_linear_srgb(d65_white_xyz())_c`, to 1e-12 relative (the sums
/// in another order), channels equal within the 1e-3 of that white to
/// (1, 1, 1).
#[test]
fn merl_of_a_grey_material_is_the_monochrome_file_times_the_srgb_of_white() {
    let thetas = "0, 40, 80";
    let mono = tables("mono", &default_with("", thetas));
    let grey = tables(
        "grey",
        &default_with(
            "wavelengths_um = { from = 0.38, to = 0.78, step = 0.04 }",
            thetas,
        ),
    );
    assert_eq!(grey.wavelengths_um().len(), 11);
    let white = xyz_to_linear_srgb(d65_white_xyz());
    println!("linear sRGB of the D65 white: {white:?}");
    for c in white {
        assert!((c - 1.0).abs() < 1e-3, "{white:?}");
    }
    let bytes = |t: &BrdfTables| {
        BrdfFormat::Merl.export_tables(t, "").unwrap()[0]
            .bytes
            .clone()
    };
    let m = Merl::parse(&bytes(&mono), "mono").unwrap();
    let g = Merl::parse(&bytes(&grey), "grey").unwrap();
    let mut positive = 0;
    for (c, &factor) in white.iter().enumerate() {
        for bin in 0..merl::N {
            let (want, got) = (
                factor * m.values[c * merl::N + bin],
                g.values[c * merl::N + bin],
            );
            assert!(
                (got - want).abs() <= 1e-12 * want,
                "channel {c} bin {bin}: {got} vs {want}"
            );
            positive += usize::from(want > 0.0);
        }
    }
    assert!(positive > merl::N, "{positive}");
}

/// A flat gold mirror at 30 degrees (one tabulated incidence, so the table
/// holds at every incidence angle): all the light leaves through the
/// specular cell with the unpolarised Fresnel reflectance `R(λ)` of gold
/// (textbook formula, n and k from the same table), so the MERL bin of the
/// specular pair holds the linear sRGB of `R(λ)` under D65, computed by
/// `optics::colour` from the spectrum directly, over the cell's projected
/// solid angle; to 1e-8 (`brdf.csv` keeps 10 digits).
#[test]
fn merl_of_flat_gold_holds_the_colour_of_its_fresnel_reflectance() {
    let nk_file = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/materials/gold.csv");
    let toml = format!(
        "[surface]\nsize = [10.0, 10.0]\nmaterial = \"gold\"\n[materials.gold]\nnk = \"{nk_file}\"\n[light]\ntheta_deg = [30]\nphotons = 4096\nwavelengths_um = {{ from = 0.38, to = 0.78, step = 0.02 }}\n[tally]\nbands = 8\n"
    );
    let t = tables("gold", &toml);
    let s = t.spectral().unwrap();
    let ws = s.wavelengths_um().to_vec();
    assert_eq!(ws.len(), 21);
    let nk = NkSpectrum::read(Path::new(nk_file)).unwrap();
    let theta = 30f64.to_radians();
    let r: Vec<f64> = ws
        .iter()
        .map(|&w| common::fresnel_textbook(theta, nk.n().at(w).unwrap(), nk.k().at(w).unwrap()))
        .collect();
    for (tab, (&w, &rl)) in s.tables().iter().zip(ws.iter().zip(&r)) {
        let got = tab.reflectance(theta);
        assert!((got - rl).abs() <= 1e-9, "{w} um: {got} vs {rl}");
    }
    let rgb = xyz_to_linear_srgb(xyz_d65(&ws, &r).unwrap());
    // The specular cell: band 3 of 8 (23.6-33.6 degrees), cell 6 of 12
    // (azimuth 165-195 degrees, around the specular azimuth 180).
    let grid = CarlsonGrid::new(8).unwrap();
    let spec = DVec3::new(-theta.sin(), 0.0, theta.cos());
    assert_eq!(grid.band_cell(grid.locate(spec).unwrap()), (3, 6));
    let proj = grid.projected_solid_angle(3, 6);
    let bytes = &BrdfFormat::Merl.export_tables(&t, "").unwrap()[0].bytes;
    let m = Merl::parse(bytes, "gold").unwrap();
    let light = DVec3::new(theta.sin(), 0.0, theta.cos());
    let got = m.lookup(light, spec);
    for c in 0..3 {
        let want = rgb[c] / proj;
        assert!(
            (got[c] - want).abs() <= 1e-8 * want,
            "channel {c}: {} vs {want}",
            got[c]
        );
    }
    println!(
        "flat gold at 30 deg: linear sRGB of R {rgb:?}, sRGB8 {:?}; MERL specular bin x proj {:?}",
        srgb8(rgb),
        got.map(|v| v * proj)
    );
}

/// MERL of wavelengths that do not cover the visible: refused before
/// tracing by `roks brdf --export merl` and by `roks export-brdf --format
/// merl` of such a folder, one line naming the option, nothing written.
/// Zemax of the same folder works.
#[test]
fn merl_of_wavelengths_outside_the_visible_is_refused() {
    let dir = scratch("refuse");
    let scene = dir.join("ir.toml");
    std::fs::write(
        &scene,
        default_with("wavelengths_um = [0.45, 0.55, 0.65]", "0"),
    )
    .unwrap();
    let out = dir.join("run");
    let o = roks(&[
        "brdf",
        s(&scene),
        "--out",
        s(&out),
        "--export",
        "zemax,merl",
    ]);
    assert_input_error(
        "brdf --export merl",
        &o,
        Path::new("--export merl"),
        &out,
        &["0.45-0.65 um", "do not cover the visible", "export zemax"],
    );
    let o = roks(&["brdf", s(&scene), "--out", s(&out), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let target = dir.join("m").join("x.binary");
    let o = roks(&[
        "export-brdf",
        s(&out),
        "--format",
        "merl",
        "--out",
        s(&target),
    ]);
    assert_input_error(
        "export-brdf --format merl",
        &o,
        &out.join("brdf.csv"),
        &target,
        &["--format merl", "do not cover the visible"],
    );
    assert!(!dir.join("m").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad spectral tables through `roks export-brdf`: a wavelength missing
/// in one incidence, a summary of other wavelengths; exit 2, one line
/// naming the file, line and column (or key), nothing written.
#[test]
fn bad_spectral_folders_exit_2_naming_the_file() {
    let dir = scratch("bad");
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        default_with("wavelengths_um = [0.45, 0.55, 0.65]", "0, 30"),
    )
    .unwrap();
    let run = dir.join("run");
    brdf_quiet(&scene, &run, "4096");
    let csv = std::fs::read_to_string(run.join("brdf.csv")).unwrap();
    let summary = std::fs::read_to_string(run.join("summary.json")).unwrap();
    let target = dir.join("x").join("out.bsdf");
    let export = |folder: &Path| {
        roks(&[
            "export-brdf",
            s(folder),
            "--format",
            "zemax",
            "--out",
            s(&target),
        ])
    };
    // Drop the 0.55 um block of the second incidence (30 degrees).
    let missing = dir.join("missing");
    std::fs::create_dir_all(&missing).unwrap();
    let kept: Vec<&str> = csv
        .lines()
        .filter(|l| !l.starts_with("30,0,0.55,"))
        .collect();
    std::fs::write(missing.join("brdf.csv"), kept.join("\n") + "\n").unwrap();
    let line = kept
        .iter()
        .position(|l| l.starts_with("30,0,0.65,"))
        .unwrap()
        + 1;
    let o = export(&missing);
    assert_input_error(
        "missing wavelength",
        &o,
        &missing.join("brdf.csv"),
        &target,
        &[
            &format!("line {line}, column 3 (wavelength_um)"),
            "found 0.65 um, expected 0.55 um",
        ],
    );
    // The summary of a run at other wavelengths.
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("brdf.csv"), &csv).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&summary).unwrap();
    v["run"]["wavelengths_um"] = serde_json::json!([0.45, 0.55, 0.7]);
    std::fs::write(other.join("summary.json"), v.to_string()).unwrap();
    let o = export(&other);
    assert_input_error(
        "other summary",
        &o,
        &other.join("summary.json"),
        &target,
        &["wavelengths_um", "not the table's wavelengths"],
    );
    assert!(!dir.join("x").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run of one wavelength reads and exports like a monochrome one: `roks
/// brdf --export merl` of the default scene (reflectance constant in
/// wavelength) at 0.55 um alone writes a grey MERL file, byte for byte the
/// file of the monochrome run with the same seed (each channel the BRDF),
/// where several wavelengths off the visible are refused (above).
#[test]
fn merl_of_one_wavelength_is_the_grey_monochrome_file() {
    let dir = scratch("one");
    let run = |name: &str, extra: &str| {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, default_with(extra, "0, 30")).unwrap();
        let out = dir.join(name);
        let o = roks(&[
            "brdf",
            s(&scene),
            "--out",
            s(&out),
            "--export",
            "merl",
            "-q",
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        std::fs::read(out.join("brdf.binary")).unwrap()
    };
    let one = run("one", "wavelengths_um = [0.55]");
    let mono = run("mono", "");
    assert!(
        one == mono,
        "the MERL file of one wavelength is not the monochrome one"
    );
    // Grey: the three channels agree at the specular direction of 30 degrees.
    let m = Merl::parse(&one, "one").unwrap();
    let theta = 30f64.to_radians();
    let got = m.lookup(
        DVec3::new(theta.sin(), 0.0, theta.cos()),
        DVec3::new(-theta.sin(), 0.0, theta.cos()),
    );
    assert!(
        got[0] > 0.0 && got[0] == got[1] && got[1] == got[2],
        "{got:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
