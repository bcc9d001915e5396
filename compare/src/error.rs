//! Errors of loading and comparing.

use std::fmt;

/// What went wrong, sorted so a tool can map each kind to an exit status.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// A file's contents are malformed or in an unsupported variant.
    #[error("{0}")]
    Invalid(String),
    /// The two inputs cannot be compared: different sizes, dimensions,
    /// sample types or channel counts.
    #[error("{0}")]
    Mismatch(String),
}

impl Error {
    /// An [`Error::Invalid`] from anything printable.
    pub fn invalid(msg: impl fmt::Display) -> Error {
        Error::Invalid(msg.to_string())
    }

    /// An [`Error::Mismatch`] from anything printable.
    pub fn mismatch(msg: impl fmt::Display) -> Error {
        Error::Mismatch(msg.to_string())
    }
}

/// Result with this crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
