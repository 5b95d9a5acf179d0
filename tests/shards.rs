//! `roks brdf --shard I/N` + `roks merge` reproduce the single run exactly:
//! byte-identical brdf.csv and inplane.csv, summary.json equal but for timings.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::Output;

use cli_common::{read, roks, summary_without_timing};

const PHOTONS: &str = "50000"; // 13 batches of 4096: the last one partial

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-shards-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn brdf(out: &Path, seed: &str, shard: Option<&str>) {
    let out_s = out.to_str().unwrap();
    let mut args = vec![
        "brdf",
        "-q",
        "--photons",
        PHOTONS,
        "--theta",
        "0,45,80",
        "--seed",
        seed,
        "--out",
        out_s,
    ];
    if let Some(s) = shard {
        args.extend(["--shard", s]);
    }
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A one-line input error (exit 2) naming `dir`.
fn assert_merge_error(o: &Output, dir: &Path, expect: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let line = err.trim_end_matches('\n');
    assert!(!line.contains('\n'), "not one line: {err:?}");
    assert!(
        line.contains(&dir.display().to_string()),
        "no dir in {line:?}"
    );
    assert!(line.contains(expect), "no `{expect}` in {line:?}");
}

#[test]
fn merged_shards_equal_the_single_run_exactly() {
    let root = scratch("exact");
    let full = root.join("full");
    brdf(&full, "5", None);
    for n in [2_u32, 3, 4] {
        let dirs: Vec<PathBuf> = (0..n).map(|i| root.join(format!("n{n}-s{i}"))).collect();
        for (i, d) in dirs.iter().enumerate() {
            brdf(d, "5", Some(&format!("{i}/{n}")));
        }
        let merged = root.join(format!("n{n}-merged"));
        // Given in reverse: merge sorts shards by photon range.
        let mut args: Vec<String> = vec!["merge".into(), "-q".into()];
        args.extend(dirs.iter().rev().map(|d| d.display().to_string()));
        args.extend(["--out".into(), merged.display().to_string()]);
        let o = roks(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for f in ["brdf.csv", "inplane.csv"] {
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
        // A shard alone is a valid (smaller) result.
        let s0 = summary_without_timing(&dirs[0]);
        assert!(s0["incidence"][0]["photons"].as_u64().unwrap() < 50_000);
    }
    // A merged result merges again (one whole-run block).
    let again = root.join("again");
    let o = roks(&[
        "merge",
        "-q",
        root.join("n2-merged").to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(read(&full, "brdf.csv") == read(&again, "brdf.csv"));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn incompatible_shards_are_refused() {
    let root = scratch("bad");
    let s = |name: &str| root.join(name);
    brdf(&s("a0"), "5", Some("0/2"));
    brdf(&s("a1"), "5", Some("1/2"));
    brdf(&s("b1"), "6", Some("1/2"));
    brdf(&s("c1"), "5", Some("1/3"));
    let out = s("out");
    let merge = |dirs: &[&str]| {
        let mut args = vec!["merge".to_string(), "-q".into()];
        args.extend(dirs.iter().map(|d| s(d).display().to_string()));
        args.extend(["--out".into(), out.display().to_string()]);
        roks(&args.iter().map(String::as_str).collect::<Vec<_>>())
    };
    assert_merge_error(
        &merge(&["a0", "b1"]),
        &s("b1"),
        "`description.run.seed` differs",
    );
    assert_merge_error(&merge(&["a0"]), &s("a0"), "missing");
    assert_merge_error(&merge(&["a0", "a1", "c1"]), &s("c1"), "overlap");
    assert_merge_error(&merge(&["a0", "nowhere"]), &s("nowhere"), "tallies.json");
    assert!(!out.exists(), "output written on error");
    // More shards than batches.
    let o = roks(&[
        "brdf",
        "-q",
        "--photons",
        "5000",
        "--shard",
        "2/3",
        "--out",
        s("x").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--shard"));
    let _ = std::fs::remove_dir_all(&root);
}

/// `roks merge --export` writes every file the single run with `--export`
/// writes (the exports and every picture, surface.png included), byte for
/// byte; summary.json equal but for timings; only tallies.json added.
#[test]
fn merged_exports_and_pictures_equal_the_single_run() {
    let base = scratch("exports");
    let (whole, merged) = (base.join("whole"), base.join("merged"));
    let common = ["-q", "--photons", "20000", "--theta", "0,40"];
    let run = |extra: &[&str]| {
        let o = roks(&[&["brdf"], &common[..], extra].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&[
        "--export",
        "zemax,merl,rgl",
        "--out",
        whole.to_str().unwrap(),
    ]);
    let shards: Vec<PathBuf> = (0..3).map(|i| base.join(format!("s{i}"))).collect();
    for (i, s) in shards.iter().enumerate() {
        run(&["--shard", &format!("{i}/3"), "--out", s.to_str().unwrap()]);
    }
    let mut args = vec!["merge", "-q", "--export", "zemax,merl,rgl"];
    args.extend(shards.iter().map(|s| s.to_str().unwrap()));
    args.extend(["--out", merged.to_str().unwrap()]);
    let o = roks(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let mut expected = names(&whole);
    expected.push("tallies.json".into());
    expected.sort();
    assert_eq!(names(&merged), expected);
    for f in names(&whole) {
        if f == ".roks-files.json" {
            // The record names the writer: brdf here, merge there.
            continue;
        }
        if f == "summary.json" {
            assert_eq!(
                summary_without_timing(&whole),
                summary_without_timing(&merged)
            );
        } else {
            assert!(read(&whole, &f) == read(&merged, &f), "{f} differs");
        }
    }
    for f in ["brdf.bsdf", "brdf.binary", "brdf_rgl.bsdf", "surface.png"] {
        assert!(whole.join(f).is_file(), "{f} not written");
    }
    let _ = std::fs::remove_dir_all(&base);
}
