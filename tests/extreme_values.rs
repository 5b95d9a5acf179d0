//! Extreme values: values that used to pass validation and then
//! panic, hang or overflow are refused with one line naming the file and the
//! key (exit status 2, nothing written); work that used to never end is
//! bounded, and what a bound cuts is counted in `summary.json`.
//!
//! Every run is watched by a hang detector (killed after 60 s): a kill is a
//! hang, not a slow run.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::Output;

use cli_common::{assert_input_error, roks_within};
use serde_json::Value;

/// Most periodic crossings of one flight (`roks::micro::MAX_CROSSINGS`).
const MAX_CROSSINGS: u64 = roks::micro::MAX_CROSSINGS as u64;

/// A fresh, empty scratch folder for this test process.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-extremes-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run `roks args`, killing it after 60 s (a hang).
fn roks_watched(case: &str, args: &[&str]) -> Output {
    roks_within(args, 60)
        .unwrap_or_else(|| panic!("{case}: roks {args:?} hung (killed after 60 s)"))
}

/// The micro scene of a case: `[surface]` lines, then the rest.
fn scene_text(surface: &str, rest: &str) -> String {
    format!(
        "[surface]\n{surface}\nedges = \"periodic\"\nmaterial = \"m\"\n\n[materials.m]\nreflectance = 0.8\n\n{rest}\n[light]\ntheta_deg = [30]\nphotons = 100\n"
    )
}

/// Bumps of one table with the given extra lines (defaults as the default scene's).
fn bumps(lines: &str) -> String {
    let mut keys = vec![
        ("shape", "\"ellipsoid\""),
        ("count", "10"),
        ("radius", "[2.5, 3.5]"),
        ("height", "[0.8, 4.8]"),
    ];
    let given: Vec<(&str, &str)> = lines.lines().filter_map(|l| l.split_once(" = ")).collect();
    keys.retain(|(k, _)| !given.iter().any(|(g, _)| g == k));
    keys.extend(given);
    let body: String = keys.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
    format!("[[bumps]]\n{body}")
}

/// Write the scene (and `files` beside it), run `roks brdf` on it, and check
/// the bad-input contract.
fn refused(case: &str, text: &str, files: &[(&str, String)], args: &[&str], expect: &[&str]) {
    let dir = scratch(case);
    for (name, content) in files {
        std::fs::write(dir.join(name), content).unwrap();
    }
    let scene = dir.join(format!("{case}.toml"));
    std::fs::write(&scene, text).unwrap();
    let out = dir.join("out");
    let mut all = vec![
        "brdf",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    all.extend_from_slice(args);
    let o = roks_watched(case, &all);
    assert_input_error(case, &o, &scene, &out, expect);
}

/// A text height map of `nx x ny` heights `h(i, j)`.
fn text_map(nx: usize, ny: usize, h: impl Fn(usize, usize) -> f64) -> String {
    (0..ny)
        .map(|j| {
            (0..nx)
                .map(|i| format!("{:e}", h(i, j)))
                .collect::<Vec<_>>()
                .join(" ")
                + "\n"
        })
        .collect()
}

/// Values that passed validation and then panicked (non-finite heights or
/// sizes in the height field) or hung (ghosts of huge bounds, flights that
/// cannot descend at heights that do not resolve the cell): each refused
/// with its key.
#[test]
fn derived_lengths_are_checked_where_the_scene_is_built() {
    let checker = text_map(4, 4, |i, j| ((i + j) % 2) as f64);
    let huge = text_map(4, 4, |i, j| if (i + j) % 2 == 0 { 1e300 } else { 0.0 });
    let big = text_map(4, 4, |i, j| if (i + j) % 2 == 0 { 1e20 } else { 0.0 });
    let map = |spec: &str| {
        scene_text(
            &format!("heightfield = {{ file = \"map.txt\", {spec} }}"),
            "",
        )
    };
    let gaussian = |size: &str, sigma: &str, tau: &str| {
        scene_text(
            &format!(
                "size = {size}\nheightfield = {{ gaussian = {{ sigma = {sigma}, tau = {tau} }}, resolution = 64 }}"
            ),
            "",
        )
    };
    // (case, scene text, files beside it, expected texts)
    type Case<'a> = (&'a str, String, Vec<(&'a str, String)>, Vec<&'a str>);
    let cases: Vec<Case> = vec![
        // tau far beyond the cell: every mode of the spectrum underflowed
        // (NaN heights, a panic).
        (
            "gaussian-tau",
            gaussian("[64.0, 64.0]", "1.0", "1e6"),
            vec![],
            vec!["surface.heightfield.gaussian.tau", "exceeds the cell"],
        ),
        (
            "gaussian-tau-just-above",
            gaussian("[64.0, 32.0]", "1.0", "64.5"),
            vec![],
            vec!["surface.heightfield.gaussian.tau", "64.5"],
        ),
        // sigma = 1e300: heights overflowed f32 (a panic).
        (
            "gaussian-sigma-huge",
            gaussian("[64.0, 64.0]", "1e300", "11.9"),
            vec![],
            vec!["surface.heightfield.gaussian.sigma", "1e300 is outside"],
        ),
        (
            "gaussian-sigma-tiny",
            gaussian("[64.0, 64.0]", "1e-300", "11.9"),
            vec![],
            vec!["surface.heightfield.gaussian.sigma", "1e-300 is outside"],
        ),
        // Finite but 1e10 cells tall (a hang).
        (
            "gaussian-sigma-tall",
            gaussian("[64.0, 64.0]", "1e12", "11.9"),
            vec![],
            vec!["surface.heightfield.gaussian.sigma", "times the cell"],
        ),
        // A height map whose pixel overflows the size.
        (
            "map-pixel-huge",
            map("pixel = 1e300"),
            vec![("map.txt", checker.clone())],
            vec!["surface.heightfield.pixel", "1e300 is outside"],
        ),
        (
            "map-pixel-times-count",
            map("pixel = 5e29"),
            vec![("map.txt", checker.clone())],
            vec!["surface.heightfield.pixel", "4 x 4 pixels"],
        ),
        (
            "map-pixel-subnormal",
            map("pixel = 5e-324"),
            vec![("map.txt", checker.clone())],
            vec!["surface.heightfield.pixel", "5e-324 is outside"],
        ),
        // Heights that overflow to infinity after scaling (a panic), or
        // stay finite but beyond the largest length.
        (
            "map-scale-to-infinity",
            map("pixel = 1.0, height_scale = 1e10"),
            vec![("map.txt", huge.clone())],
            vec!["surface.heightfield.height_scale", "a height of inf"],
        ),
        (
            "map-scale-beyond",
            map("pixel = 1.0, height_scale = 1e20"),
            vec![("map.txt", big)],
            vec!["surface.heightfield.height_scale", "1e40"],
        ),
        // Heights of 1e300 in the file itself (trapped the walk).
        (
            "map-heights-1e300",
            map("pixel = 1.0"),
            vec![("map.txt", huge)],
            vec!["surface.heightfield.file", "a height of 1e300"],
        ),
        // Heights of 1 over pixels of 1e-12: 2.5e11 cells tall.
        (
            "map-tall-over-tiny-pixels",
            map("pixel = 1e-12"),
            vec![("map.txt", checker)],
            vec!["surface.heightfield.file", "times the cell"],
        ),
        // Bumps: lengths beyond the traced range, and needles that no
        // position resolves.
        (
            "bump-height-1e300",
            scene_text("size = [30.0, 30.0]", &bumps("height = 1e300")),
            vec![],
            vec!["bumps[0].height", "1e300 is outside"],
        ),
        (
            "bump-radius-1e-300",
            scene_text("size = [30.0, 30.0]", &bumps("radius = 1e-300")),
            vec![],
            vec!["bumps[0].radius", "1e-300 is outside"],
        ),
        (
            "bump-radius-y-subnormal",
            scene_text("size = [30.0, 30.0]", &bumps("radius_y = [5e-324, 1.0]")),
            vec![],
            vec!["bumps[0].radius_y", "5e-324 is outside"],
        ),
        (
            "bump-depth-1e300",
            scene_text("size = [30.0, 30.0]", &bumps("depth = 1e300")),
            vec![],
            vec!["bumps[0].depth", "1e300 is outside"],
        ),
        (
            "bump-needles",
            scene_text(
                "size = [30.0, 30.0]",
                &bumps("shape = \"cylinder\"\nheight = 1e20"),
            ),
            vec![],
            vec!["bumps[0].height", "times the cell"],
        ),
        (
            "bump-base-footprint",
            scene_text(
                "size = [30.0, 30.0]",
                &bumps("shape = \"ellipsoid_on_hyperboloid\"\nbase = 1e40"),
            ),
            vec![],
            vec!["bumps[0].base", "radius * base"],
        ),
        (
            "size-1e300",
            scene_text("size = [1e300, 30.0]", &bumps("")),
            vec![],
            vec!["surface.size[0]", "1e300 is outside"],
        ),
        (
            "size-tiny",
            scene_text("size = [30.0, 1e-31]", &bumps("")),
            vec![],
            vec!["surface.size[1]", "1e-31 is outside"],
        ),
    ];
    for (case, text, files, expect) in &cases {
        refused(case, text, files, &[], expect);
    }
}

/// A bad option: exit status 2, one stderr line naming the option and every
/// `expect` text, nothing on stdout, no output folder.
fn assert_option_error(case: &str, o: &Output, out: &Path, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{case}: {stderr}");
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    let line = stderr.trim_end_matches('\n');
    assert!(
        !line.is_empty() && !line.contains('\n'),
        "{case}: {stderr:?}"
    );
    for e in expect {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
    assert!(o.stdout.is_empty(), "{case}: stdout");
    assert!(!out.exists(), "{case}: output folder was created");
}

/// More than 2^53 photons per incidence cannot be counted by the f64
/// tallies: refused (the option or the key), from the command line, the
/// scene, lattice and sharded runs, object scenes and `roks trace`.
#[test]
fn photon_counts_beyond_the_tallies_are_refused() {
    let dir = scratch("photons");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap();
    let default_cases: [(&str, &[&str]); 4] = [
        ("cli-1e18", &["--photons", "1000000000000000000"]),
        ("cli-2^53+1", &["--photons", "9007199254740993"]),
        (
            "cli-lattice",
            &["--photons", "9007199254741008", "--launch", "lattice"],
        ),
        (
            "cli-shard",
            &["--photons", "1000000000000000000", "--shard", "0/2"],
        ),
    ];
    for (case, args) in default_cases {
        let mut all = vec!["brdf", "--out", out_s, "-q"];
        all.extend_from_slice(args);
        let o = roks_watched(case, &all);
        assert_option_error(case, &o, &out, &["--photons", "2^53"]);
    }
    let text = scene_text("size = [30.0, 30.0]", &bumps(""))
        .replace("photons = 100\n", "photons = 9007199254740993\n");
    refused("scene-photons", &text, &[], &[], &["light.photons", "2^53"]);

    // An object scene: a flat plate lit from above.
    let object = r#"
[quadrics]
p = { plane = [0.0, 0.0, 1.0, 0.0] }
s = { sphere = { center = [0.0, 0.0, 0.0], r = 5.0 } }

[[cells]]
name = "plate"
region = "-p -s"
fill = "solid"

[walls]
p = "paint"
s = "paint"

[models.paint]
diffuse = 0.5

[[sources]]
beam = { direction = [0.0, 0.0, -1.0], diameter = 1.0 }
position = [0.0, 0.0, 2.0]
photons = 100
"#;
    let scene = dir.join("object.toml");
    std::fs::write(&scene, object).unwrap();
    let scene_s = scene.to_str().unwrap();
    let o = roks_watched(
        "trace-cli",
        &[
            "trace",
            scene_s,
            "--out",
            out_s,
            "-q",
            "--photons",
            "9007199254740993",
        ],
    );
    assert_option_error("trace-cli", &o, &out, &["--photons", "2^53"]);
    let bad = dir.join("object-photons.toml");
    std::fs::write(
        &bad,
        object.replace("photons = 100", "photons = 18000000000000000000"),
    )
    .unwrap();
    let o = roks_watched(
        "trace-scene",
        &["trace", bad.to_str().unwrap(), "--out", out_s, "-q"],
    );
    assert_input_error(
        "trace-scene",
        &o,
        &bad,
        &out,
        &["sources[0].photons", "2^53"],
    );
}

/// `summary.json` of a finished run in `out`, its first incidence.
fn first_incidence(out: &Path) -> Value {
    let s: Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    s["incidence"][0].clone()
}

/// Run `roks brdf scene` into a fresh `out`, expecting success.
fn completes(case: &str, scene: &Path, args: &[&str]) -> Value {
    let out = scene.with_extension("out");
    let _ = std::fs::remove_dir_all(&out);
    let mut all = vec![
        "brdf",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    all.extend_from_slice(args);
    let o = roks_watched(case, &all);
    assert!(
        o.status.success(),
        "{case}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    first_incidence(&out)
}

/// Grazing incidence (89.9999999 deg, about 1/cos = 5.7e8 cell sides per
/// flight before it meets the substrate) completes: flights that cross
/// `MAX_CROSSINGS` periodic sides without meeting anything are cut and
/// counted as capped, with their whole weight in `lost_cap`. A black box
/// (reflectance 0) on half the rows of the cell absorbs the other photons at
/// their first hit, so every photon is either absorbed or capped.
#[test]
fn grazing_flights_are_cut_after_a_bounded_number_of_crossings() {
    let dir = scratch("grazing");
    let scene = dir.join("grazing.toml");
    std::fs::write(
        &scene,
        r#"
[surface]
size = [10.0, 10.0]
edges = "periodic"
material = "black"

[materials.black]
reflectance = 0.0

[quadrics]
x0 = { plane = [1.0, 0.0, 0.0, 0.0] }
x1 = { plane = [1.0, 0.0, 0.0, 1.0] }
y0 = { plane = [0.0, 1.0, 0.0, 0.0] }
y1 = { plane = [0.0, 1.0, 0.0, 5.0] }
top = { plane = [0.0, 0.0, 1.0, 1.0] }

[[bodies]]
region = "+x0 -x1 +y0 -y1 -top"

[light]
theta_deg = [89.9999999]
photons = 32
"#,
    )
    .unwrap();
    let inc = completes("grazing", &scene, &[]);
    let photons = inc["photons"].as_u64().unwrap();
    let capped = inc["capped_photons"].as_u64().unwrap();
    let segments = inc["segments"].as_u64().unwrap();
    assert_eq!(photons, 32);
    assert_eq!(inc["reflectance"].as_f64(), Some(0.0));
    assert!(
        capped >= 1 && capped < photons,
        "capped {capped} of {photons}"
    );
    // Each capped photon carried weight 1 into the cap.
    assert_eq!(
        inc["lost_cap"].as_f64(),
        Some(capped as f64 / photons as f64),
        "{inc}"
    );
    // A capped flight made exactly MAX_CROSSINGS segments, an absorbed one
    // fewer (it met the box before the cap).
    assert!(segments >= capped * MAX_CROSSINGS, "{segments}");
    assert!(segments < photons * MAX_CROSSINGS, "{segments}");
}

/// A run where every photon escaped (nothing capped or lost) within
/// `max_segments` segments, on a material of reflectance 0.8 a bounce: the
/// reflectance is the mean of 0.8^bounces, between 0.8^(mean bounces)
/// (Jensen) and 0.8.
fn assert_all_escaped_at_0_8_a_bounce(case: &str, inc: &Value, max_segments: u64) {
    assert_eq!(inc["capped_photons"].as_u64(), Some(0), "{case}: {inc}");
    assert_eq!(inc["lost"].as_f64(), Some(0.0), "{case}: {inc}");
    let segments = inc["segments"].as_u64().unwrap();
    assert!(segments <= max_segments, "{case}: {segments} segments");
    let (r, bounces) = (
        inc["reflectance"].as_f64().unwrap(),
        inc["mean_bounces"].as_f64().unwrap(),
    );
    assert!(
        bounces >= 1.0 && r <= 0.8 + 1e-12 && r >= 0.8_f64.powf(bounces) - 1e-12,
        "{case}: {inc}"
    );
}

/// A height field of 1e8 tall spikes on a 64 x 64 grid of pitch 1 (1.6e6
/// cells tall, within the limit): flights from the launch plane at 30 deg
/// descend 9e5 periods before reaching the lowest vertex. The walk skips the
/// periods in which they pass above the field (within the coarse tolerance,
/// 1e-9 of the 1e8 scale times the spike's slope 1e8, for the first 8e5
/// periods it could not: the photons were capped before); so no photon is
/// capped, each walk is short, and each photon escapes after reflecting at
/// 0.8 a bounce.
#[test]
fn tall_height_fields_are_walked_in_a_bounded_number_of_periods() {
    let dir = scratch("tall-field");
    let map = text_map(64, 64, |i, j| if i == 0 && j == 0 { 1e8 } else { 0.0 });
    std::fs::write(dir.join("spike.txt"), map).unwrap();
    let scene = dir.join("spike.toml");
    std::fs::write(
        &scene,
        scene_text("heightfield = { file = \"spike.txt\", pixel = 1.0 }", "")
            .replace("photons = 100", "photons = 16"),
    )
    .unwrap();
    let inc = completes("tall-field", &scene, &[]);
    // A walk is one segment, a skip starts another: a handful per photon.
    assert_all_escaped_at_0_8_a_bounce("tall-field", &inc, 16 * 64);
}

/// Grazing incidence on the default scene's bumps along a lattice direction
/// of the cell (azimuth 0, 90, and the diagonal 45 deg of the square cell):
/// each flight passes over the same folded path, a little lower each
/// period, until it meets the highest bump on that path (5.7e8 cell sides
/// away in the worst case). The periods above every solid it can meet are
/// skipped exactly, so no photon is capped, and every photon meets a bump
/// top once and escapes (reflectance 0.8, the material's, exactly).
#[test]
fn grazing_flights_along_the_lattice_skip_the_periods_above_everything() {
    let dir = scratch("skip");
    let default = include_str!("../scenes/default.toml");
    for phi in ["0.0", "45.0", "90.0"] {
        let scene = dir.join(format!("graze-{phi}.toml"));
        let text = default
            .replace("phi_deg = 0.0", &format!("phi_deg = {phi}"))
            .replace(
                "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
                "theta_deg = [89.9999999]",
            )
            .replace("photons = 1000000", "photons = 64");
        assert!(text.contains("[89.9999999]") && text.contains("photons = 64"));
        std::fs::write(&scene, text).unwrap();
        let inc = completes(&format!("graze-{phi}"), &scene, &[]);
        assert_eq!(inc["capped_photons"].as_u64(), Some(0), "phi {phi}: {inc}");
        assert_eq!(inc["lost"].as_f64(), Some(0.0), "phi {phi}: {inc}");
        let r = inc["reflectance"].as_f64().unwrap();
        assert!((r - 0.8).abs() < 1e-12, "phi {phi}: reflectance {r}");
        assert_eq!(inc["mean_bounces"].as_f64(), Some(1.0), "phi {phi}: {inc}");
    }
}

/// The same on a Gaussian height field (aluminium, 64 x 64 squares): the
/// walk skips, exactly, the periods in which the flight passes above the
/// surface along its folded path, so grazing flights along the lattice meet
/// the field instead of being capped (before: most were, after 2^24 steps).
#[test]
fn grazing_flights_over_a_height_field_skip_the_periods_above_it() {
    let dir = scratch("skip-field");
    for phi in ["0.0", "45.0", "90.0"] {
        let scene = dir.join(format!("field-{phi}.toml"));
        std::fs::write(
            &scene,
            format!(
                r#"
[surface]
size = [64.0, 64.0]
material = "al"
heightfield = {{ gaussian = {{ sigma = 1.0, tau = 11.9 }}, resolution = 64, seed = 3 }}

[materials.al]
n = 1.015
k = 6.627

[light]
theta_deg = [89.9999999]
phi_deg = {phi}
photons = 64
"#
            ),
        )
        .unwrap();
        let inc = completes(&format!("field-{phi}"), &scene, &[]);
        assert_eq!(inc["capped_photons"].as_u64(), Some(0), "phi {phi}: {inc}");
        assert_eq!(inc["lost"].as_f64(), Some(0.0), "phi {phi}: {inc}");
        let r = inc["reflectance"].as_f64().unwrap();
        assert!(r > 0.9 && r <= 1.0, "phi {phi}: reflectance {r}");
    }
}

/// One ulp below 90 degrees (89.99999999999999, d.z = -2.8e-16) a flight
/// descends 8.5e-15 a period of the default cell, so crossing the launch
/// plane's margin of 1e-9 of the scale (3e-8) takes 3.5e6 periods, and the
/// skip's coarse tolerance (also 1e-9) could not prove any: every photon was
/// capped after 2^16 crossings, 0.34 s each, reflectance 0. The skip now asks
/// again with a fine tolerance (1e-13 of the scale) and skips rising flights
/// in doubling steps. Every photon meets a bump or the field and escapes:
/// nothing is capped or lost, a photon takes some hundreds of segments, and
/// on the bumps (reflectance 0.8 a bounce) the reflectance is the mean of
/// 0.8^bounces. The same for a cell 1e16 long across the light, whose launch
/// plane sits 1e7 above the bumps (2e5 periods at 30 deg): every photon
/// reflects once, on the substrate, exactly 0.8.
#[test]
fn flights_one_ulp_off_grazing_and_over_long_cells_are_not_capped() {
    let dir = scratch("ulp-grazing");
    let default = include_str!("../scenes/default.toml");
    let one_ulp = "theta_deg = [89.99999999999999]";
    let cases = [
        ("bumps-0", default.to_string()),
        ("bumps-45", default.replace("phi_deg = 0.0", "phi_deg = 45.0")),
        (
            "field-0",
            default
                .replace("size = [30.0, 30.0]", "size = [64.0, 64.0]\nheightfield = { gaussian = { sigma = 1.0, tau = 11.9 }, resolution = 64, seed = 3 }")
                .replace("[[bumps]]\nshape = \"ellipsoid\"\ncount = 100\nradius = [2.5, 3.5]\nheight = [0.8, 4.8]\nseed = 1\n", ""),
        ),
    ];
    for (name, text) in cases {
        let text = text
            .replace(
                "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
                one_ulp,
            )
            .replace("photons = 1000000", "photons = 32");
        assert!(
            text.contains(one_ulp) && text.contains("photons = 32"),
            "{name}"
        );
        assert_eq!(
            text.contains("[[bumps]]"),
            name.starts_with("bumps"),
            "{name}"
        );
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, text).unwrap();
        let inc = completes(name, &scene, &["--stats-resolution", "16"]);
        assert_all_escaped_at_0_8_a_bounce(name, &inc, 32 * 4096);
    }
    let long = default
        .replace("size = [30.0, 30.0]", "size = [30.0, 1e16]")
        .replace(
            "theta_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]",
            "theta_deg = [30]",
        )
        .replace("photons = 1000000", "photons = 200");
    assert!(long.contains("1e16") && long.contains("[30]"));
    let scene = dir.join("long.toml");
    std::fs::write(&scene, long).unwrap();
    let inc = completes("long", &scene, &["--stats-resolution", "16"]);
    assert_eq!(inc["capped_photons"].as_u64(), Some(0), "{inc}");
    assert_eq!(inc["mean_bounces"].as_f64(), Some(1.0), "{inc}");
    let r = inc["reflectance"].as_f64().unwrap();
    assert!((r - 0.8).abs() < 1e-12, "{inc}");
}

/// A tiny incidence angle is a valid one: `--theta 1e-300` completes, and
/// its pictures are named with the exponent form of the angle
/// (`hemisphere_1e-300deg.png`; in decimal the name would pass the file
/// system's 255-byte limit). The same for a spectral Zemax export with a
/// wavelength of 1e-300 um beside 0.5 um.
#[test]
fn tiny_angles_and_wavelengths_give_short_file_names() {
    let dir = scratch("tiny-labels");
    let scene = dir.join("tiny.toml");
    let text = scene_text("size = [30.0, 30.0]", &bumps(""));
    std::fs::write(&scene, &text).unwrap();
    let inc = completes(
        "tiny theta",
        &scene,
        &["--theta", "1e-300", "--photons", "2000"],
    );
    assert_eq!(inc["theta_deg"].as_f64(), Some(1e-300));
    let out = scene.with_extension("out");
    assert!(out.join("hemisphere_1e-300deg.png").is_file());

    let spectral = dir.join("spectral.toml");
    std::fs::write(
        &spectral,
        text.replace("reflectance = 0.8", "n = 1.5\nk = 0.1")
            .replace("[light]\n", "[light]\nwavelengths_um = [1e-300, 0.5]\n"),
    )
    .unwrap();
    completes(
        "tiny wavelength",
        &spectral,
        &["--theta", "30", "--photons", "2000", "--export", "zemax"],
    );
    let out = spectral.with_extension("out");
    for name in ["brdf_1e-300um.bsdf", "brdf_5e-1um.bsdf"] {
        assert!(out.join(name).is_file(), "{name}");
    }
}

/// Bumps far wider than the period (radius 1000 on a 30 x 30 cell, 100 of
/// them: 458 735 periodic copies, every one over every grid cell): the copies
/// buried under the tallest one are left out of the grid, so a flight tests
/// a handful of solids (362 559 a segment before, which ran for hours), and
/// `roks stats` maps the heights. The slopes are below 0.005, so every
/// photon reflects once at 0.8 and escapes.
#[test]
fn bumps_wider_than_the_period_are_traced_through_the_few_on_top() {
    let dir = scratch("wide-bumps");
    let scene = dir.join("wide.toml");
    let text = scene_text(
        "size = [30.0, 30.0]",
        &bumps("count = 100\nradius = [1000.0, 1000.0]"),
    );
    std::fs::write(&scene, text).unwrap();
    let inc = completes(
        "wide-bumps",
        &scene,
        &["--photons", "2000", "--theta", "60"],
    );
    assert_all_escaped_at_0_8_a_bounce("wide-bumps", &inc, 2 * 2000);
    assert_eq!(inc["mean_bounces"].as_f64(), Some(1.0), "{inc}");
    let tests = inc["tests_per_segment"].as_f64().unwrap();
    assert!(tests < 100.0, "{tests} solids tested a segment");
    let o = roks_watched(
        "wide-bumps stats",
        &[
            "stats",
            scene.to_str().unwrap(),
            "--resolution",
            "64",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `-0` is `0`: an incidence angle and light azimuths written `-0.0` (in the
/// scene or as `--theta -0`) give the files and pictures of `0`
/// (`hemisphere_0deg_phi0.png`, never `..._phi-0.png`), and no `-0`
/// anywhere in `summary.json`, `brdf.csv` or `inplane.csv`.
#[test]
fn negative_zero_angles_are_written_as_zero() {
    let dir = scratch("negative-zero");
    let scene = dir.join("nz.toml");
    let text = scene_text("size = [30.0, 30.0]", &bumps("")).replace(
        "theta_deg = [30]",
        "theta_deg = [-0.0]\nphi_deg = [-0.0, 90.0]",
    ) + "[tally]\nbands = 2\ninplane_step_deg = 90\n";
    std::fs::write(&scene, &text).unwrap();
    for args in [
        &["--photons", "100"][..],
        &["--photons", "100", "--theta", "-0"],
    ] {
        completes("negative zero", &scene, args);
        let out = scene.with_extension("out");
        let names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.contains("-0")), "{names:?}");
        for name in ["hemisphere_0deg_phi0.png", "hemisphere_0deg_phi90.png"] {
            assert!(names.iter().any(|n| n == name), "{name}: {names:?}");
        }
        for file in ["summary.json", "brdf.csv", "inplane.csv"] {
            let text = std::fs::read_to_string(out.join(file)).unwrap();
            assert!(
                !text.contains("-0.0") && !text.contains("\n-0,") && !text.contains(",-0,"),
                "{file}: -0 in it"
            );
        }
    }
}
