//! A rough metal: the Torrance-Sparrow microfacet BRDF with conductor Fresnel,
//! `f = D(h) G2(wo, wi) F(wo . h) / (4 cos theta_o cos theta_i)` with
//! `h = normalize(wo + wi)` (Walter et al. 2007, "Microfacet Models for
//! Refraction through Rough Surfaces", eq. 20; pbrt-v4, section 9.6,
//! "Roughness Using Microfacet Theory"). `D`, the Smith masking `G1`, the
//! height-correlated `G2` and the visible-normal sampling come from
//! [`super::microfacet`] (GGX: Heitz 2018; Beckmann: Heitz and d'Eon 2014,
//! also visible normals, not `D(h) cos` sampling); the Fresnel term is
//! [`super::fresnel::fr_conductor`] with the complex index `eta + i k`.
//!
//! Sampling draws `h` from the visible normals of `wo` and reflects `wo`
//! about it, so `pdf(wi) = D_wo(h) / (4 wo . h) = G1(wo) D(h) / (4 cos
//! theta_o)` and the weight is `F(wo . h) G2 / G1(wo)`, never above `F`. A
//! reflected direction below the horizon is returned as `None` (the missing
//! probability is the single-scattering energy loss of the Smith model).
//!
//! Roughness below [`Microfacet::SMOOTH_ALPHA`] is a smooth metal: a delta
//! lobe in the mirror direction with weight `F(cos theta_o)`.
//!
//! Reflection only: `wo.z <= 0` or `wi.z <= 0` gives zero.
//!
//! Scene form: `material = { type = "conductor", alpha = 0.2, eta = [r, g,
//! b], k = [r, g, b], distribution = "ggx" }` (or `"beckmann"`).

use super::fresnel::{fr_conductor, reflect};
use super::microfacet::Microfacet;
use super::mirror::specular_reflection;
use super::{BsdfSample, Bxdf};
use crate::math::{Vec2, Vec3};

/// A rough (or smooth) conductor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conductor {
    /// Real part of the complex index of refraction, per channel.
    pub eta: Vec3,
    /// Imaginary part (absorption), per channel, `>= 0`.
    pub k: Vec3,
    /// The microfacet distribution and its roughness.
    pub microfacet: Microfacet,
}

impl Conductor {
    /// Checks that `eta` and `k` are finite and `>= 0` and not both zero in
    /// any channel (the Fresnel equations divide by `(eta + i k)^2`), and
    /// that the roughness is finite and `>= 0`.
    pub fn validate(&self) -> Result<(), String> {
        let (e, k) = (self.eta, self.k);
        let ok = e.is_finite()
            && k.is_finite()
            && e.min_element() >= 0.0
            && k.min_element() >= 0.0
            && (e + k).cmpgt(Vec3::ZERO).all();
        if !ok {
            return Err(format!(
                "`eta` and `k` must be finite numbers >= 0, not both 0 in a channel, \
                 got eta [{}, {}, {}] and k [{}, {}, {}]",
                e.x, e.y, e.z, k.x, k.y, k.z
            ));
        }
        super::check_alpha(self.microfacet.alpha)
    }

    /// Fresnel reflectance for a cosine between `wo` and the (micro)normal.
    pub fn fresnel(&self, cos: f32) -> Vec3 {
        fr_conductor(cos, self.eta, self.k)
    }
}

impl Conductor {
    /// The half vector of `(wo, wi)` and `|wo + wi|`, for a rough
    /// conductor and both directions above the surface; `None` where the
    /// BSDF is 0 there (smooth, below, or opposite directions).
    #[inline]
    fn half(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32)> {
        if self.microfacet.is_smooth() || !(wo.z > 0.0 && wi.z > 0.0) {
            return None;
        }
        let sum = wo + wi;
        let len = sum.length();
        (len > 0.0).then(|| (sum / len, len))
    }

    /// The sample [`Bxdf::sample`] makes of the visible normal `h` (which
    /// [`Microfacet::sample_visible`] or, for a batch's lanes,
    /// [`crate::bsdf::microfacet::ggx_visible_normals_lanes`] and
    /// [`Microfacet::visible_normal_from`] gave), for `wo.z > 0`.
    #[inline]
    pub fn sample_at_normal(&self, wo: Vec3, h: Vec3) -> Option<BsdfSample> {
        let wi = reflect(wo, h);
        if !(wi.z > 0.0) {
            return None;
        }
        let (f, pdf) = self.eval_and_pdf(wo, wi);
        BsdfSample {
            wi,
            f,
            pdf,
            delta: false,
        }
        .checked()
    }

    /// [`Bxdf::eval`] and [`Bxdf::pdf`] at `(wo, wi)`, bit for bit, with
    /// the half vector, `D` and `wo`'s `Lambda` computed once: a BSDF
    /// sample needs both (the same steps in the same order as the two
    /// methods; `tests` compares them).
    #[inline]
    fn eval_and_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let Some((h, len)) = self.half(wo, wi) else {
            return (Vec3::ZERO, 0.0);
        };
        let d = self.microfacet.d(h);
        if !(d > 0.0) {
            // pdf: G1 d / (4 wo.z) is 0, or NaN (then 0) for a NaN d
            return (Vec3::ZERO, 0.0);
        }
        let (g, g1) = self.microfacet.g_and_g1(wo, wi);
        let f = self.fresnel(0.5 * len) * (d * g / (4.0 * (wo.z * wi.z)));
        let p = g1 * d / (4.0 * wo.z);
        (
            if f.is_finite() { f } else { Vec3::ZERO },
            if p.is_finite() { p } else { 0.0 },
        )
    }
}

impl Bxdf for Conductor {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        // Every step is symmetric in wo and wi, bit for bit: wo . h = wi . h =
        // |wo + wi| / 2 (no cancellation in a dot product), and sums and
        // products in commuted order round alike.
        let Some((h, len)) = self.half(wo, wi) else {
            return Vec3::ZERO;
        };
        let d = self.microfacet.d(h);
        if !(d > 0.0) {
            return Vec3::ZERO;
        }
        let g = self.microfacet.g(wo, wi);
        let f = self.fresnel(0.5 * len) * (d * g / (4.0 * (wo.z * wi.z)));
        if f.is_finite() { f } else { Vec3::ZERO }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((h, _)) = self.half(wo, wi) else {
            return 0.0;
        };
        // D_wo(h) / (4 wo . h), with D_wo(h) = G1(wo) (wo . h) D(h) / wo.z
        let p = self.microfacet.g1(wo) * self.microfacet.d(h) / (4.0 * wo.z);
        if p.is_finite() { p } else { 0.0 }
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        if self.microfacet.is_smooth() {
            return specular_reflection(wo, self.fresnel(wo.z), 1.0);
        }
        let h = self.microfacet.sample_visible(wo, u)?;
        self.sample_at_normal(wo, h)
    }

    fn is_delta(&self) -> bool {
        self.microfacet.is_smooth()
    }

    fn has_delta_component(&self) -> bool {
        self.microfacet.is_smooth()
    }

    /// The visible-normal density of `wi` is `G1(wo) D(h) / (4 wo.z)`; at
    /// `h` the normal (`wi` the mirror direction, above the surface) `D` is
    /// `1 / (pi alpha^2)` for GGX and Beckmann alike, and `G1(wo) / wo.z >= 1`
    /// for `alpha <= 1` (for GGX it is `2 / (cos + sqrt(cos^2 + alpha^2
    /// sin^2))`), so the peak is at least `1 / (4 pi alpha^2)`.
    fn lobe_peak_pdf(&self) -> f32 {
        let a = self.microfacet.alpha;
        if a <= 1.0 {
            1.0 / (4.0 * std::f32::consts::PI * a * a)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::{Distribution, Masking};

    #[test]
    fn a_sample_carries_eval_and_pdf_bit_for_bit() {
        // the sample computes both at once; MIS needs them equal to the
        // separate calls, bit for bit
        let mut n = 0;
        for distribution in [Distribution::Ggx, Distribution::Beckmann] {
            for masking in [Masking::HeightCorrelated, Masking::Separable] {
                for alpha in [0.02f32, 0.1, 0.5, 1.3] {
                    let c = Conductor {
                        eta: Vec3::new(0.2, 0.92, 1.1),
                        k: Vec3::new(3.9, 2.45, 2.2),
                        microfacet: Microfacet::new(distribution, alpha).with_masking(masking),
                    };
                    for i in 0..200 {
                        let t = (i as f32 + 0.5) / 200.0;
                        let wo = Vec3::new(0.9 * t - 0.3, 0.4 - 0.5 * t, 0.05 + t).normalize();
                        let u = Vec2::new((7.0 * t).fract(), (13.0 * t).fract());
                        if let Some(s) = c.sample(wo, u) {
                            let (f, pdf) = (c.eval(wo, s.wi), c.pdf(wo, s.wi));
                            assert_eq!(
                                s.f.to_array().map(f32::to_bits),
                                f.to_array().map(f32::to_bits)
                            );
                            assert_eq!(s.pdf.to_bits(), pdf.to_bits(), "{distribution:?} {alpha}");
                            n += 1;
                        }
                    }
                }
            }
        }
        assert!(n > 2000, "{n} samples");
    }

    #[test]
    fn smooth_is_a_mirror_with_conductor_fresnel() {
        let c = Conductor {
            eta: Vec3::new(0.2, 0.92, 1.1),
            k: Vec3::new(3.9, 2.45, 2.2),
            microfacet: Microfacet::new(Distribution::Ggx, 0.0),
        };
        let wo = Vec3::new(0.0, 0.6, 0.8);
        let s = c.sample(wo, Vec2::splat(0.3)).unwrap();
        assert!(s.delta && c.is_delta());
        assert_eq!(s.wi, Vec3::new(0.0, -0.6, 0.8));
        assert!((s.weight() - c.fresnel(0.8)).abs().max_element() < 1e-6);
        assert_eq!(c.eval(wo, s.wi), Vec3::ZERO);
        assert_eq!(c.pdf(wo, s.wi), 0.0);
    }

    #[test]
    fn lobe_peak_pdf_bounds_the_density_at_the_mirror_direction() {
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [1e-3, 0.01, 0.05, 0.1, 0.3, 0.7, 1.0] {
                let c = Conductor {
                    eta: Vec3::splat(0.2),
                    k: Vec3::splat(3.9),
                    microfacet: Microfacet::new(dist, alpha),
                };
                let floor = c.lobe_peak_pdf();
                assert!(floor > 0.0 && floor.is_finite(), "{dist:?} {alpha}");
                // from normal incidence to 0.01 above the horizon
                for i in 0..=99 {
                    let cos = 1.0 - i as f32 / 100.0;
                    let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                    let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
                    let pdf = c.pdf(wo, mirror);
                    assert!(
                        pdf >= floor * (1.0 - 1e-4),
                        "{dist:?} alpha {alpha} cos {cos}: {pdf} < {floor}"
                    );
                }
            }
        }
        // rougher than 1 claims nothing
        let rough = Conductor {
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.9),
            microfacet: Microfacet::new(Distribution::Ggx, 1.5),
        };
        assert_eq!(rough.lobe_peak_pdf(), 0.0);
    }
}
