//! Benchmarks of the macro level (`cargo bench --bench macro_level`).
//!
//! * `macro/baffled_tube_{10,100,1000}`: `roks trace` of the baffled tubes
//!   of `scenes/` (a tube with 10, 100, 1000 annular vanes), one beam
//!   position, one thread. The macro segments per photon are printed once,
//!   so the criterion time converts to time per macro segment, the figure
//!   that must stay within 2x from 10 to 1000 zones.
//! * `macro/radiator_micro`: the biconical radiator with micro walls (a
//!   descent into the Z-302 geometry at every hit), one beam position, one
//!   thread; throughput in photons.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use roks::scene::object::ObjectScene;
use std::hint::black_box;
use std::path::Path;

/// Photons of beam 0 of `scene`, traced on one thread.
fn trace(scene: &ObjectScene, photons: u64) -> (u64, u64) {
    let results = scene.run.trace(
        &scene.object,
        &scene.walls,
        &scene.models,
        &scene.beams[..1],
        &[photons],
        &|_| {},
    );
    let t = &results.leaf(0, 0).tallies;
    (t.photons, t.segments)
}

fn objects(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let mut g = c.benchmark_group("macro");
    g.sample_size(10);
    for (name, file, photons) in [
        ("baffled_tube_10", "scenes/baffled-tube-10.toml", 4096),
        ("baffled_tube_100", "scenes/baffled-tube-100.toml", 4096),
        ("baffled_tube_1000", "scenes/baffled-tube-1000.toml", 4096),
        ("radiator_micro", "scenes/radiator.toml", 4096),
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
        let scene = ObjectScene::load(&path).expect("a shipped scene");
        let (n, segments) = pool.install(|| trace(&scene, photons));
        eprintln!(
            "{name}: {:.3} macro segments per photon",
            segments as f64 / n as f64
        );
        g.throughput(Throughput::Elements(photons));
        g.bench_function(name, |b| {
            b.iter(|| pool.install(|| black_box(trace(&scene, photons))));
        });
    }
    g.finish();
}

criterion_group!(benches, objects);
criterion_main!(benches);
