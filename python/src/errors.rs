//! The library's errors as Python exceptions: a file that cannot be read or written is an
//! `OSError`, work refused by the memory budget a `MemoryError`, anything else (a damaged file,
//! unusable input) a `ValueError`. The message is the library's, its settings named as
//! Python's keywords (`resolution=812` where the command line says `--resolution 812`).
//! Warnings are `UserWarning`s, worded the same way.

use implicitize::FrontEnd;
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;

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

/// Issues a library warning (see `implicitize::pipeline::Prepared::warnings`) as a Python
/// `UserWarning`, its settings worded as keywords, pointing at the line that called the
/// package's function (two frames up: the package's wrapper calls the extension).
pub fn warn(py: Python<'_>, warning: &str) -> PyResult<()> {
    let message = implicitize::worded(warning, FrontEnd::Python).replace('\0', " ");
    let message = std::ffi::CString::new(message).unwrap_or_default();
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    PyErr::warn(py, category.as_any(), &message, 2)
}
