//! The common `main`: argument parsing, one-line errors, exit codes, and
//! a quiet end when the reader of standard output goes away.

use clap::{Arg, ArgAction, CommandFactory, FromArgMatches};
use std::fmt;
use std::io::{self, Write};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set when another process of the same job speaks for this one.
static SILENT: AtomicBool = AtomicBool::new(false);

/// Print no error message, help or completion script from this process:
/// another process of the same job speaks for it (rank 0 of an MPI job
/// for the other ranks, which parse the same command line). Exit codes
/// are unchanged.
pub fn silence() {
    SILENT.store(true, Ordering::Relaxed);
}

fn silenced() -> bool {
    SILENT.load(Ordering::Relaxed)
}

/// Exit status for bad input or a failed operation.
pub const EXIT_FAILURE: u8 = 1;
/// Exit status for command-line usage errors (clap uses 2 as well).
pub const EXIT_USAGE: u8 = 2;
/// Exit status when standard output is a pipe whose reader has gone (as
/// in `vol-info big.vvol | head -1`): what a shell shows for a process
/// ended by SIGPIPE (128 + 13), so `set -o pipefail` scripts see it like
/// any other tool's. Nothing is printed.
pub const EXIT_BROKEN_PIPE: u8 = 141;

/// The longest error message printed, in characters; longer ones are cut.
pub const MAX_MESSAGE_CHARS: usize = 1000;

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

/// Whether an error is a usage error: a [`Usage`], or a render option
/// that [`volscene`] refuses as one.
pub fn is_usage(e: &anyhow::Error) -> bool {
    e.downcast_ref::<Usage>().is_some()
        || e.chain().any(|c| {
            c.downcast_ref::<volscene::Error>()
                .is_some_and(|e| e.kind() == volscene::ErrorKind::Usage)
        })
}

/// Run a tool's body and turn an error into `tool: message` on stderr (the
/// whole context chain on one line, no backtrace, control characters
/// escaped) and exit status 1, or 2 for a [`Usage`] error; a closed
/// standard output ends the tool quietly with [`EXIT_BROKEN_PIPE`].
pub fn run(tool: &str, body: impl FnOnce() -> anyhow::Result<()>) -> ExitCode {
    match body() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => ExitCode::from(EXIT_BROKEN_PIPE),
        Err(e) => {
            report_error(tool, &format!("{e:#}"));
            if is_usage(&e) {
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
/// `--version`, `--completions` and `--man` print and exit with 0 (141
/// when standard output was closed).
pub fn parse<C: CommandFactory + FromArgMatches>(tool: &str) -> Result<C, ExitCode> {
    parse_matches(tool).map(|(c, _)| c)
}

/// [`parse`], also returning clap's matches (to tell options given on
/// the command line from defaults).
pub fn parse_matches<C: CommandFactory + FromArgMatches>(
    tool: &str,
) -> Result<(C, clap::ArgMatches), ExitCode> {
    let m = match command::<C>().try_get_matches() {
        Ok(m) => m,
        Err(e) => return Err(clap_exit(tool, e)),
    };
    if let Some(shell) = m.get_one::<clap_complete::Shell>("completions") {
        let mut cmd = command::<C>();
        let mut text = Vec::new();
        clap_complete::generate(*shell, &mut cmd, tool, &mut text);
        return Err(print_bytes(tool, &text));
    }
    if m.get_flag("man") {
        let page = clap_mangen::Man::new(command::<C>());
        let mut text = Vec::new();
        return Err(match page.render(&mut text) {
            Ok(()) => print_bytes(tool, &text),
            Err(e) => {
                report_error(tool, &e.to_string());
                ExitCode::from(EXIT_FAILURE)
            }
        });
    }
    let c = C::from_arg_matches(&m).map_err(|e| clap_exit(tool, e))?;
    Ok((c, m))
}

/// Write `bytes` to standard output: success, a quiet 141 on a closed
/// pipe, or the error.
fn print_bytes(tool: &str, bytes: &[u8]) -> ExitCode {
    if silenced() {
        return ExitCode::SUCCESS;
    }
    let mut out = io::stdout().lock();
    match out.write_all(bytes).and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::from(EXIT_BROKEN_PIPE),
        Err(e) => {
            report_error(tool, &format!("standard output: {e}"));
            ExitCode::from(EXIT_FAILURE)
        }
    }
}

fn clap_exit(tool: &str, e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        // A closed pipe is ignored here: the help has nothing after it.
        if !silenced() {
            let _ = e.print();
        }
        return ExitCode::from(if e.use_stderr() { EXIT_USAGE } else { 0 });
    }
    let msg = volscene::request::clap_message(&e);
    report_error(tool, &format!("{msg} (see --help)"));
    ExitCode::from(EXIT_USAGE)
}

/// Print `tool: message` on stderr as one line: newlines become spaces,
/// other control characters are escaped (a file name or a quoted header
/// line can carry terminal escape sequences), and the message is cut
/// after [`MAX_MESSAGE_CHARS`]. This is the last line of defence: the
/// readers already quote untrusted text through `volcore::text`.
pub fn report_error(tool: &str, message: &str) {
    if silenced() {
        return;
    }
    let msg = message.replace(['\n', '\r'], " ");
    let msg = volcore::text::clip(&msg, MAX_MESSAGE_CHARS);
    // Nowhere left to report a failure to write to stderr.
    let _ = writeln!(io::stderr().lock(), "{tool}: {msg}");
}

/// The I/O errors in an error's chain, also those inside the formats',
/// data model's and comparison crates' error types.
pub fn io_errors(e: &anyhow::Error) -> Vec<&io::Error> {
    e.chain()
        .filter_map(|c| {
            c.downcast_ref::<io::Error>()
                .or_else(|| match c.downcast_ref::<volformats::Error>() {
                    Some(volformats::Error::Io(e)) => Some(e),
                    Some(volformats::Error::Core(volcore::Error::Io(e))) => Some(e),
                    _ => None,
                })
                .or_else(
                    || match c.downcast_ref::<volformats::convert::ConvertError>() {
                        Some(volformats::convert::ConvertError {
                            error: volformats::Error::Io(e),
                            ..
                        }) => Some(e),
                        _ => None,
                    },
                )
                .or_else(|| match c.downcast_ref::<volcore::Error>() {
                    Some(volcore::Error::Io(e)) => Some(e),
                    _ => None,
                })
                .or_else(|| match c.downcast_ref::<volcompare::Error>() {
                    Some(volcompare::Error::Io(e)) => Some(e),
                    _ => None,
                })
        })
        .collect()
}

/// Whether an error comes from writing to a pipe that was closed.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    io_errors(e)
        .iter()
        .any(|e| e.kind() == io::ErrorKind::BrokenPipe)
}

/// Whether an error says the disk (or quota) is full.
pub fn is_disk_full(e: &anyhow::Error) -> bool {
    io_errors(e)
        .iter()
        .any(|e| volformats::output::is_disk_full(e))
}

/// Write one line to standard output. Unlike `println!`, which panics
/// when the reader has gone, this returns the error, and [`run`] ends the
/// tool quietly on it.
pub fn print_line(args: fmt::Arguments<'_>) -> io::Result<()> {
    let mut out = io::stdout().lock();
    out.write_fmt(args)?;
    out.write_all(b"\n")?;
    out.flush()
}

/// `println!` for the tools: returns `io::Result<()>` instead of
/// panicking on a closed pipe (see [`print_line`]).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::run::print_line(format_args!($($arg)*))
    };
}

/// `eprintln!` for the tools' notes and progress lines: a closed or
/// broken standard error is ignored (there is nowhere else to say it)
/// instead of panicking.
#[macro_export]
macro_rules! noteln {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        let _ = ::std::writeln!(::std::io::stderr().lock(), $($arg)*);
    }};
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn broken_pipes_are_found_through_wrappers() {
        let pipe = || io::Error::from(io::ErrorKind::BrokenPipe);
        assert!(is_broken_pipe(&anyhow::Error::new(pipe())));
        assert!(is_broken_pipe(
            &anyhow::Error::new(pipe()).context("out.vvol")
        ));
        assert!(is_broken_pipe(&anyhow::Error::new(volformats::Error::Io(
            pipe()
        ))));
        let conv = volformats::convert::ConvertError::new(std::path::Path::new("-"), pipe());
        assert!(is_broken_pipe(&anyhow::Error::new(conv).context("x")));
        assert!(!is_broken_pipe(&anyhow::anyhow!("Broken pipe")));
        assert!(!is_broken_pipe(&anyhow::Error::new(io::Error::from(
            io::ErrorKind::NotFound
        ))));
    }
}
