//! Messages of the command line: every bad option of every subcommand is one
//! line `roks: --option: ...` naming the option and what it takes (exit 2,
//! nothing on stdout, nothing written); `--help` and `--version` still work;
//! `roks fit` names the options and scene keys the user wrote and refuses
//! bounds the scene rejects; a flat surface's undefined statistics say why.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::Output;

use cli_common::{assert_input_error, read, roks, summary_without_timing};
use serde_json::Value;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("roks-messages-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small valid micro scene: 20 bumps, in-plane bins wide enough for a fit.
const SCENE: &str = "[surface]\nsize = [12.0, 12.0]\nedges = \"periodic\"\nmaterial = \"m\"\n\n\
[materials.m]\nreflectance = 0.8\n\n\
[[bumps]]\nshape = \"ellipsoid\"\ncount = 20\nradius = 2.5\nheight = [1.0, 1.8]\nseed = 3\n\n\
[light]\ntheta_deg = [30.0]\n\n\
[tally]\ninplane_step_deg = 5.0\ninplane_width_deg = 10.0\n";

/// A flat, grey substrate without bumps.
const FLAT: &str = "[surface]\nsize = [10.0, 10.0]\nmaterial = \"m\"\n\n[materials.m]\nreflectance = 0.5\n\n[light]\ntheta_deg = [0.0, 40.0]\n";

/// A bad option: exit 2, one line `roks: ...` containing every `expect`,
/// no panic, nothing on stdout, and `out` (if any) not created.
fn assert_option_error(case: &str, o: &Output, out: Option<&Path>, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{case}: {} {stderr}", o.status);
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    let line = stderr
        .strip_suffix('\n')
        .unwrap_or_else(|| panic!("{case}: {stderr:?}"));
    assert!(!line.contains('\n'), "{case}: not one line: {stderr:?}");
    assert!(line.starts_with("roks: "), "{case}: {line:?}");
    for e in expect {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
    assert!(
        o.stdout.is_empty(),
        "{case}: stdout {:?}",
        String::from_utf8_lossy(&o.stdout)
    );
    if let Some(out) = out {
        assert!(!out.exists(), "{case}: {} was created", out.display());
    }
}

#[test]
fn every_bad_option_is_one_line_naming_it() {
    let dir = scratch("options");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let measured = dir.join("m.csv");
    std::fs::write(
        &measured,
        "theta_i_deg,theta_o_deg,brdf\n30,0,0.2\n30,20,0.4\n",
    )
    .unwrap();
    let out = dir.join("out");
    let (s, m, o) = (
        scene.to_str().unwrap(),
        measured.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    let exr = dir.join("r.exr");
    let e = exr.to_str().unwrap();
    macro_rules! with_out {
        ($($a:expr),* $(,)?) => {
            vec![$($a,)* "--out", o]
        };
    }
    // (case, arguments, texts the one line must hold).
    let cases: Vec<(&str, Vec<&str>, Vec<&str>)> = vec![
        // Negative numbers are the option's value, refused as out of range.
        (
            "seed -1",
            with_out!("brdf", s, "--seed", "-1"),
            vec!["--seed:", "integer >= 0", "`-1`"],
        ),
        (
            "seed=-1",
            with_out!("brdf", s, "--seed=-1"),
            vec!["--seed:", "`-1`"],
        ),
        (
            "trace seed -7",
            with_out!("trace", s, "--seed", "-7"),
            vec!["--seed:", "`-7`"],
        ),
        (
            "render seed -1",
            vec!["render", s, "--out", e, "--seed", "-1"],
            vec!["--seed:", "`-1`"],
        ),
        (
            "stats resolution -3",
            vec!["stats", s, "--resolution", "-3"],
            vec!["--resolution:", "`-3`"],
        ),
        (
            "photons -5",
            with_out!("brdf", s, "--photons", "-5"),
            vec!["--photons:", "integer >= 1"],
        ),
        // Integers: exact forms only.
        (
            "photons 1.5",
            with_out!("brdf", s, "--photons", "1.5"),
            vec!["--photons:", "not a whole number"],
        ),
        (
            "photons 1e-3",
            with_out!("brdf", s, "--photons", "1e-3"),
            vec!["--photons:", "not a whole number"],
        ),
        (
            "photons abc",
            with_out!("brdf", s, "--photons", "abc"),
            vec!["--photons:", "expected an integer", "`abc`"],
        ),
        (
            "photons 1e30",
            with_out!("brdf", s, "--photons", "1e30"),
            vec!["--photons:", "at most 18446744073709551615"],
        ),
        (
            "photons 0",
            with_out!("brdf", s, "--photons", "0"),
            vec!["--photons:", ">= 1", "`0`"],
        ),
        (
            "trace photons 2.5",
            with_out!("trace", s, "--photons", "2.5"),
            vec!["--photons:"],
        ),
        (
            "spp 5e9",
            vec!["render", s, "--out", e, "--spp", "5e9"],
            vec!["--spp:", "at most 4294967295"],
        ),
        (
            "threads 0",
            with_out!("brdf", s, "--threads", "0"),
            vec!["--threads:", ">= 1"],
        ),
        (
            "fit threads 0",
            with_out!(
                "fit",
                s,
                m,
                "--param",
                "bumps[0].radius=1:3",
                "--threads",
                "0",
            ),
            vec!["--threads:"],
        ),
        (
            "size 0,10",
            vec!["render", s, "--out", e, "--size", "0,10"],
            vec!["--size:", ">= 1", "`0`"],
        ),
        (
            "size a,10",
            vec!["render", s, "--out", e, "--size", "a,10"],
            vec!["--size:", "`a`"],
        ),
        (
            "export-mesh resolution x",
            vec!["export-mesh", s, "--out", e, "--resolution", "x"],
            vec!["--resolution:"],
        ),
        // Real numbers: finite decimals.
        (
            "theta a,b",
            with_out!("brdf", s, "--theta", "a,b"),
            vec!["--theta:", "expected a number", "`a`"],
        ),
        (
            "theta ''",
            with_out!("brdf", s, "--theta", ""),
            vec!["--theta:", "empty value"],
        ),
        (
            "theta=",
            with_out!("brdf", s, "--theta="),
            vec!["--theta:", "empty value"],
        ),
        (
            "theta inf",
            with_out!("brdf", s, "--theta", "inf"),
            vec!["--theta:", "finite"],
        ),
        (
            "theta 95",
            with_out!("brdf", s, "--theta", "95"),
            vec!["--theta:", "[0, 90)"],
        ),
        (
            "tolerance nan",
            with_out!(
                "fit",
                s,
                m,
                "--param",
                "bumps[0].radius=1:3",
                "--tolerance",
                "nan",
            ),
            vec!["--tolerance:", "finite"],
        ),
        (
            "disc x",
            vec!["render", s, "--out", e, "--disc", "x"],
            vec!["--disc:", "`x`"],
        ),
        (
            "view 1,q",
            vec!["render", s, "--out", e, "--view", "1,q"],
            vec!["--view:", "`q`"],
        ),
        // Names from a fixed list.
        (
            "symmetry x",
            with_out!("brdf", s, "--symmetry", "x"),
            vec!["--symmetry:", "`x`", "none, mirror"],
        ),
        (
            "symmetry mirrr",
            with_out!("brdf", s, "--symmetry", "mirrr"),
            vec!["--symmetry:", "did you mean `mirror`"],
        ),
        (
            "polarisation x",
            with_out!("brdf", s, "--polarisation", "x"),
            vec!["--polarisation:", "none, stokes, mueller"],
        ),
        (
            "launch x",
            with_out!("brdf", s, "--launch", "x"),
            vec!["--launch:", "random, lattice"],
        ),
        (
            "export foo",
            with_out!("brdf", s, "--export", "foo"),
            vec!["--export:", "zemax, merl"],
        ),
        (
            "export zemax,fo",
            with_out!("brdf", s, "--export", "zemax,fo"),
            vec!["--export:", "`fo`", "one of zemax, merl"],
        ),
        (
            "export-brdf format x",
            with_out!("export-brdf", o, "--format", "x"),
            vec!["--format:", "`x`", "one of zemax, merl"],
        ),
        (
            "theta twice",
            with_out!("brdf", s, "--theta", "10,20,10"),
            vec!["--theta:", "10 is given twice"],
        ),
        (
            "lattice photons",
            with_out!("brdf", s, "--launch", "lattice", "--photons", "100"),
            vec!["--photons:", "multiple of 16", "got 100"],
        ),
        // Missing values.
        (
            "seed at the end",
            vec!["brdf", s, "--seed"],
            vec!["--seed:", "needs a value"],
        ),
        (
            "launch without value",
            vec!["brdf", s, "--launch"],
            vec!["--launch:", "needs a value", "random, lattice"],
        ),
        (
            "out without value",
            vec!["trace", s, "--out"],
            vec!["--out:", "needs a value"],
        ),
        // Unknown and repeated options, unexpected and missing arguments.
        (
            "unknown option",
            with_out!("brdf", s, "--phtons", "5"),
            vec![
                "--phtons:",
                "unknown option of `roks brdf`",
                "did you mean `--photons`",
            ],
        ),
        (
            "unknown short option",
            with_out!("stats", s, "-x"),
            vec!["-x:", "unknown option of `roks stats`"],
        ),
        (
            "unknown top-level option",
            vec!["-q"],
            vec!["-q:", "unknown option of `roks`"],
        ),
        (
            "repeated seed",
            with_out!("brdf", s, "--seed", "1", "--seed", "2"),
            vec!["--seed:", "more than once"],
        ),
        (
            "repeated quiet",
            with_out!("brdf", s, "-q", "--quiet"),
            vec!["--quiet:", "more than once"],
        ),
        (
            "extra argument",
            with_out!("brdf", s, "extra.toml"),
            vec!["`extra.toml`", "unexpected argument of `roks brdf`"],
        ),
        (
            "fit without measured",
            vec!["fit", s],
            vec!["missing", "--param", "<MEASURED>"],
        ),
        (
            "merge without anything",
            vec!["merge"],
            vec!["missing", "--out", "<DIRS>"],
        ),
        (
            "trace without scene",
            vec!["trace"],
            vec!["missing", "<SCENE>"],
        ),
        // Unknown subcommands.
        (
            "unknown subcommand",
            vec!["bdrf", s],
            vec![
                "`bdrf`: unknown subcommand",
                "brdf, stats, trace",
                "did you mean `brdf`",
            ],
        ),
        (
            "help of an unknown subcommand",
            vec!["help", "nope"],
            vec!["`nope`", "unknown subcommand"],
        ),
        // Checks after parsing: the same one line.
        (
            "shard 3/2",
            with_out!("brdf", s, "--shard", "3/2", "--photons", "8192"),
            vec!["--shard:"],
        ),
        (
            "render disc 0",
            vec!["render", s, "--out", e, "--disc", "0"],
            vec!["--disc:", "(0, 180]"],
        ),
        (
            "render view theta 95",
            vec!["render", s, "--out", e, "--view", "95,0"],
            vec!["--view:", "[0, 90)"],
        ),
        (
            "render background -1",
            vec!["render", s, "--out", e, "--background", "-1"],
            vec!["--background:", ">= 0"],
        ),
        (
            "render background 1e308",
            vec!["render", s, "--out", e, "--background", "1e308"],
            vec!["--background:", "above 1e30", "f32"],
        ),
        (
            "render light theta 200",
            vec!["render", s, "--out", e, "--light", "200,0"],
            vec!["--light:", "[0, 180]"],
        ),
        (
            // A value starting with `-` is the option's value, not an option.
            "render light theta -1",
            vec!["render", s, "--out", e, "--light", "-1,0"],
            vec!["--light:", "[0, 180]"],
        ),
        (
            "shard -1/2",
            with_out!("brdf", s, "--shard", "-1/2", "--photons", "8192"),
            vec!["--shard:", "`-1`"],
        ),
        (
            "render view 3 values",
            vec!["render", s, "--out", e, "--view", "1,2,3"],
            vec!["--view:", "two comma-separated"],
        ),
    ];
    for (case, args, expect) in &cases {
        let o = roks(args);
        assert_option_error(case, &o, Some(&out), expect);
        assert!(!exr.exists(), "{case}: wrote {}", exr.display());
    }
    assert!(cases.len() >= 45, "{}", cases.len());
    // An object scene's camera options: the line also names the scene.
    let object = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/bad_inputs/messages-render-object-fov-zero.toml");
    let o_s = object.to_str().unwrap();
    for (case, extra, expect) in [
        ("object fov 0", ["--fov", "0"], ["--fov:", "(0, 180)"]),
        ("object fov 180", ["--fov", "180"], ["--fov:", "(0, 180)"]),
        ("object up 0,0,0", ["--up", "0,0,0"], ["--up:", "parallel"]),
        (
            "object look-at at the camera",
            ["--look-at", "0,0,50"],
            ["--look-at:", "differ"],
        ),
    ] {
        let mut args = vec!["render", o_s, "--out", e];
        args.extend(extra);
        if case.contains("look-at") {
            args.extend(["--camera", "0,0,50"]);
        }
        let o = roks(&args);
        assert_input_error(case, &o, &object, &exr, &expect);
    }
}

#[test]
fn help_and_version_print_to_stdout() {
    for args in [
        vec!["--help"],
        vec!["-h"],
        vec!["--version"],
        vec!["-V"],
        vec!["brdf", "--help"],
        vec!["fit", "-h"],
        vec!["help", "merge"],
        vec!["help"],
    ] {
        let o = roks(&args);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(
            o.stderr.is_empty(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(!text.trim().is_empty(), "{args:?}");
        if args.contains(&"--version") || args.contains(&"-V") {
            assert_eq!(text.trim(), format!("roks {}", env!("CARGO_PKG_VERSION")));
        } else {
            assert!(text.contains("Usage: roks"), "{args:?}: {text}");
        }
    }
}

#[test]
fn no_subcommand_names_them_then_shows_the_usage() {
    let o = roks(&[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(o.stdout.is_empty());
    let err = String::from_utf8_lossy(&o.stderr);
    let mut lines = err.lines();
    assert_eq!(
        lines.next(),
        Some(
            "roks: missing subcommand: one of brdf, stats, trace, fit, export-mesh, export-heightfield, render, merge, export-brdf, fit-model, plot, report"
        )
    );
    assert!(err.contains("Usage: roks <COMMAND>"), "{err}");
}

/// Integers written with an exponent are the exact integers; negative
/// numbers reach options that take them (`--view`, `--camera`).
#[test]
fn exact_exponent_forms_and_negative_values_are_accepted() {
    let dir = scratch("accepted");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let o = roks(&[
        "brdf",
        scene.to_str().unwrap(),
        "--photons",
        "4.096e3",
        "--seed",
        "1E2",
        "--threads",
        "2e0",
        "--stats-resolution",
        "6.4e1",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&read(&out, "summary.json")).unwrap();
    assert_eq!(v["run"]["photons_per_incidence"], 4096);
    assert_eq!(v["run"]["seed"], 100);
    assert_eq!(v["surface"]["height_map_resolution"], 64);
    // The same run written plainly gives the same result.
    let plain = dir.join("plain");
    let o = roks(&[
        "brdf",
        scene.to_str().unwrap(),
        "--photons",
        "4096",
        "--seed",
        "100",
        "--stats-resolution",
        "64",
        "-q",
        "--out",
        plain.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read(&out, "brdf.csv"), read(&plain, "brdf.csv"));
    assert_eq!(summary_without_timing(&out), summary_without_timing(&plain));
    // A negative view azimuth is a value, not an unknown option `-30`.
    let exr = dir.join("r.exr");
    let o = roks(&[
        "render",
        scene.to_str().unwrap(),
        "--out",
        exr.to_str().unwrap(),
        "--size",
        "8,8",
        "--spp",
        "1",
        "--view",
        "10,-30",
        "--light",
        "20,-150",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(exr.exists());
}

fn fit_scene(dir: &Path) -> (PathBuf, PathBuf) {
    let scene = dir.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let measured = dir.join("m.csv");
    std::fs::write(
        &measured,
        "theta_i_deg,theta_o_deg,brdf\n30,-20,0.1\n30,0,0.2\n30,20,0.4\n30,40,0.2\n",
    )
    .unwrap();
    (scene, measured)
}

#[test]
fn fit_messages_name_the_option_and_the_key() {
    let dir = scratch("fit-errors");
    let (scene, measured) = fit_scene(&dir);
    let out = dir.join("out");
    let (s, m, o) = (
        scene.to_str().unwrap(),
        measured.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    let fit = |extra: &[&str]| {
        let mut a = vec!["fit", s, m, "--out", o, "-q"];
        a.extend(extra);
        roks(&a)
    };
    // Bounds the scene rejects: refused up front, naming --param, the key
    // and the scene's reason.
    for (case, param, expect) in [
        (
            "radius through 0",
            "bumps[0].radius=0:3",
            vec![
                "--param bumps[0].radius=0:3",
                "at bumps[0].radius = 0",
                "bumps[0].radius: must be > 0",
            ],
        ),
        (
            "negative radius",
            "bumps[0].radius=-2:3",
            vec!["--param bumps[0].radius=-2:3", "at bumps[0].radius = -2"],
        ),
        (
            "reversed range end",
            "bumps[0].height[1]=0.5:3",
            vec![
                "--param bumps[0].height[1]=0.5:3",
                "bumps[0].height: range [1, 0.5] is reversed",
            ],
        ),
        (
            "reflectance above 1",
            "materials.m.reflectance=0.5:1.5",
            vec![
                "at materials.m.reflectance = 1.5",
                "materials.m.reflectance",
            ],
        ),
        (
            "key that does not exist",
            "bumps[0].radiuss=1:3",
            vec![
                "--param bumps[0].radiuss:",
                "no key `radiuss` in `bumps[0]`",
            ],
        ),
        (
            "key out of range",
            "bumps[4].radius=1:3",
            vec!["--param bumps[4].radius:", "index [4] out of range"],
        ),
        (
            "a whole range",
            "bumps[0].height=1:3",
            vec!["--param bumps[0].height:", "fit one end"],
        ),
        (
            "a string",
            "surface.material=1:3",
            vec!["--param surface.material:", "not a number"],
        ),
    ] {
        let o = fit(&["--param", param]);
        assert_input_error(case, &o, &scene, &out, &expect);
    }
    // Malformed --param and fit options: the option, no internal field names.
    for (case, extra, expect) in [
        (
            "reversed bounds",
            vec!["--param", "bumps[0].radius=3:1"],
            vec!["--param bumps[0].radius=3:1:", "lo < hi"],
        ),
        (
            "no bounds",
            vec!["--param", "bumps[0].radius"],
            vec!["--param bumps[0].radius:", "key=lo:hi"],
        ),
        (
            "bad bound",
            vec!["--param", "bumps[0].radius=1:x"],
            vec!["--param", "bound `x` is not a number"],
        ),
        (
            "repeated key",
            vec![
                "--param",
                "bumps[0].radius=1:3",
                "--param",
                "bumps[0].radius=1:2",
            ],
            vec!["--param bumps[0].radius:", "given twice"],
        ),
        (
            "photons 0",
            vec!["--param", "bumps[0].radius=1:3", "--photons", "0"],
            vec!["--photons:"],
        ),
        (
            "max-evals 0",
            vec!["--param", "bumps[0].radius=1:3", "--max-evals", "0"],
            vec!["--max-evals:"],
        ),
        (
            "tolerance -1",
            vec!["--param", "bumps[0].radius=1:3", "--tolerance", "-1"],
            vec!["--tolerance:", "must be >= 0"],
        ),
        (
            "x-tolerance -1",
            vec!["--param", "bumps[0].radius=1:3", "--x-tolerance", "-1"],
            vec!["--x-tolerance:", "must be >= 0"],
        ),
        (
            "inplane-step 7",
            vec!["--param", "bumps[0].radius=1:3", "--inplane-step", "7"],
            vec!["--inplane-step:", "must divide 180"],
        ),
        (
            "inplane-width 0",
            vec!["--param", "bumps[0].radius=1:3", "--inplane-width", "0"],
            vec!["--inplane-width:", "(0, 180]"],
        ),
    ] {
        let o = fit(&extra);
        assert_option_error(case, &o, Some(&out), &expect);
        let line = String::from_utf8_lossy(&o.stderr);
        for internal in [
            "fit option",
            "max_evaluations",
            "inplane_step_deg",
            "x_tolerance",
            "parameter `",
        ] {
            assert!(!line.contains(internal), "{case}: {line}");
        }
    }
}

/// Points the search meets that the scene rejects (the two ends of a range
/// crossing) are recorded with their reason, never a bare `null`.
#[test]
fn fit_records_rejected_points_with_their_reason() {
    let dir = scratch("fit-rejected");
    let (scene, measured) = fit_scene(&dir);
    let out = dir.join("out");
    let o = roks(&[
        "fit",
        scene.to_str().unwrap(),
        measured.to_str().unwrap(),
        "--param",
        "bumps[0].height[0]=0.5:1.75",
        "--param",
        "bumps[0].height[1]=1.1:3",
        "--photons",
        "1000",
        "--scan",
        "4",
        "--max-evals",
        "20",
        "--restarts",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.lines().any(|l| l.contains("rejected by the scene at") && l.contains("bumps[0].height: range")),
        "{err}"
    );
    let v: Value = serde_json::from_slice(&read(&out, "fit.json")).unwrap();
    assert!(v["misfit"].is_f64(), "{}", v["misfit"]);
    assert!(v["start_misfit"].is_f64());
    let history = v["history"].as_array().unwrap();
    let rejected: Vec<&Value> = history.iter().filter(|h| h["misfit"].is_null()).collect();
    assert!(!rejected.is_empty());
    assert_eq!(v["rejected_evaluations"], rejected.len());
    for h in &rejected {
        let (lo, hi) = (
            h["values"][0].as_f64().unwrap(),
            h["values"][1].as_f64().unwrap(),
        );
        assert!(lo > hi, "{h}");
        // The reason names the range and its two ends (as Rust prints them;
        // serde_json may read the JSON values back one ulp off).
        let why = h["rejected"].as_str().unwrap();
        let ends = why
            .strip_prefix("bumps[0].height: range [")
            .and_then(|w| w.strip_suffix("] is reversed"))
            .unwrap_or_else(|| panic!("{why}"));
        let (a, b) = ends.split_once(", ").unwrap();
        let (a, b): (f64, f64) = (a.parse().unwrap(), b.parse().unwrap());
        assert!(
            a > b && (a - lo).abs() < 1e-12 && (b - hi).abs() < 1e-12,
            "{why}"
        );
    }
    for h in history.iter().filter(|h| !h["misfit"].is_null()) {
        assert!(h["misfit"].is_f64() && h.get("rejected").is_none(), "{h}");
    }
}

/// `roks args`, killed after 60 s (a hang detector, not a speed assertion).
fn roks_or_hang(args: &[&str]) -> Output {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("roks {args:?}: still running after 60 s (a hang)");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

/// `--scan` of any size is at most 256 points in all (it used to count down
/// from the request one by one, or overflow `m^d`).
#[test]
fn fit_scan_of_any_size_is_bounded() {
    let dir = scratch("fit-scan");
    let (scene, measured) = fit_scene(&dir);
    let out = dir.join("out");
    let o = roks_or_hang(&[
        "fit",
        scene.to_str().unwrap(),
        measured.to_str().unwrap(),
        "--param",
        "bumps[0].radius=1:3",
        "--scan",
        "1e18",
        "--photons",
        "200",
        "--max-evals",
        "1",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&read(&out, "fit.json")).unwrap();
    // The start, 256 scan points, the simplex's second vertex; then
    // --max-evals stops the search.
    assert_eq!(v["evaluations"], 258);
}

const TAU_FLAT: &str = "undefined for a flat surface (sigma = 0)";

#[test]
fn flat_surface_statistics_say_why_they_are_undefined() {
    let dir = scratch("flat");
    let scene = dir.join("flat.toml");
    std::fs::write(&scene, FLAT).unwrap();
    let s = scene.to_str().unwrap();
    // Text: the reason, no NaN.
    let o = roks(&["stats", s, "--resolution", "64"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(!text.contains("NaN"), "{text}");
    assert!(
        text.contains(&format!("tau              {TAU_FLAT}\n")),
        "{text}"
    );
    assert!(
        text.contains("sigma_over_tau   undefined (tau is undefined)\n"),
        "{text}"
    );
    // JSON: null, with the reason beside it.
    let o = roks(&["stats", s, "--resolution", "64", "--json"]);
    assert!(o.status.success());
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let check = |v: &Value, what: &str| {
        assert_eq!(v["sigma"], 0.0, "{what}");
        assert!(v["tau"].is_null(), "{what}");
        assert!(v["sigma_over_tau"].is_null(), "{what}");
        assert_eq!(v["undefined"]["tau"], TAU_FLAT, "{what}");
        assert_eq!(
            v["undefined"]["sigma_over_tau"],
            format!("tau is {TAU_FLAT}"),
            "{what}"
        );
    };
    check(&v, "stats --json");
    // summary.json of a run, and of the same run in two shards merged.
    let full = dir.join("full");
    let run = |out: &Path, shard: Option<&str>| {
        let mut a = vec![
            "brdf",
            s,
            "--photons",
            "8192",
            "--stats-resolution",
            "64",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ];
        if let Some(sh) = shard {
            a.extend(["--shard", sh]);
        }
        let o = roks(&a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&full, None);
    let summary: Value = serde_json::from_slice(&read(&full, "summary.json")).unwrap();
    check(&summary["surface"], "summary.json");
    let text = String::from_utf8_lossy(&read(&full, "summary.json")).into_owned();
    assert!(!text.contains("NaN"));
    let shards = [dir.join("s0"), dir.join("s1")];
    run(&shards[0], Some("0/2"));
    run(&shards[1], Some("1/2"));
    let merged = dir.join("merged");
    let o = roks(&[
        "merge",
        shards[0].to_str().unwrap(),
        shards[1].to_str().unwrap(),
        "-q",
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        summary_without_timing(&merged),
        summary_without_timing(&full)
    );
}

/// Heights correlated over more than half the cell: a long narrow cell under
/// one wide bump. No `tau` within the lags the map has, and the line says so.
#[test]
fn tau_beyond_half_the_cell_says_why() {
    let dir = scratch("long");
    let scene = dir.join("long.toml");
    std::fs::write(
        &scene,
        "[surface]\nsize = [100.0, 4.0]\nmaterial = \"m\"\n\n[materials.m]\nreflectance = 0.5\n\n\
         [[bumps]]\nshape = \"paraboloid\"\ncount = 1\nradius = 45\nheight = 3\nseed = 1\n",
    )
    .unwrap();
    let why = "undefined: the radial autocorrelation stays above 1/e out to the largest lag, 2 (half the cell's shorter side)";
    let s = scene.to_str().unwrap();
    let o = roks(&["stats", s, "--resolution", "128"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(!text.contains("NaN"), "{text}");
    assert!(
        text.contains(&format!("tau              {why}\n")),
        "{text}"
    );
    let o = roks(&["stats", s, "--resolution", "128", "--json"]);
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["sigma"].as_f64().is_some_and(|x| x > 0.0));
    assert!(v["tau"].is_null());
    assert_eq!(v["undefined"]["tau"], why);
}

/// A rough surface keeps its numbers and has no `undefined` key.
#[test]
fn rough_surface_statistics_are_numbers() {
    let dir = scratch("rough");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let o = roks(&[
        "stats",
        scene.to_str().unwrap(),
        "--resolution",
        "64",
        "--json",
    ]);
    assert!(o.status.success());
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["tau"].as_f64().is_some_and(|t| t > 0.0), "{v}");
    assert!(v["sigma_over_tau"].as_f64().is_some_and(|t| t > 0.0), "{v}");
    assert!(v.get("undefined").is_none(), "{v}");
}

/// The options of `roks COMMAND -h`, in the order the help lists them.
fn listed_options(command: &str) -> Vec<String> {
    let o = roks(&[command, "-h"]);
    assert_eq!(o.status.code(), Some(0), "{command} -h");
    String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .filter(|l| l.trim_start().starts_with('-'))
        .filter_map(|l| {
            l.split_whitespace()
                .find(|t| t.starts_with("--"))
                .map(|t| t.trim_end_matches(',').to_string())
        })
        .collect()
}

#[test]
fn shared_options_keep_their_place_in_the_help() {
    assert_eq!(
        listed_options("brdf"),
        [
            "--out",
            "--force",
            "--photons",
            "--seed",
            "--threads",
            "--check",
            "--theta",
            "--phi",
            "--wavelengths",
            "--launch",
            "--kernel",
            "--symmetry",
            "--polarisation",
            "--no-polarisation",
            "--stats-resolution",
            "--shard",
            "--export",
            "--report",
            "--quiet",
            "--help"
        ]
    );
    assert_eq!(
        listed_options("trace"),
        [
            "--out",
            "--force",
            "--photons",
            "--seed",
            "--threads",
            "--check",
            "--no-polarisation",
            "--wavelengths",
            "--shard",
            "--report",
            "--quiet",
            "--help"
        ]
    );
    // Names from a list show as one line of values (not one value per
    // line with its description); the export formats are named in the text.
    let help = String::from_utf8(roks(&["brdf", "--help"]).stdout).unwrap();
    assert!(
        help.contains("[possible values: random, lattice]"),
        "{help}"
    );
    assert!(
        help.contains("[possible values: none, stokes, mueller]"),
        "{help}"
    );
    assert!(
        help.contains("[possible values: scalar, wavefront]"),
        "{help}"
    );
    assert!(!help.contains("Possible values:"), "{help}");
    assert_eq!(help.matches("possible values").count(), 4, "{help}");
    let trace = String::from_utf8(roks(&["trace", "--help"]).stdout).unwrap();
    assert!(
        trace.contains("Photons per beam position (overrides each source's `photons`)"),
        "{trace}"
    );
}
