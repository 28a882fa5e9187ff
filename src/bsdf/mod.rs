//! BSDFs, evaluated in a local shading frame whose +z axis is the normal
//! turned towards `wo`. Conventions (as pbrt-v4's `BxDF`, chapter 9):
//!
//! - `wo` and `wi` both point away from the surface.
//! - `eval` returns `f(wo, wi)` **without** the cosine factor; estimators
//!   multiply by `|cos theta_i|` themselves.
//! - `sample` returns a [`BsdfSample`] whose `pdf` equals `pdf(wo, wi)` (solid
//!   angle) and whose `f` equals `eval(wo, wi)`; it returns `None` instead of a
//!   sample with zero pdf.

mod diffuse;
pub mod fresnel;
pub mod microfacet;

pub use diffuse::Diffuse;

use crate::math::Vec3;

/// A direction sampled from a BSDF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Sampled incident direction, local frame.
    pub wi: Vec3,
    /// `f(wo, wi)`, without the cosine.
    pub f: Vec3,
    /// Solid-angle density of `wi`; always `> 0`.
    pub pdf: f32,
}

impl BsdfSample {
    /// The Monte Carlo weight `f |cos| / pdf`.
    pub fn weight(&self) -> Vec3 {
        self.f * (self.wi.z.abs() / self.pdf)
    }
}
