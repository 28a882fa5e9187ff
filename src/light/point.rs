//! A point light: `intensity` I (W/sr, per RGB channel) radiated equally in
//! every direction from `position` (pbrt-v4 section 12.1, `PointLight`).
//!
//! Seen from a point at distance r it contributes I / r^2 along the single
//! direction towards it (or, with an `attenuation` of `[c, l, q]`, the
//! CSE 167 / OpenGL form I / (c + l r + q r^2); the default `[0, 0, 1]` is
//! the physical inverse square, bit for bit): a delta distribution in direction, so it is only
//! reached by light sampling (the sample's `pdf` is 1 with respect to that
//! delta, and no MIS applies). Its power, for light selection, is the
//! luminance of `4 pi I`.

use super::DeltaLightSample;
use crate::math::{SurfacePoint, Vec3, spawn_ray_to};

/// A point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLight {
    /// Where it is.
    pub position: Vec3,
    /// Radiant intensity, W/sr.
    pub intensity: Vec3,
    /// Falloff `[constant, linear, quadratic]`: radiance arrives as
    /// I / (c + l r + q r^2). [`PHYSICAL`] is the inverse square; other
    /// values serve the course formats (`.test` `attenuation`, CS184's
    /// unattenuated point light) and are a named, documented departure from
    /// physics, kept where the file asked for it.
    pub attenuation: [f32; 3],
}

/// The physical falloff, 1 / r^2.
pub const PHYSICAL: [f32; 3] = [0.0, 0.0, 1.0];

impl PointLight {
    /// A point light at `position` with `intensity` (W/sr).
    pub fn new(position: Vec3, intensity: Vec3) -> Self {
        PointLight {
            position,
            intensity,
            attenuation: PHYSICAL,
        }
    }

    /// The same light with falloff 1 / (c + l r + q r^2). `None` unless the
    /// three are finite and non-negative and the denominator is positive
    /// for every r > 0 (`l > 0` or `q > 0`, or `c > 0`).
    pub fn with_attenuation(self, [c, l, q]: [f32; 3]) -> Option<Self> {
        let ok = [c, l, q].iter().all(|x| x.is_finite() && *x >= 0.0) && c + l + q > 0.0;
        ok.then_some(PointLight {
            attenuation: [c, l, q],
            ..self
        })
    }

    /// The light as seen from `from`: `None` when `from` is at the light
    /// (the distance is 0 or not finite).
    pub fn sample_li(&self, from: &SurfacePoint) -> Option<DeltaLightSample> {
        let delta = self.position - from.p;
        let dist2 = delta.length_squared();
        if !(dist2 > 0.0) || !dist2.is_finite() {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = delta / dist;
        // the light is a point in empty space: no error box, and its "normal"
        // faces the shading point, so the shadow ray's end is not offset
        let light = SurfacePoint {
            p: self.position,
            p_err: Vec3::ZERO,
            n: -wi,
        };
        Some(DeltaLightSample {
            wi,
            // with PHYSICAL: 0 + 0 * dist + 1 * dist2 == dist2 exactly
            li: self.intensity
                / (self.attenuation[0] + self.attenuation[1] * dist + self.attenuation[2] * dist2),
            dist,
            pdf: 1.0,
            shadow: spawn_ray_to(from, &light),
        })
    }

    /// Power for light selection: luminance of `4 pi I`, in `f64` (in
    /// `f32` it overflows from I = 2.7e37 W/sr).
    pub fn power(&self) -> f64 {
        4.0 * std::f64::consts::PI * crate::math::luminance_f64(self.intensity).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(p: Vec3) -> SurfacePoint {
        SurfacePoint {
            p,
            p_err: Vec3::ZERO,
            n: Vec3::Y,
        }
    }

    #[test]
    fn radiance_falls_off_as_inverse_square_exactly() {
        let i = Vec3::new(10.0, 20.0, 30.0);
        let light = PointLight::new(Vec3::new(3.0, 4.0, 0.0), i);
        let s = light.sample_li(&at(Vec3::ZERO)).unwrap();
        // r^2 = 25 exactly in f32
        assert_eq!(s.li, i / 25.0);
        assert_eq!(s.dist, 5.0);
        assert_eq!(s.wi, Vec3::new(0.6, 0.8, 0.0));
        assert_eq!(s.pdf, 1.0);
        // any point: I / |p_light - p|^2, the same f32 operations
        for p in [Vec3::new(0.1, -2.0, 7.0), Vec3::new(1e3, 1e-3, -5.0)] {
            let s = light.sample_li(&at(p)).unwrap();
            let r2 = (light.position - p).length_squared();
            assert_eq!(s.li, i / r2);
            assert!((s.dist - r2.sqrt()).abs() <= f32::EPSILON * s.dist);
            assert!((s.wi.length() - 1.0).abs() < 1e-6);
            // the shadow ray runs towards the light and stops short of it
            let sh = s.shadow;
            assert!((sh.d - s.wi).length() < 1e-5);
            assert!(sh.t_max < s.dist && sh.t_max > 0.99 * s.dist);
        }
        assert!(light.sample_li(&at(light.position)).is_none());
    }

    #[test]
    fn attenuation_follows_the_course_formula() {
        let i = Vec3::splat(12.0);
        let light = PointLight::new(Vec3::new(0.0, 2.0, 0.0), i);
        let s = light.sample_li(&at(Vec3::ZERO)).unwrap();
        assert_eq!(s.li, i / 4.0);
        let flat = light.with_attenuation([1.0, 0.0, 0.0]).unwrap();
        assert_eq!(flat.sample_li(&at(Vec3::ZERO)).unwrap().li, i);
        let mixed = light.with_attenuation([1.0, 0.5, 0.25]).unwrap();
        // 1 + 0.5 * 2 + 0.25 * 4 = 3
        assert_eq!(mixed.sample_li(&at(Vec3::ZERO)).unwrap().li, i / 3.0);
        for bad in [
            [0.0, 0.0, 0.0],
            [-1.0, 0.0, 1.0],
            [f32::NAN, 0.0, 1.0],
            [0.0, f32::INFINITY, 0.0],
        ] {
            assert!(light.with_attenuation(bad).is_none(), "{bad:?}");
        }
    }

    #[test]
    fn power_is_four_pi_intensity() {
        let light = PointLight::new(Vec3::ZERO, Vec3::splat(2.0));
        assert!((light.power() - 8.0 * std::f64::consts::PI).abs() < 1e-12);
        // finite radiance, power beyond f32
        let strong = PointLight::new(Vec3::ZERO, Vec3::splat(1e38));
        assert!((strong.power() / (4e38 * std::f64::consts::PI) - 1.0).abs() < 1e-6);
    }
}
