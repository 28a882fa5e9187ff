//! The crate's one error type. Every loader and builder returns `Result<T>`;
//! errors carry the file (and line where known) and say what was expected, so
//! the command line can print them as a single line. Messages quote what a
//! file said, so control characters in file names and quoted text are shown
//! escaped (`\n`, `\u{1b}`): an error is always one line.

use std::borrow::Cow;
use std::fmt;
use std::path::{Path, PathBuf};

/// `s` with every control character escaped as Rust writes it, so that it
/// prints on one line.
pub fn one_line(s: &str) -> Cow<'_, str> {
    if s.chars().any(char::is_control) {
        s.chars()
            .map(|c| {
                if c.is_control() {
                    c.escape_debug().to_string()
                } else {
                    c.to_string()
                }
            })
            .collect()
    } else {
        Cow::Borrowed(s)
    }
}

/// Where in an input file something went wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// The file being read.
    pub file: PathBuf,
    /// 1-based line, when known.
    pub line: Option<usize>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let file = self.file.display().to_string();
        match self.line {
            Some(line) => write!(f, "{}:{}", one_line(&file), line),
            None => write!(f, "{}", one_line(&file)),
        }
    }
}

/// Everything that can go wrong in embertrace.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input file is malformed, missing or inconsistent.
    #[error("{at}: {message}")]
    Input {
        /// The file and line.
        at: Location,
        /// What was wrong and what was expected.
        message: String,
    },
    /// An I/O failure on a file we were told to read or write.
    #[error("{}: {}", one_line(&path.display().to_string()), one_line(&source.to_string()))]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A command-line setting is out of range or inconsistent.
    #[error("{0}")]
    Settings(String),
    /// The ray-query backend failed (for example Embree reported an error).
    #[error("{backend}: {message}")]
    Backend {
        /// Which backend.
        backend: &'static str,
        /// What it said.
        message: String,
    },
    /// A render produced non-finite samples while `--strict` was on.
    #[error("{0}")]
    Strict(String),
    /// A render stopped on SIGINT or SIGTERM after saving its checkpoint.
    #[error("{0}")]
    Interrupted(String),
}

/// The crate-wide result.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An input error at `file`, optionally at `line`.
    pub fn input(file: &Path, line: Option<usize>, message: impl Into<String>) -> Self {
        Error::Input {
            at: Location {
                file: file.to_path_buf(),
                line,
            },
            message: one_line(&message.into()).into_owned(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// The next run of non-white-space bytes in `bytes` from `*pos` (a word of
/// a text header or an ASCII data section), as a byte range; `*pos` moves
/// past it and `*line` counts the newlines skipped. `None` at the end.
pub(crate) fn next_word(
    bytes: &[u8],
    pos: &mut usize,
    line: &mut usize,
) -> Option<std::ops::Range<usize>> {
    while let Some(&b) = bytes.get(*pos) {
        if !b.is_ascii_whitespace() {
            break;
        }
        if b == b'\n' {
            *line += 1;
        }
        *pos += 1;
    }
    let start = *pos;
    while bytes.get(*pos).is_some_and(|b| !b.is_ascii_whitespace()) {
        *pos += 1;
    }
    (*pos > start).then_some(start..*pos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_and_file_names_print_on_one_line() {
        let e = Error::input(Path::new("a\nb.toml"), Some(3), "type `x\ny\u{1b}` unknown");
        assert_eq!(e.to_string(), "a\\nb.toml:3: type `x\\ny\\u{1b}` unknown");
        let e = Error::io(Path::new("c\rd"), std::io::Error::other("gone"));
        assert_eq!(e.to_string(), "c\\rd: gone");
        assert_eq!(one_line("plain é"), "plain é");
    }
}
