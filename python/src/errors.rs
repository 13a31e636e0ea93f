//! The library's errors as Python exceptions: a file that cannot be read or written is an
//! `OSError`, work refused by the memory budget a `MemoryError`, anything else (a damaged file,
//! unusable input) a `ValueError`. The message is the library's, its settings named as
//! Python's keywords (`resolution=812` where the command line says `--resolution 812`).

use implicitize::error::FrontEnd;
use pyo3::PyErr;
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};

/// The Python exception for a library error.
pub fn to_py(error: implicitize::Error) -> PyErr {
    let message = error.worded(FrontEnd::Python);
    match error {
        implicitize::Error::Io { .. } => PyOSError::new_err(message),
        implicitize::Error::Memory { .. } => PyMemoryError::new_err(message),
        _ => PyValueError::new_err(message),
    }
}

/// A `ValueError` with `message`.
pub fn invalid(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}
