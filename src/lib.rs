//! embertrace: a physically based path tracer.
//!
//! Ray queries go through the [`accel::Accelerator`] trait, answered by Intel
//! Embree, by the pure-Rust BVH, or by the brute-force oracle that checks
//! them ([`Backend`]); everything else (scene loading, camera, sampling,
//! BSDFs, lights, the estimator, the film and the image files) is Rust.
//!
//! # Rendering from Rust
//!
//! Load a scene ([`Scene::load`] reads every format the command line does),
//! choose a backend and settings on a [`Renderer`] (anything unset is the
//! scene's, as for a flag left off), render, and write the image:
//!
//! ```
//! use embertrace::{Backend, Renderer, Scene};
//! use std::path::Path;
//!
//! # fn main() -> embertrace::Result<()> {
//! let scene = Scene::load(Path::new("scenes/cornell-box.toml"))?;
//! let image = Renderer::new(&scene)
//!     .backend(Backend::Bvh)
//!     .resolution(32, 24)
//!     .spp(4)
//!     .render()?;
//! let out = std::env::temp_dir().join("embertrace-doctest.png");
//! image.write(&out)?;
//! // and read back, as linear RGB
//! let (w, h, rgb) = embertrace::image::read_png(&out)?;
//! assert_eq!((w, h, rgb.len()), (32, 24, 32 * 24 * 3));
//! assert!(image.pixels().iter().any(|p| p[0] > 0.0));
//! # Ok(())
//! # }
//! ```
//!
//! The map of the crate: [`scene`] loads files into a [`Scene`] (its
//! [`scene::SceneBuilder`] cleans and rebases geometry); [`accel`] builds a
//! backend over its triangles and spheres; [`integrator`] estimates the
//! radiance along each camera ray, with [`bsdf`], [`light`] and
//! [`sampler`], in the kernel [`plan`] picks for the scene's effects;
//! [`render`] runs it over tiles into a [`film::Film`]; [`image`] writes
//! and reads image files. [`commands`] holds the `embertrace` subcommands.
// `unsafe` lives in one place, the Embree module (`accel::embree`), which
// allows it for itself.
#![deny(unsafe_code)]
#![deny(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]
// `!(x > 0.0)` is the deliberate NaN-rejecting form throughout.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod error;
pub mod math;

pub use accel::Backend;
pub use error::{Error, Result};
pub use renderer::{PassProgress, Rendered, Renderer};
pub use scene::Scene;
pub mod bsdf;
pub mod build_info;
pub mod camera;
pub mod commands;
pub mod denoise;
pub mod farm;
pub mod film;
pub mod guiding;
pub mod hash;
pub mod image;
pub mod integrator;
pub mod light;
pub mod limits;
pub mod log;
pub mod memory;
pub mod outputs;
pub mod plan;
pub mod progressive;
pub mod render;
pub mod renderer;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod shape;
pub mod simd;
pub mod texture;
