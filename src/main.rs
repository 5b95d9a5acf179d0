//! The `roks` command line: parse the arguments, run the command, and end
//! with its exit status: 0 success; 2 bad input (scene file or arguments:
//! one line on stderr naming the file and key, nothing written); 1 other
//! failures (I/O). The commands live in [`roks::cli`].
#![forbid(unsafe_code)]

use std::process::ExitCode;

use roks::cli::args::{Cli, Command};
use roks::cli::{
    brdf, export_brdf, export_heightfield, export_mesh, fit, fit_model, merge, messages, plot,
    render, stats, trace,
};

fn main() -> ExitCode {
    let cli = match messages::parse_args::<Cli>() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    if let Err(e) = roks::limits::max_memory() {
        eprintln!("roks: {e}");
        return ExitCode::from(2);
    }
    roks::outdir::set_command(cli.command.name());
    if let Err(e) = roks::interrupt::install() {
        eprintln!("roks: cannot handle interrupts: {e}");
        return ExitCode::from(1);
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
        Command::Report(a) => roks::cli::report::execute(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("roks: {failure}");
            failure.exit_code()
        }
    }
}
