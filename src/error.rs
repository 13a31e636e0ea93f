//! The library's error type.
//!
//! Every error that comes from user input names the file it came from and, where it
//! applies, the line or byte offset, so the command-line tool can print it as one clear
//! line. No user input makes the library panic.
//!
//! Messages name the library's own settings (the fields of the option structs) between
//! backquotes, as `` `max_iterations` `` or `` `resolution=812` ``; each front end words them
//! for its users with [`Error::worded`] (the command line as `--max-iterations` and
//! `--resolution 812`, Python as `max_iterations` and `resolution=812`).

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
    /// coincident constraints, an option out of its range and the like.
    #[error("{context}: {message}")]
    Invalid {
        /// What was being processed: a file name, or a description such as "constraints".
        context: String,
        /// What was wrong.
        message: String,
    },
    /// Work refused before it started: its memory estimate exceeds the limit (see
    /// [`crate::memory`]).
    #[error("{context}: {message}")]
    Memory {
        /// What was being processed (a file name) and what needs the memory.
        context: String,
        /// The estimate, the limit and the largest setting that fits.
        message: String,
    },
    /// A fit refused before its iterations: the solid is thinner than the grid can hold (see
    /// [`crate::fit::Thickness`]); the message names the thickness measured and what would
    /// work (a finer `resolution`, or `shell`).
    #[error("{context}: {message}")]
    Thin {
        /// What was being fitted (a file name).
        context: String,
        /// The thickness measured and the settings that would work.
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

    /// The error with `context` in front of its own, unless it names it already (a stage's
    /// error, named after the file it came from).
    pub fn in_context(self, context: &str) -> Self {
        match self {
            Error::Invalid { context: inner, message } if inner != context => {
                Error::invalid(context, format!("{inner}: {message}"))
            }
            Error::Memory { context: inner, message } if inner != context => {
                Error::Memory { context: format!("{context}: {inner}"), message }
            }
            Error::Thin { context: inner, message } if inner != context => {
                Error::Thin { context: format!("{context}: {inner}"), message }
            }
            other => other,
        }
    }

    /// The message with the settings it names worded for a front end: every `` `name` `` or
    /// `` `name=value` `` between backquotes, `name` a setting (lower case and underscores),
    /// becomes what `front` calls it.
    pub fn worded(&self, front: FrontEnd) -> String {
        worded(&self.to_string(), front)
    }
}

/// Who shows an error to its user, and so how it names the library's settings.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum FrontEnd {
    /// The command line: `--max-iterations`, `--resolution 812`.
    #[default]
    Cli,
    /// Python's keyword arguments: `max_iterations`, `resolution=812`.
    Python,
}

impl FrontEnd {
    /// `setting`, with `value` when given, as this front end spells it.
    pub fn setting(self, setting: &str, value: Option<&str>) -> String {
        match (self, value) {
            (FrontEnd::Cli, None) => format!("--{}", setting.replace('_', "-")),
            (FrontEnd::Cli, Some(v)) => format!("--{} {v}", setting.replace('_', "-")),
            (FrontEnd::Python, None) => setting.to_string(),
            (FrontEnd::Python, Some(v)) => format!("{setting}={v}"),
        }
    }
}

/// `message` (an error's, perhaps with context in front) with its backquoted settings worded
/// for `front` (see [`Error::worded`]).
pub fn worded(message: &str, front: FrontEnd) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(start) = rest.find('`') {
        let Some(len) = rest[start + 1..].find('`') else { break };
        let quoted = &rest[start + 1..start + 1 + len];
        let (name, value) = match quoted.split_once('=') {
            Some((name, value)) => (name, Some(value)),
            None => (quoted, None),
        };
        out.push_str(&rest[..start]);
        if !name.is_empty() && name.bytes().all(|b| b.is_ascii_lowercase() || b == b'_') {
            out.push_str(&front.setting(name, value));
        } else {
            out.push_str(&rest[start..start + len + 2]);
        }
        rest = &rest[start + len + 2..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_worded_for_each_front_end() {
        let e = Error::invalid(
            "bunny.obj",
            "`max_iterations` must be at least 1; the largest that fits is `resolution=812`",
        );
        assert_eq!(
            e.worded(FrontEnd::Cli),
            "bunny.obj: --max-iterations must be at least 1; the largest that fits is \
             --resolution 812"
        );
        assert_eq!(
            e.worded(FrontEnd::Python),
            "bunny.obj: max_iterations must be at least 1; the largest that fits is \
             resolution=812"
        );
        let other = Error::invalid("a `Model` file", "an unmatched ` quote");
        assert_eq!(other.worded(FrontEnd::Cli), other.to_string());
    }
}
