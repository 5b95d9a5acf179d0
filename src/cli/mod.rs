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

use std::fmt;
use std::process::ExitCode;

use crate::scene::SceneError;

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
        match self {
            Self::Input(_) => ExitCode::from(2),
            Self::Other(_) => ExitCode::from(1),
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
