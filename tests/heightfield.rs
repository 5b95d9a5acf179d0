//! Height-field scenes end to end: the white furnace on a rough
//! Gaussian field, `roks stats` on a generated field, the measured-map round
//! trip (generated -> file -> loaded gives byte-identical BRDF tables), and
//! `roks export-mesh` writing exactly the traced triangles.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use roks::export::read_ply;
use roks::micro::heightfield::HeightField;
use roks::scene::micro::MicroScene;

/// A fresh, empty scratch folder for this test process.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-it-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A rough Gaussian field (sigma / tau = 0.5, RMS slope about 1) of a white
/// material: many multiple reflections, grazing flights, wraps across the cell.
const ROUGH: &str = r#"
name = "rough_field"

[surface]
size = [16.0, 16.0]
material = "white"
heightfield = { gaussian = { sigma = 1.0, tau = 2.0 }, resolution = 128, seed = 5 }

[materials.white]
reflectance = 1.0

[light]
theta_deg = [0.0, 30.0, 60.0, 80.0, 85.0, 89.0]
photons = 50000
seed = 2
"#;

/// White furnace: with reflectance 1 every photon leaves with weight exactly
/// 1 (a photon leaking below the surface would never come back up and be
/// cut as trapped, i.e. lost), nothing lost, all weight in Carlson cells.
#[test]
fn furnace_on_a_rough_gaussian_field() {
    let scene = common::scene("rough_field", ROUGH);
    for r in common::run(&scene) {
        let what = format!("theta {}", r.theta_i_deg);
        let (mean, stderr) = r.reflectance();
        assert_eq!(r.lost(), 0.0, "{what}: {}", common::losses(&r));
        assert_eq!(mean, 1.0, "{what}: reflectance {mean}");
        assert_eq!(stderr, 0.0, "{what}");
        let carlson: f64 = r.tallies.carlson.sum.iter().sum();
        assert!((carlson - r.tallies.photons as f64).abs() < 1e-9, "{what}");
        assert!(
            r.mean_bounces() > 1.0,
            "{what}: {} bounces",
            r.mean_bounces()
        );
    }
}

fn roks(args: &[&str]) -> std::process::Output {
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(args)
        .output()
        .expect("run roks");
    assert!(
        o.status.success(),
        "roks {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `roks stats` on a generated field reads its own vertex heights: the RMS
/// height is the requested sigma (to the f32 rounding of the heights).
#[test]
fn stats_gives_back_sigma_of_a_generated_field() {
    let dir = scratch("hf-stats");
    let scene = dir.join("rough.toml");
    std::fs::write(&scene, ROUGH).unwrap();
    let o = roks(&["stats", path(&scene), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let sigma = v["sigma"].as_f64().unwrap();
    assert!((sigma - 1.0).abs() < 1e-7, "sigma {sigma}");
    assert_eq!(v["height_map_resolution"], 128);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `roks stats` and the `surface` of `roks brdf`'s summary.json describe
/// the same height map by default (512 x 512 samples of the default
/// scene's bumps): the same numbers, to the last bit.
#[test]
fn stats_equals_the_surface_of_the_brdf_summary() {
    let dir = scratch("stats-summary");
    let out = dir.join("run");
    roks(&[
        "brdf",
        "--photons",
        "4096",
        "--theta",
        "0",
        "--out",
        path(&out),
        "-q",
    ]);
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let o = roks(&["stats", "--json"]);
    let stats: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(stats["height_map_resolution"], 512);
    assert_eq!(stats, summary["surface"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The measured-map round trip: a generated field written by
/// `roks export-heightfield` as text (exact decimals) and as EXR (f32; the
/// generated heights are f32 numbers) and loaded back as
/// `heightfield = { file, pixel }` gives byte-identical brdf.csv and
/// inplane.csv. Also `roks export-mesh` writes the field's own vertices and
/// triangles: every face is the traced triangle (same vertices, same
/// diagonal, same winding), exactly, since pitch and heights are f32 numbers.
#[test]
fn generated_field_round_trips_through_files() {
    let dir = scratch("hf-roundtrip");
    let generated = dir.join("generated.toml");
    let text = ROUGH.replace("reflectance = 1.0", "reflectance = 0.7");
    std::fs::write(&generated, &text).unwrap();
    let brdf = |scene: &Path, out: &str| {
        let out = dir.join(out);
        roks(&[
            "brdf",
            path(scene),
            "--out",
            path(&out),
            "--photons",
            "20000",
            "--theta",
            "0,60,85",
            "--threads",
            "2",
            "-q",
        ]);
        out
    };
    let reference = brdf(&generated, "generated");
    for ext in ["txt", "exr"] {
        let map = dir.join(format!("map.{ext}"));
        let o = roks(&["export-heightfield", path(&generated), "--out", path(&map)]);
        let hint = String::from_utf8_lossy(&o.stderr);
        let pixel = 16.0 / 128.0;
        assert!(hint.contains(&format!("pixel = {pixel:?}")), "{hint}");
        let loaded = dir.join(format!("loaded-{ext}.toml"));
        let line = format!("heightfield = {{ file = \"map.{ext}\", pixel = {pixel:?} }}");
        let scene_text = text
            .replace(
                "heightfield = { gaussian = { sigma = 1.0, tau = 2.0 }, resolution = 128, seed = 5 }",
                &line,
            )
            .replace("size = [16.0, 16.0]\n", "");
        assert!(scene_text.contains(&line));
        std::fs::write(&loaded, scene_text).unwrap();
        let out = brdf(&loaded, &format!("loaded-{ext}"));
        for f in ["brdf.csv", "inplane.csv"] {
            assert!(
                std::fs::read(reference.join(f)).unwrap() == std::fs::read(out.join(f)).unwrap(),
                "{ext}: {f} differs after the round trip"
            );
        }
    }

    let ply = dir.join("field.ply");
    roks(&["export-mesh", path(&generated), "--out", path(&ply)]);
    let mesh = read_ply(&std::fs::read(&ply).unwrap()).unwrap();
    let field = HeightField::gaussian(128, 128, glam::DVec2::splat(16.0), 1.0, 2.0, 5);
    assert_eq!(mesh.vertices.len(), 129 * 129);
    assert_eq!(mesh.faces.len(), 2 * 128 * 128);
    for (tri, face) in mesh.faces.iter().enumerate() {
        let traced = field.triangle_vertices(tri);
        for (k, &v) in face.iter().enumerate() {
            let got = mesh.vertices[v as usize].map(f64::from);
            assert_eq!(got, traced[k].to_array(), "triangle {tri} vertex {k}");
        }
    }
    // Another resolution than the field's own is refused (exit 2, one line).
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args([
            "export-mesh",
            path(&generated),
            "--out",
            path(&ply),
            "--resolution",
            "64",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The scene built by the library from the same keys is the same field.
#[test]
fn scene_field_is_the_synthesised_field() {
    let scene: MicroScene = common::scene("rough_field", ROUGH);
    let field = scene.surface.heightfield().expect("a height field");
    let direct = HeightField::gaussian(128, 128, glam::DVec2::splat(16.0), 1.0, 2.0, 5);
    assert_eq!(field.h, direct.h);
    assert_eq!(scene.surface.max_height, direct.max);
}

/// Similarity: the same field with pitch and heights scaled by 2^10 or 2^-10
/// (`pixel` and `height_scale`) gives the very same photon paths, since
/// every operation of the walk commutes with a power-of-two scale: the
/// tallies are equal bit for bit.
#[test]
fn scaled_field_gives_identical_tallies() {
    use roks::micro::heightfield_io::{Format, HeightGrid, write};
    let field = HeightField::gaussian(64, 64, glam::DVec2::splat(8.0), 0.5, 1.0, 9);
    let grid = HeightGrid {
        nx: 64,
        ny: 64,
        h: field.h.clone(),
    };
    let map = std::env::temp_dir().join(format!("roks-it-{}-scaled.txt", std::process::id()));
    std::fs::write(&map, write(&grid, Format::Text, "").unwrap()).unwrap();
    let scene = |scale: f64| {
        common::scene(
            "scaled",
            &format!(
                r#"
[surface]
material = "m"
heightfield = {{ file = {:?}, pixel = {:?}, height_scale = {scale:?} }}

[materials.m]
reflectance = 0.6

[light]
theta_deg = [0.0, 50.0, 80.0]
photons = 20000
"#,
                map.display().to_string(),
                0.125 * scale
            ),
        )
    };
    let reference = common::run(&scene(1.0));
    assert!(reference[0].mean_bounces() > 1.0);
    for scale in [1024.0, 1.0 / 1024.0] {
        for (a, b) in reference.iter().zip(common::run(&scene(scale))) {
            let what = format!("scale {scale}, theta {}", a.theta_i_deg);
            assert_eq!(a.tallies.carlson.sum, b.tallies.carlson.sum, "{what}");
            assert_eq!(a.tallies.inplane.sum, b.tallies.inplane.sum, "{what}");
            assert_eq!(a.tallies.by_bounces, b.tallies.by_bounces, "{what}");
            assert_eq!(a.tallies.segments, b.tallies.segments, "{what}");
        }
    }
}
