//! The estimator's per-path work, done for a batch of paths in lockstep
//! (a small wavefront): every path of the batch shades its hit, then the
//! shadow rays of all of them go to the backend together, then their
//! continuation rays, so a backend that traces packets (Embree) gets full
//! packets. The camera rays of a batch come from one 4 x 4 block of pixels
//! and are traced as a coherent packet.
//!
//! Each path is the forward form of the recursive estimator in the module
//! above: `L = sum_k beta_k l_k`, where `l_k` is what bounce `k` adds
//! (emission seen, light-sampled direct light, the emission its BSDF sample
//! finds) and `beta_k` the throughput up to it, roulette included. A path
//! owns its sampler and draws from it in the same order whatever the batch
//! holds: at each bounce, the roulette number for going on, then
//! `light_samples` pairs (light choice, point), then the BSDF sample. A
//! batch is always the same paths (one pixel block's, at one sample index;
//! the render loop keeps blocks whole whatever the tiling), so the image is
//! a function of the scene, the settings and the seed, for any thread count
//! or tile size. The pure-Rust backends answer a ray in a batch bit for bit
//! as alone; Embree's packet kernels may break a tie on an edge differently
//! from its single-ray kernel (`tests/conformance.rs`), which is why the
//! batches are fixed.

use super::{PathTracer, RayCounts};
use crate::accel::{Coherence, Hit};
use crate::bsdf::{Bsdf, Bxdf, Diffuse};
use crate::math::{Frame, Ray, SurfacePoint, Vec2, Vec3, gamma, spawn_ray};
use crate::sampler::Sampler;
use crate::sampling::{power_heuristic, square_to_cosine_hemisphere_lanes};
use crate::scene::EmissionRole;
use crate::scene::maps::{shadowing_alpha2, shadowing_g};
use crate::settings::{DirectStrategy, Roulette};
use std::marker::PhantomData;

mod direct;
mod guided;
mod kernel_bsdf;
pub use guided::{GuideVertex, take_recorded};
use guided::{adjoint_roulette, record};
use kernel_bsdf::{KernelBsdf, Warped};

/// Paths traced together: a 4 x 4 block of pixels, the width of Embree's
/// widest packet.
pub const BATCH: usize = 16;

/// Side of the square pixel block whose camera rays form one batch.
pub const BLOCK: u32 = 4;

/// One path of a batch: its sampler, the ray it is about to trace, and what
/// it has gathered so far.
#[derive(Debug, Clone)]
pub struct Lane {
    /// The path's sample generator.
    pub sampler: Sampler,
    /// The ray to trace next (the camera ray, for a new lane).
    pub ray: Ray,
    /// Radiance gathered so far; the sample's value once the batch is done.
    pub l: Vec3,
    /// Throughput up to the next hit.
    beta: Vec3,
    /// Product of the refraction factors `eta'^2` along the path.
    eta_scale: f32,
    /// The bounce that sent `ray` (0: the camera).
    depth: u32,
    alive: bool,
    /// The scattering event that sent `ray`, for the emission it finds.
    prev: Prev,
    /// Adjoint-driven roulette's factor for this lane's pixel
    /// ([`crate::guiding::Guide::roulette_scale`]); 0: roulette by the
    /// settings' rule.
    roulette_scale: f32,
}

/// What the emission a BSDF-sampled ray finds is weighted with.
#[derive(Debug, Clone, Copy)]
struct Prev {
    /// Throughput times the BSDF sample's weight, before roulette.
    beta_weight: Vec3,
    /// The BSDF sample's solid-angle density.
    pdf: f32,
    /// The sample came from a delta lobe (no light sample could have made it).
    delta: bool,
    /// Where light sampling looked from at that bounce.
    from: SurfacePoint,
    /// That bounce sampled lights (else the BSDF sample's light weighs 1).
    light_sampled: bool,
}

impl Lane {
    /// A path that starts with the camera ray `ray`, drawing from `sampler`.
    pub fn new(sampler: Sampler, ray: Ray) -> Self {
        Lane {
            sampler,
            ray,
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            eta_scale: 1.0,
            depth: 0,
            alive: true,
            prev: Prev {
                beta_weight: Vec3::ZERO,
                pdf: 0.0,
                delta: false,
                from: SurfacePoint {
                    p: Vec3::ZERO,
                    p_err: Vec3::ZERO,
                    n: Vec3::Z,
                },
                light_sampled: false,
            },
            roulette_scale: 0.0,
        }
    }
}

/// A ray's hit, resolved into what shading needs.
#[derive(Debug, Clone, Copy)]
pub(super) struct Interaction {
    pub(super) prim: u32,
    /// The geometric surface point; `sp.n` is the front (outward) normal.
    pub(super) sp: SurfacePoint,
    /// Unit direction back along the incoming ray.
    pub(super) wo: Vec3,
    /// Geometric normal turned to `wo`'s side.
    pub(super) ng: Vec3,
    /// Shading normal on `ng`'s side (equal to `ng` when shading flat).
    pub(super) ns: Vec3,
    /// Barycentrics of the hit (triangles).
    pub(super) u: f32,
    pub(super) v: f32,
}

/// A lane's shading point at the current bounce.
#[derive(Debug, Clone, Copy)]
struct Shade<B> {
    its: Interaction,
    bsdf: B,
    frame: Frame,
    wo_local: Vec3,
    /// The BSDF transmits (and the kernel has materials).
    transmits: bool,
    /// Where rays to the front of a smooth triangle start (Hanika's point).
    from: Option<SurfacePoint>,
    /// The unperturbed shading normal and `a2` of a normal-mapped
    /// material's shadowing term ([`crate::scene::Maps::shadowing`]).
    shadowing: Option<(Vec3, f32)>,
    /// The guide's leaf here, when the render is guided, the BSDF has no
    /// delta lobe and the leaf has learned something
    /// ([`crate::guiding`]).
    guide: Option<u32>,
    /// The lane's radiance when it arrived here, for guiding's training
    /// ([`GuideVertex::l_in`]).
    l_in: Vec3,
    /// Light sampling runs here: the BSDF's lobes are not all far more
    /// concentrated than the lights, or its maps perturb the normal
    /// ([`super::LIGHT_SAMPLING_PEAK_RATIO`]).
    sample_lights: bool,
}

impl<B> Shade<B> {
    /// The shadowing term for light from `wi` (1 without one).
    #[inline]
    fn shadowing(&self, wi: Vec3) -> f32 {
        match self.shadowing {
            None => 1.0,
            Some((n, a2)) => shadowing_g(n, a2, wi),
        }
    }
}

/// The corner normals `c` blended at barycentrics `(u, v)`, not normalised.
#[inline]
fn interpolate(c: [Vec3; 3], u: f32, v: f32) -> Vec3 {
    (1.0 - u - v) * c[0] + u * c[1] + v * c[2]
}

/// One call of a kernel, run by [`crate::simd::Dispatch::run`] so that
/// the kernel's inlined steps compile for the chosen instruction set.
struct Kernel<
    't,
    'a,
    'l,
    B,
    const M: bool,
    const D: bool,
    const E: bool,
    const L: bool,
    const S: bool,
> {
    tracer: &'t PathTracer<'a>,
    lanes: &'l mut [Lane],
    rays: &'l mut RayCounts,
    bsdf: PhantomData<B>,
}

impl<B: KernelBsdf, const M: bool, const D: bool, const E: bool, const L: bool, const S: bool>
    pulp::WithSimd for Kernel<'_, '_, '_, B, M, D, E, L, S>
{
    type Output = ();
    #[inline(always)]
    fn with_simd<V: pulp::Simd>(self, _: V) {
        self.tracer
            .trace_lanes::<B, M, D, E, L, S>(self.lanes, self.rays);
    }
}

/// A placeholder ray for unused batch slots.
const NO_RAY: Ray = Ray {
    o: Vec3::ZERO,
    d: Vec3::Z,
    t_max: 0.0,
};

impl<'a> PathTracer<'a> {
    /// Trace the paths of `lanes` (at most [`BATCH`]) to the end, in
    /// lockstep; each lane's `l` then holds its sample's radiance. The const
    /// parameters are the flags of [`crate::plan::Kernel`] of the same names
    /// (the lens is the camera ray's): code for an effect whose flag is off
    /// is compiled out.
    pub(super) fn trace_kernel<
        const MATERIALS: bool,
        const DELTA: bool,
        const ENVIRONMENT: bool,
        const EMITTERS: bool,
        const SHAPES: bool,
    >(
        &self,
        lanes: &mut [Lane],
        rays: &mut RayCounts,
    ) {
        if MATERIALS {
            self.simd.run(
                Kernel::<Bsdf, MATERIALS, DELTA, ENVIRONMENT, EMITTERS, SHAPES> {
                    tracer: self,
                    lanes,
                    rays,
                    bsdf: PhantomData,
                },
            );
        } else {
            self.simd.run(
                Kernel::<Diffuse, MATERIALS, DELTA, ENVIRONMENT, EMITTERS, SHAPES> {
                    tracer: self,
                    lanes,
                    rays,
                    bsdf: PhantomData,
                },
            );
        }
    }

    #[inline(always)]
    fn trace_lanes<
        B: KernelBsdf,
        const MATERIALS: bool,
        const DELTA: bool,
        const ENVIRONMENT: bool,
        const EMITTERS: bool,
        const SHAPES: bool,
    >(
        &self,
        lanes: &mut [Lane],
        rays: &mut RayCounts,
    ) {
        debug_assert!(lanes.len() <= BATCH);
        let mut batch = [NO_RAY; BATCH];
        let mut hits: [Option<Hit>; BATCH] = [None; BATCH];
        let mut slot = [0usize; BATCH];
        let mut shade: [Option<Shade<B>>; BATCH] = [None; BATCH];
        loop {
            // --- trace every live path's ray, the camera's as a packet ---
            let mut n = 0;
            let mut camera = false;
            for (i, lane) in lanes.iter().enumerate() {
                if lane.alive {
                    batch[n] = lane.ray;
                    slot[n] = i;
                    camera |= lane.depth == 0;
                    n += 1;
                }
            }
            if n == 0 {
                return;
            }
            let coherence = if camera {
                Coherence::Coherent
            } else {
                Coherence::Incoherent
            };
            match self.alpha {
                None => self
                    .accel
                    .intersect_batch(&batch[..n], &mut hits[..n], coherence),
                Some(alpha) => {
                    for (ray, hit) in batch[..n].iter().zip(&mut hits[..n]) {
                        *hit = self.accel.intersect_masked(ray, alpha);
                    }
                }
            }
            if camera {
                rays.camera += n as u64;
            } else {
                rays.extension += n as u64;
            }

            // --- what each hit adds, and whether its path goes on ---
            for k in 0..n {
                let i = slot[k];
                shade[i] = self.arrive::<B, MATERIALS, DELTA, ENVIRONMENT, EMITTERS, SHAPES>(
                    &mut lanes[i],
                    hits[k],
                );
            }

            // --- direct lighting: light sampling, shadow rays in batches ---
            self.sample_lights::<B, DELTA, SHAPES>(lanes, &shade, rays);

            // --- BSDF sampling: each live path's next ray; what the
            // numbers warp to for every lane at once (a Lambertian lobe's
            // direction, a rough GGX conductor's sample), in loops that
            // vectorise ---
            let mut u = [[0.5; BATCH]; 2];
            for (i, (lane, sh)) in lanes.iter_mut().zip(&shade).enumerate() {
                if sh.is_some() {
                    let v = lane.sampler.next_2d();
                    (u[0][i], u[1][i]) = (v.x, v.y);
                }
            }
            let cosine = square_to_cosine_hemisphere_lanes(&u);
            let ggx = if MATERIALS {
                self.ggx_samples(&shade, &u)
            } else {
                None
            };
            for (i, (lane, sh)) in lanes.iter_mut().zip(shade.iter_mut()).enumerate() {
                if let Some(s) = sh {
                    let u = Vec2::new(u[0][i], u[1][i]);
                    let warped = Warped::lane(&cosine, ggx.as_ref(), i);
                    self.scatter::<B, MATERIALS, DELTA, SHAPES>(lane, i, s, u, &warped);
                    *sh = None;
                }
            }
        }
    }

    /// Lane `lane`'s ray found `hit`: add the emission it sees, end the path
    /// where it ends (a miss, the depth limit, roulette), and otherwise
    /// return the shading point of the next bounce.
    #[inline(always)]
    fn arrive<
        B: KernelBsdf,
        const MATERIALS: bool,
        const DELTA: bool,
        const ENVIRONMENT: bool,
        const EMITTERS: bool,
        const SHAPES: bool,
    >(
        &self,
        lane: &mut Lane,
        hit: Option<Hit>,
    ) -> Option<Shade<B>> {
        let its = hit.map(|h| self.interaction::<SHAPES>(&lane.ray, &h));
        if lane.depth == 0 {
            // --- emission seen directly ---
            let Some(its) = its else {
                if ENVIRONMENT {
                    lane.l += self.lights.environment(lane.ray.d);
                }
                lane.alive = false;
                return None;
            };
            if EMITTERS {
                lane.l += self.zero_bounce_radiance(&its);
            }
            if self.settings.max_depth < 1 || self.black_from_behind(&its) {
                lane.alive = false;
                return None;
            }
            let leaf = self.guide.as_ref().map(|g| g.leaf_index(its.sp.p, its.ng));
            return Some(Shade {
                l_in: lane.l,
                ..self.shading_point::<B, MATERIALS, SHAPES>(its, leaf)
            });
        }

        // --- emission found by the last BSDF sample (the other half of
        // that bounce's direct lighting) ---
        let prev = lane.prev;
        let direct = self.settings.direct;
        if (EMITTERS || ENVIRONMENT) && (direct != DirectStrategy::Light || prev.delta) {
            let wi = lane.ray.d;
            // the light's density is wanted only for an MIS weight, and
            // only where light is found
            let weighs = direct == DirectStrategy::Mis && !prev.delta && prev.light_sampled;
            let (le, light_pdf) = match &its {
                None if ENVIRONMENT && weighs => self.lights.environment_and_pdf(wi),
                // the same radiance, no density: the bounce that sent the
                // ray sampled no light (a narrow lobe's, see
                // `light_choice`), so its BSDF sample weighs 1
                None if ENVIRONMENT => (self.lights.environment(wi), 0.0),
                // emission seen only: not after a non-delta bounce, nor
                // past the last bounce (EmissionRole::SeenOnly)
                Some(n)
                    if EMITTERS
                        && self.seen_only
                        && (!prev.delta || lane.depth >= self.settings.max_depth)
                        && self.scene.material(n.prim).role == EmissionRole::SeenOnly =>
                {
                    (Vec3::ZERO, 0.0)
                }
                Some(n) if EMITTERS => {
                    let le = self.emitted(n);
                    // the density light sampling had, from where it
                    // sampled: only for an MIS weight of light found
                    let pdf = if weighs && le != Vec3::ZERO {
                        self.lights.pdf_area(&prev.from, n.prim, &n.sp)
                    } else {
                        0.0
                    };
                    (le, pdf)
                }
                _ => (Vec3::ZERO, 0.0),
            };
            if le != Vec3::ZERO {
                let w = if weighs {
                    let n_light = self.settings.light_samples.max(1) as f32;
                    power_heuristic(1.0, prev.pdf, n_light, light_pdf)
                } else {
                    1.0
                };
                lane.l += prev.beta_weight * le * w;
            }
        }

        // --- indirect lighting goes on, with Russian roulette ---
        let Some(its) = its else {
            lane.alive = false;
            return None;
        };
        if lane.depth >= self.settings.max_depth || self.black_from_behind(&its) {
            lane.alive = false;
            return None;
        }
        // adjoint-driven where the guide estimates this point's radiance
        // and the pixel's ([`adjoint_roulette`]), else the settings' rule
        let leaf = self.guide.as_ref().map(|g| g.leaf_index(its.sp.p, its.ng));
        if let Some(radiance) = self.adjoint_radiance(lane, leaf) {
            // the number is drawn whatever q is, so every bounce draws as
            // many as the last
            let q = adjoint_roulette(lane, radiance);
            if lane.sampler.next_1d() >= q {
                lane.alive = false;
                return None;
            }
            lane.beta /= q;
        } else if lane.depth >= self.settings.rr_depth {
            let q = match self.settings.roulette {
                Roulette::Throughput => {
                    let b = if MATERIALS {
                        lane.beta * lane.eta_scale
                    } else {
                        lane.beta
                    };
                    b.max_element().min(1.0)
                }
                Roulette::Fixed(p) => p.min(1.0),
            };
            // q <= 0 (or NaN) ends the path; never divide by it
            if !(q > 0.0) || lane.sampler.next_1d() >= q {
                lane.alive = false;
                return None;
            }
            lane.beta /= q;
        }
        debug_assert!(lane.beta.is_finite(), "throughput became {}", lane.beta);
        Some(Shade {
            l_in: lane.l,
            ..self.shading_point::<B, MATERIALS, SHAPES>(its, leaf)
        })
    }

    /// The BSDF, frame and ray origin of a bounce at `its`, whose guide
    /// leaf is `leaf` when the render is guided.
    #[inline(always)]
    fn shading_point<B: KernelBsdf, const MATERIALS: bool, const SHAPES: bool>(
        &self,
        its: Interaction,
        leaf: Option<u32>,
    ) -> Shade<B> {
        // without spheres every primitive is a triangle: no dispatch
        let m = if SHAPES {
            self.scene.material_index(its.prim)
        } else {
            self.scene.tri_material[its.prim as usize]
        } as usize;
        let bsdf = B::at(self, &its, m);
        // A BSDF that transmits needs the outward normal (bsdf module docs).
        let transmits = MATERIALS && bsdf.has_transmission();
        let frame = Frame::from_normal(if transmits && its.ng != its.sp.n {
            -its.ns
        } else {
            its.ns
        });
        // Rays to the front of a smooth triangle leave from above it.
        let from = if SHAPES && !transmits {
            self.terminator_point(&its)
        } else {
            None
        };
        let shadowing = (SHAPES && self.normal_maps && self.scene.materials[m].maps.shadowing)
            .then(|| {
                let n = self.unperturbed_normal(&its);
                (n, shadowing_alpha2(n, its.ns))
            });
        let guide = match (&self.guide, leaf) {
            (Some(g), Some(l))
                if !bsdf.has_delta_component()
                    && g.leaf(l).is_usable()
                    && (self.record || !g.bsdf_only(l)) =>
            {
                Some(l)
            }
            _ => None,
        };
        Shade {
            wo_local: frame.to_local(its.wo),
            its,
            bsdf,
            frame,
            transmits,
            from,
            shadowing,
            guide,
            l_in: Vec3::ZERO,
            sample_lights: !super::bsdf_alone(&bsdf, self.bsdf_alone_from, || {
                SHAPES && self.normal_maps && self.scene.materials[m].maps.perturbs_normal()
            }),
        }
    }

    /// BSDF sampling at `sh` with the lane's numbers `u` (and `warped`,
    /// what they warp to): the lane's next ray and throughput, or the end
    /// of its path.
    #[inline(always)]
    fn scatter<B: KernelBsdf, const MATERIALS: bool, const DELTA: bool, const SHAPES: bool>(
        &self,
        lane: &mut Lane,
        index: usize,
        sh: &Shade<B>,
        u: Vec2,
        warped: &Warped,
    ) {
        let its = &sh.its;
        let bs = match sh.guide {
            None => sh.bsdf.sample_given(sh.wo_local, u, warped),
            Some(leaf) => self.guided_sample(sh, leaf, u),
        };
        let Some(bs) = bs else {
            lane.alive = false;
            return;
        };
        let wi = sh.frame.to_world(bs.wi);
        // the sample must leave on the side of the geometric surface its lobe
        // says: reflection on wo's side, transmission on the other (a no-op
        // when shading flat)
        let refracted = bs.wi.z * sh.wo_local.z < 0.0;
        if SHAPES && ((wi.dot(its.ng) > 0.0) == refracted) {
            lane.alive = false;
            return;
        }
        let weight = bs.weight() * sh.shadowing(wi);
        lane.ray = match &sh.from {
            Some(p) if wi.dot(its.sp.n) > 0.0 => spawn_ray(p, wi),
            _ => spawn_ray(&its.sp, wi),
        };
        lane.prev = Prev {
            beta_weight: lane.beta * weight,
            pdf: bs.pdf,
            delta: DELTA && bs.delta,
            from: sh.from.unwrap_or(its.sp),
            light_sampled: sh.sample_lights,
        };
        let beta_in = lane.beta;
        lane.beta *= weight;
        if self.record && !bs.delta {
            record(index, self.guide_vertex(sh, lane, &bs, wi, beta_in));
        }
        if MATERIALS && sh.transmits && refracted {
            // undo the 1 / eta'^2 of the refraction for the roulette
            let etap = if sh.wo_local.z > 0.0 {
                sh.bsdf.eta()
            } else {
                1.0 / sh.bsdf.eta()
            };
            lane.eta_scale *= etap * etap;
        }
        lane.depth += 1;
    }

    /// Whether `its` is the back of a one-sided material
    /// ([`crate::scene::Material::one_sided`]): `wo` not above its front
    /// shading normal, the interpolated vertex normal where the triangle
    /// has them (as Mitsuba 3 tests the cosine in the shading frame), else
    /// the geometric one. Nothing scatters there.
    #[inline]
    fn black_from_behind(&self, its: &Interaction) -> bool {
        if !self.one_sided || !self.scene.material(its.prim).one_sided {
            return false;
        }
        let front = self
            .corner_normals(its.prim)
            .map(|c| interpolate(c, its.u, its.v))
            .filter(|n| *n != Vec3::ZERO)
            .unwrap_or(its.sp.n);
        its.wo.dot(front) <= 0.0
    }

    /// The shading normal before any map perturbs it: the interpolated
    /// vertex normal where the triangle has them, else the geometric
    /// normal (either side).
    fn unperturbed_normal(&self, its: &Interaction) -> Vec3 {
        self.corner_normals(its.prim)
            .map(|c| interpolate(c, its.u, its.v).normalize_or_zero())
            .filter(|n| *n != Vec3::ZERO)
            .unwrap_or(its.ng)
    }

    #[inline]
    pub(super) fn interaction<const SHAPES: bool>(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let sp = if SHAPES {
            self.scene.hit_point(ray, hit)
        } else {
            self.scene.surface_point_placed(hit.prim, hit.u, hit.v)
        };
        let wo = -ray.d;
        let ng = if sp.n.dot(wo) < 0.0 { -sp.n } else { sp.n };
        let ns = if SHAPES {
            self.shading_normal(hit, &sp, ng, wo)
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
    /// other hit shades with `ng`. A material with a normal or bump map then
    /// perturbs that normal ([`PathTracer::mapped_normal`]). If `wo` would
    /// fall below the shading normal's horizon (closer than
    /// [`super::MIN_SHADING_COS`]), the normal is bent towards `wo` until it
    /// is not, so no view sees a black terminator; a normal that ends up
    /// below the geometric surface gives way to `ng`. Whatever the normal,
    /// the `shapes` kernels' side checks against `ng` keep light from
    /// crossing the geometric surface.
    fn shading_normal(&self, hit: &Hit, sp: &SurfacePoint, ng: Vec3, wo: Vec3) -> Vec3 {
        let mapped = self.normal_maps && self.scene.material(hit.prim).maps.perturbs_normal();
        let smooth = self.corner_normals(hit.prim);
        let mut n = match smooth {
            None if !mapped => return ng,
            None => ng,
            Some(c) => {
                let n = interpolate(c, hit.u, hit.v).normalize_or_zero();
                if n == Vec3::ZERO {
                    if !mapped {
                        return ng;
                    }
                    ng
                } else if n.dot(ng) < 0.0 {
                    -n
                } else {
                    n
                }
            }
        };
        if mapped {
            n = self.mapped_normal(hit, sp, n, ng, wo);
            if n == Vec3::ZERO || n.dot(ng) <= 0.0 {
                return ng;
            }
        }
        let cos = n.dot(wo);
        if cos < super::MIN_SHADING_COS {
            n = (n + (super::MIN_SHADING_COS - cos) * wo).normalize_or_zero();
            if n == Vec3::ZERO || n.dot(ng) <= 0.0 {
                return ng;
            }
        }
        n
    }

    /// The shading normal `n` (on `ng`'s side) perturbed by the material's
    /// normal or bump map, on `ng`'s side; zero when degenerate. Both maps
    /// work on the front side (`sp.n`'s, as Mitsuba 3's `normalmap` and
    /// `bumpmap` work in the shading frame before it is turned to the
    /// viewer) and the result is turned back.
    ///
    /// The tangent frame: `s` is `dp/du` made orthogonal to the normal
    /// (Gram-Schmidt), `t = n x s`; where the UVs are degenerate,
    /// [`Frame::from_normal`]'s tangents stand in.
    ///
    /// - Normal map (Mitsuba's `normalmap`): texel `c`, read raw, is the
    ///   normal `2 c - 1` in `(s, t, n)`, normalised.
    /// - Bump map (Mitsuba's `bumpmap`): with the height's UV gradient
    ///   `(g_u, g_v)` times `bump_scale` ([`crate::texture::ImageTexture::eval_scalar_grad`]),
    ///   `dp/du' = dp/du + n (g_u - n . dp/du)`, likewise `dp/dv'`, and the
    ///   normal is `dp/du' x dp/dv'` normalised, turned to the geometric
    ///   normal's side. A zero gradient leaves `n` as it is (the formula
    ///   gives `n` again, up to rounding); so do degenerate UVs, where the
    ///   height has no slope on the surface.
    fn mapped_normal(&self, hit: &Hit, sp: &SurfacePoint, n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
        let maps = &self.scene.material(hit.prim).maps;
        let flip = if ng == sp.n { 1.0 } else { -1.0 };
        let front = flip * n;
        let uv = self.scene.uv(hit.prim, sp, hit.u, hit.v);
        let d = self.scene.uv_derivatives(hit.prim, sp);
        let mapped = if let Some(t) = &maps.normal {
            let c = 2.0 * t.eval(uv) - Vec3::ONE;
            let s = d
                .map(|[dpdu, _]| (dpdu - front * front.dot(dpdu)).normalize_or_zero())
                .filter(|s| *s != Vec3::ZERO)
                .unwrap_or_else(|| Frame::from_normal(front).s);
            let t = front.cross(s);
            (c.x * s + c.y * t + c.z * front).normalize_or_zero()
        } else if let Some(b) = &maps.bump {
            let g = b.scale * b.texture.eval_scalar_grad(uv);
            let Some([dpdu, dpdv]) = d.filter(|_| g != Vec2::ZERO && g.is_finite()) else {
                return n;
            };
            let du = dpdu + front * (g.x - front.dot(dpdu));
            let dv = dpdv + front * (g.y - front.dot(dpdv));
            let m = du.cross(dv).normalize_or_zero();
            if m.dot(sp.n) < 0.0 { -m } else { m }
        } else {
            return n;
        };
        // Mitsuba's flip_invalid_normals: the viewer and the mapped normal
        // on opposite sides of the unperturbed normal's plane
        let mapped = if maps.flip_invalid && wo.dot(front) * wo.dot(mapped) <= 0.0 {
            (2.0 * mapped.dot(front) * front - mapped).normalize_or_zero()
        } else {
            mapped
        };
        flip * mapped
    }

    /// The vertex normals of triangle `prim`, when all three exist.
    fn corner_normals(&self, prim: u32) -> Option<[Vec3; 3]> {
        self.scene.corner_normals(prim)
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

    /// The denoiser's auxiliary values along camera ray `ray`: `(albedo,
    /// normal)` (see [`super::Auxiliary`] for the definitions). Runs the
    /// general rules (spheres, smooth normals, maps, textures) whatever the
    /// kernel, so it needs no plan.
    pub(super) fn auxiliary_values(&self, camera_ray: &Ray) -> super::Auxiliary {
        let mut ray = *camera_ray;
        let mut first: Option<(Vec3, Vec3, f32)> = None;
        let mut emitted = None;
        let aux = |albedo: Vec3, first: Option<(Vec3, Vec3, f32)>, emitted: Option<Vec3>| {
            super::Auxiliary {
                albedo,
                normal: first.map_or(Vec3::ZERO, |f| f.0),
                first_hit: first.map(|f| (f.1, f.2)),
                emitted: emitted.unwrap_or(Vec3::ZERO),
            }
        };
        for _ in 0..super::AUX_DELTA_CHAIN {
            let Some(hit) = self.closest_hit(&ray) else {
                let env = self.lights.environment(ray.d);
                emitted.get_or_insert(env);
                return aux(env.clamp(Vec3::ZERO, Vec3::ONE), first, emitted);
            };
            let its = self.interaction::<true>(&ray, &hit);
            first.get_or_insert_with(|| (its.ns, its.sp.p, (its.sp.p - camera_ray.o).length()));
            let le = self.emitted(&its);
            emitted.get_or_insert(le);
            let sh = self.shading_point::<Bsdf, true, true>(its, None);
            if !sh.bsdf.is_delta() {
                // an emitter reports its emission too, clamped as the
                // environment's is: its edge against a surface of the same
                // reflectance and normal (a ceiling light) shows in the albedo
                let albedo = (super::reflectance(&sh.bsdf) + le).clamp(Vec3::ZERO, Vec3::ONE);
                return aux(albedo, first, emitted);
            }
            // a delta surface: on along its first lobe
            let Some(bs) = sh.bsdf.sample(sh.wo_local, Vec2::new(0.0, 0.5)) else {
                return aux(Vec3::ONE, first, emitted);
            };
            let wi = sh.frame.to_world(bs.wi);
            ray = spawn_ray(&its.sp, wi);
        }
        aux(Vec3::ONE, first, emitted)
    }

    /// The zero-bounce term of camera ray `ray`: what the first hit emits
    /// towards it, or the environment where it escapes.
    pub(super) fn first_emission_value(&self, ray: &Ray) -> Vec3 {
        match self.closest_hit(ray) {
            None => self.lights.environment(ray.d),
            Some(hit) => self.emitted(&self.interaction::<true>(ray, &hit)),
        }
    }

    /// The closest hit of one ray, through the scene's cut-outs if it has
    /// any (the auxiliary images' query; the kernel traces batches).
    fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        match self.alpha {
            None => self.accel.intersect(ray),
            Some(alpha) => self.accel.intersect_masked(ray, alpha),
        }
    }

    /// Emission leaving the surface towards the viewer.
    fn zero_bounce_radiance(&self, its: &Interaction) -> Vec3 {
        self.emitted(its)
    }

    /// Radiance leaving the surface at `its` towards `wo`: the material's
    /// emission, or its emission texture at the hit's UV.
    #[inline]
    fn emitted(&self, its: &Interaction) -> Vec3 {
        let le = self.lights.le(self.scene, its.prim, its.sp.n, its.wo);
        if !self.lights.has_textured_emission() || le == Vec3::ZERO {
            return le;
        }
        match &self.scene.material(its.prim).maps.emission {
            Some(t) => t.eval(self.scene.uv(its.prim, &its.sp, its.u, its.v)),
            None => le,
        }
    }
}
