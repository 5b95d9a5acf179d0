//! No input is ever destroyed, and what a run reads is checked before any
//! work: every command refuses (exit 2, one line, nothing written) an output
//! that is, holds or would replace a file the run reads, however the path
//! is spelt; an `--out` that cannot be a file is refused up front; a file
//! name holding a newline is quoted on one line; a render's cost is bounded;
//! unknown keys of inline tables are refused; impossible Mueller tables are
//! refused and the table of an s-polarised run is accepted as a wall.
//!
//! Each case failed on the main branch before this change (exit 0 with the
//! input destroyed, a two-line message, work done and then exit 1, or a
//! table refused or accepted wrongly). `ROKS_UNDER_TEST=/path/to/roks` runs
//! the cases against another build of the binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run `roks` (this build, or `ROKS_UNDER_TEST`) in `dir`.
fn roks_in(dir: &Path, args: &[&str]) -> Output {
    let bin =
        std::env::var_os("ROKS_UNDER_TEST").unwrap_or_else(|| env!("CARGO_BIN_EXE_roks").into());
    Command::new(bin)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run roks")
}

/// A fresh scratch folder for `name`.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-inputs-kept-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small micro scene over the text height map `map` (8 x 8 samples).
fn field_scene(map: &str) -> String {
    // A PNG map holds counts: the height of one.
    let scale = if map.ends_with(".png") {
        ", height_scale = 1e-5"
    } else {
        ""
    };
    format!(
        r#"name = "field"
[surface]
size = [4.0, 4.0]
material = "paint"
heightfield = {{ file = "{map}", pixel = 0.5{scale} }}
[materials.paint]
reflectance = 0.8
[light]
theta_deg = [0.0]
photons = 4096
"#
    )
}

/// 8 x 8 heights as text.
fn map_text() -> String {
    (0..8)
        .map(|j| {
            (0..8)
                .map(|i| format!("{}", f64::from((i * j) % 5) * 0.1))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

/// A small bump scene (fast to trace); `light` is added to `[light]`.
fn bump_scene(name: &str, material: &str, light: &str, tally: &str) -> String {
    format!(
        r#"name = "{name}"
[surface]
size = [30.0, 30.0]
material = "m"
[materials.m]
{material}
[[bumps]]
shape = "ellipsoid"
count = 10
radius = 2.5
height = 1.0
seed = 1
[light]
theta_deg = [0.0, 30.0]
photons = 4096
{light}
[tally]
bands = 8
{tally}
"#
    )
}

/// An object scene: a flat slab whose walls sample the table `table`.
fn object_scene(table: &str) -> String {
    format!(
        r#"name = "slab"
[quadrics]
top = {{ plane = [0.0, 0.0, 1.0, 0.0] }}
ball = {{ sphere = {{ center = [0.0, 0.0, -10.0], r = 100.0 }} }}
[[cells]]
name = "body"
region = "-top -ball"
fill = "solid"
[[cells]]
name = "air"
region = "+top"
fill = "void"
[walls]
top = "t"
ball = "t"
[models.t]
brdf = "{table}"
[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 2.0 }}
position = [0.0, 0.0, 10.0]
photons = 1000
"#
    )
}

/// Bad input: exit 2, one line on stderr holding every string of
/// `expect`, no panic.
fn assert_refused(case: &str, o: &Output, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{case}: {stderr}");
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    let line = stderr.trim_end_matches('\n');
    assert!(!line.contains('\n'), "{case}: not one line: {stderr:?}");
    for e in expect {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
}

/// The bytes of every file under `dir` (sorted by path), to show that a
/// refused run changed nothing.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if std::fs::symlink_metadata(&p).unwrap().is_dir() {
                stack.push(p);
            } else {
                let bytes = std::fs::read(&p).unwrap_or_default();
                v.push((p, bytes));
            }
        }
    }
    v.sort();
    v
}

/// `roks brdf res/scene.toml --out res` (res a result folder holding its
/// scene and height map), spelt four ways, and the default folder holding
/// the scene: refused, nothing changed.
#[test]
fn a_result_folder_holding_the_scene_or_its_files_is_not_replaced() {
    let d = scratch("brdf");
    std::fs::write(d.join("scene.toml"), field_scene("map.txt")).unwrap();
    std::fs::write(d.join("map.txt"), map_text()).unwrap();
    let o = roks_in(&d, &["brdf", "scene.toml", "--out", "res", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["scene.toml", "map.txt"] {
        std::fs::copy(d.join(f), d.join("res").join(f)).unwrap();
    }
    std::os::unix::fs::symlink("res", d.join("link")).unwrap();
    let before = snapshot(&d);
    let absolute = format!("{}/res", d.display());
    for out in ["res", "./res/../res/", "link", "link/", absolute.as_str()] {
        let o = roks_in(&d, &["brdf", "res/scene.toml", "--out", out, "-q"]);
        assert_refused(
            out,
            &o,
            &["--out", "res/scene.toml", "a file this run reads"],
        );
        assert_eq!(snapshot(&d), before, "{out}");
    }
    // Only the height map inside: the scene beside it.
    std::fs::write(d.join("s2.toml"), field_scene("res/map.txt")).unwrap();
    let before = snapshot(&d);
    let o = roks_in(&d, &["brdf", "s2.toml", "--out", "res", "-q"]);
    assert_refused("map", &o, &["--out: res: holds res/map.txt"]);
    assert_eq!(snapshot(&d), before);
    // The default folder out/NAME holding the scene.
    std::fs::create_dir_all(d.join("out/field")).unwrap();
    std::fs::copy(d.join("res/summary.json"), d.join("out/field/summary.json")).unwrap();
    std::fs::write(d.join("out/field/s.toml"), field_scene("../../map.txt")).unwrap();
    let o = roks_in(&d, &["brdf", "out/field/s.toml", "-q"]);
    assert_refused(
        "default",
        &o,
        &["out/field/s.toml: name", "a file this run reads"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `render --out map.txt`, `render --out map.exr` over a 16-bit PNG map
/// (the preview map.png), `export-mesh`, `export-heightfield` and `stats
/// --png` over the scene's height map: refused, the map unchanged.
#[test]
fn single_files_never_replace_a_height_map() {
    let d = scratch("files");
    std::fs::write(d.join("scene.toml"), field_scene("map.txt")).unwrap();
    std::fs::write(d.join("map.txt"), map_text()).unwrap();
    let png = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(8, 8, |i, j| {
        image::Luma([((i * 977 + j * 3571) % 65536) as u16])
    });
    png.save(d.join("map.png")).unwrap();
    std::fs::write(d.join("png.toml"), field_scene("map.png")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    let before = snapshot(&d);
    let small = ["--size", "4,4", "--spp", "1"];
    let cases: Vec<(&str, Vec<&str>, &str)> = vec![
        (
            "render over the map",
            [&["render", "scene.toml", "--out", "map.txt"][..], &small].concat(),
            "--out: map.txt: is map.txt",
        ),
        (
            "render's preview over a PNG map",
            [
                &["render", "png.toml", "--out", "./sub/../map.exr"][..],
                &small,
            ]
            .concat(),
            "map.png",
        ),
        (
            "export-mesh",
            vec!["export-mesh", "scene.toml", "--out", "sub/../map.txt"],
            "--out",
        ),
        (
            "export-heightfield",
            vec!["export-heightfield", "scene.toml", "--out", "map.txt"],
            "--out",
        ),
        (
            "stats --png",
            vec!["stats", "png.toml", "--png", "map.png"],
            "--png: map.png",
        ),
        (
            "render over the scene",
            [&["render", "scene.toml", "--out", "scene.toml"][..], &small].concat(),
            "scene.toml",
        ),
    ];
    for (case, args, expect) in &cases {
        let o = roks_in(&d, args);
        assert_refused(case, &o, &[expect, "a file this run reads"]);
        assert_eq!(snapshot(&d), before, "{case}");
    }
    // A hard link of the map is the map.
    std::fs::hard_link(d.join("map.txt"), d.join("alias.txt")).unwrap();
    let o = roks_in(&d, &["export-mesh", "scene.toml", "--out", "alias.txt"]);
    assert_refused("hard link", &o, &["alias.txt"]);
    assert_eq!(
        std::fs::read(d.join("map.txt")).unwrap(),
        map_text().as_bytes()
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `roks trace --out T` where T holds a table wall's brdf.csv, and `roks
/// merge A B --out A`: refused, nothing changed.
#[test]
fn tables_and_shards_are_not_replaced() {
    let d = scratch("trace");
    std::fs::write(
        d.join("m.toml"),
        bump_scene("m", "reflectance = 0.8", "", ""),
    )
    .unwrap();
    for args in [
        &["brdf", "m.toml", "--out", "t", "-q"][..],
        &[
            "brdf",
            "m.toml",
            "--out",
            "s0",
            "--shard",
            "0/2",
            "--photons",
            "8192",
            "-q",
        ],
        &[
            "brdf",
            "m.toml",
            "--out",
            "s1",
            "--shard",
            "1/2",
            "--photons",
            "8192",
            "-q",
        ],
    ] {
        let o = roks_in(&d, args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    std::fs::write(d.join("obj.toml"), object_scene("t/brdf.csv")).unwrap();
    let before = snapshot(&d);
    let o = roks_in(&d, &["trace", "obj.toml", "--out", "t/", "-q"]);
    assert_refused(
        "trace",
        &o,
        &["--out: t/: holds t/", "a file this run reads"],
    );
    let o = roks_in(&d, &["merge", "s0", "s1", "--out", "s1", "-q"]);
    assert_refused("merge", &o, &["--out: s1: is s1"]);
    assert_eq!(snapshot(&d), before);
    let _ = std::fs::remove_dir_all(&d);
}

/// `--out zz/` names a folder where a file is written: refused before the
/// work (main rendered, then failed with exit 1).
#[test]
fn a_folder_shaped_file_output_is_refused_up_front() {
    let d = scratch("slash");
    for args in [
        &["render", "--out", "zz/", "--size", "4,4", "--spp", "1"][..],
        &["export-mesh", "--out", "zz/", "--resolution", "4"],
        &["stats", "--png", "zz/"],
    ] {
        let o = roks_in(&d, args);
        assert_refused(args[0], &o, &["zz/", "names a folder"]);
        assert!(!d.join("zz").exists(), "{args:?}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A file name holding a newline is quoted escaped, on one line.
#[test]
fn a_newline_in_a_file_name_stays_on_one_line() {
    let d = scratch("newline");
    std::fs::write(d.join("a\nb.toml"), "not toml = = 1").unwrap();
    let o = roks_in(&d, &["brdf", "a\nb.toml"]);
    assert_refused("scene", &o, &["a\\nb.toml"]);
    let o = roks_in(
        &d,
        &["render", "--out", "x\ny/", "--size", "4,4", "--spp", "1"],
    );
    assert_refused("--out", &o, &["x\\ny/"]);
    let _ = std::fs::remove_dir_all(&d);
}

/// `render --spp 4294967295` (1.1e15 camera paths) is refused at once with
/// its estimate unless `--force-long-render`; the bound is stated.
#[test]
fn a_render_beyond_the_bound_is_refused_with_its_estimate() {
    let d = scratch("render-cost");
    let t = std::time::Instant::now();
    let o = roks_in(&d, &["render", "--out", "r.exr", "--spp", "4294967295"]);
    assert_refused(
        "spp",
        &o,
        &[
            "--spp",
            "1.126e15 camera paths",
            "1e10",
            "--force-long-render",
        ],
    );
    assert!(t.elapsed().as_secs() < 30, "{:?}", t.elapsed());
    assert!(!d.join("r.exr").exists());
    // Exactly at the bound: accepted by the check (not run here).
    assert!(roks::render::job::check_cost(100_000, 100_000, 1, 1, false).is_ok());
    assert!(roks::render::job::check_cost(100_000, 100_000, 2, 1, false).is_err());
    assert!(roks::render::job::check_cost(100_000, 100_000, 2, 1, true).is_ok());
    // One pixel below the path bound, above 2^24 samples per pixel (which
    // one core traces in sequence): refused unless forced.
    assert!(roks::render::job::check_cost(1, 1, 1 << 24, 2, false).is_ok());
    assert!(roks::render::job::check_cost(1, 1, (1 << 24) + 1, 2, false).is_err());
    assert!(roks::render::job::check_cost(1, 1, u32::MAX, 2, true).is_ok());
    let _ = std::fs::remove_dir_all(&d);
}

/// `wavelengths_um = { from, to, step, unit = "nm" }`: the unknown key is
/// refused (main ignored it).
#[test]
fn unknown_keys_of_the_wavelength_grid_are_refused() {
    let d = scratch("unit");
    let scene = bump_scene(
        "u",
        "reflectance = 0.8",
        "wavelengths_um = { from = 0.4, to = 0.6, step = 0.1, unit = \"nm\" }",
        "",
    );
    std::fs::write(d.join("u.toml"), scene).unwrap();
    let o = roks_in(&d, &["brdf", "u.toml", "--out", "o", "-q"]);
    assert_refused(
        "unit",
        &o,
        &["u.toml", "light.wavelengths_um", "no other key"],
    );
    assert!(!d.join("o").exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// A run with s-polarised light writes a brdf.csv (the BRDF of s light)
/// beside a mueller.csv (m00: the unpolarised BRDF); `roks trace` accepts
/// the pair as a wall (main refused it as "a file of another run?"). A
/// mueller.csv with |m01| = |m10| = 5 m00 in one cell is refused naming
/// the file, the line and the cell (main traced it with exit 0).
#[test]
fn polarised_tables_accepted_and_impossible_ones_refused() {
    let d = scratch("mueller");
    let fresnel = "n = 1.5\nk = 0.1";
    let scene = bump_scene(
        "f",
        fresnel,
        "polarisation = \"s\"",
        "polarisation = \"mueller\"",
    );
    std::fs::write(d.join("f.toml"), scene).unwrap();
    let o = roks_in(&d, &["brdf", "f.toml", "--out", "t", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::write(d.join("obj.toml"), object_scene("t/brdf.csv")).unwrap();
    let o = roks_in(&d, &["trace", "obj.toml", "--out", "o", "-q"]);
    assert!(
        o.status.success(),
        "s light: {}",
        String::from_utf8_lossy(&o.stderr)
    );

    let text = std::fs::read_to_string(d.join("t/mueller.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (c00, c01, c10) = (col("m00"), col("m01"), col("m10"));
    let mut f: Vec<String> = lines[5].split(',').map(str::to_owned).collect();
    let m00: f64 = f[c00].parse().unwrap();
    assert!(m00 > 0.0);
    f[c01] = format!("{}", 5.0 * m00);
    f[c10] = format!("{}", 5.0 * m00);
    lines[5] = f.join(",");
    std::fs::write(d.join("t/mueller.csv"), lines.join("\n") + "\n").unwrap();
    let o = roks_in(&d, &["trace", "obj.toml", "--out", "o", "-q"]);
    assert_refused(
        "impossible",
        &o,
        &[
            "t/mueller.csv",
            "line 6",
            "cell 4",
            "degree of polarisation",
            "> 1",
        ],
    );
    let _ = std::fs::remove_dir_all(&d);
}
