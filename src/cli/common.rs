//! What several commands do alike: load a micro scene, set the worker
//! threads, check output paths and memory before any work, write files,
//! show progress.

use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressState, ProgressStyle};

use super::Failure;
pub use crate::outdir::kind::FileKind;
use crate::scene::micro::{MicroScene, Overrides};

/// The micro scene at `path`, or the embedded default scene
/// ([`crate::api::load_micro`]).
///
/// # Errors
/// The scene file's error (bad input).
pub fn load_scene(path: Option<&Path>) -> Result<MicroScene, Failure> {
    load_scene_with(path, &Overrides::default())
}

pub use crate::api::STATS_RESOLUTION;

/// [`crate::api::load_micro`].
///
/// # Errors
/// Bad input naming the option or the scene file and key.
pub fn load_scene_with(path: Option<&Path>, overrides: &Overrides) -> Result<MicroScene, Failure> {
    Ok(crate::api::load_micro(path, overrides)?)
}

/// [`crate::api::set_threads`].
///
/// # Errors
/// Bad input when their stacks exceed the memory limit.
pub fn set_threads(threads: Option<usize>) -> Result<(), Failure> {
    Ok(crate::api::set_threads(threads)?)
}

/// [`crate::api::check_memory`].
///
/// # Errors
/// Bad input, naming `option`.
pub fn check_memory(option: &'static str, what: &str, bytes: u64) -> Result<(), Failure> {
    Ok(crate::api::check_memory(option, what, bytes)?)
}

/// [`crate::api::stats_grid`].
///
/// # Errors
/// Bad input for fewer than 2 samples or a grid beyond the memory limit.
pub fn stats_grid(
    scene: &MicroScene,
    requested: Option<usize>,
    default: usize,
    option: &'static str,
) -> Result<(usize, usize), Failure> {
    Ok(crate::api::stats_grid(scene, requested, default, option)?)
}

/// [`crate::api::own_grid`].
///
/// # Errors
/// Bad input when `resolution` is not the field's own.
pub fn own_grid(scene: &MicroScene, resolution: Option<usize>) -> Result<(), Failure> {
    Ok(crate::api::own_grid(scene, resolution)?)
}

/// The result folder: `given` (`--out`), or `out/<name>` (named in messages
/// by the scene file's `name` key), checked before any work is done: it
/// can be a result folder, and replacing it destroys none of `reads`, the
/// files the run reads ([`check_kept`]).
///
/// The default folder is never taken over from another scene file: when
/// `out/<name>` holds the result of a scene at another path (its
/// `summary.json` names it), the run is refused, so an edited copy of a
/// scene that kept its `name` cannot silently replace the original's
/// result. `--out` names a folder on purpose and may replace any result.
/// `force` (`--force`) replaces a result folder that holds files roks did
/// not write ([`crate::outdir::check_folder`]).
///
/// # Errors
/// Bad input when the folder cannot be a result folder, or is the default
/// folder of another scene file.
pub fn result_dir(
    given: Option<&Path>,
    scene_file: &str,
    name: &str,
    reads: &[PathBuf],
    force: bool,
) -> Result<PathBuf, Failure> {
    let Some(out) = given else {
        let out = Path::new("out").join(name);
        let key = format!("{scene_file}: name");
        check_out_dir(&out, &key, reads, force)?;
        if let Some(other) = recorded_scene(&out)
            .filter(|o| o != scene_file && !same_file(Path::new(o), Path::new(scene_file)))
        {
            return Err(Failure::Input(format!(
                "{key}: {} holds the result of {}, another scene named {name:?}; give --out, or another name",
                shown(&out),
                other.escape_debug()
            )));
        }
        return Ok(out);
    };
    check_out_dir(out, "--out", reads, force)?;
    Ok(out.to_path_buf())
}

/// The scene file recorded in the `summary.json` of the result folder
/// `out` (`None` when there is none to read).
fn recorded_scene(out: &Path) -> Option<String> {
    let text = std::fs::read(out.join("summary.json")).ok()?;
    let v: serde_json::Value = serde_json::from_slice(&text).ok()?;
    v.get("scene")?.as_str().map(str::to_owned)
}

/// Whether `a` and `b` are one existing file: both resolve (links, `..`,
/// relative to the working folder) to the same path.
fn same_file(a: &Path, b: &Path) -> bool {
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}

/// Check a result folder before any work is done; `key` names it in the
/// message (`--out`, or `SCENE: name` for the default out/NAME): it can
/// be a result folder, replacing it destroys none of `reads`, the files the
/// run reads ([`check_kept`]), and every file in it is roks's own unless
/// `force` (`--force`), in this order.
///
/// # Errors
/// Bad input when the folder exists and is neither empty nor a roks result,
/// holds one of `reads`, or (without `force`) holds a file roks did not
/// write.
pub fn check_out_dir(out: &Path, key: &str, reads: &[PathBuf], force: bool) -> Result<(), Failure> {
    let bad = |e| Failure::Input(format!("{key}: {}: {e}", shown(out)));
    crate::outdir::check_folder(out, true).map_err(bad)?;
    check_kept(key, &[Written::Folder(out)], reads)?;
    crate::outdir::check_folder(out, force).map_err(bad)
}

/// Check an output file (`--out`) of `kind` before any work is done: it
/// can be written as a file (not a folder, nor a path ending in `/`; its
/// folder can be made), writing it replaces none of `inputs`, the files
/// the command reads ([`check_kept`]), and a file already there is that
/// kind of roks output, or roks's by its folder's record, or `force`
/// (`--force`) is given ([`crate::outdir::check_replace`]).
///
/// # Errors
/// Bad input when `out` cannot be written as a file, would replace one of
/// `inputs`, or is a file roks may not replace.
pub fn check_out_file(
    out: &Path,
    inputs: &[PathBuf],
    kind: FileKind,
    force: bool,
) -> Result<(), Failure> {
    check_out_file_as("--out", out, inputs, kind, force)
}

/// [`check_out_file`] of the output of `option`.
///
/// # Errors
/// As [`check_out_file`].
pub fn check_out_file_as(
    option: &str,
    out: &Path,
    inputs: &[PathBuf],
    kind: FileKind,
    force: bool,
) -> Result<(), Failure> {
    let bad =
        |e: crate::outdir::OutPathError| Failure::Input(format!("{option}: {}: {e}", shown(out)));
    crate::outdir::check_file(out).map_err(bad)?;
    check_kept(option, &[Written::File(out)], inputs)?;
    crate::outdir::check_replace(out, kind, force).map_err(bad)
}

/// What a command writes, to be checked against what it reads.
#[derive(Debug, Clone, Copy)]
pub enum Written<'a> {
    /// A result folder, replaced whole (every file in it goes).
    Folder(&'a Path),
    /// One file, replaced.
    File(&'a Path),
}

/// The one decision, for every command, that its outputs destroy no input:
/// refuse (naming `option`) when one of `outputs` is, holds (a folder
/// replaced whole) or would replace one of `inputs` (the scene, every file
/// it names, a table wall's files, merged folders), however either path is
/// spelt: symbolic links, `..`, trailing `/`, hard links
/// ([`crate::outdir::replaces`]). Call it before any work.
///
/// # Errors
/// Bad input naming the option, the output and the input.
pub fn check_kept(
    option: &str,
    outputs: &[Written<'_>],
    inputs: &[PathBuf],
) -> Result<(), Failure> {
    for w in outputs {
        let (out, folder) = match *w {
            Written::Folder(p) => (p, true),
            Written::File(p) => (p, false),
        };
        if let Some(input) = inputs
            .iter()
            .find(|i| crate::outdir::replaces(out, folder, i))
        {
            let how = if folder && !crate::outdir::replaces(out, false, input) {
                "holds"
            } else {
                "is"
            };
            return Err(Failure::Input(format!(
                "{option}: {}: {how} {}, a file this run reads, which writing {} would destroy; write elsewhere",
                shown(out),
                shown(input),
                if folder {
                    "the folder (replaced whole)"
                } else {
                    "it"
                }
            )));
        }
    }
    Ok(())
}

/// `path` for a message: as given, with control characters (a newline in
/// a file name) escaped as `\n`, `\u{1b}`, so that every message stays one
/// line.
#[must_use]
pub fn shown(path: &Path) -> String {
    escape_controls(&path.display().to_string())
}

/// `text` with its control characters escaped (`\n`, `\t`, `\u{7f}`).
#[must_use]
pub fn escape_controls(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// Write `bytes` to `path` atomically, creating its folder. A file written
/// into a result folder is added to its record first
/// ([`crate::outdir::record_added`], as written by the running command),
/// so that a rerun knows it as roks's own.
///
/// # Errors
/// The I/O error, naming the path.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    }
    let _commit = crate::interrupt::commit();
    crate::outdir::record_added(path, crate::outdir::command())
        .map_err(|e| anyhow::anyhow!("cannot write the record of {}: {e}", path.display()))?;
    crate::output::write_atomic(path, bytes)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    crate::interrupt::kept(shown(path));
    Ok(())
}

/// Write the result folder `out` whole, `files` as (name, bytes), with the
/// record naming `command` as their writer: staged beside it, then swapped
/// in (see [`crate::outdir`]); a reader never sees old and new files
/// mixed. The files that later commands had added to the old result, and
/// those roks did not write (only with `--force`), are named on stderr, one
/// line each ([`removed_lines`]).
///
/// # Errors
/// The I/O error, naming the folder.
pub fn write_folder<N: AsRef<str>, B: AsRef<[u8]>>(
    out: &Path,
    files: &[(N, B)],
    command: &str,
) -> Result<(), Failure> {
    let files: Vec<(&str, &[u8])> = files
        .iter()
        .map(|(n, b)| (n.as_ref(), b.as_ref()))
        .collect();
    // The swap and its note for an interrupt's line under one lock.
    let commit = crate::interrupt::commit();
    let replaced = crate::outdir::write_folder(out, &files, command)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", out.display()))?;
    crate::interrupt::kept(shown(out));
    drop(commit);
    for line in removed_lines(out, &replaced) {
        eprintln!("roks: {}", escape_controls(&line));
    }
    Ok(())
}

/// The lines that say what replacing the result folder `out` removed
/// beside the old run's own files: the files later commands had added (they
/// were made from the old table, so they go with it) and those roks did not
/// write (`--force`).
#[must_use]
pub fn removed_lines(out: &Path, r: &crate::outdir::Replaced) -> Vec<String> {
    let mut lines = Vec::new();
    if !r.added.is_empty() {
        let names: Vec<String> = r
            .added
            .iter()
            .map(|(f, by)| format!("{f} ({by})"))
            .collect();
        lines.push(format!(
            "{}: removed {}: added to the old result by later commands and made from its table, which this run replaced; run them again to remake them",
            shown(out),
            names.join(", ")
        ));
    }
    if !r.foreign.is_empty() {
        lines.push(format!(
            "--force: {}: removed {}, which roks did not write",
            shown(out),
            r.foreign.join(", ")
        ));
    }
    lines
}

/// Write `text` to standard output; a closed pipe (`roks stats | head`) is a
/// clean end, not an error.
///
/// # Errors
/// Any other write error.
pub fn print_stdout(text: &str) -> Result<(), Failure> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::Other(
            anyhow::anyhow!("cannot write to standard output: {e}"),
        )),
        _ => Ok(()),
    }
}

/// A progress bar on stderr for `total` photons, labelled `name` (hidden
/// when `quiet`): photons done, the mean rate so far and the time left at
/// that rate.
#[must_use]
pub fn progress_bar(total: u64, quiet: bool, name: &str) -> ProgressBar {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} {msg} [{bar:30}] {human_pos}/{human_len} photons, {rate}, eta {eta}",
        )
        .expect("valid template")
        .with_key("rate", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = match photon_rate(s) {
                Some(r) => write!(w, "{}/s", indicatif::HumanCount(r as u64)),
                None => write!(w, "?/s"),
            };
        })
        .with_key("eta", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
            // Photons still to trace at the run's mean rate so far (unknown
            // until the first batch is done), however long that is.
            let left = s.len().unwrap_or(0).saturating_sub(s.pos());
            let _ = match photon_rate(s) {
                Some(r) => write!(
                    w,
                    "{:#}",
                    indicatif::HumanDuration(std::time::Duration::from_secs_f64(
                        (left as f64 / r).min(1e15)
                    ))
                ),
                None => write!(w, "?"),
            };
        })
        .progress_chars("=> "),
    );
    bar.set_message(name.to_string());
    bar
}

/// Photons per second over the run so far (`None` before the first batch).
fn photon_rate(s: &ProgressState) -> Option<f64> {
    let secs = s.elapsed().as_secs_f64();
    (s.pos() > 0 && secs > 0.0).then(|| s.pos() as f64 / secs)
}

/// The options of both tracing commands (`roks brdf`, `roks trace`): the
/// result folder, the photons and seed overriding the scene's, the worker
/// threads. A command states what its photons count and which scene key
/// they override in the help of `photons` and `seed` (clap's `mut_arg`).
#[derive(clap::Args, Debug, Clone, PartialEq, Eq)]
pub struct TracingArgs {
    /// Output folder (default: out/<scene name>/), replaced whole by the run
    /// (an existing one must be empty or a roks result).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output folder even when it holds files roks did not
    /// write (they are deleted; a folder that holds a folder, or is not a
    /// roks result, is still refused).
    #[arg(long)]
    pub force: bool,
    /// Photons per incidence angle or beam position (overrides the scene's).
    #[arg(long, value_parser = super::parse::positive::<u64>)]
    pub photons: Option<u64>,
    /// Tracing seed (overrides the scene's).
    #[arg(long, value_parser = super::parse::integer::<u64>)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = super::parse::positive::<usize>)]
    pub threads: Option<usize>,
    /// Check the scene, the options (with --shard, --export and --out) and
    /// the memory the run needs, as the run would, then stop: one line on
    /// stdout (none with --quiet), exit status 0, nothing traced and
    /// nothing written; a refusal is the run's own line, exit status 2.
    #[arg(long)]
    pub check: bool,
}

/// The line of `--check` (unless `quiet`): `check: SCENE: accepted (WHAT);
/// nothing traced, nothing written`.
pub fn report_check(scene_file: &str, what: &str, quiet: bool) {
    if !quiet {
        println!("check: {scene_file}: accepted ({what}); nothing traced, nothing written");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn result_folders_are_named_by_their_key() {
        let dir = std::env::temp_dir().join(format!("roks-cli-common-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let given = dir.join("given");
        assert_eq!(
            result_dir(Some(&given), "s.toml", "x", &[], false).unwrap(),
            given
        );
        assert_eq!(
            result_dir(None, "s.toml", "x", &[], false).unwrap(),
            Path::new("out").join("x")
        );
        // A file that is not a roks result is never replaced.
        let foreign = dir.join("notes.txt");
        std::fs::write(&foreign, "mine").unwrap();
        let e = result_dir(Some(&foreign), "s.toml", "x", &[], false).unwrap_err();
        assert!(
            matches!(&e, Failure::Input(m) if m.starts_with(&format!("--out: {}: ", foreign.display()))),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
