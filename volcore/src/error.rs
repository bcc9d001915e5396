//! Errors raised by the data model.

/// What went wrong while building or reading a volume.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Dimensions that are zero, or whose product overflows 64 bits.
    #[error("invalid dimensions: {0}")]
    Dims(String),
    /// A layout parameter out of its range (brick edge, apron).
    #[error("invalid layout: {0}")]
    Layout(String),
    /// Stored data that does not match what the metadata promises.
    #[error("corrupt data: {0}")]
    Corrupt(String),
    /// An I/O failure.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// Result with the data model's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
