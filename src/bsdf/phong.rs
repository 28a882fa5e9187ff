//! The CSE 168 course material: a Lambertian term plus a specular lobe,
//! `f = kd / pi + f_s`, where the lobe is one of the course's two `brdf`
//! choices (UCSD CSE 168, assignments 3 and 4):
//!
//! - **`phong`**, the modified (energy-normalised) Phong lobe of Lafortune
//!   and Willems 1994, "Using the modified Phong reflectance model for
//!   physically based rendering": `f_s = ks (s + 2) / (2 pi) max(0, r . wi)^s`
//!   with `r` the mirror reflection of `wo` and `s` the shininess. Its
//!   cosine-weighted integral is at most `ks`, so `kd + ks <= 1` conserves
//!   energy.
//! - **`ggx`**: `f_s = F(wi . h) D(h) G1(wo) G1(wi) / (4 cos_o cos_i)` with the
//!   GGX `D` of roughness `alpha`, Smith's separable masking-shadowing (the
//!   course's, not the height-correlated one the conductors use) and
//!   Schlick's Fresnel with `F0 = ks`, `F = ks + (1 - ks) (1 - wi . h)^5`.
//!
//! The old raytracer's Blinn-Phong highlight (CSE 167) has no normalisation
//! and no counterpart here: a `.test` scene renders with this material
//! whichever integrator it names (see the README).
//!
//! Sampling follows the course: the lobe is chosen with probability
//! `t = avg(ks) / (avg(kd) + avg(ks))` (at least 1/4 for `ggx`, whose
//! Fresnel term grows at grazing angles even when `ks` is small), otherwise
//! a cosine-weighted direction. The Phong lobe samples `cos(alpha) =
//! u^(1 / (s + 1))` around `r`; the GGX lobe samples visible normals
//! (lower variance than the course's `D cos` sampling, same image). The
//! returned pdf is the mixture's, so [`Bxdf::pdf`] matches [`Bxdf::sample`].
//!
//! Scene form: `material = { type = "phong", diffuse = [r, g, b], specular
//! = [r, g, b], shininess = 30 }` or, for the GGX lobe, `roughness = 0.2`
//! in place of `shininess`.

use super::{BsdfSample, Bxdf, Microfacet, choose_lobe, fresnel::reflect, sample_at};
use crate::math::{Frame, Vec2, Vec3};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use std::f32::consts::{FRAC_1_PI, PI};

/// The specular lobe of a [`Phong`] material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lobe {
    /// The normalised Phong lobe with this exponent (`shininess`), `>= 0`.
    Phong {
        /// The exponent `s`.
        shininess: f32,
    },
    /// The GGX microfacet lobe with Schlick's Fresnel, of this roughness
    /// (at least [`Microfacet::SMOOTH_ALPHA`]).
    Ggx {
        /// GGX `alpha`.
        roughness: f32,
    },
}

/// Diffuse plus a Phong or GGX specular lobe (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phong {
    /// `kd`, in `[0, 1]` per channel.
    pub diffuse: Vec3,
    /// `ks`, in `[0, 1]` per channel.
    pub specular: Vec3,
    /// The specular lobe.
    pub lobe: Lobe,
}

impl Default for Phong {
    fn default() -> Self {
        Phong {
            diffuse: Vec3::splat(0.5),
            specular: Vec3::ZERO,
            lobe: Lobe::Phong { shininess: 1.0 },
        }
    }
}

impl Phong {
    /// The largest shininess accepted: beyond it `cos^s` is a delta lobe to
    /// `f32` (`(1 - 2^-24)^s` underflows the lobe's first ulp of angle).
    pub const MAX_SHININESS: f32 = 1e6;

    /// Checks the parameters, naming the scene keys.
    pub fn validate(&self) -> Result<(), String> {
        super::check_unit_rgb("diffuse", self.diffuse)?;
        super::check_unit_rgb("specular", self.specular)?;
        match self.lobe {
            Lobe::Phong { shininess } => {
                if !(0.0..=Self::MAX_SHININESS).contains(&shininess) {
                    return Err(format!(
                        "shininess = {shininess} out of range (0..={:e})",
                        Self::MAX_SHININESS
                    ));
                }
            }
            Lobe::Ggx { roughness } => {
                if !(Microfacet::SMOOTH_ALPHA..=1.0).contains(&roughness) {
                    return Err(format!(
                        "roughness = {roughness} out of range ({}..=1)",
                        Microfacet::SMOOTH_ALPHA
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether `kd + ks` exceeds 1 in some channel, so the material can
    /// reflect more than it receives (legal in the course's files; loaders
    /// warn).
    pub fn gains_energy(&self) -> bool {
        (self.diffuse + self.specular).max_element() > 1.0
    }

    /// Probability of sampling the specular lobe.
    fn lobe_probability(&self) -> f32 {
        let kd = self.diffuse.element_sum() / 3.0;
        let ks = self.specular.element_sum() / 3.0;
        match self.lobe {
            Lobe::Phong { .. } => {
                if ks + kd > 0.0 {
                    ks / (ks + kd)
                } else {
                    0.0
                }
            }
            Lobe::Ggx { .. } => {
                if kd > 0.0 {
                    (ks / (ks + kd)).max(0.25)
                } else {
                    1.0
                }
            }
        }
    }

    /// The specular lobe's value (without the cosine) and the density with
    /// which it samples `wi`, for `wo.z > 0` and `wi.z > 0`.
    fn lobe(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match self.lobe {
            Lobe::Phong { shininess: s } => {
                let r = Vec3::new(-wo.x, -wo.y, wo.z);
                let c = r.dot(wi).min(1.0);
                if !(c > 0.0) {
                    return (Vec3::ZERO, 0.0);
                }
                let p = c.powf(s);
                let f = self.specular * ((s + 2.0) / (2.0 * PI) * p);
                (f, (s + 1.0) / (2.0 * PI) * p)
            }
            Lobe::Ggx { roughness } => {
                let sum = wo + wi;
                let len = sum.length();
                if !(len > 0.0) {
                    return (Vec3::ZERO, 0.0);
                }
                let h = sum / len;
                let m = Microfacet::new(super::Distribution::Ggx, roughness);
                let d = m.d(h);
                if !(d > 0.0) {
                    return (Vec3::ZERO, 0.0);
                }
                // written symmetric in wo and wi bit for bit: wi . h = wo . h
                // = |wo + wi| / 2, and each product formed in one order
                let g1o = m.g1(wo);
                let c = (0.5 * len).min(1.0);
                let fresnel = self.specular + (Vec3::ONE - self.specular) * (1.0 - c).powi(5);
                let f = fresnel * (d * (g1o * m.g1(wi)) / (4.0 * (wo.z * wi.z)));
                let pdf = g1o * d / (4.0 * wo.z);
                if f.is_finite() && pdf.is_finite() {
                    (f, pdf)
                } else {
                    (Vec3::ZERO, 0.0)
                }
            }
        }
    }

    /// A direction from the specular lobe, from `u` in `[0, 1)^2`.
    fn sample_lobe(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        match self.lobe {
            Lobe::Phong { shininess: s } => {
                let r = Vec3::new(-wo.x, -wo.y, wo.z);
                let cos = u.x.powf(1.0 / (s + 1.0));
                let sin = (1.0 - cos * cos).max(0.0).sqrt();
                let phi = 2.0 * PI * u.y;
                let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
                Some(Frame::from_normal(r).to_world(local))
            }
            Lobe::Ggx { roughness } => {
                let m = Microfacet::new(super::Distribution::Ggx, roughness);
                Some(reflect(wo, m.sample_visible(wo, u)?))
            }
        }
    }
}

impl Bxdf for Phong {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3::ZERO;
        }
        self.diffuse * FRAC_1_PI + self.lobe(wo, wi).0
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let t = self.lobe_probability();
        let mut pdf = (1.0 - t) * square_to_cosine_hemisphere_pdf(wi);
        if t > 0.0 {
            pdf += t * self.lobe(wo, wi).1;
        }
        pdf
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let wi = match choose_lobe(u, self.lobe_probability()) {
            (true, u) => self.sample_lobe(wo, u)?,
            (false, u) => square_to_cosine_hemisphere(u),
        };
        sample_at(self, wo, wi)
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn has_delta_component(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The normalised lobe's cosine-weighted integral at normal incidence is
    /// `ks` exactly (`(s + 2) / (2 pi) * 2 pi / (s + 2)`): check it by a
    /// midpoint rule in `cos theta`.
    #[test]
    fn phong_lobe_albedo_at_normal_incidence_is_ks() {
        for s in [0.0f32, 1.0, 10.0, 200.0] {
            let p = Phong {
                diffuse: Vec3::ZERO,
                specular: Vec3::ONE,
                lobe: Lobe::Phong { shininess: s },
            };
            let wo = Vec3::Z;
            let n = 200_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let mu = (i as f32 + 0.5) / n as f32;
                let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                // azimuthally symmetric about the normal: 2 pi f mu dmu
                sum += (p.eval(wo, wi).x * mu) as f64;
            }
            let albedo = sum * 2.0 * std::f64::consts::PI / n as f64;
            assert!((albedo - 1.0).abs() < 1e-3, "s = {s}: {albedo}");
        }
    }

    #[test]
    fn lobe_probability_follows_the_course() {
        let mut p = Phong {
            diffuse: Vec3::splat(0.6),
            specular: Vec3::splat(0.2),
            lobe: Lobe::Phong { shininess: 5.0 },
        };
        assert_eq!(p.lobe_probability(), 0.25);
        p.specular = Vec3::ZERO;
        assert_eq!(p.lobe_probability(), 0.0);
        p.lobe = Lobe::Ggx { roughness: 0.3 };
        assert_eq!(p.lobe_probability(), 0.25);
        p.diffuse = Vec3::ZERO;
        assert_eq!(p.lobe_probability(), 1.0);
    }

    #[test]
    fn validation_names_the_key() {
        let bad = [
            (Lobe::Phong { shininess: -1.0 }, "shininess"),
            (
                Lobe::Phong {
                    shininess: f32::NAN,
                },
                "shininess",
            ),
            (Lobe::Ggx { roughness: 0.0 }, "roughness"),
            (Lobe::Ggx { roughness: 1.5 }, "roughness"),
        ];
        for (lobe, key) in bad {
            let p = Phong {
                lobe,
                ..Phong::default()
            };
            let e = p.validate().unwrap_err();
            assert!(e.contains(key), "{e}");
        }
        let p = Phong {
            specular: Vec3::new(0.1, 1.2, 0.0),
            ..Phong::default()
        };
        assert!(p.validate().unwrap_err().contains("`specular`"));
        assert!(Phong::default().validate().is_ok());
    }
}
