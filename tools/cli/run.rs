//! The common `main`: argument parsing, one-line errors and exit codes.

use clap::{Arg, ArgAction, CommandFactory, FromArgMatches};
use std::process::ExitCode;

/// Exit status for bad input or a failed operation.
pub const EXIT_FAILURE: u8 = 1;
/// Exit status for command-line usage errors (clap uses 2 as well).
pub const EXIT_USAGE: u8 = 2;

/// A usage error found after parsing (an output name the tool cannot
/// write, options that do not fit together): exit status 2.
#[derive(Debug)]
pub struct Usage(pub String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// A [`Usage`] error as an `anyhow` error.
pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(Usage(msg.into()))
}

/// Run a tool's body and turn an error into `tool: message` on stderr (the
/// whole context chain on one line, no backtrace) and exit status 1, or 2
/// for a [`Usage`] error.
pub fn run(tool: &str, body: impl FnOnce() -> anyhow::Result<()>) -> ExitCode {
    match body() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("{tool}: {msg}");
            if e.downcast_ref::<Usage>().is_some() {
                ExitCode::from(EXIT_USAGE)
            } else {
                ExitCode::from(EXIT_FAILURE)
            }
        }
    }
}

/// The tool's clap command with the two options every tool has for its
/// installation: `--completions SHELL` and `--man`.
pub fn command<C: CommandFactory>() -> clap::Command {
    C::command()
        .arg(
            Arg::new("completions")
                .long("completions")
                .value_name("SHELL")
                .value_parser(clap::value_parser!(clap_complete::Shell))
                .exclusive(true)
                .help("Print the shell completion script (bash, zsh, fish, elvish, powershell) and exit"),
        )
        .arg(
            Arg::new("man")
                .long("man")
                .action(ArgAction::SetTrue)
                .exclusive(true)
                .help("Print the man page (roff) and exit"),
        )
}

/// Parse the command line. Usage errors print one line,
/// `tool: problem (see --help)`, and exit with status 2; `--help`,
/// `--version`, `--completions` and `--man` print and exit with 0.
pub fn parse<C: CommandFactory + FromArgMatches>(tool: &str) -> Result<C, ExitCode> {
    let m = match command::<C>().try_get_matches() {
        Ok(m) => m,
        Err(e) => return Err(clap_exit(tool, e)),
    };
    if let Some(shell) = m.get_one::<clap_complete::Shell>("completions") {
        let mut cmd = command::<C>();
        clap_complete::generate(*shell, &mut cmd, tool, &mut std::io::stdout());
        return Err(ExitCode::SUCCESS);
    }
    if m.get_flag("man") {
        let page = clap_mangen::Man::new(command::<C>());
        return Err(match page.render(&mut std::io::stdout()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("{tool}: {e}");
                ExitCode::from(EXIT_FAILURE)
            }
        });
    }
    C::from_arg_matches(&m).map_err(|e| clap_exit(tool, e))
}

fn clap_exit(tool: &str, e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        let _ = e.print();
        return ExitCode::from(if e.use_stderr() { EXIT_USAGE } else { 0 });
    }
    let text = e.to_string();
    let first = text.lines().next().unwrap_or("invalid arguments");
    let first = first.trim_start_matches("error: ");
    eprintln!("{tool}: {first} (see --help)");
    ExitCode::from(EXIT_USAGE)
}
