//! Rust errors as Python exceptions, with the command-line tools' one-line
//! messages in Python's words (flags named as keywords,
//! [`crate::keywords::python_words`]): a bad option is a `ValueError`, a
//! file problem an `OSError`, a cancelled render `KeyboardInterrupt`,
//! anything else `RuntimeError`.

use crate::keywords::python_words;
use pyo3::exceptions::{
    PyFileNotFoundError, PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError,
};
use pyo3::PyErr;
use std::any::Any;
use volformats::convert::ConvertError;
use volscene::ErrorKind;

/// A panic's payload as a `RuntimeError` (a bug, not bad input).
pub fn internal(payload: &(dyn Any + Send)) -> PyErr {
    let msg = payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
        .unwrap_or("unknown panic");
    PyRuntimeError::new_err(format!("internal error in volkit: {msg}"))
}

/// A render's error by its kind.
pub fn scene(e: volscene::Error) -> PyErr {
    let msg = python_words(e.message());
    match e.kind() {
        ErrorKind::Usage | ErrorKind::Option => PyValueError::new_err(msg),
        ErrorKind::File => PyOSError::new_err(msg),
        ErrorKind::Render => PyRuntimeError::new_err(msg),
        ErrorKind::Cancelled => PyKeyboardInterrupt::new_err(msg),
    }
}

/// A reading or writing error about a file (`path: problem`), as
/// vol-convert prints it: `FileNotFoundError` for a missing input,
/// `KeyboardInterrupt` for an interrupted conversion, else `OSError`.
pub fn convert(e: ConvertError) -> PyErr {
    let msg = python_words(&e.to_string());
    let missing = match &e.error {
        volformats::Error::Io(io) => io.kind() == std::io::ErrorKind::NotFound,
        volformats::Error::Invalid(m) => m == "no such file or directory",
        _ => false,
    };
    if missing {
        return PyFileNotFoundError::new_err(msg);
    }
    if matches!(&e.error, volformats::Error::Invalid(m) if m == "interrupted") {
        return PyKeyboardInterrupt::new_err(msg);
    }
    PyOSError::new_err(msg)
}

/// A bad argument: `ValueError` with `msg`.
pub fn value(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(python_words(&msg.into()))
}

/// A file problem: `OSError` with `msg`.
pub fn os(msg: impl Into<String>) -> PyErr {
    PyOSError::new_err(python_words(&msg.into()))
}
