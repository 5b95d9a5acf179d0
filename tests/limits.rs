//! The memory budget and the bounded loads (of memory and of time): every
//! request sized by user input whose estimate exceeds the limit is refused
//! before allocating, with one line naming the file (when there is one), the
//! key or option, the estimate and the limit; exit
//! status 2; nothing written.
//!
//! Every run is under a virtual-memory limit of about 4 GB (`ulimit -v`), so
//! a request that allocated instead of being refused would fail the test
//! (abort, not status 2). Most cases set a small `ROKS_MAX_MEMORY` so the
//! outcome does not depend on this machine; the `far_above` cases use the
//! default limit with requests of terabytes.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cli_common::assert_input_error;

/// A fresh scratch folder for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-limits-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run `roks args` under `ulimit -v` (about 4 GB) with `ROKS_MAX_MEMORY`
/// set to `limit`, or unset (the default limit) for `None`.
fn roks_limited(limit: Option<&str>, args: &[&str]) -> Output {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg("ulimit -v 4000000; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_roks"))
        .args(args);
    match limit {
        Some(l) => c.env("ROKS_MAX_MEMORY", l),
        None => c.env_remove("ROKS_MAX_MEMORY"),
    };
    c.output().expect("run roks")
}

/// Write `text` to `dir/name` and return the path.
fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The memory refusal: a scene error naming `scene` and every `expect`,
/// the estimate ("would take about") and the limit's variable.
fn assert_refused(case: &str, o: &Output, scene: &Path, out: &Path, expect: &[&str]) {
    let mut all = expect.to_vec();
    all.extend([
        "would take about",
        "above the memory limit",
        "ROKS_MAX_MEMORY",
    ]);
    assert_input_error(case, o, scene, out, &all);
}

/// An option error: status 2, one line starting `roks: OPTION:` and holding
/// every `expect`, nothing on stdout, `out` not created.
fn assert_option_refused(case: &str, o: &Output, option: &str, out: &Path, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{case}: {} {stderr}", o.status);
    let line = stderr.trim_end_matches('\n');
    assert!(
        !line.is_empty() && !line.contains('\n'),
        "{case}: {stderr:?}"
    );
    assert!(
        line.starts_with(&format!("roks: {option}: ")),
        "{case}: {line}"
    );
    for e in expect
        .iter()
        .chain(&["would take about", "above the memory limit"])
    {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
    assert!(o.stdout.is_empty(), "{case}: stdout");
    assert!(!out.exists(), "{case}: {} was written", out.display());
}

const MATERIAL: &str = "[materials.paint]\nreflectance = 0.8\n";

fn bumps_scene(size: f64, count: usize, radius: f64) -> String {
    format!(
        "[surface]\nsize = [{size:?}, {size:?}]\nmaterial = \"paint\"\n{MATERIAL}\
         [[bumps]]\nshape = \"ellipsoid\"\ncount = {count}\nradius = {radius:?}\nheight = 1.0\n"
    )
}

#[test]
fn periodic_ghost_copies_are_refused_before_they_are_made() {
    let dir = scratch("ghosts");
    let out = dir.join("out");
    // One bump of radius 3 in a 0.001 cell: 3.6e7 copies (about 7.5 GB).
    let scene = write(&dir, "ghost.toml", &bumps_scene(0.001, 1, 3.0));
    let args = [
        "brdf",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let o = roks_limited(Some("1G"), &args);
    assert_refused(
        "ghosts",
        &o,
        &scene,
        &out,
        &["bumps[0]: periodic ghost copies", "3.6e7 solids"],
    );
    // The same with absorbing edges has no ghosts and runs (a short run).
    let edges = std::fs::read_to_string(&scene).unwrap().replace(
        "material = \"paint\"\n",
        "material = \"paint\"\nedges = \"absorbing\"\n",
    );
    let absorbing = write(&dir, "absorbing.toml", &edges);
    let o = roks_limited(
        Some("1G"),
        &["stats", absorbing.to_str().unwrap(), "--resolution", "16"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn far_above_the_machine_ghost_copies_are_refused_with_the_default_limit() {
    let dir = scratch("ghosts-far");
    let out = dir.join("out");
    // Radius 30 in a 0.001 cell: 3.6e9 copies, terabytes.
    let scene = write(&dir, "ghost.toml", &bumps_scene(0.001, 1, 30.0));
    let o = roks_limited(
        None,
        &[
            "brdf",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_refused("ghosts far", &o, &scene, &out, &["bumps[0]", "TiB"]);
}

#[test]
fn ten_million_bumps_are_refused_above_the_limit() {
    let dir = scratch("count");
    let out = dir.join("out");
    let scene = write(&dir, "many.toml", &bumps_scene(10_000.0, 10_000_000, 3.0));
    let args = [
        "brdf",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let o = roks_limited(Some("100M"), &args);
    assert_refused(
        "count",
        &o,
        &scene,
        &out,
        &["bumps[0].count", "10000000 bumps", "GiB", "100.0 MiB"],
    );
    // Several tables add up: the second one pushes the sum above the limit.
    let two = format!(
        "{}\n[[bumps]]\nshape = \"cone\"\ncount = 100000\nradius = 3.0\nheight = 1.0\n",
        bumps_scene(10_000.0, 20_000, 3.0)
    );
    let scene = write(&dir, "two.toml", &two);
    let o = roks_limited(Some("100M"), &["stats", scene.to_str().unwrap()]);
    assert_refused("two tables", &o, &scene, &out, &["bumps[1].count"]);
}

#[test]
fn height_fields_are_refused_by_their_size_before_synthesis_or_decoding() {
    let dir = scratch("fields");
    let out = dir.join("out");
    let gaussian = format!(
        "[surface]\nsize = [1000.0, 1000.0]\nmaterial = \"paint\"\n\
         heightfield = {{ gaussian = {{ sigma = 1.0, tau = 5.0 }}, resolution = 16384 }}\n{MATERIAL}"
    );
    let scene = write(&dir, "gauss.toml", &gaussian);
    let o = roks_limited(
        Some("100M"),
        &[
            "brdf",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_refused(
        "gaussian 16384",
        &o,
        &scene,
        &out,
        &[
            "surface.heightfield.resolution",
            "16384 x 16384 height field",
            "15.0 GiB",
        ],
    );

    // A 69-byte PNG whose header declares 12000 x 12000 pixels (its data is
    // truncated: decoding it would fail, so the refusal comes from the header).
    std::fs::write(dir.join("big.png"), png_header_only(12_000, 12_000)).unwrap();
    let map = format!(
        "[surface]\nmaterial = \"paint\"\n\
         heightfield = {{ file = \"big.png\", pixel = 0.5, height_scale = 1e-4 }}\n{MATERIAL}"
    );
    let scene = write(&dir, "png.toml", &map);
    let o = roks_limited(Some("100M"), &["stats", scene.to_str().unwrap()]);
    assert_refused(
        "png 12000",
        &o,
        &scene,
        &out,
        &[
            "surface.heightfield.file",
            "big.png",
            "12000 x 12000 height map",
        ],
    );
    // Far above any machine: 10^6 x 10^6 pixels, default limit.
    std::fs::write(dir.join("big.png"), png_header_only(1_000_000, 1_000_000)).unwrap();
    let o = roks_limited(None, &["stats", scene.to_str().unwrap()]);
    assert_refused(
        "png 1e6",
        &o,
        &scene,
        &out,
        &["surface.heightfield.file", "TiB"],
    );
}

#[test]
fn exr_headers_are_read_before_the_pixels() {
    let dir = scratch("exr");
    let out = dir.join("out");
    // A 4 x 4 map written by roks, its data and display windows then edited
    // to declare 12000 x 12000 pixels (431 bytes; decoding would fail).
    let small = dir.join("small.exr");
    let o = roks_limited(
        None,
        &[
            "export-heightfield",
            "--out",
            small.to_str().unwrap(),
            "--resolution",
            "4",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut bytes = std::fs::read(&small).unwrap();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = bytes.windows(name.len()).position(|w| w == name).unwrap() + name.len() + 4;
        let window: Vec<u8> = [0i32, 0, 11_999, 11_999]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        bytes[at..at + 16].copy_from_slice(&window);
    }
    std::fs::write(dir.join("big.exr"), bytes).unwrap();
    let map = format!(
        "[surface]\nmaterial = \"paint\"\nheightfield = {{ file = \"big.exr\", pixel = 0.5 }}\n{MATERIAL}"
    );
    let scene = write(&dir, "exr.toml", &map);
    let o = roks_limited(Some("100M"), &["stats", scene.to_str().unwrap()]);
    assert_refused(
        "exr 12000",
        &o,
        &scene,
        &out,
        &[
            "surface.heightfield.file",
            "big.exr",
            "12000 x 12000 height map",
            "8.0 GiB",
        ],
    );
}

/// A 16-bit grayscale PNG of `w x h` with a valid header and almost no data.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    fn crc(bytes: &[u8]) -> u32 {
        let mut c = 0xffff_ffff_u32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    0xedb8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    fn chunk(out: &mut Vec<u8>, kind: &[u8], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend(data);
        out.extend(&body);
        out.extend(crc(&body).to_be_bytes());
    }
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([16, 0, 0, 0, 0]);
    chunk(&mut png, b"IHDR", &ihdr);
    // zlib stream of 8 zero bytes (stored block).
    let idat = [
        0x78, 0x01, 0x01, 0x08, 0x00, 0xf7, 0xff, 0, 0, 0, 0, 0, 0, 0, 0, 0x00, 0x08, 0x00, 0x01,
    ];
    chunk(&mut png, b"IDAT", &idat);
    chunk(&mut png, b"IEND", &[]);
    png
}

#[test]
fn statistics_maps_are_refused_above_the_limit() {
    let dir = scratch("stats");
    let out = dir.join("out");
    let scene = write(&dir, "s.toml", &bumps_scene(30.0, 10, 3.0));
    let s = scene.to_str().unwrap();
    let o = roks_limited(
        None,
        &[
            "brdf",
            s,
            "--out",
            out.to_str().unwrap(),
            "--stats-resolution",
            "100000",
        ],
    );
    assert_option_refused(
        "brdf stats",
        &o,
        "--stats-resolution",
        &out,
        &["100000 x 100000"],
    );
    let o = roks_limited(None, &["stats", s, "--resolution", "100000"]);
    assert_option_refused("stats", &o, "--resolution", &out, &["GiB"]);
    // Small limit (above the scene's run of 10 incidences), moderate map.
    let o = roks_limited(Some("32M"), &["stats", s, "--resolution", "2048"]);
    assert_option_refused("stats 2048", &o, "--resolution", &out, &["32.0 MiB"]);
}

#[test]
fn brdf_tallies_are_refused_above_the_limit_for_the_scene_and_with_options() {
    let dir = scratch("tallies");
    let out = dir.join("out");
    let text = format!(
        "{}[light]\ntheta_deg = [0, 30, 60]\nphotons = 1000000\n[tally]\nbands = 1000\n",
        bumps_scene(30.0, 10, 3.0)
    );
    let scene = write(&dir, "bands.toml", &text);
    let s = scene.to_str().unwrap();
    let o = roks_limited(Some("200M"), &["brdf", s, "--out", out.to_str().unwrap()]);
    assert_refused(
        "bands",
        &o,
        &scene,
        &out,
        &["tally.bands", "1000 Carlson bands for 3 incidences"],
    );
    // 100 bands fit in 500M (the scene loads); with the options' Mueller sums
    // and lattice replicates (17 x 17 as many sums) they do not.
    let scene = write(
        &dir,
        "b100.toml",
        &text.replace("bands = 1000", "bands = 100"),
    );
    let s = scene.to_str().unwrap();
    let o = roks_limited(Some("500M"), &["stats", s, "--resolution", "8"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = roks_limited(
        Some("500M"),
        &[
            "brdf",
            s,
            "--out",
            out.to_str().unwrap(),
            "--polarisation",
            "mueller",
            "--launch",
            "lattice",
        ],
    );
    assert_refused(
        "mueller option",
        &o,
        &scene,
        &out,
        &["tally.bands", "Mueller sums and lattice replicates"],
    );
}

const OBJECT: &str = r#"
[quadrics]
s = { sphere = { center = [0.0, 0.0, 0.0], r = 10.0 } }

[[cells]]
name = "ball"
region = "-s"
fill = "solid"

[walls]
s = "m"

[models.m]
reflectance = 0.5

[[sources]]
beam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }
"#;

#[test]
fn object_sweeps_and_far_fields_are_refused_above_the_limit() {
    let dir = scratch("sweep");
    let out = dir.join("out");
    let text = format!(
        "{OBJECT}sweep = {{ from = [0.0, 0.0, 20.0], to = [5.0, 0.0, 20.0], steps = 1000000000 }}\nphotons = 100\n"
    );
    let scene = write(&dir, "sweep.toml", &text);
    let o = roks_limited(
        None,
        &[
            "trace",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_refused(
        "sweep",
        &o,
        &scene,
        &out,
        &["sources[0].sweep.steps", "1000000000 beam positions"],
    );
    // One position, but a far field of 1000 bands with Stokes sums.
    let text = format!(
        "{OBJECT}position = [0.0, 0.0, 20.0]\nphotons = 100\n[tally]\nbands = 1000\nfarfield = true\npolarisation = \"stokes\"\n"
    );
    let scene = write(&dir, "farfield.toml", &text);
    let o = roks_limited(
        Some("1G"),
        &[
            "trace",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_refused(
        "farfield",
        &o,
        &scene,
        &out,
        &["tally.bands", "1 beam positions"],
    );
}

#[test]
fn render_images_are_refused_above_the_limit() {
    let dir = scratch("render");
    let out = dir.join("x.exr");
    let o_ = out.to_str().unwrap();
    let o = roks_limited(None, &["render", "--out", o_, "--size", "100000,100000"]);
    assert_option_refused("micro", &o, "--size", &out, &["100000 x 100000 image"]);
    let object = write(
        &dir,
        "obj.toml",
        &format!("{OBJECT}position = [0.0, 0.0, 20.0]\nphotons = 100\n"),
    );
    let o = roks_limited(
        None,
        &[
            "render",
            object.to_str().unwrap(),
            "--out",
            o_,
            "--size",
            "100000,100000",
        ],
    );
    assert_option_refused("object", &o, "--size", &out, &["GiB"]);
    // A product beyond 2^64 saturates instead of wrapping.
    let o = roks_limited(
        None,
        &["render", "--out", o_, "--size", "10000000000,10000000000"],
    );
    assert_option_refused("overflow", &o, "--size", &out, &["TiB"]);
    assert!(!dir.join("x.png").exists());
}

#[test]
fn meshes_and_exported_maps_are_refused_above_the_limit() {
    let dir = scratch("mesh");
    let out = dir.join("m.ply");
    let o_ = out.to_str().unwrap();
    let o = roks_limited(None, &["export-mesh", "--out", o_, "--resolution", "46339"]);
    assert_option_refused("micro mesh", &o, "--resolution", &out, &["46339 x 46339"]);
    let object = write(
        &dir,
        "obj.toml",
        &format!("{OBJECT}position = [0.0, 0.0, 20.0]\nphotons = 100\n"),
    );
    let o = roks_limited(
        None,
        &[
            "export-mesh",
            object.to_str().unwrap(),
            "--out",
            o_,
            "--bounds=-10,-10,-10,10,10,10",
            "--resolution",
            "2048",
        ],
    );
    assert_option_refused("object mesh", &o, "--resolution", &out, &["voxel grid"]);
    let map = dir.join("h.exr");
    let o = roks_limited(
        Some("100M"),
        &[
            "export-heightfield",
            "--out",
            map.to_str().unwrap(),
            "--resolution",
            "16384",
        ],
    );
    assert_option_refused("heightfield", &o, "--resolution", &map, &["16384 x 16384"]);
}

#[test]
fn long_regions_are_refused_at_once_and_load_linearly() {
    let dir = scratch("region");
    let out = dir.join("out");
    // 100000 terms over 100000 distinct surfaces (took about two minutes to
    // refuse before; now the first term beyond 4096 stops the parse).
    let n = 100_000;
    let mut text = String::from("[quadrics]\n");
    for i in 0..n {
        text += &format!(
            "p{i} = {{ plane = [0.0, 0.0, 1.0, {:?}] }}\n",
            -1.0 - i as f64 * 1e-3
        );
    }
    let terms: Vec<String> = (0..n).map(|i| format!("-p{i}")).collect();
    text += &format!(
        "[[cells]]\nname = \"b\"\nfill = \"solid\"\nregion = \"{}\"\n",
        terms.join(" ")
    );
    text += "[models.m]\nreflectance = 0.5\n[[sources]]\nbeam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }\nposition = [0.0, 0.0, 10.0]\nphotons = 100\n";
    let scene = write(&dir, "long.toml", &text);
    let o = roks_limited(
        None,
        &[
            "trace",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_input_error(
        "terms",
        &o,
        &scene,
        &out,
        &["cells[0].region", "more than 4096 half-spaces"],
    );
    // 4096 terms over 4096 surfaces: the 17th distinct surface stops it.
    let few: Vec<String> = (0..4096).map(|i| format!("-p{i}")).collect();
    let text = text.replace(&terms.join(" "), &few.join(" "));
    let scene = write(&dir, "many.toml", &text);
    let o = roks_limited(
        None,
        &[
            "trace",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_input_error(
        "surfaces",
        &o,
        &scene,
        &out,
        &["cells[0].region", "more than 16 surfaces"],
    );
}

#[test]
fn a_bad_memory_limit_is_one_line_naming_the_variable() {
    for bad in ["abc", "-1G", "0", "1.5X", ""] {
        let o = roks_limited(Some(bad), &["stats", "--resolution", "8"]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {stderr}");
        let line = stderr.trim_end_matches('\n');
        assert!(!line.contains('\n'), "{bad:?}: {stderr}");
        assert!(
            line.starts_with("roks: ROKS_MAX_MEMORY: "),
            "{bad:?}: {line}"
        );
        assert!(line.contains(&format!("`{bad}`")), "{bad:?}: {line}");
        assert!(o.stdout.is_empty());
    }
}

#[test]
fn valid_runs_pass_a_modest_limit_with_suffixes() {
    let dir = scratch("valid");
    let out = dir.join("out");
    let o = roks_limited(
        Some("512M"),
        &[
            "brdf",
            "--out",
            out.to_str().unwrap(),
            "--photons",
            "4096",
            "--theta",
            "30",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("summary.json").exists());
    let o = roks_limited(Some("1.5G"), &["stats", "--resolution", "256"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn worker_threads_are_refused_above_the_limit() {
    let dir = scratch("threads");
    let out = dir.join("out");
    // A million threads were spawned for minutes before; now refused at once.
    let o = roks_limited(
        None,
        &[
            "brdf",
            "--out",
            out.to_str().unwrap(),
            "--photons",
            "4096",
            "--threads",
            "1000000",
        ],
    );
    assert_option_refused(
        "threads",
        &o,
        "--threads",
        &out,
        &["1000000 worker threads", "TiB"],
    );
}

/// Input files are read up to a bound (a scene file 64 MiB, a data file an
/// eighth of the memory limit), so an endless or huge file is one line,
/// exit 2, in bounded memory: `/dev/zero` as the scene and as the measured
/// BRDF of `fit`, a 13 MiB file as an angle table and as an nk table, and a
/// 70 MB scene of comment lines (before the bound, it went to the TOML
/// parser, which asked for several times its size and aborted under the
/// 4 GB address-space limit: found by fuzzing).
#[test]
fn endless_and_huge_input_files_are_refused_in_bounded_memory() {
    let dir = scratch("endless");
    let out = dir.join("out");
    let micro = |material: &str, extra: &str| {
        format!(
            "[surface]\nsize = [30.0, 30.0]\nedges = \"periodic\"\nmaterial = \"m\"\n{extra}\n[materials.m]\n{material}\n[light]\ntheta_deg = [30]\nwavelengths_um = [0.5]\n"
        )
    };
    let zero = Path::new("/dev/zero");
    let o = roks_limited(Some("100M"), &["stats", "/dev/zero"]);
    assert_input_error("stats /dev/zero", &o, zero, &out, &["larger than 64.0 MiB"]);
    // A file a scene reads must be a regular file (a device is refused
    // before it is opened: tests/scene_errors.rs), so the bound is shown on
    // a sparse regular file of 13 MiB (an nk table is named by its
    // extension: .csv).
    let big = dir.join("zero.csv");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(13 << 20)
        .unwrap();
    for (case, key, file) in [
        ("table", "materials.m.table", big.to_str().unwrap()),
        ("nk", "materials.m.nk", big.to_str().unwrap()),
    ] {
        let text = micro(&format!("{case} = \"{file}\""), "");
        let scene = write(&dir, &format!("{case}.toml"), &text);
        let o = roks_limited(Some("100M"), &["stats", scene.to_str().unwrap()]);
        assert_input_error(case, &o, &scene, &out, &[key, file, "larger than 12.5 MiB"]);
    }
    let scene = write(&dir, "s.toml", &micro("reflectance = 0.5", ""));
    let o = roks_limited(
        Some("100M"),
        &[
            "fit",
            scene.to_str().unwrap(),
            "/dev/zero",
            "--param",
            "materials.m.reflectance=0.1:0.9",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let line = String::from_utf8_lossy(&o.stderr);
    assert!(
        line.contains("/dev/zero") && line.contains("larger than"),
        "{line}"
    );
    assert!(!out.exists());
    let big = dir.join("big.toml");
    std::fs::write(&big, "#".repeat(70 << 20)).unwrap();
    let o = roks_limited(None, &["stats", big.to_str().unwrap()]);
    assert_input_error("a 70 MB scene", &o, &big, &out, &["larger than 64.0 MiB"]);
}
