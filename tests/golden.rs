//! Outputs of fixed runs, byte for byte, against figures recorded with an
//! earlier binary (commit e3116b8): acceleration structures, photon order
//! and interleaving must not move a single bit of a result where the
//! arithmetic of a history is unchanged.
//!
//! Each case runs `roks brdf` or `roks trace` with a fixed seed on two
//! threads and hashes every result file (FNV-1a, 64 bits, with its length):
//! the CSV tables whole, `summary.json` without what measures the machine
//! rather than the physics (wall-clock `seconds`, `segments_per_second`,
//! the intersection-test counters `intersection_tests` and
//! `tests_per_segment`, which count the work an acceleration structure
//! does) and without the scene's path. PNGs are drawn from the same tables
//! and are not hashed. One case, `default_shards`, runs the default scene as
//! two shards (`--shard 0/2`, `--shard 1/2`) and merges them (`roks merge`):
//! it hashes the merged folder's tables, `summary.json` and `tallies.json`
//! and each shard's `tallies.json` (without `seconds`, the intersection-test
//! counters and the scene's path). The recorded hashes are in
//! `tests/golden/hashes.txt`.
//!
//! When a change of physics or of an exact formula moves results on
//! purpose, rerun with `ROKS_BLESS=1 cargo test --test golden` to record
//! the new hashes, and say in the commit which outputs moved and why.

mod cli_common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The recorded hashes: lines `case file length hash`.
const HASHES: &str = "tests/golden/hashes.txt";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// `summary.json` without the machine's figures and the scene path (see the module docs).
fn summary_physics(dir: &Path) -> Vec<u8> {
    fn strip(v: &mut Value) {
        match v {
            Value::Object(m) => {
                for key in [
                    "seconds",
                    "segments_per_second",
                    "intersection_tests",
                    "tests_per_segment",
                ] {
                    m.remove(key);
                }
                m.values_mut().for_each(strip);
            }
            Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut v: Value = serde_json::from_slice(&cli_common::read(dir, "summary.json")).unwrap();
    v.as_object_mut().unwrap().remove("scene");
    strip(&mut v);
    serde_json::to_vec_pretty(&v).unwrap()
}

/// A micro scene from `scenes/NAME.toml` with text replacements, written to `dir`.
fn micro_scene(dir: &Path, name: &str, edits: &[(&str, &str)]) -> String {
    let mut text = std::fs::read_to_string(root().join("scenes").join(format!("{name}.toml")))
        .unwrap_or_else(|e| panic!("scenes/{name}.toml: {e}"));
    for (from, to) in edits {
        assert!(text.contains(from), "scenes/{name}.toml has no `{from}`");
        text = text.replace(from, to);
    }
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path.to_string_lossy().into_owned()
}

/// The cases: name and the `roks` arguments (`{out}` is the output folder).
fn cases(dir: &Path) -> Vec<(&'static str, Vec<String>)> {
    let few_bands = [("bands = 32", "bands = 8")];
    let default = micro_scene(dir, "default", &few_bands);
    let al = {
        let path = dir.join("al.toml");
        let text = std::fs::read_to_string(&default)
            .unwrap()
            .replace("reflectance = 0.8", "n = 1.015\nk = 6.627");
        std::fs::write(
            &path,
            text.replace("[tally]", "[tally]\npolarisation = \"mueller\""),
        )
        .unwrap();
        path.to_string_lossy().into_owned()
    };
    let field = micro_scene(
        dir,
        "gaussian",
        &[("resolution = 1024", "resolution = 128")],
    );
    let reflecting = micro_scene(dir, "edge-30-reflecting", &[]);
    let absorbing = micro_scene(dir, "edge-30-absorbing", &[]);
    let z302 = micro_scene(dir, "z302-micro", &few_bands);
    let brdf = |scene: &str, extra: &[&str]| {
        let mut a: Vec<String> = [
            "brdf",
            scene,
            "--threads",
            "2",
            "-q",
            "--stats-resolution",
            "64",
        ]
        .iter()
        .map(|s| (*s).to_string())
        .collect();
        a.extend(extra.iter().map(|s| (*s).to_string()));
        a
    };
    let trace = |scene: &str, photons: &str| {
        ["trace", scene, "--photons", photons, "--threads", "2", "-q"]
            .iter()
            .map(|s| (*s).to_string())
            .collect::<Vec<_>>()
    };
    vec![
        (
            "default_random",
            brdf(&default, &["--theta", "0,30,60,85", "--photons", "20000"]),
        ),
        (
            "default_lattice_mirror",
            brdf(
                &default,
                &[
                    "--theta",
                    "30,60",
                    "--photons",
                    "20480",
                    "--launch",
                    "lattice",
                    "--symmetry",
                    "mirror",
                ],
            ),
        ),
        (
            "aluminium_mueller",
            brdf(&al, &["--theta", "45", "--photons", "10000"]),
        ),
        (
            "heightfield_128",
            brdf(&field, &["--theta", "30,60", "--photons", "20000"]),
        ),
        (
            "edges_reflecting",
            brdf(&reflecting, &["--theta", "60", "--photons", "10000"]),
        ),
        (
            "edges_absorbing",
            brdf(&absorbing, &["--theta", "80", "--photons", "10000"]),
        ),
        (
            "z302_csg",
            brdf(&z302, &["--theta", "30", "--photons", "5000"]),
        ),
        ("radiator_micro", trace("scenes/radiator.toml", "300")),
        (
            "cylinder_cavity",
            trace("scenes/cylinder-cavity.toml", "1000"),
        ),
        (
            "baffled_tube_100",
            trace("scenes/baffled-tube-100.toml", "2000"),
        ),
    ]
}

/// Run every case; `case -> file -> (length, hash)`. With `kernel`, the
/// `roks brdf` cases only, each with `--kernel KERNEL`.
fn measure(kernel: Option<&str>) -> BTreeMap<String, BTreeMap<String, (usize, u64)>> {
    let tmp = std::env::temp_dir().join(format!(
        "roks-golden-{}-{}",
        std::process::id(),
        kernel.unwrap_or("default")
    ));
    std::fs::create_dir_all(&tmp).unwrap();
    let mut got = BTreeMap::new();
    for (name, mut args) in cases(&tmp) {
        if let Some(k) = kernel {
            if args[0] != "brdf" {
                continue;
            }
            args.extend(["--kernel".to_string(), k.to_string()]);
        }
        let out = tmp.join(name);
        args.extend(["--out".to_string(), out.to_string_lossy().into_owned()]);
        let o = Command::new(env!("CARGO_BIN_EXE_roks"))
            .args(&args)
            .current_dir(root())
            .output()
            .expect("run roks");
        assert!(
            o.status.success(),
            "{name}: roks {args:?} failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let mut files = BTreeMap::new();
        let mut names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|f| f.ends_with(".csv"))
            .collect();
        names.sort();
        for f in names {
            let bytes = cli_common::read(&out, &f);
            files.insert(f, (bytes.len(), fnv1a(&bytes)));
        }
        let summary = summary_physics(&out);
        files.insert("summary.json".to_string(), (summary.len(), fnv1a(&summary)));
        got.insert(name.to_string(), files);
    }
    shard_case(&tmp, kernel, &mut got);
    std::fs::remove_dir_all(&tmp).ok();
    got
}

/// `tallies.json` without what measures the machine (as [`summary_physics`])
/// and without the scene's path in `description`.
fn tallies_physics(dir: &Path) -> Vec<u8> {
    fn strip(v: &mut Value) {
        match v {
            Value::Object(m) => {
                for key in ["seconds", "intersection_tests"] {
                    m.remove(key);
                }
                m.values_mut().for_each(strip);
            }
            Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut v: Value = serde_json::from_slice(&cli_common::read(dir, "tallies.json")).unwrap();
    v["description"].as_object_mut().unwrap().remove("scene");
    strip(&mut v);
    serde_json::to_vec(&v).unwrap()
}

/// The default scene in two shards (`--shard 0/2`, `--shard 1/2`) merged by
/// `roks merge`: each shard's `tallies.json` and the merged folder's files.
fn shard_case(
    tmp: &Path,
    kernel: Option<&str>,
    got: &mut BTreeMap<String, BTreeMap<String, (usize, u64)>>,
) {
    let scene = micro_scene(tmp, "default", &[("bands = 32", "bands = 8")]);
    let run = |args: &[String]| {
        let o = Command::new(env!("CARGO_BIN_EXE_roks"))
            .args(args)
            .current_dir(root())
            .output()
            .expect("run roks");
        assert!(
            o.status.success(),
            "shards: roks {args:?} failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let dirs: Vec<PathBuf> = (0..2).map(|i| tmp.join(format!("shard{i}"))).collect();
    for (i, d) in dirs.iter().enumerate() {
        let mut args: Vec<String> = [
            "brdf",
            &scene,
            "--threads",
            "2",
            "-q",
            "--stats-resolution",
            "64",
            "--theta",
            "0,60",
            "--photons",
            "20000",
            "--shard",
            &format!("{i}/2"),
            "--out",
            &d.to_string_lossy(),
        ]
        .iter()
        .map(|s| (*s).to_string())
        .collect();
        if let Some(k) = kernel {
            args.extend(["--kernel".to_string(), k.to_string()]);
        }
        run(&args);
    }
    let merged = tmp.join("shards_merged");
    let mut args: Vec<String> = vec!["merge".into(), "-q".into()];
    args.extend(dirs.iter().map(|d| d.to_string_lossy().into_owned()));
    args.extend(["--out".into(), merged.to_string_lossy().into_owned()]);
    run(&args);
    let mut files = BTreeMap::new();
    for f in ["brdf.csv", "inplane.csv"] {
        let bytes = cli_common::read(&merged, f);
        files.insert(f.to_string(), (bytes.len(), fnv1a(&bytes)));
    }
    let summary = summary_physics(&merged);
    files.insert("summary.json".to_string(), (summary.len(), fnv1a(&summary)));
    let tallies = tallies_physics(&merged);
    files.insert("tallies.json".to_string(), (tallies.len(), fnv1a(&tallies)));
    for (i, d) in dirs.iter().enumerate() {
        let t = tallies_physics(d);
        files.insert(format!("shard{i}/tallies.json"), (t.len(), fnv1a(&t)));
    }
    got.insert("default_shards".to_string(), files);
}

#[test]
fn outputs_match_the_recorded_hashes() {
    let got = measure(None);
    let text: String = got
        .iter()
        .flat_map(|(case, files)| {
            files
                .iter()
                .map(move |(f, (len, h))| format!("{case} {f} {len} {h:016x}\n"))
        })
        .collect();
    let path = root().join(HASHES);
    if std::env::var_os("ROKS_BLESS").is_some() {
        std::fs::write(&path, &text).unwrap();
        return;
    }
    let recorded = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{HASHES}: {e}"));
    let differ: Vec<String> = recorded
        .lines()
        .zip(text.lines())
        .filter(|(a, b)| a != b)
        .map(|(a, b)| format!("recorded {a}\n     now {b}"))
        .collect();
    assert!(
        differ.is_empty() && recorded.lines().count() == text.lines().count(),
        "outputs moved (rerun with ROKS_BLESS=1 only if that is meant):\n{}",
        differ.join("\n")
    );
}

/// The wavefront kernel (`--kernel wavefront`) writes the recorded bytes
/// of every `roks brdf` case: bumps with random and lattice launches and
/// mirror symmetry, Fresnel with Mueller tallies, a height field,
/// reflecting and absorbing edges, CSG bodies, and shards merged.
#[test]
fn the_wavefront_kernel_writes_the_recorded_bytes() {
    let got = measure(Some("wavefront"));
    let recorded = std::fs::read_to_string(root().join(HASHES)).unwrap();
    let mut compared = 0;
    for line in recorded.lines() {
        let mut w = line.split(' ');
        let (case, file) = (w.next().unwrap(), w.next().unwrap());
        let Some(files) = got.get(case) else {
            continue;
        };
        let (len, h) = files
            .get(file)
            .unwrap_or_else(|| panic!("{case}: no {file}"));
        assert_eq!(
            format!("{case} {file} {len} {h:016x}"),
            line,
            "the wavefront kernel moved {case} {file}"
        );
        compared += 1;
    }
    assert_eq!(
        compared,
        got.values().map(BTreeMap::len).sum::<usize>(),
        "a case without recorded hashes"
    );
    assert!(got.contains_key("default_shards") && got.len() == 8);
}

/// Every file of a `roks brdf` result folder `out` but the pictures, and
/// `summary.json` without the machine's figures: name -> bytes.
fn folder_physics(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files: BTreeMap<String, Vec<u8>> = std::fs::read_dir(out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".csv"))
        .map(|f| {
            let bytes = cli_common::read(out, &f);
            (f, bytes)
        })
        .collect();
    files.insert("summary.json".into(), summary_physics(out));
    files
}

/// The two kernels write the same bytes for the features the recorded
/// cases leave out: spectral lanes (Stokes vectors per wavelength), surface
/// realisations, several light azimuths, and a lattice launch on a height
/// field.
#[test]
fn the_kernels_agree_on_spectral_realisations_and_azimuths() {
    let tmp = std::env::temp_dir().join(format!("roks-kernels-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let default = micro_scene(&tmp, "default", &[("bands = 32", "bands = 8")]);
    let field = micro_scene(
        &tmp,
        "gaussian",
        &[("resolution = 1024", "resolution = 128")],
    );
    let cases: [(&str, &str, &[&str]); 4] = [
        (
            "spectral",
            "scenes/gold-spectral.toml",
            &[
                "--theta",
                "40",
                "--photons",
                "6000",
                "--polarisation",
                "stokes",
            ],
        ),
        (
            "realisations",
            "scenes/gaussian-ensemble.toml",
            &["--theta", "60", "--photons", "65536"],
        ),
        (
            "azimuths",
            &default,
            &["--theta", "30,70", "--phi", "0,45,90", "--photons", "8000"],
        ),
        (
            "field_lattice",
            &field,
            &["--theta", "50", "--photons", "8192", "--launch", "lattice"],
        ),
    ];
    for (name, scene, extra) in cases {
        let by_kernel: Vec<BTreeMap<String, Vec<u8>>> = ["scalar", "wavefront"]
            .iter()
            .map(|kernel| {
                let out = tmp.join(format!("{name}-{kernel}"));
                let o = Command::new(env!("CARGO_BIN_EXE_roks"))
                    .args(["brdf", scene, "--threads", "2", "-q"])
                    .args(["--stats-resolution", "64", "--kernel", kernel])
                    .args(extra)
                    .arg("--out")
                    .arg(&out)
                    .current_dir(root())
                    .output()
                    .expect("run roks");
                assert!(
                    o.status.success(),
                    "{name} {kernel}: {}",
                    String::from_utf8_lossy(&o.stderr)
                );
                folder_physics(&out)
            })
            .collect();
        assert!(by_kernel[0].len() >= 3, "{name}: {:?}", by_kernel[0].keys());
        assert_eq!(
            by_kernel[0].keys().collect::<Vec<_>>(),
            by_kernel[1].keys().collect::<Vec<_>>(),
            "{name}"
        );
        for (f, bytes) in &by_kernel[0] {
            assert!(
                *bytes == by_kernel[1][f],
                "{name}: {f} differs between the kernels"
            );
        }
    }
    std::fs::remove_dir_all(&tmp).ok();
}

#[test]
fn the_hash_is_fnv1a() {
    // Published FNV-1a 64 test vectors.
    assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
    assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
}
