//! Path guiding in the estimator ([`crate::guiding`]): a guided bounce's
//! mixture of the BSDF and the guide, its density, and the bounces a
//! guide's training records.

use super::{KernelBsdf, Shade};
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
/// [`PathTracer::set_recording`]): a caller that traces one batch and then
/// takes them gets that batch's, in order, whatever thread it runs on.
pub fn take_recorded() -> Vec<(u32, GuideVertex)> {
    RECORDED.with(|r| std::mem::take(&mut *r.borrow_mut()))
}

/// A bounce of a path, as guiding's training records it: the radiance
/// that arrived along `dir` is `(l_end - l) / beta`, with `l_end` the
/// path's radiance at its end.
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
}

impl GuideVertex {
    /// The training record for a path that ended with radiance `l_end`:
    /// the incident radiance's luminance over the sampling density, or
    /// `None` where it is not finite.
    pub fn record(&self, l_end: Vec3) -> Option<crate::guiding::Record> {
        let diff = l_end - self.l;
        let li = Vec3::select(self.beta.cmpgt(Vec3::ZERO), diff / self.beta, Vec3::ZERO);
        let value = crate::math::luminance(li.max(Vec3::ZERO)) / self.pdf;
        value.is_finite().then_some(crate::guiding::Record {
            p: self.p,
            n: self.n,
            dir: self.dir,
            value,
        })
    }
}

impl PathTracer<'_> {
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
                let a = crate::guiding::BSDF_FRACTION;
                a * p + (1.0 - a) * g.leaf(leaf).pdf(wi_world)
            }
            _ => p,
        }
    }

    /// A direction from the mixture of the BSDF (with probability
    /// [`crate::guiding::BSDF_FRACTION`]) and the guide's leaf `leaf`, with
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
        let a = crate::guiding::BSDF_FRACTION;
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
