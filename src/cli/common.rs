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

pub use crate::outdir::check::{Written, escape_controls, shown};
pub use crate::outdir::write::removed_lines;

impl From<crate::outdir::check::OutputError> for Failure {
    fn from(e: crate::outdir::check::OutputError) -> Self {
        use crate::outdir::check::OutputError;
        match e {
            OutputError::Refused(m) => Self::Input(m),
            OutputError::Write(m) => Self::Other(anyhow::Error::msg(m)),
        }
    }
}

/// [`crate::outdir::check::result_dir`], as a command's failure.
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
    Ok(crate::outdir::check::result_dir(
        given, scene_file, name, reads, force,
    )?)
}

/// [`crate::outdir::check::check_out_dir`], as a command's failure.
///
/// # Errors
/// Bad input when the folder cannot be replaced.
pub fn check_out_dir(out: &Path, key: &str, reads: &[PathBuf], force: bool) -> Result<(), Failure> {
    Ok(crate::outdir::check::check_out_dir(out, key, reads, force)?)
}

/// [`crate::outdir::check::check_out_file_as`] of `--out`, as a command's
/// failure.
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

/// [`crate::outdir::check::check_out_file_as`], as a command's failure.
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
    Ok(crate::outdir::check::check_out_file_as(
        option, out, inputs, kind, force,
    )?)
}

/// [`crate::outdir::check::check_kept`], as a command's failure.
///
/// # Errors
/// Bad input naming the option, the output and the input.
pub fn check_kept(
    option: &str,
    outputs: &[Written<'_>],
    inputs: &[PathBuf],
) -> Result<(), Failure> {
    Ok(crate::outdir::check::check_kept(option, outputs, inputs)?)
}

/// [`crate::outdir::write::write_file`], as a command's failure.
///
/// # Errors
/// The I/O error, naming the path.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    Ok(crate::outdir::write::write_file(path, bytes)?)
}

/// [`crate::outdir::write::write_folder`], as a command's failure.
///
/// # Errors
/// The I/O error, naming the folder.
pub fn write_folder<N: AsRef<str>, B: AsRef<[u8]>>(
    out: &Path,
    files: &[(N, B)],
    command: &str,
) -> Result<(), Failure> {
    Ok(crate::outdir::write::write_folder(out, files, command)?)
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
