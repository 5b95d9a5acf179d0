//! The output folder: a result folder is replaced whole by a
//! rerun (no stale file of an earlier run survives, a reader or a kill sees
//! the old result or the new one, never a mixture); `--out` and the scene's
//! `name` are checked before any work, with one line naming them; single
//! output files are replaced atomically.

mod cli_common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Instant;

use cli_common::{assert_input_error, ok};

/// A small periodic micro scene (fast to trace).
const MICRO: &str = r#"
name = "small"

[surface]
size = [10.0, 10.0]
edges = "periodic"
material = "paint"

[materials.paint]
reflectance = 0.8

[[bumps]]
shape = "ellipsoid"
count = 10
radius = [1.5, 2.5]
height = [1.0, 2.5]
seed = 4

[light]
theta_deg = [30]
photons = 4096

[tally]
bands = 8
"#;

/// An object scene with a micro wall (`micro.toml` beside it) and the far
/// field tallied.
fn object_scene() -> String {
    cli_common::painted_cavity(2000, "farfield = true\n")
}

/// A fresh, empty scratch folder for this test process.
fn scratch(name: &str) -> PathBuf {
    cli_common::scratch("outdir", name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `dir/scene.toml` holding `text`.
fn write_scene(dir: &Path, text: &str) -> PathBuf {
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    scene
}

/// Run roks in `cwd`, killed after 60 s (a hang detector, not a speed
/// assertion: every run here takes well under a second).
fn roks_in(cwd: &Path, args: &[&str]) -> Output {
    cli_common::roks_in(cwd, args, 60)
}

/// Every entry of `dir` (names, hidden ones included) and the bytes of its
/// files; `summary.json` without the wall-clock fields.
fn contents(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut m = BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        let t = e.file_type().unwrap();
        let bytes = if t.is_dir() {
            b"<folder>".to_vec()
        } else if t.is_symlink() {
            b"<link>".to_vec()
        } else if name == "summary.json" {
            serde_json::to_vec(&cli_common::summary_without_timing(dir)).unwrap()
        } else {
            std::fs::read(e.path()).unwrap()
        };
        m.insert(name, bytes);
    }
    m
}

/// The entry names of `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    contents(dir).into_keys().collect()
}

/// `--out` refused: exit 2, one line naming `--out`, the path and `reason`,
/// nothing on stdout, and `dir`'s entries unchanged.
fn assert_out_refused(
    case: &str,
    o: &Output,
    out: &Path,
    reason: &str,
    dir: &Path,
    before: &[String],
) {
    assert_input_error(case, o, out, &dir.join("never-created"), &["--out", reason]);
    assert_eq!(names(dir), before, "{case}: the folder changed");
}

/// A rerun into a folder holding another run's result leaves exactly the
/// new run's files: no hemisphere map of an angle no longer run, no
/// tallies.json of an earlier --shard run, no brdf.bsdf of an earlier
/// --export, no file added by export-brdf; and nothing beside the folder.
#[test]
fn a_rerun_replaces_the_result_folder_whole() {
    let dir = scratch("rerun");
    let scene = write_scene(&dir, MICRO);
    let out = dir.join("res");
    let fresh = dir.join("fresh");
    let common = ["--photons", "8192", "--stats-resolution", "32", "-q"];
    let mut old = vec!["brdf", s(&scene), "--out", s(&out), "--theta", "0,30"];
    old.extend(["--shard", "0/2", "--export", "zemax"]);
    old.extend(common);
    ok(&roks_in(&dir, &old), "old run");
    ok(
        &roks_in(
            &dir,
            &[
                "export-brdf",
                s(&out),
                "--format",
                "merl",
                "--out",
                s(&out.join("extra.binary")),
                "-q",
            ],
        ),
        "export-brdf",
    );
    let had = names(&out);
    for f in [
        "hemisphere_0deg.png",
        "tallies.json",
        "brdf.bsdf",
        "extra.binary",
    ] {
        assert!(had.contains(&f.to_string()), "old run lacks {f}: {had:?}");
    }
    for target in [&out, &fresh] {
        let mut new = vec!["brdf", s(&scene), "--out", s(target), "--theta", "45"];
        new.extend(common);
        ok(&roks_in(&dir, &new), "new run");
    }
    assert_eq!(contents(&out), contents(&fresh));
    assert_eq!(names(&dir), ["fresh", "res", "scene.toml"]);
}

/// `roks trace` and `roks merge` replace their folders whole too: a rerun
/// without the far field leaves no farfield.csv; a merge into a shard's
/// folder leaves the merged result only.
#[test]
fn trace_and_merge_replace_their_folders_whole() {
    let dir = scratch("trace-merge");
    let scene = write_scene(&dir, &object_scene());
    let out = dir.join("res");
    ok(
        &roks_in(&dir, &["trace", s(&scene), "--out", s(&out), "-q"]),
        "trace",
    );
    assert!(out.join("farfield.csv").exists());
    let scene2 = dir.join("nofar.toml");
    std::fs::write(
        &scene2,
        object_scene().replace("farfield = true", "farfield = false"),
    )
    .unwrap();
    ok(
        &roks_in(&dir, &["trace", s(&scene2), "--out", s(&out), "-q"]),
        "trace again",
    );
    assert_eq!(
        names(&out),
        [
            ".roks-files.json",
            "reflectance.csv",
            "reflectance.png",
            "summary.json"
        ]
    );

    let micro = write_scene(&dir, MICRO);
    let shards: Vec<PathBuf> = (0..2).map(|i| dir.join(format!("sh{i}"))).collect();
    for (i, sh) in shards.iter().enumerate() {
        let shard = format!("{i}/2");
        let a = [
            "brdf",
            s(&micro),
            "--out",
            s(sh),
            "--shard",
            &shard,
            "--photons",
            "8192",
            "--stats-resolution",
            "32",
            "-q",
        ];
        ok(&roks_in(&dir, &a), "shard");
    }
    // Merge into the first shard's own folder: refused, it is an input.
    let a = [
        "merge",
        s(&shards[0]),
        s(&shards[1]),
        "--out",
        s(&shards[0]),
        "-q",
    ];
    assert_eq!(
        roks_in(&dir, &a).status.code(),
        Some(2),
        "merge into a shard"
    );
    // Merge into a copy of a shard's folder holding an export the merge is
    // not asked for (brdf.bsdf): it must go, the folder is the merge's own
    // (surface.png is the shards', which the merge keeps).
    let copy = dir.join("copy");
    std::fs::create_dir(&copy).unwrap();
    for name in names(&shards[0]) {
        std::fs::copy(shards[0].join(&name), copy.join(&name)).unwrap();
    }
    std::fs::write(copy.join("brdf.bsdf"), "a stale export\n").unwrap();
    // Not in the folder's record (.roks-files.json, copied from the shard):
    // a file roks did not write there, refused unless --force
    // (docs/src/output-safety.md).
    let mut a = vec![
        "merge",
        s(&shards[0]),
        s(&shards[1]),
        "--out",
        s(&copy),
        "-q",
    ];
    let o = roks_in(&dir, &a);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("holds the file \"brdf.bsdf\""));
    a.push("--force");
    ok(&roks_in(&dir, &a), "merge");
    assert_eq!(
        names(&copy),
        [
            ".roks-files.json",
            "brdf.csv",
            "hemisphere_30deg.png",
            "inplane.csv",
            "inplane.png",
            "reflectance.png",
            "summary.json",
            "surface.png",
            "tallies.json"
        ]
    );
}

/// Leftovers of killed runs beside a result folder (`.NAME.new-PID`,
/// `.NAME.old-PID` of a process that is gone) are removed by the next write;
/// those of a running process (pid 1) are left alone. A killed single-file
/// write's `.FILE.PID.tmp` goes with the next write of that file.
#[test]
fn leftovers_of_killed_runs_are_removed() {
    let dir = scratch("leftovers");
    let scene = write_scene(&dir, MICRO);
    let out = dir.join("res");
    // pid_max is at most 2^22 on Linux: these processes cannot exist.
    for stale in [".res.new-4194305", ".res.old-4194306", ".res.new-1"] {
        std::fs::create_dir(dir.join(stale)).unwrap();
        std::fs::write(dir.join(stale).join("brdf.csv"), "stale").unwrap();
    }
    std::fs::write(dir.join(".mesh.ply.4194305.tmp"), "stale").unwrap();
    std::fs::write(dir.join(".mesh.ply.1.tmp"), "live").unwrap();
    let a = [
        "brdf",
        s(&scene),
        "--out",
        s(&out),
        "--photons",
        "4096",
        "--stats-resolution",
        "32",
        "-q",
    ];
    ok(&roks_in(&dir, &a), "brdf");
    let mesh = dir.join("mesh.ply");
    let a = [
        "export-mesh",
        s(&scene),
        "--out",
        s(&mesh),
        "--resolution",
        "8",
    ];
    ok(&roks_in(&dir, &a), "export-mesh");
    assert_eq!(
        names(&dir),
        [
            ".mesh.ply.1.tmp",
            ".res.new-1",
            "mesh.ply",
            "res",
            "scene.toml"
        ]
    );
}

/// A run killed (SIGKILL) at any moment, many times, while it replaces an
/// older result: the folder always holds the whole old result or the whole
/// new one (same names, same bytes; no `*.tmp`, no staging folder inside);
/// the next complete run removes every leftover beside it.
#[test]
fn a_killed_run_leaves_the_old_result_or_the_new_one() {
    let dir = scratch("kill");
    let scene = write_scene(&dir, MICRO);
    let out = dir.join("res");
    let run = |target: &Path, theta: &str, seed: &str| {
        vec![
            "brdf".to_string(),
            s(&scene).into(),
            "--out".into(),
            s(target).into(),
            "--theta".into(),
            theta.into(),
            "--seed".into(),
            seed.into(),
            "--photons".into(),
            "4096".into(),
            "--stats-resolution".into(),
            "32".into(),
            "--threads".into(),
            "1".into(),
            "-q".into(),
        ]
    };
    let old_args = run(&out, "30", "1");
    let new_args = run(&out, "0,20,40,50,60,70,80", "2");
    // The reference results: the old one kept (copied back into `out`
    // before each round), the new one's contents.
    let reference = |args: &[String], d: &Path| {
        let mut a = args.to_vec();
        a[3] = s(d).into();
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        ok(&roks_in(&dir, &a), "reference run");
        contents(d)
    };
    let kept = scratch("kill-old");
    let old_dir = kept.join("res");
    let old = reference(&old_args, &old_dir);
    let start = Instant::now();
    let new = reference(&new_args, &kept.join("new"));
    let span = start.elapsed();
    assert_ne!(
        old.keys().collect::<Vec<_>>(),
        new.keys().collect::<Vec<_>>()
    );
    let new_args: Vec<&str> = new_args.iter().map(String::as_str).collect();

    let (mut saw_old, mut saw_new, mut staged) = (0, 0, 0);
    let rounds = 40;
    for k in 0..rounds {
        if !out.exists() || contents(&out) != old {
            let _ = std::fs::remove_dir_all(&out);
            std::fs::create_dir(&out).unwrap();
            for name in old.keys() {
                std::fs::copy(old_dir.join(name), out.join(name)).unwrap();
            }
        }
        // Kill times spread over the second half of the run and a little
        // beyond (tracing, plotting, the write phase, the swap): a fixed
        // sequence, not tuned to pass.
        let f = k as f64 / rounds as f64;
        let delay = span.mul_f64(0.4 + 0.8 * f);
        let mut child = Command::new(env!("CARGO_BIN_EXE_roks"))
            .args(&new_args)
            .current_dir(&dir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(delay);
        let _ = child.kill();
        child.wait().unwrap();
        assert!(out.exists(), "round {k}: no result folder at all");
        if names(&dir).iter().any(|n| n.starts_with(".res.new-")) {
            staged += 1;
        }
        let now = contents(&out);
        if now == old {
            saw_old += 1;
        } else if now == new {
            saw_new += 1;
        } else {
            panic!(
                "round {k}: neither the old nor the new result: {:?}",
                now.keys().collect::<Vec<_>>()
            );
        }
    }
    eprintln!(
        "{rounds} kills: {saw_old} left the old result, {saw_new} the new one; {staged} during the write phase (a staging folder left)"
    );
    ok(&roks_in(&dir, &new_args), "complete run");
    assert_eq!(contents(&out), new);
    assert_eq!(names(&dir), ["res", "scene.toml"]);
}

/// `--out` that cannot take a result folder is refused before any work
/// (with 10^12 photons, tracing would take days): a file, a path through a
/// file, a folder in /proc, a folder that is not a roks result (it would be
/// replaced whole), `/`; for every command that writes a folder.
#[test]
fn a_bad_out_folder_is_refused_before_tracing() {
    let dir = scratch("bad-out");
    let scene = write_scene(&dir, MICRO);
    let object = dir.join("object.toml");
    std::fs::write(&object, object_scene()).unwrap();
    let measured = dir.join("measured.csv");
    std::fs::write(
        &measured,
        "theta_i_deg,theta_o_deg,brdf\n30,30,0.5\n30,0,0.2\n",
    )
    .unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, "mine").unwrap();
    let mine = dir.join("mine");
    std::fs::create_dir_all(mine.join("sub")).unwrap();
    std::fs::write(mine.join("notes.txt"), "mine").unwrap();
    let notes = dir.join("notes");
    std::fs::create_dir(&notes).unwrap();
    std::fs::write(notes.join("notes.txt"), "mine").unwrap();
    let through = file.join("x");
    let proc = PathBuf::from("/proc/roks-no-such-folder");
    let before = names(&dir);
    let cases: [(&Path, &str); 6] = [
        (&file, "is a file, not a folder"),
        (&through, "a-file is a file, not a folder"),
        (&proc, "cannot create anything in /proc"),
        (&mine, "holds the folder \"sub\""),
        (&notes, "not a roks result folder"),
        (Path::new("/"), "must name a file or folder"),
    ];
    for (out, reason) in cases {
        let o = s(out);
        let commands: [Vec<&str>; 4] = [
            vec![
                "brdf",
                s(&scene),
                "--out",
                o,
                "--photons",
                "1000000000000",
                "-q",
            ],
            vec![
                "trace",
                s(&object),
                "--out",
                o,
                "--photons",
                "1000000000000",
                "-q",
            ],
            vec!["merge", s(&dir), "--out", o, "-q"],
            vec![
                "fit",
                s(&scene),
                s(&measured),
                "--param",
                "bumps[0].height[1]=2:3",
                "--photons",
                "1000000000000",
                "--out",
                o,
                "-q",
            ],
        ];
        for a in commands {
            let case = format!("{} --out {o}", a[0]);
            assert_out_refused(&case, &roks_in(&dir, &a), out, reason, &dir, &before);
        }
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"mine");
    assert_eq!(names(&mine), ["notes.txt", "sub"]);
}

/// Single-file outputs: `--out` at a folder, through a file, in /proc, or
/// (render) the PNG preview's own name is refused before any work, one
/// line; a rewrite replaces the file atomically (no temporary file left).
#[test]
fn a_bad_out_file_is_refused_before_any_work() {
    let dir = scratch("bad-file");
    let scene = write_scene(&dir, MICRO);
    let file = dir.join("a-file");
    std::fs::write(&file, "mine").unwrap();
    let result = dir.join("res");
    let a = [
        "brdf",
        s(&scene),
        "--out",
        s(&result),
        "--photons",
        "4096",
        "--stats-resolution",
        "32",
        "-q",
    ];
    ok(&roks_in(&dir, &a), "brdf");
    let before = names(&dir);
    let folder = dir.clone();
    let through = file.join("x.ply");
    let proc = PathBuf::from("/proc/roks-no-such-folder/x.ply");
    let png = dir.join("x.png");
    for (out, reason) in [
        (&folder, "is a folder, not a file"),
        (&through, "a-file is a file, not a folder"),
        (&proc, "cannot create anything in /proc"),
    ] {
        let o = s(out);
        let commands: [Vec<&str>; 4] = [
            vec!["render", s(&scene), "--out", o, "--spp", "1000000000"],
            vec!["export-mesh", s(&scene), "--out", o],
            vec!["export-heightfield", s(&scene), "--out", o],
            vec![
                "export-brdf",
                s(&result),
                "--format",
                "zemax",
                "--out",
                o,
                "-q",
            ],
        ];
        for a in commands {
            let case = format!("{} --out {o}", a[0]);
            assert_out_refused(&case, &roks_in(&dir, &a), out, reason, &dir, &before);
        }
    }
    let a = ["render", s(&scene), "--out", s(&png), "--spp", "1000000000"];
    assert_out_refused(
        "render --out x.png",
        &roks_in(&dir, &a),
        &png,
        "PNG preview",
        &dir,
        &before,
    );

    // An output that is one of the command's inputs, which writing would
    // replace (the scene; the result's table or summary, also through
    // another spelling of the path): refused, the input untouched (found by
    // fuzzing: export-mesh --out scene.toml overwrote the scene).
    let scene_bytes = std::fs::read(&scene).unwrap();
    let table = result.join("brdf.csv");
    let table_bytes = std::fs::read(&table).unwrap();
    let other_spelling = dir.join("res/../res/summary.json");
    let summary_bytes = std::fs::read(&other_spelling).unwrap();
    let cases: [(Vec<&str>, &Path); 5] = [
        (vec!["export-mesh", s(&scene), "--out", s(&scene)], &scene),
        (
            vec!["export-heightfield", s(&scene), "--out", s(&scene)],
            &scene,
        ),
        (
            vec![
                "render",
                s(&scene),
                "--out",
                s(&scene),
                "--spp",
                "1000000000",
            ],
            &scene,
        ),
        (
            vec![
                "export-brdf",
                s(&result),
                "--format",
                "zemax",
                "--out",
                s(&table),
                "-q",
            ],
            &table,
        ),
        (
            vec![
                "export-brdf",
                s(&result),
                "--format",
                "zemax",
                "--out",
                s(&other_spelling),
                "-q",
            ],
            &other_spelling,
        ),
    ];
    for (a, out) in cases {
        let case = format!("{} --out {}", a[0], out.display());
        assert_out_refused(
            &case,
            &roks_in(&dir, &a),
            out,
            "a file this run reads",
            &dir,
            &before,
        );
    }
    assert_eq!(std::fs::read(&scene).unwrap(), scene_bytes);
    assert_eq!(std::fs::read(&table).unwrap(), table_bytes);
    assert_eq!(std::fs::read(&other_spelling).unwrap(), summary_bytes);

    // Rewrites replace the files in place, EXR and PNG each atomically.
    let exr = dir.join("r.exr");
    for spp in ["1", "2"] {
        let a = [
            "render",
            s(&scene),
            "--out",
            s(&exr),
            "--size",
            "8,8",
            "--spp",
            spp,
        ];
        ok(&roks_in(&dir, &a), "render");
    }
    let mut want = before.clone();
    want.extend(["r.exr".to_string(), "r.png".to_string()]);
    want.sort();
    assert_eq!(names(&dir), want);
}

/// A scene `name` that is not one plain folder name is refused, one line
/// naming the key, whether or not --out is given (the name is the result
/// folder out/NAME): nothing is written, inside or outside out/.
#[test]
fn a_scene_name_that_is_not_one_plain_folder_is_refused() {
    let dir = scratch("names");
    let long = "x".repeat(201);
    let body = MICRO.replace("name = \"small\"\n", "");
    let object_body = object_scene();
    for (name, reason) in [
        (r#""../escaped""#, "contains '/'"),
        (r#""/tmp/abs""#, "contains '/'"),
        (r#""a/b""#, "contains '/'"),
        (r#""a\\b""#, "contains '\\\\'"),
        (r#""a\u0000b""#, "contains '\\0'"),
        (r#""a\nb""#, "contains '\\n'"),
        (r#""""#, "is empty"),
        (r#"".""#, "starts with `.`"),
        (r#""..""#, "starts with `.`"),
        (r#"".hidden""#, "starts with `.`"),
        (&format!("{long:?}"), "201 bytes"),
    ] {
        for (command, text) in [("brdf", &body), ("trace", &object_body)] {
            let scene = dir.join("scene.toml");
            std::fs::write(&scene, format!("name = {name}\n{text}")).unwrap();
            for with_out in [false, true] {
                let mut a = vec![command, s(&scene), "--photons", "1000000000000", "-q"];
                if with_out {
                    a.extend(["--out", "res"]);
                }
                let o = roks_in(&dir, &a);
                let case = format!("{command} name = {name}");
                assert_input_error(&case, &o, &scene, &dir.join("out"), &["name", reason]);
                assert_eq!(names(&dir), ["scene.toml"], "{case}");
            }
        }
    }
    // Without a `name`, the file stem is the name: `..toml` gives `.`.
    let scene = dir.join("..toml");
    std::fs::write(&scene, &body).unwrap();
    let o = roks_in(&dir, &["brdf", s(&scene), "--photons", "100", "-q"]);
    assert_input_error(
        "..toml",
        &o,
        &scene,
        &dir.join("out"),
        &["name", "set name ="],
    );
    // A plain name with spaces and non-ASCII letters is fine.
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, format!("name = \"Zähler 2\"\n{body}")).unwrap();
    let o = roks_in(
        &dir,
        &[
            "brdf",
            s(&scene),
            "--photons",
            "4096",
            "--stats-resolution",
            "32",
            "-q",
        ],
    );
    ok(&o, "plain name");
    assert!(dir.join("out/Zähler 2/summary.json").exists());
    assert_eq!(names(&dir.join("out")), ["Zähler 2"]);
}

/// A symbolic link to a result folder: the rerun replaces the folder it
/// points to, and the link still leads to the (new) result; `DIR/.` is DIR.
#[test]
fn a_link_to_a_result_folder_is_followed() {
    let dir = scratch("link");
    let scene = write_scene(&dir, MICRO);
    let target = dir.join("target");
    let link = dir.join("link");
    let a = [
        "brdf",
        s(&scene),
        "--out",
        s(&target),
        "--theta",
        "30",
        "--photons",
        "4096",
        "--stats-resolution",
        "32",
        "-q",
    ];
    ok(&roks_in(&dir, &a), "brdf");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let a = [
        "brdf",
        s(&scene),
        "--out",
        s(&link),
        "--theta",
        "45",
        "--photons",
        "4096",
        "--stats-resolution",
        "32",
        "-q",
    ];
    ok(&roks_in(&dir, &a), "brdf via the link");
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(target.join("hemisphere_45deg.png").exists());
    assert!(!target.join("hemisphere_30deg.png").exists());
    assert_eq!(names(&dir), ["link", "scene.toml", "target"]);
    // `link/.` and `target/.` name the same folders (not a staging folder
    // inside them).
    for (out, theta) in [("link/.", "60"), ("target/.", "70")] {
        let a = [
            "brdf",
            s(&scene),
            "--out",
            out,
            "--theta",
            theta,
            "--photons",
            "4096",
            "--stats-resolution",
            "32",
            "-q",
        ];
        ok(&roks_in(&dir, &a), out);
        let png = format!("hemisphere_{theta}deg.png");
        assert_eq!(
            names(&target),
            [
                ".roks-files.json",
                "brdf.csv",
                png.as_str(),
                "inplane.csv",
                "inplane.png",
                "reflectance.png",
                "summary.json",
                "surface.png"
            ]
        );
        assert_eq!(names(&dir), ["link", "scene.toml", "target"]);
    }
}

/// Late bad input (found by the trace: a wall without a model) writes
/// nothing either: no folder, no staging folder beside it.
#[test]
fn an_input_error_after_tracing_writes_nothing() {
    let dir = scratch("late");
    let scene = write_scene(&dir, &object_scene().replace("s = \"paint\"\n", ""));
    let out = dir.join("res");
    let o = roks_in(&dir, &["trace", s(&scene), "--out", s(&out), "-q"]);
    assert_input_error("unmodelled wall", &o, &scene, &out, &["walls.s"]);
    assert_eq!(names(&dir), ["scene.toml"]);
}

/// An edited copy of a scene that kept its `name` never silently replaces
/// the original's result in the default folder `out/<name>`: refused (exit
/// 2, one line naming the copy's `name` key and the other scene file, the
/// folder untouched). The same scene file by another spelling of its path
/// reruns into it, and `--out` writes the copy's result on purpose.
#[test]
fn a_copy_of_a_scene_never_replaces_the_original_result() {
    let dir = scratch("copy");
    let original = write_scene(&dir, MICRO);
    let copy = dir.join("copy.toml");
    std::fs::write(
        &copy,
        MICRO.replace("reflectance = 0.8", "reflectance = 0.7"),
    )
    .unwrap();
    let run = |scene: &str| {
        roks_in(
            &dir,
            &[
                "brdf",
                scene,
                "--photons",
                "4096",
                "--stats-resolution",
                "32",
                "-q",
            ],
        )
    };
    ok(&run("scene.toml"), "original");
    let result = dir.join("out").join("small");
    let before = contents(&result);
    let o = run("copy.toml");
    assert_input_error(
        "copy",
        &o,
        Path::new("copy.toml"),
        &dir.join("never-created"),
        &["name", "holds the result of scene.toml", "--out"],
    );
    assert_eq!(contents(&result), before, "the original's result changed");
    // The same file by another path: a rerun.
    ok(&run("./scene.toml"), "same file, other path");
    ok(&run(s(&original)), "same file, absolute path");
    // On purpose: --out.
    let o = roks_in(
        &dir,
        &[
            "brdf",
            "copy.toml",
            "--out",
            "out/small",
            "--photons",
            "4096",
            "--stats-resolution",
            "32",
            "-q",
        ],
    );
    ok(&o, "copy with --out");
    let _ = std::fs::remove_dir_all(&dir);
}
