//! Training a guide before the render, and `--guiding auto`'s decision.
//!
//! Training iteration `k` renders `2^k` samples per pixel of the whole
//! image with the guide of iteration `k - 1` (BSDF sampling alone for
//! `k = 0`), from a sample stream of its own (the render's seed mixed with
//! the iteration), so the render's own samples are untouched. The image's
//! pixel blocks are traced in parallel, a chunk of blocks at a time, and
//! each chunk's records are added to the tree in block order: the guide is
//! the same bits for any thread count. Every shard of a farm render repeats
//! the same training, so shards merge to the one-machine image bit for bit,
//! and a resumed render trains again to the same guide.

use super::{BATCH, BLOCK, GuideVertex, Lane, PathTracer, RayCounts, take_recorded};
use crate::camera::Camera;
use crate::guiding::{GuideBuilder, GuidingMode, Record};
use crate::math::{Vec2, Vec3, luminance};
use crate::sampler::{Sampler, mix64};
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

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

/// Blocks traced in parallel before their records join the tree.
const CHUNK_BLOCKS: usize = 256;

/// How a guide is trained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrainSettings {
    /// Iterations of `1, 2, 4, ...` samples per pixel.
    pub iterations: u32,
    /// The render's seed (the training mixes it with each iteration).
    pub seed: u64,
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
    /// Their time.
    pub train_seconds: f64,
    /// Rays they traced.
    pub train_rays: RayCounts,
    /// The guide's spatial leaves.
    pub leaves: usize,
    /// Its directional nodes, all leaves together.
    pub nodes: usize,
}

impl GuidingReport {
    /// A render that was not guided.
    pub fn off(mode: GuidingMode) -> Self {
        GuidingReport {
            mode,
            on: false,
            auto: None,
            prepass_seconds: 0.0,
            iterations: 0,
            train_spp: 0,
            train_seconds: 0.0,
            train_rays: RayCounts::default(),
            leaves: 0,
            nodes: 0,
        }
    }

    /// One line for the log and `embertrace plan`.
    pub fn describe(&self) -> String {
        let share = self.auto.map_or(String::new(), |m| {
            let mut s = format!(
                "; {:.0} % of the pre-pass's light arrives after the first bounce (auto looks further from {:.0} %)",
                100.0 * m.indirect_share,
                100.0 * AUTO_INDIRECT_SHARE
            );
            if let Some(r) = m.second_moment_ratio {
                s += &format!(
                    "; guided, its samples' second moment is {r:.2}x (auto guides below 1 / {GUIDED_COST})"
                );
            }
            s
        });
        if self.on && self.iterations == 0 {
            format!("guiding on ({}){share}", self.mode)
        } else if self.on {
            format!(
                "guiding on ({}): {} iterations, {} spp, {:.2} s, {} leaves, {} nodes{share}",
                self.mode,
                self.iterations,
                self.train_spp,
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
    /// non-delta bounce.
    pub indirect_share: f64,
    /// The guided pre-pass's mean squared sample luminance over the
    /// unguided one's (`None` when the share alone said no).
    pub second_moment_ratio: Option<f64>,
}

/// `auto` guides only where the guided estimator's variance per sample,
/// times this, is below the unguided one's: a guided render's time over
/// an unguided one's at equal samples, its training included. Measured:
/// `benches/race/hard/door-ajar.xml`, 256 spp, one thread, 2-core AMD EPYC
/// (AVX-512): 9.26 s unguided; guided 12.63 s of rendering (1.36x) plus
/// 3.49 s of training (63 spp).
pub const GUIDED_COST: f64 = 1.7;

/// Training iterations of `auto`'s guided pre-pass (`1 + 2 + 4` spp at the
/// pre-pass's size).
const AUTO_ITERATIONS: u32 = 3;

/// Decide, for `mode`, whether to guide: `on` and `off` as they say; `auto`
/// by a pre-pass of [`PREPASS_SPP`] samples per pixel at most
/// [`PREPASS_SIDE`] pixels a side. When at least [`AUTO_INDIRECT_SHARE`] of
/// its light arrives after the first bounce, a guide is trained on the
/// pre-pass's pixels and the pre-pass is repeated with it: guiding is on
/// when its mean squared sample luminance times [`GUIDED_COST`] is below
/// the unguided one (the pixels' means are the same, so the second moments
/// differ by exactly the variances). Every number is a function of the
/// scene, the settings and the seed, so the decision is too. Returns the
/// decision, the measurements and the time.
pub fn decide(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    resolution: [u32; 2],
    seed: u64,
    mode: GuidingMode,
    pool: &rayon::ThreadPool,
) -> (bool, Option<AutoMeasure>, f64) {
    match mode {
        GuidingMode::On => (true, None, 0.0),
        GuidingMode::Off => (false, None, 0.0),
        GuidingMode::Auto => {
            let t = Instant::now();
            let view = PrepassView::new(resolution);
            let plain = prepass(tracer, camera, &view, seed, pool);
            let mut measure = AutoMeasure {
                indirect_share: plain.share,
                second_moment_ratio: None,
            };
            if plain.share < AUTO_INDIRECT_SHARE || !(plain.second_moment > 0.0) {
                return (false, Some(measure), t.elapsed().as_secs_f64());
            }
            let settings = TrainSettings {
                iterations: AUTO_ITERATIONS,
                seed,
            };
            train_view(tracer, scene, camera, &view, settings, pool);
            let guided = prepass(tracer, camera, &view, seed, pool);
            tracer.set_guide(None);
            let ratio = guided.second_moment / plain.second_moment;
            measure.second_moment_ratio = Some(ratio);
            (
                ratio * GUIDED_COST < 1.0,
                Some(measure),
                t.elapsed().as_secs_f64(),
            )
        }
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
struct Prepass {
    /// Share of the light (luminance) arriving after the first non-delta
    /// bounce.
    share: f64,
    /// Mean squared luminance of the samples.
    second_moment: f64,
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
    let sums: Vec<[f64; 4]> = pool.install(|| {
        blocks
            .par_iter()
            .map(|&origin| {
                // total, after the first bounce, squares, samples
                let mut sum = [0.0f64; 4];
                let mut rays = RayCounts::default();
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
                    let vertices = trace_recorded(shared, &mut lanes, &mut rays);
                    for (lane, vertices) in lanes.iter().zip(&vertices) {
                        sum[3] += 1.0;
                        if !lane.l.is_finite() {
                            continue;
                        }
                        let y = luminance(lane.l.max(Vec3::ZERO)) as f64;
                        sum[0] += y;
                        sum[2] += y * y;
                        if let Some(v) = vertices.first() {
                            sum[1] += luminance((lane.l - v.l).max(Vec3::ZERO)) as f64;
                        }
                    }
                }
                sum
            })
            .collect()
    });
    tracer.set_recording(false);
    let mut total = [0.0f64; 4];
    for s in &sums {
        for k in 0..4 {
            total[k] += s[k];
        }
    }
    Prepass {
        share: if total[0] > 0.0 {
            total[1] / total[0]
        } else {
            0.0
        },
        second_moment: total[2] / total[3].max(1.0),
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
    let view = PrepassView {
        resolution,
        stretch: Vec2::ONE,
    };
    train_view(tracer, scene, camera, &view, settings, pool)
}

/// [`train`] over the pixels of `view`.
fn train_view(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    view: &PrepassView,
    settings: TrainSettings,
    pool: &rayon::ThreadPool,
) -> GuidingReport {
    let resolution = view.resolution;
    let t = Instant::now();
    let bounds = scene.bounds();
    let mut builder = GuideBuilder::new(bounds.min, bounds.max);
    let blocks = block_origins(resolution);
    let mut rays = RayCounts::default();
    tracer.set_guide(None);
    tracer.set_recording(true);
    for k in 0..settings.iterations {
        let spp = 1u32 << k;
        let seed = mix64(settings.seed ^ mix64(0x6e1d_e000 + k as u64));
        let shared: &PathTracer<'_> = tracer;
        for chunk in blocks.chunks(CHUNK_BLOCKS) {
            let records: Vec<(Vec<Record>, RayCounts)> = pool.install(|| {
                chunk
                    .par_iter()
                    .map(|&origin| {
                        let mut out = Vec::new();
                        let mut r = RayCounts::default();
                        for s in 0..spp {
                            let mut lanes = block_lanes(
                                shared,
                                camera,
                                resolution,
                                origin,
                                s,
                                seed,
                                view.stretch,
                            );
                            let vertices = trace_recorded(shared, &mut lanes, &mut r);
                            for (lane, vertices) in lanes.iter().zip(&vertices) {
                                if !lane.l.is_finite() {
                                    continue;
                                }
                                out.extend(vertices.iter().filter_map(|v| v.record(lane.l)));
                            }
                        }
                        (out, r)
                    })
                    .collect()
            });
            for (rec, r) in &records {
                builder.deposit(rec);
                rays.add(r);
            }
        }
        tracer.set_guide(Some(Arc::new(builder.finish_iteration(k))));
    }
    tracer.set_recording(false);
    let (leaves, nodes) = tracer
        .guide()
        .map_or((0, 0), |g| (g.leaf_count(), g.node_count()));
    GuidingReport {
        mode: GuidingMode::On,
        on: true,
        auto: None,
        prepass_seconds: 0.0,
        iterations: settings.iterations,
        train_spp: settings.spp(),
        train_seconds: t.elapsed().as_secs_f64(),
        train_rays: rays,
        leaves,
        nodes,
    }
}

/// Trace one batch (at most [`BATCH`] lanes) with the tracer recording,
/// and return each lane's bounces in order.
fn trace_recorded(
    tracer: &PathTracer<'_>,
    lanes: &mut [Lane],
    rays: &mut RayCounts,
) -> Vec<Vec<GuideVertex>> {
    assert!(lanes.len() <= BATCH, "one batch at a time");
    take_recorded();
    tracer.trace(lanes, rays);
    let mut per_lane = vec![Vec::new(); lanes.len()];
    for (i, v) in take_recorded() {
        per_lane[i as usize].push(v);
    }
    per_lane
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
            lanes.push(Lane::new(sampler, ray));
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
}

/// Decide and, when guiding, train on `pool`: the tracer is left with its
/// guide set (or none). The report's times count the pre-pass and the
/// training.
pub fn prepare(
    tracer: &mut PathTracer<'_>,
    scene: &Scene,
    camera: &Camera,
    request: &GuidingRequest,
    pool: &rayon::ThreadPool,
) -> GuidingReport {
    if request.mode == GuidingMode::Off {
        tracer.set_guide(None);
        return GuidingReport::off(GuidingMode::Off);
    }
    let (on, measure, prepass_seconds) = decide(
        tracer,
        scene,
        camera,
        request.resolution,
        request.seed,
        request.mode,
        pool,
    );
    if !on {
        tracer.set_guide(None);
        return GuidingReport {
            auto: measure,
            prepass_seconds,
            ..GuidingReport::off(request.mode)
        };
    }
    let iterations = if request.progressive {
        PROGRESSIVE_ITERATIONS
    } else {
        TrainSettings::iterations_for(request.spp)
    };
    let settings = TrainSettings {
        iterations,
        seed: request.seed,
    };
    let report = train(tracer, scene, camera, request.resolution, settings, pool);
    GuidingReport {
        mode: request.mode,
        auto: measure,
        prepass_seconds,
        ..report
    }
}
