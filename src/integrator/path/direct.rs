//! Direct lighting by light sampling for a batch's lanes: each round
//! draws one light sample per lane with a shading point and traces the
//! round's shadow rays as one batch.

use super::{BATCH, KernelBsdf, Lane, NO_RAY, Shade};
use crate::accel::Coherence;
use crate::integrator::{PathTracer, RayCounts};
use crate::math::Vec3;
use crate::sampling::power_heuristic;
use crate::settings::DirectStrategy;

/// A light sample waiting for its shadow ray: its lane, and what it adds
/// if the ray is unoccluded (before the throughput and the MIS weight,
/// which is computed only then: most shadow rays of a scene lit through a
/// gap are occluded, and a guided bounce's weight walks the guide's tree).
#[derive(Debug, Clone, Copy)]
struct Pending {
    lane: usize,
    /// The BSDF value (shadowing included) times the light's radiance.
    f_li: Vec3,
    /// The direction to the light, in the lane's shading frame and in the
    /// world.
    wi_local: Vec3,
    wi: Vec3,
    /// The light sample's density.
    pdf: f32,
    /// The sample is weighted against BSDF sampling (else by 1: a delta
    /// light, or no MIS).
    weighted: bool,
}

impl PathTracer<'_> {
    /// Light sampling at every lane with a shading point: `light_samples`
    /// rounds, each drawing one light sample per lane and tracing the
    /// round's shadow rays as one batch; each lane adds the mean of its
    /// unoccluded samples times its throughput.
    #[inline(always)]
    pub(super) fn sample_lights<B: KernelBsdf, const DELTA: bool, const SHAPES: bool>(
        &self,
        lanes: &mut [Lane],
        shade: &[Option<Shade<B>>; BATCH],
        rays: &mut RayCounts,
    ) {
        let direct = self.settings.direct;
        let use_light = direct != DirectStrategy::Bsdf;
        let mis = direct == DirectStrategy::Mis;
        // Delta and panel lights can only be light-sampled, whatever the
        // strategy.
        let sample_lights = use_light || (DELTA && self.lights.has_unreachable());
        if !sample_lights || self.lights.is_empty() {
            return;
        }
        let rounds = self.settings.light_samples.max(1);
        let n_light = rounds as f32;
        let certain = self.lights.choice_is_certain();
        let mut sum = [Vec3::ZERO; BATCH];
        let mut shadow = [NO_RAY; BATCH];
        let mut pending = [Pending {
            lane: 0,
            f_li: Vec3::ZERO,
            wi_local: Vec3::Z,
            wi: Vec3::Z,
            pdf: 1.0,
            weighted: false,
        }; BATCH];
        let mut occluded = [false; BATCH];
        let mut any = false;
        for _ in 0..rounds {
            let mut n = 0;
            for (i, (lane, sh)) in lanes.iter_mut().zip(shade).enumerate() {
                // useless on a pure delta BSDF
                let Some(sh) = sh
                    .as_ref()
                    .filter(|sh| sh.sample_lights && !(DELTA && sh.bsdf.is_delta()))
                else {
                    continue;
                };
                any = true;
                // the light choice's number, drawn only where it can matter
                let u_sel = if certain {
                    lane.sampler.skip_1d();
                    0.0
                } else {
                    lane.sampler.next_1d()
                };
                let u = lane.sampler.next_2d();
                let from = sh.from.as_ref().unwrap_or(&sh.its.sp);
                let Some(ls) = self.lights.sample(self.scene, from, u_sel, u) else {
                    continue;
                };
                let delta_light = DELTA && ls.unreachable;
                if !use_light && !delta_light {
                    continue;
                }
                // no light through the geometric surface, whatever the
                // shading normal says (a no-op when shading flat)
                if SHAPES && !sh.transmits && ls.wi.dot(sh.its.ng) <= 0.0 {
                    continue;
                }
                let wi_local = sh.frame.to_local(ls.wi);
                let f = sh.bsdf.eval(sh.wo_local, wi_local) * sh.shadowing(ls.wi);
                if f == Vec3::ZERO || ls.li == Vec3::ZERO {
                    continue;
                }
                shadow[n] = ls.shadow;
                pending[n] = Pending {
                    lane: i,
                    f_li: f * ls.li,
                    wi_local,
                    wi: ls.wi,
                    pdf: ls.pdf,
                    weighted: mis && !delta_light,
                };
                n += 1;
            }
            if n == 0 {
                continue;
            }
            rays.shadow += n as u64;
            match self.alpha {
                None => self.accel.occluded_batch(
                    &shadow[..n],
                    &mut occluded[..n],
                    Coherence::Incoherent,
                ),
                Some(alpha) => {
                    for (ray, o) in shadow[..n].iter().zip(&mut occluded[..n]) {
                        *o = self.accel.occluded_masked(ray, alpha);
                    }
                }
            }
            for (p, &o) in pending[..n].iter().zip(&occluded[..n]) {
                if o {
                    continue;
                }
                let w = match &shade[p.lane] {
                    Some(sh) if p.weighted => {
                        power_heuristic(n_light, p.pdf, 1.0, self.scatter_pdf(sh, p.wi_local, p.wi))
                    }
                    _ => 1.0,
                };
                sum[p.lane] += p.f_li * (p.wi_local.z.abs() * w / p.pdf);
            }
        }
        if any {
            for (i, lane) in lanes.iter_mut().enumerate() {
                if shade[i].is_some() {
                    lane.l += lane.beta * (sum[i] / n_light);
                }
            }
        }
    }
}
