//! Textures on a material's parameters other than the diffuse albedo (which
//! is [`super::Material::texture`]), and its normal or bump map.
//!
//! A textured parameter replaces the constant that [`super::Material::bsdf`]
//! (or [`super::Material::emission`]) holds: the constant stays as the
//! value the untextured code paths read (the plan, the diffuse-only kernels'
//! albedo table; for emission, the texture's mean, so that the light's power
//! is right), and [`Maps::apply`] writes the texture's value at the shading
//! point's UV into a copy of the BSDF. Each value is clamped into the range
//! [`crate::bsdf::Bsdf::validate`] accepts, so a texture can never make a
//! BSDF that a scene file could not:
//!
//! | parameter | BSDFs | clamp |
//! |---|---|---|
//! | `specular` | mirror and glass `reflectance`, phong `specular` | each channel to `[0, 1]` |
//! | `transmittance` | glass `transmittance` | each channel to `[0, 1]` |
//! | `alpha` | conductor `alpha` (a scalar: [`ImageTexture::eval_scalar`]) | `>= 0` (texels are finite and `>= 0` already) |
//! | `emission` | any | none (texels are finite and `>= 0`) |
//!
//! A plastic's `alpha` cannot be textured: its coat's albedo table is
//! integrated once per roughness (about 15 ms), so loaders refuse it.

use crate::bsdf::{Bsdf, Microfacet};
use crate::math::{Vec2, Vec3};
use crate::texture::ImageTexture;
use std::sync::Arc;

/// A bump map: a height texture (read raw) and the scale its values are
/// multiplied by (Mitsuba 3's `bumpmap`).
#[derive(Debug, Clone, PartialEq)]
pub struct BumpMap {
    /// Heights (a scalar texture, [`ImageTexture::eval_scalar`]).
    pub texture: Arc<ImageTexture>,
    /// Multiplies the heights.
    pub scale: f32,
}

/// A material's textured parameters and its normal or bump map (each
/// texture shared by every material that names its file with the same
/// decoding).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Maps {
    /// Specular reflectance: a mirror's or glass's `reflectance`, a phong
    /// material's `specular`.
    pub specular: Option<Arc<ImageTexture>>,
    /// A glass's `transmittance`.
    pub transmittance: Option<Arc<ImageTexture>>,
    /// A conductor's roughness.
    pub alpha: Option<Arc<ImageTexture>>,
    /// Emitted radiance (then [`super::Material::emission`] is its mean).
    pub emission: Option<Arc<ImageTexture>>,
    /// A tangent-space normal map, read raw, with Mitsuba 3's encoding
    /// (`normalmap`): a texel `c` is the normal `2 c - 1` in the frame
    /// (tangent, bitangent, normal).
    pub normal: Option<Arc<ImageTexture>>,
    /// A bump map.
    pub bump: Option<BumpMap>,
}

impl Maps {
    /// Whether some texture replaces a parameter of the BSDF.
    #[inline]
    pub fn textures_bsdf(&self) -> bool {
        self.specular.is_some() || self.transmittance.is_some() || self.alpha.is_some()
    }

    /// Whether the material perturbs its shading normal (a normal or bump
    /// map), so its meshes need tangent frames.
    #[inline]
    pub fn perturbs_normal(&self) -> bool {
        self.normal.is_some() || self.bump.is_some()
    }

    /// Write the textured parameters' values at `uv` into `bsdf` (clamped as
    /// the module docs say). A texture on a parameter the BSDF lacks (which
    /// the loaders refuse) is ignored.
    #[inline]
    pub fn apply(&self, bsdf: &mut Bsdf, uv: Vec2) {
        let unit = |t: &ImageTexture| t.eval(uv).clamp(Vec3::ZERO, Vec3::ONE);
        if let Some(t) = &self.specular {
            let c = unit(t);
            match bsdf {
                Bsdf::Mirror(m) => m.reflectance = c,
                Bsdf::Glass(g) => g.reflectance = c,
                Bsdf::Phong(p) => p.specular = c,
                _ => {}
            }
        }
        if let (Some(t), Bsdf::Glass(g)) = (&self.transmittance, &mut *bsdf) {
            g.transmittance = unit(t);
        }
        if let (Some(t), Bsdf::Conductor(c)) = (&self.alpha, &mut *bsdf) {
            let alpha = t.eval_scalar(uv).max(0.0);
            c.microfacet = Microfacet::new(c.microfacet.distribution, alpha);
        }
    }

    /// The name of the specular key for `bsdf` as scene files spell it.
    pub fn specular_key(bsdf: &Bsdf) -> &'static str {
        match bsdf {
            Bsdf::Phong(_) => "specular",
            _ => "reflectance",
        }
    }
}
