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
use crate::bsdf::{Bsdf, Bxdf, Diffuse, Phong};
use crate::camera::Camera;
use crate::light::Lights;
use crate::math::{Frame, Ray, SurfacePoint, Vec2, Vec3, gamma, spawn_ray};
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

/// The effects an estimator kernel is compiled for. Each flag switches code
/// on at compile time: a kernel whose flag is off has no branch, call or
/// table lookup for that effect. The general kernel (every flag on) checks
/// each effect per shading point instead; on a scene without the effect those
/// checks take the branch the specialised kernel compiled, with the same
/// arithmetic in the same order, so both give the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Kernel {
    /// Material dispatch (mirror, glass, conductor, plastic) and textures;
    /// off: every surface is a Lambertian with a per-material albedo.
    pub materials: bool,
    /// Delta lights or delta BSDF lobes; off: no delta checks, every sample
    /// has a density and MIS applies to all of them.
    pub delta: bool,
    /// Environment lighting; off: an escaping ray returns black at once.
    pub environment: bool,
    /// Emissive surfaces (area lights); off: a hit is never looked up for
    /// emission and, with no environment either, no MIS weight is computed.
    pub emitters: bool,
    /// Spheres or smooth normals; off: every hit is a flat-shaded triangle.
    pub shapes: bool,
    /// A thin-lens camera; off: camera rays come from the pinhole, with no
    /// lens sample drawn.
    pub lens: bool,
}

impl Kernel {
    /// Every effect on: the fully general kernel (`--plan general`).
    pub const GENERAL: Kernel = Kernel {
        materials: true,
        delta: true,
        environment: true,
        emitters: true,
        shapes: true,
        lens: true,
    };

    /// What a kernel without each flag leaves out, for the flags that are off.
    pub fn omitted(&self) -> Vec<&'static str> {
        [
            (
                self.materials,
                "material dispatch, Fresnel and texture code",
            ),
            (self.delta, "delta-lobe and delta-light checks"),
            (self.environment, "environment lookups on escape"),
            (self.emitters, "emission lookups at hits"),
            (self.shapes, "sphere and smooth-normal shading"),
            (self.lens, "lens sampling"),
        ]
        .iter()
        .filter(|(on, _)| !on)
        .map(|(_, what)| *what)
        .collect()
    }

    /// The flags as a short string, e.g. `materials+delta`, or `minimal`.
    pub fn describe(&self) -> String {
        let on: Vec<&str> = [
            ("materials", self.materials),
            ("delta", self.delta),
            ("environment", self.environment),
            ("emitters", self.emitters),
            ("shapes", self.shapes),
            ("lens", self.lens),
        ]
        .iter()
        .filter(|(_, f)| *f)
        .map(|(n, _)| *n)
        .collect();
        if on.is_empty() {
            "minimal".to_string()
        } else {
            on.join("+")
        }
    }
}

/// A ray's hit, resolved into what shading needs.
#[derive(Debug, Clone, Copy)]
struct Interaction {
    prim: u32,
    /// The geometric surface point; `sp.n` is the front (outward) normal.
    sp: SurfacePoint,
    /// Unit direction back along the incoming ray.
    wo: Vec3,
    /// Geometric normal turned to `wo`'s side.
    ng: Vec3,
    /// Shading normal on `ng`'s side (equal to `ng` when shading flat).
    ns: Vec3,
    /// Barycentrics of the hit (triangles).
    u: f32,
    v: f32,
}

/// The signature of a compiled radiance kernel.
type LiFn<'a> = fn(&PathTracer<'a>, &Ray, &mut Sampler, &mut RayCounts) -> Vec3;

/// The path tracer.
pub struct PathTracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accelerator,
    lights: Lights,
    settings: IntegratorSettings,
    /// Per material: its Lambertian albedo (the diffuse-only kernels' table).
    albedo: Vec<Vec3>,
    kernel: Kernel,
    li_fn: LiFn<'a>,
}

/// A shading normal may not leave `wo` closer to the surface than this
/// cosine: a view below the interpolated normal's horizon would see a
/// reflective surface as black.
const MIN_SHADING_COS: f32 = 1e-2;

impl<'a> PathTracer<'a> {
    /// A path tracer over `scene`, answering ray queries with `accel`, with the
    /// kernel specialised for the scene's effects.
    pub fn new(scene: &'a Scene, accel: &'a dyn Accelerator, settings: IntegratorSettings) -> Self {
        let kernel = crate::plan::Plan::new(scene, &settings).kernel;
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
        PathTracer {
            scene,
            accel,
            lights: Lights::new(scene),
            settings,
            albedo: scene
                .materials
                .iter()
                .map(|m| m.albedo().unwrap_or(Vec3::ZERO))
                .collect(),
            kernel,
            li_fn: select_kernel(kernel),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &IntegratorSettings {
        &self.settings
    }

    /// The kernel this tracer runs.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Radiance arriving at the camera along `ray` (one Monte Carlo sample).
    pub fn li(&self, ray: &Ray, sampler: &mut Sampler, rays: &mut RayCounts) -> Vec3 {
        (self.li_fn)(self, ray, sampler, rays)
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

    fn li_kernel<const M: bool, const D: bool, const E: bool, const A: bool, const S: bool>(
        &self,
        ray: &Ray,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        rays.camera += 1;
        let Some(hit) = self.accel.intersect(ray) else {
            return if E {
                self.lights.environment(ray.d)
            } else {
                Vec3::ZERO
            };
        };
        let its = self.interaction::<S>(ray, &hit);
        let mut l = if A {
            self.zero_bounce_radiance(&its)
        } else {
            Vec3::ZERO
        };
        if self.settings.max_depth >= 1 {
            l += self.shade::<M, D, E, A, S>(&its, Vec3::ONE, 1.0, 1, sampler, rays);
        }
        l
    }

    fn interaction<const S: bool>(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let sp = if S {
            self.scene.hit_point(ray, hit)
        } else {
            self.scene.surface_point(hit.prim, hit.u, hit.v)
        };
        let wo = -ray.d;
        let ng = if sp.n.dot(wo) < 0.0 { -sp.n } else { sp.n };
        let ns = if S {
            self.shading_normal(hit, ng, wo)
        } else {
            ng
        };
        Interaction {
            prim: hit.prim,
            sp,
            wo,
            ng,
            ns,
            u: hit.u,
            v: hit.v,
        }
    }

    /// The smooth-shading rule. A triangle whose three corners have vertex
    /// normals gets their barycentric interpolation (corners face the
    /// triangle's front, see the scene builder), turned to `ng`'s side; any
    /// other hit shades with `ng`. If `wo` would fall below the shading
    /// normal's horizon (closer than [`MIN_SHADING_COS`]), the normal is bent
    /// towards `wo` until it is not, so no view sees a black terminator.
    fn shading_normal(&self, hit: &Hit, ng: Vec3, wo: Vec3) -> Vec3 {
        let Some(c) = self.corner_normals(hit.prim) else {
            return ng;
        };
        let b0 = 1.0 - hit.u - hit.v;
        let mut n = (b0 * c[0] + hit.u * c[1] + hit.v * c[2]).normalize_or_zero();
        if n == Vec3::ZERO {
            return ng;
        }
        if n.dot(ng) < 0.0 {
            n = -n;
        }
        let cos = n.dot(wo);
        if cos < MIN_SHADING_COS {
            n = (n + (MIN_SHADING_COS - cos) * wo).normalize_or_zero();
            if n == Vec3::ZERO || n.dot(ng) <= 0.0 {
                return ng;
            }
        }
        n
    }

    /// The vertex normals of triangle `prim`, when all three exist.
    fn corner_normals(&self, prim: u32) -> Option<[Vec3; 3]> {
        let c = self.scene.tri_shading_normals.get(prim as usize)?;
        (c.iter().all(|n| *n != Vec3::ZERO)).then_some(*c)
    }

    /// Where rays leaving a smooth-shaded triangle to its front start
    /// (Hanika 2021, "Hacking the Shadow Terminator", Ray Tracing Gems II
    /// chapter 4): the hit point moved onto the barycentric blend of its
    /// projections onto the corners' tangent planes, where it lies below them.
    /// On a coarse mesh of a curved surface that is where the smooth surface
    /// would be, so shadow rays leave from above the facet and the shading
    /// terminator is not cut into facets. `None` for flat hits and for views
    /// from the back.
    fn terminator_point(&self, its: &Interaction) -> Option<SurfacePoint> {
        if its.ng != its.sp.n {
            return None;
        }
        let c = self.corner_normals(its.prim)?;
        let tri = self.scene.triangle(its.prim);
        let b = [1.0 - its.u - its.v, its.u, its.v];
        let p = its.sp.p;
        let mut shift = Vec3::ZERO;
        for k in 0..3 {
            shift -= b[k] * (p - tri[k]).dot(c[k]).min(0.0) * c[k];
        }
        if shift == Vec3::ZERO || !shift.is_finite() {
            return None;
        }
        let q = p + shift;
        Some(SurfacePoint {
            p: q,
            p_err: its.sp.p_err
                + Vec3::splat(gamma(8) * (p.abs().max_element() + shift.abs().max_element())),
            n: its.sp.n,
        })
    }

    /// Emission leaving the surface towards the viewer.
    fn zero_bounce_radiance(&self, its: &Interaction) -> Vec3 {
        self.lights.le(self.scene, its.prim, its.sp.n, its.wo)
    }

    /// The material's BSDF at `its` and continue the path there.
    fn shade<const M: bool, const D: bool, const E: bool, const A: bool, const S: bool>(
        &self,
        its: &Interaction,
        beta: Vec3,
        eta_scale: f32,
        depth: u32,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        // without spheres every primitive is a triangle: no dispatch
        let m = if S {
            self.scene.material_index(its.prim)
        } else {
            self.scene.tri_material[its.prim as usize]
        } as usize;
        if !M {
            let bsdf = Diffuse {
                albedo: self.albedo[m],
            };
            return self.bounce::<Diffuse, M, D, E, A, S>(
                its, &bsdf, beta, eta_scale, depth, sampler, rays,
            );
        }
        let material = &self.scene.materials[m];
        let Some(t) = &material.texture else {
            return self.bounce::<Bsdf, M, D, E, A, S>(
                its,
                &material.bsdf,
                beta,
                eta_scale,
                depth,
                sampler,
                rays,
            );
        };
        let uv = self.scene.uv(its.prim, &its.sp, its.u, its.v);
        let albedo = t.eval(uv).clamp(Vec3::ZERO, Vec3::ONE);
        let textured = match &material.bsdf {
            Bsdf::Plastic(p) => Bsdf::Plastic(p.with_diffuse(albedo)),
            Bsdf::Phong(p) => Bsdf::Phong(Phong {
                diffuse: albedo,
                ..*p
            }),
            _ => Bsdf::Diffuse(Diffuse { albedo }),
        };
        self.bounce::<Bsdf, M, D, E, A, S>(its, &textured, beta, eta_scale, depth, sampler, rays)
    }

    /// Light arriving after one or more bounces at `its` with BSDF `bsdf`,
    /// where `beta` is the path throughput up to `its`, `eta_scale` the
    /// product of the refraction factors `eta'^2` along it, and `depth` the
    /// bounce about to happen.
    #[allow(clippy::too_many_arguments)]
    fn bounce<
        B: Bxdf,
        const M: bool,
        const D: bool,
        const E: bool,
        const A: bool,
        const S: bool,
    >(
        &self,
        its: &Interaction,
        bsdf: &B,
        beta: Vec3,
        eta_scale: f32,
        depth: u32,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        // A BSDF that transmits needs the outward normal (bsdf module docs).
        let transmits = M && bsdf.has_transmission();
        let frame = Frame::from_normal(if transmits && its.ng != its.sp.n {
            -its.ns
        } else {
            its.ns
        });
        let wo_local = frame.to_local(its.wo);
        let n_light = self.settings.light_samples.max(1) as f32;
        let use_light = self.settings.direct != DirectStrategy::Bsdf;
        let use_bsdf_emission = self.settings.direct != DirectStrategy::Light;
        let mis = self.settings.direct == DirectStrategy::Mis;
        // Delta lights can only be light-sampled, whatever the strategy.
        let sample_lights = use_light || (D && self.lights.has_delta());
        let mut l = Vec3::ZERO;
        // Rays to the front of a smooth triangle leave from above it.
        let from = if S && !transmits {
            self.terminator_point(its)
        } else {
            None
        };

        // --- direct lighting: light sampling (useless on a pure delta BSDF) ---
        if sample_lights && !self.lights.is_empty() && !(D && bsdf.is_delta()) {
            let mut sum = Vec3::ZERO;
            for _ in 0..self.settings.light_samples.max(1) {
                let u_sel = sampler.next_1d();
                let u = sampler.next_2d();
                let Some(ls) =
                    self.lights
                        .sample(self.scene, from.as_ref().unwrap_or(&its.sp), u_sel, u)
                else {
                    continue;
                };
                let delta_light = D && ls.delta;
                if !use_light && !delta_light {
                    continue;
                }
                // no light through the geometric surface, whatever the
                // shading normal says (a no-op when shading flat)
                if S && !transmits && ls.wi.dot(its.ng) <= 0.0 {
                    continue;
                }
                let wi_local = frame.to_local(ls.wi);
                let f = bsdf.eval(wo_local, wi_local);
                if f == Vec3::ZERO || ls.li == Vec3::ZERO {
                    continue;
                }
                rays.shadow += 1;
                if self.accel.occluded(&ls.shadow) {
                    continue;
                }
                let w = if delta_light || !mis {
                    1.0
                } else {
                    power_heuristic(n_light, ls.pdf, 1.0, bsdf.pdf(wo_local, wi_local))
                };
                sum += f * ls.li * (wi_local.z.abs() * w / ls.pdf);
            }
            l += sum / n_light;
        }

        // --- BSDF sampling ---
        let Some(bs) = bsdf.sample(wo_local, sampler.next_2d()) else {
            return l;
        };
        let wi = frame.to_world(bs.wi);
        // the sample must leave on the side of the geometric surface its lobe
        // says: reflection on wo's side, transmission on the other (a no-op
        // when shading flat)
        let refracted = bs.wi.z * wo_local.z < 0.0;
        if S && ((wi.dot(its.ng) > 0.0) == refracted) {
            return l;
        }
        let weight = bs.weight();
        let ray = match &from {
            Some(p) if wi.dot(its.sp.n) > 0.0 => spawn_ray(p, wi),
            _ => spawn_ray(&its.sp, wi),
        };
        rays.extension += 1;
        let next = self.accel.intersect(&ray);
        let delta_sample = D && bs.delta;

        // --- emission found by the BSDF sample (the other half of direct lighting) ---
        let next_its = next.map(|h| self.interaction::<S>(&ray, &h));
        if (A || E) && (use_bsdf_emission || delta_sample) {
            let (le, light_pdf) = match &next_its {
                None if E => (self.lights.environment(wi), self.lights.pdf_environment(wi)),
                Some(n) if A => (
                    self.lights.le(self.scene, n.prim, n.sp.n, n.wo),
                    // the density light sampling had, from where it sampled
                    self.lights
                        .pdf_area(from.as_ref().unwrap_or(&its.sp), n.prim, &n.sp),
                ),
                _ => (Vec3::ZERO, 0.0),
            };
            if le != Vec3::ZERO {
                let w = if mis && use_light && !delta_sample {
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
        let mut eta_scale = eta_scale;
        if M && transmits && refracted {
            // undo the 1 / eta'^2 of the refraction for the roulette
            let etap = if wo_local.z > 0.0 {
                bsdf.eta()
            } else {
                1.0 / bsdf.eta()
            };
            eta_scale *= etap * etap;
        }
        if depth >= self.settings.rr_depth {
            let q = match self.settings.roulette {
                Roulette::Throughput => {
                    let b = if M { beta * eta_scale } else { beta };
                    b.max_element().min(1.0)
                }
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
        l + scale
            * self.shade::<M, D, E, A, S>(&next_its, beta, eta_scale, depth + 1, sampler, rays)
    }
}

/// The compiled kernel for each combination of the flags that the estimator
/// specialises on (the lens is handled by [`PathTracer::camera_ray`]).
fn select_kernel<'a>(k: Kernel) -> LiFn<'a> {
    macro_rules! pick {
        ($($m:literal $d:literal $e:literal $a:literal $s:literal),* $(,)?) => {
            match (k.materials, k.delta, k.environment, k.emitters, k.shapes) {
                $(($m, $d, $e, $a, $s) => PathTracer::li_kernel::<$m, $d, $e, $a, $s>,)*
            }
        };
    }
    pick!(
        false false false false false, false false false false true,
        false false false true false, false false false true true,
        false false true false false, false false true false true,
        false false true true false, false false true true true,
        false true false false false, false true false false true,
        false true false true false, false true false true true,
        false true true false false, false true true false true,
        false true true true false, false true true true true,
        true false false false false, true false false false true,
        true false false true false, true false false true true,
        true false true false false, true false true false true,
        true false true true false, true false true true true,
        true true false false false, true true false false true,
        true true false true false, true true false true true,
        true true true false false, true true true false true,
        true true true true false, true true true true true,
    )
}
