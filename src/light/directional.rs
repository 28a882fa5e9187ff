//! A directional light: parallel light travelling along `direction`, with
//! irradiance E (per RGB channel) on a surface facing it (pbrt-v4 section
//! 12.4, `DistantLight`).
//!
//! A shading point receives E from the single direction `-direction`: a delta
//! distribution in direction, reached only by light sampling (`pdf` 1 with
//! respect to that delta; no MIS), unoccluded up to infinity. Its power, for
//! light selection, is the luminance of E times the area of a disk as wide as
//! the scene, `pi r^2`, as pbrt-v4's `DistantLight::Phi` has it.

use super::DeltaLightSample;
use crate::math::{SurfacePoint, Vec3, spawn_ray};

/// A directional (distant) light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels in.
    direction: Vec3,
    /// Irradiance on a surface perpendicular to the light.
    irradiance: Vec3,
}

impl DirectionalLight {
    /// Light travelling along `direction` (any non-zero finite length; it is
    /// normalised) with `irradiance`. `None` for a zero or non-finite
    /// direction.
    pub fn new(direction: Vec3, irradiance: Vec3) -> Option<Self> {
        // scaled by its largest component first, so that neither a tiny
        // (1e-38) nor a huge (1e38) vector under- or overflows its length
        let m = direction.abs().max_element();
        if !direction.is_finite() || !(m > 0.0) {
            return None;
        }
        // a unit direction (to a few ulps) is kept as it is, so a scene
        // written out by `convert` reads back to the same bits
        if (direction.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
            return Some(DirectionalLight {
                direction,
                irradiance,
            });
        }
        let d = direction / m;
        Some(DirectionalLight {
            direction: d / d.length(),
            irradiance,
        })
    }

    /// The unit direction the light travels in.
    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// The irradiance on a surface facing the light.
    pub fn irradiance(&self) -> Vec3 {
        self.irradiance
    }

    /// The light as seen from `from`: E arriving from `-direction`.
    pub fn sample_li(&self, from: &SurfacePoint) -> DeltaLightSample {
        let wi = -self.direction;
        DeltaLightSample {
            wi,
            li: self.irradiance,
            dist: f32::INFINITY,
            pdf: 1.0,
            shadow: spawn_ray(from, wi),
        }
    }

    /// Power for light selection in a scene whose bounding sphere has radius
    /// `scene_radius`: luminance of `E pi r^2`, in `f64`.
    pub fn power(&self, scene_radius: f32) -> f64 {
        let r = scene_radius as f64;
        std::f64::consts::PI * r * r * crate::math::luminance_f64(self.irradiance).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_arrives_against_its_direction() {
        let e = Vec3::new(1.0, 2.0, 3.0);
        let light = DirectionalLight::new(Vec3::new(0.0, -2.0, 0.0), e).unwrap();
        assert_eq!(light.direction(), -Vec3::Y);
        let from = SurfacePoint {
            p: Vec3::new(1.0, 0.0, 1.0),
            p_err: Vec3::ZERO,
            n: Vec3::Y,
        };
        let s = light.sample_li(&from);
        assert_eq!(s.wi, Vec3::Y);
        assert_eq!(s.li, e);
        assert_eq!(s.pdf, 1.0);
        assert_eq!(s.dist, f32::INFINITY);
        assert_eq!(s.shadow.t_max, f32::INFINITY);
        assert_eq!(s.shadow.d, Vec3::Y);
        assert!(s.shadow.o.y > 0.0, "the shadow ray leaves the surface");
    }

    #[test]
    fn bad_directions_and_power() {
        assert!(DirectionalLight::new(Vec3::ZERO, Vec3::ONE).is_none());
        assert!(DirectionalLight::new(Vec3::new(f32::NAN, 0.0, 1.0), Vec3::ONE).is_none());
        assert!(DirectionalLight::new(Vec3::new(1.0, f32::INFINITY, 0.0), Vec3::ONE).is_none());
        // tiny and huge vectors normalise without under- or overflow
        let tiny = DirectionalLight::new(Vec3::new(1e-38, 0.0, 0.0), Vec3::ONE).unwrap();
        assert_eq!(tiny.direction(), Vec3::X);
        let huge = DirectionalLight::new(Vec3::new(0.0, -3e38, 0.0), Vec3::ONE).unwrap();
        assert_eq!(huge.direction(), -Vec3::Y);
        let light = DirectionalLight::new(Vec3::X, Vec3::ONE).unwrap();
        // luminance 1, r = 2: pi * 4
        assert!((light.power(2.0) - 4.0 * std::f64::consts::PI).abs() < 1e-12);
    }
}
