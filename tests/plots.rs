//! `roks plot` and the pictures of result folders: drawn from the folder's
//! files by one code path, so that `roks plot` redraws exactly what `roks
//! brdf`, `merge` and `trace` wrote; merged folders get the whole run's
//! pictures; bad folders are one-line input errors that change nothing.

mod cli_common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use cli_common::{read, roks};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-plots-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn ok(args: &[&str]) {
    let o = roks(args);
    assert!(
        o.status.success(),
        "roks {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The PNG files of `dir`, by name.
fn pictures(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .map(|n| {
            let b = read(dir, &n);
            (n, b)
        })
        .collect()
}

/// Delete the pictures of `dir`, run `roks plot dir`, and check it drew the
/// same files, byte for byte.
fn redraw_is_identical(dir: &Path, expect: &[&str]) {
    let before = pictures(dir);
    for e in expect {
        assert!(
            before.contains_key(*e),
            "{}: no {e} in {:?}",
            dir.display(),
            before.keys()
        );
    }
    for n in before.keys() {
        std::fs::remove_file(dir.join(n)).unwrap();
    }
    ok(&["plot", dir.to_str().unwrap(), "-q"]);
    let after = pictures(dir);
    assert_eq!(
        before.keys().collect::<Vec<_>>(),
        after.keys().collect::<Vec<_>>()
    );
    for (n, b) in &before {
        assert!(after[n] == *b, "{}: {n} redrawn differently", dir.display());
    }
}

/// A run of two light azimuths (Stokes): `roks plot` writes the pictures
/// per incidence and azimuth under the names `roks brdf` gave them, byte
/// for byte, none overwriting another.
#[test]
fn plot_redraws_every_azimuth() {
    let dir = scratch("azimuths");
    ok(&[
        "brdf",
        "scenes/gaussian-rough.toml",
        "--polarisation",
        "stokes",
        "--theta",
        "0,45",
        "--phi",
        "0,90",
        "--photons",
        "1000",
        "--out",
        dir.to_str().unwrap(),
        "-q",
    ]);
    let expect = [
        "hemisphere_0deg_phi0.png",
        "hemisphere_0deg_phi90.png",
        "hemisphere_45deg_phi0.png",
        "hemisphere_45deg_phi90.png",
        "dop_45deg_phi0.png",
        "dop_45deg_phi90.png",
        "inplane.png",
        "reflectance.png",
    ];
    redraw_is_identical(&dir, &expect);
    // The azimuths' maps differ (the light turned), so none is a copy.
    let p = pictures(&dir);
    assert!(p["hemisphere_45deg_phi0.png"] != p["hemisphere_45deg_phi90.png"]);
    assert!(!p.contains_key("hemisphere_45deg.png"), "{:?}", p.keys());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A polarised micro run (Mueller and Stokes), a spectral run, and an
/// object run: `roks plot` redraws every picture exactly (surface.png from
/// the scene file named in summary.json).
#[test]
fn plot_redraws_what_the_runs_drew() {
    let mueller = scratch("mueller");
    ok(&[
        "brdf",
        "scenes/gaussian-rough.toml",
        "--polarisation",
        "mueller",
        "--theta",
        "0,45",
        "--photons",
        "3000",
        "--out",
        mueller.to_str().unwrap(),
        "-q",
    ]);
    redraw_is_identical(
        &mueller,
        &[
            "hemisphere_0deg.png",
            "hemisphere_45deg.png",
            "inplane.png",
            "reflectance.png",
            "mueller_45deg.png",
            "mueller_stderr_45deg.png",
            "surface.png",
        ],
    );
    let stokes = scratch("stokes");
    ok(&[
        "brdf",
        "scenes/gaussian-rough.toml",
        "--polarisation",
        "stokes",
        "--theta",
        "30",
        "--photons",
        "2000",
        "--out",
        stokes.to_str().unwrap(),
        "-q",
    ]);
    redraw_is_identical(&stokes, &["dop_30deg.png", "hemisphere_30deg.png"]);
    let spectral = scratch("spectral");
    ok(&[
        "brdf",
        "scenes/gold-spectral.toml",
        "--theta",
        "20",
        "--photons",
        "1000",
        "--out",
        spectral.to_str().unwrap(),
        "-q",
    ]);
    redraw_is_identical(&spectral, &["colour_20deg.png", "hemisphere_20deg.png"]);
    let object = scratch("object");
    ok(&[
        "trace",
        "scenes/cylinder-cavity.toml",
        "--photons",
        "200",
        "--out",
        object.to_str().unwrap(),
        "-q",
    ]);
    redraw_is_identical(&object, &["reflectance.png"]);
    for d in [mueller, stokes, spectral, object] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// `roks merge` draws the pictures of the whole run: every picture of the
/// merged folder is byte for byte the whole run's (surface.png: the
/// shards').
#[test]
fn merged_shards_have_the_whole_runs_pictures() {
    let (whole, a, b, merged) = (
        scratch("whole"),
        scratch("a"),
        scratch("b"),
        scratch("merged"),
    );
    let run = |out: &Path, shard: Option<&str>| {
        let mut args = vec![
            "brdf",
            "--polarisation",
            "mueller",
            "--theta",
            "0,60",
            "--photons",
            "12000",
            "--out",
            out.to_str().unwrap(),
            "-q",
        ];
        if let Some(s) = shard {
            args.extend(["--shard", s]);
        }
        ok(&args);
    };
    run(&whole, None);
    run(&a, Some("0/2"));
    run(&b, Some("1/2"));
    ok(&[
        "merge",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
        "-q",
    ]);
    let (w, m) = (pictures(&whole), pictures(&merged));
    // Every picture, surface.png included (the merge keeps the shards').
    let mut names: Vec<&String> = w.keys().collect();
    names.sort();
    assert_eq!(names, m.keys().collect::<Vec<_>>());
    assert!(names.len() >= 7, "{names:?}");
    for n in names {
        assert!(w[n] == m[n], "{n} differs");
    }
    for d in [whole, a, b, merged] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Bad folders: one line naming the folder (and file), exit status 2, and
/// no picture written or changed.
#[test]
fn bad_folders_are_input_errors() {
    let missing = scratch("missing");
    let o = roks(&["plot", missing.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.lines().count() == 1 && e.contains("summary.json"), "{e}");
    let dir = scratch("broken");
    ok(&[
        "brdf",
        "--theta",
        "10",
        "--photons",
        "500",
        "--out",
        dir.to_str().unwrap(),
        "-q",
    ]);
    let before = pictures(&dir);
    let text = String::from_utf8(read(&dir, "brdf.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    lines[1].push_str(",junk");
    std::fs::write(dir.join("brdf.csv"), lines.join("\n") + "\n").unwrap();
    let o = roks(&["plot", dir.to_str().unwrap()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.lines().count() == 1 && e.contains("brdf.csv: line 2") && !e.contains("panicked"),
        "{e}"
    );
    assert!(pictures(&dir) == before);
    let _ = std::fs::remove_dir_all(dir);
}

/// The pictures the issue found misleading, as a run writes them: a
/// spectral run of ten incidences at two light azimuths draws
/// `inplane.png` and `reflectance.png` as small multiples (four panels:
/// 1400 x 680 pixels) and a Mueller run draws its standard errors with a
/// scale bar per panel (1100 x 1180); every picture decodes, and `roks
/// plot` redraws each byte for byte.
#[test]
fn the_fixed_pictures_are_written_and_decode() {
    let dir = scratch("multiples");
    ok(&[
        "brdf",
        "--theta",
        "0,10,20,30,40,50,60,70,80,85",
        "--phi",
        "0,90",
        "--wavelengths",
        "0.45,0.55,0.65",
        "--photons",
        "400",
        "--out",
        dir.to_str().unwrap(),
        "-q",
    ]);
    let mueller = scratch("mueller-errors");
    ok(&[
        "brdf",
        "--polarisation",
        "mueller",
        "--theta",
        "45",
        "--photons",
        "2000",
        "--out",
        mueller.to_str().unwrap(),
        "-q",
    ]);
    for (d, name, size) in [
        (&dir, "inplane.png", (1400, 680)),
        (&dir, "reflectance.png", (1400, 680)),
        (&dir, "hemisphere_85deg_phi90.png", (0, 0)),
        (&mueller, "mueller_stderr_45deg.png", (1100, 1180)),
        (&mueller, "mueller_45deg.png", (1100, 1060)),
    ] {
        let img = image::load_from_memory(&read(d, name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        if size != (0, 0) {
            assert_eq!((img.width(), img.height()), size, "{name}");
        }
    }
    redraw_is_identical(&dir, &["inplane.png", "reflectance.png"]);
    redraw_is_identical(&mueller, &["mueller_stderr_45deg.png"]);
    for d in [dir, mueller] {
        let _ = std::fs::remove_dir_all(d);
    }
}
