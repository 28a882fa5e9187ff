//! Alpha masks: cut-out surfaces, decided stochastically per ray.
//!
//! A material may carry an [`AlphaMask`]: a constant opacity in `[0, 1]` or
//! a scalar texture looked up at the hit's texture coordinates. A ray that
//! meets a masked triangle with opacity `a` at the hit takes the hit with
//! probability `a` and otherwise passes through it as if nothing were
//! there, inside the traversal (the backend goes on to the next candidate;
//! no new ray is spawned). Averaged over rays this is the mix Mitsuba 3's
//! `mask` BSDF makes of its nested BSDF (weight `a`) and a null interaction
//! (weight `1 - a`), and pbrt-v4's stochastic alpha test; it is unbiased,
//! and shadow rays see through the holes the same way.
//!
//! The decision is exact for opacities 0 and 1 and otherwise compares `a`
//! with a uniform number hashed from the ray's origin and direction bits
//! and the primitive id ([`threshold`]): no state, so every backend, thread
//! count and traversal order decides the same way, and the same ray meeting
//! two masked layers decides for each independently (pbrt-v4 hashes the ray
//! alone, which makes two stacked layers of opacity 1/2 pass together half
//! the time instead of a quarter). The one input the backends compute
//! differently is the barycentric position a texture is read at (see
//! [`crate::accel::AlphaTest`]).
//!
//! Limits (refused by the loaders, so they never reach a render): a mask on
//! an emitting material (light sampling would then see emitters that
//! camera and BSDF rays may pass through: the two strategies would estimate
//! different lights) and on a sphere.

use super::Scene;
use crate::accel::AlphaTest;
use crate::math::{Ray, Vec2};
use crate::texture::ImageTexture;
use std::sync::Arc;

/// A material's opacity.
#[derive(Debug, Clone, PartialEq)]
pub enum AlphaMask {
    /// The same opacity everywhere, in `[0, 1]`.
    Constant(f32),
    /// A scalar texture ([`ImageTexture::eval_scalar`]), clamped to `[0, 1]`.
    Texture(Arc<ImageTexture>),
}

impl AlphaMask {
    /// The opacity at texture coordinates `uv`.
    #[inline]
    pub fn opacity(&self, uv: Vec2) -> f32 {
        match self {
            AlphaMask::Constant(a) => *a,
            AlphaMask::Texture(t) => t.eval_scalar(uv).clamp(0.0, 1.0),
        }
    }

    /// Whether the mask reads texture coordinates.
    pub fn is_textured(&self) -> bool {
        matches!(self, AlphaMask::Texture(_))
    }
}

/// The uniform number in `[0, 1)` that ray `ray` compares with the opacity
/// of primitive `prim`: a hash of the bits of its origin and direction and
/// of `prim` (SplitMix64's finaliser, chained), its top 24 bits scaled.
#[inline]
fn threshold(ray: &Ray, prim: u32) -> f32 {
    use crate::sampler::mix64;
    let bits = |a: f32, b: f32| (a.to_bits() as u64) << 32 | b.to_bits() as u64;
    let mut h = mix64(bits(ray.o.x, ray.o.y) ^ (prim as u64) << 7);
    h = mix64(h ^ bits(ray.o.z, ray.d.x));
    h = mix64(h ^ bits(ray.d.y, ray.d.z));
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

impl Scene {
    /// The scene's alpha masks as the backends ask them, when some material
    /// has one (`None`: every surface is opaque, and queries take the plain,
    /// unfiltered path).
    pub fn alpha_test(&self) -> Option<&dyn AlphaTest> {
        self.materials
            .iter()
            .any(|m| m.alpha_mask.is_some())
            .then_some(self as &dyn AlphaTest)
    }
}

impl AlphaTest for Scene {
    #[inline]
    fn ignores(&self, ray: &Ray, prim: u32, u: f32, v: f32) -> bool {
        let Some(mask) = &self.materials[self.material_index(prim) as usize].alpha_mask else {
            return false;
        };
        // a constant needs no texture coordinates
        let uv = if mask.is_textured() {
            let corners = match self.instanced(prim) {
                Some((k, t)) => self.instances.uv(k, t),
                None => self.tri_uv.get(prim as usize).copied(),
            };
            let Some(c) = corners else {
                return false;
            };
            (1.0 - u - v) * c[0] + u * c[1] + v * c[2]
        } else {
            Vec2::ZERO
        };
        let a = mask.opacity(uv);
        // exact at 0 and 1: the threshold is below 1, and `>=` passes 0
        threshold(ray, prim) >= a
    }
}
