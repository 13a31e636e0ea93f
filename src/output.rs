//! Output files that are never half-written.
//!
//! Every file the library and the `implicitize` command write (models, reports, volumes and
//! their grid files, meshes, pictures) goes through [`write_with`] or [`write_bytes`]: the
//! contents are written to a temporary file in the same folder, flushed to the disk
//! (`fsync`), and only then renamed over the destination. A rename within one folder is
//! atomic, so a process killed at any moment leaves the destination either as it was before
//! (absent, or the previous complete file) or complete and new; never truncated.
//!
//! A killed process can leave its temporary file behind: a hidden file in the destination's
//! folder named `.NAME.PID.N.tmp` (for destination `NAME`), which is safe to delete.
//!
//! [`check_destination`] and [`prepare_folder`] check, before any long work starts, that a
//! file can be written where it is asked for, so a long run does not fail at its end.
//!
//! ```
//! use implicitize::output;
//! # fn main() -> implicitize::Result<()> {
//! let dir = std::env::temp_dir();
//! let path = dir.join(format!("implicitize-doc-{}.txt", std::process::id()));
//! output::check_destination(&path)?;
//! let io = |e| implicitize::Error::io(&path, e);
//! output::write_with(&path, |out| std::io::Write::write_all(out, b"hello\n").map_err(io))?;
//! assert_eq!(std::fs::read(&path).unwrap(), b"hello\n");
//! # std::fs::remove_file(&path).unwrap();
//! # Ok(())
//! # }
//! ```

use std::fs::File;
use std::io::{BufWriter, ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Temporary files made by this process so far, for unique names.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A temporary file beside its destination, removed unless it was renamed into place.
struct Temporary {
    path: PathBuf,
    kept: bool,
}

impl Temporary {
    /// Creates a new, empty temporary file in the folder of `destination`.
    fn create(destination: &Path) -> Result<(Temporary, File)> {
        let name = destination.file_name().ok_or_else(|| {
            Error::invalid(destination.display().to_string(), "not a file name to write to")
        })?;
        let folder = folder_of(destination);
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let mut temporary_name = std::ffi::OsString::from(".");
            temporary_name.push(name);
            temporary_name.push(format!(".{}.{n}.tmp", std::process::id()));
            let path = folder.join(temporary_name);
            match File::options().write(true).create_new(true).open(&path) {
                Ok(file) => return Ok((Temporary { path, kept: false }, file)),
                Err(e) if e.kind() == ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io(destination, e)),
            }
        }
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if !self.kept {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// The folder a destination is written in (`.` for a bare file name).
fn folder_of(destination: &Path) -> &Path {
    match destination.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// Writes `path` atomically: `write` fills a buffered temporary file in the same folder, which
/// is flushed, synced to the disk and renamed over `path` only when `write` succeeded.
///
/// # Errors
/// An error naming `path` when the temporary file cannot be created, written, synced or
/// renamed, or the error `write` returned; `path` is then left as it was.
pub fn write_with<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let (mut temporary, file) = Temporary::create(path)?;
    let mut out = BufWriter::new(file);
    write(&mut out)?;
    let io = |e| Error::io(path, e);
    let file = out.into_inner().map_err(|e| io(e.into_error()))?;
    file.sync_all().map_err(io)?;
    drop(file);
    std::fs::rename(&temporary.path, path).map_err(io)?;
    temporary.kept = true;
    sync_folder(folder_of(path));
    Ok(())
}

/// Writes `bytes` to `path` atomically, as [`write_with`].
///
/// # Errors
/// As [`write_with`].
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |out| out.write_all(bytes).map_err(|e| Error::io(path, e)))
}

/// Syncs a folder so a rename in it survives a crash of the machine. Best effort: some file
/// systems cannot sync folders, and the file itself is already complete.
fn sync_folder(folder: &Path) {
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
}

/// Checks, before the work starts, that a file can be written at `path`: its folder exists
/// and takes new files, and `path` is not a folder. Nothing is left behind.
///
/// # Errors
/// An error naming `path` and what is wrong.
pub fn check_destination(path: &Path) -> Result<()> {
    let folder = folder_of(path);
    let invalid = |message: String| Error::invalid(path.display().to_string(), message);
    if !folder.is_dir() {
        return Err(invalid(format!("the folder {} does not exist", folder.display())));
    }
    if path.is_dir() {
        return Err(invalid("is a folder, not a file".into()));
    }
    Temporary::create(path).map(drop)
}

/// Creates the folder `dir` (and its parents) if need be and checks that it takes new files,
/// before the work that writes into it starts.
///
/// # Errors
/// An error naming `dir` when it cannot be created or written into.
pub fn prepare_folder(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::invalid(dir.display().to_string(), format!("cannot create the folder: {e}"))
    })?;
    Temporary::create(&dir.join("check")).map(drop)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn files_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn replaces_a_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_bytes(&path, b"old").unwrap();
        write_bytes(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(files_in(dir.path()), ["out.txt"]);
    }

    #[test]
    fn a_failed_write_keeps_the_previous_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_bytes(&path, b"old").unwrap();
        let failed = write_with(&path, |out| {
            out.write_all(b"half").unwrap();
            Err(Error::invalid("test", "stopped halfway"))
        });
        assert!(failed.unwrap_err().to_string().contains("stopped halfway"));
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(files_in(dir.path()), ["out.txt"]);
    }

    #[test]
    fn a_missing_folder_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing/out.txt");
        let message = check_destination(&path).unwrap_err().to_string();
        assert!(message.contains("missing/out.txt") && message.contains("does not exist"));
        assert!(write_bytes(&path, b"x").unwrap_err().to_string().contains("missing/out.txt"));
    }

    #[test]
    fn a_folder_is_not_a_destination() {
        let dir = tempfile::tempdir().unwrap();
        let message = check_destination(dir.path()).unwrap_err().to_string();
        assert!(message.contains("is a folder"), "{message}");
        check_destination(&dir.path().join("fine.json")).unwrap();
        prepare_folder(&dir.path().join("a/b")).unwrap();
        assert_eq!(files_in(dir.path()), ["a"]);
        assert!(files_in(&dir.path().join("a/b")).is_empty());
    }
}
