//! Units of the command line: its arguments ([`roks::cli::args`]), the
//! one-line messages of clap's errors ([`roks::cli::messages`]) and the
//! exit statuses of failures ([`roks::cli::Failure`]).

use std::process::ExitCode;

use clap::{CommandFactory, Parser, Subcommand};
use roks::api::values::integer;
use roks::cli::Failure;
use roks::cli::args::{Cli, Command};
use roks::cli::messages::{command, message};
use roks::scene::SceneError;

#[test]
fn the_command_line_is_consistent() {
    // clap's own checks: unique names, valid defaults and value parsers.
    Cli::command().debug_assert();
}

#[test]
fn tracing_commands_share_their_run_options() {
    let parse = |args: &[&str]| roks::cli::messages::command::<Cli>().try_get_matches_from(args);
    for (command, scene) in [("brdf", "s.toml"), ("trace", "o.toml")] {
        let m = parse(&[
            "roks",
            command,
            scene,
            "--out",
            "d",
            "--photons",
            "1e3",
            "--seed",
            "7",
            "--threads",
            "2",
        ])
        .unwrap();
        let cli = <Cli as clap::FromArgMatches>::from_arg_matches(&m).unwrap();
        let run = match cli.command {
            Command::Brdf(a) => a.tracing,
            Command::Trace(a) => a.tracing,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            run,
            roks::cli::common::TracingArgs {
                out: Some("d".into()),
                photons: Some(1000),
                seed: Some(7),
                threads: Some(2),
                force: false,
                check: false,
            }
        );
    }
    // Each command's help says what its photons count.
    let help = |command: &str| {
        let mut cmd = Cli::command();
        let sub = cmd.find_subcommand_mut(command).unwrap();
        sub.get_arguments()
            .find(|a| a.get_id() == "photons")
            .and_then(|a| a.get_help())
            .map(ToString::to_string)
            .unwrap()
    };
    assert_eq!(
        help("brdf"),
        "Photons per incidence angle (overrides [light] photons)"
    );
    assert_eq!(
        help("trace"),
        "Photons per beam position (overrides each source's `photons`)"
    );
}

/// A small command line of the same shape as `roks`.
#[derive(Parser, Debug)]
#[command(name = "roks")]
struct Line {
    #[command(subcommand)]
    command: Sub,
}

#[derive(Subcommand, Debug)]
enum Sub {
    /// A command.
    Go {
        /// A seed.
        #[arg(long, value_parser = integer::<u64>)]
        seed: Option<u64>,
        /// A name from a list.
        #[arg(long, value_parser = ["none", "mirror"])]
        pick: Option<String>,
        /// A required file.
        #[arg(long)]
        out: std::path::PathBuf,
    },
}

/// The one line for `args` (after `roks`).
fn line(args: &[&str]) -> String {
    let cmd = command::<Line>();
    let e = cmd
        .clone()
        .try_get_matches_from(std::iter::once("roks").chain(args.iter().copied()))
        .unwrap_err();
    let args: Vec<String> = args.iter().map(ToString::to_string).collect();
    message(&cmd, &args, &e)
}

#[test]
fn one_line_per_error() {
    assert_eq!(
        line(&["go", "--out", "o", "--seed", "-1"]),
        "--seed: must be an integer >= 0 (digits, or exact forms like 1e6 or 2.5e3), got `-1`"
    );
    assert_eq!(
        line(&["go", "--out", "o", "--pick", "mirrr"]),
        "--pick: `mirrr` is not allowed: one of none, mirror; did you mean `mirror`?"
    );
    assert_eq!(
        line(&["go", "--out", "o", "--pick"]),
        "--pick: needs a value: one of none, mirror"
    );
    assert_eq!(
        line(&["go", "--out", "o", "--sed", "1"]),
        "--sed: unknown option of `roks go`; did you mean `--seed`? (`roks go --help` lists the options)"
    );
    assert_eq!(
        line(&["go", "--out", "o", "x.toml"]),
        "`x.toml`: unexpected argument of `roks go` (`roks go --help` shows what it takes)"
    );
    assert_eq!(
        line(&["go", "--out", "o", "--seed", "1", "--seed", "2"]),
        "--seed: given more than once (give each option once)"
    );
    assert_eq!(
        line(&["go"]),
        "missing --out <OUT> (`roks go --help` shows the usage)"
    );
    assert_eq!(
        line(&["goo"]),
        "`goo`: unknown subcommand, expected one of go; did you mean `go`?"
    );
}

#[test]
fn failures_name_their_cause_and_status() {
    let input = Failure::Input("s.toml: light.photons: must be > 0".into());
    assert_eq!(input.to_string(), "s.toml: light.photons: must be > 0");
    assert_eq!(input.exit_code(), ExitCode::from(2));
    let scene = Failure::from(SceneError {
        file: "s.toml".into(),
        key: "bumps[0].radius".into(),
        message: "must be positive".into(),
    });
    assert!(
        matches!(&scene, Failure::Input(m) if m == "s.toml: bumps[0].radius: must be positive")
    );
    // The chain of causes on one line.
    let other = Failure::from(anyhow::anyhow!("disk full").context("cannot write out/x"));
    assert_eq!(other.to_string(), "cannot write out/x: disk full");
    assert_eq!(other.exit_code(), ExitCode::from(1));
}
