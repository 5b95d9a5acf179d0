//! Shared by the CLI tests: the command line's contract for bad input, and
//! reading output folders for byte-for-byte comparisons.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

/// Run the `roks` binary of this build with `args`, collecting its output.
pub fn roks(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(args)
        .output()
        .expect("run roks")
}

/// `roks` with `args`, killed after `seconds`: `None` if it had not
/// finished by then (a hang, or a refusal that did not come before the
/// work).
pub fn roks_within(args: &[&str], seconds: u64) -> Option<std::process::Output> {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run roks");
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_secs(seconds) {
        if child.try_wait().expect("wait").is_some() {
            return Some(child.wait_with_output().expect("output"));
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

/// The bytes of `dir/name` (panics naming the file).
pub fn read(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

/// `dir/summary.json` without its wall-clock fields `seconds` and
/// `segments_per_second` (at any depth): what must be identical between
/// runs of the same seed.
pub fn summary_without_timing(dir: &Path) -> Value {
    fn strip(v: &mut Value) {
        match v {
            Value::Object(m) => {
                m.remove("seconds");
                m.remove("segments_per_second");
                m.values_mut().for_each(strip);
            }
            Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut v: Value = serde_json::from_slice(&read(dir, "summary.json")).unwrap();
    strip(&mut v);
    v
}

/// Bad input: exit status 2, exactly one line on stderr containing the scene
/// file's path and every string of `expect` (the key, the reason), no panic,
/// nothing on stdout, and no output folder `out` created.
pub fn assert_input_error(case: &str, o: &Output, scene: &Path, out: &Path, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{case}: status {}, stderr {stderr}",
        o.status
    );
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    assert!(stderr.ends_with('\n'), "{case}: {stderr:?}");
    let line = stderr.trim_end_matches('\n');
    assert!(
        !line.is_empty() && !line.contains('\n'),
        "{case}: not one line: {stderr:?}"
    );
    let path = scene.display().to_string();
    assert!(
        line.contains(&path),
        "{case}: no file path `{path}` in {line:?}"
    );
    for e in expect {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
    assert!(
        o.stdout.is_empty(),
        "{case}: stdout {:?}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(!out.exists(), "{case}: output folder was created");
}

/// A fresh, empty folder `roks-{prefix}-{pid}-{name}` in the system's
/// temporary folder (`prefix` names the test file, the process id keeps
/// concurrent runs apart).
pub fn scratch(prefix: &str, name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("roks-{prefix}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run roks in `cwd`, killed after `seconds` (a hang detector, not a speed
/// assertion): panics naming `args` if it is still running then.
pub fn roks_in(cwd: &Path, args: &[&str], seconds: u64) -> Output {
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(args)
        .current_dir(cwd)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run roks");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(seconds) {
            child.kill().unwrap();
            panic!("roks {args:?} still running after {seconds} s");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.wait_with_output().unwrap()
}

/// `o` succeeded (else panics with `what`, the status and stderr); its
/// stderr.
pub fn ok(o: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{what}: {}: {stderr}", o.status);
    stderr
}

/// The entry names of `dir`, sorted (hidden ones included).
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `roks brdf SCENE --out OUT --photons PHOTONS -q`, asserted to succeed
/// (else panics with its stderr).
pub fn brdf_quiet(scene: &Path, out: &Path, photons: &str) {
    let o = roks(&[
        "brdf",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--photons",
        photons,
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The quadrics and cells of the object tests' spherical cavity: a sphere
/// `s` of radius 10 cut by the plane `cut` at z = 6 (the aperture), in a
/// shell out to the sphere `o` of radius 11 (cells `cavity`, `shell`).
/// Scenes add `seed`, `[walls]`, models, sources and tallies around it.
pub const CAVITY: &str = r#"[quadrics]
s = { sphere = { center = [0.0, 0.0, 0.0], r = 10.0 } }
o = { sphere = { center = [0.0, 0.0, 0.0], r = 11.0 } }
cut = { plane = [0.0, 0.0, 1.0, 6.0] }

[[cells]]
name = "cavity"
region = "-s -cut"
fill = "void"
[[cells]]
name = "shell"
region = "+s -o -cut"
fill = "solid"
"#;

/// The [`CAVITY`] with every face painted (Lambertian, reflectance 0.7), a
/// beam of diameter 2 straight down through the aperture carrying
/// `photons`, seed 9, 4 bands; `tally` (lines ending in a newline) is
/// added to `[tally]`. Fast to trace.
pub fn painted_cavity(photons: u32, tally: &str) -> String {
    format!(
        r#"
seed = 9

{CAVITY}
[walls]
s = "paint"
o = "paint"
cut = "paint"

[models.paint]
diffuse = 0.7

[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 2.0 }}
position = [0.0, 0.0, 7.0]
photons = {photons}

[tally]
bands = 4
{tally}"#
    )
}
