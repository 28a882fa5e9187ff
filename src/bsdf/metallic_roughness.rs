//! The glTF 2.0 metallic-roughness material, as the specification's
//! Appendix B defines its BRDF ("Appendix B: BRDF Implementation", glTF 2.0
//! specification, Khronos 2021), with the two extensions that change it
//! without adding lobes, `KHR_materials_specular` and `KHR_materials_ior`:
//!
//! ```text
//! f = metallic * metal + (1 - metallic) * dielectric
//! metal      = F_metal(c) * S
//! dielectric = (1 - w max(F_d(c))) * base_color / pi + w F_d(c) * S
//! F_metal(c) = base_color + (1 - base_color) (1 - c)^5      (Schlick)
//! F_d(c)     = f0 + (1 - f0) (1 - c)^5,  f0 = min(((ior - 1) / (ior + 1))^2 specular_color, 1)
//! S          = D(h) G1(wo) G1(wi) / (4 cos_o cos_i)          (GGX, alpha = roughness^2)
//! ```
//!
//! with `h` the half vector of `wo` and `wi`, `c = wo . h = wi . h`, `w`
//! the specular weight (`specularFactor`) and `G` Smith's separable
//! masking-shadowing, as the specification writes `V_GGX`. Every term is
//! symmetric in `wo` and `wi`, so the BRDF is reciprocal. It is a
//! single-scattering model: a white rough metal loses what GGX's single
//! scattering loses (the tests measure it against the conductor's
//! quadrature), and the dielectric's `1 - max(F)` weighting of the diffuse
//! term is the specification's approximation of a layer, not an energy
//! balance (a white dielectric of roughness 0.4 reflects 0.999 at normal
//! incidence but 1.135 seen at 80 degrees, `tests/metallic_roughness.rs`):
//! neither is compensated here, so that an image matches other renderers
//! of the specification's model. This is the bias of this file.
//!
//! With `roughness^2` below [`Microfacet::SMOOTH_ALPHA`] the specular lobe
//! is a delta in the mirror direction with weight `F(cos_o)`, the limit of
//! `S` times the Fresnel factor. The diffuse term keeps its half-vector
//! Fresnel weight in either case.
//!
//! Sampling chooses the specular lobe (visible GGX normals) with
//! probability proportional to an estimate of its reflectance at `wo`
//! (Schlick's Fresnel at `cos_o`), kept within `[0.1, 0.9]` while both
//! lobes reflect, otherwise a cosine-weighted direction; the pdf is the
//! mixture's, so [`Bxdf::pdf`] matches [`Bxdf::sample`].
//!
//! Scene form: `material = { type = "metallic_roughness", base_color =
//! [r, g, b], metallic = 0.0, roughness = 0.5 }`, optionally `ior = 1.5`,
//! `specular = 1.0` and `specular_color = [1, 1, 1]`.

use super::{
    BsdfSample, Bxdf, Distribution, Microfacet, check_unit_rgb, choose_lobe, fresnel::reflect,
    sample_at,
};
use crate::math::{Vec2, Vec3};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use std::f32::consts::FRAC_1_PI;

/// The glTF 2.0 metallic-roughness BRDF (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetallicRoughness {
    /// `baseColorFactor` (times its texture), linear, in `[0, 1]`.
    pub base_color: Vec3,
    /// `metallicFactor`, in `[0, 1]`.
    pub metallic: f32,
    /// `roughnessFactor` (perceptual: GGX `alpha` is its square), in `[0, 1]`.
    pub roughness: f32,
    /// `KHR_materials_specular`'s `specularFactor`, in `[0, 1]`.
    pub specular: f32,
    /// `KHR_materials_specular`'s `specularColorFactor`, finite and `>= 0`.
    pub specular_color: Vec3,
    /// `KHR_materials_ior`'s `ior`: `>= 1`, or 0 for an infinite index
    /// (`f0 = 1`).
    pub ior: f32,
}

impl Default for MetallicRoughness {
    /// The specification's defaults (a white rough metal).
    fn default() -> Self {
        MetallicRoughness {
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            specular: 1.0,
            specular_color: Vec3::ONE,
            ior: 1.5,
        }
    }
}

/// Schlick's `(1 - c)^5`.
#[inline]
fn schlick_weight(c: f32) -> f32 {
    (1.0 - c.clamp(0.0, 1.0)).powi(5)
}

impl MetallicRoughness {
    /// Checks the parameters, naming the scene keys.
    pub fn validate(&self) -> Result<(), String> {
        check_unit_rgb("base_color", self.base_color)?;
        for (key, v) in [
            ("metallic", self.metallic),
            ("roughness", self.roughness),
            ("specular", self.specular),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(format!("`{key}` must be a number in [0, 1], got {v}"));
            }
        }
        let c = self.specular_color;
        if !(c.is_finite() && c.min_element() >= 0.0) {
            return Err(format!(
                "`specular_color` must be three finite numbers >= 0, got [{}, {}, {}]",
                c.x, c.y, c.z
            ));
        }
        if !(self.ior == 0.0 || (self.ior >= 1.0 && self.ior.is_finite())) {
            return Err(format!(
                "`ior` must be a finite number >= 1, or 0 (an infinite index), got {}",
                self.ior
            ));
        }
        Ok(())
    }

    /// GGX `alpha`, the square of the perceptual roughness.
    pub fn alpha(&self) -> f32 {
        self.roughness * self.roughness
    }

    /// Whether the specular lobe is a delta (`alpha` below
    /// [`Microfacet::SMOOTH_ALPHA`]).
    pub fn is_smooth(&self) -> bool {
        !(self.alpha() >= Microfacet::SMOOTH_ALPHA)
    }

    fn microfacet(&self) -> Microfacet {
        Microfacet::new(Distribution::Ggx, self.alpha()).with_masking(super::Masking::Separable)
    }

    /// The dielectric's Fresnel reflectance at normal incidence.
    pub fn dielectric_f0(&self) -> Vec3 {
        let r = (self.ior - 1.0) / (self.ior + 1.0);
        (r * r * self.specular_color).min(Vec3::ONE)
    }

    /// The specular lobe's Fresnel factor at `c` (metal and dielectric
    /// mixed by `metallic`, the dielectric's weighted by `specular`) and
    /// the weight of the diffuse term, `(1 - metallic) (1 - w max F_d)`.
    #[inline]
    fn fresnel(&self, c: f32) -> (Vec3, f32) {
        let s5 = schlick_weight(c);
        let f0 = self.dielectric_f0();
        let fd = f0 + (Vec3::ONE - f0) * s5;
        let fm = self.base_color + (Vec3::ONE - self.base_color) * s5;
        let m = self.metallic;
        let spec = m * fm + ((1.0 - m) * self.specular) * fd;
        let diffuse = (1.0 - m) * (1.0 - self.specular * fd.max_element()).max(0.0);
        (spec, diffuse)
    }

    /// Probability of sampling the specular lobe from `wo`.
    fn lobe_probability(&self, wo: Vec3) -> f32 {
        let (spec, diffuse) = self.fresnel(wo.z);
        let s = spec.element_sum() / 3.0;
        let d = diffuse * self.base_color.element_sum() / 3.0;
        if !(d > 0.0) {
            1.0
        } else if !(s > 0.0) {
            0.0
        } else {
            (s / (s + d)).clamp(0.1, 0.9)
        }
    }
}

impl Bxdf for MetallicRoughness {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3::ZERO;
        }
        let sum = wo + wi;
        let len = sum.length();
        if !(len > 0.0) {
            return Vec3::ZERO;
        }
        // wo . h = wi . h = |wo + wi| / 2: symmetric bit for bit
        let (spec, diffuse) = self.fresnel(0.5 * len);
        let mut f = (diffuse * FRAC_1_PI) * self.base_color;
        if !self.is_smooth() && spec.max_element() > 0.0 {
            let m = self.microfacet();
            let d = m.d(sum / len);
            let s = d * (m.g1(wo) * m.g1(wi)) / (4.0 * (wo.z * wi.z));
            if s.is_finite() {
                f += spec * s;
            }
        }
        f
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let p = self.lobe_probability(wo);
        let mut pdf = (1.0 - p) * square_to_cosine_hemisphere_pdf(wi);
        if p > 0.0 && !self.is_smooth() {
            let sum = wo + wi;
            let len = sum.length();
            if len > 0.0 {
                let m = self.microfacet();
                let lobe = m.g1(wo) * m.d(sum / len) / (4.0 * wo.z);
                if lobe.is_finite() {
                    pdf += p * lobe;
                }
            }
        }
        pdf
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let p = self.lobe_probability(wo);
        let wi = match choose_lobe(u, p) {
            (true, _) if self.is_smooth() => {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let (spec, _) = self.fresnel(wo.z);
                return BsdfSample {
                    wi,
                    f: spec / wo.z,
                    pdf: p,
                    delta: true,
                }
                .checked();
            }
            (true, u) => reflect(wo, self.microfacet().sample_visible(wo, u)?),
            (false, u) => square_to_cosine_hemisphere(u),
        };
        sample_at(self, wo, wi)
    }

    fn is_delta(&self) -> bool {
        self.is_smooth() && self.metallic >= 1.0
    }

    fn has_delta_component(&self) -> bool {
        self.is_smooth()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_the_key() {
        assert_eq!(MetallicRoughness::default().validate(), Ok(()));
        let infinite = MetallicRoughness {
            ior: 0.0,
            ..Default::default()
        };
        assert_eq!(infinite.validate(), Ok(()));
        assert_eq!(infinite.dielectric_f0(), Vec3::ONE);
        let bad = [
            (
                MetallicRoughness {
                    base_color: Vec3::splat(1.1),
                    ..Default::default()
                },
                "`base_color`",
            ),
            (
                MetallicRoughness {
                    metallic: -0.1,
                    ..Default::default()
                },
                "`metallic`",
            ),
            (
                MetallicRoughness {
                    roughness: f32::NAN,
                    ..Default::default()
                },
                "`roughness`",
            ),
            (
                MetallicRoughness {
                    specular: 2.0,
                    ..Default::default()
                },
                "`specular`",
            ),
            (
                MetallicRoughness {
                    specular_color: Vec3::new(1.0, -1.0, 1.0),
                    ..Default::default()
                },
                "`specular_color`",
            ),
            (
                MetallicRoughness {
                    ior: 0.5,
                    ..Default::default()
                },
                "`ior`",
            ),
        ];
        for (b, key) in bad {
            let e = b.validate().unwrap_err();
            assert!(e.contains(key), "{e}");
        }
    }

    /// With `specular = 0` and `metallic = 0` the model is Lambertian, bit
    /// for bit: how a glTF file writes a diffuse surface.
    #[test]
    fn no_specular_is_lambertian() {
        let base = Vec3::new(0.8, 0.5, 0.2);
        let b = MetallicRoughness {
            base_color: base,
            metallic: 0.0,
            roughness: 0.3,
            specular: 0.0,
            ..Default::default()
        };
        let wo = Vec3::new(0.3, 0.2, 0.9).normalize();
        let wi = Vec3::new(-0.5, 0.1, 0.6).normalize();
        assert_eq!(b.eval(wo, wi), base * FRAC_1_PI);
        assert_eq!(b.pdf(wo, wi), square_to_cosine_hemisphere_pdf(wi));
    }

    /// The default dielectric's `f0` is 0.04 (`ior = 1.5`), the
    /// specification's constant.
    #[test]
    fn default_dielectric_f0_is_four_percent() {
        let f0 = MetallicRoughness::default().dielectric_f0();
        assert!((f0 - Vec3::splat(0.04)).abs().max_element() < 1e-7, "{f0}");
    }

    /// A smooth metal is a delta lobe whose weight is Schlick's Fresnel of
    /// the base colour at the angle of incidence.
    #[test]
    fn smooth_metal_is_a_schlick_mirror() {
        let base = Vec3::new(0.9, 0.6, 0.3);
        let b = MetallicRoughness {
            base_color: base,
            metallic: 1.0,
            roughness: 0.0,
            ..Default::default()
        };
        assert!(b.is_delta());
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let s = b.sample(wo, Vec2::new(0.5, 0.5)).unwrap();
        assert!(s.delta);
        assert_eq!(s.wi, Vec3::new(-0.6, 0.0, 0.8));
        let expected = base + (Vec3::ONE - base) * 0.2f32.powi(5);
        assert!((s.weight() - expected).abs().max_element() < 1e-6);
    }
}
