//! A panel light: a one-sided emitting parallelogram that is no surface.
//!
//! It lights the scene through light sampling alone. No ray ever meets it:
//! camera rays, BSDF samples and other lights' shadow rays pass through it,
//! so it is invisible to the camera and in mirrors, and it casts no shadow.
//! This is the CS184 course's CGL `<area>` light, which the course keeps in
//! `scene->lights` and never adds to its BVH (`AreaLight::sample_L` in the
//! course's `src/scene/light.cpp`). The light is a parallelogram of
//! radiance `L` centred at `center` with edges `dim_x` and `dim_y`, emitting
//! to the side `facing` points to. It is sampled uniformly by area, as the
//! course samples it, and the density in solid angle is
//! `d^2 / (A |cos theta_l|)`.
//!
//! Since no BSDF sample can find it, the estimator treats its samples as
//! it treats a delta light's ([`super::LightSample::unreachable`]): MIS
//! weight 1, and light-sampled whatever the `--direct` strategy. Its power,
//! for light selection, is the luminance of `L A pi`, the same as a
//! one-sided emissive quad of the same size.

use crate::math::{SurfacePoint, Vec2, Vec3, gamma, luminance_f64};
use std::f64::consts::PI;

/// A one-sided emitting parallelogram that is not geometry (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanelLight {
    /// Centre, in render space once the scene is built.
    pub center: Vec3,
    /// The edge the first sample coordinate runs along.
    pub dim_x: Vec3,
    /// The edge the second sample coordinate runs along.
    pub dim_y: Vec3,
    /// Unit normal of the emitting side.
    pub facing: Vec3,
    /// Emitted radiance.
    pub radiance: Vec3,
}

/// What a panel light sends to a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanelSample {
    /// Unit direction from the shading point towards the point on the light.
    pub wi: Vec3,
    /// Radiance arriving along `-wi` if unoccluded.
    pub li: Vec3,
    /// Solid-angle density of `wi`.
    pub pdf: f32,
    /// The point on the light, for the shadow ray: its error bound is the
    /// rounding of `center + s dim_x + t dim_y`, so the shadow ray stops
    /// short of the light by that much and a surface that lies in the
    /// light's plane (the course's emissive `light` mesh) does not shadow it.
    /// The course's shadow rays stop `EPS_F` short for the same reason.
    pub to: SurfacePoint,
}

impl PanelLight {
    /// A panel light; `None` unless every vector is finite, the edges span
    /// a positive area and `facing` has a length.
    pub fn new(
        center: Vec3,
        dim_x: Vec3,
        dim_y: Vec3,
        facing: Vec3,
        radiance: Vec3,
    ) -> Option<Self> {
        let facing = facing.normalize_or_zero();
        let ok = [center, dim_x, dim_y, radiance]
            .iter()
            .all(|v| v.is_finite())
            && facing != Vec3::ZERO
            && dim_x.cross(dim_y).length() > 0.0;
        ok.then_some(PanelLight {
            center,
            dim_x,
            dim_y,
            facing,
            radiance,
        })
    }

    /// Area of the parallelogram.
    pub fn area(&self) -> f32 {
        self.dim_x.cross(self.dim_y).length()
    }

    /// Power for light selection: `luminance(L) A pi` (one side).
    pub fn power(&self) -> f64 {
        luminance_f64(self.radiance).max(0.0) * self.area() as f64 * PI
    }

    /// The four corners, counter-clockwise seen from the emitting side.
    pub fn corners(&self) -> [Vec3; 4] {
        let (hx, hy) = (0.5 * self.dim_x, 0.5 * self.dim_y);
        let c = [
            self.center - hx - hy,
            self.center + hx - hy,
            self.center + hx + hy,
            self.center - hx + hy,
        ];
        if self.dim_x.cross(self.dim_y).dot(self.facing) < 0.0 {
            [c[3], c[2], c[1], c[0]]
        } else {
            c
        }
    }

    /// A point on the light, uniform by area with `u`, as seen from `from`:
    /// `None` where it cannot light `from` (behind the light, in its plane,
    /// or at it).
    pub fn sample_li(&self, from: &SurfacePoint, u: Vec2) -> Option<PanelSample> {
        let p = self.center + (u.x - 0.5) * self.dim_x + (u.y - 0.5) * self.dim_y;
        let delta = p - from.p;
        let dist2 = delta.length_squared();
        if !(dist2 > 0.0) || !dist2.is_finite() {
            return None;
        }
        let wi = delta / dist2.sqrt();
        let cos_l = -self.facing.dot(wi);
        if !(cos_l > 0.0) {
            return None;
        }
        let pdf = dist2 / (cos_l * self.area());
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        // two products and two sums per coordinate, each rounded once
        let p_err =
            gamma(4) * (self.center.abs() + 0.5 * (self.dim_x.abs() + self.dim_y.abs()) + p.abs());
        Some(PanelSample {
            wi,
            li: self.radiance,
            pdf,
            to: SurfacePoint {
                p,
                p_err,
                n: self.facing,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel() -> PanelLight {
        PanelLight::new(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.8),
            -Vec3::Y,
            Vec3::splat(10.0),
        )
        .unwrap()
    }

    fn below() -> SurfacePoint {
        SurfacePoint {
            p: Vec3::new(0.1, 0.0, -0.2),
            p_err: Vec3::ZERO,
            n: Vec3::Y,
        }
    }

    #[test]
    fn degenerate_panels_are_refused() {
        let p = panel();
        assert!(PanelLight::new(p.center, p.dim_x, 2.0 * p.dim_x, p.facing, p.radiance).is_none());
        assert!(PanelLight::new(p.center, p.dim_x, p.dim_y, Vec3::ZERO, p.radiance).is_none());
        assert!(PanelLight::new(Vec3::NAN, p.dim_x, p.dim_y, p.facing, p.radiance).is_none());
    }

    #[test]
    fn it_lights_only_the_side_it_faces() {
        let p = panel();
        assert!(p.sample_li(&below(), Vec2::new(0.3, 0.7)).is_some());
        let above = SurfacePoint {
            p: Vec3::new(0.0, 3.0, 0.0),
            ..below()
        };
        assert!(p.sample_li(&above, Vec2::new(0.3, 0.7)).is_none());
    }

    #[test]
    fn corners_wind_counter_clockwise_seen_from_the_front() {
        let c = panel().corners();
        let n = (c[1] - c[0]).cross(c[2] - c[0]);
        assert!(n.dot(-Vec3::Y) > 0.0, "normal {n}");
        assert!((n.length() - 0.48).abs() < 1e-6, "twice half the area");
    }

    /// The estimate of the irradiance at a point below the panel, by the
    /// panel's own samples, against the closed form of a rectangle's form
    /// factor seen from a point on a parallel plane below its centre
    /// (Lambert, as in `tests/common::lambert_form_factor`).
    #[test]
    fn area_sampling_integrates_the_solid_angle() {
        let p = PanelLight::new(
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
            -Vec3::Y,
            Vec3::ONE,
        )
        .unwrap();
        let from = SurfacePoint {
            p: Vec3::ZERO,
            p_err: Vec3::ZERO,
            n: Vec3::Y,
        };
        // a 1 x 1 unit-square rectangle at height h, seen from below a
        // corner: E / L = (1/2) [a/sqrt(1+a^2) atan(b/sqrt(1+a^2)) + ...]
        // with a = b = 1 for h = 1; the panel is four such quarters
        let q = |a: f64, b: f64| {
            let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
            0.5 * (a / sa * (b / sa).atan() + b / sb * (a / sb).atan())
        };
        let exact = 4.0 * q(1.0, 1.0);
        let n = 256;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let s = p.sample_li(&from, u).unwrap();
                sum += (s.li.x * s.wi.y / s.pdf) as f64;
            }
        }
        let e = sum / (n * n) as f64;
        assert!((e - exact).abs() < 1e-4 * exact, "{e} vs {exact}");
    }
}
