//! `[tally] symmetry = "mirror"`: every escaping photon scored half in its
//! own direction and half in its mirror image in the plane of incidence.
//!
//! * Same photons, folded and not (azimuth 0, where the Carlson grid is
//!   itself mirror symmetric): every cell holds exactly the mean of itself
//!   and its mirror cell (the two cells per band straddling the plane keep
//!   their own); the reflectance and the in-plane tally do not change.
//! * A mirror-symmetric surface (one bump at the centre of the cell): the
//!   folded and unfolded BRDFs agree statistically, and the folded standard
//!   error is 1/sqrt(2) of the unfolded one off the plane (the cell collects
//!   its mirror cell's photons too).

mod common;

use glam::DVec3;
use roks::tally::{CarlsonGrid, Symmetry, symmetry};
use roks::transport::brdf::IncidenceResult;
use roks::transport::launch::Launch;

fn run(toml: &str, fold: Symmetry, launch: Launch, seed: u64) -> Vec<IncidenceResult> {
    let scene = common::scene("symmetry", toml);
    let mut run = common::brdf_run(&scene);
    run.symmetry = fold;
    run.launch = launch;
    run.seed = seed;
    run.trace_whole(&scene.surface, &|_| {}).into_leaves()
}

/// The mirror cell of every cell at azimuth 0 (from the cell centres).
fn mirror_cells(grid: &CarlsonGrid) -> Vec<usize> {
    (0..grid.n_cells())
        .map(|flat| {
            let (band, cell) = grid.band_cell(flat);
            let (theta, phi) = grid.centre(band, cell);
            let d = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            grid.locate(symmetry::mirror(d, 0.0))
                .expect("an upward direction")
        })
        .collect()
}

#[test]
fn folding_the_same_photons_averages_mirror_cells() {
    let toml = roks::scene::micro::DEFAULT_SCENE
        .replace("photons = 1000000", "photons = 40000")
        .replace(
            "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
            "theta_deg = [0, 45, 80]",
        );
    let grid = CarlsonGrid::new(32).unwrap();
    let mirror = mirror_cells(&grid);
    for launch in [Launch::Random, Launch::Lattice] {
        let plain = run(&toml, Symmetry::None, launch, 4);
        let folded = run(&toml, Symmetry::Mirror, launch, 4);
        for (p, f) in plain.iter().zip(&folded) {
            let what = format!("{launch:?} theta {}", p.theta_i_deg);
            assert_eq!(p.tallies.reflected, f.tallies.reflected, "{what}");
            assert_eq!(p.tallies.inplane, f.tallies.inplane, "{what}");
            assert_eq!(p.tallies.by_bounces, f.tallies.by_bounces, "{what}");
            let (u, v) = (&p.tallies.carlson.sum, &f.tallies.carlson.sum);
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0);
            for c in 0..grid.n_cells() {
                let m = mirror[c];
                assert_eq!(mirror[m], c, "mirror of the mirror");
                // On the plane (cells 0 and 2j of band j straddle it) m = c
                // and the cell keeps its own photons.
                assert!(
                    close(v[c], 0.5 * (u[c] + u[m])),
                    "{what}: cell {c}: {} vs ({} + {}) / 2",
                    v[c],
                    u[c],
                    u[m]
                );
            }
            let on_plane = (0..grid.n_cells()).filter(|&c| mirror[c] == c).count();
            assert_eq!(on_plane, 2 * 32, "{what}: two cells per band on the plane");
        }
    }
}

#[test]
fn symmetric_surface_same_brdf_and_half_the_variance() {
    // One half-ellipsoid bump at the centre of a 10 x 10 cell: the geometry
    // is its own mirror image in y (the plane of incidence at azimuth 0).
    let toml = r#"
[surface]
size = [10.0, 10.0]
material = "paint"

[materials.paint]
reflectance = 0.8

[quadrics]
bump = { ellipsoid = { center = [5.0, 5.0, 0.0], semi_axes = [3.0, 3.0, 2.0] } }

[[bodies]]
region = "-bump"

[light]
theta_deg = [40.0]
photons = 400000

[tally]
bands = 8
"#;
    let plain = run(toml, Symmetry::None, Launch::Random, 1).remove(0);
    let folded = run(toml, Symmetry::Mirror, Launch::Random, 2).remove(0);
    let n = plain.tallies.photons;
    let grid = CarlsonGrid::new(8).unwrap();
    let mirror = mirror_cells(&grid);
    let (mut chi2, mut dof, mut ratios) = (0.0, 0_usize, Vec::new());
    for (c, &m) in mirror.iter().enumerate() {
        // Cells with at least 400 photons' worth.
        if plain.tallies.carlson.sum[c] < 400.0 {
            continue;
        }
        let (sp, sf) = (plain.carlson_stderr(c), folded.carlson_stderr(c));
        let d = plain.tallies.carlson.mean(c, n) - folded.tallies.carlson.mean(c, n);
        chi2 += d * d / (sp * sp + sf * sf);
        dof += 1;
        if m != c {
            ratios.push(sf / sp);
        }
    }
    assert!(
        dof > 40 && ratios.len() > 20,
        "{dof} cells, {} off the plane",
        ratios.len()
    );
    // chi²/dof below its p = 1e-4 point (Wilson–Hilferty).
    let k = dof as f64;
    let a = 2.0 / (9.0 * k);
    let limit = (1.0 - a + 3.72 * a.sqrt()).powi(3);
    assert!(chi2 / k < limit, "chi²/dof {} over {dof} cells", chi2 / k);
    // Median standard-error ratio: 1/sqrt(2) = 0.707 for a symmetric BRDF
    // (each cell's estimate has a relative error of a few % at >= 400 photons).
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    assert!(
        (median - std::f64::consts::FRAC_1_SQRT_2).abs() < 0.05,
        "median folded / plain standard error {median}"
    );
}
