//! A spot light: a point light at `position` whose intensity `I` (W/sr, per
//! RGB channel, on the axis) is shaped by a cone about `direction`, with
//! Mitsuba 3's falloff (`src/emitters/spot.cpp`, `SpotLight::falloff_curve`):
//! with `theta` the angle between the axis and the direction of emission,
//!
//! ```text
//! f(theta) = 1                                         theta <= beam_width
//!          = (cutoff_angle - theta) / (cutoff_angle - beam_width)
//!                                                      beam_width < theta < cutoff_angle
//!          = 0                                         theta >= cutoff_angle
//! ```
//!
//! i.e. full intensity inside the beam, then linear in the angle (not in its
//! cosine, as pbrt-v4's smoothstep) down to zero at the cutoff. Mitsuba
//! tests `cos theta >= cos beam_width` for the beam and `cos theta > cos
//! cutoff_angle` for the cone, and takes `theta = acos(cos theta)` in the
//! band; so does [`SpotLight::falloff`]. Defaults as Mitsuba's: a cutoff of
//! 20 degrees and a beam of 3/4 of the cutoff.
//!
//! Seen from a point at distance r it contributes `I f(theta) / r^2` along
//! the single direction towards it: a delta distribution, reached by light
//! sampling only (`pdf` 1 with respect to the delta, no MIS). Its power, for
//! light selection, is pbrt-v4's `SpotLight::Phi` with this falloff instead:
//! the luminance of `I` times the integral of `f` over the sphere,
//!
//! ```text
//! 2 pi int_0^cutoff f(theta) sin theta dtheta
//!   = 2 pi (1 - (sin cutoff - sin beam) / (cutoff - beam)),
//! ```
//!
//! which is `2 pi (1 - cos cutoff)` in the limit `beam -> cutoff` (a hard
//! cone), computed in `f64`.
//!
//! glTF's `KHR_lights_punctual` spot ([`SpotLight::smooth`], `falloff =
//! "smooth"`) falls off instead as the square of a linear ramp in the
//! cosine, from 1 at the inner cone (`beam_width`) to 0 at the outer
//! (`cutoff_angle`): `f = t^2`, `t = (cos theta - cos outer) / (cos inner -
//! cos outer)` clamped to `[0, 1]` (the extension's reference code); its
//! integral over the sphere is `2 pi ((1 - cos inner) + (cos inner - cos
//! outer) / 3)`.
//!
//! pbrt-v4's spot ([`SpotLight::smoothstep`], `falloff = "smoothstep"`)
//! takes the smoothstep `t^2 (3 - 2 t)` of the same ramp, between its
//! `coneangle` and `coneangle - conedelta`; its integral is `2 pi ((1 -
//! cos inner) + (cos inner - cos outer) / 2)`.
//!
//! Scene form (angles in degrees):
//!
//! ```toml
//! [[light]]
//! type = "spot"
//! position = [0.0, 3.0, 0.0]
//! target = [0.0, 0.0, 0.0]      # or: direction = [0.0, -1.0, 0.0]
//! intensity = [10.0, 9.0, 8.0]  # W/sr on the axis, or one number
//! cutoff_angle = 30.0           # default 20
//! beam_width = 20.0             # default 3/4 of cutoff_angle
//! falloff = "linear"            # or "smooth" (glTF's) or "smoothstep" (pbrt-v4's); beam_width may be 0 with either
//! ```

use super::DeltaLightSample;
use crate::math::{SurfacePoint, Vec3, spawn_ray_to};

/// Mitsuba's default cutoff angle, degrees.
pub const DEFAULT_CUTOFF_ANGLE: f32 = 20.0;

/// How a spot light's intensity falls off between its beam and its cutoff.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Falloff {
    /// Linear in the angle (Mitsuba 3's).
    #[default]
    Linear,
    /// The square of a ramp linear in the cosine (glTF's).
    Smooth,
    /// Hermite's smoothstep `t^2 (3 - 2 t)` of that ramp (pbrt-v4's).
    SmoothStep,
}

/// A spot light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotLight {
    /// The falloff between beam and cutoff.
    falloff: Falloff,
    /// Where it is.
    pub position: Vec3,
    /// The axis as given (any non-zero finite length), kept so that a
    /// converted scene writes it back to the same bits.
    direction: Vec3,
    /// The unit axis.
    axis: Vec3,
    /// Radiant intensity on the axis, W/sr.
    pub intensity: Vec3,
    /// Cutoff angle in degrees, as given.
    cutoff_deg: f32,
    /// Beam width in degrees, as given.
    beam_deg: f32,
    cutoff: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    /// `1 / (cutoff - beam)` in radians (infinite for a hard cone: then
    /// the band is empty and it is never used).
    inv_transition: f32,
}

impl SpotLight {
    /// A spot light at `position` pointing along `direction` (any non-zero
    /// finite length) with `intensity` on its axis, a cutoff of
    /// `cutoff_deg` degrees and a beam of `beam_deg` degrees (`None`: 3/4
    /// of the cutoff). Errors, as one line each: a zero or non-finite
    /// direction, angles outside (0, 90], a beam wider than the cutoff.
    pub fn new(
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cutoff_deg: f32,
        beam_deg: Option<f32>,
    ) -> Result<Self, String> {
        let m = direction.abs().max_element();
        if !direction.is_finite() || !(m > 0.0) {
            return Err(format!(
                "spot light: the direction must be finite and non-zero, got {direction}"
            ));
        }
        let beam_deg = beam_deg.unwrap_or(cutoff_deg * 0.75);
        for (name, a) in [("cutoff_angle", cutoff_deg), ("beam_width", beam_deg)] {
            if !(a > 0.0 && a <= 90.0) {
                return Err(format!(
                    "spot light: `{name}` must be in (0, 90] degrees, got {a}"
                ));
            }
        }
        if beam_deg > cutoff_deg {
            return Err(format!(
                "spot light: `beam_width` {beam_deg} must not exceed `cutoff_angle` {cutoff_deg}"
            ));
        }
        let d = direction / m;
        let cutoff = cutoff_deg.to_radians();
        let beam = beam_deg.to_radians();
        Ok(SpotLight {
            falloff: Falloff::Linear,
            position,
            direction,
            axis: d / d.length(),
            intensity,
            cutoff_deg,
            beam_deg,
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: 1.0 / (cutoff - beam),
        })
    }

    /// glTF's spot light: full intensity within `inner` radians of the
    /// axis, none beyond `outer`, the smooth falloff between (module docs).
    /// Errors, as one line each: a zero or non-finite direction, angles
    /// outside `0 <= inner < outer <= pi / 2`.
    pub fn smooth(
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        inner: f32,
        outer: f32,
    ) -> Result<Self, String> {
        if !(inner >= 0.0 && inner < outer && outer <= std::f32::consts::FRAC_PI_2 + 1e-6) {
            return Err(format!(
                "spot light: cone angles must satisfy 0 <= inner < outer <= pi/2, got inner {inner} and outer {outer}"
            ));
        }
        let outer_deg = outer.to_degrees().min(90.0);
        // a valid linear light of the same cone, then the falloff swapped
        let mut s = Self::new(position, direction, intensity, outer_deg, Some(outer_deg))?;
        s.falloff = Falloff::Smooth;
        s.beam_deg = inner.to_degrees();
        s.cos_beam = inner.cos();
        Ok(s)
    }

    /// pbrt-v4's spot light: full intensity within `inner` radians of the
    /// axis, none beyond `outer`, the smoothstep falloff between (module
    /// docs), with the errors of [`SpotLight::smooth`].
    pub fn smoothstep(
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        inner: f32,
        outer: f32,
    ) -> Result<Self, String> {
        let mut s = Self::smooth(position, direction, intensity, inner, outer)?;
        s.falloff = Falloff::SmoothStep;
        Ok(s)
    }

    /// The falloff between beam and cutoff.
    pub fn falloff_kind(&self) -> Falloff {
        self.falloff
    }

    /// The axis as given.
    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// The unit axis.
    pub fn axis(&self) -> Vec3 {
        self.axis
    }

    /// The cutoff angle, degrees.
    pub fn cutoff_angle(&self) -> f32 {
        self.cutoff_deg
    }

    /// The beam width, degrees.
    pub fn beam_width(&self) -> f32 {
        self.beam_deg
    }

    /// The falloff `f` (Mitsuba's, or glTF's for [`SpotLight::smooth`])
    /// for a direction of emission at `cos_theta` from the axis, in [0, 1].
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        if !(cos_theta > self.cos_cutoff) {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else if self.falloff != Falloff::Linear {
            let t = (cos_theta - self.cos_cutoff) / (self.cos_beam - self.cos_cutoff);
            let t = t.clamp(0.0, 1.0);
            if self.falloff == Falloff::Smooth {
                t * t
            } else {
                t * t * (3.0 - 2.0 * t)
            }
        } else {
            ((self.cutoff - cos_theta.min(1.0).acos()) * self.inv_transition).clamp(0.0, 1.0)
        }
    }

    /// The light as seen from `from`: `None` when `from` is at the light or
    /// outside the cone.
    pub fn sample_li(&self, from: &SurfacePoint) -> Option<DeltaLightSample> {
        let delta = self.position - from.p;
        let dist2 = delta.length_squared();
        if !(dist2 > 0.0) || !dist2.is_finite() {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = delta / dist;
        let f = self.falloff(self.axis.dot(-wi));
        if f == 0.0 {
            return None;
        }
        // a point in empty space, as for a point light
        let light = SurfacePoint {
            p: self.position,
            p_err: Vec3::ZERO,
            n: -wi,
        };
        Some(DeltaLightSample {
            wi,
            li: self.intensity * (f / dist2),
            dist,
            pdf: 1.0,
            shadow: spawn_ray_to(from, &light),
        })
    }

    /// `int f dw` over the sphere, in `f64`: `2 pi (1 - (sin c - sin b) /
    /// (c - b))`, written as `2 pi (1 - cos((c + b) / 2) sinc((c - b) / 2))`
    /// so that a narrow band (or none) loses nothing.
    pub fn solid_angle_weight(&self) -> f64 {
        let c = (self.cutoff_deg as f64).to_radians();
        let b = (self.beam_deg as f64).to_radians();
        if self.falloff != Falloff::Linear {
            // 1 - cos x = 2 sin^2(x / 2), without cancellation; the ramp's
            // mean is 1/3 squared, 1/2 smoothstepped
            let one_minus = |x: f64| 2.0 * (0.5 * x).sin().powi(2);
            let (ob, oc) = (one_minus(b), one_minus(c));
            let mean = if self.falloff == Falloff::Smooth {
                1.0 / 3.0
            } else {
                0.5
            };
            return 2.0 * std::f64::consts::PI * (ob + (oc - ob) * mean);
        }
        let h = 0.5 * (c - b);
        let sinc = if h < 1e-4 {
            1.0 - h * h / 6.0
        } else {
            h.sin() / h
        };
        let m = 0.5 * (c + b);
        // 1 - cos(m) sinc(h) = (1 - cos m) + cos m (1 - sinc h), both >= 0
        let one_minus_cos_m = 2.0 * (0.5 * m).sin().powi(2);
        let one_minus_sinc = if h < 1e-4 { h * h / 6.0 } else { 1.0 - sinc };
        2.0 * std::f64::consts::PI * (one_minus_cos_m + m.cos() * one_minus_sinc)
    }

    /// Power for light selection: luminance of `I` times
    /// [`SpotLight::solid_angle_weight`], in `f64`.
    pub fn power(&self) -> f64 {
        crate::math::luminance_f64(self.intensity).max(0.0) * self.solid_angle_weight()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn at(p: Vec3) -> SurfacePoint {
        SurfacePoint {
            p,
            p_err: Vec3::ZERO,
            n: Vec3::Y,
        }
    }

    fn down(cutoff: f32, beam: Option<f32>) -> SpotLight {
        SpotLight::new(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, Vec3::ONE, cutoff, beam).unwrap()
    }

    /// glTF's falloff (the square of the ramp in the cosine) and pbrt-v4's
    /// (its smoothstep), and their integrals over the sphere against a
    /// midpoint rule in the cosine.
    #[test]
    fn smooth_falloffs_are_gltfs_and_pbrts() {
        let (inner, outer) = (10f32.to_radians(), 40f32.to_radians());
        let smooth = SpotLight::smooth(Vec3::ZERO, -Vec3::Y, Vec3::ONE, inner, outer).unwrap();
        let step = SpotLight::smoothstep(Vec3::ZERO, -Vec3::Y, Vec3::ONE, inner, outer).unwrap();
        let c = 0.5 * (inner.cos() + outer.cos());
        for (s, mid) in [(smooth, 0.25), (step, 0.5)] {
            assert_eq!(s.falloff(1.0), 1.0);
            assert_eq!(s.falloff(inner.cos() + 1e-6), 1.0);
            assert!((s.falloff(c) - mid).abs() < 1e-5, "{}", s.falloff(c));
            assert_eq!(s.falloff(outer.cos() - 1e-6), 0.0);
            let n = 200_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let mu = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                sum += s.falloff(mu as f32) as f64;
            }
            let numeric = 2.0 * PI * sum * 2.0 / n as f64;
            let w = s.solid_angle_weight();
            assert!((numeric - w).abs() < 1e-4 * w, "{numeric} vs {w}");
        }
        // an inner cone of 0 is allowed; inner >= outer is not
        assert!(SpotLight::smooth(Vec3::ZERO, Vec3::Y, Vec3::ONE, 0.0, 0.5).is_ok());
        assert!(SpotLight::smooth(Vec3::ZERO, Vec3::Y, Vec3::ONE, 0.5, 0.5).is_err());
        assert!(SpotLight::smooth(Vec3::ZERO, Vec3::Y, Vec3::ONE, 0.1, 2.0).is_err());
    }

    #[test]
    fn falloff_is_mitsubas() {
        let s = down(30.0, Some(10.0));
        let f = |deg: f32| s.falloff(deg.to_radians().cos());
        assert_eq!(f(0.0), 1.0);
        assert_eq!(f(9.9), 1.0);
        assert!((f(20.0) - 0.5).abs() < 1e-4, "{}", f(20.0));
        assert!((f(25.0) - 0.25).abs() < 1e-4, "{}", f(25.0));
        assert_eq!(f(30.5), 0.0);
        assert_eq!(f(120.0), 0.0);
        // the default beam is 3/4 of the cutoff
        assert_eq!(down(20.0, None).beam_width(), 15.0);
        // a hard cone: no band, no division by zero
        let hard = down(20.0, Some(20.0));
        assert_eq!(hard.falloff(19.9f32.to_radians().cos()), 1.0);
        assert_eq!(hard.falloff(20.1f32.to_radians().cos()), 0.0);
    }

    #[test]
    fn radiance_is_intensity_times_falloff_over_r2() {
        let s = SpotLight::new(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, -3.0, 0.0),
            Vec3::new(4.0, 8.0, 12.0),
            40.0,
            Some(20.0),
        )
        .unwrap();
        let ls = s.sample_li(&at(Vec3::ZERO)).unwrap();
        assert_eq!(ls.li, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(ls.wi, Vec3::Y);
        assert_eq!(ls.pdf, 1.0);
        // 30 degrees off the axis: half way through the band
        let x = 2.0 * 30f32.to_radians().tan();
        let ls = s.sample_li(&at(Vec3::new(x, 0.0, 0.0))).unwrap();
        let r2 = 4.0 + x * x;
        assert!((ls.li.x - 4.0 * 0.5 / r2).abs() < 1e-4 * ls.li.x);
        // outside the cone and at the light: nothing
        assert!(s.sample_li(&at(Vec3::new(5.0, 0.0, 0.0))).is_none());
        assert!(s.sample_li(&at(Vec3::new(0.0, 3.0, 0.0))).is_none());
        assert!(s.sample_li(&at(s.position)).is_none());
    }

    #[test]
    fn power_integrates_the_falloff() {
        for (c, b) in [(30.0f32, 10.0f32), (20.0, 15.0), (90.0, 1.0), (5.0, 5.0)] {
            let s = down(c, Some(b));
            // midpoint rule over theta in f64
            let n = 200_000;
            let (cr, br) = ((c as f64).to_radians(), (b as f64).to_radians());
            let mut sum = 0.0;
            for k in 0..n {
                let t = (k as f64 + 0.5) / n as f64 * cr;
                let f = if t <= br { 1.0 } else { (cr - t) / (cr - br) };
                sum += f * t.sin() * cr / n as f64;
            }
            let want = 2.0 * PI * sum;
            let got = s.solid_angle_weight();
            assert!((got / want - 1.0).abs() < 1e-6, "{c} {b}: {got} vs {want}");
            assert!((s.power() / got - 1.0).abs() < 1e-6);
        }
        // a hard cone of 90 degrees is a hemisphere
        assert!((down(90.0, Some(90.0)).solid_angle_weight() - 2.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn bad_angles_and_directions_are_refused() {
        let mk = |d: Vec3, c: f32, b: Option<f32>| SpotLight::new(Vec3::ZERO, d, Vec3::ONE, c, b);
        assert!(mk(Vec3::ZERO, 20.0, None).is_err());
        assert!(mk(Vec3::new(f32::NAN, 1.0, 0.0), 20.0, None).is_err());
        for (c, b) in [(0.0, None), (91.0, None), (-5.0, None), (f32::NAN, None)] {
            assert!(mk(Vec3::Y, c, b).is_err(), "{c}");
        }
        assert!(
            mk(Vec3::Y, 20.0, Some(25.0))
                .unwrap_err()
                .contains("beam_width")
        );
        assert!(mk(Vec3::Y, 20.0, Some(0.0)).is_err());
        assert!(mk(Vec3::Y, 20.0, Some(f32::INFINITY)).is_err());
        assert!(mk(Vec3::Y, 90.0, Some(90.0)).is_ok());
    }
}
