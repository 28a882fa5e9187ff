//! Training a guide before the render, and `--guiding auto`'s decision.
//!
//! Training iteration `k` renders `2^k` samples per pixel of the whole
//! image with the guide of iteration `k - 1` (BSDF sampling alone for
//! `k = 0`), from a sample stream of its own (the render's seed mixed with
//! the iteration), so the render's own samples are untouched. The image's
//! pixel blocks are traced in parallel, a chunk of blocks at a time, and
//! each chunk's records are added to the tree in block order: the guide is
//! the same bits for any thread count. The samples' values are summed per
//! pixel, in the same order, for the pixel estimates of adjoint-driven
//! roulette (box-filtered, see `box_filtered`). Every shard of a farm render repeats
//! the same training, so shards merge to the one-machine image bit for bit,
//! and a resumed render trains again to the same guide.

use super::light_choice::LightChoice;
use super::{BATCH, BLOCK, GuideVertex, Lane, PathTracer, RayCounts, take_recorded};
use crate::camera::Camera;
use crate::guiding::{GuideBuilder, GuidingMode, PixelEstimate, Record};
use crate::math::{Vec2, Vec3, luminance};
use crate::sampler::{Sampler, mix64};
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// `auto` guides no render of fewer samples per pixel than this (a
/// progressive render trains [`PROGRESSIVE_ITERATIONS`], enough): its guide
/// would learn from too few paths. Measured on
/// `benches/race/hard/door-ajar.xml` (128 x 128, RMSE against a 4096-spp
/// reference, seeds 1 to 4, 2 threads, wall time, training and `auto`'s
/// pre-pass included, the 2-core Intel Xeon VM, 2026-11-29, leaves of
/// 1500 records), efficiency `1 / (MSE x time)` guided over unguided:
/// 1.34x at 32 spp under `auto` (RMSE 0.0334 in 1.58 s against 0.0673 in
/// 0.53 s; each seed within 0.0330 to 0.0339), and under `--guiding on`
/// 1.02x at 16 spp (0.0579 in 0.77 s against 0.0971 in 0.28 s). It was 64
/// until then, when leaves of 12000 records gave 1.08x at 32 spp (the
/// 2-core AMD EPYC VM, 0.0373 in 1.19 s against 0.0673 in 0.40 s); before
/// that 128, when the guided error at 64 spp still swung with the seed.
pub const AUTO_MIN_SPP: u32 = 32;

/// `auto` guides a scene when at least this share of the pre-pass's light
/// (luminance, summed over its pixels) arrived after the first non-delta
/// bounce: light that light sampling at the first hit cannot find.
pub const AUTO_INDIRECT_SHARE: f64 = 0.6;

/// The pre-pass's largest image side, in pixels.
const PREPASS_SIDE: u32 = 64;

/// The pre-pass's samples per pixel.
const PREPASS_SPP: u32 = 4;

/// Training iterations for a progressive render (`--time-limit`,
/// `--target-error`), whose sample count is not known in advance:
/// `1 + 2 + ... + 16 = 31` samples per pixel.
pub const PROGRESSIVE_ITERATIONS: u32 = 5;

/// The last training iterations whose samples the render keeps
/// ([`crate::guiding::Guide::reused`]), never iteration 0 (the BSDF alone).
/// Each of their samples is an unbiased estimate of its pixel, drawn with
/// a guide trained on fewer paths than the render's, so its variance is
/// higher; added with the weight of a render sample, the last two still
/// lower the error. Measured on `benches/race/hard/door-ajar.xml`, guided,
/// RMSE against a 4096-spp reference over 6 seeds: at 64 spp (training
/// 1 + 2 + 4 + 8) 0.02392 keeping none, 0.02323 the last (8 spp), 0.02305
/// the last two, 0.02337 three, 0.02361 four; at 256 spp (3 seeds)
/// 0.00978 against 0.00941 with two.
pub const REUSED_ITERATIONS: u32 = 2;

/// Blocks traced in parallel before their records join the tree.
const CHUNK_BLOCKS: usize = 256;

/// How a guide is trained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrainSettings {
    /// Iterations of `1, 2, 4, ...` samples per pixel.
    pub iterations: u32,
    /// The render's seed (the training mixes it with each iteration).
    pub seed: u64,
    /// Keep the last iterations' samples for the render
    /// ([`REUSED_ITERATIONS`]).
    pub reuse: bool,
}

impl TrainSettings {
    /// The iterations for a render of `spp` samples per pixel: as many as
    /// fit a quarter of it (`2^n - 1 <= spp / 4`), at least one.
    pub fn iterations_for(spp: u32) -> u32 {
        let budget = (spp / 4).max(1) as u64;
        let mut n = 1;
        while n < 16 && (1u64 << (n + 1)) - 1 <= budget {
            n += 1;
        }
        n
    }

    /// Samples per pixel the training traces, all iterations together.
    pub fn spp(&self) -> u32 {
        (1u32 << self.iterations) - 1
    }

    /// Whether iteration `k`'s samples are kept for the render.
    pub fn reuses(&self, k: u32) -> bool {
        self.reuse && k >= 1 && k + REUSED_ITERATIONS >= self.iterations
    }

    /// Samples per pixel kept for the render ([`TrainSettings::reuses`]).
    pub fn reused_spp(&self) -> u32 {
        (0..self.iterations)
            .filter(|&k| self.reuses(k))
            .map(|k| 1u32 << k)
            .sum()
    }
}

/// What guiding did, for the report and `embertrace plan`.
#[derive(Debug, Clone, PartialEq)]
pub struct GuidingReport {
    /// The mode asked for.
    pub mode: GuidingMode,
    /// Whether the render was guided.
    pub on: bool,
    /// What `auto`'s pre-pass measured.
    pub auto: Option<AutoMeasure>,
    /// `auto`'s pre-pass time.
    pub prepass_seconds: f64,
    /// Training iterations run.
    pub iterations: u32,
    /// Samples per pixel they traced.
    pub train_spp: u32,
    /// Of those, samples per pixel the render's image holds
    /// ([`REUSED_ITERATIONS`]).
    pub kept_spp: u32,
    /// Their time.
    pub train_seconds: f64,
    /// Rays they traced.
    pub train_rays: RayCounts,
    /// The guide's spatial leaves.
    pub leaves: usize,
    /// Its directional nodes, all leaves together.
    pub nodes: usize,
    /// The guide was read from the checkpoint the render resumes
    /// ([`resume`]): no pre-pass, no training.
    pub from_checkpoint: bool,
    /// Where bounces skip light sampling, when a pre-pass decided it
    /// ([`super::light_choice`]; for an unguided render, after guiding's
    /// decision).
    pub light_choice: Option<LightChoice>,
}

impl GuidingReport {
    /// A render that was not guided.
    pub fn off(mode: GuidingMode) -> Self {
        GuidingReport {
            mode,
            on: false,
            light_choice: None,
            auto: None,
            prepass_seconds: 0.0,
            iterations: 0,
            train_spp: 0,
            kept_spp: 0,
            train_seconds: 0.0,
            train_rays: RayCounts::default(),
            leaves: 0,
            nodes: 0,
            from_checkpoint: false,
        }
    }

    /// One line for the log and `embertrace plan`.
    pub fn describe(&self) -> String {
        let share = self.auto.map_or(String::new(), |m| {
            let mut s = match m.indirect_share {
                Some(share) => format!(
                    "; {:.0} % of the pre-pass's light arrives after the first bounce (auto looks further from {:.0} %)",
                    100.0 * share,
                    100.0 * AUTO_INDIRECT_SHARE
                ),
                None => String::new(),
            };
            if m.too_few_samples() {
                s += &format!(
                    "; too few samples to learn a guide from (auto guides from {AUTO_MIN_SPP} spp; no pre-pass ran)"
                );
            }
            if let (Some(v), Some(c), Some(k)) = (m.variance_ratio, m.cost_ratio, m.gave_up_after) {
                s += &format!(
                    "; after {k} training iterations, guided, its variance was {v:.2}x (at {c:.2}x the time per sample): training stopped"
                );
            } else if let (Some(v), Some(c)) = (m.variance_ratio, m.cost_ratio) {
                s += &format!(
                    "; guided, its variance is {v:.2}x at {c:.2}x the time per sample (auto guides when the product is below 1)"
                );
            }
            s
        });
        if self.from_checkpoint {
            format!(
                "guiding on ({}): the checkpoint's guide ({} iterations, {} leaves, {} nodes), not trained again",
                self.mode, self.iterations, self.leaves, self.nodes
            )
        } else if self.on && self.iterations == 0 {
            format!("guiding on ({}){share}", self.mode)
        } else if self.on {
            format!(
                "guiding on ({}): {} iterations, {} spp ({} kept), {:.2} s, {} leaves, {} nodes{share}",
                self.mode,
                self.iterations,
                self.train_spp,
                self.kept_spp,
                self.train_seconds,
                self.leaves,
                self.nodes
            )
        } else {
            format!("guiding off ({}){share}", self.mode)
        }
    }
}

/// What `auto` measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoMeasure {
    /// The unguided pre-pass's share of light arriving after the first
    /// non-delta bounce; `None` when the render has too few samples for
    /// `auto` to guide it, so that no pre-pass ran.
    pub indirect_share: Option<f64>,
    /// The guided pre-pass's variance over the unguided one's: the sum over
    /// the pixels of each pixel's sample variance (luminance), `None` when
    /// the share alone said no.
    pub variance_ratio: Option<f64>,
    /// A guided sample's predicted time over an unguided one's
    /// ([`guided_cost`]), `None` when the share alone said no.
    pub cost_ratio: Option<f64>,
    /// Training stopped after this many iterations, the guide having not
    /// lowered the pre-pass's variance ([`AUTO_PROBE_ITERATIONS`]); the
    /// ratios are that probe's.
    pub gave_up_after: Option<u32>,
}

impl AutoMeasure {
    /// The render has fewer samples than [`AUTO_MIN_SPP`], so `auto` left
    /// guiding off without a pre-pass (no share was measured): whatever the
    /// pre-pass measured, the guide would learn from too few paths (on the
    /// door scene at 16 spp the pre-pass took 0.015 s of a 0.21 s render).
    pub fn too_few_samples(&self) -> bool {
        self.indirect_share.is_none()
    }
}

/// After this many training iterations (`1 + 2 + 4 = 7` samples per pixel)
/// `auto` runs the guided pre-pass once early, and when the guide has not
/// lowered its variance at all, stops training and leaves guiding off: a
/// guide that learned nothing from 7 samples a pixel did not learn enough
/// from 63 on the scenes measured (`--guiding auto`, 256 spp, 2 threads,
/// 2-core AMD EPYC):
/// - `benches/race/hard/door-ajar.xml`, the pre-pass's variance ratio after
///   1 to 5 iterations: 1.08, 0.67, 0.53, 0.43, 0.34 (seed 1) and 0.66,
///   0.32, 0.27, 0.21, 0.21 (seed 2); guided, and untouched (the probe
///   does not change the guide: the same bits);
/// - `glossy-env.xml` without its plastic sphere (rough metals under the
///   sky, 65 % of the light indirect; `tests/guiding.rs` writes it): 1.14
///   after 3 iterations, 1.10 after all 6, guiding off either way; 2.04 to
///   2.12 s instead of 2.77 to 2.85 s (training 0.09 s instead of 0.83 s).
pub const AUTO_PROBE_ITERATIONS: u32 = 3;

/// A guided path's time per ray over an unguided path's: the guide's
/// lookups, its sampling and densities, and adjoint-driven roulette.
/// Measured: `benches/race/hard/door-ajar.xml`, 256 spp, 2 threads, 2-core
/// AMD EPYC (AVX-512), two runs each (`render_seconds` less
/// `train_seconds`): unguided 40.3 M rays in 3.03 and 3.02 s; guided
/// 53.2 M rays in 6.17 and 6.13 s of rendering after 2.5 s of training,
/// 1.55x and 1.54x per ray (2026-11-29; 1.74x when adjoint-driven
/// roulette came in, `c340e73`, before light sampling deferred its MIS
/// weight to unoccluded samples and the door took `embree+naive`).
pub const GUIDED_RAY_COST: f64 = 1.54;

/// A guided sample's predicted time over an unguided one's, once the guide
/// is trained: the rays per sample of the two pre-passes (`ray_ratio`,
/// guided over unguided; adjoint-driven roulette keeps the paths that
/// matter longer) times [`GUIDED_RAY_COST`].
pub fn guided_cost(ray_ratio: f64) -> f64 {
    ray_ratio * GUIDED_RAY_COST
}

/// Decide, for the request's mode, whether to guide: `on` and `off` as they
/// say; `auto` by a pre-pass of [`PREPASS_SPP`] samples per pixel at most
/// [`PREPASS_SIDE`] pixels a side. When at least [`AUTO_INDIRECT_SHARE`] of
/// its light arrives after the first bounce, the render's guide is trained
/// (all of it: a guide trained on fewer paths predicts too little, see
/// `docs/guide/guiding.md`) and the pre-pass is repeated with it. Guiding
/// is on when the guided pre-pass's variance (each pixel's sample variance,
/// summed), times its predicted cost per sample ([`guided_cost`], the
/// training already spent), is below the unguided one's: when the rest of
/// the render reaches a lower error in the same time. Every number, ray
/// counts included, is a function of the scene, the settings and the seed,
/// so the decision is too. The tracer is left with the guide when guiding
/// is on (and none otherwise); the report counts the pre-passes' time and
/// the training's, whether kept or not.
///
/// Then, when the render is not guided and its lights call for it, a
/// pre-pass decides where bounces skip light sampling
/// ([`super::light_choice::decide`]). Guiding's pre-passes and training
/// run with light sampling at every bounce, so its decision does not
/// depend on this one; a guided render keeps light sampling everywhere.
pub fn prepare(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    request: &GuidingRequest,
    pool: &rayon::ThreadPool,
) -> GuidingReport {
    let mut plain = None;
    let report = prepare_guiding(tracer, scene, camera, request, pool, &mut plain);
    let t = Instant::now();
    let light_choice = if report.on {
        None
    } else {
        // guiding's unguided pre-pass, where it ran, is the one with light
        // sampling everywhere: the same view, seed and tracer settings
        let every = plain.map(|p: Prepass| (p.variance, p.rays));
        let view = PrepassView::new(request.resolution);
        super::light_choice::decide(tracer, request.spp, request.progressive, every, |tracer| {
            let p = prepass(tracer, camera, &view, request.seed, pool);
            (p.variance, p.rays)
        })
    };
    // only when a pre-pass ran for it
    let light_seconds = if light_choice.is_some() {
        t.elapsed().as_secs_f64()
    } else {
        0.0
    };
    GuidingReport {
        light_choice,
        prepass_seconds: report.prepass_seconds + light_seconds,
        ..report
    }
}

/// [`prepare`]'s guiding decision; `auto`'s unguided pre-pass, where it
/// ran, is left in `plain`.
fn prepare_guiding(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    request: &GuidingRequest,
    pool: &rayon::ThreadPool,
    plain_out: &mut Option<Prepass>,
) -> GuidingReport {
    let train_full = |tracer: &mut PathTracer<'_>| {
        let settings = request.train_settings();
        train(tracer, scene, camera, request.resolution, settings, pool)
    };
    let report = match request.mode {
        GuidingMode::Off => GuidingReport::off(GuidingMode::Off),
        GuidingMode::On => train_full(tracer),
        GuidingMode::Auto => {
            let mut measure = AutoMeasure {
                indirect_share: None,
                variance_ratio: None,
                cost_ratio: None,
                gave_up_after: None,
            };
            if !request.progressive && request.spp < AUTO_MIN_SPP {
                return GuidingReport {
                    auto: Some(measure),
                    ..GuidingReport::off(GuidingMode::Auto)
                };
            }
            let t = Instant::now();
            let view = PrepassView::new(request.resolution);
            let plain = prepass(tracer, camera, &view, request.seed, pool);
            *plain_out = Some(plain.clone());
            measure.indirect_share = Some(plain.share);
            if plain.share < AUTO_INDIRECT_SHARE || !(plain.variance > 0.0) {
                return GuidingReport {
                    auto: Some(measure),
                    prepass_seconds: t.elapsed().as_secs_f64(),
                    ..GuidingReport::off(GuidingMode::Auto)
                };
            }
            let prepass_seconds = t.elapsed().as_secs_f64();
            // after AUTO_PROBE_ITERATIONS, a guide that has not lowered the
            // pre-pass's variance at all ends the training
            let mut gave_up = None;
            let trained = train_until(
                tracer,
                scene,
                camera,
                request.resolution,
                request.train_settings(),
                pool,
                |k, tracer| {
                    if k + 1 != AUTO_PROBE_ITERATIONS {
                        return false;
                    }
                    let probe = prepass(tracer, camera, &view, request.seed, pool);
                    let variance = probe.variance / plain.variance;
                    if variance < 1.0 {
                        return false;
                    }
                    let cost =
                        guided_cost(probe.rays.total() as f64 / plain.rays.total().max(1) as f64);
                    gave_up = Some((variance, cost));
                    true
                },
            );
            let t = Instant::now();
            let (variance, cost) = gave_up.unwrap_or_else(|| {
                let guided = prepass(tracer, camera, &view, request.seed, pool);
                let variance = guided.variance / plain.variance;
                let cost =
                    guided_cost(guided.rays.total() as f64 / plain.rays.total().max(1) as f64);
                (variance, cost)
            });
            measure.variance_ratio = Some(variance);
            measure.cost_ratio = Some(cost);
            measure.gave_up_after = gave_up.map(|_| AUTO_PROBE_ITERATIONS);
            GuidingReport {
                on: gave_up.is_none() && variance * cost < 1.0,
                auto: Some(measure),
                prepass_seconds: prepass_seconds + t.elapsed().as_secs_f64(),
                ..trained
            }
        }
    };
    if !report.on {
        tracer.set_guide(None);
    }
    GuidingReport {
        mode: request.mode,
        // an unguided image holds no training samples
        kept_spp: if report.on { report.kept_spp } else { 0 },
        ..report
    }
}

/// The pre-pass's pixels: a small image spread over the render's film.
struct PrepassView {
    resolution: [u32; 2],
    /// Film pixels per pre-pass pixel.
    stretch: Vec2,
}

impl PrepassView {
    fn new(resolution: [u32; 2]) -> Self {
        let [w, h] = resolution;
        let scale = (PREPASS_SIDE as f64 / w.max(h).max(1) as f64).min(1.0);
        let small = [
            ((w as f64 * scale).round() as u32).max(1),
            ((h as f64 * scale).round() as u32).max(1),
        ];
        PrepassView {
            resolution: small,
            stretch: Vec2::new(w as f32 / small[0] as f32, h as f32 / small[1] as f32),
        }
    }
}

/// What a pre-pass found.
#[derive(Debug, Clone)]
struct Prepass {
    /// Share of the light (luminance) arriving after the first non-delta
    /// bounce.
    share: f64,
    /// The pixels' sample variances (luminance), summed.
    variance: f64,
    /// Rays traced, by kind.
    rays: RayCounts,
}

/// [`PREPASS_SPP`] samples per pixel of `view` with the tracer as it is
/// (guided or not).
fn prepass(
    tracer: &mut PathTracer<'_>,
    camera: &Camera,
    view: &PrepassView,
    seed: u64,
    pool: &rayon::ThreadPool,
) -> Prepass {
    tracer.set_recording(true);
    let shared: &PathTracer<'_> = tracer;
    let blocks = block_origins(view.resolution);
    let sums: Vec<([f64; 3], RayCounts)> = pool.install(|| {
        blocks
            .par_iter()
            .map(|&origin| {
                // per lane (pixel): sum and sum of squares of its samples
                let mut pixel = [[0.0f64; 2]; BATCH];
                // total, after the first bounce
                let mut light = [0.0f64; 2];
                let mut rays = RayCounts::default();
                let mut recorded = Recorded::default();
                for s in 0..PREPASS_SPP {
                    let mut lanes = block_lanes(
                        shared,
                        camera,
                        view.resolution,
                        origin,
                        s,
                        seed,
                        view.stretch,
                    );
                    recorded.trace(shared, &mut lanes, &mut rays);
                    for (j, lane) in lanes.iter().enumerate() {
                        // a non-finite sample counts as black, as the film
                        // leaves it out
                        let l = if lane.l.is_finite() {
                            lane.l.max(Vec3::ZERO)
                        } else {
                            Vec3::ZERO
                        };
                        let y = luminance(l) as f64;
                        pixel[j][0] += y;
                        pixel[j][1] += y * y;
                        light[0] += y;
                        if let Some(v) = recorded.lane(j).next().filter(|_| lane.l.is_finite()) {
                            light[1] += luminance((lane.l - v.l).max(Vec3::ZERO)) as f64;
                        }
                    }
                }
                let n = PREPASS_SPP as f64;
                let variance: f64 = pixel
                    .iter()
                    .map(|&[sum, sq]| ((sq - sum * sum / n) / (n - 1.0)).max(0.0))
                    .sum();
                ([light[0], light[1], variance], rays)
            })
            .collect()
    });
    tracer.set_recording(false);
    let mut total = [0.0f64; 3];
    let mut rays = RayCounts::default();
    for (s, r) in &sums {
        for k in 0..3 {
            total[k] += s[k];
        }
        rays.add(r);
    }
    Prepass {
        share: if total[0] > 0.0 {
            total[1] / total[0]
        } else {
            0.0
        },
        variance: total[2],
        rays,
    }
}

/// Train a guide for `tracer` over the whole image and leave it set on the
/// tracer (recording off again).
pub fn train(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    resolution: [u32; 2],
    settings: TrainSettings,
    pool: &rayon::ThreadPool,
) -> GuidingReport {
    train_until(tracer, scene, camera, resolution, settings, pool, |_, _| {
        false
    })
}

/// [`train`], stopping early after the first iteration `k` (from 0) for
/// which `stop(k, tracer)` holds, the tracer then holding that iteration's
/// guide. `stop` may trace with the tracer (a pre-pass); recording is
/// turned on again after it.
#[allow(clippy::too_many_arguments)]
fn train_until(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    resolution: [u32; 2],
    settings: TrainSettings,
    pool: &rayon::ThreadPool,
    mut stop: impl FnMut(u32, &mut PathTracer<'_>) -> bool,
) -> GuidingReport {
    let t = Instant::now();
    let bounds = scene.bounds();
    let mut builder = GuideBuilder::new(bounds.min, bounds.max);
    let blocks = block_origins(resolution);
    let mut rays = RayCounts::default();
    // every iteration's samples per pixel: luminance sum, count
    let n_pixels = resolution[0] as usize * resolution[1] as usize;
    let mut pixel_sums = vec![(0.0f64, 0u32); n_pixels];
    // (a second film of the image's size, while the render holds it)
    let mut kept = match settings.reuse {
        true => crate::film::Film::new(resolution[0], resolution[1]),
        false => crate::film::Film::new(0, 0),
    };
    tracer.set_guide(None);
    tracer.set_recording(true);
    let mut iterations = 0;
    for k in 0..settings.iterations {
        let spp = 1u32 << k;
        let seed = mix64(settings.seed ^ mix64(0x6e1d_e000 + k as u64));
        let keep = settings.reuses(k);
        let shared: &PathTracer<'_> = tracer;
        for chunk in blocks.chunks(CHUNK_BLOCKS) {
            let learning = &builder;
            let records: Vec<BlockRecords> = pool.install(|| {
                chunk
                    .par_iter()
                    .map(|&origin| {
                        let mut out = BlockRecords::default();
                        let mut recorded = Recorded::default();
                        for s in 0..spp {
                            let mut lanes =
                                block_lanes(shared, camera, resolution, origin, s, seed, Vec2::ONE);
                            recorded.trace(shared, &mut lanes, &mut out.rays);
                            for (j, lane) in lanes.iter().enumerate() {
                                if !lane.l.is_finite() {
                                    continue;
                                }
                                let y = luminance(lane.l.max(Vec3::ZERO));
                                let pixel = block_pixel(resolution, origin, j);
                                out.pixels.push((pixel, y));
                                if keep && lane.l.min_element() >= 0.0 {
                                    let w = resolution[0] as usize;
                                    let xy = [(pixel % w) as u32, (pixel / w) as u32];
                                    out.kept.push((xy, lane.l));
                                }
                                out.records
                                    .extend(recorded.lane(j).filter_map(|v| v.record(lane.l)));
                            }
                        }
                        // the records' leaves here, in parallel: the
                        // deposit below then fills the leaves in parallel
                        out.leaves = out
                            .records
                            .iter()
                            .map(|r| learning.leaf_of(r) as u32)
                            .collect();
                        out
                    })
                    .collect()
            });
            // every leaf takes its records in the blocks' order, whatever
            // the thread count (the serial deposit's sums, bit for bit)
            pool.install(|| {
                builder.deposit_by_leaf(records.iter().map(|b| (&b.records[..], &b.leaves[..])))
            });
            for block in &records {
                for &([x, y], l) in &block.kept {
                    kept.add_sample(x, y, l);
                }
                rays.add(&block.rays);
                for &(p, y) in &block.pixels {
                    let e = &mut pixel_sums[p];
                    e.0 += y as f64;
                    e.1 += 1;
                }
            }
        }
        let pixels = PixelEstimate {
            resolution,
            mean: box_filtered(&pixel_sums, resolution),
        };
        let mut guide = builder.finish_iteration(k).with_pixels(pixels);
        if settings.reuse && k + 1 == settings.iterations {
            guide = guide.with_reused(std::mem::replace(&mut kept, crate::film::Film::new(0, 0)));
        }
        tracer.set_guide(Some(Arc::new(guide)));
        iterations = k + 1;
        if iterations < settings.iterations && stop(k, tracer) {
            break;
        }
        tracer.set_recording(true);
    }
    tracer.set_recording(false);
    let (leaves, nodes) = tracer
        .guide()
        .map_or((0, 0), |g| (g.leaf_count(), g.node_count()));
    GuidingReport {
        mode: GuidingMode::On,
        on: true,
        auto: None,
        light_choice: None,
        prepass_seconds: 0.0,
        iterations,
        train_spp: (1u32 << iterations) - 1,
        kept_spp: if iterations == settings.iterations {
            settings.reused_spp()
        } else {
            0
        },
        train_seconds: t.elapsed().as_secs_f64(),
        train_rays: rays,
        leaves,
        nodes,
        from_checkpoint: false,
    }
}

/// Guide `tracer` by `guide`, which a checkpoint of this render saved
/// (`--resume`): the guide that [`prepare`] trained for `request` when the
/// render began, so the resumed samples are those an uninterrupted render
/// takes, without the pre-pass or the training. The report names the
/// iterations that trained it, as the checkpoint's settings do.
pub fn resume(
    tracer: &mut PathTracer<'_>,
    guide: crate::guiding::Guide,
    request: &GuidingRequest,
) -> GuidingReport {
    let (leaves, nodes) = (guide.leaf_count(), guide.node_count());
    tracer.set_guide(Some(Arc::new(guide)));
    GuidingReport {
        on: true,
        iterations: request.train_settings().iterations,
        // the checkpoint's film holds them
        kept_spp: request.train_settings().reused_spp(),
        leaves,
        nodes,
        from_checkpoint: true,
        ..GuidingReport::off(request.mode)
    }
}

/// The pixels' estimates for adjoint-driven roulette: the mean of the
/// samples within [`ESTIMATE_RADIUS`] pixels (a square), from per-pixel
/// `(sum, count)`. A few training samples leave most pixels of a dim,
/// indirectly lit image black or with one lucky path; their neighbours'
/// samples give an estimate that is rarely 0 and less noisy.
fn box_filtered(sums: &[(f64, u32)], resolution: [u32; 2]) -> Vec<f32> {
    let [w, h] = resolution.map(|v| v as usize);
    let r = ESTIMATE_RADIUS;
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (mut sum, mut n) = (0.0f64, 0u64);
            for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                    let (s, c) = sums[yy * w + xx];
                    sum += s;
                    n += c as u64;
                }
            }
            if n > 0 {
                out[y * w + x] = (sum / n as f64) as f32;
            }
        }
    }
    out
}

/// The half-width of the square over which [`box_filtered`] averages.
const ESTIMATE_RADIUS: usize = 2;

/// What one pixel block's training samples left.
#[derive(Default)]
struct BlockRecords {
    /// The records, in the order of the samples and their bounces.
    records: Vec<Record>,
    /// The guide's leaf of each record ([`GuideBuilder::leaf_of`]).
    leaves: Vec<u32>,
    /// (pixel index, luminance) of each finite sample.
    pixels: Vec<(usize, f32)>,
    /// (pixel, value) of each sample the render keeps: finite and not
    /// negative, as the render accepts them.
    kept: Vec<([u32; 2], Vec3)>,
    rays: RayCounts,
}

/// The index (row-major) of the `j`-th pixel of the block at `origin`, in
/// [`block_lanes`]' order.
fn block_pixel(resolution: [u32; 2], origin: [u32; 2], j: usize) -> usize {
    let w = resolution[0];
    let bw = (origin[0] + BLOCK).min(w) - origin[0];
    let (dx, dy) = (j as u32 % bw, j as u32 / bw);
    ((origin[1] + dy) * w + origin[0] + dx) as usize
}

/// One batch's bounces, as the tracer recorded them: (lane, bounce) in the
/// order they happened. Reused from batch to batch, so that recording
/// allocates only until the buffers are large enough.
#[derive(Default)]
struct Recorded(Vec<(u32, GuideVertex)>);

impl Recorded {
    /// Trace one batch (at most [`BATCH`] lanes) with the tracer
    /// recording, keeping its bounces.
    fn trace(&mut self, tracer: &PathTracer<'_>, lanes: &mut [Lane], rays: &mut RayCounts) {
        assert!(lanes.len() <= BATCH, "one batch at a time");
        // whatever an earlier caller left on this thread
        take_recorded(&mut self.0);
        tracer.trace(lanes, rays);
        take_recorded(&mut self.0);
    }

    /// Lane `j`'s bounces, in order.
    fn lane(&self, j: usize) -> impl Iterator<Item = &GuideVertex> {
        self.0
            .iter()
            .filter(move |(i, _)| *i as usize == j)
            .map(|(_, v)| v)
    }
}

/// The top-left corners of the image's [`BLOCK`] x [`BLOCK`] pixel blocks,
/// row by row.
fn block_origins(resolution: [u32; 2]) -> Vec<[u32; 2]> {
    let [w, h] = resolution;
    (0..h)
        .step_by(BLOCK as usize)
        .flat_map(|y| (0..w).step_by(BLOCK as usize).map(move |x| [x, y]))
        .collect()
}

/// Sample `s` of the pixels of the block at `origin`, as lanes with their
/// camera rays, drawn from `seed`'s stream; the film position is the pixel
/// position times `stretch`.
fn block_lanes(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    resolution: [u32; 2],
    origin: [u32; 2],
    s: u32,
    seed: u64,
    stretch: Vec2,
) -> Vec<Lane> {
    let [w, h] = resolution;
    let mut lanes = Vec::with_capacity((BLOCK * BLOCK) as usize);
    for y in origin[1]..(origin[1] + BLOCK).min(h) {
        for x in origin[0]..(origin[0] + BLOCK).min(w) {
            let pixel = y as u64 * w as u64 + x as u64;
            let mut sampler = Sampler::new(seed, pixel, s as u64);
            let p = (Vec2::new(x as f32, y as f32) + sampler.next_2d()) * stretch;
            let ray = tracer.camera_ray(camera, p, &mut sampler);
            let mut lane = Lane::new(sampler, ray);
            if let Some(g) = tracer.guide() {
                // the guide's pixel estimates are the render's film's
                lane.set_roulette_scale(g.roulette_scale(p.x as u32, p.y as u32));
            }
            lanes.push(lane);
        }
    }
    lanes
}

/// What a render asks of guiding: the mode, the view, and the render's
/// samples (to size the training).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidingRequest {
    /// `--guiding`.
    pub mode: GuidingMode,
    /// The image's size.
    pub resolution: [u32; 2],
    /// The render's seed.
    pub seed: u64,
    /// The render's samples per pixel (its cap, for a progressive render).
    pub spp: u32,
    /// The render stops on a time or error budget, so `spp` is only a cap.
    pub progressive: bool,
    /// The render may add the last training iterations' samples to its
    /// own ([`REUSED_ITERATIONS`]): false under `--clamp`, whose report
    /// counts the render's samples only.
    pub reuse: bool,
}

impl GuidingRequest {
    /// The training the render runs: [`TrainSettings::iterations_for`] its
    /// samples, or [`PROGRESSIVE_ITERATIONS`].
    pub fn train_settings(&self) -> TrainSettings {
        let iterations = if self.progressive {
            PROGRESSIVE_ITERATIONS
        } else {
            TrainSettings::iterations_for(self.spp)
        };
        TrainSettings {
            iterations,
            seed: self.seed,
            reuse: self.reuse,
        }
    }
}
