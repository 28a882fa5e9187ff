//! A rough dielectric boundary: GGX microfacet reflection and refraction
//! (Walter, Marschner, Li and Torrance 2007, "Microfacet Models for
//! Refraction through Rough Surfaces"; pbrt-v4's `DielectricBxDF`, rough
//! case, section 9.7). With `wm` the generalised half vector,
//! `wm = normalize(eta' wi + wo)` turned to `+z`, `eta' = ior` when `wo` is
//! outside and `1 / ior` inside (1 for reflection), and `F` the exact
//! Fresnel reflectance at `wo . wm`:
//!
//! ```text
//! reflection:   f = R D(wm) G(wo, wi) F / |4 cos_i cos_o|
//! transmission: f = T D(wm) G(wo, wi) (1 - F) |wi.wm wo.wm| / (|cos_i cos_o| (wi.wm + wo.wm / eta')^2 eta'^2)
//! ```
//!
//! `G` height-correlated; the last `1 / eta'^2` carries radiance across the
//! interface as [`super::Glass`] explains. Microfacets that face away from
//! either direction contribute nothing.
//!
//! **Frame** as [`super::Glass`]: `+z` is the outward normal, `wo.z < 0`
//! inside.
//!
//! **Sampling** has two uniform numbers (the crate's BSDF interface), not
//! the three pbrt-v4 uses to choose the lobe by `F(wo . wm)` after drawing
//! `wm`. The first chooses the lobe before `wm` is drawn, reflection with
//! probability `P_r` = the smooth surface's Fresnel reflectance at `wo`
//! kept within `[0.05, 0.95]` (so that a lobe is never starved: under total
//! internal reflection of the macro surface, some microfacets still
//! refract), and is rescaled to draw `wm` from the visible normals with the
//! second. A transmission whose `wm` reflects totally returns `None`. The
//! density is `P_r` times the reflection lobe's plus `1 - P_r` times the
//! transmission lobe's, the same in [`Bxdf::pdf`], so sampling is unbiased;
//! its variance is somewhat higher than pbrt-v4's where `F(wo . wm)` strays
//! far from `F(cos_o)`.
//!
//! Below [`Microfacet::SMOOTH_ALPHA`] the boundary is the smooth
//! [`super::Glass`] (loaders choose it), so this type always has a rough
//! lobe.
//!
//! Scene form: `material = { type = "rough_glass", ior = 1.5, alpha = 0.1,
//! reflectance = [1, 1, 1], transmittance = [1, 1, 1] }`.

use super::fresnel::fr_dielectric;
use super::{BsdfSample, Bxdf, Distribution, Glass, Microfacet, choose_lobe};
use crate::math::{Vec2, Vec3};

/// A rough dielectric boundary (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughGlass {
    /// Index of refraction inside relative to outside; finite and `> 0`.
    pub ior: f32,
    /// GGX roughness, at least [`Microfacet::SMOOTH_ALPHA`].
    pub alpha: f32,
    /// Scale on the reflected lobe, per channel, in `[0, 1]`.
    pub reflectance: Vec3,
    /// Scale on the refracted lobe, per channel, in `[0, 1]`.
    pub transmittance: Vec3,
}

impl Default for RoughGlass {
    fn default() -> Self {
        RoughGlass {
            ior: 1.5,
            alpha: 0.1,
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
        }
    }
}

/// The generalised half vector of `wo` and `wi` turned to `+z`, `eta'`, and
/// whether the pair reflects; `None` where it is undefined or a microfacet
/// would face away from either direction.
fn half_vector(wo: Vec3, wi: Vec3, ior: f32) -> Option<(Vec3, f32, bool)> {
    let (co, ci) = (wo.z, wi.z);
    if co == 0.0 || ci == 0.0 {
        return None;
    }
    let reflect = co * ci > 0.0;
    let etap = if reflect {
        1.0
    } else if co > 0.0 {
        ior
    } else {
        1.0 / ior
    };
    let m = wi * etap + wo;
    let len2 = m.length_squared();
    if !(len2 > 0.0) || !len2.is_finite() {
        return None;
    }
    let mut wm = m / len2.sqrt();
    if wm.z < 0.0 {
        wm = -wm;
    }
    if wm.dot(wi) * ci < 0.0 || wm.dot(wo) * co < 0.0 {
        return None;
    }
    Some((wm, etap, reflect))
}

impl RoughGlass {
    /// Checks the index and scales as [`Glass::validate`] does, and the
    /// roughness.
    pub fn validate(&self) -> Result<(), String> {
        Glass {
            ior: self.ior,
            reflectance: self.reflectance,
            transmittance: self.transmittance,
        }
        .validate()?;
        if !(self.alpha >= Microfacet::SMOOTH_ALPHA && self.alpha.is_finite()) {
            return Err(format!(
                "`alpha` must be a finite number >= {} (a smoother surface is `glass`), got {}",
                Microfacet::SMOOTH_ALPHA,
                self.alpha
            ));
        }
        Ok(())
    }

    fn microfacet(&self) -> Microfacet {
        Microfacet::new(Distribution::Ggx, self.alpha)
    }

    /// The probability of choosing the reflection lobe from `wo`.
    pub fn reflect_probability(&self, wo: Vec3) -> f32 {
        fr_dielectric(wo.z, self.ior).clamp(0.05, 0.95)
    }

    /// Density of visible normals `wm` seen from `w` (either side).
    fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let m = self.microfacet();
        m.g1(w) * w.dot(wm).abs() * m.d(wm) / w.z.abs()
    }
}

impl Bxdf for RoughGlass {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wm, etap, reflect)) = half_vector(wo, wi, self.ior) else {
            return Vec3::ZERO;
        };
        let m = self.microfacet();
        let f = fr_dielectric(wo.dot(wm), self.ior);
        let dg = m.d(wm) * m.g(wo, wi);
        let v = if reflect {
            self.reflectance * (dg * f / (4.0 * wi.z * wo.z).abs())
        } else {
            let (ci, co) = (wi.dot(wm), wo.dot(wm));
            let denom = (ci + co / etap).powi(2) * wi.z * wo.z;
            self.transmittance * (dg * (1.0 - f) * (ci * co / denom).abs() / (etap * etap))
        };
        if v.is_finite() { v } else { Vec3::ZERO }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wm, etap, reflect)) = half_vector(wo, wi, self.ior) else {
            return 0.0;
        };
        let pr = self.reflect_probability(wo);
        let dv = self.d_visible(wo, wm);
        let p = if reflect {
            pr * dv / (4.0 * wo.dot(wm).abs())
        } else {
            let (ci, co) = (wi.dot(wm), wo.dot(wm));
            (1.0 - pr) * dv * ci.abs() / (ci + co / etap).powi(2)
        };
        if p.is_finite() { p } else { 0.0 }
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z != 0.0) || !wo.is_finite() {
            return None;
        }
        let (reflect, u) = choose_lobe(u, self.reflect_probability(wo));
        // visible normals of the side wo is on, turned to +z
        let up = if wo.z > 0.0 { wo } else { -wo };
        let wm = self.microfacet().sample_visible(up, u)?;
        let wi = if reflect {
            super::fresnel::reflect(wo, wm)
        } else {
            // refract through wm (the side of wo decides the relative
            // index); None under total internal reflection
            super::fresnel::refract(wo, wm, self.ior)?.wt
        };
        if (wi.z * wo.z > 0.0) != reflect {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
            delta: false,
        }
        .checked()
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn has_delta_component(&self) -> bool {
        false
    }

    fn has_transmission(&self) -> bool {
        true
    }

    fn eta(&self) -> f32 {
        self.ior
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A refracted sample's direction obeys Snell's law about its `wm`.
    #[test]
    fn refraction_follows_snell_about_the_microfacet() {
        let g = RoughGlass::default();
        let wo = Vec3::new(0.5, 0.1, 0.86).normalize();
        let mut seen = 0;
        for i in 0..200 {
            let u = Vec2::new(0.97, (i as f32 + 0.5) / 200.0);
            let Some(s) = g.sample(wo, u) else { continue };
            assert!(s.wi.z < 0.0, "transmission chosen: {}", s.wi);
            let (wm, etap, reflect) = half_vector(wo, s.wi, g.ior).unwrap();
            assert!(!reflect && etap == 1.5);
            let sin_o = wo.cross(wm).length();
            let sin_i = s.wi.cross(wm).length();
            assert!(
                (sin_o - 1.5 * sin_i).abs() < 1e-4,
                "{sin_o} vs {}",
                1.5 * sin_i
            );
            seen += 1;
        }
        assert!(seen > 150);
        let bad = RoughGlass {
            alpha: 0.0,
            ..Default::default()
        };
        assert!(bad.validate().unwrap_err().contains("`alpha`"));
    }
}
