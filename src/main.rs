//! The `roks` command line: parse the arguments, run the command, and end
//! with its exit status: 0 success; 2 bad input (scene file or arguments:
//! one line on stderr naming the file and key, nothing written); 1 other
//! failures (I/O). The commands live in [`roks::cli`]; [`roks::cli::run`]
//! is the whole command line (the Python package's `roks` runs it too).
#![forbid(unsafe_code)]

use std::process::ExitCode;

fn main() -> ExitCode {
    ExitCode::from(roks::cli::run(std::env::args_os()))
}
