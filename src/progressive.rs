//! Progressive rendering: passes of samples added to a film until a budget
//! runs out, so that a user sees what accuracy costs in time.
//!
//! - **Passes.** Pass `k` adds samples `n_k .. n_k + m_k` to every pixel
//!   still sampled ([`render_pass`]); each pixel sums its samples in index
//!   order, so the image after passes totalling `n` samples is bit for bit
//!   the image of one `n`-sample run.
//! - **Budgets**, whichever ends first:
//!   - `max_spp`: samples per pixel at most;
//!   - `time_limit`: stop after the pass that reaches the limit. Passes are
//!     sized from the measured time per sample so that each takes at most a
//!     tenth of the limit and the last ends at the limit: the time spent
//!     overshoots by at most the error of that prediction, or by one
//!     one-sample pass when a single sample per pixel takes longer than the
//!     time left;
//!   - `target_error`: stop when the estimated relative error of the image
//!     ([`relative_error`]) is at most the target.
//!
//!   Without adaptive sampling, passes double the sample count (1, 2, 4, ...
//!   in all), so the checks and the convergence log cost little.
//! - **Adaptive sampling** (the CS184 path tracer's rule): every `batch`
//!   samples a pixel stops once `1.96 sigma / sqrt(n) <= tolerance * mu`,
//!   with `mu` and `sigma` the mean and standard deviation of its samples'
//!   luminance. The film keeps per-channel moments only, so `sigma` is
//!   bounded by `sum_c w_c sigma_c` (the standard deviation of a weighted
//!   sum is at most the weighted sum of standard deviations): a pixel can
//!   stop later than under the exact rule, never earlier. A pixel that has
//!   stopped is no longer a source of bias: its estimate is the mean of the
//!   samples it took, as in the course renderer; the stopping rule itself
//!   depends on the samples, which biases each pixel slightly (a named bias
//!   of this module, the one the course renderer accepts too).

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{Film, Pixel};
use crate::integrator::{PathTracer, RayCounts};
use crate::render::{
    ClampReport, NonFiniteReport, RenderOutput, RenderSettings, render_pass, thread_pool,
};
use serde::Serialize;
use std::time::Instant;

/// Confidence level of the reported error estimate and of the adaptive
/// stopping rule.
pub const CONFIDENCE: f64 = 0.95;
/// The normal quantile for [`CONFIDENCE`] (two-sided).
pub const Z95: f64 = 1.96;

/// Adaptive sampling settings (`-a BATCH TOL`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Samples between convergence checks.
    pub batch: u32,
    /// Largest accepted 95 % half-width relative to the pixel's mean.
    pub tolerance: f64,
}

/// When a progressive render stops.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Budget {
    /// Samples per pixel at most.
    pub max_spp: u32,
    /// Seconds of rendering at most (the pass that reaches it is the last).
    pub time_limit: Option<f64>,
    /// Relative error (95 % confidence) to stop at.
    pub target_error: Option<f64>,
    /// Per-pixel adaptive sampling.
    pub adaptive: Option<Adaptive>,
}

impl Budget {
    /// Whether this budget needs passes (anything beyond a fixed spp).
    pub fn is_progressive(&self) -> bool {
        self.time_limit.is_some() || self.target_error.is_some() || self.adaptive.is_some()
    }

    /// Check the settings; errors name the option.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Settings(m));
        if let Some(t) = self.time_limit {
            if !(t > 0.0 && t.is_finite()) {
                return bad(format!(
                    "--time-limit must be a positive number of seconds, not {t}"
                ));
            }
        }
        if let Some(e) = self.target_error {
            if !(e > 0.0 && e.is_finite()) {
                return bad(format!("--target-error must be a positive number, not {e}"));
            }
        }
        if let Some(a) = self.adaptive {
            if a.batch < 2 {
                return bad(format!(
                    "-a: the batch must be at least 2 samples, not {}",
                    a.batch
                ));
            }
            if !(a.tolerance > 0.0 && a.tolerance.is_finite()) {
                return bad(format!(
                    "-a: the tolerance must be a positive number, not {}",
                    a.tolerance
                ));
            }
        }
        Ok(())
    }
}

/// The state after one pass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PassRecord {
    /// Pass number, from 1.
    pub pass: u32,
    /// Seconds of rendering so far.
    pub seconds: f64,
    /// Samples per pixel taken so far by the pixels still sampled (the most
    /// any pixel has).
    pub spp: u32,
    /// Samples taken so far over the whole image.
    pub samples: u64,
    /// Rays traced so far.
    pub rays: u64,
    /// [`relative_error`] of the image so far.
    pub relative_error: f64,
    /// Pixels still being sampled.
    pub active_pixels: u64,
}

/// Why a progressive render stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// `max_spp` reached.
    Spp,
    /// The time limit reached.
    TimeLimit,
    /// The target error reached.
    TargetError,
    /// Every pixel converged under adaptive sampling.
    Converged,
}

/// A finished progressive render.
#[derive(Debug)]
pub struct ProgressiveOutput {
    /// The film and the totals, as one run would give them.
    pub out: RenderOutput,
    /// One record per pass.
    pub passes: Vec<PassRecord>,
    /// What ended the render.
    pub stop: StopReason,
    /// Samples per pixel, row-major (where adaptive sampling sent them).
    pub pixel_samples: Vec<u32>,
}

/// The estimated relative error of the image: the 95 % half-width of the
/// image's RMS error, relative to its RMS value,
/// `1.96 sqrt(sum var(mean)) / sqrt(sum mean^2)` over all pixels and
/// channels, with each pixel's variance of the mean estimated from its
/// samples. Infinite while some pixel has fewer than two samples (no
/// variance estimate yet); 0 for a black image without variance.
pub fn relative_error(film: &Film) -> f64 {
    let (mut var, mut sq) = (0.0f64, 0.0f64);
    for y in 0..film.height() {
        for x in 0..film.width() {
            let p = film.pixel(x, y);
            if p.count < 2 {
                return f64::INFINITY;
            }
            var += p.variance_of_mean_f64().iter().sum::<f64>();
            sq += p.mean_f64().iter().map(|m| m * m).sum::<f64>();
        }
    }
    if var == 0.0 {
        0.0
    } else {
        Z95 * (var / sq).sqrt()
    }
}

/// Whether a pixel passes the adaptive rule (see the module documentation).
pub fn pixel_converged(p: &Pixel, tolerance: f64) -> bool {
    if p.count < 2 {
        return false;
    }
    let w = [0.2126, 0.7152, 0.0722];
    let n = p.count as f64;
    let mean = p.mean_f64();
    let var = p.variance_f64();
    let mu: f64 = (0..3).map(|c| w[c] * mean[c]).sum();
    let sigma: f64 = (0..3).map(|c| w[c] * var[c].sqrt()).sum();
    Z95 * sigma / n.sqrt() <= tolerance * mu
}

/// Render in passes until `budget` runs out. `on_pass` sees each pass's
/// record and the film after it (for convergence logs); an error from it
/// stops the render.
pub fn render_progressive(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    budget: &Budget,
    kept: Option<&Film>,
    on_pass: &mut dyn FnMut(&PassRecord, &Film) -> Result<()>,
) -> Result<ProgressiveOutput> {
    budget.validate()?;
    let [w, h] = settings.resolution;
    let n_pixels = u64::from(w) * u64::from(h);
    let mut film = Film::new(w, h);
    if let Some(k) = kept {
        film.add_overlap(k);
    }
    let pool = thread_pool(settings.threads)?;
    let max_spp = budget.max_spp.max(1);
    let mut active = vec![true; n_pixels as usize];
    let mut pixel_samples = vec![0u32; n_pixels as usize];
    let mut n_active = n_pixels;
    let (mut done, mut samples) = (0u32, 0u64);
    let mut rays = RayCounts::default();
    let mut nonfinite = NonFiniteReport::default();
    let mut clamp = ClampReport::default();
    let mut passes = Vec::new();
    let start = Instant::now();
    let stop = loop {
        let elapsed = start.elapsed().as_secs_f64();
        // the next pass's size
        let mut n = match (budget.adaptive, budget.target_error) {
            (Some(a), _) => a.batch,
            (None, Some(_)) => done.max(2),
            // doubling: 1, 2, 4, ... samples in all, one record each
            (None, None) => done.max(1),
        };
        if let Some(limit) = budget.time_limit {
            if samples > 0 {
                // seconds per pixel sample, from the passes so far
                let per_sample = elapsed / samples as f64;
                let pass_time = (limit - elapsed).min(0.1 * limit);
                let fit = (pass_time / (per_sample * n_active as f64)).ceil();
                n = n.min(fit.clamp(1.0, u32::MAX as f64) as u32);
            }
        }
        n = n.min(max_spp - done);
        let rs = RenderSettings {
            total_spp: Some(max_spp),
            spp: n,
            first_sample: done,
            ..*settings
        };
        let mask = (n_active < n_pixels).then_some(&active[..]);
        let pass = render_pass(tracer, camera, &rs, &mut film, mask, &pool, &|| {});
        rays.add(&pass.rays);
        nonfinite.merge(&pass.nonfinite);
        clamp.merge(&pass.clamp);
        for (a, c) in active.iter().zip(pixel_samples.iter_mut()) {
            if *a {
                *c += n;
            }
        }
        samples += n_active * u64::from(n);
        done += n;
        if let Some(a) = budget.adaptive {
            for y in 0..h {
                for x in 0..w {
                    let i = (y as usize) * (w as usize) + x as usize;
                    if active[i] && pixel_converged(film.pixel(x, y), a.tolerance) {
                        active[i] = false;
                        n_active -= 1;
                    }
                }
            }
        }
        let record = PassRecord {
            pass: passes.len() as u32 + 1,
            seconds: start.elapsed().as_secs_f64(),
            spp: done,
            samples,
            rays: rays.total(),
            relative_error: relative_error(&film),
            active_pixels: n_active,
        };
        passes.push(record);
        on_pass(&record, &film)?;
        if budget
            .target_error
            .is_some_and(|e| record.relative_error <= e)
        {
            break StopReason::TargetError;
        }
        if budget.time_limit.is_some_and(|t| record.seconds >= t) {
            break StopReason::TimeLimit;
        }
        if n_active == 0 {
            break StopReason::Converged;
        }
        if done >= max_spp {
            break StopReason::Spp;
        }
    };
    nonfinite.finish(w);
    Ok(ProgressiveOutput {
        out: RenderOutput {
            film,
            rays,
            nonfinite,
            clamp,
            seconds: start.elapsed().as_secs_f64(),
            threads: pool.current_num_threads(),
        },
        passes,
        stop,
        pixel_samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    #[test]
    fn relative_error_of_known_pixels() {
        let mut film = Film::new(2, 1);
        // pixel 0: samples 1 and 3 in every channel: mean 2, variance 2,
        // variance of the mean 1; pixel 1: constant 2
        for v in [1.0, 3.0] {
            film.add_sample(0, 0, Vec3::splat(v));
            film.add_sample(1, 0, Vec3::splat(2.0));
        }
        let want = Z95 * (3.0f64 / (6.0 * 4.0)).sqrt();
        assert!((relative_error(&film) - want).abs() < 1e-12);
        let mut one = Film::new(1, 1);
        one.add_sample(0, 0, Vec3::ONE);
        assert_eq!(relative_error(&one), f64::INFINITY);
    }

    #[test]
    fn adaptive_rule_matches_the_course_formula_for_grey_pixels() {
        // grey samples: the luminance bound is exact
        let mut film = Film::new(1, 1);
        for v in [1.0, 1.2, 0.8, 1.0] {
            film.add_sample(0, 0, Vec3::splat(v));
        }
        let p = film.pixel(0, 0);
        // sigma = sqrt(0.08 / 3), half-width 1.96 sigma / 2 = 0.16
        let half = Z95 * (0.08f64 / 3.0).sqrt() / 2.0;
        assert!(pixel_converged(p, half / 1.0 + 1e-6));
        assert!(!pixel_converged(p, half - 1e-6));
    }

    #[test]
    fn budgets_are_validated() {
        for b in [
            Budget {
                time_limit: Some(0.0),
                ..Budget::default()
            },
            Budget {
                target_error: Some(f64::NAN),
                ..Budget::default()
            },
            Budget {
                adaptive: Some(Adaptive {
                    batch: 1,
                    tolerance: 0.05,
                }),
                ..Budget::default()
            },
            Budget {
                adaptive: Some(Adaptive {
                    batch: 8,
                    tolerance: -1.0,
                }),
                ..Budget::default()
            },
        ] {
            assert!(b.validate().is_err(), "{b:?}");
        }
    }
}
