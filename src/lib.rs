//! embertrace: a physically based path tracer.
//!
//! Intel Embree (or the brute-force oracle) answers ray queries through the
//! [`accel::Accelerator`] trait; everything else (scene loading, camera,
//! sampling, BSDFs, lights, the estimator, the film and image files) is Rust.
#![deny(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

pub mod accel;
pub mod error;
pub mod math;

pub use error::{Error, Result};
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod bsdf;
pub mod camera;
pub mod integrator;
pub mod light;
pub mod render;
pub mod report;
pub mod film;
