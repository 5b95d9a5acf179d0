//! The README's and the user guide's recipes run as written.
//!
//! A recipe is a fenced shell block whose info string is `sh recipe`
//! (or `sh recipe python` for one that needs the Python environment):
//!
//! ````markdown
//! ```sh recipe
//! roks brdf scenes/default.toml --photons ${ROKS_PHOTONS:-1000000}
//! ```
//! ````
//!
//! Every recipe of `README.md` and `docs/src/**/*.md` runs in a fresh
//! temporary folder holding a copy of the repository's `scenes/`, as one
//! `bash` script (`set -euo pipefail`), with the `roks` cargo built first on
//! `PATH`, and small work through the variables the recipes read with their
//! defaults: `ROKS_PHOTONS` (photons per angle or beam position) and
//! `ROKS_SPP` (samples per pixel of a render). `ROKS_BIN` names the same
//! binary for the Python tools, and `ROKS_REPO` the repository (for the
//! scripts a recipe runs, `${ROKS_REPO:-.}/python/examples/x.py`: the
//! current folder when a reader runs it from a clone). Lines that begin with
//! `cargo install` or `pip install` are not run (installing is the reader's
//! step, not the test's). A failing command fails the test, naming the
//! file, the line of the command and the command.
//!
//! `sh recipe python` blocks run with the project's Python environment
//! (`.venv` at the repository root, or `ROKS_PYTHON`, as in
//! `tests/mitsuba_chain.rs`) first on `PATH`; without one they are skipped
//! with a message, unless `ROKS_REQUIRE_MITSUBA=1`, where that is a failure.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Photons per angle or beam position in the recipes (`ROKS_PHOTONS`).
const PHOTONS: &str = "4096";
/// Samples per pixel of a render in the recipes (`ROKS_SPP`).
const SPP: &str = "1";

/// One recipe: where it is, what it needs, its text.
#[derive(Debug, Clone)]
struct Recipe {
    /// The file, relative to the repository.
    file: String,
    /// The line of the first command (the one after the fence).
    line: usize,
    /// Needs the Python environment.
    python: bool,
    /// The block's lines.
    body: Vec<String>,
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The recipes of one markdown text: fenced blocks at the top level (not
/// inside another fence, such as a markdown example of a recipe) whose info
/// string begins `sh recipe`.
fn recipes_in(file: &str, text: &str) -> Vec<Recipe> {
    let mut out = Vec::new();
    // The open fence's backticks, and the recipe it holds (if it is one).
    let mut open: Option<(String, Option<Recipe>)> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        let ticks = t.len() - t.trim_start_matches('`').len();
        if let Some((fence, recipe)) = open.as_mut() {
            if ticks >= fence.len() && t.trim_end() == "`".repeat(ticks) {
                out.extend(recipe.take());
                open = None;
            } else if let Some(r) = recipe.as_mut() {
                r.body.push(line.to_string());
            }
            continue;
        }
        if ticks < 3 {
            continue;
        }
        let words: Vec<&str> = t[ticks..].split_whitespace().collect();
        let recipe =
            (words.first() == Some(&"sh") && words.get(1) == Some(&"recipe")).then(|| Recipe {
                file: file.to_string(),
                line: i + 2,
                python: words.get(2) == Some(&"python"),
                body: Vec::new(),
            });
        open = Some(("`".repeat(ticks), recipe));
    }
    assert!(open.is_none(), "{file}: a fenced block is not closed");
    out
}

/// The markdown files holding recipes: README.md and docs/src/**/*.md.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .map(|d| d.map(|e| e.expect("dir entry").path()).collect())
            .unwrap_or_default();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "md") {
                out.push(p);
            }
        }
    }
    let mut files = vec![root().join("README.md")];
    walk(&root().join("docs/src"), &mut files);
    files
}

fn all_recipes() -> Vec<Recipe> {
    let mut out = Vec::new();
    for path in markdown_files() {
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let rel = path.strip_prefix(root()).unwrap_or(&path);
        out.extend(recipes_in(&rel.display().to_string(), &text));
    }
    out
}

/// The script of a recipe: a first line that stops at the first failing
/// command and names its line in the file, then the block itself (so the
/// block's line `k` is the script's line `k + 1`), install lines left out.
fn script(r: &Recipe) -> String {
    let offset = r.line as i64 - 2;
    let mut s = format!(
        "set -eEuo pipefail; trap 'echo \"{}:$((LINENO + {offset})): failed (exit $?): $BASH_COMMAND\" >&2' ERR\n",
        r.file
    );
    for line in &r.body {
        let t = line.trim_start();
        if t.starts_with("cargo install") || t.starts_with("pip install") {
            s.push_str(": not run by tests/recipes.rs\n");
        } else {
            s.push_str(line);
            s.push('\n');
        }
    }
    s
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create the copy's folder");
    for e in std::fs::read_dir(from).expect("read scenes/") {
        let e = e.expect("dir entry");
        let target = to.join(e.file_name());
        if e.file_type().expect("file type").is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).expect("copy a scene file");
        }
    }
}

/// A fresh folder under the target dir with a copy of `scenes/`.
fn workdir(tag: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("recipes")
        .join(format!("{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    copy_dir(&root().join("scenes"), &dir.join("scenes"));
    dir
}

/// The Python environment's `bin` folder, or why there is none.
fn python_bin() -> Result<PathBuf, String> {
    let py = std::env::var_os("ROKS_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".venv/bin/python"));
    let ok = py.exists()
        && Command::new(&py)
            .args(["-c", "import mitsuba, numpy, matplotlib, roks_tools"])
            .output()
            .is_ok_and(|o| o.status.success());
    match (ok, py.parent()) {
        (true, Some(bin)) => Ok(bin.to_path_buf()),
        _ => Err(format!(
            "{} cannot import mitsuba, numpy, matplotlib and roks_tools (run scripts/setup_venv.sh)",
            py.display()
        )),
    }
}

/// Run one recipe in `dir`; `Err` holds the message naming the block and
/// the failing line, with the output's tail.
fn run(r: &Recipe, dir: &Path, python: Option<&Path>) -> Result<(), String> {
    let roks = PathBuf::from(env!("CARGO_BIN_EXE_roks"));
    let mut path = vec![roks.parent().expect("the binary's folder").to_path_buf()];
    path.extend(python.map(Path::to_path_buf));
    path.extend(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    ));
    let out = Command::new("bash")
        .args(["--noprofile", "--norc", "-c", &script(r)])
        .current_dir(dir)
        .env("PATH", std::env::join_paths(path).expect("PATH"))
        .env("ROKS_BIN", &roks)
        .env("ROKS_REPO", root())
        .env("ROKS_PHOTONS", PHOTONS)
        .env("ROKS_SPP", SPP)
        .env("MPLBACKEND", "Agg")
        .output()
        .map_err(|e| format!("{}:{}: cannot start bash: {e}", r.file, r.line))?;
    if out.status.success() {
        return Ok(());
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let named = stderr
        .lines()
        .rev()
        .find(|l| l.starts_with(&format!("{}:", r.file)))
        .map_or_else(
            || format!("{}:{}: the recipe failed ({})", r.file, r.line, out.status),
            str::to_string,
        );
    let tail: Vec<&str> = stderr.lines().rev().take(12).collect();
    let tail: Vec<&str> = tail.into_iter().rev().collect();
    Err(format!(
        "{named}\n  stdout: {}\n  stderr:\n    {}",
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .last()
            .unwrap_or(""),
        tail.join("\n    ")
    ))
}

#[test]
fn every_recipe_runs() {
    let recipes = all_recipes();
    assert!(
        recipes.iter().any(|r| r.file == "README.md"),
        "README.md has no recipe"
    );
    let python = python_bin();
    let required = std::env::var("ROKS_REQUIRE_MITSUBA").is_ok_and(|v| v == "1");
    let mut failures = Vec::new();
    let start = Instant::now();
    for (k, r) in recipes.iter().enumerate() {
        let py = if r.python {
            match &python {
                Ok(bin) => Some(bin.as_path()),
                Err(why) if required => {
                    failures.push(format!(
                        "{}:{}: ROKS_REQUIRE_MITSUBA=1 but {why}",
                        r.file, r.line
                    ));
                    continue;
                }
                Err(why) => {
                    eprintln!("recipe {}:{}: skipped: {why}", r.file, r.line);
                    continue;
                }
            }
        } else {
            None
        };
        let dir = workdir(&format!("{k:02}"));
        let t = Instant::now();
        let result = run(r, &dir, py);
        eprintln!(
            "recipe {}:{}: {:.1} s{}",
            r.file,
            r.line,
            t.elapsed().as_secs_f64(),
            if result.is_ok() { "" } else { ", FAILED" }
        );
        match result {
            Ok(()) => {
                let _ = std::fs::remove_dir_all(&dir);
            }
            Err(e) => failures.push(e),
        }
    }
    eprintln!(
        "recipes: {} in {:.1} s",
        recipes.len(),
        start.elapsed().as_secs_f64()
    );
    assert!(
        failures.is_empty(),
        "{} recipe(s) failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The runner names the file and the line of the failing command, stops
/// there, and leaves install lines out.
#[test]
fn a_failing_command_is_named() {
    let md = "text\n\n```sh recipe\necho one\nfalse\necho never\n```\n\n```sh\nfalse\n```\n\
              ````markdown\n```sh recipe\nfalse\n```\n````\n";
    let found = recipes_in("x.md", md);
    assert_eq!(
        found.len(),
        1,
        "only the marked block is a recipe, not one shown inside another fence"
    );
    assert_eq!(found[0].line, 4);
    let dir = workdir("self-test");
    let err = run(&found[0], &dir, None).expect_err("`false` fails");
    assert!(err.starts_with("x.md:5: failed (exit 1): false"), "{err}");
    assert!(!err.contains("never"), "{err}");
    let install = recipes_in(
        "y.md",
        "```sh recipe\ncargo install --path .\n  pip install ./python\nroks --version\n```\n",
    );
    assert_eq!(install[0].body.len(), 3);
    run(&install[0], &dir, None).expect("install lines are not run; roks is on PATH");
    let python = recipes_in("z.md", "```sh recipe python\ntrue\n```\n");
    assert!(python[0].python);
    let _ = std::fs::remove_dir_all(&dir);
}

/// CI runs the README's test command: the `cargo test` line of the
/// README's shell blocks is a line of `.ci/run`.
#[test]
fn ci_runs_the_readme_test_command() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let command = readme
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .find(|l| l.starts_with("cargo test"))
        .expect("README.md names its test command (a line beginning `cargo test`)");
    let ci = std::fs::read_to_string(root().join(".ci/run")).expect(".ci/run");
    assert!(
        ci.lines().any(|l| l.trim() == command),
        ".ci/run does not run the README's test command `{command}`"
    );
}
