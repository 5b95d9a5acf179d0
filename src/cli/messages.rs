//! Clap's errors turned into the one line every bad option gets (see the
//! conventions in [`crate::cli`]), and the command line parsed with them.

use std::ffi::OsString;
use std::process::ExitCode;

use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{Command, CommandFactory, FromArgMatches};

/// The command of `C` as `roks` parses it: every option that takes values
/// also takes negative numbers as values (see the module doc).
#[must_use]
pub fn command<C: CommandFactory>() -> Command {
    fn negatives(cmd: Command) -> Command {
        cmd.mut_args(|a| {
            if a.get_action().takes_values() && !a.is_positional() {
                a.allow_negative_numbers(true)
            } else {
                a
            }
        })
        .mut_subcommands(negatives)
    }
    negatives(C::command())
}

/// Parse the process's arguments into `C`. On `--help` or `--version`: the
/// text on stdout and `Err(ExitCode::SUCCESS)`; on a bad argument: one line
/// `roks: ...` on stderr (see [`message`]) and `Err(2)`.
///
/// # Errors
/// The exit code to end the process with, its output printed.
pub fn parse_args<C: CommandFactory + FromArgMatches>() -> Result<C, ExitCode> {
    parse_args_from(std::env::args_os()).map_err(ExitCode::from)
}

/// The command line `args` (the program name first) parsed without
/// printing: a bad argument gives the one line [`parse_args`] prints after
/// `roks: `, `--help` and `--version` their text. The Python module checks
/// its options of a scene this way, with the command line's messages.
///
/// # Errors
/// The one-line message.
pub fn try_parse<C: CommandFactory + FromArgMatches>(args: &[String]) -> Result<C, String> {
    let cmd = command::<C>();
    cmd.clone()
        .try_get_matches_from(args)
        .and_then(|mut m| C::from_arg_matches_mut(&mut m))
        .map_err(|e| match e.kind() {
            ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => e.to_string(),
            _ => message(&cmd, &args[1.min(args.len())..], &e),
        })
}

/// [`parse_args`] of `args` (the program name first, as
/// [`std::env::args_os`] gives them).
///
/// # Errors
/// As [`parse_args`], the exit status as a number (0 or 2).
pub fn parse_args_from<C: CommandFactory + FromArgMatches>(
    args: impl IntoIterator<Item = OsString>,
) -> Result<C, u8> {
    let args: Vec<OsString> = args.into_iter().collect();
    let cmd = command::<C>();
    let e = match cmd
        .clone()
        .try_get_matches_from(&args)
        .and_then(|mut m| C::from_arg_matches_mut(&mut m))
    {
        Ok(c) => return Ok(c),
        Err(e) => e,
    };
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            // A closed pipe (`roks --help | head`) is a clean end.
            let _ = e.print();
            Err(0)
        }
        _ => {
            let args: Vec<String> = args
                .iter()
                .skip(1)
                .map(|a| a.to_string_lossy().into_owned())
                .collect();
            eprintln!("roks: {}", message(&cmd, &args, &e));
            if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                use std::io::Write as _;
                let help = cmd.clone().render_help();
                let _ = write!(std::io::stderr(), "\n{help}");
            }
            Err(2)
        }
    }
}

/// The option of a clap argument as written in its messages (`--seed
/// <SEED>` is `--seed`; a positional `<SCENE>` stays `<SCENE>`).
fn option_name(arg: &str) -> &str {
    if arg.starts_with('-') {
        arg.split([' ', '=']).next().unwrap_or(arg)
    } else {
        arg
    }
}

fn strings(v: Option<&ContextValue>) -> Vec<String> {
    match v {
        Some(ContextValue::String(s)) => vec![s.clone()],
        Some(ContextValue::Strings(s)) => s.clone(),
        Some(ContextValue::StyledStr(s)) => vec![s.to_string()],
        Some(ContextValue::StyledStrs(s)) => s.iter().map(ToString::to_string).collect(),
        _ => Vec::new(),
    }
}

fn quoted(list: &[String]) -> String {
    list.iter()
        .map(|s| format!("`{s}`"))
        .collect::<Vec<_>>()
        .join(" or ")
}

/// The one line (without `roks: `) for a clap error `e` of `cmd`, given the
/// arguments `args` (without the program name; they name the subcommand).
#[must_use]
pub fn message(cmd: &Command, args: &[String], e: &clap::Error) -> String {
    let one = |kind| strings(e.get(kind));
    let first = |kind| one(kind).into_iter().next().unwrap_or_default();
    let arg = first(ContextKind::InvalidArg);
    let option = option_name(&arg).to_string();
    let value = first(ContextKind::InvalidValue);
    let sub = args
        .iter()
        .find_map(|a| cmd.find_subcommand(a))
        .filter(|s| s.get_name() != "help");
    // `roks brdf` and `roks brdf --help`, or `roks` and `roks --help`.
    let (usage, help) = sub.map_or_else(
        || ("roks".to_string(), "roks --help".to_string()),
        |s| {
            let n = s.get_name();
            (format!("roks {n}"), format!("roks {n} --help"))
        },
    );
    let subcommands = || {
        cmd.get_subcommands()
            .map(|s| s.get_name().to_string())
            .filter(|n| n != "help")
            .collect::<Vec<_>>()
            .join(", ")
    };
    let suggest = |kind| {
        let s = one(kind);
        if s.is_empty() {
            String::new()
        } else {
            format!("; did you mean {}?", quoted(&s))
        }
    };
    match e.kind() {
        ErrorKind::ValueValidation => {
            let why = std::error::Error::source(e)
                .map_or_else(|| format!("invalid value `{value}`"), ToString::to_string);
            format!("{option}: {why}")
        }
        ErrorKind::InvalidValue => {
            let valid = one(ContextKind::ValidValue);
            let allowed = if valid.is_empty() {
                String::new()
            } else {
                format!(": one of {}", valid.join(", "))
            };
            if value.is_empty() {
                format!("{option}: needs a value{allowed}")
            } else {
                format!(
                    "{option}: `{value}` is not allowed{allowed}{}",
                    suggest(ContextKind::SuggestedValue)
                )
            }
        }
        ErrorKind::UnknownArgument if arg.starts_with('-') && arg.len() > 1 => format!(
            "{arg}: unknown option of `{usage}`{} (`{help}` lists the options)",
            suggest(ContextKind::SuggestedArg),
        ),
        ErrorKind::UnknownArgument => {
            format!("`{arg}`: unexpected argument of `{usage}` (`{help}` shows what it takes)")
        }
        ErrorKind::InvalidSubcommand => format!(
            "`{}`: unknown subcommand, expected one of {}{}",
            first(ContextKind::InvalidSubcommand),
            subcommands(),
            suggest(ContextKind::SuggestedSubcommand),
        ),
        ErrorKind::MissingSubcommand | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            format!("missing subcommand: one of {}", subcommands())
        }
        ErrorKind::MissingRequiredArgument => format!(
            "missing {} (`{help}` shows the usage)",
            one(ContextKind::InvalidArg).join(" and "),
        ),
        ErrorKind::ArgumentConflict => {
            let prior = one(ContextKind::PriorArg);
            if prior.is_empty() || prior.iter().all(|p| p == &arg) {
                format!("{option}: given more than once (give each option once)")
            } else {
                format!(
                    "{option}: cannot be used with {}",
                    prior
                        .iter()
                        .map(|p| option_name(p))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        }
        ErrorKind::TooManyValues
        | ErrorKind::TooFewValues
        | ErrorKind::WrongNumberOfValues
        | ErrorKind::NoEquals => {
            format!("{option}: {}", clap_line(e))
        }
        ErrorKind::InvalidUtf8 => format!("an argument of `{usage}` is not valid UTF-8"),
        _ => clap_line(e),
    }
}

/// Clap's own message, as one line (its first, without `error: `).
fn clap_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let line = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    line.trim_start_matches("error: ").trim().to_string()
}
