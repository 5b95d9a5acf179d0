//! `roks report` and `--report` without a browser (the page itself is
//! tested in headless Chromium by `tests/report_browser.rs`):
//! * the report of a merged folder is byte for byte the report of the
//!   whole run, for `roks brdf` and `roks trace` shards;
//! * `roks report DIR` writes the same file as `--report` did;
//! * `--report` adds `report.html` and changes no other file;
//! * output safety: a report.html roks did not write is kept (refused
//!   without `--force`), one roks wrote is replaced, `--out` elsewhere.

mod cli_common;

use std::path::{Path, PathBuf};

use cli_common::{read, roks};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-report-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(args: &[&str]) {
    let out = roks(args);
    assert!(
        out.status.success(),
        "roks {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

#[test]
fn the_report_of_merged_shards_is_the_whole_runs() {
    let t = tmp("merge");
    let s = |p: &str| t.join(p).display().to_string();
    let brdf = [
        "brdf",
        "--photons",
        "8192",
        "--theta",
        "0,50",
        "--phi",
        "0,90",
        "--stats-resolution",
        "32",
        "-q",
        "--report",
        "--out",
    ];
    ok(&[&brdf[..], &[&s("whole")]].concat());
    for i in 0..2 {
        let shard = format!("{i}/2");
        ok(&[&brdf[..], &[&s(&format!("s{i}")), "--shard", &shard]].concat());
    }
    ok(&[
        "merge",
        &s("s1"),
        &s("s0"),
        "--out",
        &s("merged"),
        "--report",
        "-q",
    ]);
    let whole = read(&t.join("whole"), "report.html");
    assert!(whole.starts_with(b"<!DOCTYPE html>\n<!-- roks report -->\n"));
    assert!(
        whole == read(&t.join("merged"), "report.html"),
        "the merged folder's report differs from the whole run's"
    );
    // A shard's report is another one (its block of photons).
    assert!(whole != read(&t.join("s0"), "report.html"));

    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cylinder-cavity.toml");
    let scene = scene.display().to_string();
    let trace = ["trace", &scene, "--photons", "8192", "-q", "--out"];
    ok(&[&trace[..], &[&s("twhole"), "--report"]].concat());
    for i in 0..2 {
        let shard = format!("{i}/2");
        ok(&[&trace[..], &[&s(&format!("t{i}")), "--shard", &shard]].concat());
    }
    ok(&[
        "merge",
        &s("t0"),
        &s("t1"),
        "--out",
        &s("tmerged"),
        "--report",
        "-q",
    ]);
    assert!(
        read(&t.join("twhole"), "report.html") == read(&t.join("tmerged"), "report.html"),
        "the merged trace's report differs from the whole run's"
    );
    // A shard of `roks trace` has no table to report.
    let out = roks(&[&trace[..], &[&s("t9"), "--shard", "0/2", "--report"]].concat());
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        "roks: --report: not for a shard (its folder holds no reflectance.csv); report the folder of `roks merge`\n"
    );
    std::fs::remove_dir_all(&t).unwrap();
}

#[test]
fn roks_report_writes_what_report_wrote_and_keeps_foreign_files() {
    let t = tmp("cli");
    let (a, b) = (t.join("a"), t.join("b"));
    let (sa, sb) = (a.display().to_string(), b.display().to_string());
    let run = [
        "brdf",
        "--photons",
        "4096",
        "--theta",
        "30",
        "--polarisation",
        "mueller",
        "--stats-resolution",
        "32",
        "-q",
        "--out",
    ];
    ok(&[&run[..], &[&sa, "--report"]].concat());
    ok(&[&run[..], &[&sb]].concat());
    // --report adds report.html and changes no other file.
    let mut with = names(&a);
    with.retain(|n| n != "report.html");
    assert_eq!(with, names(&b));
    for n in names(&b)
        .iter()
        .filter(|n| *n != "summary.json" && *n != ".roks-files.json")
    {
        assert!(read(&a, n) == read(&b, n), "{n} differs with --report");
    }
    // A report.html in the folder that roks did not write is kept.
    std::fs::write(b.join("report.html"), "notes\n").unwrap();
    let out = roks(&["report", &sb]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(b.join("report.html")).unwrap(),
        "notes\n"
    );
    std::fs::remove_file(b.join("report.html")).unwrap();
    // `roks report` makes the same file of the written folder.
    ok(&["report", &sb, "-q"]);
    assert!(read(&a, "report.html") != Vec::<u8>::new());
    let (ra, rb) = (read(&a, "report.html"), read(&b, "report.html"));
    // The two runs differ only in their times, which a report leaves out.
    assert!(ra == rb, "roks report differs from --report");
    // Again: roks's own report is replaced.
    ok(&["report", &sb, "-q"]);
    // --out elsewhere; a file there roks did not write is kept.
    let other = t.join("other.html");
    std::fs::write(&other, "<html>mine</html>\n").unwrap();
    let so = other.display().to_string();
    let out = roks(&["report", &sb, "--out", &so]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(&other).unwrap(),
        "<html>mine</html>\n"
    );
    assert!(String::from_utf8_lossy(&out.stderr).starts_with(&format!("roks: --out: {so}: ")));
    ok(&["report", &sb, "--out", &so, "--force", "-q"]);
    assert!(read(&t, "other.html") == rb);
    // Not a result folder: one line, exit status 2.
    let out = roks(&["report", &t.display().to_string()]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    std::fs::remove_dir_all(&t).unwrap();
}
