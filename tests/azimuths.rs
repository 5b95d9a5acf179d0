//! Several light azimuths (`[light] phi_deg = [...]`, `--phi`, issue 33):
//! the exact reflectances of V-grooves lit across and along, the
//! anisotropy figure far beyond its bound for them and within it for an
//! isotropic ensemble, the photon streams of each azimuth, the layout of
//! the result folder, and shards merged per azimuth, byte for byte.

mod cli_common;
mod common;

use std::path::{Path, PathBuf};

use cli_common::{assert_input_error, read, roks, summary_without_timing};
use roks::tally::anisotropy::Anisotropy;
use roks::tally::sum::BATCH;
use roks::transport::brdf::{Azimuths, BrdfResult, BrdfRun};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-azimuths-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `|got - want| <= max(4 sigma, 1e-12)`: 4 reported standard errors, or
/// rounding when every photon carries the same weight (sigma 0).
fn within(what: &str, got: (f64, f64), want: f64) {
    let (r, se) = got;
    assert!(
        (r - want).abs() <= (4.0 * se).max(1e-12),
        "{what}: {r} +- {se}, exact {want}"
    );
}

/// 45-degree specular V-grooves along y, wall reflectance 0.8, lit from 30
/// degrees across (phi = 0) and along (phi = 90) the grooves. Across: the
/// 2-D grooves of Zipin (1966) (REFERENCE.md: 1/sqrt 3 of the photons leave
/// after one reflection, the rest after two), reflectance
/// `rho / sqrt 3 + rho² (1 - 1/sqrt 3)`. Along: the grooves' section sees a
/// flight at normal incidence, and 45-degree grooves send every such
/// flight back up after exactly two reflections (Zipin: alpha = 45,
/// theta = 0), whatever its component along y: reflectance `rho²`, every
/// photon alike. The anisotropy figure (the two tables turned by 90
/// degrees onto each other) is far beyond its 4-sigma bound, and the
/// first azimuth's table is bit for bit that of a run at phi = 0 alone.
#[test]
fn grooves_across_and_along_give_both_closed_forms() {
    let rho: f64 = 0.8;
    let photons = 40_000;
    let text = common::grooves_toml(45.0, 30.0, rho, photons, 7);
    let one = common::scene("grooves", &text);
    let both = common::scene(
        "grooves",
        &text.replace("phi_deg = 0.0", "phi_deg = [0.0, 90.0]"),
    );
    let run = both.brdf_run();
    assert_eq!(run.phi_deg, Azimuths(vec![0.0, 90.0]));
    let result = run.trace_whole(&both.surface, &|_| {});
    assert_eq!(result.incidence[0].azimuth.len(), 2);
    let (across, along) = (result.leaf(0, 0, 0), result.leaf(0, 1, 0));
    assert_eq!((across.phi_i_deg, along.phi_i_deg), (0.0, 90.0));
    let s3 = 3f64.sqrt();
    within(
        "across",
        across.reflectance(),
        rho / s3 + rho * rho * (1.0 - 1.0 / s3),
    );
    within("along", along.reflectance(), rho * rho);
    // Along: every photon reflected exactly twice.
    let n = along.tallies.photons as f64;
    assert_eq!(along.tallies.bounces, 2 * along.tallies.photons);
    assert!((along.tallies.by_bounces[2] - rho * rho * n).abs() <= 1e-9 * n);
    // Across: 1/sqrt 3 once, the rest twice, within 4 sigma of the counts.
    let once = across.tallies.by_bounces[1] / (rho * n);
    let sigma = (once * (1.0 - once) / n).sqrt();
    assert!((once - 1.0 / s3).abs() <= 4.0 * sigma, "{once}");

    let a = result.anisotropy(&run.grid()).expect("two azimuths");
    eprintln!(
        "grooves: anisotropy chi2/dof {} over {} cells, bound {}",
        a.figure.chi2_dof, a.figure.dof, a.figure.bound
    );
    assert_eq!(a.pair_count, 1);
    assert!(a.figure.dof > 0);
    assert!(
        a.figure.chi2_dof > 100.0 * a.figure.bound,
        "grooves look isotropic: {:?}",
        a.figure
    );

    // The first azimuth's photons are those of the run at phi = 0 alone.
    let alone = one.brdf_run().trace_whole(&one.surface, &|_| {});
    assert_eq!(
        serde_json::to_string(&alone.leaf(0, 0, 0).tallies).unwrap(),
        serde_json::to_string(&across.tallies).unwrap()
    );
    assert!(alone.anisotropy(&run.grid()).is_none());
}

/// A Gaussian field (sigma/tau = 0.6, 48 tau wide, 8 grid squares per tau)
/// as an ensemble of 64 realisations (one batch each), lit from 30 degrees
/// at azimuths 30 and 210. A height field's triangles (every square cut
/// along the diagonal from (i, j) to (i + 1, j + 1)) are unchanged by a half
/// turn, and the Gaussian statistics by any turn, so the ensemble lit from
/// phi and phi + 180 is the same random surface: the two tables agree
/// within their errors (anisotropy within its 4-sigma bound), and so do
/// the reflectances (within 4 combined standard errors). Other pairs of
/// azimuths (0 and 90: the diagonal mirror, not a turn) are equivalent only
/// in the limit of a fine grid.
#[test]
fn a_gaussian_ensemble_is_isotropic_under_a_half_turn() {
    let cells = 24;
    let size = 2.0 * f64::from(cells);
    let scene = common::scene(
        "ensemble",
        &format!(
            r#"
[surface]
size = [{size}, {size}]
material = "m"
heightfield = {{ gaussian = {{ sigma = 1.2, tau = 2.0 }}, resolution = {res}, seed = 3 }}
realisations = 64
[materials.m]
reflectance = 0.7
[light]
theta_deg = [30]
phi_deg = [30.0, 210.0]
photons = {photons}
seed = 9
[tally]
bands = 8
"#,
            res = 8 * cells,
            photons = 64 * BATCH,
        ),
    );
    let run = scene.brdf_run();
    let result = run.trace_realisations(&scene.surfaces(), run.photon_range(), &|_| {});
    let (a, b) = (result.leaf(0, 0, 0), result.leaf(0, 1, 0));
    let ((ra, sa), (rb, sb)) = (a.reflectance(), b.reflectance());
    let z = (ra - rb) / sa.hypot(sb);
    let figure = result.anisotropy(&run.grid()).expect("two azimuths").figure;
    eprintln!(
        "ensemble: reflectance {ra} +- {sa} and {rb} +- {sb} (z = {z}); anisotropy chi2/dof {} over {} cells, bound {}, p = {}",
        figure.chi2_dof, figure.dof, figure.bound, figure.p_value
    );
    assert!(z.abs() <= 4.0, "reflectances differ: z = {z}");
    // Every cell compared (a half turn maps every band onto itself).
    assert!(figure.dof > (run.grid().n_cells() as u64) / 2, "{figure:?}");
    assert!(figure.isotropic(), "{figure:?}");
}

/// A result's anisotropy compares the tables it holds at their azimuths:
/// a table copied to a second azimuth a full turn away (to rounding) is
/// compared cell by cell with itself, chi² 0 over every cell with photons.
#[test]
fn identical_tables_at_the_same_azimuth_have_no_anisotropy() {
    let text = common::grooves_toml(45.0, 30.0, 0.8, 8192, 7);
    let scene = common::scene("grooves", &text);
    let run = scene.brdf_run();
    let mut result: BrdfResult = run.trace_whole(&scene.surface, &|_| {});
    let mut copy = result.incidence[0].azimuth[0].clone();
    copy.phi_i_deg = 360.0 - 1e-13; // a full turn, to rounding
    for l in &mut copy.wavelength {
        l.phi_i_deg = copy.phi_i_deg;
    }
    result.incidence[0].azimuth.push(copy);
    let a: Anisotropy = result.anisotropy(&run.grid()).unwrap();
    assert_eq!(a.figure.chi2, 0.0);
    assert!(a.figure.dof > 0);
}

/// The options of a small two-azimuth run of the default scene.
fn brdf(out: &Path, extra: &[&str]) {
    let mut args = vec![
        "brdf",
        "-q",
        "--photons",
        "20000",
        "--theta",
        "0,45",
        "--phi",
        "0,90",
        "--seed",
        "5",
        "--polarisation",
        "stokes",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Shards merged per azimuth give the whole run's files byte for byte (2
/// and 3 shards of 5 batches), and the thread count changes no bit; the
/// folder's layout: blocks incidence, then azimuth; `inplane.csv` with
/// `phi_i_deg`; pictures per azimuth; `summary.json` with the list of
/// azimuths, one entry per incidence and azimuth, and `anisotropy`.
#[test]
fn shards_and_threads_per_azimuth_are_exact() {
    let root = scratch("shards");
    let full = root.join("full");
    brdf(&full, &["--threads", "2"]);
    let one_thread = root.join("one-thread");
    brdf(&one_thread, &["--threads", "1"]);
    let tables = ["brdf.csv", "inplane.csv", "stokes.csv"];
    for f in tables {
        assert!(read(&full, f) == read(&one_thread, f), "threads: {f}");
    }
    for n in [2_u32, 3] {
        let dirs: Vec<PathBuf> = (0..n).map(|i| root.join(format!("n{n}-s{i}"))).collect();
        for (i, d) in dirs.iter().enumerate() {
            brdf(d, &["--shard", &format!("{i}/{n}")]);
        }
        let merged = root.join(format!("n{n}-merged"));
        let mut args: Vec<String> = vec!["merge".into(), "-q".into()];
        args.extend(dirs.iter().map(|d| d.display().to_string()));
        args.extend(["--out".into(), merged.display().to_string()]);
        let o = roks(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for f in tables.iter().copied().chain([
            "hemisphere_45deg_phi90.png",
            "dop_0deg_phi0.png",
            "inplane.png",
        ]) {
            assert!(
                read(&full, f) == read(&merged, f),
                "{n} shards: {f} differs"
            );
        }
        assert_eq!(
            summary_without_timing(&full),
            summary_without_timing(&merged),
            "{n} shards"
        );
    }

    // The layout.
    let text = String::from_utf8(read(&full, "brdf.csv")).unwrap();
    let mut blocks: Vec<(String, String)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let mut c = l.split(',');
            (c.next().unwrap().into(), c.next().unwrap().into())
        })
        .collect();
    blocks.dedup();
    let want: Vec<(String, String)> = [("0", "0"), ("0", "90"), ("45", "0"), ("45", "90")]
        .iter()
        .map(|(t, p)| ((*t).into(), (*p).into()))
        .collect();
    assert_eq!(blocks, want, "brdf.csv blocks: incidence, then azimuth");
    let inplane = String::from_utf8(read(&full, "inplane.csv")).unwrap();
    assert!(inplane.starts_with("theta_i_deg,phi_i_deg,theta_o_deg,brdf,brdf_stderr\n"));
    assert!(inplane.contains("\n45,90,"));
    let s = summary_without_timing(&full);
    assert_eq!(s["run"]["phi_deg"], serde_json::json!([0.0, 90.0]));
    let entries: Vec<(f64, f64)> = s["incidence"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["theta_deg"].as_f64().unwrap(),
                e["phi_deg"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        entries,
        [(0.0, 0.0), (0.0, 90.0), (45.0, 0.0), (45.0, 90.0)]
    );
    let a = &s["anisotropy"];
    assert_eq!(a["pair_count"], 2);
    assert!(a["dof"].as_u64().unwrap() > 0 && a["chi2_dof"].as_f64().unwrap() > 0.0);
    for name in [
        "hemisphere_0deg_phi0.png",
        "hemisphere_0deg_phi90.png",
        "hemisphere_45deg_phi0.png",
        "hemisphere_45deg_phi90.png",
    ] {
        assert!(full.join(name).exists(), "{name}");
    }
    assert!(!full.join("hemisphere_45deg.png").exists());
    let _ = std::fs::remove_dir_all(&root);
}

/// A run of one azimuth given as a list is the run given as a number, bit
/// for bit (the files of a one-azimuth run do not change): `run.phi_deg`
/// is a number in `summary.json`, no `anisotropy`, no `phi_i_deg` column
/// in `inplane.csv`.
#[test]
fn one_azimuth_as_a_list_is_the_number() {
    let root = scratch("one");
    let a = root.join("a");
    let o = roks(&[
        "brdf",
        "-q",
        "--photons",
        "4096",
        "--theta",
        "30",
        "--phi",
        "45",
        "--out",
        a.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scene = root.join("list.toml");
    std::fs::write(
        &scene,
        roks::scene::micro::DEFAULT_SCENE
            .replace("phi_deg = 0.0", "phi_deg = [45]")
            .replace("photons = 1000000", "photons = 4096")
            .replace(
                "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
                "theta_deg = [30]",
            ),
    )
    .unwrap();
    let c = root.join("c");
    let o = roks(&[
        "brdf",
        scene.to_str().unwrap(),
        "-q",
        "--out",
        c.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["brdf.csv", "inplane.csv"] {
        assert!(read(&a, f) == read(&c, f), "{f}");
    }
    let s = summary_without_timing(&c);
    assert_eq!(s["run"]["phi_deg"], serde_json::json!(45.0));
    assert!(s.get("anisotropy").is_none());
    assert!(
        String::from_utf8(read(&c, "inplane.csv"))
            .unwrap()
            .starts_with("theta_i_deg,theta_o_deg,")
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Bad azimuths: one line naming the file and `light.phi_deg` (with the
/// index of the azimuth at fault), exit status 2, no folder.
#[test]
fn bad_azimuths_are_refused_by_key() {
    let root = scratch("bad");
    for (case, value, expect) in [
        ("range", "[0, 360]", "light.phi_deg[1]"),
        ("negative", "-10", "light.phi_deg[0]"),
        ("twice", "[90, 0, 90]", "light.phi_deg[2]"),
        ("empty", "[]", "light.phi_deg"),
        ("text", "\"east\"", "light.phi_deg"),
    ] {
        let scene = root.join(format!("{case}.toml"));
        std::fs::write(
            &scene,
            roks::scene::micro::DEFAULT_SCENE
                .replace("phi_deg = 0.0", &format!("phi_deg = {value}")),
        )
        .unwrap();
        let out = root.join(format!("out-{case}"));
        let o = roks(&[
            "brdf",
            scene.to_str().unwrap(),
            "-q",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_input_error(case, &o, &scene, &out, &[expect]);
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// The per-azimuth seed rule, stated in `Azimuths`' docs.
#[test]
fn azimuth_seeds() {
    let mut run: BrdfRun = roks::scene::micro::MicroScene::default_scene().brdf_run();
    run.seed = 5;
    assert_eq!(run.azimuth_seed(0), 5);
    assert_eq!(
        run.azimuth_seed(1),
        5u64.wrapping_add(0xD1B5_4A32_D192_ED03)
    );
}
