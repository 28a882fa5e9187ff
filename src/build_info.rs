//! The build's identity (`build.rs` computes it): the version, the commit
//! the tree was at, and a digest of the source. `embertrace --version`
//! prints it, and the farm's accumulation files record the digest so that
//! parts from builds whose code differs do not merge by accident
//! (`merge --allow-mixed-builds` and `render --allow-mixed-builds` for
//! those who know better).

/// The package version.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The commit the build's tree was at, `-dirty` if it had changes, or
/// `unknown` outside a git checkout.
pub const COMMIT: &str = env!("EMBERTRACE_COMMIT");

/// A 64-bit digest (hex) of every source file, `build.rs` and `Cargo.lock`:
/// builds that differ in any code that could change a pixel differ here.
pub const SOURCE_DIGEST: &str = env!("EMBERTRACE_SOURCE_DIGEST");

/// `--version`'s text: version, commit and source digest.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("EMBERTRACE_COMMIT"),
    ", source ",
    env!("EMBERTRACE_SOURCE_DIGEST"),
    ")"
);
