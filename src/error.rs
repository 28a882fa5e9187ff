//! The crate's one error type. Every loader and builder returns `Result<T>`;
//! errors carry the file (and line where known) and say what was expected, so
//! the command line can print them as a single line.

use std::fmt;
use std::path::{Path, PathBuf};

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
        match self.line {
            Some(line) => write!(f, "{}:{}", self.file.display(), line),
            None => write!(f, "{}", self.file.display()),
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
    #[error("{}: {source}", path.display())]
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
            message: message.into(),
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
