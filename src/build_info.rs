//! The build's identity (`build.rs` computes it): the version, the commit
//! the tree was at, and a digest of the source. `embertrace --version`
//! prints it, and the farm's accumulation files record the digest so that
//! parts from builds whose code differs do not merge by accident
//! (`merge --allow-mixed-builds` and `render --allow-mixed-builds` for
//! those who know better).

/// The ray backends compiled in, for `--version`.
#[cfg(feature = "embree4")]
macro_rules! ray_backends {
    () => {
        "Embree 4 (embree4 feature, embree4-sys) and the pure-Rust BVH"
    };
}
#[cfg(all(feature = "embree", not(feature = "embree4")))]
macro_rules! ray_backends {
    () => {
        "Embree 3 (embree feature, bindgen) and the pure-Rust BVH"
    };
}
#[cfg(not(any(feature = "embree", feature = "embree4")))]
macro_rules! ray_backends {
    () => {
        "the pure-Rust BVH (built without Embree)"
    };
}

/// The package version.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The commit the build's tree was at, `-dirty` if it had changes, or
/// `unknown` outside a git checkout.
pub const COMMIT: &str = env!("EMBERTRACE_COMMIT");

/// A 64-bit digest (hex) of every source file, `build.rs` and `Cargo.lock`:
/// builds that differ in any code that could change a pixel differ here.
pub const SOURCE_DIGEST: &str = env!("EMBERTRACE_SOURCE_DIGEST");

/// The cargo features the build was made with, comma-separated
/// (`embree`, `embree4`, or empty for the BVH alone).
pub const FEATURES: &str = env!("EMBERTRACE_FEATURES");

/// `--version`'s text: version, commit, source digest and ray backends.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("EMBERTRACE_COMMIT"),
    ", source ",
    env!("EMBERTRACE_SOURCE_DIGEST"),
    ")\nray queries: ",
    ray_backends!(),
);
