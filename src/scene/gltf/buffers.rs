//! The bytes a glTF file points at: its buffers (a GLB's binary chunk, a
//! `data:` URI, or a file next to the scene) and its images' encoded bytes
//! (a buffer view, a `data:` URI, or a file).

use crate::error::{Error, Result};
use crate::limits::MAX_MESH_FILE_BYTES;
use base64::Engine;
use std::path::{Path, PathBuf};

/// A URI's bytes: a `data:` URI's payload (base64), or the file it names
/// relative to the scene's folder (percent-escapes decoded). `what` names
/// the thing in errors ("buffer 2", "image 0"); `files` collects the files
/// read.
pub(super) fn uri_bytes(
    path: &Path,
    uri: &str,
    what: &str,
    files: &mut Vec<PathBuf>,
) -> Result<Vec<u8>> {
    let fail = |m: String| Error::input(path, None, format!("{what}: {m}"));
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((header, payload)) = rest.split_once(',') else {
            return Err(fail("a data: URI without a comma".into()));
        };
        if !header.ends_with(";base64") {
            return Err(fail(format!(
                "a data: URI that is not base64 (`data:{header},...`)"
            )));
        }
        return base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| fail(format!("its data: URI is not valid base64: {e}")));
    }
    if uri.contains("://") {
        return Err(fail(format!(
            "`{}` is not a relative file name: only files next to the scene and data: URIs are read",
            crate::error::one_line(uri)
        )));
    }
    let name = percent_decode(uri).ok_or_else(|| {
        fail(format!(
            "`{}` has a malformed percent-escape",
            crate::error::one_line(uri)
        ))
    })?;
    let file = path.parent().unwrap_or(Path::new("")).join(&name);
    if let Some(why) = crate::scene::not_a_file(&file) {
        return Err(fail(format!("`{}` {why}", crate::error::one_line(&name))));
    }
    let bytes = crate::scene::read_bounded(
        &file,
        MAX_MESH_FILE_BYTES,
        crate::scene::Content::Magic(b"", "any"),
    )?;
    files.push(file);
    Ok(bytes)
}

/// `%XX` escapes decoded (a URI's file name); `None` when an escape is
/// malformed or the result is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The bytes of every buffer of `doc`, in order: the GLB chunk `blob` for
/// the one without a URI, the others from their URIs. A buffer shorter than
/// its declared `byteLength` is an error (accessors would read past it).
pub(super) fn load_buffers(
    path: &Path,
    doc: &gltf::Document,
    blob: Option<Vec<u8>>,
    files: &mut Vec<PathBuf>,
) -> Result<Vec<Vec<u8>>> {
    let mut blob = blob;
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let what = format!("buffer {}", buffer.index());
        let bytes = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                Error::input(
                    path,
                    None,
                    format!("{what} has no URI, and the file has no binary (GLB) chunk"),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => uri_bytes(path, uri, &what, files)?,
        };
        if bytes.len() < buffer.length() {
            return Err(Error::input(
                path,
                None,
                format!(
                    "{what} holds {} bytes, but its byteLength says {}",
                    bytes.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(bytes);
    }
    Ok(out)
}

/// The encoded bytes of `image`.
pub(super) fn image_bytes<'b>(
    path: &Path,
    image: &gltf::Image<'_>,
    buffers: &'b [Vec<u8>],
    files: &mut Vec<PathBuf>,
) -> Result<std::borrow::Cow<'b, [u8]>> {
    let what = format!("image {}", image.index());
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let data = &buffers[view.buffer().index()];
            let range = view.offset()..view.offset().saturating_add(view.length());
            data.get(range)
                .map(std::borrow::Cow::Borrowed)
                .ok_or_else(|| {
                    Error::input(
                        path,
                        None,
                        format!("{what}: its buffer view runs past its buffer"),
                    )
                })
        }
        gltf::image::Source::Uri { uri, .. } => {
            Ok(std::borrow::Cow::Owned(uri_bytes(path, uri, &what, files)?))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("a%20b.png").as_deref(), Some("a b.png"));
        assert_eq!(percent_decode("plain.bin").as_deref(), Some("plain.bin"));
        assert_eq!(percent_decode("bad%2"), None);
        assert_eq!(percent_decode("bad%zz"), None);
    }

    #[test]
    fn data_uris_decode_and_bad_ones_are_named() {
        let mut files = Vec::new();
        let p = Path::new("s.gltf");
        let ok = uri_bytes(
            p,
            "data:application/octet-stream;base64,AAEC",
            "buffer 0",
            &mut files,
        );
        assert_eq!(ok.unwrap(), vec![0, 1, 2]);
        let e = uri_bytes(p, "data:text/plain,abc", "buffer 1", &mut files).unwrap_err();
        assert!(e.to_string().contains("buffer 1"), "{e}");
        let e = uri_bytes(p, "https://x/y.bin", "buffer 2", &mut files).unwrap_err();
        assert!(e.to_string().contains("relative file"), "{e}");
        assert!(files.is_empty());
    }
}
