//! A perfect specular reflector, `f = R delta(wi - reflect(wo)) / |cos theta_i|`
//! (pbrt-v4, section 9.3, "Specular Reflection and Transmission", with the
//! Fresnel term replaced by a constant reflectance). Its one lobe is a Dirac
//! delta: [`Bxdf::eval`] and [`Bxdf::pdf`] are zero for every pair of
//! directions, and [`Bxdf::sample`] returns the mirror direction with
//! `f = R / cos(theta_i)` and `pdf = 1`, marked [`BsdfSample::delta`], so its
//! weight is exactly `R`.
//!
//! Scene form: `material = { type = "mirror", reflectance = [r, g, b] }`
//! (default reflectance 1).

use super::{BsdfSample, Bxdf};
use crate::math::{Vec2, Vec3};

/// Perfect mirror reflection, reflection only (`wo.z > 0`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mirror {
    /// Reflectance per channel, in `[0, 1]`.
    pub reflectance: Vec3,
}

impl Default for Mirror {
    fn default() -> Self {
        Mirror {
            reflectance: Vec3::ONE,
        }
    }
}

impl Mirror {
    /// Checks that the reflectance is finite and in `[0, 1]`.
    pub fn validate(&self) -> Result<(), String> {
        super::check_unit_rgb("reflectance", self.reflectance)
    }
}

/// The delta-lobe sample in the mirror direction of `wo` (`wo.z > 0`) with
/// reflectance `r`: `f = r / cos` and the given lobe probability `pdf`.
/// `None` when the cosine is zero or so small that `f` overflows.
pub(super) fn specular_reflection(wo: Vec3, r: Vec3, pdf: f32) -> Option<BsdfSample> {
    if !(wo.z > 0.0) || !(pdf > 0.0) {
        return None;
    }
    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
    BsdfSample {
        wi,
        f: r / wi.z,
        pdf,
        delta: true,
    }
    .checked()
}

impl Bxdf for Mirror {
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3, _u: Vec2) -> Option<BsdfSample> {
        specular_reflection(wo, self.reflectance, 1.0)
    }

    fn is_delta(&self) -> bool {
        true
    }

    fn has_delta_component(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflects_about_the_normal_with_weight_r() {
        let m = Mirror {
            reflectance: Vec3::new(0.9, 0.5, 0.1),
        };
        let wo = Vec3::new(0.3, -0.4, 0.5).normalize();
        let s = m.sample(wo, Vec2::splat(0.5)).unwrap();
        assert!(s.delta);
        assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
        assert!((s.weight() - m.reflectance).abs().max_element() < 1e-7);
        assert_eq!(m.eval(wo, s.wi), Vec3::ZERO);
        assert_eq!(m.pdf(wo, s.wi), 0.0);
        assert!(m.sample(-wo, Vec2::ZERO).is_none());
        assert!(m.sample(Vec3::X, Vec2::ZERO).is_none());
    }
}
