//! Coverage-guided fuzzing of the scene loaders: `scene.toml` is the input,
//! `scene.toml` is loaded. Run with `cargo +nightly fuzz run toml_scene` from the
//! repository root.
#![no_main]

#[path = "common.rs"]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| common::run(data, "scene.toml", "scene.toml"));
