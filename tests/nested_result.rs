//! The one transport entry point of the micro level returns its result
//! nested as incidence x light azimuth x wavelength, each leaf with its
//! batch-tree nodes. Its leaves are, bit for bit, those the earlier flat
//! entry points gave (`BrdfRun::run_shard_one` and the sums of its nodes,
//! one list per incidence and wavelength, commit 163b90e): the SHA-256 of
//! each leaf's sums and nodes (as `tallies.json` writes them, exact floats)
//! is recorded in `tests/golden/nested_leaves.txt`, for a monochrome run, a
//! spectral run, a polarised lattice run with mirror symmetry, and a shard.
//!
//! Rerun with `ROKS_BLESS=1 cargo test --test nested_result` only when a
//! change of physics moves the sums on purpose (tests/golden.rs moves then too).

use std::fmt::Write as _;

use roks::scene::SceneFile;
use roks::scene::micro::{DEFAULT_SCENE, MicroScene};
use roks::tally::PolarTally;
use roks::tally::sum::BATCH;
use roks::transport::brdf::{BrdfRun, BrdfTallies, ShardRange};
use roks::transport::launch::Launch;
use sha2::{Digest, Sha256};

const FIXTURE: &str = "tests/golden/nested_leaves.txt";

fn scene(text: &str) -> MicroScene {
    let scene_file = SceneFile {
        file: "t.toml".into(),
        dir: ".".into(),
    };
    MicroScene::from_str(text, scene_file, "t".into()).unwrap()
}

/// The cases: name, scene, run.
fn cases() -> Vec<(&'static str, MicroScene, BrdfRun)> {
    let plain = scene(DEFAULT_SCENE);
    let mut mono = plain.brdf_run();
    mono.photons = 3 * BATCH + 100;
    mono.theta_deg = vec![30.0, 70.0];
    mono.bands = 3;
    let mut spectral = mono.clone();
    spectral.wavelengths_um = vec![0.4, 0.5, 0.6];
    let al = scene(&DEFAULT_SCENE.replace("reflectance = 0.8", "n = 1.015\nk = 6.627"));
    let mut polar = al.brdf_run();
    polar.photons = 2 * BATCH + 16 * 7;
    polar.theta_deg = vec![0.0, 60.0];
    polar.bands = 3;
    polar.launch = Launch::Lattice;
    polar.symmetry = roks::tally::Symmetry::Mirror;
    polar.polarisation.transport = true;
    polar.polarisation.tally = PolarTally::Stokes;
    let mut shard = mono.clone();
    shard.photons = 5 * BATCH + 100;
    shard.shard = Some(ShardRange {
        count: 3,
        first_photon: 2 * BATCH,
        index: 1,
        last_photon: 4 * BATCH,
    });
    let scene2 = || scene(DEFAULT_SCENE);
    vec![
        ("mono", scene2(), mono),
        ("spectral", scene2(), spectral),
        ("polar", al, polar),
        ("shard", plain, shard),
    ]
}

/// The hash of one leaf: its sums and nodes as `tallies.json` writes them
/// (intersection-test counts zeroed: they measure the acceleration
/// structure, not the physics, as in tests/golden.rs).
fn digest(tallies: &BrdfTallies, nodes: &[(u32, u64, &BrdfTallies)]) -> String {
    let text = |t: &BrdfTallies| {
        let mut t = t.clone();
        t.intersection_tests = 0;
        serde_json::to_string(&t).unwrap()
    };
    let mut h = Sha256::new();
    h.update(text(tallies));
    for (level, index, value) in nodes {
        h.update(format!("|{level},{index},"));
        h.update(text(value));
    }
    h.finalize().iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// Lines `case incidence azimuth wavelength theta phi wavelength_um hash`,
/// one per leaf, from the nested result's indices.
fn lines() -> String {
    let mut out = String::new();
    for (name, scene, run) in cases() {
        let result = run.trace(&scene.surface, run.photon_range(), &|_| {});
        assert_eq!(result.incidence.len(), run.theta_deg.len());
        for (i, by_incidence) in result.incidence.iter().enumerate() {
            assert_eq!(by_incidence.azimuth.len(), 1, "one light azimuth");
            for (a, by_azimuth) in by_incidence.azimuth.iter().enumerate() {
                assert_eq!(by_azimuth.wavelength.len(), run.lane_count());
                for (l, leaf) in by_azimuth.wavelength.iter().enumerate() {
                    assert!(std::ptr::eq(leaf, result.leaf(i, a, l)));
                    // The root of a whole run is its sums, kept once.
                    let tree = leaf.tree_nodes(&run);
                    let nodes: Vec<_> = tree.iter().map(|n| (n.level, n.index, &n.value)).collect();
                    let _ = writeln!(
                        out,
                        "{name} {i} {a} {l} {} {} {:?} {}",
                        leaf.theta_i_deg,
                        leaf.phi_i_deg,
                        leaf.wavelength_um,
                        digest(&leaf.tallies, &nodes)
                    );
                }
            }
        }
    }
    out
}

#[test]
fn nested_leaves_are_the_flat_entry_points_sums() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE);
    let got = lines();
    if std::env::var_os("ROKS_BLESS").is_some() {
        std::fs::write(&path, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap();
    assert_eq!(got, want, "leaves differ from {FIXTURE}");
}
