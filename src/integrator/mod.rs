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
//! Russian roulette (Arvo and Kirk 1990; pbrt-v4 section 13.1.1) starts at
//! bounce `rr_depth`. The default continues with probability
//! `q = min(1, max(beta))` (throughput-based); `--rr P` fixes `q = P`. A path
//! with `q <= 0` ends; a surviving path is divided by `q > 0`, so its
//! throughput stays finite.

use crate::accel::{Accelerator, Hit};
use crate::bsdf::Diffuse;
use crate::light::Lights;
use crate::math::{Frame, Ray, SurfacePoint, Vec3, spawn_ray};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::Scene;
use std::fmt;
use std::str::FromStr;

/// Which direct-lighting strategy to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectStrategy {
    /// Light and BSDF sampling combined by MIS.
    Mis,
    /// Light sampling only.
    Light,
    /// BSDF sampling only.
    Bsdf,
}

impl FromStr for DirectStrategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "mis" => Ok(DirectStrategy::Mis),
            "light" => Ok(DirectStrategy::Light),
            "bsdf" => Ok(DirectStrategy::Bsdf),
            _ => Err(format!(
                "unknown direct strategy `{s}` (expected mis, light or bsdf)"
            )),
        }
    }
}

impl fmt::Display for DirectStrategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DirectStrategy::Mis => "mis",
            DirectStrategy::Light => "light",
            DirectStrategy::Bsdf => "bsdf",
        })
    }
}

/// Russian roulette policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Roulette {
    /// Continue with probability `min(1, max component of the throughput)`.
    Throughput,
    /// Continue with a fixed probability in `[0, 1]`.
    Fixed(f32),
}

/// Estimator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegratorSettings {
    /// Maximum number of bounces.
    pub max_depth: u32,
    /// Light samples per shading point (at least 1 when light sampling is used).
    pub light_samples: u32,
    /// Direct-lighting strategy.
    pub direct: DirectStrategy,
    /// Russian roulette policy.
    pub roulette: Roulette,
    /// First bounce at which roulette may end a path.
    pub rr_depth: u32,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings {
            max_depth: 64,
            light_samples: 1,
            direct: DirectStrategy::Mis,
            roulette: Roulette::Throughput,
            rr_depth: 3,
        }
    }
}

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

/// A ray's hit, resolved into what shading needs.
#[derive(Debug, Clone, Copy)]
struct Interaction {
    prim: u32,
    sp: SurfacePoint,
    /// Unit direction back along the incoming ray.
    wo: Vec3,
    /// Shading frame with its normal on `wo`'s side.
    frame: Frame,
}

/// The path tracer.
pub struct PathTracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accelerator,
    lights: Lights,
    settings: IntegratorSettings,
}

impl<'a> PathTracer<'a> {
    /// A path tracer over `scene`, answering ray queries with `accel`.
    pub fn new(scene: &'a Scene, accel: &'a dyn Accelerator, settings: IntegratorSettings) -> Self {
        PathTracer {
            scene,
            accel,
            lights: Lights::new(scene),
            settings,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &IntegratorSettings {
        &self.settings
    }

    fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let sp = self.scene.surface_point(hit.prim, hit.u, hit.v);
        let wo = -ray.d;
        let n = if sp.n.dot(wo) < 0.0 { -sp.n } else { sp.n };
        Interaction {
            prim: hit.prim,
            sp,
            wo,
            frame: Frame::from_normal(n),
        }
    }

    fn bsdf(&self, its: &Interaction) -> Diffuse {
        Diffuse {
            albedo: self.scene.material(its.prim).albedo,
        }
    }

    /// Radiance arriving at the camera along `ray` (one Monte Carlo sample).
    pub fn li(&self, ray: &Ray, sampler: &mut Sampler, rays: &mut RayCounts) -> Vec3 {
        rays.camera += 1;
        let Some(hit) = self.accel.intersect(ray) else {
            return self.lights.environment();
        };
        let its = self.interaction(ray, &hit);
        let mut l = self.zero_bounce_radiance(&its);
        if self.settings.max_depth >= 1 {
            l += self.at_least_one_bounce_radiance(&its, Vec3::ONE, 1, sampler, rays);
        }
        l
    }

    /// Emission leaving the surface towards the viewer.
    fn zero_bounce_radiance(&self, its: &Interaction) -> Vec3 {
        self.lights.le(self.scene, its.prim, its.sp.n, its.wo)
    }

    /// Light arriving after one or more bounces at `its`, where `beta` is the
    /// path throughput up to `its` and `depth` the bounce about to happen.
    fn at_least_one_bounce_radiance(
        &self,
        its: &Interaction,
        beta: Vec3,
        depth: u32,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        let bsdf = self.bsdf(its);
        let wo_local = its.frame.to_local(its.wo);
        let n_light = self.settings.light_samples.max(1) as f32;
        let use_light = self.settings.direct != DirectStrategy::Bsdf;
        let use_bsdf_emission = self.settings.direct != DirectStrategy::Light;
        let mis = self.settings.direct == DirectStrategy::Mis;
        let mut l = Vec3::ZERO;

        // --- direct lighting: light sampling ---
        if use_light && !self.lights.is_empty() {
            let mut sum = Vec3::ZERO;
            for _ in 0..self.settings.light_samples.max(1) {
                let u_sel = sampler.next_1d();
                let u = sampler.next_2d();
                let Some(ls) = self.lights.sample(self.scene, &its.sp, u_sel, u) else {
                    continue;
                };
                let wi_local = its.frame.to_local(ls.wi);
                let f = bsdf.eval(wo_local, wi_local);
                // f is zero unless wi is on wo's side of the geometric surface
                if f == Vec3::ZERO || ls.li == Vec3::ZERO {
                    continue;
                }
                rays.shadow += 1;
                if self.accel.occluded(&ls.shadow) {
                    continue;
                }
                let w = if mis {
                    power_heuristic(n_light, ls.pdf, 1.0, bsdf.pdf(wo_local, wi_local))
                } else {
                    1.0
                };
                sum += f * ls.li * (wi_local.z.abs() * w / ls.pdf);
            }
            l += sum / n_light;
        }

        // --- BSDF sampling ---
        let Some(bs) = bsdf.sample(wo_local, sampler.next_2d()) else {
            return l;
        };
        // the frame's normal is the geometric one turned to wo, and the diffuse
        // BSDF samples only its side: no ray leaves through the surface
        let wi = its.frame.to_world(bs.wi);
        let weight = bs.weight();
        let ray = spawn_ray(&its.sp, wi);
        rays.extension += 1;
        let next = self.accel.intersect(&ray);

        // --- emission found by the BSDF sample (the other half of direct lighting) ---
        let next_its = next.map(|h| self.interaction(&ray, &h));
        if use_bsdf_emission {
            let (le, light_pdf) = match &next_its {
                None => (self.lights.environment(), self.lights.pdf_environment()),
                Some(n) => (
                    self.lights.le(self.scene, n.prim, n.sp.n, n.wo),
                    self.lights.pdf_area(&its.sp, n.prim, &n.sp),
                ),
            };
            if le != Vec3::ZERO {
                let w = if mis && use_light {
                    power_heuristic(1.0, bs.pdf, n_light, light_pdf)
                } else {
                    1.0
                };
                l += weight * le * w;
            }
        }

        // --- indirect lighting: recurse, with Russian roulette ---
        let Some(next_its) = next_its else {
            return l;
        };
        if depth >= self.settings.max_depth {
            return l;
        }
        let mut beta = beta * weight;
        let mut scale = weight;
        if depth >= self.settings.rr_depth {
            let q = match self.settings.roulette {
                Roulette::Throughput => beta.max_element().min(1.0),
                Roulette::Fixed(p) => p.min(1.0),
            };
            // q <= 0 (or NaN) ends the path; never divide by it
            if !(q > 0.0) || sampler.next_1d() >= q {
                return l;
            }
            beta /= q;
            scale /= q;
        }
        debug_assert!(beta.is_finite(), "throughput became {beta}");
        l + scale * self.at_least_one_bounce_radiance(&next_its, beta, depth + 1, sampler, rays)
    }
}
