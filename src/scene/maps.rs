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
//! | `alpha` | conductor, plastic and rough glass `alpha` (a scalar: [`ImageTexture::eval_scalar`]) | `>= 0` (texels are finite and `>= 0` already); rough glass at least `Microfacet::SMOOTH_ALPHA` |
//! | `emission` | any | none (texels are finite and `>= 0`) |
//! | `metallic_roughness` | metallic-roughness (glTF's texture: green is the roughness, blue the metalness) | each to `[0, 1]` |
//!
//! A plastic's coat albedo table is integrated once per roughness (about
//! 15 ms), so a textured plastic roughness reads its coat from
//! [`PlasticCoats`], built at load over the texture's range.

use crate::bsdf::{Bsdf, PlasticCoats};
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
    /// A conductor's or plastic's roughness.
    pub alpha: Option<Arc<ImageTexture>>,
    /// A metallic-roughness material's roughness (green) and metalness
    /// (blue), read raw, glTF's packing, its factors multiplied in.
    pub metallic_roughness: Option<Arc<ImageTexture>>,
    /// A plastic's coats over its roughness texture's range (with `alpha`).
    pub plastic_coats: Option<Arc<PlasticCoats>>,
    /// Emitted radiance (then [`super::Material::emission`] is its mean).
    pub emission: Option<Arc<ImageTexture>>,
    /// A tangent-space normal map, read raw, with Mitsuba 3's encoding
    /// (`normalmap`): a texel `c` is the normal `2 c - 1` in the frame
    /// (tangent, bitangent, normal).
    pub normal: Option<Arc<ImageTexture>>,
    /// A bump map.
    pub bump: Option<BumpMap>,
    /// With a normal or bump map: where the viewer and the mapped normal
    /// lie on opposite sides of the unperturbed shading normal's plane
    /// (`(wo . n) (wo . m) <= 0`), the mapped normal `m` is mirrored about
    /// `n` (its tangential part negated), Mitsuba 3's
    /// `flip_invalid_normals` (Schüssler et al. 2017). Off, the smooth
    /// shading rule bends an invalid normal towards the viewer instead
    /// (`integrator::path`).
    pub flip_invalid: bool,
    /// With a normal or bump map: light arriving at `wi` is attenuated by
    /// Mitsuba 3's `use_shadowing_function` term (Conty Estevez et al. 2019,
    /// "A Microfacet-Based Shadowing Function to Solve the Bump Terminator
    /// Problem", Ray Tracing Gems): `G = 2 / (1 + sqrt(1 + a2 tan^2 wi))`,
    /// `a2 = min(tan^2(m) / 8, 1)`, both angles from the unperturbed shading
    /// normal. It scales the BSDF's value and its samples' weights, not
    /// their densities: a named, deliberate loss of energy at grazing light.
    pub shadowing: bool,
}

/// The term of [`Maps::shadowing`] for light from `wi`, with `a2` from
/// [`shadowing_alpha2`]; `n` the unperturbed shading normal (either side).
#[inline]
pub fn shadowing_g(n: Vec3, a2: f32, wi: Vec3) -> f32 {
    let c2 = n.dot(wi).powi(2);
    if !(c2 > 0.0) {
        return 0.0;
    }
    let tan2 = (1.0 - c2).max(0.0) / c2;
    2.0 / (1.0 + (1.0 + a2 * tan2).sqrt())
}

/// `a2` of [`shadowing_g`]: the squared roughness that the mapped normal
/// `m`'s tilt from `n` implies, `min(tan^2 / 8, 1)`.
#[inline]
pub fn shadowing_alpha2(n: Vec3, m: Vec3) -> f32 {
    let c2 = n.dot(m).powi(2);
    if !(c2 > 0.0) {
        return 1.0;
    }
    (0.125 * (1.0 - c2).max(0.0) / c2).min(1.0)
}

impl Maps {
    /// Whether some texture replaces a parameter of the BSDF.
    #[inline]
    pub fn textures_bsdf(&self) -> bool {
        self.specular.is_some()
            || self.transmittance.is_some()
            || self.alpha.is_some()
            || self.metallic_roughness.is_some()
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
                Bsdf::ThinGlass(g) => g.reflectance = c,
                Bsdf::RoughGlass(g) => g.reflectance = c,
                Bsdf::Phong(p) => p.specular = c,
                _ => {}
            }
        }
        match (&self.transmittance, &mut *bsdf) {
            (Some(t), Bsdf::Glass(g)) => g.transmittance = unit(t),
            (Some(t), Bsdf::ThinGlass(g)) => g.transmittance = unit(t),
            (Some(t), Bsdf::RoughGlass(g)) => g.transmittance = unit(t),
            _ => {}
        }
        if let (Some(t), Bsdf::Conductor(c)) = (&self.alpha, &mut *bsdf) {
            let alpha = t.eval_scalar(uv).max(0.0);
            c.microfacet = c.microfacet.with_alpha(alpha);
        }
        if let (Some(t), Bsdf::MetallicRoughness(m)) = (&self.metallic_roughness, &mut *bsdf) {
            let c = unit(t);
            m.roughness = c.y;
            m.metallic = c.z;
        }
        if let (Some(t), Bsdf::RoughGlass(g)) = (&self.alpha, &mut *bsdf) {
            g.alpha = t.eval_scalar(uv).max(crate::bsdf::Microfacet::SMOOTH_ALPHA);
        }
        if let (Some(t), Some(coats), Bsdf::Plastic(p)) =
            (&self.alpha, &self.plastic_coats, &mut *bsdf)
        {
            *p = coats.at(t.eval_scalar(uv).max(0.0), p.diffuse());
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

/// Per triangle, `[dp/du, dp/dv]` from its corners' positions and UVs, for
/// the triangles whose material has a normal or bump map (zeros for the
/// others); empty when no used material has one, so a scene without maps
/// stores nothing.
///
/// With `e1 = p1 - p0`, `e2 = p2 - p0` and UV differences `(du1, dv1)`,
/// `(du2, dv2)`, the linear map from UV to position has
/// `dp/du = (dv2 e1 - dv1 e2) / det` and `dp/dv = (du1 e2 - du2 e1) / det`
/// with `det = du1 dv2 - dv1 du2` (pbrt-v4 section 6.5.3, the same per-face
/// tangents MikkTSpace starts from). A triangle whose UVs are degenerate
/// (`det` zero or not finite) keeps zeros, and shading builds its frame from
/// the normal alone. The frames are per triangle, not averaged per vertex:
/// along an edge where two triangles' UV mappings differ, a normal map's
/// frame changes there. Gram-Schmidt against the shading normal happens per
/// hit (the normal varies over a smooth triangle).
pub(super) fn uv_derivatives(scene: &super::Scene) -> Vec<[Vec3; 2]> {
    let needs: Vec<bool> = scene
        .materials
        .iter()
        .map(|m| m.maps.perturbs_normal())
        .collect();
    let any = scene.tri_material.iter().any(|&m| needs[m as usize]);
    if !any || scene.tri_uv.is_empty() {
        return Vec::new();
    }
    (0..scene.triangle_count())
        .map(|t| {
            if !needs[scene.tri_material[t] as usize] {
                return [Vec3::ZERO; 2];
            }
            triangle_uv_derivatives(scene.triangle(t as u32), scene.tri_uv[t])
        })
        .collect()
}

/// `[dp/du, dp/dv]` of the triangle with corners `p` and texture coordinates
/// `uv` (zeros where the UVs are degenerate).
pub(super) fn triangle_uv_derivatives(p: [Vec3; 3], uv: [crate::math::Vec2; 3]) -> [Vec3; 2] {
    let [p0, p1, p2] = p;
    let [t0, t1, t2] = uv;
    let (e1, e2) = (p1 - p0, p2 - p0);
    let (d1, d2) = (t1 - t0, t2 - t0);
    let det = d1.x * d2.y - d1.y * d2.x;
    let dpdu = (d2.y * e1 - d1.y * e2) / det;
    let dpdv = (d1.x * e2 - d2.x * e1) / det;
    if det == 0.0 || !dpdu.is_finite() || !dpdv.is_finite() {
        [Vec3::ZERO; 2]
    } else {
        [dpdu, dpdv]
    }
}

/// `[dp/du, dp/dv]` on a sphere of radius `r` at outward normal `n`, for
/// [`super::Scene::uv`]'s mapping `u = phi / 2 pi` with
/// `phi = atan2(-n.z, n.x)` and `v = 1 - theta / pi` with
/// `theta = acos(n.y)`; `None` at the poles, where `dp/du` vanishes.
pub(super) fn sphere_uv_derivatives(r: f32, n: Vec3) -> Option<[Vec3; 2]> {
    use std::f32::consts::{PI, TAU};
    // n = (cos phi sin theta, cos theta, -sin phi sin theta)
    let sin_theta = (n.x * n.x + n.z * n.z).sqrt();
    if !(sin_theta > 1e-6) {
        return None;
    }
    let (cos_phi, sin_phi) = (n.x / sin_theta, -n.z / sin_theta);
    let cos_theta = n.y;
    let dpdphi = r * Vec3::new(-sin_phi * sin_theta, 0.0, -cos_phi * sin_theta);
    let dpdtheta = r * Vec3::new(cos_phi * cos_theta, -sin_theta, -sin_phi * cos_theta);
    Some([TAU * dpdphi, -PI * dpdtheta])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_derivatives_follow_the_uv_mapping() {
        // finite differences of the mapping's inverse at a few points
        let r = 2.0;
        let point = |u: f32, v: f32| {
            let phi = u * std::f32::consts::TAU;
            let theta = (1.0 - v) * std::f32::consts::PI;
            r * Vec3::new(
                phi.cos() * theta.sin(),
                theta.cos(),
                -phi.sin() * theta.sin(),
            )
        };
        for (u, v) in [(0.1, 0.3), (0.6, 0.7), (0.9, 0.55)] {
            let n = point(u, v) / r;
            let [du, dv] = sphere_uv_derivatives(r, n).unwrap();
            let h = 1e-3;
            let fu = (point(u + h, v) - point(u - h, v)) / (2.0 * h);
            let fv = (point(u, v + h) - point(u, v - h)) / (2.0 * h);
            assert!((du - fu).length() < 1e-2 * fu.length(), "{du} {fu}");
            assert!((dv - fv).length() < 1e-2 * fv.length(), "{dv} {fv}");
        }
        assert_eq!(sphere_uv_derivatives(1.0, Vec3::Y), None);
    }
}
