//! Errors raised while reading or writing files.

/// What went wrong with a file. Messages are one line and do not repeat the
/// file name: callers add it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file's contents contradict the format.
    #[error("{0}")]
    Invalid(String),
    /// A stored checksum does not match the data.
    #[error("checksum mismatch: {0}")]
    Checksum(String),
    /// The data model rejected what the file describes.
    #[error(transparent)]
    Core(#[from] volcore::Error),
    /// An I/O failure.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

impl Error {
    /// An [`Error::Invalid`] from anything printable.
    pub fn invalid(msg: impl Into<String>) -> Error {
        Error::Invalid(msg.into())
    }
}

/// Result with the formats' [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Map an unexpected end of file to a message saying the file is truncated.
pub fn truncated(what: &str) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |e| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            Error::Invalid(format!("file is truncated (ends inside the {what})"))
        } else {
            Error::Io(e)
        }
    }
}
