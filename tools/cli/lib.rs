//! Shared plumbing for the volkit command-line tools: argument parsers,
//! progress bars, JSON output and the error-reporting `main` wrapper.

pub mod args;
pub mod json;
pub mod progress;
pub mod run;
pub mod select;
pub mod stdout;

pub use run::{is_usage, parse, run, usage};
pub use select::{RawSpec, Selection};
pub use stdout::stdout_file;
