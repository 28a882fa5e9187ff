//! Isotropic microfacet distributions with Smith masking-shadowing and
//! sampling of visible normals.
//!
//! - Normal distributions `D(h)`: GGX / Trowbridge-Reitz (Walter et al. 2007,
//!   "Microfacet Models for Refraction through Rough Surfaces", eq. 33) and
//!   Beckmann (ibid., eq. 25; the "Beckmann" of the CS184 microfacet
//!   assignment). Both are normalised so that `integral D(h) cos(theta_h)
//!   dh = 1`.
//! - Masking: Smith's `Lambda` for each distribution, exact (Heitz 2014,
//!   "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
//!   section 5.3: GGX eq. 72, Beckmann eq. 69, which needs `erf`), with
//!   `G1 = 1 / (1 + Lambda)` and the height-correlated masking-shadowing
//!   `G2 = 1 / (1 + Lambda(wo) + Lambda(wi))` (ibid., eq. 99). pbrt-v4 uses
//!   the same (section 9.6.3); its Beckmann `Lambda` is a rational fit, ours
//!   is the closed form. [`Masking::Separable`] takes `G1(wo) G1(wi)`
//!   instead (never larger: it ignores that a point masked in one direction
//!   tends to be shadowed in the other), the form of Mitsuba 3's
//!   `MicrofacetDistribution::G`, which Mitsuba scenes are read with.
//! - Sampling: visible normals, `D_w(h) = G1(w) max(0, w . h) D(h) / cos(theta_w)`
//!   (Heitz 2014, eq. 38), for both distributions:
//!   - GGX: stretch `w` to the isotropic configuration (Heitz 2018,
//!     "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)),
//!     sample its visible hemisphere as a spherical cap (Dupuy and Benyoub
//!     2023, "Sampling Visible GGX Normals with Spherical Caps"), unstretch.
//!   - Beckmann: Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based
//!     BSDFs using the Distribution of Visible Normals" (section 4 and
//!     appendix): stretch, sample the visible slope distribution of the
//!     unit-roughness surface (a Gaussian in `y`; in `x` the inverse of
//!     `CDF(x) ~ erfc(-x) + tan(theta) exp(-x^2) / sqrt(pi)`, found here by
//!     safeguarded Newton iteration in `f64`), rotate, unstretch.

use crate::math::trig::sin_cos_turn;
use crate::math::{Vec2, Vec3};
use std::f32::consts::PI;

/// The shape of the microfacet normal distribution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Distribution {
    /// GGX / Trowbridge-Reitz: long tails, the default.
    #[default]
    Ggx,
    /// Beckmann: a Gaussian distribution of slopes.
    Beckmann,
}

impl std::str::FromStr for Distribution {
    type Err = String;

    /// The scene-file names: `ggx` and `beckmann`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "ggx" => Ok(Distribution::Ggx),
            "beckmann" => Ok(Distribution::Beckmann),
            _ => Err(format!(
                "unknown microfacet distribution `{s}` (expected ggx or beckmann)"
            )),
        }
    }
}

/// How masking and shadowing combine into `G(wo, wi)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Masking {
    /// Height-correlated Smith `G2 = 1 / (1 + Lambda(wo) + Lambda(wi))`
    /// (Heitz 2014, eq. 99; pbrt-v4): the default.
    #[default]
    HeightCorrelated,
    /// Separable Smith `G1(wo) G1(wi)` (Heitz 2014, eq. 98): Mitsuba 3's.
    Separable,
}

impl Masking {
    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Masking::HeightCorrelated => "height-correlated",
            Masking::Separable => "separable",
        }
    }
}

impl std::str::FromStr for Masking {
    type Err = String;

    /// The scene-file names: `height-correlated` and `separable`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "height-correlated" => Ok(Masking::HeightCorrelated),
            "separable" => Ok(Masking::Separable),
            _ => Err(format!(
                "unknown masking `{s}` (expected height-correlated or separable)"
            )),
        }
    }
}

/// An isotropic microfacet distribution of roughness `alpha` (the RMS slope
/// for Beckmann, the width for GGX; `alpha = 0` is a perfect mirror).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Microfacet {
    /// Which distribution.
    pub distribution: Distribution,
    /// Roughness, `>= 0`.
    pub alpha: f32,
    /// How `G` combines the two directions' masking.
    pub masking: Masking,
}

impl Microfacet {
    /// Below this roughness a surface is treated as a perfect specular
    /// reflector (a delta lobe): `D` would overflow `f32` long before the
    /// image could tell the difference (pbrt-v4's `EffectivelySmooth` uses
    /// the same threshold).
    pub const SMOOTH_ALPHA: f32 = 1e-3;

    /// A distribution of the given kind and roughness.
    pub fn new(distribution: Distribution, alpha: f32) -> Self {
        Microfacet {
            distribution,
            alpha,
            masking: Masking::default(),
        }
    }

    /// The same surface with `G` combined as `masking` says.
    pub fn with_masking(self, masking: Masking) -> Self {
        Microfacet { masking, ..self }
    }

    /// The same distribution and masking at roughness `alpha`.
    pub fn with_alpha(self, alpha: f32) -> Self {
        Microfacet { alpha, ..self }
    }

    /// Whether this surface is to be treated as perfectly smooth.
    pub fn is_smooth(&self) -> bool {
        !(self.alpha >= Self::SMOOTH_ALPHA)
    }

    /// The normal distribution `D(h)` for a unit microfacet normal `h`
    /// (per steradian, zero below the horizon).
    pub fn d(&self, h: Vec3) -> f32 {
        if !(h.z > 0.0) {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let sin2 = h.x * h.x + h.y * h.y;
        let cos2 = h.z * h.z;
        match self.distribution {
            Distribution::Ggx => ggx_d(a2, sin2, cos2),
            Distribution::Beckmann => {
                let e = (-(sin2 / cos2) / a2).exp();
                if e == 0.0 {
                    return 0.0;
                }
                e / (PI * a2 * cos2 * cos2)
            }
        }
    }

    /// Smith's `Lambda(w)`: the ratio of masked to visible projected area in
    /// direction `w` (depends only on `|tan(theta)|`).
    pub fn lambda(&self, w: Vec3) -> f32 {
        match self.distribution {
            Distribution::Ggx => ggx_lambda(self.alpha, w),
            Distribution::Beckmann => beckmann_lambda(self.alpha, w),
        }
    }

    /// Smith masking `G1(w) = 1 / (1 + Lambda(w))`.
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Masking-shadowing `G(wo, wi)`, height-correlated or separable
    /// ([`Masking`]); symmetric, bit for bit (the two `Lambda`s are added
    /// first, or the two `G1`s multiplied, both commutative).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.masking {
            Masking::HeightCorrelated => 1.0 / (1.0 + (self.lambda(wo) + self.lambda(wi))),
            Masking::Separable => self.g1(wo) * self.g1(wi),
        }
    }

    /// [`Microfacet::g`] of `(wo, wi)` and [`Microfacet::g1`] of `wo`
    /// together, bit for bit as the two calls give them, with `wo`'s
    /// `Lambda` computed once (a BSDF sample needs both: `f` and `pdf`).
    #[inline]
    pub fn g_and_g1(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let (lo, li) = (self.lambda(wo), self.lambda(wi));
        let g1_wo = 1.0 / (1.0 + lo);
        let g = match self.masking {
            Masking::HeightCorrelated => 1.0 / (1.0 + (lo + li)),
            Masking::Separable => g1_wo * (1.0 / (1.0 + li)),
        };
        (g, g1_wo)
    }

    /// Density of visible normals seen from `w` (`w.z > 0`), per steradian of
    /// `h`: `G1(w) max(0, w . h) D(h) / w.z`.
    pub fn d_visible(&self, w: Vec3, h: Vec3) -> f32 {
        if !(w.z > 0.0) {
            return 0.0;
        }
        let cos = w.dot(h);
        if !(cos > 0.0) {
            return 0.0;
        }
        self.g1(w) * cos * self.d(h) / w.z
    }

    /// A microfacet normal drawn from [`Microfacet::d_visible`] for `w` with
    /// `w.z > 0`, from `u` in `[0, 1)^2`. `None` where the warp leaves the
    /// support (at the edges of the square, or for `w.z <= 0`).
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Option<Vec3> {
        if !(w.z > 0.0) {
            return None;
        }
        let h = match self.distribution {
            Distribution::Ggx => self.sample_visible_ggx(w, u),
            Distribution::Beckmann => self.sample_visible_beckmann(w, u)?,
        };
        (h.is_finite() && h.z > 0.0 && h.dot(w) > 0.0).then_some(h)
    }

    /// Dupuy and Benyoub 2023, "Sampling Visible GGX Normals with
    /// Spherical Caps" (HPG; listing 3): in the stretched configuration the
    /// visible normals of the hemisphere seen from `vh` are `c + vh`, `c`
    /// uniform on the spherical cap `z > -vh.z`, so no frame around `vh` is
    /// built. The same density as Heitz 2018's projected-disk warp, with
    /// about half its dependent square roots and divisions; the points go
    /// elsewhere in the square (`u.x` turns the azimuth, `u.y` moves across
    /// the cap).
    ///
    /// Written without a branch or a call, so that
    /// [`ggx_visible_normals_lanes`] vectorises with this function's bits.
    #[inline(always)]
    fn sample_visible_ggx(&self, w: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        // the hemisphere configuration: stretch
        let vh = Vec3::new(a * w.x, a * w.y, w.z).normalize();
        // a uniform point of the cap z in (-vh.z, 1]
        let (sin_p, cos_p) = sin_cos_turn(u.x);
        let z = (1.0 - u.y) * (1.0 + vh.z) - vh.z;
        let sin_t = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        // the halfway vector, then unstretch
        let h = Vec3::new(sin_t * cos_p, sin_t * sin_p, z) + vh;
        Vec3::new(a * h.x, a * h.y, h.z.max(0.0)).normalize()
    }

    /// [`Microfacet::sample_visible`] given `h`, the GGX visible normal
    /// its numbers give (from [`ggx_visible_normals_lanes`]); the
    /// distribution must be GGX.
    #[inline]
    pub fn visible_normal_from(&self, w: Vec3, h: Vec3) -> Option<Vec3> {
        debug_assert_eq!(self.distribution, Distribution::Ggx);
        (w.z > 0.0 && h.is_finite() && h.z > 0.0 && h.dot(w) > 0.0).then_some(h)
    }

    /// Heitz and d'Eon 2014, section 4.
    fn sample_visible_beckmann(&self, w: Vec3, u: Vec2) -> Option<Vec3> {
        let a = self.alpha;
        // stretch to unit roughness; the azimuth is unchanged
        let ws = Vec3::new(a * w.x, a * w.y, w.z).normalize();
        let sin_t = (ws.x as f64).hypot(ws.y as f64);
        let tan_t = sin_t / ws.z as f64;
        // slopes for a view at azimuth 0
        let sx = visible_slope(tan_t, u.x as f64);
        let sy = visible_slope(0.0, u.y as f64);
        if !(sx.is_finite() && sy.is_finite()) {
            return None;
        }
        // rotate to the view's azimuth
        let (cos_p, sin_p) = if sin_t > 0.0 {
            (ws.x as f64 / sin_t, ws.y as f64 / sin_t)
        } else {
            (1.0, 0.0)
        };
        let x = cos_p * sx - sin_p * sy;
        let y = sin_p * sx + cos_p * sy;
        // unstretch; the normal of slope (x, y) is (-x, -y, 1) normalised
        let m = Vec3::new(-(a as f64 * x) as f32, -(a as f64 * y) as f32, 1.0);
        Some(m.normalize())
    }
}

const SQRT_PI: f64 = 1.772_453_850_905_516;

/// Complementary error function in `f64`, with fractional error below
/// 1.2e-7 everywhere (Press et al., *Numerical Recipes*, 2nd ed., section 6.2,
/// `erfcc`: a Chebyshev fit). The polynomial in `t` goes by Horner's rule
/// over its coefficients: the operations of the nested form, in its order
/// (the same bits), which rustfmt took 12 s to format on every run.
pub fn erfc(x: f64) -> f64 {
    const C: [f64; 9] = [
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = C.iter().rev().fold(0.0, |acc, &c| c + t * acc);
    let r = t * (-z * z - 1.265_512_23 + t * poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Inverse of the cumulative distribution of visible slopes `x` of the
/// unit-roughness Beckmann surface seen from `tan(theta) = tan_t` at azimuth
/// 0 (Heitz and d'Eon 2014, appendix). Up to a constant, the density is
/// `(1 - x tan_t) exp(-x^2)` on `x < cot(theta)`, so the cumulative is
/// `erfc(-x) + tan_t exp(-x^2) / sqrt(pi)`. With `tan_t = 0` it is the
/// Gaussian of the `y` slope. Safeguarded Newton: every step that would leave
/// the bracket bisects instead, so it always converges. Returns `-inf` or the
/// upper end for `u` at the ends of `[0, 1]`; the caller rejects those.
fn visible_slope(tan_t: f64, u: f64) -> f64 {
    let c = if tan_t > 0.0 {
        1.0 / tan_t
    } else {
        f64::INFINITY
    };
    let k = tan_t / SQRT_PI;
    let cdf = |x: f64| {
        let e = (-x * x).exp();
        erfc(-x) + if k > 0.0 { k * e } else { 0.0 }
    };
    let total = cdf(c);
    let target = u * total;
    if !(target > 0.0) {
        return f64::NEG_INFINITY;
    }
    if !(target < total) {
        return c;
    }
    // bracket [lo, hi] with cdf(lo) <= target <= cdf(hi)
    let mut lo = -1.0f64;
    while cdf(lo) > target && lo > -64.0 {
        lo *= 2.0;
    }
    let mut hi = c.min(1.0);
    while cdf(hi) < target && hi < c {
        hi = (hi * 2.0).min(c);
    }
    let mut x = 0.5 * (lo + hi);
    for _ in 0..100 {
        let f = cdf(x) - target;
        if f > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let density = 2.0 / SQRT_PI * (-x * x).exp() * (1.0 - x * tan_t);
        let mut next = x - f / density;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - x).abs() <= 1e-12 * (1.0 + x.abs()) {
            return next;
        }
        x = next;
    }
    x
}

/// GGX's `D` for `alpha^2` and the normal's `sin^2` and `cos^2` (above
/// the horizon): `alpha^2 / (pi (sin^2 + alpha^2 cos^2)^2)`, no `1 - cos^2`
/// cancellation. [`Microfacet::d`] and the lanes' form
/// (`bsdf::samples_at_normals_lanes`) are this function.
#[inline(always)]
pub(crate) fn ggx_d(a2: f32, sin2: f32, cos2: f32) -> f32 {
    let t = sin2 + a2 * cos2;
    a2 / (PI * t * t)
}

/// Beckmann's Smith `Lambda(w)` (Heitz 2014): with `a = 1 / (alpha
/// tan(theta))`, `(erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi))`, in `f64`.
fn beckmann_lambda(alpha: f32, w: Vec3) -> f32 {
    let sin2 = w.x * w.x + w.y * w.y;
    let cos2 = w.z * w.z;
    if sin2 == 0.0 {
        return 0.0;
    }
    if cos2 == 0.0 {
        return f32::INFINITY;
    }
    let a = (w.z.abs() as f64) / (alpha as f64 * (sin2 as f64).sqrt());
    if a == 0.0 {
        return f32::INFINITY;
    }
    let l = 0.5 * (-erfc(a) + (-a * a).exp() / (a * SQRT_PI));
    l.max(0.0) as f32
}

/// GGX's Smith `Lambda(w)`, `(sqrt(1 + a^2 tan^2) - 1) / 2` written without
/// cancellation: 0 along the normal, infinite at the horizon. Selects, no
/// branch, so a loop of it over lanes vectorises; [`Microfacet::lambda`]
/// and the lanes' form are this function.
#[inline(always)]
pub(crate) fn ggx_lambda(alpha: f32, w: Vec3) -> f32 {
    let sin2 = w.x * w.x + w.y * w.y;
    let cos2 = w.z * w.z;
    let x = alpha * alpha * (sin2 / cos2);
    let l = x / (2.0 * (1.0 + (1.0 + x).sqrt()));
    if sin2 == 0.0 {
        0.0
    } else if cos2 == 0.0 || x.is_infinite() {
        f32::INFINITY
    } else {
        l
    }
}

/// The GGX visible normal ([`Microfacet::sample_visible`]'s, before its
/// checks) for every lane `k`: roughness `alpha[k]`, direction
/// `(w[0][k], w[1][k], w[2][k])`, numbers `(u[0][k], u[1][k])`. One loop
/// without a branch, which the compiler turns into vector code for the
/// caller's instruction set, each lane the bits of the scalar call
/// (issue 37: a batch's rough conductors sample their normals together).
#[inline(always)]
pub fn ggx_visible_normals_lanes<const N: usize>(
    alpha: &[f32; N],
    w: &[[f32; N]; 3],
    u: &[[f32; N]; 2],
) -> [[f32; N]; 3] {
    let mut h = [[0.0; N]; 3];
    for k in 0..N {
        let m = Microfacet {
            distribution: Distribution::Ggx,
            alpha: alpha[k],
            masking: Masking::HeightCorrelated,
        };
        let v = m.sample_visible_ggx(
            Vec3::new(w[0][k], w[1][k], w[2][k]),
            Vec2::new(u[0][k], u[1][k]),
        );
        (h[0][k], h[1][k], h[2][k]) = (v.x, v.y, v.z);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;
    use crate::sampling::square_to_uniform_sphere;

    #[test]
    fn the_lanes_ggx_normals_are_each_lanes_scalar_sample() {
        let mut s = Sampler::new(3, 4, 5);
        for round in 0..200 {
            let (mut alpha, mut w, mut u) = ([0.0; 16], [[0.0; 16]; 3], [[0.0; 16]; 2]);
            let mut dirs = [Vec3::ZERO; 16];
            for k in 0..16 {
                // roughnesses from glossy to rough, directions over the
                // whole sphere (a lane below the surface gets no sample)
                alpha[k] = [0.002, 0.05, 0.3, 1.0, 2.5][(k + round) % 5];
                dirs[k] = square_to_uniform_sphere(s.next_2d());
                (w[0][k], w[1][k], w[2][k]) = (dirs[k].x, dirs[k].y, dirs[k].z);
                let v = s.next_2d();
                (u[0][k], u[1][k]) = (v.x, v.y);
            }
            let h = ggx_visible_normals_lanes(&alpha, &w, &u);
            for k in 0..16 {
                let m = Microfacet {
                    distribution: Distribution::Ggx,
                    alpha: alpha[k],
                    masking: Masking::default(),
                };
                let got = m.visible_normal_from(dirs[k], Vec3::new(h[0][k], h[1][k], h[2][k]));
                let want = m.sample_visible(dirs[k], Vec2::new(u[0][k], u[1][k]));
                assert_eq!(
                    got.map(|v| v.to_array().map(f32::to_bits)),
                    want.map(|v| v.to_array().map(f32::to_bits)),
                    "alpha {}, w {}",
                    alpha[k],
                    dirs[k]
                );
            }
        }
    }

    fn spherical(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    /// `integral D(h) cos(theta_h) dh = 1` (the projected microfacet area is
    /// the macro surface's), by a midpoint rule in `(cos^2 theta, phi)`
    /// refined towards the peak.
    #[test]
    fn projected_area_is_one() {
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.05f32, 0.3, 1.0] {
                let m = Microfacet::new(dist, alpha);
                // substitute t = tan^2 theta = alpha^2 s / (1 - s) to spread the peak:
                // D cos dh = D cos sin dtheta dphi; integrate in theta on a
                // fine grid near 0 (f64 accumulation)
                let n = 200_000;
                let mut sum = 0.0f64;
                let tmax = std::f64::consts::FRAC_PI_2;
                for i in 0..n {
                    // theta = tmax * v^2 with v uniform: dense near the pole
                    let v = (i as f64 + 0.5) / n as f64;
                    let th = tmax * v * v;
                    let dth = tmax * 2.0 * v / n as f64;
                    let h = spherical(th as f32, 0.0);
                    sum += m.d(h) as f64 * th.cos() * th.sin() * dth * 2.0 * std::f64::consts::PI;
                }
                // the midpoint rule on this grid and f32 evaluation of D: 1e-3
                assert!((sum - 1.0).abs() < 1e-3, "{dist:?} {alpha}: {sum}");
            }
        }
    }

    /// `integral D_w(h) dh = 1` for every view (the visible projected area of
    /// the microfacets equals the macro surface's, which is what makes Smith's
    /// G1 consistent with D), Monte Carlo over uniform directions.
    #[test]
    fn visible_normals_integrate_to_one() {
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.2f32, 0.7] {
                let m = Microfacet::new(dist, alpha);
                for theta in [0.0f32, 1.0, 1.5] {
                    let w = spherical(theta, 0.4);
                    let mut s = Sampler::new(7, 0, 0);
                    let n = 400_000;
                    let mut sum = 0.0f64;
                    let mut sum2 = 0.0f64;
                    for _ in 0..n {
                        let h = square_to_uniform_sphere(s.next_2d());
                        let x = m.d_visible(w, h) as f64 * 4.0 * std::f64::consts::PI;
                        sum += x;
                        sum2 += x * x;
                    }
                    let mean = sum / n as f64;
                    let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                    // 6 standard errors: a band no sound D/G1 pair leaves
                    assert!(
                        (mean - 1.0).abs() < 6.0 * se,
                        "{dist:?} a={alpha} th={theta}: {mean} +- {se}"
                    );
                }
            }
        }
    }

    #[test]
    fn erfc_values() {
        // erfc(0) = 1, erfc(1) = 0.157299207, erfc(-1) = 1.842700793, erfc(3) = 2.20904970e-5
        assert!((erfc(0.0) - 1.0).abs() < 1e-7);
        assert!((erfc(1.0) - 0.157_299_207).abs() < 1.2e-7 * 0.16);
        assert!((erfc(-1.0) - 1.842_700_793).abs() < 1e-7);
        assert!((erfc(3.0) / 2.209_049_70e-5 - 1.0).abs() < 1.2e-7);
    }

    /// The visible-slope inversion lands on its target cumulative.
    #[test]
    fn visible_slope_inverts_its_cdf() {
        for tan_t in [0.0f64, 0.1, 1.0, 10.0, 1e4] {
            let k = tan_t / SQRT_PI;
            let cdf = |x: f64| erfc(-x) + k * (-x * x).exp();
            let total = if tan_t > 0.0 { cdf(1.0 / tan_t) } else { 2.0 };
            for u in [1e-30f64, 1e-7, 0.1, 0.5, 0.9, 1.0 - 1e-7] {
                let x = visible_slope(tan_t, u);
                assert!(x.is_finite());
                let got = cdf(x) / total;
                assert!(
                    (got - u).abs() <= 1e-9 * u.max(1e-12) + 1e-13,
                    "tan {tan_t} u {u}: x {x} gives {got}"
                );
            }
            assert_eq!(visible_slope(tan_t, 0.0), f64::NEG_INFINITY);
        }
    }

    #[test]
    fn lambda_limits() {
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            let m = Microfacet::new(dist, 0.5);
            assert_eq!(m.lambda(Vec3::Z), 0.0);
            assert_eq!(m.g1(Vec3::X), 0.0);
            let l = m.lambda(spherical(1.0, 0.3));
            assert!(l > 0.0 && l.is_finite());
            // monotone in theta
            let mut prev = 0.0;
            for i in 1..90 {
                let l = m.lambda(spherical((i as f32).to_radians(), 0.0));
                assert!(l >= prev, "{dist:?} at {i} deg");
                prev = l;
            }
        }
    }

    #[test]
    fn separable_masking_is_the_product_and_never_above_the_correlated() {
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.05, 0.3, 1.0] {
                let corr = Microfacet::new(dist, alpha);
                let sep = corr.with_masking(Masking::Separable);
                assert_eq!(sep.with_alpha(0.7).masking, Masking::Separable);
                for (a, b) in [(5, 10), (40, 70), (80, 85), (0, 60), (89, 1)] {
                    let wo = spherical((a as f32).to_radians(), 0.4);
                    let wi = spherical((b as f32).to_radians(), 2.5);
                    let (gc, gs) = (corr.g(wo, wi), sep.g(wo, wi));
                    assert_eq!(gs, corr.g1(wo) * corr.g1(wi));
                    assert_eq!(gs.to_bits(), sep.g(wi, wo).to_bits());
                    // G1 G1 = 1 / (1 + Lo + Li + Lo Li) <= 1 / (1 + Lo + Li)
                    assert!(
                        gs <= gc * (1.0 + 1e-6),
                        "{dist:?} {alpha} {a} {b}: {gs} > {gc}"
                    );
                    // equal where one direction is unmasked
                    if a == 0 {
                        assert!((gs - gc).abs() <= 1e-6 * gc);
                    }
                }
            }
        }
        assert_eq!("separable".parse::<Masking>(), Ok(Masking::Separable));
        assert_eq!(
            Masking::HeightCorrelated.name().parse::<Masking>(),
            Ok(Masking::HeightCorrelated)
        );
        assert!("smith".parse::<Masking>().is_err());
    }
}
