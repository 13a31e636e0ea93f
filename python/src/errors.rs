//! The library's errors as Python exceptions: a file that cannot be read or written is an
//! `OSError`, anything else (a damaged file, unusable input) a `ValueError`; the message is the
//! one the command-line tool prints after `error: `.

use pyo3::PyErr;
use pyo3::exceptions::{PyOSError, PyValueError};

/// The Python exception for a library error.
pub fn to_py(error: implicitize::Error) -> PyErr {
    match error {
        implicitize::Error::Io { .. } => PyOSError::new_err(error.to_string()),
        _ => PyValueError::new_err(error.to_string()),
    }
}

/// A `ValueError` with `message`.
pub fn invalid(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}
