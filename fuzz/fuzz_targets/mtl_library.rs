//! Coverage-guided fuzzing of the scene loaders: `mesh.mtl` is the input,
//! `mesh.obj` is loaded. Run with `cargo +nightly fuzz run mtl_library` from the
//! repository root.
#![no_main]

#[path = "common.rs"]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| common::run(data, "mesh.mtl", "mesh.obj"));
