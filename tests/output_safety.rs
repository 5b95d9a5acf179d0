//! Nothing a user owns is lost (docs/src/output-safety.md), for every
//! writer of roks:
//! * a result folder holding a file roks did not write (a user's
//!   `notes.txt`) is refused before any work (10^12 photons would take
//!   days), one line naming the file, exit 2, the file kept byte for byte;
//!   `--force` replaces the folder and says what it removed;
//! * a scene, a note and a picture given as a single-file `--out` (or
//!   `--png`) are each kept, refused in one line naming the path, exit 2;
//!   `--force` replaces them, and a rerun over roks's own file needs no
//!   flag;
//! * a rerun over its own folder removes the exports and fits later
//!   commands had added, and names them in one line;
//! * Ctrl-C (SIGINT) and SIGTERM: one line, exit 130, no output and no
//!   staging leftovers.

mod cli_common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use cli_common::{names, ok};

/// A small periodic micro scene (fast to trace), Fresnel material so that
/// a Mueller tally is meaningful.
const MICRO: &str = r#"
name = "small"

[surface]
size = [10.0, 10.0]
edges = "periodic"
material = "metal"

[materials.metal]
n = 1.2
k = 7.26

[[bumps]]
shape = "ellipsoid"
count = 10
radius = [1.5, 2.5]
height = [1.0, 2.5]
seed = 4

[light]
theta_deg = [0, 30]
photons = 4096

[tally]
bands = 8
"#;

/// An object scene (fast to trace).
fn object_scene() -> String {
    cli_common::painted_cavity(500, "")
}

/// Photons no test waits for: a refusal must come before the work.
const DAYS: &str = "1000000000000";

/// A fresh, empty scratch folder for this test process.
fn scratch(name: &str) -> PathBuf {
    cli_common::scratch("safety", name)
}

/// Run roks in `cwd`, killed after 120 s (a hang detector).
fn roks_in(cwd: &Path, args: &[&str]) -> Output {
    cli_common::roks_in(cwd, args, 120)
}

/// Refused: exit 2, one line on stderr holding every string of `expect`,
/// no panic.
fn refused(case: &str, o: &Output, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{case}: {}: {stderr}", o.status);
    assert_eq!(stderr.lines().count(), 1, "{case}: {stderr}");
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "{case}: {e:?} not in {stderr}");
    }
}

/// Hidden staging or temporary entries in `dir` (`.NAME.new-PID`,
/// `.NAME.old-PID`, `.FILE.PID.tmp`).
fn leftovers(dir: &Path) -> Vec<String> {
    names(dir)
        .into_iter()
        .filter(|n| {
            n.starts_with('.')
                && (n.contains(".new-") || n.contains(".old-") || n.ends_with(".tmp"))
        })
        .collect()
}

/// A PNG picture roks did not write (no `Software` text).
fn picture() -> Vec<u8> {
    let img = image::RgbImage::from_pixel(4, 3, image::Rgb([200, 10, 10]));
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    png
}

/// The user's files: a scene, a note, a picture.
fn foreign() -> [(&'static str, Vec<u8>); 3] {
    [
        ("scene", MICRO.as_bytes().to_vec()),
        ("note", b"measured on the 3rd; keep!\n".to_vec()),
        ("picture", picture()),
    ]
}

/// `dir` with `scene.toml` (MICRO), `object.toml` and a Mueller result
/// `res` of the micro scene.
fn setup(name: &str) -> PathBuf {
    let dir = scratch(name);
    std::fs::write(dir.join("scene.toml"), MICRO).unwrap();
    std::fs::write(dir.join("object.toml"), object_scene()).unwrap();
    let o = roks_in(
        &dir,
        &[
            "brdf",
            "scene.toml",
            "--out",
            "res",
            "--photons",
            "3000",
            "--stats-resolution",
            "32",
            "--polarisation",
            "mueller",
            "-q",
        ],
    );
    ok(&o, "brdf res");
    dir
}

/// Each single-file writer: its arguments with `OUT` for the path it
/// writes (the foreign file is put there), and `(flag, beside)`: the
/// option that names it and a second file it writes beside it.
fn single_file_writers() -> Vec<(&'static str, Vec<&'static str>, &'static str)> {
    let export = |format| {
        vec![
            "export-brdf",
            "res",
            "--format",
            format,
            "--out",
            "OUT",
            "-q",
        ]
    };
    let heights = vec![
        "export-heightfield",
        "scene.toml",
        "--out",
        "OUT",
        "--resolution",
        "4",
    ];
    vec![
        ("export-brdf zemax", export("zemax"), "x.toml"),
        ("export-brdf merl", export("merl"), "x.binary"),
        ("export-brdf rgl", export("rgl"), "x.bsdf"),
        ("export-brdf pbsdf", export("pbsdf"), "x.pbsdf"),
        (
            "fit-model json",
            vec!["fit-model", "res", "--model", "abg", "--out", "OUT", "-q"],
            "x.json",
        ),
        (
            "render exr",
            vec![
                "render",
                "scene.toml",
                "--out",
                "OUT",
                "--size",
                "4,4",
                "--spp",
                "1",
            ],
            "x.exr",
        ),
        (
            "export-mesh",
            vec![
                "export-mesh",
                "scene.toml",
                "--out",
                "OUT",
                "--resolution",
                "4",
            ],
            "x.ply",
        ),
        ("export-heightfield txt", heights.clone(), "x.txt"),
        ("export-heightfield exr", heights, "x.exr"),
        (
            "stats --png",
            vec!["stats", "scene.toml", "--resolution", "16", "--png", "OUT"],
            "x.png",
        ),
    ]
}

fn with_out<'a>(args: &[&'a str], out: &'a str) -> Vec<&'a str> {
    args.iter()
        .map(|a| if *a == "OUT" { out } else { a })
        .collect()
}

/// A scene, a note and a picture at the output path of every single-file
/// writer: kept byte for byte and refused in one line naming the path,
/// exit 2; `--force` replaces it; a rerun over roks's own file then works
/// without the flag.
#[test]
fn a_users_file_given_as_out_is_kept_unless_forced() {
    let dir = setup("single");
    for (what, args, name) in single_file_writers() {
        for (kind, bytes) in foreign() {
            let case = format!("{what} over a {kind}");
            let out = dir.join(name);
            std::fs::write(&out, &bytes).unwrap();
            let a = with_out(&args, name);
            let o = roks_in(&dir, &a);
            refused(
                &case,
                &o,
                &[name, "that roks wrote, so it is kept", "--force"],
            );
            assert_eq!(std::fs::read(&out).unwrap(), bytes, "{case}: changed");
            let mut forced = a.clone();
            forced.push("--force");
            ok(&roks_in(&dir, &forced), &format!("{case} --force"));
            assert_ne!(std::fs::read(&out).unwrap(), bytes, "{case}: not replaced");
            ok(
                &roks_in(&dir, &a),
                &format!("{case}: rerun over its own file"),
            );
            assert!(leftovers(&dir).is_empty(), "{case}: {:?}", leftovers(&dir));
        }
    }
    // The files written beside --out: render's PNG preview and fit-model's
    // plot and OpticStudio text, each refused as its own kind.
    let fit = vec![
        "fit-model",
        "res",
        "--model",
        "abg",
        "--out",
        "f.json",
        "-q",
    ];
    let beside: [(&str, Vec<&str>, &str); 3] = [
        (
            "render preview",
            vec![
                "render",
                "scene.toml",
                "--out",
                "pic.exr",
                "--size",
                "4,4",
                "--spp",
                "1",
            ],
            "pic.png",
        ),
        ("fit-model plot", fit.clone(), "f.png"),
        ("fit-model text", fit, "f_opticstudio.txt"),
    ];
    for (what, a, name) in beside {
        for (kind, bytes) in foreign() {
            let case = format!("{what} over a {kind}");
            let path = dir.join(name);
            std::fs::write(&path, &bytes).unwrap();
            refused(&case, &roks_in(&dir, &a), &[name, "so it is kept"]);
            assert_eq!(std::fs::read(&path).unwrap(), bytes, "{case}: changed");
            let mut forced = a.clone();
            forced.push("--force");
            ok(&roks_in(&dir, &forced), &format!("{case} --force"));
            assert_ne!(std::fs::read(&path).unwrap(), bytes, "{case}");
        }
    }
    // The issue's case, word for word: a scene in a project folder.
    std::fs::create_dir(dir.join("myproj")).unwrap();
    let scene = dir.join("myproj/al-rough.toml");
    std::fs::write(&scene, MICRO).unwrap();
    let a = [
        "export-brdf",
        "res",
        "--format",
        "zemax",
        "--out",
        "myproj/al-rough.toml",
    ];
    refused(
        "zemax over a scene",
        &roks_in(&dir, &a),
        &[
            "roks: --out: myproj/al-rough.toml: exists and is not a Zemax BSDF table that roks wrote, so it is kept: write elsewhere, or give --force to replace it",
        ],
    );
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), MICRO);
    // An empty file holds nothing to lose (`--out "$(mktemp)"`).
    std::fs::write(dir.join("empty.ply"), b"").unwrap();
    ok(
        &roks_in(
            &dir,
            &[
                "export-mesh",
                "scene.toml",
                "--out",
                "empty.ply",
                "--resolution",
                "4",
            ],
        ),
        "export-mesh over an empty file",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The folder writers and a way to make each one's result, and its rerun
/// that would take days (so a refusal must come before the work).
fn folder_writers() -> Vec<(&'static str, Vec<&'static str>, Vec<&'static str>)> {
    let zemax = vec![
        "export-brdf",
        "spec",
        "--format",
        "zemax",
        "--out",
        "OUT",
        "-q",
    ];
    vec![
        (
            "brdf",
            vec![
                "brdf",
                "scene.toml",
                "--out",
                "OUT",
                "--photons",
                "1000",
                "--stats-resolution",
                "16",
                "-q",
            ],
            vec![
                "brdf",
                "scene.toml",
                "--out",
                "OUT",
                "--photons",
                DAYS,
                "-q",
            ],
        ),
        (
            "trace",
            vec![
                "trace",
                "object.toml",
                "--out",
                "OUT",
                "--photons",
                "200",
                "-q",
            ],
            vec![
                "trace",
                "object.toml",
                "--out",
                "OUT",
                "--photons",
                DAYS,
                "-q",
            ],
        ),
        (
            "merge",
            vec!["merge", "s0", "s1", "--out", "OUT", "-q"],
            vec!["merge", "s0", "s1", "--out", "OUT", "-q"],
        ),
        (
            "fit",
            vec![
                "fit",
                "scene.toml",
                "measured.csv",
                "--param",
                "bumps[0].height[1]=2:3",
                "--photons",
                "300",
                "--max-evals",
                "3",
                "--restarts",
                "0",
                "--scan",
                "0",
                "--out",
                "OUT",
                "-q",
            ],
            vec![
                "fit",
                "scene.toml",
                "measured.csv",
                "--param",
                "bumps[0].height[1]=2:3",
                "--photons",
                DAYS,
                "--out",
                "OUT",
                "-q",
            ],
        ),
        ("export-brdf spectral zemax", zemax.clone(), zemax),
    ]
}

/// A user's file in the result folder of every folder writer: refused
/// before any work in one line naming it, exit 2, the file and the folder
/// kept; `--force` replaces the folder and names the file it removed.
#[test]
fn a_users_file_in_a_result_folder_is_kept_unless_forced() {
    let dir = setup("folders");
    for (i, shard) in ["0/2", "1/2"].iter().enumerate() {
        let out = format!("s{i}");
        let a = [
            "brdf",
            "scene.toml",
            "--shard",
            shard,
            "--out",
            &out,
            "--photons",
            "8192",
            "--stats-resolution",
            "16",
            "-q",
        ];
        ok(&roks_in(&dir, &a), "shard");
    }
    let spec = [
        "brdf",
        "scene.toml",
        "--out",
        "spec",
        "--wavelengths",
        "0.45,0.55",
        "--photons",
        "500",
        "--stats-resolution",
        "16",
        "-q",
    ];
    ok(&roks_in(&dir, &spec), "spectral run");
    std::fs::write(
        dir.join("measured.csv"),
        "theta_i_deg,theta_o_deg,brdf\n30,30,0.5\n30,0,0.2\n",
    )
    .unwrap();
    for (what, make, days) in folder_writers() {
        let folder = format!("out-{}", what.replace(' ', "-"));
        ok(
            &roks_in(&dir, &with_out(&make, &folder)),
            &format!("{what}: first run"),
        );
        let path = dir.join(&folder);
        assert!(
            names(&path).contains(&".roks-files.json".to_owned()),
            "{what}: no record"
        );
        // Its own result is replaced without a word about foreign files.
        let again = ok(
            &roks_in(&dir, &with_out(&make, &folder)),
            &format!("{what}: rerun"),
        );
        assert!(!again.contains("removed"), "{what}: {again}");
        for (kind, bytes) in foreign() {
            let case = format!("{what} over a folder holding a {kind}");
            let file = path.join("mine");
            std::fs::write(&file, &bytes).unwrap();
            let before = names(&path);
            let o = roks_in(&dir, &with_out(&days, &folder));
            refused(
                &case,
                &o,
                &[
                    &format!("--out: {folder}: holds the file \"mine\", which roks did not write"),
                    "--force",
                ],
            );
            assert_eq!(std::fs::read(&file).unwrap(), bytes, "{case}: changed");
            assert_eq!(names(&path), before, "{case}: the folder changed");
            let mut forced = with_out(&make, &folder);
            forced.push("--force");
            let stderr = ok(&roks_in(&dir, &forced), &format!("{case} --force"));
            assert!(
                stderr.contains(&format!(
                    "roks: --force: {folder}: removed mine, which roks did not write"
                )),
                "{case}: {stderr}"
            );
            assert!(!file.exists(), "{case}: not replaced");
        }
        assert!(leftovers(&dir).is_empty(), "{what}: {:?}", leftovers(&dir));
    }
    // The default folder out/NAME is judged alike, naming the scene's key.
    ok(
        &roks_in(
            &dir,
            &[
                "brdf",
                "scene.toml",
                "--photons",
                "500",
                "--stats-resolution",
                "16",
                "-q",
            ],
        ),
        "default",
    );
    std::fs::write(dir.join("out/small/notes.txt"), "mine").unwrap();
    refused(
        "default folder",
        &roks_in(&dir, &["brdf", "scene.toml", "--photons", DAYS, "-q"]),
        &["scene.toml: name: out/small: holds the file \"notes.txt\""],
    );
    assert_eq!(
        std::fs::read(dir.join("out/small/notes.txt")).unwrap(),
        b"mine"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A rerun over its own folder, after exports, fits and pictures were
/// added to it, works, removes them (they were made from the old table) and
/// names each with the command that made it, in one line.
#[test]
fn a_rerun_removes_and_names_what_later_commands_added() {
    let dir = setup("rerun");
    let res = dir.join("res");
    ok(
        &roks_in(
            &dir,
            &[
                "export-brdf",
                "res",
                "--format",
                "zemax",
                "--out",
                "res/brdf.bsdf",
                "-q",
            ],
        ),
        "zemax",
    );
    ok(
        &roks_in(
            &dir,
            &[
                "export-brdf",
                "res",
                "--format",
                "rgl",
                "--out",
                "res/brdf_rgl.bsdf",
                "-q",
            ],
        ),
        "rgl",
    );
    ok(
        &roks_in(&dir, &["fit-model", "res", "--model", "abg", "-q"]),
        "fit-model",
    );
    ok(&roks_in(&dir, &["plot", "res", "-q"]), "plot");
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(res.join(".roks-files.json")).unwrap()).unwrap();
    assert_eq!(record["command"], "brdf");
    assert_eq!(record["files"]["brdf.bsdf"], "export-brdf");
    assert_eq!(record["files"]["fit_abg_opticstudio.txt"], "fit-model");
    // plot redrew brdf's own pictures: still brdf's.
    assert_eq!(record["files"]["inplane.png"], "brdf");
    let a = [
        "brdf",
        "scene.toml",
        "--out",
        "res",
        "--photons",
        "2000",
        "--stats-resolution",
        "32",
        "--polarisation",
        "mueller",
        "-q",
    ];
    let stderr = ok(&roks_in(&dir, &a), "rerun");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(
        lines,
        [
            "roks: res: removed brdf.bsdf (export-brdf), brdf_rgl.bsdf (export-brdf), fit_abg.json (fit-model), fit_abg.png (fit-model), fit_abg_opticstudio.txt (fit-model): added to the old result by later commands and made from its table, which this run replaced; run them again to remake them"
        ],
    );
    for gone in [
        "brdf.bsdf",
        "brdf_rgl.bsdf",
        "fit_abg.json",
        "fit_abg.png",
        "fit_abg_opticstudio.txt",
    ] {
        assert!(!res.join(gone).exists(), "{gone}");
    }
    // A folder written before the record existed: judged by the names roks
    // writes; its added files are named as an earlier roks's.
    ok(
        &roks_in(&dir, &["fit-model", "res", "--model", "abg", "-q"]),
        "fit-model",
    );
    std::fs::remove_file(res.join(".roks-files.json")).unwrap();
    let stderr = ok(&roks_in(&dir, &a), "rerun without a record");
    assert!(
        stderr.contains("removed fit_abg.json (an earlier roks)"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Send `signal` (`INT`, `TERM`) to `pid` with kill(1).
fn kill(signal: &str, pid: u32) {
    let st = Command::new("kill")
        .args([&format!("-{signal}"), &pid.to_string()])
        .status()
        .expect("kill");
    assert!(st.success());
}

/// Ctrl-C and SIGTERM in the middle of a long run: one line, exit 130, the
/// out folder absent (a new one) or unchanged (an old result), and no
/// staging folder or temporary file left.
#[test]
fn an_interrupted_run_says_so_and_leaves_nothing() {
    let dir = setup("interrupt");
    let before: Vec<(String, Vec<u8>)> = names(&dir.join("res"))
        .into_iter()
        .map(|n| {
            let b = std::fs::read(dir.join("res").join(&n)).unwrap();
            (n, b)
        })
        .collect();
    for (signal, out) in [("INT", "new"), ("TERM", "new"), ("INT", "res")] {
        let case = format!("SIG{signal} into {out}");
        let child = Command::new(env!("CARGO_BIN_EXE_roks"))
            .args([
                "brdf",
                "scene.toml",
                "--out",
                out,
                "--photons",
                DAYS,
                "--stats-resolution",
                "16",
                "-q",
            ])
            .current_dir(&dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Let it start tracing (the handler is installed before any work).
        std::thread::sleep(Duration::from_millis(1500));
        kill(signal, child.id());
        let start = Instant::now();
        let o = child.wait_with_output().unwrap();
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{case}: slow to stop"
        );
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(130), "{case}: {}: {stderr}", o.status);
        assert_eq!(stderr, "roks: interrupted: nothing written\n", "{case}");
        assert!(leftovers(&dir).is_empty(), "{case}: {:?}", leftovers(&dir));
    }
    assert!(!dir.join("new").exists());
    let after: Vec<(String, Vec<u8>)> = names(&dir.join("res"))
        .into_iter()
        .map(|n| {
            let b = std::fs::read(dir.join("res").join(&n)).unwrap();
            (n, b)
        })
        .collect();
    assert_eq!(after, before, "the old result changed");
    let _ = std::fs::remove_dir_all(&dir);
}
