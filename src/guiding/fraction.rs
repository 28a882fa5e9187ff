//! The learned share of BSDF samples at a guided bounce, one per spatial
//! leaf (Müller 2019, "Practical Path Guiding in Production", in the
//! SIGGRAPH 2019 course "Path Guiding in Production": the selection
//! probability by stochastic gradient descent on a KL divergence).
//!
//! A guided bounce samples the mixture `q = a p_bsdf + (1 - a) p_guide`.
//! A fixed `a = 1/2` wastes half the samples wherever one of the two is
//! far the better: on a narrow glossy lobe the guide's cells are wider than
//! the lobe and its samples land where the BSDF is nearly zero; on a
//! diffuse wall lit through a gap the BSDF's samples miss the gap. Each
//! leaf learns its own `a = sigmoid(theta)` by stochastic gradient descent
//! (Adam: Kingma and Ba 2015) on the Kullback-Leibler divergence from the
//! integrand `F = f cos L` (normalised) to `q`:
//!
//! `d D_KL / d a = -E_q[ (F / q) (p_bsdf - p_guide) / q ]`,
//!
//! estimated from training's recorded bounces. A bounce sampled with
//! density `q_s` (the mixture of the guide and share it was trained
//! with) gives `F / q_s` as the luminance of what the path gathered after
//! it over the throughput that arrived, so the gradient sample is
//! `-(F / q_s) (p_bsdf - p_guide) / q_a * a (1 - a)` (the last factor the
//! sigmoid's derivative), with `q_a` the mixture at the current share.
//! Records are reduced in their fixed order, one Adam step per
//! [`BATCH`] of them, so the learned shares are a function of the scene,
//! the settings and the seed, whatever the thread count.

/// Records per Adam step. Müller's own code steps after every second
/// record. 16 learned too slowly in small leaves: with leaves of 750
/// records (`SPLIT_RECORDS`), none of `glossy-env`'s 133 reached the
/// upper limit at 64 spp (6 of 9 with 12000), and its noise rose to
/// 1.34x; 2 undid that but gave back part of the door's gain (0.02005
/// against 0.01937 at 64 spp, leaves of 1500), 8 kept 1.05x of
/// `glossy-env`'s noise, 4 none.
pub const BATCH: u32 = 4;

/// Adam's step size, on `theta`.
const LEARNING_RATE: f64 = 0.01;

/// Adam's decay rates of the first and second moments, and its guard.
const BETA1: f64 = 0.9;
const BETA2: f64 = 0.999;
const EPSILON: f64 = 1e-8;

/// `theta` stays in `[-THETA_LIMIT, THETA_LIMIT]`, so that `a` stays in
/// about `[0.018, 0.982]`: neither strategy is ever dropped, and MIS with
/// light sampling keeps both densities.
const THETA_LIMIT: f64 = 4.0;

/// One recorded guided bounce, as the share's gradient needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FractionSample {
    /// `F / q_s`: the luminance the path gathered after the bounce over
    /// the throughput that arrived there.
    pub weight: f32,
    /// The BSDF's density of the sampled direction.
    pub bsdf_pdf: f32,
    /// The guide's density of it.
    pub guide_pdf: f32,
}

/// A leaf's share and its optimiser's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fraction {
    theta: f64,
    /// Adam's first and second moment estimates and its step count.
    m: f64,
    v: f64,
    steps: i32,
    /// The current batch's gradient sum and size.
    sum: f64,
    count: u32,
}

impl Default for Fraction {
    /// `theta = 0`: the share starts at one half, Müller et al. 2017's.
    fn default() -> Self {
        Fraction {
            theta: 0.0,
            m: 0.0,
            v: 0.0,
            steps: 0,
            sum: 0.0,
            count: 0,
        }
    }
}

impl Fraction {
    /// The share of BSDF samples, `sigmoid(theta)`.
    pub fn bsdf_share(&self) -> f32 {
        sigmoid(self.theta) as f32
    }

    /// Whether the share has reached its upper limit: the leaf learned that
    /// the guide's samples are (nearly) wasted there, and a render samples
    /// its bounces by the BSDF alone ([`crate::guiding::Guide::bsdf_only`]).
    pub fn saturated(&self) -> bool {
        self.theta >= THETA_LIMIT
    }

    /// Adds one recorded bounce; every [`BATCH`] of them take an Adam step.
    /// Samples that carry nothing to learn from (no guide density, a
    /// non-finite or negative weight) are passed over.
    pub fn add(&mut self, s: &FractionSample) {
        let (w, pb, pg) = (s.weight as f64, s.bsdf_pdf as f64, s.guide_pdf as f64);
        if !(w >= 0.0 && w.is_finite() && pg > 0.0 && pg.is_finite() && pb >= 0.0) {
            return;
        }
        let a = sigmoid(self.theta);
        let q = a * pb + (1.0 - a) * pg;
        if !(q > 0.0 && q.is_finite()) {
            return;
        }
        let gradient = -w * (pb - pg) / q * a * (1.0 - a);
        if !gradient.is_finite() {
            return;
        }
        self.sum += gradient;
        self.count += 1;
        if self.count == BATCH {
            self.step(self.sum / BATCH as f64);
            self.sum = 0.0;
            self.count = 0;
        }
    }

    /// One Adam step down `gradient`.
    fn step(&mut self, gradient: f64) {
        self.steps += 1;
        self.m = BETA1 * self.m + (1.0 - BETA1) * gradient;
        self.v = BETA2 * self.v + (1.0 - BETA2) * gradient * gradient;
        let m = self.m / (1.0 - BETA1.powi(self.steps));
        let v = self.v / (1.0 - BETA2.powi(self.steps));
        self.theta = (self.theta - LEARNING_RATE * m / (v.sqrt() + EPSILON))
            .clamp(-THETA_LIMIT, THETA_LIMIT);
    }
}

fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples from `q` of a 1D integrand on `[0, 1)` with a narrow lobe:
    /// where the "BSDF" matches the integrand and the "guide" is uniform,
    /// the share grows towards the BSDF; the other way round, it falls.
    #[test]
    fn the_share_moves_towards_the_strategy_that_matches_the_integrand() {
        // integrand: a narrow box of width 0.05 at 0.5; the matching
        // density is 20 inside it, the uniform one 1 everywhere
        let inside = |x: f64| (0.475..0.525).contains(&x);
        let narrow = |x: f64| if inside(x) { 20.0 } else { 0.0 };
        for bsdf_matches in [true, false] {
            let mut f = Fraction::default();
            let mut rng = crate::sampler::Sampler::new(3, 0, 0);
            for _ in 0..20_000 {
                let a = f.bsdf_share() as f64;
                let (u, v) = (rng.next_1d() as f64, rng.next_1d() as f64);
                // sample the mixture at the current share
                let from_narrow = (u < a) == bsdf_matches;
                let x = if from_narrow { 0.475 + 0.05 * v } else { v };
                let (pn, pu) = (narrow(x), 1.0);
                let (pb, pg) = if bsdf_matches { (pn, pu) } else { (pu, pn) };
                let q = a * pb + (1.0 - a) * pg;
                let integrand = if inside(x) { 1.0 } else { 0.0 };
                f.add(&FractionSample {
                    weight: (integrand / q) as f32,
                    bsdf_pdf: pb as f32,
                    guide_pdf: pg as f32,
                });
            }
            let share = f.bsdf_share();
            if bsdf_matches {
                assert!(share > 0.9, "share {share}");
            } else {
                assert!(share < 0.1, "share {share}");
            }
        }
    }

    #[test]
    fn samples_without_a_guide_density_or_with_bad_weights_teach_nothing() {
        let mut f = Fraction::default();
        for w in [f32::NAN, f32::INFINITY, -1.0] {
            for _ in 0..BATCH {
                f.add(&FractionSample {
                    weight: w,
                    bsdf_pdf: 1.0,
                    guide_pdf: 2.0,
                });
            }
        }
        for _ in 0..BATCH {
            f.add(&FractionSample {
                weight: 1.0,
                bsdf_pdf: 1.0,
                guide_pdf: 0.0,
            });
        }
        assert_eq!(f, Fraction::default());
        assert_eq!(f.bsdf_share(), 0.5);
    }
}
