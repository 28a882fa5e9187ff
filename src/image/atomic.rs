//! Atomic writes: every file goes to a temporary file in the target's
//! directory, is synced, then renamed over the target, so a reader never
//! sees a half-written file and a failed write leaves nothing.

use crate::error::{Error, Result};
use std::ffi::OsString;
use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The directory `path` lives in (`.` for a bare file name).
pub(super) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A temporary file next to its target, removed on drop unless it was renamed
/// into place.
pub(super) struct TempFile {
    path: PathBuf,
    renamed: bool,
}

impl TempFile {
    /// Creates `.{name}.tmp-{pid}-{n}` in `target`'s directory, where `n` makes
    /// concurrent writes from one process distinct.
    pub(super) fn create(target: &Path) -> Result<(TempFile, File)> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let Some(name) = target.file_name() else {
            return Err(Error::Settings(format!(
                "{}: not a file name",
                target.display()
            )));
        };
        let mut tmp_name = OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(
            ".tmp-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let path = parent_dir(target).join(tmp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| Error::io(target, e))?;
        Ok((
            TempFile {
                path,
                renamed: false,
            },
            file,
        ))
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.renamed {
            // Best effort: the write already failed, and that error is the one
            // to report.
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Writes `path` through `write`: the bytes go to a temporary file in the same
/// directory, which is flushed, synced and renamed over `path`. On any error
/// (including one from `write`) the temporary file is removed and `path` is
/// left as it was.
///
/// A target that exists and is not a regular file (a device such as
/// `/dev/null` or `/dev/full`, a FIFO, a socket, or a link to one) cannot be
/// replaced without destroying it: it is written in place, and its errors
/// (`/dev/full`'s "no space left") are this write's.
pub(crate) fn write_atomically<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    if is_special(path)? {
        let file = OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| Error::io(path, e))?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        w.into_inner()
            .map_err(|e| Error::io(path, e.into_error()))?;
        return Ok(());
    }
    let (mut tmp, file) = TempFile::create(path)?;
    let mut w = BufWriter::new(file);
    write(&mut w)?;
    let file = w
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(path, e))?;
    drop(file);
    fs::rename(&tmp.path, path).map_err(|e| Error::io(path, e))?;
    tmp.renamed = true;
    // Make the rename itself durable. Best effort: the new file is already in
    // place, so failing here would misreport a completed write.
    if let Ok(dir) = File::open(parent_dir(path)) {
        let _ = dir.sync_all();
    }
    Ok(())
}

/// Whether `path` (its links followed) exists and is neither a regular file
/// nor a directory: a target to write in place. A directory is an error.
pub(super) fn is_special(path: &Path) -> Result<bool> {
    match fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(Error::Settings(format!(
            "{}: is a directory, not a file to write",
            path.display()
        ))),
        Ok(m) => Ok(!m.is_file()),
        Err(_) => Ok(false),
    }
}

/// Writes `bytes` to `path` atomically: to a temporary file in the same
/// directory, synced, then renamed over `path`; on error nothing appears at
/// `path` (an existing file is left untouched) and the temporary file is
/// removed. For reports and other small files.
pub fn write_file_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

#[cfg(test)]
mod tests {
    use super::super::testing::{entries, gradient_film};
    use super::super::{OutputOptions, write_image};
    use super::*;
    use crate::film::Film;

    #[test]
    fn failed_writes_leave_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let film = gradient_film(2, 2);

        // Missing directory: an error naming the target, nothing created.
        let target = dir.path().join("missing").join("img.pfm");
        let err = write_image(&target, &film, &OutputOptions::default()).unwrap_err();
        assert!(
            matches!(err, Error::Io { ref path, .. } if *path == target),
            "{err}"
        );
        assert!(entries(dir.path()).is_empty());

        // An encoder that fails halfway: the partial temporary file is removed
        // and an existing target keeps its old contents.
        let target = dir.path().join("report.json");
        fs::write(&target, b"old").unwrap();
        let err = write_atomically(&target, |w| {
            w.write_all(&[1u8; 100_000]).unwrap();
            Err(Error::Settings("encoder gave up".into()))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "encoder gave up");
        assert_eq!(entries(dir.path()), ["report.json"]);
        assert_eq!(fs::read(&target).unwrap(), b"old");

        // Empty films cannot be encoded: refused before any file is made.
        let empty = dir.path().join("empty.exr");
        assert!(write_image(&empty, &Film::new(0, 2), &OutputOptions::default()).is_err());
        assert_eq!(entries(dir.path()), ["report.json"]);

        // A successful write replaces the target and leaves no temporary.
        write_file_atomically(&target, b"{\"spp\": 4}").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"{\"spp\": 4}");
        assert_eq!(entries(dir.path()), ["report.json"]);
    }
}
