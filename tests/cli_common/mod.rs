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
