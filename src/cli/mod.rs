//! The `roks` command line: its arguments ([`args::Cli`]), one module per
//! command, and the one-line messages of bad input. The binary only parses,
//! dispatches to a command's `execute` and maps a [`Failure`] to its exit
//! status; each command parses its options, calls the library API
//! ([`crate::api`]: load, trace, write) and prints. Library errors carry
//! their messages ([`crate::api::Error`]) and become a [`Failure`] by `?`.
//!
//! # Conventions
//! * Every bad option gives exactly one line on stderr, `roks: --seed: ...`,
//!   naming the option and what it accepts, and exit status 2; a bad scene
//!   file gives one line naming the file and the key. The only longer answer
//!   is `roks` without a subcommand: the first line says so, the usage
//!   follows ([`messages`]).
//! * `--help` and `--version` print to stdout and exit 0.
//! * Every option that takes a value takes a negative number as its value
//!   (`--seed -1` is the value -1 of `--seed`, refused as out of range; not
//!   an unknown option `-1`).
//! * Numbers are exact ([`crate::api::values`]): integer options take digits or exact
//!   forms like `1e6`, real options any finite decimal.
//! * Options that override a scene key are checked by the scene loader's own
//!   checks, so that a value gives the same message either way.
//! * Nothing is written before every input is checked; result folders are
//!   replaced whole ([`crate::outdir`]).

// The doc comments of the commands' arguments are their `--help` text,
// written for a terminal: `[tally] farfield`, `bumps[0].height` are scene
// keys in brackets and `out/<scene name>/` a placeholder, not links or tags.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

pub mod args;
pub mod brdf;
pub mod common;
pub mod export_brdf;
pub mod export_heightfield;
pub mod export_mesh;
pub mod fit;
pub mod fit_model;
pub mod merge;
pub mod messages;
pub mod plot;
pub mod render;
pub mod report;
pub mod stats;
pub mod trace;

use std::ffi::OsString;
use std::fmt;
use std::process::ExitCode;

use crate::scene::SceneError;
use args::{Cli, Command};

/// Run the command line `args` (the program name first, as
/// [`std::env::args_os`] gives them) as the `roks` binary does, and return
/// its exit status: 0 success; 2 bad input (scene file or arguments: one
/// line on stderr naming the file and key, nothing written); 1 other
/// failures (I/O); 130 interrupted. The binary and the Python package's
/// `roks` command both call this.
///
/// It installs the interrupt handler ([`crate::interrupt::install`]) and
/// names the running command for the records of result folders: call it
/// once per process, from a command-line entry point only.
pub fn run(args: impl IntoIterator<Item = OsString>) -> u8 {
    let cli = match messages::parse_args_from::<Cli>(args) {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    if let Err(e) = crate::limits::max_memory() {
        eprintln!("roks: {e}");
        return 2;
    }
    crate::outdir::set_command(cli.command.name());
    if let Err(e) = crate::interrupt::install() {
        eprintln!("roks: cannot handle interrupts: {e}");
        return 1;
    }
    let result = match cli.command {
        Command::Brdf(a) => brdf::execute(a),
        Command::Stats(a) => stats::execute(a),
        Command::Trace(a) => trace::execute(a),
        Command::Fit(a) => fit::execute(a),
        Command::ExportMesh(a) => export_mesh::execute(a),
        Command::ExportHeightfield(a) => export_heightfield::execute(a),
        Command::Render(a) => render::execute(a),
        Command::Merge(a) => merge::execute(a),
        Command::ExportBrdf(a) => export_brdf::execute(a),
        Command::FitModel(a) => fit_model::execute(a),
        Command::Plot(a) => plot::execute(a),
        Command::Report(a) => report::execute(a),
    };
    match result {
        Ok(()) => 0,
        Err(failure) => {
            eprintln!("roks: {failure}");
            failure.status()
        }
    }
}

/// Why a command failed, by exit status.
#[derive(Debug)]
pub enum Failure {
    /// Bad input (a scene file, an option): exit status 2. One line naming
    /// the file or the option, the key and what is wrong.
    Input(String),
    /// Anything else (reading or writing files): exit status 1.
    Other(anyhow::Error),
}

impl Failure {
    /// The exit status of the process: 2 for bad input, 1 otherwise.
    #[must_use]
    pub fn exit_code(&self) -> ExitCode {
        ExitCode::from(self.status())
    }

    /// [`exit_code`](Self::exit_code) as a number: 2 or 1.
    #[must_use]
    pub fn status(&self) -> u8 {
        match self {
            Self::Input(_) => 2,
            Self::Other(_) => 1,
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // One line, whatever a quoted file name holds.
        let text = match self {
            Self::Input(message) => crate::outdir::check::escape_controls(message),
            Self::Other(e) => crate::outdir::check::escape_controls(&format!("{e:#}")),
        };
        f.write_str(&text)
    }
}

impl std::error::Error for Failure {}

/// An export's error: bad input (exit status 2) or a writer's defect (1).
impl From<crate::export::exporter::ExportError> for Failure {
    fn from(e: crate::export::exporter::ExportError) -> Self {
        if e.is_input() {
            Self::Input(e.to_string())
        } else {
            Self::Other(anyhow::Error::msg(e.to_string()))
        }
    }
}

impl From<SceneError> for Failure {
    fn from(e: SceneError) -> Self {
        Self::Input(e.to_string())
    }
}

impl From<crate::api::Error> for Failure {
    /// A library error: bad input but for a failed read or write.
    fn from(e: crate::api::Error) -> Self {
        match e {
            crate::api::Error::Io(e) => Self::Other(e),
            e => Self::Input(e.to_string()),
        }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Self::Other(e)
    }
}
