//! Direct lighting by light sampling for a batch's lanes: each round
//! draws one light sample per lane with a shading point and traces the
//! round's shadow rays as one batch.

use super::{BATCH, KernelBsdf, Lane, NO_RAY, Shade};
use crate::accel::Coherence;
use crate::integrator::{PathTracer, RayCounts};
use crate::math::Vec3;
use crate::sampling::power_heuristic;
use crate::settings::DirectStrategy;

/// A light sample waiting for its shadow ray: its lane and what it adds
/// if the ray is unoccluded (before the throughput).
#[derive(Debug, Clone, Copy)]
struct Pending {
    lane: usize,
    contribution: Vec3,
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
            contribution: Vec3::ZERO,
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
                let w = if delta_light || !mis {
                    1.0
                } else {
                    power_heuristic(n_light, ls.pdf, 1.0, self.scatter_pdf(sh, wi_local, ls.wi))
                };
                shadow[n] = ls.shadow;
                pending[n] = Pending {
                    lane: i,
                    contribution: f * ls.li * (wi_local.z.abs() * w / ls.pdf),
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
                if !o {
                    sum[p.lane] += p.contribution;
                }
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
