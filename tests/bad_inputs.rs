//! The bad-input corpus: every file `tests/bad_inputs/*.toml` is one bad or
//! extreme input, and `roks` must answer each as docs/src/commands.md promises:
//! exit status 2, exactly one line on stderr naming the file and the key,
//! nothing on stdout, no output folder, no panic, and no hang or blow-up
//! (every case runs under a 4 GiB address-space limit and a 60 s kill, which
//! detect a hang or an allocation instead of a refusal; they are not speed
//! assertions: a case normally fails within milliseconds).
//!
//! A case file is the scene text (TOML) with header comment lines on top:
//!
//! ```text
//! # args: brdf {scene} --out {out} --photons 100 -q
//! # expect: bumps[0].radius
//! # expect: must be positive
//! # file: {scene}
//! # env: ROKS_MAX_MEMORY=100M
//! ```
//!
//! * `args`: the command line after `roks`, split at white space; the token
//!   `''` is an empty argument. Placeholders: `{scene}` this file's path,
//!   `{out}` a scratch path that must not exist afterwards, `{dir}` an
//!   existing scratch folder, `{data}` the folder `tests/bad_inputs/data`.
//!   Default: `brdf {scene} --out {out} --photons 100 -q`.
//! * `expect` (any number): a text the single stderr line must contain.
//! * `file`: the path the line must name (default `{scene}`; `-` for none,
//!   e.g. a bad option, whose name is then an `expect`).
//! * `env` (any number): `KEY=VALUE` set for the run.
//! * `status`: the exit status (default 2).
//!
//! Auxiliary files live under `tests/bad_inputs/data/`; a scene refers to
//! them relative to itself (`data/...`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The corpus must keep at least this many cases (at least 100).
const MIN_CASES: usize = 100;
/// Address-space limit of every case, KiB (4 GiB).
const MEMORY_KIB: u64 = 4 << 20;
/// A case still running after this long is a hang.
const HANG: Duration = Duration::from_secs(60);

struct Case {
    name: String,
    scene: PathBuf,
    args: Vec<String>,
    expect: Vec<String>,
    file: Option<String>,
    env: Vec<(String, String)>,
    status: i32,
}

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs")
}

/// Parse the header of one case file; `dir`/`out` are its scratch paths.
fn parse_case(scene: &Path, dir: &Path, out: &Path) -> Result<Case, String> {
    let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
    let text = std::fs::read_to_string(scene).map_err(|e| format!("{name}: {e}"))?;
    let fill = |s: &str| {
        s.replace("{scene}", &scene.display().to_string())
            .replace("{out}", &out.display().to_string())
            .replace("{dir}", &dir.display().to_string())
            .replace("{data}", &corpus_dir().join("data").display().to_string())
    };
    let mut case = Case {
        name: name.clone(),
        scene: scene.to_path_buf(),
        args: Vec::new(),
        expect: Vec::new(),
        file: Some(fill("{scene}")),
        env: Vec::new(),
        status: 2,
    };
    let mut args = None;
    for line in text.lines() {
        let Some(header) = line.strip_prefix('#') else {
            break;
        };
        let Some((key, value)) = header.trim().split_once(':') else {
            continue;
        };
        let value = value.trim();
        match key.trim() {
            "args" => args = Some(value.to_string()),
            "expect" => case.expect.push(fill(value)),
            "file" => case.file = (value != "-").then(|| fill(value)),
            "env" => {
                let (k, v) = value
                    .split_once('=')
                    .ok_or_else(|| format!("{name}: env line without `=`"))?;
                case.env.push((k.trim().to_string(), fill(v.trim())));
            }
            "status" => {
                case.status = value
                    .parse()
                    .map_err(|_| format!("{name}: bad status `{value}`"))?
            }
            _ => {}
        }
    }
    let args = args.unwrap_or_else(|| "brdf {scene} --out {out} --photons 100 -q".into());
    case.args = args
        .split_whitespace()
        .map(|t| if t == "''" { String::new() } else { fill(t) })
        .collect();
    if case.expect.is_empty() {
        return Err(format!("{name}: no `# expect:` line"));
    }
    Ok(case)
}

/// Run one case; `Err` says what was wrong with roks's answer.
fn run_case(case: &Case, out: &Path) -> Result<(), String> {
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg(format!("ulimit -v {MEMORY_KIB}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_roks"))
        .args(&case.args)
        .env_remove("ROKS_MAX_MEMORY")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in &case.env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().map_err(|e| format!("spawn: {e}"))?;
    let start = Instant::now();
    loop {
        if child.try_wait().map_err(|e| e.to_string())?.is_some() {
            break;
        }
        if start.elapsed() > HANG {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("still running after {} s (a hang)", HANG.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let o = child.wait_with_output().map_err(|e| e.to_string())?;
    let stderr = String::from_utf8_lossy(&o.stderr);
    if o.status.code() != Some(case.status) {
        return Err(format!(
            "status {} (want {}), stderr {stderr:?}",
            o.status, case.status
        ));
    }
    if stderr.contains("panicked") {
        return Err(format!("panic: {stderr:?}"));
    }
    let line = stderr.strip_suffix('\n').unwrap_or(&stderr);
    if line.is_empty() || line.contains('\n') || !stderr.ends_with('\n') {
        return Err(format!("not one line: {stderr:?}"));
    }
    if let Some(file) = &case.file {
        if !line.contains(file.as_str()) {
            return Err(format!("no file `{file}` in {line:?}"));
        }
    }
    for e in &case.expect {
        if !line.contains(e.as_str()) {
            return Err(format!("no `{e}` in {line:?}"));
        }
    }
    if !o.stdout.is_empty() {
        return Err(format!("stdout {:?}", String::from_utf8_lossy(&o.stdout)));
    }
    if out.exists() {
        return Err(format!("{} was created", out.display()));
    }
    Ok(())
}

/// The case files, sorted.
fn cases() -> Vec<PathBuf> {
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(corpus_dir())
        .expect("tests/bad_inputs")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    scenes
}

#[test]
fn corpus() {
    let scenes = cases();
    let scratch = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_inputs");
    let _ = std::fs::remove_dir_all(&scratch);
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let threads = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .min(4);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(scene) = scenes.get(i) else { break };
                    let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
                    let dir = scratch.join(&stem);
                    std::fs::create_dir_all(&dir).unwrap();
                    let out = dir.join("out");
                    let verdict = parse_case(scene, &dir, &out).and_then(|case| {
                        run_case(&case, &out)
                            .map_err(|e| format!("{} ({}): {e}", case.name, case.scene.display()))
                    });
                    match verdict {
                        Ok(()) => {
                            let _ = std::fs::remove_dir_all(&dir);
                        }
                        Err(e) => failures.lock().unwrap().push(e),
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs answered wrongly:\n{}",
        failures.len(),
        scenes.len(),
        failures.join("\n")
    );
}

/// The corpus keeps its size (cases are removed only with their class).
#[test]
fn corpus_size() {
    let n = cases().len();
    assert!(
        n >= MIN_CASES,
        "the corpus holds {n} cases, fewer than {MIN_CASES}"
    );
}
