//! The command line's one logging facility: everything a command prints on
//! standard error, other than the final error itself (`main`), goes through
//! here, at the level the global flags chose:
//!
//! | flags | level | prints |
//! |---|---|---|
//! | `-q` | [`Level::Quiet`] | warnings |
//! | (none) | [`Level::Normal`] | warnings, notes, progress |
//! | `-v` | [`Level::Verbose`] | and details: settings resolved, backend and its library, build and load times, threads, SIMD level |
//! | `-vv` | [`Level::Debug`] | and per-step diagnostics |
//!
//! Warnings survive `-q` because they say what the image will lack (a
//! material the file asks for that the renderer replaced, say). Results a
//! command exists to print (tables, JSON, the man page) go to standard
//! output, never through here. The level is process-wide (one atomic), set
//! once by `main`; the library's own default is [`Level::Normal`].

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU8, Ordering};

/// How much a command says on standard error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Warnings only (`-q`).
    Quiet = 0,
    /// Warnings, notes and progress (the default).
    Normal = 1,
    /// Also details (`-v`).
    Verbose = 2,
    /// Also diagnostics (`-vv` and more).
    Debug = 3,
}

static LEVEL: AtomicU8 = AtomicU8::new(Level::Normal as u8);

impl Level {
    /// The level of `-q` (`quiet`) and `verbose` counted `-v`s.
    pub fn from_flags(quiet: bool, verbose: u8) -> Level {
        match (quiet, verbose) {
            (true, _) => Level::Quiet,
            (false, 0) => Level::Normal,
            (false, 1) => Level::Verbose,
            (false, _) => Level::Debug,
        }
    }
}

/// Set the process's level.
pub fn set_level(level: Level) {
    LEVEL.store(level as u8, Ordering::Relaxed);
}

/// The process's level.
pub fn level() -> Level {
    match LEVEL.load(Ordering::Relaxed) {
        0 => Level::Quiet,
        1 => Level::Normal,
        2 => Level::Verbose,
        _ => Level::Debug,
    }
}

/// Whether messages of `at` are printed.
pub fn enabled(at: Level) -> bool {
    level() >= at
}

/// `warning: <message>`, at every level.
pub fn warn(message: &str) {
    eprintln!("warning: {message}");
}

/// A note or progress line (not with `-q`).
pub fn note(message: &str) {
    if enabled(Level::Normal) {
        eprintln!("{message}");
    }
}

/// A detail (`-v`).
pub fn detail(message: &str) {
    if enabled(Level::Verbose) {
        eprintln!("{message}");
    }
}

/// A diagnostic (`-vv`).
pub fn debug(message: &str) {
    if enabled(Level::Debug) {
        eprintln!("debug: {message}");
    }
}

/// Whether to draw progress bars: not with `-q`, and only on a terminal.
pub fn progress_bars() -> bool {
    enabled(Level::Normal) && std::io::stderr().is_terminal()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_map_to_levels() {
        assert_eq!(Level::from_flags(true, 0), Level::Quiet);
        assert_eq!(Level::from_flags(true, 2), Level::Quiet);
        assert_eq!(Level::from_flags(false, 0), Level::Normal);
        assert_eq!(Level::from_flags(false, 1), Level::Verbose);
        assert_eq!(Level::from_flags(false, 5), Level::Debug);
        assert!(Level::Quiet < Level::Normal && Level::Verbose < Level::Debug);
    }
}
