//! What the XML scene loaders (Mitsuba 3, CS184 COLLADA) share: messages
//! that name the file and the element's line.

use crate::error::Error;
use roxmltree::{Document, Node};
use std::path::Path;

/// The 1-based line where element `n` starts.
pub(super) fn line(doc: &Document, n: Node) -> usize {
    doc.text_pos_at(n.range().start).row as usize
}

/// An input error at element `n` of `path`.
pub(super) fn error(path: &Path, doc: &Document, n: Node, msg: impl Into<String>) -> Error {
    Error::input(path, Some(line(doc, n)), msg)
}

/// A warning at element `n` of `path`, as `file:line: message`.
pub(super) fn warning(path: &Path, doc: &Document, n: Node, msg: impl std::fmt::Display) -> String {
    format!("{}:{}: {msg}", path.display(), line(doc, n))
}
