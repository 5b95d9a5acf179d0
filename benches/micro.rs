//! Benchmarks of the micro level (`cargo bench`).
//!
//! * `brdf/default_60deg`: photons of the embedded default scene (100
//!   overlapping ellipsoids, rho = 0.8) at 60 degrees incidence, the
//!   figure docs/src/performance.md quotes. Throughput is in photons; the number of
//!   straight flights per photon is printed once so the criterion time
//!   converts to segments per second.
//! * `entry/*`: one ray-body entry test, single quadric vs CSG body.
//! * `polarisation/{scalar,stokes,stokes_tally,mueller_tally}`: the default
//!   scene's geometry with aluminium walls (Fresnel, n = 1.015 + 6.627i) at
//!   60 degrees: the unpolarised weight against a Stokes vector through
//!   every bounce, with and without the Stokes tally, and the Mueller
//!   columns with the Mueller tally (segments per photon printed for each:
//!   compare the time per segment).
//! * `spectral/{mono_scalar,w32_scalar,mono_stokes,w32_stokes}`: the
//!   default scene's geometry with aluminium walls from
//!   `scenes/materials/aluminium.csv` at 60 degrees, one thread: a
//!   monochrome run at 0.55 um against one trace carrying 32 wavelengths
//!   (0.40-0.71 um), scalar weight and Stokes vectors (the same paths, so
//!   the time ratio is the ratio per segment; 200 000 photons per run, so
//!   that the start and end of a run, which allocate and merge 32 tallies,
//!   weigh little).
//! * `heightfield/gaussian_{256,1024}_60deg`: photons of `scenes/gaussian.toml`
//!   (a Gaussian height field of Al, sigma 1, tau 11.9 on 64 x 64) at 60
//!   degrees on 256² and 1024² grids (segments per photon printed once).
//! * `scaling/{bumps_100,bumps_100000,field_256,field_4096}`: one thread,
//!   60 degrees, the scenes of `scripts/scaling.py` (the default scene's
//!   ellipsoids at constant density on a cell of side 3 sqrt(N); Gaussian
//!   fields of sigma 1, tau 8 pitches, pitch 0.25): the rate per thread of
//!   100 000 bumps against 100, and of a 4096² field against 256²
//!   (segments per photon printed once for each); `bumps_r60`: the 100
//!   bumps of `bumps_100` with radius 60, two periods wide (the bump-size
//!   rows of `scripts/scaling.py`), against `bumps_100`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use roks::geometry::body::{Aabb, Body, Ray};
use roks::geometry::quadric::Quadric;
use roks::geometry::region;
use roks::scene::micro::MicroScene;
use std::hint::black_box;

/// The run traced at 60 degrees incidence only: every wavelength's leaf.
fn at_60_all(
    run: &roks::transport::brdf::BrdfRun,
    surface: &roks::micro::MicroSurface,
) -> roks::transport::brdf::BrdfResult {
    let mut run = run.clone();
    run.theta_deg = vec![60.0];
    run.trace_whole(surface, &|_| {})
}

/// The run traced at 60 degrees incidence only: the first wavelength's leaf.
fn at_60(
    run: &roks::transport::brdf::BrdfRun,
    surface: &roks::micro::MicroSurface,
) -> roks::transport::brdf::IncidenceResult {
    at_60_all(run, surface).into_leaves().swap_remove(0)
}

/// The scene's run with 20 000 photons, after printing its segments per photon at 60 degrees.
fn probe_run(scene: &MicroScene, label: &str) -> roks::transport::brdf::BrdfRun {
    let mut run = scene.brdf_run();
    run.photons = 20_000;
    let probe = at_60(&run, &scene.surface);
    eprintln!(
        "{label}, 60 deg: {:.3} segments per photon",
        probe.tallies.segments as f64 / probe.tallies.photons as f64
    );
    run
}

fn brdf(c: &mut Criterion) {
    let scene = MicroScene::default_scene();
    let run = probe_run(&scene, "default scene");
    let mut g = c.benchmark_group("brdf");
    g.sample_size(20);
    g.throughput(Throughput::Elements(run.photons));
    g.bench_function("default_60deg", |b| {
        b.iter(|| black_box(at_60(&run, &scene.surface)));
    });
    g.finish();
}

fn entry(c: &mut Criterion) {
    let e = Quadric::ellipsoid(DVec3::new(0.3, -0.2, 0.0), DVec3::new(3.0, 2.5, 2.0));
    let names = ["a", "b", "c"];
    let single = Body::new(
        vec![e],
        region::parse("-a", |n| names.iter().position(|m| *m == n)).unwrap(),
        Aabb::EVERYTHING,
        0,
    );
    let csg = Body::new(
        vec![e, Quadric::plane_z(1.0), Quadric::plane_z(-5.0)],
        region::parse("-a -b +c", |n| names.iter().position(|m| *m == n)).unwrap(),
        Aabb::EVERYTHING,
        0,
    );
    let rays: Vec<Ray> = (0..256)
        .map(|k| {
            let a = k as f64 * 0.37;
            let o = DVec3::new(4.0 * a.cos(), 4.0 * a.sin(), 3.0);
            Ray::new(o, (DVec3::new(0.2 * a.sin(), 0.1, 0.0) - o).normalize())
        })
        .collect();
    let mut g = c.benchmark_group("entry");
    g.throughput(Throughput::Elements(rays.len() as u64));
    for (name, body) in [("single_ellipsoid", &single), ("csg_3_surfaces", &csg)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                rays.iter()
                    .filter_map(|r| body.first_entry(black_box(r), 100.0, None))
                    .map(|e| e.t)
                    .sum::<f64>()
            });
        });
    }
    g.finish();
}

fn heightfield(c: &mut Criterion) {
    let text = include_str!("../scenes/gaussian.toml");
    let mut g = c.benchmark_group("heightfield");
    g.sample_size(10);
    for n in [256, 1024] {
        let scene_file = roks::scene::SceneFile {
            file: "gaussian.toml".into(),
            dir: ".".into(),
        };
        let scene_text = text.replace("resolution = 1024", &format!("resolution = {n}"));
        let scene = MicroScene::from_str(&scene_text, scene_file, "gaussian".into()).unwrap();
        let run = probe_run(&scene, &format!("gaussian {n}²"));
        g.throughput(Throughput::Elements(run.photons));
        g.bench_function(format!("gaussian_{n}_60deg"), |b| {
            b.iter(|| black_box(at_60(&run, &scene.surface)));
        });
    }
    g.finish();
}

fn polarisation(c: &mut Criterion) {
    use roks::tally::PolarTally;
    use roks::transport::brdf::Polarisation;
    let text =
        roks::scene::micro::DEFAULT_SCENE.replace("reflectance = 0.8", "n = 1.015\nk = 6.627");
    let scene_file = roks::scene::SceneFile {
        file: "default.toml".into(),
        dir: ".".into(),
    };
    let scene = MicroScene::from_str(&text, scene_file, "default-al".into()).unwrap();
    let mut g = c.benchmark_group("polarisation");
    g.sample_size(20);
    for (name, transport, tally) in [
        ("scalar", false, PolarTally::None),
        ("stokes", true, PolarTally::None),
        ("stokes_tally", true, PolarTally::Stokes),
        ("mueller_tally", true, PolarTally::Mueller),
    ] {
        let mut run = scene.brdf_run();
        run.photons = 20_000;
        run.polarisation = Polarisation {
            transport,
            tally,
            ..run.polarisation
        };
        let probe = at_60(&run, &scene.surface);
        eprintln!(
            "default scene, Al, {name}, 60 deg: {:.4} segments per photon",
            probe.tallies.segments as f64 / probe.tallies.photons as f64
        );
        g.throughput(Throughput::Elements(run.photons));
        g.bench_function(name, |b| {
            b.iter(|| black_box(at_60(&run, &scene.surface)));
        });
    }
    g.finish();
}

fn spectral(c: &mut Criterion) {
    let al =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/materials/aluminium.csv");
    let mut g = c.benchmark_group("spectral");
    g.sample_size(10);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for (name, wavelengths, polarised) in [
        ("mono_scalar", "[0.55]", false),
        (
            "w32_scalar",
            "{ from = 0.40, to = 0.71, step = 0.01 }",
            false,
        ),
        ("mono_stokes", "[0.55]", true),
        (
            "w32_stokes",
            "{ from = 0.40, to = 0.71, step = 0.01 }",
            true,
        ),
    ] {
        let text = roks::scene::micro::DEFAULT_SCENE
            .replace(
                "reflectance = 0.8",
                &format!("nk = {:?}", al.display().to_string()),
            )
            .replace(
                "[light]",
                &format!("[light]\nwavelengths_um = {wavelengths}"),
            );
        let scene_file = roks::scene::SceneFile {
            file: "default.toml".into(),
            dir: ".".into(),
        };
        let mut scene = MicroScene::from_str(&text, scene_file, "default-al".into()).unwrap();
        if name.starts_with("mono") {
            // A true monochrome run: the index at 0.55 um, no wavelength lane.
            scene = MicroScene::from_str(
                &roks::scene::micro::DEFAULT_SCENE.replace(
                    "reflectance = 0.8",
                    &format!("n = {}\nk = {}", nk_at(&al, 0.55).0, nk_at(&al, 0.55).1),
                ),
                roks::scene::SceneFile {
                    file: "default.toml".into(),
                    dir: ".".into(),
                },
                "default-al".into(),
            )
            .unwrap();
        }
        let mut run = scene.brdf_run();
        run.photons = 200_000;
        run.polarisation.transport = polarised;
        g.throughput(Throughput::Elements(run.photons));
        g.bench_function(name, |b| {
            b.iter(|| pool.install(|| black_box(at_60_all(&run, &scene.surface))));
        });
    }
    g.finish();
}

/// n and k of a measured table at `um`.
fn nk_at(path: &std::path::Path, um: f64) -> (f64, f64) {
    let t = roks::optics::spectrum::NkSpectrum::read(path).unwrap();
    let nk = t.at(um).unwrap();
    (nk.n, nk.k)
}

/// `scripts/scaling.py`'s bump scene: N ellipsoids at constant density.
fn bump_scene(n: usize) -> String {
    let side = 3.0 * (n as f64).sqrt();
    format!(
        "name = \"bumps-{n}\"\n[surface]\nsize = [{side:?}, {side:?}]\nedges = \"periodic\"\n\
         material = \"paint\"\n[materials.paint]\nreflectance = 0.8\n[[bumps]]\nshape = \"ellipsoid\"\n\
         count = {n}\nradius = [2.5, 3.5]\nheight = [0.8, 4.8]\nseed = 1\n[light]\ntheta_deg = [60]\n"
    )
}

/// `scripts/scaling.py`'s height-field scene: an N² Gaussian field.
fn field_scene(n: usize) -> String {
    let side = 0.25 * n as f64;
    format!(
        "name = \"field-{n}\"\n[surface]\nsize = [{side:?}, {side:?}]\nedges = \"periodic\"\n\
         material = \"paint\"\nheightfield = {{ gaussian = {{ sigma = 1.0, tau = 2.0 }}, resolution = {n}, seed = 1 }}\n\
         [materials.paint]\nreflectance = 0.8\n[light]\ntheta_deg = [60]\n"
    )
}

fn scaling(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let mut g = c.benchmark_group("scaling");
    g.sample_size(10);
    for (name, text) in [
        ("bumps_100", bump_scene(100)),
        ("bumps_100000", bump_scene(100_000)),
        (
            "bumps_r60",
            bump_scene(100).replace("radius = [2.5, 3.5]", "radius = [60.0, 60.0]"),
        ),
        ("field_256", field_scene(256)),
        ("field_4096", field_scene(4096)),
    ] {
        let scene_file = roks::scene::SceneFile {
            file: format!("{name}.toml"),
            dir: ".".into(),
        };
        let scene = MicroScene::from_str(&text, scene_file, name.into()).unwrap();
        let mut run = pool.install(|| probe_run(&scene, name));
        // Enough photons per run for the Morton order of large surfaces to
        // find neighbours (the command line's regime, not a probe's).
        run.photons = 200_000;
        g.throughput(Throughput::Elements(run.photons));
        g.bench_function(name, |b| {
            b.iter(|| pool.install(|| black_box(at_60(&run, &scene.surface))));
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    brdf,
    entry,
    polarisation,
    spectral,
    heightfield,
    scaling
);
criterion_main!(benches);
