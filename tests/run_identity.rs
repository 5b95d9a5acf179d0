//! The identity of a run is its content: `roks merge` refuses shards whose
//! scene text or any file the scene reads (an n, k table, an angle table,
//! a height map) changed between them, naming the first field of the run's
//! description that differs, and merges shards of the same content given by
//! other paths into the single run's files.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cli_common::read;

/// A fresh scratch folder for `name`.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-identity-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `roks ARGS` run in the folder `cwd`.
fn roks_in(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run roks")
}

/// `roks brdf SCENE --shard SHARD --out OUT` in `cwd` (two batches, one angle).
fn shard(cwd: &Path, scene: &str, shard: &str, out: &str) {
    let o = roks_in(
        cwd,
        &[
            "brdf",
            scene,
            "-q",
            "--photons",
            "8192",
            "--theta",
            "30",
            "--shard",
            shard,
            "--out",
            out,
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A flat micro scene of material `m` given by `material` (TOML keys),
/// with extra top-level `surface` keys and `light` keys.
fn scene(material: &str, surface: &str, light: &str) -> String {
    format!(
        "[surface]\n{surface}\nmaterial = \"m\"\n\n[materials.m]\n{material}\n\n[light]\n{light}\n\n[tally]\nbands = 2\n"
    )
}

/// Shard 0 traced, then `edit` applied in `dir`, then shard 1: the merge
/// must be refused (exit 2, one line) naming shard 1's file and `key`.
fn assert_refused(dir: &Path, edit: impl FnOnce(&Path), key: &str) {
    shard(dir, "s.toml", "0/2", "a");
    edit(dir);
    shard(dir, "s.toml", "1/2", "b");
    let o = roks_in(dir, &["merge", "a", "b", "-q", "--out", "m"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(&format!(
            "b/tallies.json: {key}: differs from a/tallies.json"
        )),
        "{err}"
    );
    assert!(!dir.join("m").exists());
}

#[test]
fn a_changed_scene_text_is_refused() {
    let dir = scratch("text");
    std::fs::write(
        dir.join("s.toml"),
        scene("reflectance = 0.8", "size = [1.0, 1.0]", ""),
    )
    .unwrap();
    assert_refused(
        &dir,
        |d| {
            std::fs::write(
                d.join("s.toml"),
                scene("reflectance = 0.7", "size = [1.0, 1.0]", ""),
            )
            .unwrap();
        },
        "description.content.scene_sha256",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_changed_nk_table_is_refused() {
    let dir = scratch("nk");
    std::fs::write(
        dir.join("s.toml"),
        scene(
            "nk = \"m.csv\"",
            "size = [1.0, 1.0]",
            "wavelengths_um = [0.5, 0.6]",
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("m.csv"),
        "wavelength_um,n,k\n0.4,1.5,0.1\n0.7,1.6,0.2\n",
    )
    .unwrap();
    assert_refused(
        &dir,
        |d| {
            std::fs::write(
                d.join("m.csv"),
                "wavelength_um,n,k\n0.4,1.5,0.1\n0.7,1.7,0.2\n",
            )
            .unwrap()
        },
        "description.content.files.materials.m.nk",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_changed_angle_table_is_refused() {
    let dir = scratch("angle");
    std::fs::write(
        dir.join("s.toml"),
        scene("table = \"r.csv\"", "size = [1.0, 1.0]", ""),
    )
    .unwrap();
    std::fs::write(dir.join("r.csv"), "angle_deg,reflectance\n0,0.5\n90,0.9\n").unwrap();
    assert_refused(
        &dir,
        |d| std::fs::write(d.join("r.csv"), "angle_deg,reflectance\n0,0.5\n90,0.8\n").unwrap(),
        "description.content.files.materials.m.table",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_changed_height_map_is_refused() {
    let dir = scratch("map");
    std::fs::write(
        dir.join("s.toml"),
        scene(
            "reflectance = 0.8",
            "heightfield = { file = \"h.txt\", pixel = 1.0 }",
            "",
        ),
    )
    .unwrap();
    let map = |top: f64| format!("0 0.1 0 0.2\n0.1 {top} 0.1 0\n0 0.1 0 0.1\n0.2 0 0.1 0\n");
    std::fs::write(dir.join("h.txt"), map(0.3)).unwrap();
    assert_refused(
        &dir,
        |d| std::fs::write(d.join("h.txt"), map(0.4)).unwrap(),
        "description.content.files.surface.heightfield.file",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same scene and table given as `s.toml`, `./s.toml` and a copy in
/// another folder: the shards merge, into the single run's files.
#[test]
fn the_same_content_by_another_path_merges() {
    let dir = scratch("paths");
    let text = scene("table = \"r.csv\"", "size = [1.0, 1.0]", "");
    let table = "angle_deg,reflectance\n0,0.5\n90,0.9\n";
    std::fs::write(dir.join("s.toml"), &text).unwrap();
    std::fs::write(dir.join("r.csv"), table).unwrap();
    let copy = dir.join("copy");
    std::fs::create_dir_all(&copy).unwrap();
    std::fs::write(copy.join("s.toml"), &text).unwrap();
    std::fs::write(copy.join("r.csv"), table).unwrap();

    shard(&dir, "s.toml", "0/2", "a");
    shard(&dir, "./s.toml", "1/2", "b");
    shard(&dir, "copy/s.toml", "1/2", "c");
    let o = roks_in(
        &dir,
        &[
            "brdf",
            "s.toml",
            "-q",
            "--photons",
            "8192",
            "--theta",
            "30",
            "--out",
            "whole",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (second, out) in [("b", "ab"), ("c", "ac")] {
        let o = roks_in(&dir, &["merge", "a", second, "-q", "--out", out]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for file in ["brdf.csv", "inplane.csv"] {
            assert_eq!(
                read(&dir.join(out), file),
                read(&dir.join("whole"), file),
                "{out}/{file}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
