//! `roks trace --shard I/N` + `roks merge` reproduce the single run of an
//! object scene exactly: every file of the folder byte for byte (tables and
//! pictures), `summary.json` equal but for its timings, for N = 1, 2, 3 and
//! an uneven split, on another thread count than the single run: a
//! polarised beam sweep with a Stokes far field, and a spectral run (a
//! measured n, k table) with Stokes sums. And the merge refuses shards of
//! another run (naming the first field that differs, the content of a file
//! the scene reads included), missing and repeated shards, and tampered
//! sums, with one line naming the file and the key.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::Output;

use cli_common::{names, read, roks, summary_without_timing};

/// An open cylindrical cavity: Fresnel side wall (polarising), a
/// specular + Lambertian floor and rim. `{sources}` and `{extra}` are
/// filled in by the cases.
const CAVITY: &str = r#"
name = "cav"
[quadrics]
wall  = { cylinder_z = { r = 5.0 } }
front = { plane = [0.0, 0.0, 1.0, 0.0] }
bottom = { plane = [0.0, 0.0, 1.0, -10.0] }
outer = { cylinder_z = { r = 6.0 } }
under = { plane = [0.0, 0.0, 1.0, -11.0] }
[[cells]]
name = "cavity"
region = "-wall -front +bottom"
fill = "void"
[[cells]]
name = "body"
region = "-outer -front +under ~(-wall -front +bottom)"
fill = "solid"
[walls]
wall = "metal"
bottom = "paint"
front = "paint"
[models.paint]
specular = 0.2
diffuse = 0.5
[tally]
bands = 6
farfield = true
polarisation = "stokes"
"#;

/// A polarised sweep of three positions of 9000 photons (3 batches each,
/// the last partial) and a single unpolarised position of 20000 (5
/// batches: a tree that is not a left fold): 14 batches in all.
const SWEEP: &str = r#"
[models.metal]
n = 1.5
k = 3.0
[[sources]]
beam = { direction = [0.3, 0.0, -1.0], diameter = 2.0 }
sweep = { from = [0.0, 0.0, 2.0], to = [3.0, 0.0, 2.0], steps = 3 }
photons = 9000
polarisation = "s"
[[sources]]
beam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }
position = [1.0, 1.0, 3.0]
photons = 20000
"#;

/// Three wavelengths of a measured n, k table, polarised: one position of
/// 20000 photons (5 batches) and one of 5000 (2 batches).
const SPECTRAL: &str = r#"
[models.metal]
nk = "gold.csv"
[light]
wavelengths_um = [0.45, 0.55, 0.65]
[[sources]]
beam = { direction = [0.0, 0.2, -1.0], diameter = 3.0 }
position = [0.5, 0.0, 1.0]
photons = 20000
polarisation = { linear = 30.0 }
[[sources]]
beam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }
position = [-1.0, 0.0, 1.0]
photons = 5000
"#;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-object-shards-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The cavity scene with `sources` written to `dir/cav.toml` (and the gold
/// n, k table beside it).
fn scene(dir: &Path, sources: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(root.join("scenes/materials/gold.csv"), dir.join("gold.csv")).unwrap();
    let path = dir.join("cav.toml");
    std::fs::write(&path, format!("{CAVITY}{sources}")).unwrap();
    path
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn trace(scene: &Path, out: &Path, threads: &str, shard: Option<String>) -> Output {
    let (scene, out) = (scene.display().to_string(), out.display().to_string());
    let mut args = vec![
        "trace",
        "-q",
        &scene,
        "--seed",
        "7",
        "--threads",
        threads,
        "--out",
        &out,
    ];
    let shard = shard.unwrap_or_default();
    if !shard.is_empty() {
        args.extend(["--shard", &shard]);
    }
    roks(&args)
}

fn merge(dirs: &[PathBuf], out: &Path) -> Output {
    let mut args: Vec<String> = vec!["merge".into(), "-q".into()];
    args.extend(dirs.iter().map(|d| d.display().to_string()));
    args.extend(["--out".into(), out.display().to_string()]);
    roks(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// The shard folders of `scene` split in `n` (on one thread each).
fn shards(scene: &Path, root: &Path, n: u32) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let d = root.join(format!("n{n}-s{i}"));
            ok(&trace(scene, &d, "1", Some(format!("{i}/{n}"))));
            d
        })
        .collect()
}

/// Merge `n` shards (given in reverse) and compare with the single run
/// `full`: the same files, byte for byte but summary.json's timings.
fn assert_merge_equals(scene: &Path, root: &Path, full: &Path, n: u32) {
    let mut dirs = shards(scene, root, n);
    dirs.reverse();
    let merged = root.join(format!("n{n}-merged"));
    ok(&merge(&dirs, &merged));
    assert_eq!(names(full), names(&merged), "{n} shards");
    // The record names the writer: trace there, merge here.
    for f in names(full)
        .iter()
        .filter(|f| *f != "summary.json" && *f != ".roks-files.json")
    {
        assert!(read(full, f) == read(&merged, f), "{n} shards: {f} differs");
    }
    assert_eq!(
        summary_without_timing(full),
        summary_without_timing(&merged),
        "{n} shards"
    );
}

fn check_case(name: &str, sources: &str, expect_files: &[&str]) {
    let root = scratch(name);
    let scene = scene(&root, sources);
    let full = root.join("full");
    ok(&trace(&scene, &full, "2", None));
    for f in expect_files {
        assert!(full.join(f).is_file(), "{name}: no {f}");
    }
    // 14 (sweep) or 7 (spectral) batches in all: 1, 2, 3 and an uneven 5.
    for n in [1, 2, 3, 5] {
        assert_merge_equals(&scene, &root, &full, n);
    }
    std::fs::remove_dir_all(&root).ok();
}

#[test]
fn polarised_sweep_with_stokes_far_field_merges_exactly() {
    check_case(
        "sweep",
        SWEEP,
        &[
            "reflectance.csv",
            "farfield.csv",
            "farfield_stokes.csv",
            "reflectance.png",
        ],
    );
}

#[test]
fn spectral_polarised_run_merges_exactly() {
    check_case(
        "spectral",
        SPECTRAL,
        &["reflectance.csv", "farfield.csv", "farfield_stokes.csv"],
    );
}

/// A one-line input error (exit 2) naming `file` and containing `expect`.
fn assert_error(o: &Output, file: &str, expect: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let line = err.trim_end_matches('\n');
    assert!(!line.contains('\n'), "not one line: {err:?}");
    assert!(line.contains(file), "no `{file}` in {line:?}");
    assert!(line.contains(expect), "no `{expect}` in {line:?}");
}

#[test]
fn merge_refuses_shards_of_other_runs_gaps_repeats_and_tampering() {
    let root = scratch("refuse");
    let scene = scene(&root, SPECTRAL);
    let dirs = shards(&scene, &root, 3);
    let out = root.join("out");
    let shown = |d: &Path| d.join("tallies.json").display().to_string();

    // Another seed: named as the first field that differs.
    let seed = root.join("seed");
    let (s, o) = (scene.display().to_string(), seed.display().to_string());
    ok(&roks(&[
        "trace", "-q", &s, "--seed", "8", "--shard", "1/3", "--out", &o,
    ]));
    let o = merge(&[dirs[0].clone(), seed.clone(), dirs[2].clone()], &out);
    assert_error(&o, &shown(&seed), "description.run.seed");

    // The n, k table edited between shards: the content identity differs.
    let edited = root.join("edited");
    std::fs::create_dir_all(&edited).unwrap();
    let table = std::fs::read_to_string(root.join("gold.csv")).unwrap();
    std::fs::write(edited.join("gold.csv"), format!("{table}\n")).unwrap();
    std::fs::write(edited.join("cav.toml"), std::fs::read(&scene).unwrap()).unwrap();
    let other = root.join("other");
    ok(&trace(
        &edited.join("cav.toml"),
        &other,
        "1",
        Some("1/3".into()),
    ));
    let o = merge(&[dirs[0].clone(), other.clone(), dirs[2].clone()], &out);
    assert_error(
        &o,
        &shown(&other),
        "description.content.files.models.metal.nk",
    );
    // The same content under another path merges.
    let moved = root.join("moved");
    std::fs::create_dir_all(&moved).unwrap();
    std::fs::copy(root.join("gold.csv"), moved.join("gold.csv")).unwrap();
    std::fs::copy(&scene, moved.join("cav.toml")).unwrap();
    let same = root.join("same");
    ok(&trace(
        &moved.join("cav.toml"),
        &same,
        "1",
        Some("1/3".into()),
    ));
    ok(&merge(
        &[dirs[0].clone(), same, dirs[2].clone()],
        &root.join("same-merged"),
    ));

    // A missing shard, a repeated one, shards of another split.
    let o = merge(&[dirs[0].clone(), dirs[2].clone()], &out);
    assert_error(&o, "tallies.json", "missing: 1");
    let o = merge(&[dirs[0].clone(), dirs[1].clone(), dirs[1].clone()], &out);
    assert_error(&o, &shown(&dirs[1]), "given twice");
    let half = shards(&scene, &root, 2);
    let o = merge(&[dirs[0].clone(), half[1].clone(), dirs[2].clone()], &out);
    assert_error(&o, &shown(&half[1]), "description.shard.count");

    // Tampered sums: a NaN, and one photon too many.
    let text = std::fs::read_to_string(dirs[1].join("tallies.json")).unwrap();
    let bad = root.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    let (from, to) = (
        "\"reflected\":{\"sum\":[\"",
        "\"reflected\":{\"sum\":[\"NaN\",\"",
    );
    assert!(text.contains(from));
    std::fs::write(bad.join("tallies.json"), text.replacen(from, to, 1)).unwrap();
    let o = merge(&[dirs[0].clone(), bad.clone(), dirs[2].clone()], &out);
    assert_error(&o, &shown(&bad), "positions[0].nodes[0].tallies");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let p = v["positions"][0]["nodes"][0]["tallies"]["photons"]
        .as_u64()
        .unwrap();
    let swapped = text.replacen(
        &format!("\"photons\":{p},\"reflected\""),
        &format!("\"photons\":{},\"reflected\"", p + 1),
        1,
    );
    assert_ne!(swapped, text);
    std::fs::write(bad.join("tallies.json"), swapped).unwrap();
    let o = merge(&[dirs[0].clone(), bad.clone(), dirs[2].clone()], &out);
    assert_error(&o, &shown(&bad), "positions[0].nodes[0].tallies.photons");
    // A node index at the end of u64: refused, no overflow.
    let mut far = v.clone();
    far["positions"][0]["nodes"][0]["index"] = u64::MAX.into();
    std::fs::write(bad.join("tallies.json"), far.to_string()).unwrap();
    let o = merge(&[dirs[0].clone(), bad.clone(), dirs[2].clone()], &out);
    assert_error(&o, &shown(&bad), "positions[0].nodes[0]: tree node");
    assert!(!out.exists(), "a refused merge wrote {}", out.display());
    std::fs::remove_dir_all(&root).ok();
}

#[test]
fn more_shards_than_batches_are_refused_before_any_work() {
    let root = scratch("count");
    let scene = scene(&root, SPECTRAL); // 7 batches
    let out = root.join("out");
    let o = trace(&scene, &out, "1", Some("0/8".into()));
    assert_error(&o, "--shard", "8 shards but only 7 batches");
    assert!(!out.exists());
    ok(&trace(&scene, &out, "1", Some("6/7".into())));
    std::fs::remove_dir_all(&root).ok();
}
