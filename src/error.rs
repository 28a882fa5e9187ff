//! The crate's one error type. Every loader and builder returns `Result<T>`;
//! errors carry the file (and line where known) and say what was expected, so
//! the command line can print them as a single line. Messages quote what a
//! file said, so control characters in file names and quoted text are shown
//! escaped (`\n`, `\u{1b}`): an error is always one line. And it is short:
//! a run of more than [`TOKEN_MAX`] bytes without white space (a 10 MB key
//! in a TOML file) is quoted by its first [`TOKEN_KEEP`] characters and its
//! size, and a message longer than [`MESSAGE_MAX`] bytes keeps its start
//! and its end ([`clip`]).

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

/// Longest run of non-white-space an error quotes whole, in bytes (a long
/// path still fits).
pub const TOKEN_MAX: usize = 256;

/// Characters kept of a longer run: `kkkk... (10000002 bytes)`.
pub const TOKEN_KEEP: usize = 64;

/// Longest message printed whole, in bytes, once its runs are clipped.
pub const MESSAGE_MAX: usize = 2048;

/// The first `n` characters of `s`.
fn head(s: &str, n: usize) -> &str {
    s.char_indices().nth(n).map_or(s, |(i, _)| &s[..i])
}

/// The last `n` characters of `s`.
fn tail(s: &str, n: usize) -> &str {
    s.char_indices()
        .rev()
        .nth(n.saturating_sub(1))
        .map_or(s, |(i, _)| &s[i..])
}

/// `s` on one line ([`one_line`]) and short: each run of non-white-space
/// longer than [`TOKEN_MAX`] bytes becomes its first [`TOKEN_KEEP`]
/// characters, `...` and its length in bytes; then, if still longer than
/// [`MESSAGE_MAX`] bytes, the message keeps its first and last quarter of
/// that and says how much it left out.
pub fn clip(s: &str) -> Cow<'_, str> {
    let line = one_line(s);
    let long_run = line
        .split(char::is_whitespace)
        .any(|run| run.len() > TOKEN_MAX);
    if !long_run && line.len() <= MESSAGE_MAX {
        return line;
    }
    let mut out = String::new();
    let mut rest: &str = &line;
    while !rest.is_empty() {
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let (run, after) = rest.split_at(end);
        if run.len() > TOKEN_MAX {
            out.push_str(head(run, TOKEN_KEEP));
            out.push_str(&format!("... ({} bytes)", run.len()));
        } else {
            out.push_str(run);
        }
        let space = after.len() - after.trim_start().len();
        out.push_str(&after[..space]);
        rest = &after[space..];
    }
    if out.len() > MESSAGE_MAX {
        let (a, b) = (head(&out, MESSAGE_MAX / 4), tail(&out, MESSAGE_MAX / 4));
        out = format!("{a} [... {} bytes ...] {b}", out.len() - a.len() - b.len());
    }
    Cow::Owned(out)
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
            Some(line) => write!(f, "{}:{}", clip(&file), line),
            None => write!(f, "{}", clip(&file)),
        }
    }
}

/// Everything that can go wrong in embertrace.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input file is malformed, missing or inconsistent.
    #[error("{at}: {}", clip(message))]
    Input {
        /// The file and line.
        at: Location,
        /// What was wrong and what was expected.
        message: String,
    },
    /// An I/O failure on a file we were told to read or write.
    #[error("{}: {}", clip(&path.display().to_string()), clip(&source.to_string()))]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A command-line setting is out of range or inconsistent.
    #[error("{}", clip(.0))]
    Settings(String),
    /// The ray-query backend failed (for example Embree reported an error).
    #[error("{backend}: {}", clip(message))]
    Backend {
        /// Which backend.
        backend: &'static str,
        /// What it said.
        message: String,
    },
    /// A render produced non-finite samples while `--strict` was on.
    #[error("{}", clip(.0))]
    Strict(String),
    /// A render stopped on SIGINT or SIGTERM after saving its checkpoint.
    #[error("{}", clip(.0))]
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
            message: clip(&message.into()).into_owned(),
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

    #[test]
    fn long_runs_and_long_messages_are_clipped() {
        let big = "é".repeat(5_000_000);
        let e = Error::input(
            Path::new("s.toml"),
            Some(2),
            format!("unknown field `{big}`, expected x"),
        );
        let s = e.to_string();
        let kept = format!(
            "s.toml:2: unknown field `{}... (10000003 bytes) expected x",
            "é".repeat(63)
        );
        assert_eq!(s, kept);
        // a run up to TOKEN_MAX bytes, such as a long path, is kept whole
        let path = "/a".repeat(TOKEN_MAX / 2);
        assert_eq!(clip(&path), path);
        // many short runs: the start and the end survive
        let words = "word ".repeat(10_000);
        let message = format!("start {words}end");
        let c = clip(&message);
        assert!(
            c.len() < MESSAGE_MAX && c.starts_with("start word") && c.ends_with("word end"),
            "{c}"
        );
        assert!(c.contains(" bytes ...] "), "{c}");
        assert_eq!(
            Error::Settings(format!("-o {big}")).to_string().len(),
            3 + 64 * 2 + 20
        );
    }
}
