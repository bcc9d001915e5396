//! The common `main`: one-line errors and exit codes.

use std::process::ExitCode;

/// Exit status for bad input or a failed operation.
pub const EXIT_FAILURE: u8 = 1;
/// Exit status for command-line usage errors (clap uses 2 as well).
pub const EXIT_USAGE: u8 = 2;

/// Run a tool's body and turn an error into `tool: message` on stderr (the
/// whole context chain on one line, no backtrace) and exit status 1.
pub fn run(tool: &str, body: impl FnOnce() -> anyhow::Result<()>) -> ExitCode {
    match body() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("{tool}: {msg}");
            ExitCode::from(EXIT_FAILURE)
        }
    }
}
