//! A smooth dielectric boundary (glass, water): specular reflection and
//! refraction weighted by the exact Fresnel equations, with total internal
//! reflection (pbrt-v4, section 9.5, "Dielectric BSDF", smooth case; Fresnel
//! and Snell's law in [`super::fresnel`]).
//!
//! **Frame.** Unlike the reflective BSDFs, glass must know which side is
//! which: its local `+z` is the surface's *outward* normal (the side of index
//! 1), not the normal turned towards `wo`. `wo.z < 0` means `wo` is inside the
//! glass (index `ior`). [`Bxdf::has_transmission`] tells the estimator so.
//!
//! **Lobes.** Both lobes are Dirac deltas: [`Bxdf::eval`] and [`Bxdf::pdf`]
//! are zero everywhere. [`Bxdf::sample`] picks reflection with probability
//! `F = fr_dielectric(cos theta_o, ior)` (exactly the Fresnel reflectance, so
//! under total internal reflection `F = 1` and it always reflects) and
//! refraction with probability `1 - F`; the first random number decides, the
//! second is unused. Reflection returns `f = R F / |cos theta_i|`, `pdf = F`
//! (weight `R`); refraction returns `f = T (1 - F) / (|cos theta_i| eta'^2)`,
//! `pdf = 1 - F` (weight `T / eta'^2`).
//!
//! **Radiance across the interface.** The renderer traces from the camera, so
//! the sampled `wi` carries *radiance* towards `wo` (pbrt's
//! `TransportMode::Radiance`). Radiance divided by the square of the index,
//! `L / n^2`, is what a lossless boundary conserves: light squeezed into the
//! denser medium's narrower cone has `n^2` times the radiance. So a refracted
//! sample's weight is divided by `eta'^2`, where `eta' = n(wi's side) /
//! n(wo's side)` (`ior` for `wo` outside, `1 / ior` for `wo` inside). A ray
//! that enters and leaves a glass object gets `1 / ior^2` and then `ior^2`:
//! the product is 1, so a glass sphere in a uniform environment of radiance 1
//! renders 1. With `reflectance = transmittance = 1`, every sample conserves
//! `L / n^2` exactly (`R + T = 1` in expectation, including total internal
//! reflection).
//!
//! Scene form: `material = { type = "glass", ior = 1.5, reflectance = [1, 1,
//! 1], transmittance = [1, 1, 1] }`.

use super::fresnel::{fr_dielectric, refract};
use super::{BsdfSample, Bxdf};
use crate::math::{Vec2, Vec3};

/// A smooth dielectric: index `ior` inside (the `-z` side), 1 outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Glass {
    /// Index of refraction inside relative to outside; finite and `> 0`.
    pub ior: f32,
    /// Scale on the reflected lobe, per channel, in `[0, 1]`.
    pub reflectance: Vec3,
    /// Scale on the refracted lobe, per channel, in `[0, 1]`.
    pub transmittance: Vec3,
}

impl Default for Glass {
    fn default() -> Self {
        Glass {
            ior: 1.5,
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
        }
    }
}

impl Glass {
    /// Checks that `ior` is finite and positive and both scales are in
    /// `[0, 1]`.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.ior.is_finite() && self.ior > 0.0) {
            return Err(format!(
                "`ior` must be a finite number > 0, got {}",
                self.ior
            ));
        }
        super::check_unit_rgb("reflectance", self.reflectance)?;
        super::check_unit_rgb("transmittance", self.transmittance)
    }

    /// The probability that [`Bxdf::sample`] reflects for this `wo`: the
    /// Fresnel reflectance (1 under total internal reflection).
    pub fn reflect_probability(&self, wo: Vec3) -> f32 {
        fr_dielectric(wo.z, self.ior)
    }
}

impl Bxdf for Glass {
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z != 0.0) || !wo.is_finite() {
            return None;
        }
        let fr = fr_dielectric(wo.z, self.ior);
        if u.x < fr {
            // --- specular reflection, probability F ---
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return BsdfSample {
                wi,
                f: self.reflectance * (fr / wi.z.abs()),
                pdf: fr,
                delta: true,
            }
            .checked();
        }
        // --- specular transmission, probability 1 - F ---
        let pt = 1.0 - fr;
        if !(pt > 0.0) {
            return None;
        }
        let r = refract(wo, Vec3::Z, self.ior)?;
        let wi = r.wt;
        if wi.z == 0.0 || wi.z.signum() == wo.z.signum() {
            return None;
        }
        BsdfSample {
            wi,
            f: self.transmittance * (pt / (wi.z.abs() * r.etap * r.etap)),
            pdf: pt,
            delta: true,
        }
        .checked()
    }

    fn is_delta(&self) -> bool {
        true
    }

    fn has_delta_component(&self) -> bool {
        true
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

    #[test]
    fn chooses_by_fresnel_and_conserves_basic_radiance() {
        let g = Glass::default();
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let fr = fr_dielectric(0.8, 1.5);
        let r = g.sample(wo, Vec2::new(0.5 * fr, 0.3)).unwrap();
        assert_eq!(r.wi, Vec3::new(-0.6, 0.0, 0.8));
        assert!((r.pdf - fr).abs() < 1e-7);
        assert!((r.weight() - Vec3::ONE).abs().max_element() < 1e-6);
        let t = g.sample(wo, Vec2::new(0.5 + 0.5 * fr, 0.3)).unwrap();
        assert!(t.wi.z < 0.0 && (t.wi.length() - 1.0).abs() < 1e-6);
        assert!((t.pdf - (1.0 - fr)).abs() < 1e-7);
        // weight 1 / eta^2 entering, so that L / n^2 is unchanged
        assert!((t.weight() * 2.25 - Vec3::ONE).abs().max_element() < 1e-6);
        // and eta^2 leaving along the reverse path
        let back = g.sample(t.wi, Vec2::new(0.999, 0.3)).unwrap();
        assert!((back.wi - wo).abs().max_element() < 1e-6);
        assert!((back.weight() / 2.25 - Vec3::ONE).abs().max_element() < 1e-6);
    }

    #[test]
    fn total_internal_reflection_always_reflects() {
        let g = Glass::default();
        // inside, 60 degrees from the normal: past the critical 41.8 degrees
        let wo = Vec3::new(0.866_025_4, 0.0, -0.5);
        assert_eq!(g.reflect_probability(wo), 1.0);
        for x in [0.0f32, 0.5, 0.999_999_94] {
            let s = g.sample(wo, Vec2::new(x, 0.5)).unwrap();
            assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
            assert!((s.weight() - Vec3::ONE).abs().max_element() < 1e-6);
        }
    }
}
