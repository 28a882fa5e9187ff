//! The radiance estimator, shaped like the classic course path tracer so a
//! reader recognises it:
//!
//! ```text
//! L(ray) = zero_bounce_radiance            emission seen directly
//!        + at_least_one_bounce_radiance    direct lighting at this hit, then
//!                                          one BSDF-sampled continuation,
//!                                          recursively
//! ```
//!
//! Direct lighting combines light sampling and BSDF sampling by multiple
//! importance sampling with the power heuristic (Veach 1997, chapter 9): each
//! shading point takes `light_samples` light samples and one BSDF sample; the
//! emission the BSDF sample finds is weighted against the light-sampling
//! density, so it is neither lost nor counted twice. `--direct light` and
//! `--direct bsdf` keep one strategy with weight 1.
//!
//! Depth convention (`-m`): 0 = emitted light only, 1 = direct lighting only,
//! k = paths of up to k bounces.
//!
//! The recursion runs forwards, a path at a time in a batch of paths
//! traced in lockstep ([`path`]): `L = sum_k beta_k l_k`, with `beta_k` the
//! throughput that the recursion's factors multiply to.
//!
//! Russian roulette (Arvo and Kirk 1990; pbrt-v4 section 13.1.1) starts at
//! bounce `rr_depth`. The default continues with probability
//! `q = min(1, max(beta))` (throughput-based); `--rr P` fixes `q = P`. A path
//! with `q <= 0` ends; a surviving path is divided by `q > 0`, so its
//! throughput stays finite.

pub mod light_bvh;
pub mod light_choice;
mod lights;
mod path;
pub mod training;

pub use lights::Lights;
pub use path::{BATCH, BLOCK, GuideVertex, Lane, take_recorded};

use crate::accel::Accelerator;
use crate::bsdf::Bxdf;
use crate::camera::Camera;
use crate::math::{Ray, Vec2, Vec3};
use crate::plan::{Kernel, Plan};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::settings::IntegratorSettings;

/// Rays traced, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Primary rays from the camera.
    pub camera: u64,
    /// BSDF-sampled continuation rays.
    pub extension: u64,
    /// Shadow (occlusion) rays.
    pub shadow: u64,
}

impl RayCounts {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.extension + self.shadow
    }

    /// Add `other` into `self`.
    pub fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.extension += other.extension;
        self.shadow += other.shadow;
    }
}

/// The signature of a compiled kernel: trace a batch of paths to the end.
type TraceFn<'a> = fn(&PathTracer<'a>, &mut [Lane], &mut RayCounts);

/// The path tracer.
pub struct PathTracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accelerator,
    /// The scene's alpha masks, if it has any: queries then go through
    /// [`Accelerator::intersect_masked`] and
    /// [`Accelerator::occluded_masked`], a ray at a time.
    alpha: Option<&'a dyn crate::accel::AlphaTest>,
    lights: Lights,
    settings: IntegratorSettings,
    /// Per material: its Lambertian albedo (the diffuse-only kernels' table).
    albedo: Vec<Vec3>,
    /// Some material has a normal or bump map (checked before any hit looks
    /// its material up for one, so scenes without maps pay a branch only in
    /// the `shapes` kernels).
    normal_maps: bool,
    /// Some emitting material is [`crate::scene::EmissionRole::SeenOnly`]
    /// (checked before a hit found by a non-delta bounce looks its material
    /// up for its role, so other scenes pay one predictable branch where a
    /// BSDF sample finds emission).
    seen_only: bool,
    /// Some material is one-sided ([`crate::scene::Material::one_sided`]):
    /// checked before a hit looks its material up for that, so scenes of
    /// two-sided surfaces pay one predictable branch per hit.
    one_sided: bool,
    kernel: Kernel,
    trace_fn: TraceFn<'a>,
    /// The instruction set the kernel runs with ([`crate::simd`]).
    simd: crate::simd::Dispatch,
    /// The learned distribution of incident light that non-delta bounces
    /// sample from beside their BSDF ([`crate::guiding`]); `None`: BSDF
    /// sampling alone.
    guide: Option<std::sync::Arc<crate::guiding::Guide>>,
    /// Paths' bounces are kept for [`take_recorded`] (a guide's training).
    record: bool,
    /// A non-delta bounce whose BSDF's lobes all peak at least this high
    /// samples the BSDF alone, no light ([`bsdf_alone_from`],
    /// [`crate::bsdf::Bxdf::lobe_peak_pdf`]); `None`: none does.
    bsdf_alone_from: Option<f32>,
}

/// How high, against the density of light sampling, a BSDF's lobes must
/// all peak for a bounce to skip light sampling (MIS then weighs the light
/// its BSDF sample finds by 1): at 2, the light's power-heuristic weight at
/// the lobe's peak is at most 1/5, and where it nears 1 (the lobe's tails)
/// the BSDF is small. Both strategies are unbiased, so this only trades
/// noise against time. It applies where the uniform environment is the
/// only light ([`Lights::peak_pdf`]), where light sampling draws the whole
/// sphere and the lobe is the better strategy: `scenes/sphere-1m.toml` (a
/// diffuse terrain, 16 spp; 2-core AMD EPYC, noise = RMSE of seeds 1 and 2
/// over sqrt 2, time = user CPU of one thread): noise 0.02117 to 0.01666,
/// 3.87 s to 2.73 s.
///
/// Tried and left out: bounding an environment map by its highest density
/// (`max L / int L dw`). On `benches/race/hard/glossy-env.xml` (64 spp) the
/// aluminium walls (alpha 0.05, peak 31.8 /sr, under a sky peaking at 6.6
/// /sr) then skipped light sampling: noise 0.01211 to 0.01177, 1.05 s to
/// 0.83 s. But on `tests/data/mitsuba/metals.xml` (rough spheres under a
/// sky peaking at 1.37 /sr, 64 spp) with the copper's alpha set to 0.17,
/// 0.14, 0.1 and 0.07, skipping raised the noise from 0.0211, 0.0194,
/// 0.0218, 0.0221 to 0.0269, 0.0291, 0.0243, 0.0236, even at ratios near
/// 12; and on `tests/data/mitsuba/maps.xml`, a normal-mapped rough metal,
/// from 0.0312 to 0.0369. A lobe's peak does not say how much of it a
/// sphere's grazing views or a perturbed normal send below the surface.
pub const LIGHT_SAMPLING_PEAK_RATIO: f32 = 2.0;

/// The BSDF peak density from which a bounce samples the BSDF alone:
/// [`LIGHT_SAMPLING_PEAK_RATIO`] times the light's density, when the
/// uniform environment is the only light ([`Lights::peak_pdf`]) and direct
/// light is combined by MIS; otherwise `None` (never). Either way the
/// estimator is unbiased: a bounce's strategies are chosen by its BSDF
/// alone, and the BSDF sample's weight says which ran.
/// Never under `--light-sampling always`.
fn bsdf_alone_from(lights: &Lights, settings: &IntegratorSettings) -> Option<f32> {
    lights
        .peak_pdf()
        .filter(|&p| {
            settings.direct == crate::settings::DirectStrategy::Mis
                && settings.light_sampling == crate::settings::LightSampling::Auto
                && p > 0.0
        })
        .map(|p| LIGHT_SAMPLING_PEAK_RATIO * p)
}

/// Whether a bounce on `bsdf` samples it alone, no light: its lobes all
/// peak at `from` ([`bsdf_alone_from`]) or higher, and its material's maps
/// do not perturb the normal (asked only then). Without a threshold, as in
/// most scenes, nothing is computed.
#[inline]
fn bsdf_alone(bsdf: &impl Bxdf, from: Option<f32>, perturbs_normal: impl FnOnce() -> bool) -> bool {
    from.is_some_and(|f| bsdf.lobe_peak_pdf() >= f && !perturbs_normal())
}

/// The most delta surfaces [`PathTracer::auxiliary`] follows.
const AUX_DELTA_CHAIN: usize = 8;

/// What a denoiser (Intel Open Image Denoise, OptiX) takes besides the noisy
/// image, for one camera ray: the first hit's albedo and shading normal.
///
/// - `albedo`, as OIDN defines it: the reflectance of the first non-delta
///   surface along the ray, following delta surfaces (mirror, glass, smooth
///   metal) along their first lobe (a mirror's reflection; glass's
///   reflection, the lobe the number 0 picks); 1 after
///   [`AUX_DELTA_CHAIN`] delta surfaces; where the ray escapes, the
///   environment's radiance clamped to `[0, 1]`. A surface's reflectance is
///   its diffuse albedo (textures applied), a plastic's base albedo, a phong
///   material's `diffuse + specular` clamped to 1, a rough metal's Fresnel
///   reflectance at normal incidence, a metallic-roughness material's base
///   colour.
/// - `normal`: the first hit's shading normal (smooth normals, normal and
///   bump maps applied), world space, facing the camera; zero on a miss.
/// - `first_hit`: where the camera ray first hits a surface (world space)
///   and how far along the ray that is; `None` on a miss.
/// - `emitted`: the estimator's zero-bounce term for this ray, the same
///   value it adds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Auxiliary {
    /// First non-delta hit's reflectance.
    pub albedo: Vec3,
    /// First hit's shading normal.
    pub normal: Vec3,
    /// First hit's position and distance from the ray's origin.
    pub first_hit: Option<(Vec3, f32)>,
    /// What the path tracer adds before the first bounce: the first hit's
    /// emission, or the environment's radiance where the ray escapes.
    pub emitted: Vec3,
}

/// The reflectance [`Auxiliary::albedo`] reports for a non-delta BSDF.
fn reflectance(b: &crate::bsdf::Bsdf) -> Vec3 {
    use crate::bsdf::Bsdf;
    match b {
        Bsdf::Diffuse(d) => d.albedo,
        Bsdf::Plastic(p) => p.diffuse(),
        Bsdf::Phong(p) => (p.diffuse + p.specular).min(Vec3::ONE),
        Bsdf::MetallicRoughness(m) => m.base_color,
        Bsdf::Conductor(c) => {
            crate::bsdf::fresnel::fr_conductor(1.0, c.eta, c.k).clamp(Vec3::ZERO, Vec3::ONE)
        }
        Bsdf::Mirror(m) => m.reflectance,
        Bsdf::Glass(g) => g.reflectance,
        Bsdf::ThinGlass(g) => g.reflectance,
        Bsdf::RoughGlass(g) => g.reflectance,
    }
}

/// A shading normal may not leave `wo` closer to the surface than this
/// cosine: a view below the interpolated normal's horizon would see a
/// reflective surface as black.
const MIN_SHADING_COS: f32 = 1e-2;

/// The names of `scene`'s materials (their BSDFs before textures) whose
/// bounces sample the BSDF alone when lobes peaking at `from` or higher do
/// ([`bsdf_alone`]); none for `None`.
fn bsdf_alone_materials(scene: &Scene, from: Option<f32>) -> Vec<String> {
    scene
        .materials
        .iter()
        .filter(|m| !m.bsdf.is_delta() && bsdf_alone(&m.bsdf, from, || m.maps.perturbs_normal()))
        .map(|m| m.name.clone())
        .collect()
}

/// `names` as a list for a message: each in backticks, comma-separated.
fn quoted(names: &[String]) -> String {
    names
        .iter()
        .map(|m| format!("`{m}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where bounces sample the BSDF alone, for `plan`
/// ([`LIGHT_SAMPLING_PEAK_RATIO`], [`light_choice`]).
#[derive(Debug, Clone, PartialEq)]
pub struct BsdfAlone {
    /// The lights' density, when the uniform environment is the only light.
    pub lights_peak_pdf: Option<f32>,
    /// The BSDF peak density from which a bounce skips light sampling;
    /// `None`: never.
    pub from: Option<f32>,
    /// The materials whose BSDF (before textures) skips it.
    pub materials: Vec<String>,
    /// The environment map's highest density, when it is the only light
    /// ([`Lights::environment_map_peak_pdf`]).
    pub map_peak_pdf: Option<f32>,
    /// Under it, the materials a pre-pass may let skip light sampling
    /// ([`light_choice::ENV_PEAK_RATIO`]).
    pub map_candidates: Vec<String>,
    /// `--light-sampling`.
    pub mode: crate::settings::LightSampling,
    /// `--direct`.
    pub direct: crate::settings::DirectStrategy,
}

impl BsdfAlone {
    /// Which bounces of `scene`, rendered with `settings`, skip light
    /// sampling (under an environment map, which may: a pre-pass decides).
    pub fn of(scene: &Scene, settings: &IntegratorSettings) -> Self {
        let lights = Lights::with_sampler(scene, settings.light_sampler);
        let from = bsdf_alone_from(&lights, settings);
        let map_peak_pdf = lights.environment_map_peak_pdf();
        BsdfAlone {
            lights_peak_pdf: lights.peak_pdf(),
            from,
            materials: bsdf_alone_materials(scene, from),
            map_peak_pdf,
            map_candidates: bsdf_alone_materials(
                scene,
                map_peak_pdf.map(|p| light_choice::ENV_PEAK_RATIO * p),
            ),
            mode: settings.light_sampling,
            direct: settings.direct,
        }
    }

    /// One line for `plan`.
    pub fn describe(&self) -> String {
        use crate::settings::{DirectStrategy, LightSampling};
        let peak = self.lights_peak_pdf.unwrap_or(0.0);
        let infinite = self.lights_peak_pdf.is_some() || self.map_peak_pdf.is_some();
        match self.from {
            _ if self.mode == LightSampling::Always => {
                "light sampling: at every non-delta bounce (--light-sampling always)".to_string()
            }
            Some(f) if self.materials.is_empty() => format!(
                "light sampling: at every non-delta bounce (no material's lobes all peak at or above {f:.3} /sr, {LIGHT_SAMPLING_PEAK_RATIO} x the uniform sky's density)"
            ),
            Some(f) => format!(
                "light sampling: skipped, BSDF sampling alone, where every lobe peaks at or above {f:.3} /sr ({LIGHT_SAMPLING_PEAK_RATIO} x the uniform sky's density, {peak:.3} /sr): {}",
                quoted(&self.materials)
            ),
            None if infinite && self.direct != DirectStrategy::Mis => {
                "light sampling: at every non-delta bounce (direct light not combined by MIS)"
                    .to_string()
            }
            None => match self.map_peak_pdf {
                Some(p) if self.map_candidates.is_empty() => format!(
                    "light sampling: at every non-delta bounce (no material's lobes all peak at or above {:.3} /sr, {} x the environment map's highest density)",
                    light_choice::ENV_PEAK_RATIO * p,
                    light_choice::ENV_PEAK_RATIO
                ),
                Some(p) => format!(
                    "light sampling: at every non-delta bounce here; {} (lobes peaking at or above {:.3} /sr, {} x the environment map's highest density) skip it where a pre-pass finds that pays, in an unguided render of at least {} spp",
                    quoted(&self.map_candidates),
                    light_choice::ENV_PEAK_RATIO * p,
                    light_choice::ENV_PEAK_RATIO,
                    light_choice::MIN_SPP
                ),
                None => "light sampling: at every non-delta bounce (neither the uniform environment nor an environment map is the only light)"
                    .to_string(),
            },
        }
    }
}

impl<'a> PathTracer<'a> {
    /// A path tracer over `scene`, answering ray queries with `accel`, with the
    /// kernel specialised for the scene's effects.
    pub fn new(scene: &'a Scene, accel: &'a dyn Accelerator, settings: IntegratorSettings) -> Self {
        let kernel = Plan::new(scene, &settings).kernel;
        Self::with_kernel(scene, accel, settings, kernel)
    }

    /// A path tracer running `kernel`. A kernel must have every flag on that
    /// the scene's plan has (it may have more: [`Kernel::GENERAL`] runs any
    /// scene).
    pub fn with_kernel(
        scene: &'a Scene,
        accel: &'a dyn Accelerator,
        settings: IntegratorSettings,
        kernel: Kernel,
    ) -> Self {
        let lights = Lights::with_sampler(scene, settings.light_sampler);
        PathTracer {
            scene,
            accel,
            alpha: scene.alpha_test(),
            bsdf_alone_from: bsdf_alone_from(&lights, &settings),
            lights,
            settings,
            albedo: scene
                .materials
                .iter()
                .map(|m| m.albedo().unwrap_or(Vec3::ZERO))
                .collect(),
            normal_maps: scene.materials.iter().any(|m| m.maps.perturbs_normal()),
            seen_only: scene.seen_only_emitters(),
            one_sided: scene.materials.iter().any(|m| m.one_sided),
            kernel,
            trace_fn: select_kernel(kernel),
            simd: crate::simd::Dispatch::default(),
            guide: None,
            record: false,
        }
    }

    /// Sample non-delta bounces from a mixture of the BSDF and `guide`
    /// (`None`: the BSDF alone).
    pub fn set_guide(&mut self, guide: Option<std::sync::Arc<crate::guiding::Guide>>) {
        self.guide = guide;
    }

    /// The BSDF peak density from which a non-delta bounce samples the
    /// BSDF alone, no light; `None`: every non-delta bounce samples lights.
    pub fn bsdf_alone_from(&self) -> Option<f32> {
        self.bsdf_alone_from
    }

    /// Let non-delta bounces whose BSDF's lobes all peak at `from` or
    /// higher sample the BSDF alone (`None`: none does); set by
    /// [`light_choice::decide`] from its pre-pass. Unbiased for any
    /// value: MIS then weighs the light such a bounce's BSDF sample finds
    /// by 1. Ignored (none does) where a light cannot be found by BSDF
    /// sampling (point, spot, directional and panel lights), whose light
    /// such a bounce would lose.
    pub fn set_bsdf_alone_from(&mut self, from: Option<f32>) {
        self.bsdf_alone_from = from.filter(|_| !self.lights.has_unreachable());
    }

    /// The lights as the estimator samples them.
    pub(crate) fn lights(&self) -> &Lights {
        &self.lights
    }

    /// The guide the render samples from, if any.
    pub fn guide(&self) -> Option<&crate::guiding::Guide> {
        self.guide.as_deref()
    }

    /// Keep every path's non-delta bounces for a guide's training
    /// ([`take_recorded`]).
    pub fn set_recording(&mut self, record: bool) {
        self.record = record;
    }

    /// The settings.
    pub fn settings(&self) -> &IntegratorSettings {
        &self.settings
    }

    /// Run the kernels with the instruction set of `level` (or the widest
    /// the CPU has below it); the image is the same bits on every level.
    pub fn with_simd(mut self, level: crate::simd::Level) -> Self {
        self.simd = level.dispatcher();
        self
    }

    /// The instruction set the kernels run with.
    pub fn simd(&self) -> crate::simd::Level {
        self.simd.level()
    }

    /// The kernel this tracer runs.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Radiance arriving at the camera along `ray` (one Monte Carlo sample),
    /// drawing from `sampler`: a batch of one path.
    pub fn li(&self, ray: &Ray, sampler: &mut Sampler, rays: &mut RayCounts) -> Vec3 {
        let mut lane = [Lane::new(sampler.clone(), *ray)];
        self.trace(&mut lane, rays);
        let [lane] = lane;
        *sampler = lane.sampler;
        lane.l
    }

    /// Trace the paths of `lanes` (at most [`BATCH`], each set up with
    /// [`Lane::new`] from its camera ray) to the end; each lane's `l` is then
    /// its sample's radiance. The paths are traced in lockstep, so their
    /// rays reach the backend in batches, but each path's value depends on
    /// its own sampler only.
    pub fn trace(&self, lanes: &mut [Lane], rays: &mut RayCounts) {
        for chunk in lanes.chunks_mut(BATCH) {
            (self.trace_fn)(self, chunk, rays);
        }
    }

    /// The denoiser's auxiliary values along camera ray `ray` ([`Auxiliary`]).
    pub fn auxiliary(&self, ray: &Ray) -> Auxiliary {
        self.auxiliary_values(ray)
    }

    /// [`Auxiliary::emitted`] alone, without shading the hit.
    pub fn first_emission(&self, ray: &Ray) -> Vec3 {
        self.first_emission_value(ray)
    }

    /// The camera ray for film position `p`: a lens sample is drawn only by a
    /// kernel with the lens on, and then only when the lens has an aperture.
    pub fn camera_ray(&self, camera: &Camera, p: Vec2, sampler: &mut Sampler) -> Ray {
        if self.kernel.lens && !camera.lens().is_pinhole() {
            camera.generate_ray_lens(p, sampler.next_2d())
        } else {
            camera.generate_ray(p)
        }
    }
}

/// The compiled kernel for the flags of `k` that the estimator specialises
/// on (the lens is handled by [`PathTracer::camera_ray`]). Each step turns
/// one run-time flag into a const generic of the same name and hands on to
/// the next, so every one of the 32 combinations is compiled and the last
/// step names one.
fn select_kernel<'a>(k: Kernel) -> TraceFn<'a> {
    if k.materials {
        bind_delta::<true>(k)
    } else {
        bind_delta::<false>(k)
    }
}

fn bind_delta<'a, const MATERIALS: bool>(k: Kernel) -> TraceFn<'a> {
    if k.delta {
        bind_environment::<MATERIALS, true>(k)
    } else {
        bind_environment::<MATERIALS, false>(k)
    }
}

fn bind_environment<'a, const MATERIALS: bool, const DELTA: bool>(k: Kernel) -> TraceFn<'a> {
    if k.environment {
        bind_emitters::<MATERIALS, DELTA, true>(k)
    } else {
        bind_emitters::<MATERIALS, DELTA, false>(k)
    }
}

fn bind_emitters<'a, const MATERIALS: bool, const DELTA: bool, const ENVIRONMENT: bool>(
    k: Kernel,
) -> TraceFn<'a> {
    if k.emitters {
        bind_shapes::<MATERIALS, DELTA, ENVIRONMENT, true>(k)
    } else {
        bind_shapes::<MATERIALS, DELTA, ENVIRONMENT, false>(k)
    }
}

fn bind_shapes<
    'a,
    const MATERIALS: bool,
    const DELTA: bool,
    const ENVIRONMENT: bool,
    const EMITTERS: bool,
>(
    k: Kernel,
) -> TraceFn<'a> {
    if k.shapes {
        PathTracer::trace_kernel::<MATERIALS, DELTA, ENVIRONMENT, EMITTERS, true>
    } else {
        PathTracer::trace_kernel::<MATERIALS, DELTA, ENVIRONMENT, EMITTERS, false>
    }
}
