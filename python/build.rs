//! The RPATH of the Python module: the main crate's `build.rs` records where
//! Embree 4 (`--features embree4`) and OIDN (`--features denoise`) live in
//! the RPATH of its own binaries only (`cargo:rustc-link-arg` reaches the
//! package that prints it), so this module, a cdylib of another package,
//! records them itself, from the same `EMBREE_DIR` and `OIDN_DIR`.

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    let dir = |var: &str| {
        env::var_os(var)
            .filter(|d| !d.is_empty())
            .map(PathBuf::from)
    };
    let mut rpath = Vec::new();
    if env::var_os("CARGO_FEATURE_EMBREE4").is_some() {
        if let Some(d) = dir("EMBREE_DIR") {
            let lib = ["lib", "lib64", ""]
                .iter()
                .map(|l| d.join(l))
                .find(|l| l.join("libembree4.so").exists());
            rpath.extend(lib);
        }
    }
    if env::var_os("CARGO_FEATURE_DENOISE").is_some() {
        rpath.extend(dir("OIDN_DIR").map(|d| d.join("lib")));
    }
    for d in rpath {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", d.display());
    }
}
