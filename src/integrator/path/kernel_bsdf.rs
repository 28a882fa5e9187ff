//! What the batch kernels need of a BSDF ([`KernelBsdf`]), and the BSDF
//! numbers they warp for every lane at once (issue 37: loops over the
//! batch that the compiler vectorises, each lane the bits of the BSDF's own
//! sampling).

use super::{BATCH, Interaction, Shade};
use crate::bsdf::microfacet::ggx_visible_normals_lanes;
use crate::bsdf::{
    Bsdf, BsdfSample, Bxdf, Conductor, ConductorLanes, Diffuse, Distribution, LaneSamples, Masking,
    MetallicRoughness, Phong, samples_at_normals_lanes,
};
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

    /// A rough GGX conductor, whose sample the kernel computes across the
    /// batch ([`Warped::ggx`]; an unguided lane's, the others sample one
    /// at a time).
    fn ggx_conductor(&self) -> Option<&Conductor>;
}

/// A lane's BSDF numbers as the kernel warps them for every lane at once
/// (issue 37): a loop over the batch that vectorises, each lane the bits
/// the BSDF's own sampling computes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Warped {
    /// The cosine-weighted direction
    /// ([`crate::sampling::square_to_cosine_hemisphere`]).
    pub(super) cosine: Vec3,
    /// Where the batch had a rough GGX conductor
    /// ([`KernelBsdf::ggx_conductor`]): the visible normal for the lane's
    /// `wo` (unchecked; meaningless where the lane has no such conductor),
    /// and the conductor's `wi`, `f` and `pdf` for it (before the checks
    /// of [`Conductor::sample_at_normal`]).
    pub(super) ggx: Option<GgxLane>,
}

/// One lane's [`Warped::ggx`].
#[derive(Debug, Clone, Copy)]
pub(super) struct GgxLane {
    h: Vec3,
    wi: Vec3,
    f: Vec3,
    pdf: f32,
}

impl Warped {
    /// Lane `j` of the batch's warps.
    #[inline(always)]
    pub(super) fn lane(cosine: &[[f32; BATCH]; 3], ggx: Option<&GgxLanes>, j: usize) -> Self {
        let v = |a: &[[f32; BATCH]; 3]| Vec3::new(a[0][j], a[1][j], a[2][j]);
        Warped {
            cosine: v(cosine),
            ggx: ggx.map(|(h, s)| GgxLane {
                h: v(h),
                wi: v(&s.wi),
                f: v(&s.f),
                pdf: s.pdf[j],
            }),
        }
    }
}

/// The rough GGX conductors' visible normals and samples of a batch.
pub(super) type GgxLanes = ([[f32; BATCH]; 3], LaneSamples<BATCH>);

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
    fn ggx_conductor(&self) -> Option<&Conductor> {
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
        match (self, &warped.ggx) {
            (Bsdf::Diffuse(d), _) => d.sample_warped(wo, warped.cosine),
            (Bsdf::Conductor(c), Some(g)) if self.ggx_conductor().is_some() => {
                // the checks of `sample_visible` and `sample_at_normal`
                c.microfacet.visible_normal_from(wo, g.h)?;
                if !(g.wi.z > 0.0) {
                    return None;
                }
                BsdfSample {
                    wi: g.wi,
                    f: g.f,
                    pdf: g.pdf,
                    delta: false,
                }
                .checked()
            }
            (b, _) => b.sample(wo, u),
        }
    }

    #[inline(always)]
    fn ggx_conductor(&self) -> Option<&Conductor> {
        match self {
            Bsdf::Conductor(c)
                if c.microfacet.distribution == Distribution::Ggx && !c.microfacet.is_smooth() =>
            {
                Some(c)
            }
            _ => None,
        }
    }
}

impl PathTracer<'_> {
    /// The GGX visible normals and the samples of the lanes whose unguided
    /// BSDF is a rough GGX conductor ([`KernelBsdf::ggx_conductor`]), for
    /// their numbers `u`; `None` when no lane has one.
    #[inline(always)]
    pub(super) fn ggx_samples<B: KernelBsdf>(
        &self,
        shade: &[Option<Shade<B>>; BATCH],
        u: &[[f32; BATCH]; 2],
    ) -> Option<GgxLanes> {
        let mut c = ConductorLanes {
            alpha: [1.0; BATCH],
            eta: [[1.0; BATCH]; 3],
            k: [[0.0; BATCH]; 3],
            separable: [false; BATCH],
        };
        let mut wo = [[0.0; BATCH], [0.0; BATCH], [1.0; BATCH]];
        let mut any = false;
        for (j, sh) in shade.iter().enumerate() {
            let Some(sh) = sh.as_ref().filter(|sh| sh.guide.is_none()) else {
                continue;
            };
            if let Some(m) = sh.bsdf.ggx_conductor() {
                c.alpha[j] = m.microfacet.alpha;
                c.separable[j] = m.microfacet.masking == Masking::Separable;
                for ch in 0..3 {
                    (c.eta[ch][j], c.k[ch][j]) = (m.eta[ch], m.k[ch]);
                }
                (wo[0][j], wo[1][j], wo[2][j]) = (sh.wo_local.x, sh.wo_local.y, sh.wo_local.z);
                any = true;
            }
        }
        any.then(|| {
            let h = ggx_visible_normals_lanes(&c.alpha, &wo, u);
            let s = samples_at_normals_lanes(&c, &wo, &h);
            (h, s)
        })
    }
}
