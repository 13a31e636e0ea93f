//! The library's error type.
//!
//! Every error that comes from user input names the file it came from and, where it
//! applies, the line or byte offset, so the command-line tool can print it as one clear
//! line. No user input makes the library panic.

use std::fmt;
use std::path::PathBuf;

/// Where in a file a problem was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A 1-based line of a text file.
    Line(usize),
    /// A 0-based byte offset into a binary file.
    Byte(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Byte(n) => write!(f, "byte {n}"),
        }
    }
}

/// Everything that can go wrong in implicitize.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read or written.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said (part of the message, so not repeated as a cause).
        error: std::io::Error,
    },
    /// The file's contents are not what its format requires.
    #[error("{}{}: {message}", path.display(), location.map(|l| format!(" ({l})")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where in the file, when known.
        location: Option<Location>,
        /// What was wrong.
        message: String,
    },
    /// The input parsed but cannot be used: an empty or flat mesh, NaN coordinates,
    /// coincident constraints and the like.
    #[error("{context}: {message}")]
    Invalid {
        /// What was being processed: a file name, or a description such as "constraints".
        context: String,
        /// What was wrong.
        message: String,
    },
}

/// The library's result type.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), error: source }
    }

    /// A parse error in `path`, optionally at a location.
    pub fn parse(
        path: impl Into<PathBuf>,
        location: Option<Location>,
        message: impl Into<String>,
    ) -> Self {
        Error::Parse { path: path.into(), location, message: message.into() }
    }

    /// Input that parsed but cannot be used.
    pub fn invalid(context: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid { context: context.into(), message: message.into() }
    }
}
