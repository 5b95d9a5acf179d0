//! Surface realisations (`[surface] realisations = R`): the ensemble of R
//! random surfaces, each tracing its block of whole batches.
//!
//! * The ensemble's sums equal, bit for bit, those of R single-realisation
//!   runs of the scene with the geometry seeds `realisation_seed(seed, r)`,
//!   each tracing realisation r's photon block, pushed into one batch tree;
//!   and each realisation's reflectance is that run's.
//! * The same for one thread and for the pool's threads.
//! * The spread of the realisations' reflectances shrinks as the field grows.
//! * Shards of an ensemble merge to the whole run; realisations of a
//!   surface that is one surface are refused.

mod common;

use roks::scene::micro::{MicroScene, realisation_seed};
use roks::tally::sum::BATCH;
use roks::tally::sum::Node;
use roks::transport::brdf::{BrdfRun, BrdfTallies, IncidenceResult, ShardRange, add_up};

/// A Gaussian field of `cells` correlation lengths (tau = 2) per side, 8
/// grid squares per correlation length, geometry seed `seed`.
fn gaussian(cells: u32, seed: u64, realisations: u64, photons: u64, theta: &str) -> MicroScene {
    gaussian_at(cells, seed, realisations, photons, theta, 0.0)
}

/// [`gaussian`] lit from azimuth `phi` (degrees).
fn gaussian_at(
    cells: u32,
    seed: u64,
    realisations: u64,
    photons: u64,
    theta: &str,
    phi: f64,
) -> MicroScene {
    let size = 2.0 * f64::from(cells);
    common::scene(
        "ensemble",
        &format!(
            r#"
[surface]
size = [{size}, {size}]
material = "m"
heightfield = {{ gaussian = {{ sigma = 1.2, tau = 2.0 }}, resolution = {res}, seed = {seed} }}
realisations = {realisations}
[materials.m]
reflectance = 0.7
[light]
theta_deg = [{theta}]
phi_deg = {phi:?}
photons = {photons}
seed = 9
[tally]
bands = 8
"#,
            res = 8 * cells,
        ),
    )
}

/// Two random bump tables (the second with its default seed 2).
fn bumps(seed: u64, seed2: Option<u64>, realisations: u64, photons: u64) -> MicroScene {
    let seed2 = seed2.map_or(String::new(), |s| format!("seed = {s}"));
    common::scene(
        "bumps",
        &format!(
            r#"
[surface]
size = [20.0, 20.0]
material = "m"
realisations = {realisations}
[materials.m]
reflectance = 0.8
[[bumps]]
shape = "ellipsoid"
count = 12
radius = [1.5, 3.0]
height = [1.0, 3.0]
seed = {seed}
[[bumps]]
shape = "cone"
count = 6
radius = 2.0
height = 2.5
{seed2}
[light]
theta_deg = [0, 60]
photons = {photons}
seed = 4
[tally]
bands = 8
"#
        ),
    )
}

/// The leaf of incidence `theta` (first wavelength) of `run`'s photons
/// ([`BrdfRun::photon_range`]) on `surfaces`.
fn leaf(run: &BrdfRun, surfaces: &[&roks::micro::MicroSurface], theta: f64) -> IncidenceResult {
    let mut run = run.clone();
    run.theta_deg = vec![theta];
    run.trace_realisations(surfaces, run.photon_range(), &|_| {})
        .into_leaves()
        .swap_remove(0)
}

/// The tree nodes of [`leaf`] (a whole run of one realisation: its root,
/// which the leaf keeps as its sums).
fn nodes(
    run: &BrdfRun,
    surfaces: &[&roks::micro::MicroSurface],
    theta: f64,
) -> Vec<Node<BrdfTallies>> {
    leaf(run, surfaces, theta).tree_nodes(run).into_owned()
}

/// The ensemble against single-realisation runs of the seeds of each
/// realisation over its photon block.
fn check_ensemble(ensemble: &MicroScene, single: impl Fn(u64) -> MicroScene) {
    let run = ensemble.brdf_run();
    let r_count = run.realisations;
    assert!(r_count > 1);
    assert_eq!(ensemble.surfaces().len() as u64, r_count);
    for &theta in &run.theta_deg {
        let result = leaf(&run, &ensemble.surfaces(), theta);
        let mut pieces = Vec::new();
        for r in 0..r_count {
            let scene = single(r);
            let mut one = scene.brdf_run();
            assert_eq!(one.realisations, 1);
            let (b0, b1) = run.realisation_batches(r);
            one.shard = Some(ShardRange {
                count: r_count,
                index: r,
                first_photon: b0 * BATCH,
                last_photon: (b1 * BATCH).min(run.photons),
            });
            let own = nodes(&one, &[&scene.surface], theta);
            let sums = add_up(&own).unwrap();
            assert_eq!(sums.photons, (b1 * BATCH).min(run.photons) - b0 * BATCH);
            let (mean, se) = (
                sums.reflected.mean(0, sums.photons),
                sums.reflected.stderr(0, sums.photons),
            );
            let got = result.realisations[r as usize];
            assert_eq!(got.photons, sums.photons, "realisation {r}");
            assert_eq!(got.reflectance.to_bits(), mean.to_bits(), "realisation {r}");
            assert_eq!(
                got.reflectance_stderr.to_bits(),
                se.to_bits(),
                "realisation {r}"
            );
            pieces.extend(own);
        }
        let root = add_up(&run.combine(pieces.iter())).unwrap();
        assert_eq!(
            root, result.tallies,
            "theta {theta}: ensemble != single runs"
        );
        assert_eq!(root.photons, run.photons);
        // The realisations differ: not one surface traced R times.
        let r0 = result.realisations[0].reflectance;
        assert!(
            result.realisations.iter().any(|x| x.reflectance != r0),
            "{:?}",
            result.realisations
        );
    }
}

#[test]
fn gaussian_ensemble_is_the_single_realisation_runs_bit_for_bit() {
    // 6 batches and a partial one over 3 realisations: blocks of 2, 2, 3.
    let photons = 6 * BATCH + 1000;
    let ensemble = gaussian(4, 3, 3, photons, "0, 50");
    check_ensemble(&ensemble, |r| {
        gaussian(4, realisation_seed(3, r), 1, photons, "0, 50")
    });
}

#[test]
fn bump_ensemble_is_the_single_realisation_runs_bit_for_bit() {
    let photons = 5 * BATCH;
    let ensemble = bumps(1, None, 4, photons);
    check_ensemble(&ensemble, |r| {
        bumps(
            realisation_seed(1, r),
            Some(realisation_seed(2, r)),
            1,
            photons,
        )
    });
    // Realisation 0 is the scene's own surface: R = 1 traces it.
    let one = bumps(1, None, 1, photons);
    let run = one.brdf_run();
    let mut four = run.clone();
    four.realisations = 4;
    let surfaces = vec![&one.surface; 4];
    let a = add_up(&nodes(&run, &[&one.surface], 60.0)).unwrap();
    let b = add_up(&four.combine(nodes(&four, &surfaces, 60.0).iter())).unwrap();
    assert_eq!(a, b, "one surface in four blocks is the one-block run");
}

#[test]
fn ensembles_are_the_same_for_any_thread_count() {
    let scene = gaussian(4, 3, 3, 6 * BATCH + 1000, "60");
    let run = scene.brdf_run();
    let trace = || leaf(&run, &scene.surfaces(), 60.0);
    let many = trace();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(trace);
    assert_eq!(many.tallies, one.tallies);
    assert_eq!(many.realisations, one.realisations);
}

/// The spread of the realisations' reflectances at 70 degrees (where
/// shadowing and multiple reflections, which depend on the realisation, are
/// strong), for a field of `cells` correlation lengths per side: `(spread,
/// Monte Carlo spread, sampling error of the spread)`.
fn spread(cells: u32) -> (f64, f64, f64) {
    let r = 24;
    let scene = gaussian(cells, 3, r, r * 2 * BATCH, "70");
    let run = scene.brdf_run();
    let result = leaf(&run, &scene.surfaces(), 70.0);
    let s = roks::output::summary::RealisationsSummary::new(&result.realisations).unwrap();
    // Standard error of a sample standard deviation of R normal values.
    (
        s.spread,
        s.monte_carlo_spread,
        s.spread / (2.0 * (r as f64 - 1.0)).sqrt(),
    )
}

#[test]
fn the_spread_between_realisations_shrinks_as_the_field_grows() {
    let (small, mc_small, e_small) = spread(2);
    let (large, mc_large, e_large) = spread(8);
    eprintln!(
        "spread {small} +- {e_small} (MC {mc_small}) -> {large} +- {e_large} (MC {mc_large})"
    );
    // The surfaces' spread dominates the photon noise in the small field...
    assert!(small > 3.0 * mc_small, "{small} vs MC {mc_small}");
    // ... and falls by well over its errors in a field 4 times wider.
    assert!(
        small - large > 4.0 * (e_small * e_small + e_large * e_large).sqrt(),
        "{small} +- {e_small} -> {large} +- {e_large}"
    );
}

mod cli_common;

/// A scratch folder for one test.
fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("roks-realis-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const GAUSSIAN_4: &str = r#"
[surface]
size = [8.0, 8.0]
material = "m"
heightfield = { gaussian = { sigma = 1.2, tau = 2.0 }, resolution = 32, seed = 3 }
realisations = 4
[materials.m]
reflectance = 0.7
[light]
theta_deg = [0, 60]
photons = 50000
[tally]
bands = 8
"#;

/// `roks brdf --shard I/N` of an ensemble and `roks merge` give the whole
/// run's files (brdf.csv byte for byte, summary.json with its realisations
/// but for timings), for shards that cut realisations' blocks.
#[test]
fn shards_of_an_ensemble_merge_to_the_whole_run() {
    use cli_common::{read, roks, summary_without_timing};
    let root = scratch("shards");
    let scene = root.join("g.toml");
    std::fs::write(&scene, GAUSSIAN_4).unwrap();
    let brdf = |out: &std::path::Path, shard: Option<&str>| {
        let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
        let mut args = vec!["brdf", s, "-q", "--out", o];
        if let Some(sh) = shard {
            args.extend(["--shard", sh]);
        }
        let r = roks(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    let full = root.join("full");
    brdf(&full, None);
    let summary = summary_without_timing(&full);
    assert_eq!(summary["run"]["realisations"], 4);
    for inc in summary["incidence"].as_array().unwrap() {
        let r = &inc["realisations"];
        assert_eq!(r["reflectance"].as_array().unwrap().len(), 4);
        // 13 batches over 4 realisations: 3, 3, 3 and 4 (the last partial).
        let photons: Vec<u64> = r["photons"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p.as_u64().unwrap())
            .collect();
        assert_eq!(photons, [12288, 12288, 12288, 13136]);
        assert!(r["spread"].as_f64().unwrap() > 0.0);
    }
    for n in [3_u32, 5] {
        let dirs: Vec<_> = (0..n).map(|i| root.join(format!("n{n}-{i}"))).collect();
        for (i, d) in dirs.iter().enumerate() {
            brdf(d, Some(&format!("{i}/{n}")));
        }
        let merged = root.join(format!("merged{n}"));
        let mut args = vec!["merge".to_owned(), "-q".to_owned()];
        args.extend(dirs.iter().map(|d| d.display().to_string()));
        args.extend(["--out".into(), merged.display().to_string()]);
        let o = roks(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            read(&full, "brdf.csv") == read(&merged, "brdf.csv"),
            "{n} shards"
        );
        assert_eq!(summary, summary_without_timing(&merged), "{n} shards");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Realisations of a surface that is one surface, or more than the
/// batches: one line naming the file and the key, exit 2.
#[test]
fn realisations_of_one_surface_are_refused() {
    use cli_common::{assert_input_error, roks};
    let root = scratch("refused");
    std::fs::write(root.join("map.txt"), "0 1\n1 0\n").unwrap();
    let cases = [
        (
            "map",
            "[surface]\nmaterial = \"m\"\nheightfield = { file = \"map.txt\", pixel = 1.0 }\nrealisations = 2\n",
            "a measured height map is one surface",
        ),
        (
            "bodies",
            "[surface]\nsize = [4.0, 4.0]\nmaterial = \"m\"\nrealisations = 2\n[quadrics]\ns = { sphere = { center = [2.0, 2.0, 0.0], r = 1.0 } }\n[[bodies]]\nregion = \"-s\"\n",
            "explicit bodies is one surface",
        ),
        (
            "flat",
            "[surface]\nsize = [4.0, 4.0]\nmaterial = \"m\"\nrealisations = 2\n",
            "a flat substrate is one surface",
        ),
        (
            "batches",
            "[surface]\nsize = [8.0, 8.0]\nmaterial = \"m\"\nheightfield = { gaussian = { sigma = 1.0, tau = 2.0 }, resolution = 16 }\nrealisations = 4\n[light]\nphotons = 8193\n",
            "must be in 1..=3",
        ),
        (
            "zero",
            "[surface]\nsize = [8.0, 8.0]\nmaterial = \"m\"\nheightfield = { gaussian = { sigma = 1.0, tau = 2.0 }, resolution = 16 }\nrealisations = 0\n",
            "must be in 1..=",
        ),
    ];
    for (name, text, expect) in cases {
        let scene = root.join(format!("{name}.toml"));
        std::fs::write(&scene, format!("{text}[materials.m]\nreflectance = 0.5\n")).unwrap();
        let out = root.join(format!("out-{name}"));
        let o = roks(&[
            "brdf",
            scene.to_str().unwrap(),
            "-q",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_input_error(name, &o, &scene, &out, &["surface.realisations", expect]);
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// The commands that see one surface of an ensemble: `roks stats` reports
/// realisation 0 and says so in one line; `roks fit` and `roks trace` of an
/// object whose wall descends into the ensemble refuse it in one line
/// naming the key, exit 2, nothing written.
#[test]
fn commands_of_one_surface_say_so_or_refuse_realisations() {
    use cli_common::{assert_input_error, roks};
    let root = scratch("one-surface");
    let micro = root.join("micro.toml");
    std::fs::write(
        &micro,
        GAUSSIAN_4.replace("[surface]\n", "[surface]\nedges = \"periodic\"\n"),
    )
    .unwrap();
    let single = root.join("single.toml");
    std::fs::write(
        &single,
        GAUSSIAN_4.replace("realisations = 4", "realisations = 1"),
    )
    .unwrap();
    // stats: the statistics of realisation 0, which are those of the scene
    // with realisations = 1, and one line saying so (absent for one).
    let stats = |scene: &std::path::Path| {
        let o = roks(&["stats", scene.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).unwrap()
    };
    let (four, one) = (stats(&micro), stats(&single));
    let note: Vec<&str> = four
        .lines()
        .filter(|l| l.starts_with("realisations"))
        .collect();
    assert_eq!(
        note,
        ["realisations     4: statistics of realisation 0 (the scene's own seed) only"]
    );
    let numbers = |t: &str| {
        t.lines()
            .filter(|l| !l.starts_with("realisations") && !l.starts_with("scene"))
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    assert_eq!(numbers(&four), numbers(&one));
    assert!(!one.contains("realisations"), "{one}");
    // fit: refused before any tracing.
    let measured = root.join("measured.csv");
    std::fs::write(&measured, "theta_i_deg,theta_o_deg,brdf\n0,10,0.2\n").unwrap();
    let out = root.join("fit-out");
    let o = roks(&[
        "fit",
        micro.to_str().unwrap(),
        measured.to_str().unwrap(),
        "--param",
        "materials.m.reflectance=0.1:0.9",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_input_error(
        "fit",
        &o,
        &micro,
        &out,
        &["surface.realisations", "4 realisations"],
    );
    // trace: an object scene whose wall is the ensemble.
    let object = root.join("object.toml");
    std::fs::write(
        &object,
        "[quadrics]\nwall = { cylinder_z = { r = 25.0 } }\nfront = { plane = [0.0, 0.0, 1.0, 0.0] }\ntip = { plane = [0.0, 0.0, 1.0, -150.0] }\nouter = { cylinder_z = { r = 30.0 } }\n[[cells]]\nname = \"cavity\"\nregion = \"-wall -front +tip\"\nfill = \"void\"\n[[cells]]\nname = \"body\"\nregion = \"-outer -front +tip ~(-wall)\"\nfill = \"solid\"\n[walls]\nwall = \"rough\"\nfront = \"rough\"\ntip = \"rough\"\n[models.rough]\nmicro = \"micro.toml\"\n[[sources]]\nbeam = { direction = [0.0, 0.0, -1.0], diameter = 2.0 }\nposition = [0.0, 0.0, 10.0]\nphotons = 1000\n",
    )
    .unwrap();
    let out = root.join("trace-out");
    let o = roks(&[
        "trace",
        object.to_str().unwrap(),
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_input_error(
        "trace",
        &o,
        &object,
        &out,
        &["models.rough.micro", "surface.realisations = 4"],
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// chi^2 / dof of the mirror pairs of a table lit from azimuth 45 degrees:
/// the Carlson cells `(band j, cell k)` and `(j, j - k mod 4j)` (azimuth
/// `phi` and `90 - phi`), for the `k` with `2k != j mod 4j` (the cells on
/// the plane of incidence are their own images), each pair with photons in
/// both counted once with `z = (f_a - f_b) / sqrt(s_a² + s_b²)` (`f` the
/// fraction, `s` its standard error; the cells' small multinomial
/// covariance `-f_a f_b / N` is neglected). `(chi^2 / dof, dof)`.
fn mirror_chi2(run: &BrdfRun, r: &IncidenceResult) -> (f64, usize) {
    let grid = run.grid();
    let t = &r.tallies;
    let (mut chi2, mut dof) = (0.0, 0);
    for j in 1..=grid.bands() {
        let n = 4 * j;
        for k in 0..n {
            let m = (j + n - k) % n;
            if m <= k {
                continue; // its own image, or the pair counted at m
            }
            let (a, b) = (grid.index(j, k), grid.index(j, m));
            let (sa, sb) = (r.carlson_stderr(a), r.carlson_stderr(b));
            if sa > 0.0 && sb > 0.0 {
                let d = t.carlson.mean(a, t.photons) - t.carlson.mean(b, t.photons);
                chi2 += d * d / (sa * sa + sb * sb);
                dof += 1;
            }
        }
    }
    (chi2 / dof as f64, dof)
}

/// A Gaussian surface is mirror symmetric about the plane of incidence in
/// the mean: at 30 degrees the ensemble of 64 realisations (one batch
/// each) passes the mirror test within its errors (chi^2/dof within 4 sigma
/// of 1, `sqrt(2 / dof)`), where one realisation of the same photons fails
/// it far beyond. Lit from 45 degrees: the height field's triangles (every
/// grid square cut along the diagonal from `(i, j)` to `(i + 1, j + 1)`)
/// are mirror symmetric about the diagonal planes only, so about the plane
/// at azimuth 0 even the ensemble is not (chi^2/dof 1.8 here). The field
/// (48 tau wide) is wide enough that one realisation's asymmetry, which the
/// ensemble divides by 64, is well below one batch's photon noise.
#[test]
fn the_ensemble_table_is_mirror_symmetric_where_one_realisation_is_not() {
    let photons = 64 * BATCH;
    let mut chi2 = Vec::new();
    for r in [1, 64] {
        let scene = gaussian_at(24, 3, r, photons, "30", 45.0);
        let run = scene.brdf_run();
        let result = leaf(&run, &scene.surfaces(), 30.0);
        chi2.push(mirror_chi2(&run, &result));
    }
    let [(one, dof1), (many, dof)] = chi2[..] else {
        unreachable!()
    };
    eprintln!("mirror chi2/dof: one realisation {one} ({dof1} pairs), 64: {many} ({dof} pairs)");
    let bound = 1.0 + 4.0 * (2.0 / dof as f64).sqrt();
    assert!(many < bound, "ensemble {many} >= {bound}");
    assert!(one > 3.0 * bound, "one realisation {one}: not asymmetric");
}

/// The memory limit counts every realisation's surface: 64 fields of
/// 512 x 512 (about 15 MiB each) are refused under a 512 MiB limit that one
/// field passes, naming the key.
#[test]
fn the_memory_limit_counts_every_realisation() {
    let root = scratch("memory");
    let scene = root.join("big.toml");
    let text = |r: u32| {
        format!(
            "[surface]\nsize = [64.0, 64.0]\nmaterial = \"m\"\nheightfield = {{ gaussian = {{ sigma = 1.0, tau = 2.0 }}, resolution = 512 }}\nrealisations = {r}\n[materials.m]\nreflectance = 0.5\n[light]\nphotons = 300000\ntheta_deg = [0]\n"
        )
    };
    let run = |r: u32| {
        std::fs::write(&scene, text(r)).unwrap();
        let out = root.join(format!("out{r}"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_roks"))
            .args(["stats", scene.to_str().unwrap()])
            .env("ROKS_MAX_MEMORY", "512M")
            .output()
            .unwrap();
        (o, out)
    };
    let (o, _) = run(1);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (o, out) = run(64);
    cli_common::assert_input_error(
        "64 realisations",
        &o,
        &scene,
        &out,
        &[
            "surface.realisations",
            "64 surface realisations",
            "memory limit",
        ],
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// The example scene `scenes/gaussian-ensemble.toml` runs (16 realisations,
/// one batch each at 65 536 photons) and reports every realisation.
#[test]
fn the_example_ensemble_scene_runs() {
    let root = scratch("example");
    let scene =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gaussian-ensemble.toml");
    let out = root.join("out");
    let o = cli_common::roks(&[
        "brdf",
        scene.to_str().unwrap(),
        "-q",
        "--photons",
        "65536",
        "--theta",
        "30",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = cli_common::summary_without_timing(&out);
    let r = &s["incidence"][0]["realisations"];
    assert_eq!(r["photons"].as_array().unwrap().len(), 16, "{r}");
    assert!(
        r["photons"].as_array().unwrap().iter().all(|p| p == 4096),
        "{r}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// One column of a CSV text, by its header name.
fn csv_column(text: &str, name: &str) -> Vec<f64> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let i = header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    lines
        .map(|l| l.split(',').nth(i).unwrap().parse().unwrap())
        .collect()
}

/// `(z of the reflectance, Σ z² / n over the cells, n)` of two result
/// folders of the same scene, with the errors of `brdf.csv`'s column
/// `stderr` and the reflectance's `summary.json` key `reflectance_key`:
/// `z = (f_a - f_b) / sqrt(s_a² + s_b²)` over the cells with `s_a² + s_b²
/// > 0`.
fn agreement(
    a: &std::path::Path,
    b: &std::path::Path,
    stderr: &str,
    key: &str,
) -> (f64, f64, usize) {
    use cli_common::summary_without_timing;
    let csv = |d: &std::path::Path| String::from_utf8(cli_common::read(d, "brdf.csv")).unwrap();
    let (ta, tb) = (csv(a), csv(b));
    let (fa, fb) = (csv_column(&ta, "fraction"), csv_column(&tb, "fraction"));
    let (sa, sb) = (csv_column(&ta, stderr), csv_column(&tb, stderr));
    let (mut chi2, mut n) = (0.0, 0);
    for c in 0..fa.len() {
        let var = sa[c] * sa[c] + sb[c] * sb[c];
        if var > 0.0 {
            chi2 += (fa[c] - fb[c]).powi(2) / var;
            n += 1;
        }
    }
    let (ea, eb) = (summary_without_timing(a), summary_without_timing(b));
    let (ia, ib) = (&ea["incidence"][0], &eb["incidence"][0]);
    let r = |i: &serde_json::Value, k: &str| i[k].as_f64().unwrap();
    let z = (r(ia, "reflectance") - r(ib, "reflectance")) / r(ia, key).hypot(r(ib, key));
    (z, chi2 / n as f64, n)
}

/// Two independent ensembles (other geometry seeds, other tracing seeds)
/// of the Gaussian field of `scenes/gaussian-ensemble.toml` (16
/// realisations, at 30 degrees, 16 bands, 16 batches per realisation) agree
/// within the errors they report: the reflectances within 4 standard
/// errors, and over the cells `var(z) = Σ z² / n` within 4 sigma of 1 for
/// a chi² of `n` degrees of freedom, `|var(z) - 1| <= 4 sqrt(2 / n)`. (With
/// errors of 15 degrees of freedom each, z follows Student's t of about 30
/// degrees of freedom, whose variance 30/28 is well inside that bound.)
/// The photon-noise errors alone (`fraction_stderr_photon`,
/// `reflectance_stderr_photon`: the files' errors before the ensemble's)
/// fail the same test: the surfaces differ by more than their photons.
/// The summary gives 15 degrees of freedom.
#[test]
fn two_independent_ensembles_agree_within_their_errors() {
    let root = scratch("two-ensembles");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gaussian-ensemble.toml"),
    )
    .unwrap()
    .replace("bands = 32", "bands = 16");
    let run = |name: &str, geometry: u64, seed: u64| {
        let scene = root.join(format!("{name}.toml"));
        let t = text.replace("seed = 3 }", &format!("seed = {geometry} }}"));
        assert!(t.contains(&format!("resolution = 256, seed = {geometry} }}")));
        std::fs::write(&scene, t).unwrap();
        let out = root.join(name);
        let photons = (16 * 16 * BATCH).to_string();
        let o = cli_common::roks(&[
            "brdf",
            scene.to_str().unwrap(),
            "-q",
            "--photons",
            &photons,
            "--theta",
            "30",
            "--seed",
            &seed.to_string(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    };
    let (a, b) = (run("a", 3, 1), run("b", 1003, 2));
    let s = cli_common::summary_without_timing(&a);
    assert_eq!(s["incidence"][0]["stderr_dof"], 15, "{}", s["incidence"][0]);
    let (z, var, n) = agreement(&a, &b, "fraction_stderr", "reflectance_stderr");
    let bound = 4.0 * (2.0 / n as f64).sqrt();
    eprintln!("ensemble errors: z {z:.2}, var(z) {var:.6} over {n} cells (1 +- {bound:.3})");
    let (z_p, var_p, n_p) = agreement(
        &a,
        &b,
        "fraction_stderr_photon",
        "reflectance_stderr_photon",
    );
    let bound_p = 4.0 * (2.0 / n_p as f64).sqrt();
    eprintln!("photon errors: z {z_p:.2}, var(z) {var_p:.3} over {n_p} cells (1 +- {bound_p:.3})");
    assert!(z.abs() <= 4.0, "reflectances differ by z = {z}");
    assert!((var - 1.0).abs() <= bound, "var(z) {var} over {n} cells");
    // The old errors (photon noise only) fail.
    assert!(
        z_p.abs() > 4.0 || (var_p - 1.0).abs() > bound_p,
        "photon errors pass: z {z_p}, var(z) {var_p}"
    );
    let _ = std::fs::remove_dir_all(&root);
}
