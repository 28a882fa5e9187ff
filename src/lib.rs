//! embertrace: a physically based path tracer.
//!
//! Intel Embree (or the brute-force oracle) answers ray queries through the
//! [`accel::Accelerator`] trait; everything else (scene loading, camera,
//! sampling, BSDFs, lights, the estimator, the film and image files) is Rust.
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

pub use error::{Error, Result};
pub mod bsdf;
pub mod camera;
pub mod commands;
pub mod farm;
pub mod film;
pub mod image;
pub mod integrator;
pub mod light;
pub mod limits;
pub mod outputs;
pub mod plan;
pub mod progressive;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod shape;
pub mod texture;
