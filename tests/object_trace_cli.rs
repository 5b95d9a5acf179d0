//! `roks trace` through the binary: reproducibility for any thread count, and
//! the scene-error contract (exit status 2, one stderr line naming the scene
//! file and the offending key, nothing on stdout, no output folder).

mod cli_common;
mod object_common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cli_common::{CAVITY, read, summary_without_timing};
use object_common::scratch;

/// A periodic micro scene for the `micro` wall model.
const MICRO: &str = r#"
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
"#;

/// A valid object scene: a spherical cavity (radius 10, aperture above
/// z = 6) in a shell of outer radius 11; the inner wall is Lambertian, the
/// outer one rough (micro descent), the cut face `cut` has no model; a beam
/// through the aperture. Each error case breaks one thing in it.
fn good() -> String {
    format!(
        r#"
seed = 9

{CAVITY}
[walls]
s = "paint"
o = "rough"

[models.paint]
diffuse = 0.7

[models.rough]
micro = "micro.toml"

[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 2.0 }}
position = [0.0, 0.0, 7.0]
photons = 2000

[tally]
bands = 4
farfield = true
"#
    )
}

/// Write `text` as `<dir>/<case>.toml` next to the micro scene files.
fn write_scene(dir: &Path, case: &str, text: &str) -> PathBuf {
    std::fs::write(dir.join("micro.toml"), MICRO).unwrap();
    std::fs::write(
        dir.join("micro-absorbing.toml"),
        MICRO.replace(r#"edges = "periodic""#, r#"edges = "absorbing""#),
    )
    .unwrap();
    let scene = dir.join(format!("{case}.toml"));
    std::fs::write(&scene, text).unwrap();
    scene
}

/// `roks trace SCENE --out OUT -q` plus `extra` arguments.
fn trace(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_roks"))
        .arg("trace")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .arg("-q")
        .args(extra)
        .output()
        .expect("run roks")
}

/// Photon n of beam position k draws from its own stream and batch tallies
/// are summed in batch order, so `--threads 1` and `--threads 2` must write
/// byte-identical reflectance.csv and farfield.csv (and summary.json up to
/// the wall-clock `seconds`); another seed must change the results. The
/// scene exercises the random paths: diffuse walls, micro descent (random
/// frame, start point, roulette inside), a sweep of 3 beam positions with
/// 20 000 photons each (5 batches of 4096).
#[test]
fn trace_same_bytes_for_any_thread_count() {
    let dir = scratch("trace-repro");
    // Sweep the beam from the aperture (inner wall) out over the shell's
    // outer wall (micro descent); the cut face gets a model too.
    let text = good()
        .replace(
            "position = [0.0, 0.0, 7.0]",
            "sweep = { from = [0.0, 0.0, 12.0], to = [9.5, 3.0, 12.0], steps = 3 }",
        )
        .replace("diameter = 2.0", "diameter = 4.0")
        .replace("o = \"rough\"", "o = \"rough\"\ncut = \"rough\"")
        .replace("photons = 2000", "photons = 20000");
    let scene = write_scene(&dir, "repro", &text);
    let run = |name: &str, threads: &str, seed: &str| {
        let out = dir.join(name);
        let o = trace(&scene, &out, &["--threads", threads, "--seed", seed]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    };
    let one = run("t1", "1", "17");
    let two = run("t2", "2", "17");
    let other = run("seed18", "2", "18");
    for f in ["reflectance.csv", "farfield.csv"] {
        assert!(
            read(&one, f) == read(&two, f),
            "{f} differs between 1 and 2 threads"
        );
        assert!(
            read(&one, f) != read(&other, f),
            "{f} does not depend on the seed"
        );
    }
    let (s1, s2) = (summary_without_timing(&one), summary_without_timing(&two));
    assert_eq!(s1, s2, "summary.json differs between 1 and 2 threads");
    let sources = s1["sources"].as_array().unwrap();
    assert_eq!(sources.len(), 3);
    assert_eq!(s1["seed"], 17);
    // All three wall kinds were really hit somewhere along the sweep.
    for wall in ["s", "o", "cut"] {
        assert!(
            sources
                .iter()
                .any(|s| s["absorbed"][wall].as_f64().unwrap_or(0.0) > 0.0),
            "no absorption on {wall}: {s1}"
        );
    }
    // 3 positions x 80 cells, plus the header.
    let ff = String::from_utf8(read(&one, "farfield.csv")).unwrap();
    assert_eq!(ff.lines().count(), 1 + 3 * 80);
    // Consistency of the files: per source, the far-field fractions add up to
    // the reflectance of reflectance.csv (every escape after a reflection is
    // tallied in exactly one cell; 9-digit printing), the solid angles of the
    // 80 cells to 4 pi, their projected solid angles (about z) to 2 pi over
    // the full sphere, and brdf = fraction / projected solid angle.
    let refl = String::from_utf8(read(&one, "reflectance.csv")).unwrap();
    let refl: Vec<f64> = refl
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    assert_eq!(refl.len(), 3);
    let mut sums = [(0.0, 0.0, 0.0); 3];
    for l in ff.lines().skip(1) {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        let (src, omega, proj, frac, brdf) = (v[0] as usize, v[9], v[10], v[11], v[13]);
        sums[src].0 += frac;
        sums[src].1 += omega;
        sums[src].2 += proj;
        assert!(
            (brdf - frac / proj).abs() <= 1e-8 * brdf.abs().max(1e-300),
            "{l}"
        );
    }
    for (k, (f, o, p)) in sums.iter().enumerate() {
        assert!(
            (f - refl[k]).abs() <= 1e-7 * refl[k],
            "source {k}: {f} vs {}",
            refl[k]
        );
        assert!((o - 4.0 * std::f64::consts::PI).abs() < 1e-9, "{o}");
        assert!((p - 2.0 * std::f64::consts::PI).abs() < 1e-9, "{p}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Replace `from` (which must occur) by `to` in the good scene.
fn broken(from: &str, to: &str) -> String {
    assert!(good().contains(from), "`{from}` not in the good scene");
    good().replacen(from, to, 1)
}

/// Run `roks trace` on `text` and check the error contract; `expect` are
/// substrings the stderr line must contain besides the file path.
fn check(case: &str, text: &str, expect: &[&str]) {
    check_with(case, text, &[], expect);
}

/// [`check`] with `extra` command-line arguments.
fn check_with(case: &str, text: &str, extra: &[&str], expect: &[&str]) {
    let dir = scratch(&format!("trace-err-{case}"));
    let scene = write_scene(&dir, case, text);
    let out = dir.join("out");
    let o = trace(&scene, &out, extra);
    cli_common::assert_input_error(case, &o, &scene, &out, expect);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The good scene itself runs (so each case below fails for its own reason).
#[test]
fn good_scene_runs() {
    let dir = scratch("trace-good");
    let scene = write_scene(&dir, "good", &good());
    let out = dir.join("out");
    let o = trace(&scene, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["summary.json", "reflectance.csv", "farfield.csv"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `summary.json` says whether the far field was tallied (`farfield`, and
/// `farfield_stokes` for its Stokes vectors), so a missing `farfield.csv`
/// is told from one never written; each key matches the files.
#[test]
fn summary_says_whether_the_far_field_was_tallied() {
    let dir = scratch("trace-farfield-key");
    for (case, text, tallied) in [
        ("with", good(), true),
        (
            "without",
            good().replace("farfield = true", "farfield = false"),
            false,
        ),
    ] {
        let scene = write_scene(&dir, case, &text);
        let out = dir.join(case);
        let o = trace(&scene, &out, &[]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
        assert_eq!(summary["farfield"], serde_json::json!(tallied), "{case}");
        assert_eq!(
            summary["farfield_stokes"],
            serde_json::json!(false),
            "{case}"
        );
        assert_eq!(out.join("farfield.csv").exists(), tallied, "{case}");
        assert!(!out.join("farfield_stokes.csv").exists(), "{case}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A BRDF table that does not exist yet names the command that makes it:
/// the micro scene beside the object scene whose result folder it is
/// (`micro.toml`, named by its file stem, writes `out/micro/`), else the
/// command's general form.
#[test]
fn missing_brdf_table_names_the_command_that_makes_it() {
    check(
        "missing_table",
        &broken("diffuse = 0.7", r#"brdf = "out/micro/brdf.csv""#),
        &[
            "models.paint.brdf",
            "out/micro/brdf.csv: no such file",
            "`roks brdf ",
            "micro.toml --out ",
            "run that first",
        ],
    );
    check(
        "missing_table_unknown",
        &broken("diffuse = 0.7", r#"brdf = "tables/brdf.csv""#),
        &[
            "tables/brdf.csv: no such file",
            "`roks brdf MICRO_SCENE --out ",
        ],
    );
}

#[test]
fn unknown_key() {
    check(
        "unknown_key",
        &broken("[tally]\n", "[tally]\ncolour = 1\n"),
        &["tally.colour", "unknown field"],
    );
}

#[test]
fn region_names_unknown_surface() {
    check(
        "unknown_surface",
        &broken(r#"region = "-s -cut""#, r#"region = "-s -nope""#),
        &["cells[0].region", "unknown surface `nope`"],
    );
}

#[test]
fn beam_position_inside_a_solid() {
    check(
        "in_solid",
        &broken("position = [0.0, 0.0, 7.0]", "position = [0.0, 0.0, -10.5]"),
        &["sources[0].position", "solid cell `shell`"],
    );
}

/// The beam's centre is in the cavity but its disc reaches into the shell:
/// photons there would start inside a solid, so this is a scene error too.
#[test]
fn beam_disc_reaching_into_a_solid() {
    check(
        "disc_in_solid",
        &broken(
            "beam = { direction = [0.0, 0.0, -1.0], diameter = 2.0 }\nposition = [0.0, 0.0, 7.0]",
            "beam = { direction = [1.0, 0.0, 0.0], diameter = 24.0 }\nposition = [0.0, 0.0, 0.0]",
        ),
        &["sources[0].beam.diameter", "solid cell `shell`"],
    );
}

#[test]
fn void_cells_overlap_at_the_beam() {
    check(
        "overlap",
        &broken(
            "[[cells]]\nname = \"shell\"",
            "[[cells]]\nname = \"inner\"\nregion = \"-s\"\nfill = \"void\"\n[[cells]]\nname = \"shell\"",
        )
        .replace("position = [0.0, 0.0, 7.0]", "position = [0.0, 0.0, 5.0]"),
        &["cells", "cavity", "inner", "overlap"],
    );
}

#[test]
fn wall_names_unknown_model() {
    check(
        "unknown_model",
        &broken(r#"s = "paint""#, r#"s = "varnish""#),
        &["walls.s", "unknown model `varnish`"],
    );
}

#[test]
fn model_with_two_kinds() {
    check(
        "two_kinds",
        &broken("diffuse = 0.7\n", "diffuse = 0.7\nreflectance = 0.5\n"),
        &["models.paint", "exactly one kind"],
    );
}

#[test]
fn micro_model_with_absorbing_edges() {
    check(
        "absorbing",
        &broken(
            r#"micro = "micro.toml""#,
            r#"micro = "micro-absorbing.toml""#,
        ),
        &["models.rough.micro", "periodic"],
    );
}

/// A beam wide enough to hit the shell's flat top (surface `cut`, no model):
/// found only while tracing, still a scene error before any output.
#[test]
fn photons_hit_a_surface_without_model() {
    check(
        "unmodelled",
        &broken("diameter = 2.0", "diameter = 18.0"),
        &["walls.cut", "no model"],
    );
}

#[test]
fn unknown_polarisation_state() {
    check(
        "unknown_state",
        &broken(
            "photons = 2000\n",
            "photons = 2000\npolarisation = \"diagonal\"\n",
        ),
        &["sources[0].polarisation", "unknown state `diagonal`"],
    );
}

#[test]
fn unphysical_stokes_vector() {
    check(
        "stokes_dop",
        &broken(
            "photons = 2000\n",
            "photons = 2000\npolarisation = [1.0, 1.0, 1.0, 0.0]\n",
        ),
        &["sources[0].polarisation", "degree of polarisation"],
    );
}

#[test]
fn unknown_polarisation_tally() {
    check(
        "mueller_tally",
        &broken(
            "farfield = true\n",
            "farfield = true\npolarisation = \"mueller\"\n",
        ),
        &["tally.polarisation", "\"mueller\" is for micro scenes"],
    );
}

#[test]
fn stokes_tally_needs_the_far_field() {
    check(
        "stokes_no_farfield",
        &broken("farfield = true\n", "polarisation = \"stokes\"\n"),
        &["tally.polarisation", "farfield = true"],
    );
}

#[test]
fn stokes_tally_needs_polarised_transport() {
    let text = broken(
        "farfield = true\n",
        "farfield = true\npolarisation = \"stokes\"\n",
    );
    check(
        "stokes_scalar",
        &format!("{text}\n[transport]\npolarisation = false\n"),
        &["transport.polarisation", "conflicts"],
    );
    check_with(
        "stokes_no_polarisation",
        &text,
        &["--no-polarisation"],
        &["tally.polarisation", "--no-polarisation"],
    );
}
