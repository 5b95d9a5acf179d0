//! What several commands do alike: the tracing options, the `--check`
//! line, the progress bar, printing to stdout, and output errors as a
//! command's failure.

use std::path::PathBuf;

use indicatif::{ProgressBar, ProgressState, ProgressStyle};

use super::Failure;

impl From<crate::outdir::check::OutputError> for Failure {
    fn from(e: crate::outdir::check::OutputError) -> Self {
        use crate::outdir::check::OutputError;
        match e {
            OutputError::Refused(m) => Self::Input(m),
            OutputError::Write(m) => Self::Other(anyhow::Error::msg(m)),
        }
    }
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
    #[arg(long, value_parser = crate::api::values::positive::<u64>)]
    pub photons: Option<u64>,
    /// Tracing seed (overrides the scene's).
    #[arg(long, value_parser = crate::api::values::integer::<u64>)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores). Does not change results.
    #[arg(long, value_parser = crate::api::values::positive::<usize>)]
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
    use crate::outdir::check::result_dir;
    use std::path::Path;

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
        let e = Failure::from(result_dir(Some(&foreign), "s.toml", "x", &[], false).unwrap_err());
        assert!(
            matches!(&e, Failure::Input(m) if m.starts_with(&format!("--out: {}: ", foreign.display()))),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
