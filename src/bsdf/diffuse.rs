//! The Lambertian BSDF, `f = albedo / pi`, sampled by cosine-weighted
//! directions (pbrt-v4 section 9.2). Reflection only: `wi` on the other side
//! of the surface from `wo` gets zero.

use super::{BsdfSample, Bxdf};
use crate::math::{Vec2, Vec3};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use std::f32::consts::FRAC_1_PI;

/// Lambertian reflection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diffuse {
    /// Albedo in `[0, 1]` per channel.
    pub albedo: Vec3,
}

fn same_hemisphere(wo: Vec3, wi: Vec3) -> bool {
    wo.z > 0.0 && wi.z > 0.0
}

impl Diffuse {
    /// `f(wo, wi)` without the cosine.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if same_hemisphere(wo, wi) {
            self.albedo * FRAC_1_PI
        } else {
            Vec3::ZERO
        }
    }

    /// Solid-angle density of sampling `wi` given `wo`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if same_hemisphere(wo, wi) {
            square_to_cosine_hemisphere_pdf(wi)
        } else {
            0.0
        }
    }

    /// A cosine-weighted direction on `wo`'s side.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        self.sample_warped(wo, square_to_cosine_hemisphere(u))
    }

    /// [`Diffuse::sample`] given the cosine-weighted direction `wi` that
    /// its numbers warp to (the kernels warp a batch's at once,
    /// [`crate::sampling::square_to_cosine_hemisphere_lanes`]).
    #[inline]
    pub fn sample_warped(&self, wo: Vec3, wi: Vec3) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = square_to_cosine_hemisphere_pdf(wi);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f: self.albedo * FRAC_1_PI,
            pdf,
            delta: false,
        })
    }
}

impl Bxdf for Diffuse {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        Diffuse::eval(self, wo, wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        Diffuse::pdf(self, wo, wi)
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        Diffuse::sample(self, wo, u)
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn has_delta_component(&self) -> bool {
        false
    }

    /// `cos / pi` peaks at `1 / pi`, along the normal, whatever `wo`.
    fn lobe_peak_pdf(&self) -> f32 {
        std::f32::consts::FRAC_1_PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    #[test]
    fn sample_eval_pdf_agree() {
        let b = Diffuse {
            albedo: Vec3::new(0.2, 0.5, 0.9),
        };
        let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
        let mut s = Sampler::new(0, 0, 0);
        for _ in 0..10_000 {
            let Some(bs) = b.sample(wo, s.next_2d()) else {
                continue;
            };
            assert!((bs.pdf - b.pdf(wo, bs.wi)).abs() <= 1e-5 * bs.pdf);
            assert!((bs.f - b.eval(wo, bs.wi)).abs().max_element() <= 1e-6);
            let w = bs.weight();
            assert!(
                (w - b.albedo).abs().max_element() < 1e-5 * 4.0,
                "weight {w}"
            );
        }
    }

    #[test]
    fn white_diffuse_reflects_all_energy() {
        // Hard case 15: the directional albedo of rho = 1, the integral of
        // f cos over the hemisphere, by a midpoint rule in (cos theta, phi)
        // (exact for a constant f: the error is the rule's, below 1e-6).
        let d = Diffuse { albedo: Vec3::ONE };
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let (nt, np) = (400, 400);
        let mut sum = 0.0f64;
        for i in 0..nt {
            let c = (i as f32 + 0.5) / nt as f32;
            let s = (1.0 - c * c).sqrt();
            for j in 0..np {
                let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / np as f32;
                let wi = Vec3::new(s * phi.cos(), s * phi.sin(), c);
                // d(omega) = d(cos) d(phi)
                sum += (d.eval(wo, wi).x * c) as f64
                    * (1.0 / nt as f64)
                    * (std::f64::consts::TAU / np as f64);
            }
        }
        assert!((sum - 1.0).abs() < 1e-5 && sum <= 1.01, "albedo {sum}");
    }

    #[test]
    fn grazing_and_opposite_sides() {
        let b = Diffuse { albedo: Vec3::ONE };
        let wo = Vec3::Z;
        for c in [1.0f32, 1e-3, 1e-6, 1e-8, 0.0, -0.0] {
            let wi = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
            let f = b.eval(wo, wi);
            let p = b.pdf(wo, wi);
            assert!(f.is_finite() && f.min_element() >= 0.0 && p.is_finite() && p >= 0.0);
            if c == 0.0 {
                assert_eq!(f * c, Vec3::ZERO);
                assert_eq!(p, 0.0);
            }
        }
        assert_eq!(b.eval(wo, -Vec3::Z), Vec3::ZERO);
        assert_eq!(b.pdf(wo, -Vec3::Z), 0.0);
        assert!(b.sample(-Vec3::Z, Vec2::splat(0.5)).is_none());
    }
}
