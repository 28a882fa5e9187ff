//! Coverage-guided fuzzing of the scene loaders: `mesh.obj` is the input,
//! `mesh.obj` is loaded. Run with `cargo +nightly fuzz run obj_mesh` from the
//! repository root.
#![no_main]

#[path = "common.rs"]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| common::run(data, "mesh.obj", "mesh.obj"));
