//! A thin dielectric sheet (a window pane, a soap film): pbrt-v4's
//! `ThinDielectricBxDF` (section 9.5.2 of *Physically Based Rendering*, 4th
//! edition). Light entering the sheet bounces between its two parallel
//! faces; summing the bounces, the sheet reflects
//! `R' = R + T^2 R / (1 - R^2)` and transmits `T' = 1 - R'`, with `R` the
//! Fresnel reflectance of one face at the angle of incidence and `T = 1 - R`
//! (no total internal reflection: the ray leaves at the angle it entered).
//! Both lobes are deltas: the mirror direction, and straight through
//! (`wi = -wo`, no refraction, so radiance is not rescaled: [`Bxdf::eta`] is
//! 1). [`Bxdf::sample`] picks reflection with probability `R'`, so with
//! `reflectance = transmittance = 1` every sample has weight 1.
//!
//! **Frame.** As [`super::Glass`]: `+z` is the surface's outward normal; the
//! sheet is symmetric, so either side sees the same.
//!
//! Scene form: `material = { type = "thin_glass", ior = 1.5, reflectance =
//! [1, 1, 1], transmittance = [1, 1, 1] }`.

use super::fresnel::fr_dielectric;
use super::{BsdfSample, Bxdf, Glass};
use crate::math::{Vec2, Vec3};

/// A thin dielectric sheet of index `ior` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThinGlass {
    /// Index of refraction of the sheet relative to its surroundings;
    /// finite and `> 0`.
    pub ior: f32,
    /// Scale on the reflected lobe, per channel, in `[0, 1]`.
    pub reflectance: Vec3,
    /// Scale on the transmitted lobe, per channel, in `[0, 1]`.
    pub transmittance: Vec3,
}

impl Default for ThinGlass {
    fn default() -> Self {
        ThinGlass {
            ior: 1.5,
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
        }
    }
}

impl ThinGlass {
    /// Checks the index and scales as [`Glass::validate`] does.
    pub fn validate(&self) -> Result<(), String> {
        Glass {
            ior: self.ior,
            reflectance: self.reflectance,
            transmittance: self.transmittance,
        }
        .validate()
    }

    /// The sheet's reflectance `R'` seen from `wo`, all bounces summed.
    pub fn reflectance_at(&self, wo: Vec3) -> f32 {
        let r = fr_dielectric(wo.z.abs(), self.ior);
        if r < 1.0 {
            let t = 1.0 - r;
            r + t * t * r / (1.0 - r * r)
        } else {
            1.0
        }
    }
}

impl Bxdf for ThinGlass {
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
        let r = self.reflectance_at(wo);
        let (wi, scale, p) = if u.x < r {
            (Vec3::new(-wo.x, -wo.y, wo.z), self.reflectance, r)
        } else {
            (-wo, self.transmittance, 1.0 - r)
        };
        if !(p > 0.0) {
            return None;
        }
        BsdfSample {
            wi,
            f: scale * (p / wi.z.abs()),
            pdf: p,
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
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At normal incidence one face reflects 4 % (`ior = 1.5`); the sheet
    /// `2 R / (1 + R)`, 7.69 %. Samples go straight through or mirror, with
    /// weight 1, from either side.
    #[test]
    fn sheet_sums_its_bounces_and_conserves_energy() {
        let g = ThinGlass::default();
        let r = g.reflectance_at(Vec3::Z);
        assert!((r - 0.08 / 1.04).abs() < 1e-6, "{r}");
        for wo in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.6, 0.0, -0.8)] {
            let rr = g.reflectance_at(wo);
            let refl = g.sample(wo, Vec2::new(0.5 * rr, 0.5)).unwrap();
            assert_eq!(refl.wi, Vec3::new(-wo.x, -wo.y, wo.z));
            assert!((refl.weight() - Vec3::ONE).abs().max_element() < 1e-6);
            let through = g.sample(wo, Vec2::new(0.5 + 0.5 * rr, 0.5)).unwrap();
            assert_eq!(through.wi, -wo);
            assert!((through.weight() - Vec3::ONE).abs().max_element() < 1e-6);
            assert!((refl.pdf + through.pdf - 1.0).abs() < 1e-6);
        }
        // grazing: the sheet reflects nearly everything, still at weight 1
        let graze = Vec3::new(0.999_999, 0.0, 0.001_414);
        assert!(g.reflectance_at(graze) > 0.98);
    }
}
