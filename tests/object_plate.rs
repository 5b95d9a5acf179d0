//! A flat macro plate whose top wall is rough (`roks trace`) against the
//! micro level (`roks brdf`): the `micro` descent model and the `brdf` table
//! model.
//!
//! The plate is a solid box (top face z = 0, 10 x 10, 1 thick) lit by a
//! parallel beam of diameter 2 along -omega_i, omega_i = (sin t, 0, cos t),
//! whose footprint lies well inside the top face; light leaving the flat top
//! upward never meets the convex box again, so every photon makes exactly one
//! macro reflection, on the top face, and the object's far field (cells
//! i < n_cells, same Carlson grid) is the plate's reflected distribution.
//!
//! Which comparison is exact:
//! * **micro descent.** At every hit the micro geometry is turned by a
//!   uniform random angle about the normal and entered at a uniform random
//!   point. The plate's expected far field is therefore the micro BRDF
//!   *averaged over the light's azimuth phi_i*, with outgoing directions
//!   measured relative to the plane of incidence. This equals `roks brdf` at
//!   phi_i = 0 cell by cell only for a statistically isotropic micro surface,
//!   which a periodic cell of 20 random ellipsoids is not exactly. Exact
//!   references are therefore (a) the micro kernel itself, traced here with a
//!   uniform random phi_i per photon and the outgoing direction turned back by
//!   -phi_i (unbiased, every cell); and (b) the rotation-invariant totals of
//!   `roks brdf` (reflectance, band totals) averaged over phi_i, estimated by
//!   `BrdfRun` (the code `roks brdf` runs) at 24 equally spaced light
//!   azimuths, a periodic trapezoidal rule, exact for every azimuthal
//!   harmonic below 24 (the azimuthal variation of a rough surface's
//!   reflectance is smooth, its 24th harmonic negligible beside the noise).
//! * **brdf table.** The table model does not rotate: the local frame has the
//!   light on +x, the table's phi_i = 0 frame. Sampling picks a cell with
//!   probability fraction / R and multiplies the weight by R, so the plate's
//!   expected cell fractions are the table's exactly and its reflectance at a
//!   tabulated angle is exactly R (zero variance); between two tabulated
//!   angles the table is interpolated linearly in theta_i (stochastically).

mod object_common;

use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use roks::micro::Scratch;
use roks::scene::micro::MicroScene;
use roks::tally::{Accumulator, CarlsonGrid};
use roks::transport::micro::{Controls, Fate, trace};

use object_common::{assert_4sigma, band_cells, merged, run, scene, scratch};

/// The micro scene: 20 ellipsoids on a 10 x 10 periodic cell, reflectance 0.8.
const MICRO: &str = r#"
name = "plate-micro"

[surface]
size = [10.0, 10.0]
edges = "periodic"
material = "paint"

[materials.paint]
reflectance = 0.8

[[bumps]]
shape = "ellipsoid"
count = 20
radius = [1.5, 2.5]
height = [1.0, 2.5]
seed = 7

[light]
theta_deg = [40]
photons = 100000

[tally]
bands = 4
"#;

/// The plate lit at each of `thetas` (degrees), wall model `model` (TOML).
fn plate(model: &str, thetas: &[f64], photons: u64) -> String {
    let mut sources = String::new();
    for t in thetas {
        let (s, c) = t.to_radians().sin_cos();
        sources.push_str(&format!(
            "[[sources]]\nbeam = {{ direction = [{}, 0.0, {}], diameter = 2.0 }}\nposition = [{}, 0.0, {}]\nphotons = {photons}\n\n",
            -s,
            -c,
            3.0 * s,
            3.0 * c
        ));
    }
    format!(
        r#"
seed = 11

[quadrics]
top = {{ plane = [0.0, 0.0, 1.0, 0.0] }}
bottom = {{ plane = [0.0, 0.0, 1.0, -1.0] }}
xp = {{ plane = [1.0, 0.0, 0.0, 5.0] }}
xm = {{ plane = [1.0, 0.0, 0.0, -5.0] }}
yp = {{ plane = [0.0, 1.0, 0.0, 5.0] }}
ym = {{ plane = [0.0, 1.0, 0.0, -5.0] }}

[[cells]]
name = "plate"
region = "-top +bottom -xp +xm -yp +ym"
fill = "solid"

[walls]
top = "rough"

[models.rough]
{model}

{sources}
[tally]
bands = 4
farfield = true
"#
    )
}

/// The micro kernel averaged over the light's azimuth: per photon a uniform
/// phi_i, a uniform start point on the launch plane (as `roks brdf`), the
/// outgoing direction turned by -phi_i into the frame with the light on +x,
/// tallied on the Carlson grid. Returns (reflected, cells) accumulators.
fn micro_rotation_averaged(
    micro: &MicroScene,
    theta_deg: f64,
    photons: u64,
    grid: &CarlsonGrid,
) -> (Accumulator, Accumulator) {
    let surface = &micro.surface;
    let controls = Controls::default();
    let mut scratch = Scratch::new(surface);
    let mut rng = Pcg64Mcg::seed_from_u64(2024);
    let mut refl = Accumulator::new(1);
    let mut cells = Accumulator::new(grid.n_cells());
    let (st, ct) = theta_deg.to_radians().sin_cos();
    for _ in 0..photons {
        let phi = 2.0 * PI * rng.random::<f64>();
        let (sp, cp) = phi.sin_cos();
        let dir = -DVec3::new(st * cp, st * sp, ct);
        let start = DVec3::new(
            rng.random::<f64>() * surface.size.x,
            rng.random::<f64>() * surface.size.y,
            surface.top,
        );
        let h = trace(surface, start, dir, 1.0, &controls, &mut rng, &mut scratch);
        match h.fate {
            Fate::Escaped { dir: l, weight } => {
                refl.score(0, weight);
                // Turn by -phi about z.
                let back = DVec3::new(cp * l.x + sp * l.y, -sp * l.x + cp * l.y, l.z);
                if let Some(c) = grid.locate(back) {
                    cells.score(c, weight);
                }
            }
            Fate::Absorbed => {}
            other => panic!("micro photon lost: {other:?}"),
        }
    }
    (refl, cells)
}

/// Micro descent on the plate at theta_i = 40 degrees against (a) the micro
/// kernel with random light azimuth, cell by cell, and (b) `roks brdf`'s
/// reflectance and band totals averaged over 24 light azimuths; all within
/// 4 combined standard errors (independent runs: sigma^2 adds).
#[test]
fn plate_with_micro_descent_matches_azimuth_averaged_micro_brdf() {
    let dir = scratch("plate-micro");
    std::fs::write(dir.join("micro.toml"), MICRO).unwrap();
    let n_obj = 1_000_000;
    let sc = scene(
        "plate",
        &plate(r#"micro = "micro.toml""#, &[40.0], n_obj),
        &dir,
    );
    let r = &run(&sc)[0];
    let t = &r.tallies;
    assert_eq!(t.photons, n_obj);
    assert_eq!(t.unmodelled.0, 0, "photons hit a side of the plate");
    assert_eq!(t.missed, 0.0, "the beam lies on the top face");
    assert_eq!(t.lost, 0.0);
    assert_eq!(t.bounces, n_obj, "one macro reflection per photon");
    let grid = sc.run.farfield_grid().grid;
    let half = grid.n_cells();
    for c in half..2 * half {
        assert_eq!(
            t.farfield.sum[c], 0.0,
            "light below the plate's horizon, cell {c}"
        );
    }
    let (refl, refl_se) = r.reflectance();

    // (a) The micro kernel with a uniform random light azimuth per photon.
    let micro = MicroScene::load(&dir.join("micro.toml")).unwrap();
    let n_mic = 1_000_000;
    let (m_refl, m_cells) = micro_rotation_averaged(&micro, 40.0, n_mic, &grid);
    let (mr, mr_se) = (m_refl.mean(0, n_mic), m_refl.stderr(0, n_mic));
    let sig = |a: f64, b: f64| a.hypot(b);
    assert_4sigma("reflectance vs micro kernel", refl, mr, sig(refl_se, mr_se));
    for c in 0..half {
        let (f, fe) = (t.farfield.mean(c, n_obj), t.farfield.stderr(c, n_obj));
        let (g, ge) = (m_cells.mean(c, n_mic), m_cells.stderr(c, n_mic));
        let (band, cell) = grid.band_cell(c);
        assert_4sigma(
            &format!("cell {c} (band {band}, cell {cell}) vs micro kernel"),
            f,
            g,
            sig(fe, ge),
        );
    }
    // The test has power: a single reflection would give 0.8; the bumps
    // make several, and the reflectance is far from both 0 and 0.8.
    assert!(refl > 0.3 && refl < 0.78, "{refl}");

    // (b) `roks brdf` (BrdfRun) at 24 light azimuths: reflectance and band totals.
    let k = 24;
    let per = 40_000;
    let mut run = micro.brdf_run();
    run.theta_deg = vec![40.0];
    run.photons = per;
    assert_eq!(run.bands, 4);
    let mut sum_r = 0.0;
    let mut var_r = 0.0;
    let mut bands = vec![(0.0, 0.0); grid.bands() + 1];
    for j in 0..k {
        run.phi_deg = roks::transport::brdf::Azimuths::one(360.0 * j as f64 / k as f64);
        run.seed = 100 + j as u64;
        let res = run.trace_whole(&micro.surface, &|_| {}).into_leaves();
        let (rr, rs) = res[0].reflectance();
        sum_r += rr;
        var_r += rs * rs;
        for (band, acc) in bands.iter_mut().enumerate().skip(1) {
            let (m, s) = merged(&res[0].tallies.carlson, band_cells(&grid, band), per);
            acc.0 += m;
            acc.1 += s * s;
        }
    }
    let kf = k as f64;
    assert_4sigma(
        "reflectance vs roks brdf averaged over phi_i",
        refl,
        sum_r / kf,
        sig(refl_se, var_r.sqrt() / kf),
    );
    for (band, (sum, var)) in bands.iter().enumerate().skip(1) {
        let (f, fe) = merged(&t.farfield, band_cells(&grid, band), n_obj);
        assert_4sigma(
            &format!("band {band} vs roks brdf averaged over phi_i"),
            f,
            sum / kf,
            sig(fe, var.sqrt() / kf),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// One row of brdf.csv: (theta_i, band, cell, fraction, fraction_stderr).
fn read_table(path: &Path) -> Vec<(f64, usize, usize, f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
                f[12].parse().unwrap(),
                f[13].parse().unwrap(),
            )
        })
        .collect()
}

/// The `brdf` table model: a table written by the `roks brdf` binary
/// (theta_i 0..80 step 10, bands 4, summary.json beside it) on the plate.
/// At theta_i = 40 (tabulated) every photon's weight becomes R(40): the
/// plate's reflectance equals the table's exactly (zero variance), and so
/// agrees with `roks brdf`'s summary reflectance within its stated error;
/// each far-field cell expects the table's fraction (4 sigma of the trace),
/// empty table cells stay empty. At 45 degrees the expectation is the mean
/// of the 40 and 50 degree tables (linear interpolation), reflectance and
/// cells within 4 sigma.
#[test]
fn plate_with_brdf_table_reproduces_the_table() {
    let dir = scratch("plate-table");
    std::fs::write(dir.join("micro.toml"), MICRO).unwrap();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .arg("brdf")
        .arg(dir.join("micro.toml"))
        .arg("--out")
        .arg(&out)
        .args(["--theta", "0,10,20,30,40,50,60,70,80"])
        .args(["--photons", "100000", "--stats-resolution", "32", "-q"])
        .output()
        .expect("run roks brdf");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = read_table(&out.join("brdf.csv"));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let inc = summary["incidence"].as_array().unwrap();
    let at = |theta: f64| -> Vec<(usize, usize, f64, f64)> {
        table
            .iter()
            .filter(|r| r.0 == theta)
            .map(|r| (r.1, r.2, r.3, r.4))
            .collect()
    };
    let summary_r = |theta: f64| {
        let e = inc
            .iter()
            .find(|e| e["theta_deg"].as_f64() == Some(theta))
            .unwrap();
        (
            e["reflectance"].as_f64().unwrap(),
            e["reflectance_stderr"].as_f64().unwrap(),
        )
    };
    let (t40, t50) = (at(40.0), at(50.0));
    let grid = CarlsonGrid::new(4).unwrap();
    assert_eq!(t40.len(), grid.n_cells());
    assert_eq!(t50.len(), grid.n_cells());
    let r40: f64 = t40.iter().map(|r| r.2).sum();
    let r50: f64 = t50.iter().map(|r| r.2).sum();

    let n_obj = 500_000;
    let sc = scene(
        "plate-table",
        &plate(r#"brdf = "out/brdf.csv""#, &[40.0, 45.0], n_obj),
        &dir,
    );
    let results = run(&sc);
    assert_eq!(results.len(), 2);
    for r in &results {
        assert_eq!(r.tallies.unmodelled.0, 0);
        assert_eq!(r.tallies.missed, 0.0);
        assert_eq!(r.tallies.lost, 0.0);
        assert_eq!(r.tallies.bounces, n_obj);
        for c in grid.n_cells()..2 * grid.n_cells() {
            assert_eq!(r.tallies.farfield.sum[c], 0.0, "cell {c} below the horizon");
        }
    }

    // theta_i = 40: exact reflectance.
    let (refl, se) = results[0].reflectance();
    assert!(
        (refl - r40).abs() <= 1e-9 * r40,
        "plate reflectance {refl} vs table R(40) {r40}"
    );
    assert!(se <= 1e-9 * refl, "every photon carries R(40): stderr {se}");
    let (sr, sse) = summary_r(40.0);
    assert_4sigma("reflectance vs roks brdf summary", refl, sr, se.hypot(sse));
    let t = &results[0].tallies;
    for (c, &(band, cell, frac, _)) in t40.iter().enumerate() {
        assert_eq!(grid.index(band, cell), c);
        let (f, fe) = (t.farfield.mean(c, n_obj), t.farfield.stderr(c, n_obj));
        if frac == 0.0 {
            assert_eq!(f, 0.0, "40 deg: cell {c} is empty in the table");
        } else {
            assert_4sigma(
                &format!("40 deg: cell {c} (band {band}, cell {cell})"),
                f,
                frac,
                fe,
            );
        }
    }

    // theta_i = 45: the mean of the 40 and 50 degree tables.
    let (refl, se) = results[1].reflectance();
    assert!(se > 0.0);
    assert_4sigma("45 deg reflectance", refl, 0.5 * (r40 + r50), se);
    let t = &results[1].tallies;
    for c in 0..grid.n_cells() {
        let want = 0.5 * (t40[c].2 + t50[c].2);
        let (f, fe) = (t.farfield.mean(c, n_obj), t.farfield.stderr(c, n_obj));
        if want == 0.0 {
            assert_eq!(f, 0.0, "45 deg: cell {c}");
        } else {
            assert_4sigma(&format!("45 deg: cell {c}"), f, want, fe);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
