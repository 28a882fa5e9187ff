//! Path guiding in the estimator ([`crate::guiding`]): a guided bounce's
//! mixture of the BSDF and the guide, its density, and the bounces a
//! guide's training records.

use super::{KernelBsdf, Lane, Shade};
use crate::bsdf::BsdfSample;
use crate::guiding::fraction::FractionSample;
use crate::integrator::PathTracer;
use crate::math::{Vec2, Vec3};

thread_local! {
    /// The non-delta bounces a recording kernel ([`PathTracer::set_recording`])
    /// traced on this thread, as (lane index in its batch, bounce), in the
    /// order they happened; [`take_recorded`] hands them over. Kept beside
    /// the lanes, not in them, so that a render that does not record moves
    /// no more bytes per lane.
    static RECORDED: std::cell::RefCell<Vec<(u32, GuideVertex)>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// Keep bounce `v` of lane `index` ([`RECORDED`]); out of line, since only
/// a guide's training records.
#[cold]
#[inline(never)]
pub(super) fn record(index: usize, v: GuideVertex) {
    RECORDED.with(|r| r.borrow_mut().push((index as u32, v)));
}

/// The bounces recorded on this thread since the last call (see
/// [`PathTracer::set_recording`]), into `into` (emptied first): a caller
/// that traces one batch and then takes them gets that batch's, in order,
/// whatever thread it runs on. The two vectors trade places, so a caller
/// that keeps passing the same one records without allocating once both
/// are large enough.
pub fn take_recorded(into: &mut Vec<(u32, GuideVertex)>) {
    into.clear();
    RECORDED.with(|r| std::mem::swap(&mut *r.borrow_mut(), into));
}

/// A bounce of a path, as guiding's training records it: the radiance
/// that arrived along `dir` is `(l_end - l) / beta`, and the radiance that
/// left towards the path's previous vertex `(l_end - l_in) / beta_in`, with
/// `l_end` the path's radiance at its end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuideVertex {
    /// Where the bounce was.
    pub p: Vec3,
    /// The geometric normal there, turned to the side the path came from.
    pub n: Vec3,
    /// The direction it sampled (world).
    pub dir: Vec3,
    /// The density it was sampled with (the mixture's, when guided).
    pub pdf: f32,
    /// Throughput after the bounce's sample weight.
    pub beta: Vec3,
    /// Radiance the path had gathered when it sampled the direction.
    pub l: Vec3,
    /// Throughput that arrived at the bounce (after its roulette).
    pub beta_in: Vec3,
    /// Radiance the path had gathered when it arrived (emission seen here
    /// included, light sampled here not).
    pub l_in: Vec3,
    /// The BSDF's density of `dir`.
    pub bsdf_pdf: f32,
    /// The guide's density of `dir` at a guided bounce; 0 at an unguided
    /// one.
    pub guide_pdf: f32,
}

impl GuideVertex {
    /// The training record for a path that ended with radiance `l_end`:
    /// the incident radiance's luminance over the sampling density, or
    /// `None` where it is not finite.
    pub fn record(&self, l_end: Vec3) -> Option<crate::guiding::Record> {
        let value = radiance_over(l_end - self.l, self.beta) / self.pdf;
        let radiance = radiance_over(l_end - self.l_in, self.beta_in);
        // F / q: what the path gathered after the bounce over the
        // throughput that arrived (the bounce's weight f cos / q times the
        // radiance that arrived)
        let fraction = (self.guide_pdf > 0.0).then(|| FractionSample {
            weight: radiance_over(l_end - self.l, self.beta_in),
            bsdf_pdf: self.bsdf_pdf,
            guide_pdf: self.guide_pdf,
        });
        value.is_finite().then_some(crate::guiding::Record {
            p: self.p,
            n: self.n,
            dir: self.dir,
            value,
            radiance: if radiance.is_finite() { radiance } else { -1.0 },
            fraction,
        })
    }
}

/// The luminance of radiance `gathered` over throughput `beta`, channel by
/// channel (0 in a channel the throughput does not carry).
fn radiance_over(gathered: Vec3, beta: Vec3) -> f32 {
    let l = Vec3::select(beta.cmpgt(Vec3::ZERO), gathered / beta, Vec3::ZERO);
    crate::math::luminance(l.max(Vec3::ZERO))
}

/// Adjoint-driven Russian roulette (Vorba and Křivánek 2016, without
/// their splitting): the probability that `lane`, arriving where the guide
/// estimates the outgoing radiance's luminance at `radiance`, goes on. Its
/// expected contribution, throughput times that radiance, is set against
/// the window below its pixel's estimate ([`crate::guiding::WEIGHT_WINDOW`]):
/// at or above the window's floor the path goes on, below it in
/// proportion, never with less than [`crate::guiding::ROULETTE_FLOOR`].
/// Paths that still matter live as long as they matter, whatever their
/// depth; paths that no longer can end early. Unbiased: a survivor's
/// throughput is divided by the probability.
#[inline]
pub(super) fn adjoint_roulette(lane: &Lane, radiance: f32) -> f32 {
    let expected = crate::math::luminance(lane.beta) * radiance * lane.roulette_scale;
    if expected.is_nan() {
        return crate::guiding::ROULETTE_FLOOR;
    }
    expected.clamp(crate::guiding::ROULETTE_FLOOR, 1.0)
}

impl Lane {
    /// Set adjoint-driven roulette's factor for the lane's pixel
    /// ([`crate::guiding::Guide::roulette_scale`]; 0, the default: roulette
    /// by the settings' rule).
    pub fn set_roulette_scale(&mut self, scale: f32) {
        self.roulette_scale = scale;
    }
}

impl PathTracer<'_> {
    /// The guide's estimate of the radiance leaving guide leaf `leaf`, for
    /// [`adjoint_roulette`]: `None` when the render is not guided, the
    /// lane's pixel has no estimate, or no training path said.
    #[inline]
    pub(super) fn adjoint_radiance(&self, lane: &Lane, leaf: Option<u32>) -> Option<f32> {
        match (&self.guide, leaf) {
            (Some(g), Some(l)) if lane.roulette_scale > 0.0 => g.leaf_radiance(l),
            _ => None,
        }
    }

    /// What training records of the bounce `sh` that sampled `bs` (world
    /// direction `wi`) with throughput `beta_in` arriving; `lane` is past
    /// the bounce. The two densities are evaluated again here, so that the
    /// sampling itself computes nothing only training needs.
    #[cold]
    #[inline(never)]
    pub(super) fn guide_vertex<B: KernelBsdf>(
        &self,
        sh: &Shade<B>,
        lane: &Lane,
        bs: &BsdfSample,
        wi: Vec3,
        beta_in: Vec3,
    ) -> GuideVertex {
        let guide_pdf = match (sh.guide, &self.guide) {
            (Some(leaf), Some(g)) => g.leaf(leaf).pdf(wi),
            _ => 0.0,
        };
        GuideVertex {
            p: sh.its.sp.p,
            n: sh.its.ng,
            dir: wi,
            pdf: bs.pdf,
            beta: lane.beta,
            l: lane.l,
            beta_in,
            l_in: sh.l_in,
            bsdf_pdf: sh.bsdf.pdf(sh.wo_local, bs.wi),
            guide_pdf,
        }
    }

    /// The density with which [`PathTracer::scatter`] samples `wi` (local
    /// frame; `wi_world` in the world): the BSDF's, or at a guided bounce
    /// the mixture's of the BSDF and the guide.
    #[inline]
    pub(super) fn scatter_pdf<B: KernelBsdf>(
        &self,
        sh: &Shade<B>,
        wi_local: Vec3,
        wi_world: Vec3,
    ) -> f32 {
        let p = sh.bsdf.pdf(sh.wo_local, wi_local);
        match (sh.guide, &self.guide) {
            (Some(leaf), Some(g)) => {
                let a = g.bsdf_share(leaf);
                a * p + (1.0 - a) * g.leaf(leaf).pdf(wi_world)
            }
            _ => p,
        }
    }

    /// A direction from the mixture of the BSDF (with the leaf's learned
    /// probability, [`crate::guiding::Guide::bsdf_share`]) and the guide's
    /// leaf `leaf`, with
    /// the mixture's density: the first number picks the strategy and is
    /// rescaled for it (so a guided bounce draws no more numbers than an
    /// unguided one). Never inlined: an unguided render's kernel stays as
    /// small as it was.
    #[inline(never)]
    pub(super) fn guided_sample<B: KernelBsdf>(
        &self,
        sh: &Shade<B>,
        leaf: u32,
        u: Vec2,
    ) -> Option<crate::bsdf::BsdfSample> {
        let g = self.guide.as_ref()?;
        let tree = g.leaf(leaf);
        let a = g.bsdf_share(leaf);
        let (by_bsdf, u) = crate::bsdf::choose_lobe(u, a);
        let (wi, f, bsdf_pdf, guide_pdf) = if by_bsdf {
            let bs = sh.bsdf.sample(sh.wo_local, u)?;
            if bs.delta {
                // not reached (guided BSDFs have no delta lobe); a delta
                // sample is a discrete choice of probability `a` times its own
                return crate::bsdf::BsdfSample {
                    pdf: bs.pdf * a,
                    ..bs
                }
                .checked();
            }
            let guide_pdf = tree.pdf(sh.frame.to_world(bs.wi));
            (bs.wi, bs.f, bs.pdf, guide_pdf)
        } else {
            let (d, guide_pdf) = tree.sample(u);
            let wi = sh.frame.to_local(d);
            let f = sh.bsdf.eval(sh.wo_local, wi);
            if f == Vec3::ZERO {
                return None;
            }
            (wi, f, sh.bsdf.pdf(sh.wo_local, wi), guide_pdf)
        };
        crate::bsdf::BsdfSample {
            wi,
            f,
            pdf: a * bsdf_pdf + (1.0 - a) * guide_pdf,
            delta: false,
        }
        .checked()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guiding::{ROULETTE_FLOOR, WEIGHT_WINDOW};
    use crate::math::Ray;
    use crate::sampler::Sampler;

    fn lane(beta: f32, scale: f32) -> Lane {
        let ray = Ray {
            o: Vec3::ZERO,
            d: Vec3::Z,
            t_max: 1.0,
        };
        let mut l = Lane::new(Sampler::new(1, 0, 0), ray);
        l.beta = Vec3::splat(beta);
        l.set_roulette_scale(scale);
        l
    }

    #[test]
    fn adjoint_roulette_keeps_what_matters_and_thins_the_rest_in_proportion() {
        // pixel estimate 0.5: the window's floor is 2 / (1 + s) of it
        let scale = (1.0 + WEIGHT_WINDOW) / (2.0 * 0.5);
        let floor = 0.5 * 2.0 / (1.0 + WEIGHT_WINDOW);
        // expected contribution at or above the floor: always goes on
        assert_eq!(adjoint_roulette(&lane(1.0, scale), floor), 1.0);
        assert_eq!(adjoint_roulette(&lane(0.5, scale), 4.0 * floor), 1.0);
        // below it: in proportion
        let q = adjoint_roulette(&lane(0.25, scale), floor);
        assert!((q - 0.25).abs() < 1e-5, "{q}");
        // never below the floor, whatever the estimate says (0 included)
        assert_eq!(adjoint_roulette(&lane(1e-6, scale), floor), ROULETTE_FLOOR);
        assert_eq!(adjoint_roulette(&lane(1.0, scale), 0.0), ROULETTE_FLOOR);
        assert_eq!(
            adjoint_roulette(&lane(1.0, scale), f32::NAN),
            ROULETTE_FLOOR
        );
    }
}
