//! Reading the files a scene names: whole, with a size cap checked before a
//! byte is read ([`crate::limits`]), text refused at its first NUL byte,
//! binary formats at their missing magic bytes, and a path that is not a
//! file (a directory, nothing) named as such.

use crate::error::{Error, Result};
use crate::limits::MAX_SCENE_FILE_BYTES;
use std::path::Path;

/// What a file read by [`read_bounded`] must look like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Content {
    /// Text: a NUL byte (binary data, UTF-16, `/dev/zero`) is refused at
    /// its line as soon as it is read.
    Text,
    /// Data that starts with these bytes, in the named format.
    Magic(&'static [u8], &'static str),
}

/// Read `path` whole, refusing files over `limit` bytes before reading them
/// (devices and pipes, which have no size, after `limit` bytes) and data that
/// is not `content`, as early as it shows.
pub(crate) fn read_bounded(path: &Path, limit: u64, content: Content) -> Result<Vec<u8>> {
    use std::io::Read;
    let too_big = |size: String| {
        Error::input(
            path,
            None,
            format!("{size} bytes: larger than the {limit} bytes such a file may have"),
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(Error::input(path, None, "is a directory, expected a file"));
    }
    if meta.len() > limit {
        return Err(too_big(meta.len().to_string()));
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut reader = file.take(limit + 1);
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    let mut chunk = vec![0u8; 1 << 16];
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(path, e)),
        };
        let start = bytes.len();
        bytes.extend_from_slice(&chunk[..n]);
        match content {
            Content::Text => {
                if let Some(i) = chunk[..n].iter().position(|&b| b == 0) {
                    let line = bytes[..start + i].iter().filter(|&&b| b == b'\n').count() + 1;
                    return Err(Error::input(
                        path,
                        Some(line),
                        "binary data (a NUL byte): not a text file (UTF-16 text must be converted to UTF-8)",
                    ));
                }
            }
            Content::Magic(magic, format) => {
                let have = bytes.len().min(magic.len());
                if bytes[..have] != magic[..have] {
                    return Err(not_format(path, magic, format));
                }
            }
        }
        if bytes.len() as u64 > limit {
            return Err(too_big(format!("more than {limit}")));
        }
    }
    if let Content::Magic(magic, format) = content {
        if bytes.len() < magic.len() {
            return Err(not_format(path, magic, format));
        }
    }
    Ok(bytes)
}

/// Why a file a scene names cannot be read as one: `None` when it is a
/// file, else "is a directory" or "not found".
pub(crate) fn not_a_file(path: &Path) -> Option<&'static str> {
    if path.is_file() {
        None
    } else if path.is_dir() {
        Some("is a directory")
    } else {
        Some("not found")
    }
}

/// The error for a file that lacks its format's `magic` first bytes.
fn not_format(path: &Path, magic: &[u8], format: &str) -> Error {
    Error::input(
        path,
        None,
        format!(
            "does not start with `{}`: not a {format} file",
            String::from_utf8_lossy(magic)
        ),
    )
}

/// A text scene file, read whole (see [`read_bounded`]), with the line of
/// the first byte that is not UTF-8.
pub(super) fn read_scene_text(path: &Path) -> Result<String> {
    let bytes = read_bounded(path, MAX_SCENE_FILE_BYTES, Content::Text)?;
    String::from_utf8(bytes).map_err(|e| {
        let bytes = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
        Error::input(path, Some(line), "not UTF-8 text")
    })
}
