//! Where bounces on glossy surfaces skip light sampling under an
//! environment map, decided by a pre-pass.
//!
//! Multiple importance sampling spends a light sample and a shadow ray at
//! every non-delta bounce. Where a BSDF's lobe is much narrower than the
//! light, the BSDF sample alone finds that light almost as well, and the
//! light sample mostly pays for a shadow ray that its MIS weight then
//! discounts. Under the uniform environment a fixed rule decides
//! ([`super::LIGHT_SAMPLING_PEAK_RATIO`]). Under an environment map no such
//! rule held: bounding the map by its highest density, the rough metal
//! walls of `benches/race/hard/glossy-env.xml` gain by skipping (the
//! walls hide most of the sky from one another, so most shadow rays are
//! occluded), but rough spheres under the same sky lose (the copper sphere
//! of `tests/data/mitsuba/metals.xml`: noise 0.0215 to 0.0288 at the same
//! time, see [`ENV_PEAK_RATIO`]). So the render measures it: a pre-pass
//! with light sampling at every bounce and one where the candidate
//! materials sample their BSDF alone, and the second is kept when its
//! variance times its predicted cost per sample is clearly the lower
//! ([`SKIP_BELOW`]).
//!
//! The pre-passes are those of `auto` guiding (a small image spread over
//! the film, [`super::training`]), traced with the render's seed, and the
//! cost is predicted from their ray counts, so the decision is a function
//! of the scene, the settings and the seed: any thread count, shard or
//! resumed render makes the same one. Both choices are unbiased; only the
//! noise and the time differ.

use super::{PathTracer, RayCounts, bsdf_alone_materials, quoted};
use crate::settings::{DirectStrategy, LightSampling};

/// A material is a candidate for skipping light sampling when all its
/// lobes peak at or above this many times the environment map's highest
/// density ([`super::Lights::environment_map_peak_pdf`]). Measured on
/// `benches/race/hard/glossy-env.xml` (64 spp, 4 seeds, RMSE against
/// Mitsuba 3's 4096-spp reference, `render_seconds` at 2 threads; 2-core
/// AMD EPYC): light sampling everywhere 0.01223 in 0.542 s; skipping at 2x
/// (the two walls of alpha 0.05) 0.01188 in 0.534 s; at 1x (the floor of
/// alpha 0.1 as well) 0.01214 in 0.432 s; at 0.2x (the copper of alpha 0.2
/// too) 0.01210 in 0.412 s. At 1x, on `tests/data/mitsuba/metals.xml` the
/// copper sphere (alpha 0.2) is a candidate, and skipping there raised the
/// noise (RMSE of seed pairs over sqrt 2, 64 spp, 3 pairs) from 0.0215 to
/// 0.0288 at the same time: what the pre-pass is for.
pub const ENV_PEAK_RATIO: f32 = 1.0;

/// The time of a shadow ray's light sample (choosing the light, sampling
/// the map, evaluating the BSDF, tracing) over that of a bounce's
/// extension ray with its shading, for the pre-pass's cost prediction.
/// Measured: `glossy-env.xml`, 64 spp, one thread, `render_seconds`:
/// 3.00 M camera and extension rays with 1.077 M shadow rays in 0.992 s,
/// skipping at the walls and floor 0.215 M shadow rays in 0.828 s: 191 ns
/// a shadow ray, 262 ns a bounce.
pub const SHADOW_RAY_COST: f64 = 0.73;

/// The candidates skip light sampling when the pre-pass's variance ratio
/// times its cost ratio is below this, not merely below 1: the variance
/// ratio scatters from seed to seed (`metals.xml` with the copper's alpha
/// at 0.1, seeds 1 to 6: 0.87 to 1.31, where 3 pairs of 64-spp renders
/// measured 1.13; `glossy-env.xml`: 0.90 to 1.00, products 0.75 to 0.83),
/// and where skipping saves little time a wrong skip only adds noise.
pub const SKIP_BELOW: f64 = 0.85;

/// Renders of fewer samples per pixel (not progressive) run no pre-pass:
/// its two passes of 4 spp at 64 x 64 pixels cost about 2 spp of a 128 x
/// 128 render.
pub const MIN_SPP: u32 = 16;

/// What the pre-pass measured, and what it chose.
#[derive(Debug, Clone, PartialEq)]
pub struct LightChoice {
    /// The environment map's highest density (`/sr`).
    pub map_peak_pdf: f32,
    /// The candidate materials (their BSDFs before textures).
    pub materials: Vec<String>,
    /// The pre-pass's variance with the candidates skipping light
    /// sampling over its variance without (the pixels' sample variances of
    /// luminance, summed).
    pub variance_ratio: f64,
    /// Its predicted time per sample over the other's ([`SHADOW_RAY_COST`]).
    pub cost_ratio: f64,
    /// The candidates skip light sampling: `variance_ratio * cost_ratio`
    /// is below [`SKIP_BELOW`].
    pub skip: bool,
}

impl LightChoice {
    /// The lobe peak from which a bounce is a candidate for skipping:
    /// [`ENV_PEAK_RATIO`] times `map_peak_pdf`.
    pub fn from(&self) -> f32 {
        ENV_PEAK_RATIO * self.map_peak_pdf
    }

    /// One line for the log and `embertrace plan`.
    pub fn describe(&self) -> String {
        let measured = format!(
            "with BSDF sampling alone at {} (lobes peaking at or above {:.3} /sr, {ENV_PEAK_RATIO} x the map's highest density), a pre-pass measured {:.2}x the variance at {:.2}x the time per sample",
            quoted(&self.materials),
            self.from(),
            self.variance_ratio,
            self.cost_ratio
        );
        if self.skip {
            format!("light sampling: skipped where the BSDF's lobes are narrow; {measured}")
        } else {
            format!("light sampling: at every non-delta bounce; {measured}")
        }
    }
}

/// Decide for `tracer`'s render of `spp` samples per pixel (a cap when
/// `progressive`) where bounces skip light sampling, and leave the tracer
/// set so ([`PathTracer::set_bsdf_alone_from`]). `prepass` traces the
/// pre-pass with the tracer as it is set and returns the pixels' summed
/// sample variance and the rays it traced (`auto` guiding's pre-pass,
/// [`super::training`]); `every`, when given, is its result with light
/// sampling at every bounce (the tracer's setting under an environment
/// map, before this), already traced by guiding's `auto`.
///
/// `None`, and the tracer untouched, unless the environment map is the
/// only light, `--light-sampling` is `auto`, direct light is combined by
/// MIS, the render has [`MIN_SPP`] samples or is progressive, and some
/// material is a candidate. For unguided renders only.
pub fn decide(
    tracer: &mut PathTracer<'_>,
    spp: u32,
    progressive: bool,
    every: Option<(f64, RayCounts)>,
    mut prepass: impl FnMut(&mut PathTracer<'_>) -> (f64, RayCounts),
) -> Option<LightChoice> {
    let settings = tracer.settings();
    if settings.light_sampling != LightSampling::Auto
        || settings.direct != DirectStrategy::Mis
        || (!progressive && spp < MIN_SPP)
    {
        return None;
    }
    let map_peak_pdf = tracer.lights().environment_map_peak_pdf()?;
    let from = ENV_PEAK_RATIO * map_peak_pdf;
    let materials = bsdf_alone_materials(tracer.scene, Some(from));
    if materials.is_empty() {
        return None;
    }
    // under an environment map the tracer starts with light sampling
    // everywhere (the uniform sky's rule does not apply), and is left so
    // unless skipping pays
    debug_assert_eq!(tracer.bsdf_alone_from(), None);
    let (every, every_rays) = every.unwrap_or_else(|| {
        tracer.set_bsdf_alone_from(None);
        prepass(tracer)
    });
    tracer.set_bsdf_alone_from(Some(from));
    let (alone, alone_rays) = prepass(tracer);
    let cost = |r: &RayCounts| (r.camera + r.extension) as f64 + SHADOW_RAY_COST * r.shadow as f64;
    let variance_ratio = if every > 0.0 { alone / every } else { 1.0 };
    let cost_ratio = cost(&alone_rays) / cost(&every_rays).max(1.0);
    let skip = variance_ratio * cost_ratio < SKIP_BELOW;
    tracer.set_bsdf_alone_from(skip.then_some(from));
    Some(LightChoice {
        map_peak_pdf,
        materials,
        variance_ratio,
        cost_ratio,
        skip,
    })
}
