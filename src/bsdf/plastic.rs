//! Plastic: a Lambertian base under a smooth or rough dielectric coating.
//!
//! The model is Mitsuba 0.6's `plastic` / `roughplastic` (Jakob, *Mitsuba
//! documentation*, section 8.2; the base term goes back to Weidlich and
//! Wilkie 2007, "Arbitrarily Layered Micro-Facet Surfaces"), made exactly
//! energy-conserving for a white base:
//!
//! - **Coat:** white specular reflection off the dielectric interface of index
//!   `ior`, weighted by the exact Fresnel term: a delta lobe of weight
//!   `F(cos theta_o)` when smooth, or the GGX microfacet BRDF `D G2 F(wo . h)
//!   / (4 cos theta_o cos theta_i)` when rough (Walter et al. 2007, see
//!   [`super::conductor`] for the same lobe with metal Fresnel).
//! - **Base:** light that the coat lets through is scattered by the
//!   Lambertian base of albedo `rho`, bounces between base and coat, and leaves
//!   through the coat:
//!   `f_d = rho (1 - E(mu_i)) (1 - E(mu_o)) / (pi eta^2 (1 - rho r_int))`.
//!   `E(mu)` is the coat's directional albedo from outside (the Fresnel
//!   reflectance `F(mu)` when smooth, a precomputed table of the rough
//!   specular lobe's albedo when rough), `1 / eta^2` is the widening of the
//!   cone as radiance leaves the denser coat, and `1 / (1 - rho r_int)` sums
//!   the internal bounces, with `r_int` the coat's diffuse reflectance seen
//!   from inside.
//! - **`r_int`.** Reciprocity of the interface gives `eta^2 (1 - r_int) = 1 -
//!   E_avg`, with `E_avg = 2 integral E(mu) mu dmu` the coat's hemispherical
//!   albedo from outside (for a smooth coat this is the classical identity
//!   between the internal and external diffuse Fresnel reflectances). Using it
//!   as the definition of `r_int` for the rough coat too makes a white base
//!   (`rho = 1`) conserve energy: the directional albedo is then
//!   `E(mu_o) + (1 - E(mu_o)) = 1` for every `wo`, exactly for the smooth
//!   coat and up to the table's error (about 1e-3) for the rough one. For the
//!   smooth coat this is exactly Mitsuba's `plastic`.
//! - `f_d` is symmetric in `wo` and `wi`, so the BRDF is reciprocal.
//!
//! **Sampling.** The first random number picks the coat with probability
//! `p_s = E(mu_o) / (E(mu_o) + (1 - E(mu_o)) A)`, the ratio of the coat's
//! albedo to the sum of both lobes' albedos (`A` is the base lobe's albedo
//! factor averaged over the channels), and is then rescaled to `[0, 1)` for
//! the chosen lobe: visible GGX normals for the rough coat, the mirror
//! direction for the smooth coat (a delta sample with `pdf = p_s`), cosine
//! weighting for the base. The returned pdf of a non-delta sample is the
//! mixture `p_s pdf_coat + (1 - p_s) cos / pi`.
//!
//! **Linear base (Mitsuba's default, `nonlinear = false`).** Mitsuba sums the
//! internal bounces as `1 / (1 - r_int)` instead of `1 / (1 - rho r_int)`
//! unless its `nonlinear` flag is set: the base's colour then scales
//! linearly with `rho`, and a white base is no longer exactly
//! energy-conserving. [`Plastic::with_options`] offers both, so that a
//! Mitsuba scene renders as Mitsuba means it; the TOML default stays the
//! energy-conserving `nonlinear = true`. Under a rough coat the linear
//! base also takes Mitsuba 3's `r_int`: not reciprocity's, but a 64-node
//! sum over the rough coat's reflectance from inside, which keeps the
//! microfacet model's energy loss (and the sum's own 1.5 % shortfall), so
//! it is smaller: with reciprocity's value a Beckmann coat at alpha 0.15
//! rendered 4.8 % brighter in red than Mitsuba's `roughplastic`, with this
//! one 0.6 % (`benches/studies/roughplastic_gap.py`). The linear rough base
//! also takes Mitsuba 3's transmittance `T(mu)` through the coat in place of
//! `1 - E(mu)` ([`mitsuba_transmittance`]: the microfacet model loses energy
//! going in and out as it does in reflection), without which its
//! directional albedo was up to 51 % above Mitsuba's (GGX, alpha 0.6, 75
//! degrees); with it, every case of tests/rough_plastic.rs is within 0.3 %.
//! A linear rough coat's build then integrates 128 more directional
//! integrals, twice as many as its table.
//!
//! The coat uses GGX unless [`Plastic::with_options`] picks Beckmann (as
//! Mitsuba's `roughplastic` does by default). Build a `Plastic` once per
//! material: [`Plastic::new`]
//! integrates `E(mu)` (about 15 ms for a rough coat, measured in the test
//! profile); evaluation then costs a table lookup.
//!
//! Scene form: `material = { type = "plastic", diffuse = [r, g, b], ior = 1.5,
//! alpha = 0.1 }` (`alpha = 0` is smooth).

use super::fresnel::{fr_dielectric, reflect, refract};
use super::microfacet::{Distribution, Masking, Microfacet};
use super::mirror::specular_reflection;
use super::{BsdfSample, Bxdf, choose_lobe, sample_at};
use crate::math::{Vec2, Vec3};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use std::collections::HashMap;
use std::f32::consts::PI;
use std::sync::{Mutex, OnceLock};

/// Nodes of the rough coat's albedo table, at `mu = (i / (N - 1))^3`: dense
/// near grazing, where `E` changes fastest. With [`TABLE_GRID`], the table
/// is within 1.2e-3 of `E` for alpha from 0.002 to 1 (measured against a
/// 256 x 256 grid at 201 angles), which bounds how far a white plastic's
/// albedo strays from 1.
const TABLE: usize = 64;
/// The table's quadrature: an `n x n` midpoint grid over the visible-normal
/// warp, per node.
const TABLE_GRID: usize = 64;
/// Midpoints for `E_avg = 2 integral E(mu) mu dmu`.
const AVG_STEPS: usize = 4096;

/// A rough coat's albedo table, `E(mu)` at the nodes. Tables are shared
/// and live for the process ([`intern`]): a `Plastic` holds references, so
/// it stays small enough to copy per hit (with the table inline it was 304
/// bytes, and copying it showed in profiles as a `memmove` per bounce).
type CoatTable = &'static [f32; TABLE];

/// The table of a smooth coat, which never reads it.
static NO_TABLE: [f32; TABLE] = [0.0; TABLE];

/// The process's copy of `table`: one per distinct table ever built (a
/// scene's plastics, 16 per textured roughness), so loading a scene again
/// adds none.
fn intern(table: [f32; TABLE]) -> CoatTable {
    type Tables = HashMap<[u32; TABLE], CoatTable>;
    static TABLES: OnceLock<Mutex<Tables>> = OnceLock::new();
    let mut tables = TABLES
        .get_or_init(Default::default)
        .lock()
        // a panic elsewhere while holding the lock leaves the map whole
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let shared: &CoatTable = tables
        .entry(table.map(f32::to_bits))
        .or_insert_with(|| Box::leak(Box::new(table)));
    shared
}

/// A diffuse base under a dielectric coat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plastic {
    diffuse: Vec3,
    ior: f32,
    microfacet: Microfacet,
    /// `E(mu)` at the table's nodes (rough coat only).
    coat_albedo: CoatTable,
    /// The linear rough base's transmittance `T(mu)` at the table's nodes:
    /// Mitsuba 3's (see [`mitsuba_transmittance`]), which keeps the energy
    /// the microfacet model loses; `None` where the base takes `1 - E(mu)`
    /// (smooth coats, the nonlinear base).
    coat_transmit: Option<CoatTable>,
    /// Between two levels of a textured roughness ([`PlasticCoats::at`]):
    /// the upper level's albedo and transmittance tables and the weight (in
    /// `(0, 1)`) it gets.
    coat_between: Option<(CoatTable, Option<CoatTable>, f32)>,
    /// `2 integral E(mu) mu dmu`.
    coat_avg: f32,
    /// `eta^2 (1 - r_int)`, the linear base's bounce sum's denominator:
    /// `1 - E_avg` by reciprocity, but for a rough coat Mitsuba's integral
    /// of its reflectance from inside (see [`mitsuba_internal_reflectance`]).
    linear_norm: f32,
    /// `rho / (pi (eta^2 - rho (eta^2 - 1 + E_avg)))` per channel: `f_d`
    /// without the two transmission factors.
    kd: Vec3,
    /// The base lobe's albedo factor `kd pi (1 - E_avg)`, averaged over
    /// channels, for the lobe choice.
    base_albedo: f32,
    /// Internal bounces sum as `1 / (1 - rho r_int)` (true) or
    /// `1 / (1 - r_int)` (false, Mitsuba's default).
    nonlinear: bool,
}

impl Plastic {
    /// A plastic with base albedo `diffuse` (each channel in `[0, 1]`), coat
    /// index `ior` (finite, `>= 1`: the base formula assumes a coat denser
    /// than the air above it) and GGX roughness `alpha` (finite, `>= 0`;
    /// below [`Microfacet::SMOOTH_ALPHA`] the coat is smooth). An error names
    /// the offending scene key.
    pub fn new(diffuse: Vec3, ior: f32, alpha: f32) -> Result<Self, String> {
        Self::with_options(
            diffuse,
            ior,
            alpha,
            Distribution::Ggx,
            Masking::default(),
            true,
        )
    }

    /// [`Plastic::new`] with the coat's microfacet `distribution` and the
    /// base's bounce sum chosen (`nonlinear`, see the module notes).
    pub fn with_options(
        diffuse: Vec3,
        ior: f32,
        alpha: f32,
        distribution: Distribution,
        masking: Masking,
        nonlinear: bool,
    ) -> Result<Self, String> {
        super::check_unit_rgb("diffuse", diffuse)?;
        if !(ior.is_finite() && ior >= 1.0) {
            return Err(format!("`ior` must be a finite number >= 1, got {ior}"));
        }
        super::check_alpha(alpha)?;
        let microfacet = Microfacet::new(distribution, alpha).with_masking(masking);
        let mut p = Plastic {
            diffuse,
            ior,
            microfacet,
            coat_albedo: &NO_TABLE,
            coat_transmit: None,
            coat_between: None,
            coat_avg: 0.0,
            linear_norm: 0.0,
            kd: Vec3::ZERO,
            base_albedo: 0.0,
            nonlinear,
        };
        if !microfacet.is_smooth() {
            p.coat_albedo = tabulate(|mu| rough_coat_albedo(&microfacet, ior, mu));
            if !nonlinear {
                p.coat_transmit = Some(tabulate(|mu| mitsuba_transmittance(&microfacet, ior, mu)));
            }
        }
        let mut avg = 0.0f64;
        for i in 0..AVG_STEPS {
            let mu = (i as f64 + 0.5) / AVG_STEPS as f64;
            avg += p.coat(mu as f32) as f64 * mu;
        }
        p.coat_avg = (2.0 * avg / AVG_STEPS as f64) as f32;
        p.linear_norm = if nonlinear || microfacet.is_smooth() {
            1.0 - p.coat_avg
        } else {
            ior * ior * (1.0 - mitsuba_internal_reflectance(&microfacet, ior))
        };
        p.set_diffuse(diffuse);
        Ok(p)
    }

    /// The same coat over base albedo `diffuse` (each channel in `[0, 1]`;
    /// a texture lookup): the coat's table is kept, only the base terms are
    /// recomputed.
    pub fn with_diffuse(&self, diffuse: Vec3) -> Self {
        let mut p = *self;
        p.set_diffuse(diffuse.clamp(Vec3::ZERO, Vec3::ONE));
        p
    }

    fn set_diffuse(&mut self, diffuse: Vec3) {
        let eta2 = self.ior * self.ior;
        let e_avg = self.coat_avg;
        self.diffuse = diffuse;
        // eta^2 (1 - rho r_int) = eta^2 - rho (eta^2 - 1 + E_avg); linear:
        // eta^2 (1 - r_int), which is 1 - E_avg for a smooth coat
        self.kd = if self.nonlinear {
            diffuse / (PI * (Vec3::splat(eta2) - diffuse * (eta2 - 1.0 + e_avg)))
        } else {
            diffuse / (PI * self.linear_norm)
        };
        let a = self.kd * (PI * (1.0 - e_avg));
        self.base_albedo = (a.x + a.y + a.z) / 3.0;
    }

    /// Base albedo.
    pub fn diffuse(&self) -> Vec3 {
        self.diffuse
    }

    /// Coat index of refraction.
    pub fn ior(&self) -> f32 {
        self.ior
    }

    /// The coat's microfacet distribution and roughness.
    pub fn microfacet(&self) -> Microfacet {
        self.microfacet
    }

    /// Whether the base's bounces sum non-linearly in its albedo.
    pub fn nonlinear(&self) -> bool {
        self.nonlinear
    }

    /// The coat's directional albedo `E(mu)` from outside.
    pub fn coat(&self, mu: f32) -> f32 {
        if self.microfacet.is_smooth() {
            return fr_dielectric(mu, self.ior);
        }
        let e = lookup(self.coat_albedo, mu);
        match self.coat_between {
            None => e,
            Some((next, _, w)) => (1.0 - w) * e + w * lookup(next, mu),
        }
    }

    /// What the coat lets through to the base at `cos theta = mu`: `1 -
    /// E(mu)`, or for the linear rough base Mitsuba 3's transmittance.
    pub fn transmittance(&self, mu: f32) -> f32 {
        match (self.coat_transmit, self.coat_between) {
            (None, _) => 1.0 - self.coat(mu),
            (Some(t), None) => lookup(t, mu),
            (Some(t), Some((_, next, w))) => {
                let upper = next.map_or(0.0, |n| lookup(n, mu));
                (1.0 - w) * lookup(t, mu) + w * upper
            }
        }
    }

    /// The coat's hemispherical albedo `E_avg = 2 integral E(mu) mu dmu`.
    pub fn coat_average(&self) -> f32 {
        self.coat_avg
    }

    /// Probability of sampling the coat for this `wo`.
    fn coat_probability(&self, wo: Vec3) -> f32 {
        let e = self.coat(wo.z);
        let total = e + (1.0 - e) * self.base_albedo;
        if total > 0.0 { e / total } else { 0.5 }
    }

    fn base(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.kd * (self.transmittance(wi.z) * self.transmittance(wo.z))
    }

    /// The rough coat's lobe and its pdf given `wo` (both `z > 0`).
    /// The lobe is symmetric in `wo` and `wi` bit for bit (see
    /// [`super::Conductor`]'s `eval`).
    fn rough_coat(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let sum = wo + wi;
        let len = sum.length();
        if !(len > 0.0) {
            return (0.0, 0.0);
        }
        let m = &self.microfacet;
        let d = m.d(sum / len);
        if !(d > 0.0) {
            return (0.0, 0.0);
        }
        let f = fr_dielectric(0.5 * len, self.ior) * (d * m.g(wo, wi) / (4.0 * (wo.z * wi.z)));
        let pdf = m.g1(wo) * d / (4.0 * wo.z);
        if f.is_finite() && pdf.is_finite() {
            (f, pdf)
        } else {
            (0.0, 0.0)
        }
    }
}

/// The rough coat's directional albedo for `cos theta_o = mu`, by an
/// `n x n` midpoint grid through the visible-normal warp: the integrand
/// `F(wo . h) G2 / G1(wo)` goes to zero where the reflected direction reaches
/// the horizon, so the grid converges fast.
fn rough_coat_albedo(m: &Microfacet, ior: f32, mu: f32) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1 = m.g1(wo);
    visible_normal_mean(m, wo, |h| {
        let wi = reflect(wo, h);
        if wi.z > 0.0 {
            fr_dielectric(wo.dot(h), ior) * m.g(wo, wi) / g1
        } else {
            0.0
        }
    })
}

/// The mean of `f` over the visible normals of `w`, on a `TABLE_GRID`
/// squared midpoint grid through the visible-normal warp.
fn visible_normal_mean(m: &Microfacet, w: Vec3, f: impl Fn(Vec3) -> f32) -> f32 {
    let mut sum = 0.0f64;
    for a in 0..TABLE_GRID {
        for b in 0..TABLE_GRID {
            let u = Vec2::new(
                (a as f32 + 0.5) / TABLE_GRID as f32,
                (b as f32 + 0.5) / TABLE_GRID as f32,
            );
            if let Some(h) = m.sample_visible(w, u) {
                sum += f(h) as f64;
            }
        }
    }
    (sum / (TABLE_GRID * TABLE_GRID) as f64) as f32
}

/// `f` at the table's nodes, `mu = s^3` for `s` evenly spaced in `[0, 1]`
/// (the first at `1e-5`), shared.
fn tabulate(f: impl Fn(f32) -> f32) -> CoatTable {
    let mut table = [0.0; TABLE];
    for (i, e) in table.iter_mut().enumerate() {
        let s = i as f32 / (TABLE - 1) as f32;
        *e = f((s * s * s).max(1e-5));
    }
    intern(table)
}

/// A table at `mu` (nodes at `mu = s^3`, `s` evenly spaced), linear between
/// nodes.
fn lookup(table: CoatTable, mu: f32) -> f32 {
    let s = mu.clamp(0.0, 1.0).cbrt() * (TABLE - 1) as f32;
    let i = (s as usize).min(TABLE - 2);
    let t = s - i as f32;
    (1.0 - t) * table[i] + t * table[i + 1]
}

/// The rough coat's transmittance for `cos theta = mu` as Mitsuba 3's
/// `roughplastic` takes it (`eval_transmittance` in its `microfacet.h`):
/// the mean over visible normals `h` of `(1 - F(w . h)) G1(t)`, `t` the
/// direction refracted through `h`, on the same midpoint grid as
/// [`rough_coat_albedo`] ([`visible_normal_mean`]). It is not `1 - E(mu)`:
/// the microfacet model loses energy in transmission as in reflection, 16 % of a white base's
/// albedo for GGX at alpha 0.6 (tests/rough_plastic.rs).
fn mitsuba_transmittance(m: &Microfacet, ior: f32, mu: f32) -> f32 {
    let w = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    visible_normal_mean(m, w, |h| match refract(w, h, ior) {
        Some(r) if r.wt.z < 0.0 => (1.0 - fr_dielectric(w.dot(h), ior)) * m.g1(r.wt),
        _ => 0.0,
    })
}

/// Nodes of [`mitsuba_internal_reflectance`]'s sum (Mitsuba 3's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
const MITSUBA_NODES: usize = 64;

/// The rough coat's diffuse reflectance from inside as Mitsuba 3's
/// `roughplastic` computes it (`roughplastic.cpp`, its constructor): twice
/// the mean of `mu E_int(mu)` over 64 evenly spaced `mu` from 0 to 1 (the
/// first at 1e-6), with `E_int` the coat's directional albedo at index
/// `1 / eta` (total internal reflection included). Its microfacet model
/// loses energy, which reciprocity's `1 - (1 - E_avg) / eta^2` does not
/// count, so this is the smaller, and a linear base under it the darker
/// (by about 5 % for Beckmann at alpha 0.15, eta 1.5; see the README).
fn mitsuba_internal_reflectance(m: &Microfacet, ior: f32) -> f32 {
    let sum: f64 = (0..MITSUBA_NODES)
        .map(|i| {
            let mu = (i as f32 / (MITSUBA_NODES - 1) as f32).max(1e-6);
            (mu * rough_coat_albedo(m, 1.0 / ior, mu)) as f64
        })
        .sum();
    (2.0 * sum / MITSUBA_NODES as f64) as f32
}

impl Bxdf for Plastic {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3::ZERO;
        }
        let base = self.base(wo, wi);
        if self.microfacet.is_smooth() {
            return base;
        }
        base + Vec3::splat(self.rough_coat(wo, wi).0)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let ps = self.coat_probability(wo);
        let base = (1.0 - ps) * square_to_cosine_hemisphere_pdf(wi);
        if self.microfacet.is_smooth() {
            return base;
        }
        base + ps * self.rough_coat(wo, wi).1
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let ps = self.coat_probability(wo);
        let wi = match choose_lobe(u, ps) {
            // --- the coat ---
            (true, _) if self.microfacet.is_smooth() => {
                return specular_reflection(wo, Vec3::splat(fr_dielectric(wo.z, self.ior)), ps);
            }
            (true, u) => reflect(wo, self.microfacet.sample_visible(wo, u)?),
            // --- the base ---
            (false, u) => square_to_cosine_hemisphere(u),
        };
        sample_at(self, wo, wi)
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn has_delta_component(&self) -> bool {
        self.microfacet.is_smooth()
    }
}

/// One plastic coat at the roughnesses of a roughness texture, for
/// [`crate::scene::Maps`]: the rough coat's albedo table is integrated once
/// per roughness (milliseconds), too slow per hit, so it is built at
/// [`PlasticCoats::LEVELS`] roughnesses spread evenly in `sqrt(alpha)` over
/// the texture's range (where `E` changes fastest, at low roughness, they
/// lie closest; plus the smooth coat when some texel is below
/// [`Microfacet::SMOOTH_ALPHA`]), and a hit's coat interpolates the table
/// and its hemispherical average linearly between the two nearest levels;
/// the microfacet lobe itself takes the texel's roughness exactly. `E(mu)`
/// is smooth in alpha, so the interpolation adds little to the table's own
/// error (measured in the tests: within 6e-4 of a table built at the
/// roughness itself, at every angle, over 0.05-0.5).
#[derive(Debug, Clone, PartialEq)]
pub struct PlasticCoats {
    /// The coat for texels below [`Microfacet::SMOOTH_ALPHA`], when some are.
    smooth: Option<Plastic>,
    /// Rough coats at `sqrt(alpha) = lo + k step`.
    levels: Vec<Plastic>,
    /// `sqrt` of the first level's roughness.
    lo: f32,
    /// Between levels, in `sqrt(alpha)`.
    step: f32,
}

impl PlasticCoats {
    /// Rough coats built across a texture's range.
    pub const LEVELS: usize = 16;

    /// The coat of `base` (its base albedo, index, distribution and bounce
    /// sum) at roughnesses from `lo` to `hi` (a texture's smallest and
    /// largest value, both finite and `>= 0`). One level only when the
    /// rough range is a single value, which then gives the same bits as a
    /// constant roughness.
    pub fn new(base: &Plastic, lo: f32, hi: f32) -> Result<Self, String> {
        super::check_alpha(lo)?;
        super::check_alpha(hi)?;
        let make = |alpha: f32| {
            Plastic::with_options(
                base.diffuse,
                base.ior,
                alpha,
                base.microfacet.distribution,
                base.microfacet.masking,
                base.nonlinear,
            )
        };
        let smooth = if lo < Microfacet::SMOOTH_ALPHA {
            Some(make(lo)?)
        } else {
            None
        };
        let rough_lo = lo.max(Microfacet::SMOOTH_ALPHA);
        let rough_hi = hi.max(rough_lo);
        let n = if rough_hi > rough_lo { Self::LEVELS } else { 1 };
        let (s_lo, s_hi) = (rough_lo.sqrt(), rough_hi.sqrt());
        let step = if n > 1 {
            (s_hi - s_lo) / (n - 1) as f32
        } else {
            0.0
        };
        // the ends exactly, so a texel at either gets its own table
        let level = |k: usize| match k {
            0 => rough_lo,
            k if k + 1 == n => rough_hi,
            k => (s_lo + k as f32 * step).powi(2),
        };
        let levels = (0..n)
            .map(|k| make(level(k)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(PlasticCoats {
            smooth,
            levels,
            lo: s_lo,
            step,
        })
    }

    /// The coat at roughness `alpha` (a texel, `>= 0`) over base albedo
    /// `diffuse`.
    pub fn at(&self, alpha: f32, diffuse: Vec3) -> Plastic {
        if alpha < Microfacet::SMOOTH_ALPHA {
            if let Some(s) = &self.smooth {
                return s.with_diffuse(diffuse);
            }
        }
        if self.levels.len() == 1 {
            return self.levels[0].with_diffuse(diffuse);
        }
        let s = ((alpha.sqrt() - self.lo) / self.step).clamp(0.0, (self.levels.len() - 1) as f32);
        let i = (s as usize).min(self.levels.len() - 2);
        let t = s - i as f32;
        let (a, b) = (&self.levels[i], &self.levels[i + 1]);
        let mut p = *a;
        p.microfacet = a.microfacet.with_alpha(alpha.max(Microfacet::SMOOTH_ALPHA));
        if t > 0.0 {
            p.coat_between = Some((b.coat_albedo, b.coat_transmit, t));
        }
        p.coat_avg = (1.0 - t) * a.coat_avg + t * b.coat_avg;
        p.linear_norm = (1.0 - t) * a.linear_norm + t * b.linear_norm;
        p.set_diffuse(diffuse.clamp(Vec3::ZERO, Vec3::ONE));
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba's internal reflectance: near the smooth limit it is the same
    /// 64-node sum over the Fresnel term from inside (index `1 / eta`, total
    /// internal reflection included); rough, it is smaller than
    /// reciprocity's value by the energy the microfacet model loses, and
    /// only a linear rough coat takes it.
    #[test]
    fn mitsuba_internal_reflectance_from_inside() {
        let ior = 1.5f32;
        let nodes = MITSUBA_NODES as f64;
        let smooth_sum: f64 = (0..MITSUBA_NODES)
            .map(|i| {
                let mu = (i as f32 / (MITSUBA_NODES - 1) as f32).max(1e-6);
                (mu * fr_dielectric(mu, 1.0 / ior)) as f64
            })
            .sum();
        let smooth = 2.0 * smooth_sum / nodes;
        // the classical internal diffuse reflectance at 1.5 is 0.5963; a mean
        // over 64 nodes from 0 to 1 (f(0) = 0) is 63/64 of the trapezoid
        // rule plus f(1) / 128, f(1) = 2 F(1) = 2 (0.5 / 2.5)^2, so Mitsuba's
        // sum is short of the integral by 1.5 %, and so is this
        let expected = 63.0 / 64.0 * 0.5963 + 0.08 / 128.0;
        assert!(
            (smooth - expected).abs() < 3e-4,
            "{smooth} against {expected}"
        );
        let near_smooth = Microfacet::new(Distribution::Beckmann, 0.002);
        let r = mitsuba_internal_reflectance(&near_smooth, ior) as f64;
        assert!((r - smooth).abs() < 2e-3, "{r} against {smooth}");
        let rough = Microfacet::new(Distribution::Beckmann, 0.15).with_masking(Masking::Separable);
        let r_rough = mitsuba_internal_reflectance(&rough, ior);
        let linear = |nonlinear, alpha| {
            Plastic::with_options(
                Vec3::splat(0.5),
                ior,
                alpha,
                Distribution::Beckmann,
                Masking::Separable,
                nonlinear,
            )
            .unwrap()
        };
        let p = linear(false, 0.15);
        let reciprocity = 1.0 - (1.0 - p.coat_avg) / (ior * ior);
        assert!(
            r_rough < reciprocity - 0.01,
            "{r_rough} against {reciprocity}"
        );
        assert_eq!(p.linear_norm, ior * ior * (1.0 - r_rough));
        // the others keep reciprocity's value
        for q in [linear(true, 0.15), linear(false, 0.0), linear(true, 0.0)] {
            assert_eq!(q.linear_norm, 1.0 - q.coat_avg);
        }
    }

    /// The smooth coat's hemispherical albedo obeys the classical identity
    /// with the internal diffuse reflectance, computed here independently by
    /// integrating the Fresnel term from inside.
    #[test]
    fn smooth_coat_identity() {
        for ior in [1.0f32, 1.33, 1.5, 2.0] {
            let p = Plastic::new(Vec3::splat(0.5), ior, 0.0).unwrap();
            let n = 100_000;
            let mut r_int = 0.0f64;
            for i in 0..n {
                let mu = (i as f64 + 0.5) / n as f64;
                r_int += fr_dielectric(-(mu as f32), ior) as f64 * mu;
            }
            let r_int = 2.0 * r_int / n as f64;
            let lhs = (ior * ior) as f64 * (1.0 - r_int);
            let rhs = 1.0 - p.coat_average() as f64;
            // midpoint rules over a kink at the critical angle (inside): 1e-4
            assert!((lhs - rhs).abs() < 1e-4, "ior {ior}: {lhs} vs {rhs}");
        }
    }

    /// The rough coat's table rises towards grazing and stays in [0, 1].
    #[test]
    fn rough_coat_table_is_sane() {
        let p = Plastic::new(Vec3::splat(0.5), 1.5, 0.3).unwrap();
        let e1 = p.coat(1.0);
        // near normal incidence about F(1) = 0.04
        assert!((0.02..0.06).contains(&e1), "{e1}");
        for i in 0..=100 {
            let e = p.coat(i as f32 / 100.0);
            assert!((0.0..=1.0).contains(&e));
        }
        assert!(p.coat(0.05) > e1);
    }

    /// Mitsuba's linear base: the same as the non-linear one for a white
    /// base, and linear in the albedo otherwise (the coat is a delta lobe
    /// here, so `eval` is the base alone).
    #[test]
    fn linear_base_scales_with_albedo() {
        let (wo, wi) = (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.5, 0.2, 0.6).normalize(),
        );
        let lin = |rho: f32| {
            Plastic::with_options(
                Vec3::splat(rho),
                1.5,
                0.0,
                Distribution::Ggx,
                Masking::default(),
                false,
            )
            .unwrap()
            .eval(wo, wi)
        };
        let non = |rho: f32| {
            Plastic::new(Vec3::splat(rho), 1.5, 0.0)
                .unwrap()
                .eval(wo, wi)
        };
        let (l1, n1) = (lin(1.0), non(1.0));
        assert!((l1 - n1).abs().max_element() <= 1e-6 * n1.x, "{l1} vs {n1}");
        let l5 = lin(0.5);
        assert!(
            (l5 - 0.5 * l1).abs().max_element() <= 1e-6 * l1.x,
            "{l5} vs {l1}"
        );
        // the non-linear sum weights a darker base less
        assert!(non(0.5).x < l5.x);
    }

    #[test]
    fn coat_tables_are_shared_and_the_bsdf_stays_small() {
        let a = Plastic::new(Vec3::splat(0.5), 1.5, 0.2).unwrap();
        let b = Plastic::new(Vec3::splat(0.1), 1.5, 0.2).unwrap();
        let c = Plastic::new(Vec3::splat(0.5), 1.5, 0.3).unwrap();
        assert!(std::ptr::eq(a.coat_albedo, b.coat_albedo));
        assert!(!std::ptr::eq(a.coat_albedo, c.coat_albedo));
        // the kernels copy a BSDF per hit: no inline tables
        assert!(std::mem::size_of::<super::super::Bsdf>() <= 96);
    }

    #[test]
    fn coats_between_levels_are_within_a_thousandth_of_their_own_table() {
        let base = Plastic::new(Vec3::new(0.6, 0.3, 0.2), 1.5, 0.05).unwrap();
        let coats = PlasticCoats::new(&base, 0.05, 0.5).unwrap();
        // at a level the coat is the one built there, bit for bit
        let level = coats.at(0.05, base.diffuse());
        assert_eq!(level, base);
        for alpha in [0.07f32, 0.13, 0.2, 0.31, 0.44, 0.5] {
            let own = Plastic::new(base.diffuse(), 1.5, alpha).unwrap();
            let got = coats.at(alpha, base.diffuse());
            assert_eq!(got.microfacet(), own.microfacet());
            let mut worst = 0.0f32;
            for k in 0..=40 {
                let mu = k as f32 / 40.0;
                worst = worst.max((got.coat(mu) - own.coat(mu)).abs());
            }
            println!("alpha {alpha}: worst {worst}");
            assert!(worst < 1e-3, "alpha {alpha}: {worst}");
            assert!((got.coat_average() - own.coat_average()).abs() < 1e-3);
        }
        // a smooth texel takes the smooth coat; one level when the range is
        // a single roughness
        let mixed = PlasticCoats::new(&base, 0.0, 0.3).unwrap();
        assert!(mixed.at(0.0, base.diffuse()).microfacet().is_smooth());
        let one = PlasticCoats::new(&base, 0.2, 0.2).unwrap();
        let own = Plastic::new(base.diffuse(), 1.5, 0.2).unwrap();
        assert_eq!(one.at(0.2, base.diffuse()), own);
    }
}
