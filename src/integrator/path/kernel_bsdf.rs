//! What the batch kernels need of a BSDF ([`KernelBsdf`]), and the BSDF
//! numbers they warp for every lane at once (issue 37: loops over the
//! batch that the compiler vectorises, each lane the bits of the BSDF's own
//! sampling).

use super::{BATCH, Interaction, Shade};
use crate::bsdf::microfacet::ggx_visible_normals_lanes;
use crate::bsdf::{Bsdf, BsdfSample, Bxdf, Diffuse, Distribution, MetallicRoughness, Phong};
use crate::integrator::PathTracer;
use crate::math::{Vec2, Vec3};

/// A BSDF as a kernel evaluates it: the diffuse-only kernels read a
/// Lambertian from the per-material albedo table, the others dispatch on
/// the material (with its texture).
pub(super) trait KernelBsdf: Bxdf + Copy {
    /// The BSDF of material `m` at `its`.
    fn at(tracer: &PathTracer<'_>, its: &Interaction, m: usize) -> Self;

    /// The BSDF's sample for the numbers `u`, given what the kernel warped
    /// them to across the batch (which a Lambertian lobe and a rough GGX
    /// conductor take as they are, the others ignore).
    fn sample_given(&self, wo: Vec3, u: Vec2, warped: &Warped) -> Option<BsdfSample>;

    /// The roughness of a rough GGX conductor, whose visible normal the
    /// kernel samples across the batch ([`Warped::ggx`]).
    fn ggx_alpha(&self) -> Option<f32>;
}

/// A lane's BSDF numbers as the kernel warps them for every lane at once
/// (issue 37): a loop over the batch that vectorises, each lane the bits
/// the BSDF's own sampling computes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Warped {
    /// The cosine-weighted direction
    /// ([`crate::sampling::square_to_cosine_hemisphere`]).
    pub(super) cosine: Vec3,
    /// The GGX visible normal for [`KernelBsdf::ggx_alpha`] and the
    /// lane's `wo` (unchecked; zero where the lane has no such conductor).
    pub(super) ggx: Vec3,
}

impl KernelBsdf for Diffuse {
    #[inline]
    fn at(tracer: &PathTracer<'_>, _: &Interaction, m: usize) -> Self {
        Diffuse {
            albedo: tracer.albedo[m],
        }
    }

    #[inline(always)]
    fn sample_given(&self, wo: Vec3, _: Vec2, warped: &Warped) -> Option<BsdfSample> {
        self.sample_warped(wo, warped.cosine)
    }

    #[inline(always)]
    fn ggx_alpha(&self) -> Option<f32> {
        None
    }
}

impl KernelBsdf for Bsdf {
    #[inline]
    fn at(tracer: &PathTracer<'_>, its: &Interaction, m: usize) -> Self {
        let material = &tracer.scene.materials[m];
        if material.texture.is_none() && !material.maps.textures_bsdf() {
            return material.bsdf;
        }
        let uv = tracer.scene.uv(its.prim, &its.sp, its.u, its.v);
        let mut bsdf = match &material.texture {
            None => material.bsdf,
            Some(t) => {
                let albedo = t.eval(uv).clamp(Vec3::ZERO, Vec3::ONE);
                match &material.bsdf {
                    Bsdf::Plastic(p) => Bsdf::Plastic(p.with_diffuse(albedo)),
                    Bsdf::Phong(p) => Bsdf::Phong(Phong {
                        diffuse: albedo,
                        ..*p
                    }),
                    Bsdf::MetallicRoughness(m) => Bsdf::MetallicRoughness(MetallicRoughness {
                        base_color: albedo,
                        ..*m
                    }),
                    _ => Bsdf::Diffuse(Diffuse { albedo }),
                }
            }
        };
        material.maps.apply(&mut bsdf, uv);
        bsdf
    }

    #[inline(always)]
    fn sample_given(&self, wo: Vec3, u: Vec2, warped: &Warped) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(d) => d.sample_warped(wo, warped.cosine),
            Bsdf::Conductor(c) if self.ggx_alpha().is_some() => {
                let h = c.microfacet.visible_normal_from(wo, warped.ggx)?;
                c.sample_at_normal(wo, h)
            }
            b => b.sample(wo, u),
        }
    }

    #[inline(always)]
    fn ggx_alpha(&self) -> Option<f32> {
        match self {
            Bsdf::Conductor(c)
                if c.microfacet.distribution == Distribution::Ggx && !c.microfacet.is_smooth() =>
            {
                Some(c.microfacet.alpha)
            }
            _ => None,
        }
    }
}

impl PathTracer<'_> {
    /// The GGX visible normals of the lanes whose unguided BSDF is a rough
    /// GGX conductor ([`KernelBsdf::ggx_alpha`]), for their numbers `u`;
    /// `None` when no lane has one.
    #[inline(always)]
    pub(super) fn ggx_normals<B: KernelBsdf>(
        &self,
        shade: &[Option<Shade<B>>; BATCH],
        u: &[[f32; BATCH]; 2],
    ) -> Option<[[f32; BATCH]; 3]> {
        let mut alpha = [1.0; BATCH];
        let mut wo = [[0.0; BATCH], [0.0; BATCH], [1.0; BATCH]];
        let mut any = false;
        for (k, sh) in shade.iter().enumerate() {
            let Some(sh) = sh.as_ref().filter(|sh| sh.guide.is_none()) else {
                continue;
            };
            if let Some(a) = sh.bsdf.ggx_alpha() {
                alpha[k] = a;
                (wo[0][k], wo[1][k], wo[2][k]) = (sh.wo_local.x, sh.wo_local.y, sh.wo_local.z);
                any = true;
            }
        }
        any.then(|| ggx_visible_normals_lanes(&alpha, &wo, u))
    }
}
