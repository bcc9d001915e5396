//! Errors raised while setting up a frame.

/// Why a frame cannot be rendered as asked.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The camera description is degenerate.
    #[error("camera: {0}")]
    Camera(String),
    /// A setting is out of range.
    #[error("{0}")]
    Setting(String),
    /// The transfer function text could not be parsed.
    #[error("transfer function, line {line}: {msg}")]
    TfSyntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// The index does not belong to the volume.
    #[error("index: {0}")]
    Index(String),
    /// The caller raised the frame's [`crate::settings::Cancel`] flag.
    #[error("cancelled")]
    Cancelled,
}
