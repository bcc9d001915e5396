//! The one error type of a render's options, files and frame: a line of
//! text, as vol-render prints it after its name, and what kind of problem
//! it is (so a caller can tell a bad option from a file it cannot read).

use std::fmt;

/// What kind of problem an [`Error`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// Options that cannot be used as given (a malformed value, options
    /// that do not go together), found after the command line was parsed:
    /// vol-render exits with status 2, like clap's own usage errors.
    Usage,
    /// An option's value that the volume, the other options or the
    /// renderer refuse (a step too small for the volume, `--iso` outside
    /// iso mode): vol-render exits with status 1.
    Option,
    /// A file that cannot be read or written, or whose contents are not
    /// what they should be (the volume, its index, a transfer function, a
    /// scene file, an environment map, a path-tracing state).
    File,
    /// The renderer failed on a frame it had accepted.
    Render,
    /// The caller raised the render's [`volrender::Cancel`] flag.
    Cancelled,
}

/// Why a render cannot be done as asked: one line, without the tool's
/// name (`shapes.vvol: --iso needs --mode iso`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    kind: ErrorKind,
    message: String,
    /// The message names its own input at fault (a transfer function or
    /// environment map file), so [`Error::naming_volume`] leaves it as is.
    named: bool,
}

impl Error {
    /// An error of `kind` saying `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Error {
        Error {
            kind,
            message: message.into(),
            named: false,
        }
    }

    /// A [`ErrorKind::Usage`] error.
    pub fn usage(message: impl Into<String>) -> Error {
        Error::new(ErrorKind::Usage, message)
    }

    /// An [`ErrorKind::Option`] error.
    pub fn option(message: impl Into<String>) -> Error {
        Error::new(ErrorKind::Option, message)
    }

    /// A [`ErrorKind::File`] error.
    pub fn file(message: impl Into<String>) -> Error {
        Error::new(ErrorKind::File, message)
    }

    /// The cancelled error (`cancelled`).
    pub fn cancelled() -> Error {
        Error::new(ErrorKind::Cancelled, "cancelled")
    }

    /// What kind of problem this is.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The message, one line.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The same error with `what: ` before its message (the file or
    /// option it concerns), as a context chain prints.
    pub fn context(self, what: impl fmt::Display) -> Error {
        Error {
            kind: self.kind,
            message: format!("{what}: {}", self.message),
            named: self.named,
        }
    }

    /// The same error, marked as naming the input at fault itself: its
    /// message starts with a file other than the volume (`wide.tf: ...`).
    pub fn named(self) -> Error {
        Error {
            named: true,
            ..self
        }
    }

    /// The error of a render of the volume `name`: `name: ` before the
    /// message, unless the message names its own input at fault (see
    /// [`Error::named`]): a bad transfer function file is not the volume's
    /// fault.
    pub fn naming_volume(self, name: impl fmt::Display) -> Error {
        if self.named {
            self
        } else {
            self.context(name)
        }
    }

    /// A renderer's error, of the kind its variant says: settings and
    /// cameras it refuses are option problems, an index that does not fit
    /// is a file problem.
    pub fn from_render(e: volrender::RenderError) -> Error {
        use volrender::RenderError as R;
        let kind = match &e {
            R::Camera(_) | R::Setting(_) | R::TfSyntax { .. } => ErrorKind::Option,
            R::Index(_) => ErrorKind::File,
            R::Cancelled => ErrorKind::Cancelled,
        };
        Error::new(kind, e.to_string())
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

/// A `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// An error and its sources as one line, `error: source: source`, as
/// `anyhow` prints a chain with `{:#}` (so messages read as they did when
/// the tool wrapped errors in `anyhow`).
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// Turn another crate's error into one of this crate's, with a kind and
/// a context.
pub(crate) trait Kind<T> {
    /// The error as `kind`, its message (and sources) after `what: `.
    fn kind_ctx(self, kind: ErrorKind, what: impl fmt::Display) -> Result<T>;
}

impl<T, E: std::error::Error> Kind<T> for std::result::Result<T, E> {
    fn kind_ctx(self, kind: ErrorKind, what: impl fmt::Display) -> Result<T> {
        self.map_err(|e| Error::new(kind, format!("{what}: {}", chain(&e))))
    }
}

/// clap's error as a usage error of one line (see [`clap_message`]).
pub(crate) fn clap_error(e: clap::Error) -> Error {
    Error::usage(clap_message(&e))
}

/// clap's error message on one line: the text up to its usage block,
/// without the `error: ` in front; every tool prints its usage errors so.
pub fn clap_message(e: &clap::Error) -> String {
    let text = e.to_string();
    let lines: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    let msg = lines.join(" ");
    msg.trim_start_matches("error: ").to_string()
}
