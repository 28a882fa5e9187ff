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

use super::fresnel::{fr_conductor, fr_conductor_channel, reflect};
use super::microfacet::{Microfacet, ggx_d, ggx_lambda};
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

/// The parameters of a batch's rough GGX conductors, one lane each
/// ([`samples_at_normals_lanes`]); a lane without one holds any finite
/// values.
#[derive(Debug, Clone, Copy)]
pub struct ConductorLanes<const N: usize> {
    /// [`Microfacet::alpha`].
    pub alpha: [f32; N],
    /// [`Conductor::eta`], channel by channel.
    pub eta: [[f32; N]; 3],
    /// [`Conductor::k`], channel by channel.
    pub k: [[f32; N]; 3],
    /// The masking is [`super::Masking::Separable`] (else height-correlated).
    pub separable: [bool; N],
}

/// What [`Conductor::sample_at_normal`] computes before its checks, for
/// every lane: `wi`, `f` and `pdf` (meaningful where `wi.z > 0`).
#[derive(Debug, Clone, Copy)]
pub struct LaneSamples<const N: usize> {
    /// The reflected direction.
    pub wi: [[f32; N]; 3],
    /// The BSDF's value there.
    pub f: [[f32; N]; 3],
    /// Its density.
    pub pdf: [f32; N],
}

/// [`Conductor::sample_at_normal`] of every lane `j` of a batch whose
/// conductors are rough GGX ones (`c`), seen from `wo[..][j]`, for the
/// visible normal `h[..][j]` (issue 37). One loop without a branch or a
/// call, which the compiler turns into vector code for the caller's
/// instruction set; each lane runs `eval_and_pdf`'s steps through the
/// functions the scalar path calls (`ggx_d`, `ggx_lambda`,
/// `fr_conductor_channel`), so each gets its bits (`tests` compares them).
#[inline(always)]
pub fn samples_at_normals_lanes<const N: usize>(
    c: &ConductorLanes<N>,
    wo: &[[f32; N]; 3],
    h: &[[f32; N]; 3],
) -> LaneSamples<N> {
    let mut out = LaneSamples {
        wi: [[0.0; N]; 3],
        f: [[0.0; N]; 3],
        pdf: [0.0; N],
    };
    for j in 0..N {
        let wo = Vec3::new(wo[0][j], wo[1][j], wo[2][j]);
        let wi = reflect(wo, Vec3::new(h[0][j], h[1][j], h[2][j]));
        (out.wi[0][j], out.wi[1][j], out.wi[2][j]) = (wi.x, wi.y, wi.z);
        // the half vector (`half`; both directions above, by the caller's
        // checks)
        let sum = wo + wi;
        let len = sum.length();
        let hh = sum / len;
        // D (GGX), 0 below the horizon
        let a = c.alpha[j];
        let (sin2, cos2) = (hh.x * hh.x + hh.y * hh.y, hh.z * hh.z);
        let d = if hh.z > 0.0 {
            ggx_d(a * a, sin2, cos2)
        } else {
            0.0
        };
        let (lo, li) = (ggx_lambda(a, wo), ggx_lambda(a, wi));
        let g1 = 1.0 / (1.0 + lo);
        let g = if c.separable[j] {
            g1 * (1.0 / (1.0 + li))
        } else {
            1.0 / (1.0 + (lo + li))
        };
        let scale = d * g / (4.0 * (wo.z * wi.z));
        let f: [f32; 3] = std::array::from_fn(|ch| {
            fr_conductor_channel(0.5 * len, c.eta[ch][j], c.k[ch][j]) * scale
        });
        let p = g1 * d / (4.0 * wo.z);
        // zero where `half` or `D` gives none, or a value is not finite
        let some = len > 0.0 && d > 0.0;
        let f_ok = some && f.iter().all(|v| v.is_finite());
        for (out, f) in out.f.iter_mut().zip(f) {
            out[j] = if f_ok { f } else { 0.0 };
        }
        out.pdf[j] = if some && p.is_finite() { p } else { 0.0 };
    }
    out
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

    #[test]
    fn the_lanes_samples_are_each_lanes_scalar_sample() {
        use crate::bsdf::microfacet::ggx_visible_normals_lanes;
        use crate::sampler::Sampler;
        use crate::sampling::square_to_uniform_sphere;
        let mut s = Sampler::new(9, 8, 7);
        // metals of the usual tables, a dielectric-like one (k = 0, the
        // a^2 branch below zero) and a grazing-friendly eta near 1
        let metals = [
            (Vec3::new(0.2, 0.92, 1.1), Vec3::new(3.9, 2.45, 2.14)),
            (Vec3::new(0.14, 0.37, 1.44), Vec3::new(4.2, 2.6, 2.3)),
            (Vec3::new(1.5, 1.5, 1.5), Vec3::ZERO),
            (Vec3::new(1.0, 1.02, 0.98), Vec3::new(0.0, 0.01, 0.3)),
        ];
        let mut compared = 0;
        for round in 0..300 {
            let mut c = ConductorLanes {
                alpha: [0.0; 16],
                eta: [[0.0; 16]; 3],
                k: [[0.0; 16]; 3],
                separable: [false; 16],
            };
            let (mut wo, mut u) = ([[0.0; 16]; 3], [[0.0; 16]; 2]);
            let mut scalar = Vec::new();
            for j in 0..16 {
                let (eta, k) = metals[(j + round) % 4];
                let alpha = [0.002, 0.05, 0.3, 1.0, 2.5][(j + 3 * round) % 5];
                let masking = [Masking::HeightCorrelated, Masking::Separable][(j + round / 2) % 2];
                let m = Conductor {
                    eta,
                    k,
                    microfacet: Microfacet {
                        distribution: Distribution::Ggx,
                        alpha,
                        masking,
                    },
                };
                c.alpha[j] = alpha;
                c.separable[j] = masking == Masking::Separable;
                for ch in 0..3 {
                    (c.eta[ch][j], c.k[ch][j]) = (eta[ch], k[ch]);
                }
                let w = square_to_uniform_sphere(s.next_2d());
                (wo[0][j], wo[1][j], wo[2][j]) = (w.x, w.y, w.z);
                let v = s.next_2d();
                (u[0][j], u[1][j]) = (v.x, v.y);
                scalar.push((m, w, v));
            }
            let h = ggx_visible_normals_lanes(&c.alpha, &wo, &u);
            let got = samples_at_normals_lanes(&c, &wo, &h);
            for (j, (m, w, v)) in scalar.into_iter().enumerate() {
                let want = m.sample(w, v);
                let lane = m
                    .microfacet
                    .visible_normal_from(w, Vec3::new(h[0][j], h[1][j], h[2][j]))
                    .and_then(|_| {
                        let wi = Vec3::new(got.wi[0][j], got.wi[1][j], got.wi[2][j]);
                        (wi.z > 0.0).then_some(())?;
                        BsdfSample {
                            wi,
                            f: Vec3::new(got.f[0][j], got.f[1][j], got.f[2][j]),
                            pdf: got.pdf[j],
                            delta: false,
                        }
                        .checked()
                    });
                let bits = |b: Option<BsdfSample>| {
                    b.map(|b| {
                        (
                            b.wi.to_array().map(f32::to_bits),
                            b.f.to_array().map(f32::to_bits),
                            b.pdf.to_bits(),
                        )
                    })
                };
                compared += usize::from(want.is_some());
                assert_eq!(bits(lane), bits(want), "{m:?} from {w}, u {v}");
            }
        }
        assert!(compared > 1500, "only {compared} samples compared");
    }
}
