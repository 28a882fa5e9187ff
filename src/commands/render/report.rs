//! The JSON run report (`--report run.json`) and the image metadata derived
//! from it. Field names are fixed: other scripts read them.

use crate::error::{Error, Result};
use crate::render::{RenderOutput, RenderSettings};
use crate::settings::{IntegratorSettings, Roulette};
use serde::Serialize;
use std::path::Path;

/// Rays by kind.
#[derive(Debug, Clone, Serialize)]
pub struct RaysReport {
    /// Primary rays.
    pub camera: u64,
    /// Continuation rays.
    pub extension: u64,
    /// Shadow rays.
    pub shadow: u64,
    /// Their sum.
    pub total: u64,
}

/// Rejected (NaN, infinite, negative) samples.
#[derive(Debug, Clone, Serialize)]
pub struct NonFinitePixels {
    /// Samples with a NaN component.
    pub nan: u64,
    /// Samples with an infinite component (and no NaN).
    pub inf: u64,
    /// Finite samples with a negative component.
    pub negative: u64,
    /// The first few pixels with a rejected sample, `[x, y]` in scan order.
    pub first_pixels: Vec<[u32; 2]>,
}

/// What `--clamp` removed (clamping biases the image darker).
#[derive(Debug, Clone, Serialize)]
pub struct ClampSummary {
    /// The largest component a sample could keep.
    pub max: f32,
    /// Samples scaled down.
    pub clamped_samples: u64,
    /// Radiance removed per sample on average, per channel.
    pub removed_per_sample: [f64; 3],
    /// Removed energy as a share of all the energy the samples carried.
    pub removed_fraction: f64,
}

/// Everything `--report` writes.
#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    /// Scene file.
    pub scene: String,
    /// Output image.
    pub output: String,
    /// Backend name.
    pub backend: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum bounces.
    pub max_depth: u32,
    /// Light samples per shading point.
    pub light_samples: u32,
    /// Direct-lighting strategy.
    pub direct: String,
    /// Russian roulette: "throughput" or the fixed probability.
    pub russian_roulette: String,
    /// First bounce with roulette.
    pub rr_depth: u32,
    /// `[width, height]`.
    pub resolution: [u32; 2],
    /// Seed.
    pub seed: u64,
    /// Sample generator: "independent" or "sobol".
    pub sampler: String,
    /// Threads used.
    pub threads: usize,
    /// The kernels' vector instruction set (`--simd`'s names).
    pub simd: String,
    /// Seconds spent loading the scene.
    pub load_seconds: f64,
    /// Seconds spent building the acceleration structure.
    pub accel_build_seconds: f64,
    /// Seconds spent rendering.
    pub render_seconds: f64,
    /// Rays by kind.
    pub rays: RaysReport,
    /// Millions of rays per second of render time.
    pub mrays_per_second: f64,
    /// Millions of paths (camera samples) per second of render time.
    pub mpaths_per_second: f64,
    /// Samples rejected for being NaN, infinite or negative.
    pub nonfinite_samples: u64,
    /// Where they were.
    pub nonfinite: NonFinitePixels,
    /// Mean linear RGB over the image.
    pub mean_rgb: [f64; 3],
    /// The effects the scene calls for (`embertrace plan`'s names).
    pub effects: Vec<String>,
    /// The estimator kernel that ran: its flags, or `minimal`.
    pub kernel: String,
    /// What `--clamp` removed (absent without a clamp).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clamp: Option<ClampSummary>,
    /// Passes, budgets and the error estimate of a progressive render
    /// (absent for a fixed-spp render).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub progressive: Option<ProgressiveReport>,
    /// Seconds spent rendering the auxiliary images (`--albedo`,
    /// `--normal`, `--aovs`, `--denoise`; absent without them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auxiliary_seconds: Option<f64>,
    /// Seconds the denoiser took (`--denoise`; absent without it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoise_seconds: Option<f64>,
    /// What path guiding did (`--guiding`); its pre-pass and training
    /// seconds are also in `render_seconds`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub guiding: Option<GuidingSummary>,
    /// Where bounces skip light sampling, as an unguided render under an
    /// environment map measured it (`crate::integrator::light_choice`;
    /// absent where no pre-pass ran for it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light_sampling: Option<LightSamplingSummary>,
}

/// The report's `light_sampling` object.
#[derive(Debug, Clone, Serialize)]
pub struct LightSamplingSummary {
    /// The candidate materials sampled their BSDF alone.
    pub skip: bool,
    /// The candidates: materials whose lobes all peak at or above `from`.
    pub materials: Vec<String>,
    /// That peak density (`/sr`).
    pub from: f32,
    /// The pre-pass's variance with the candidates skipping over without.
    pub variance_ratio: f64,
    /// Its predicted time per sample skipping over not.
    pub cost_ratio: f64,
}

impl LightSamplingSummary {
    /// The summary of `c`.
    pub fn of(c: &crate::integrator::light_choice::LightChoice) -> Self {
        LightSamplingSummary {
            skip: c.skip,
            materials: c.materials.clone(),
            from: c.from(),
            variance_ratio: c.variance_ratio,
            cost_ratio: c.cost_ratio,
        }
    }
}

/// The report's `guiding` object.
#[derive(Debug, Clone, Serialize)]
pub struct GuidingSummary {
    /// `auto`, `on` or `off`, as asked.
    pub mode: String,
    /// Whether the render was guided.
    pub on: bool,
    /// `auto`'s pre-pass: the share of light arriving after the first
    /// non-delta bounce (absent for `on` and `off`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub indirect_share: Option<f64>,
    /// `auto`'s guided pre-pass: its variance (the pixels' sample
    /// variances, summed) over the unguided pre-pass's (absent where the
    /// share alone decided).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variance_ratio: Option<f64>,
    /// `auto`'s predicted time per guided sample over an unguided one's,
    /// training included (absent where the share alone decided).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cost_ratio: Option<f64>,
    /// `auto` stopped training after this many iterations, the guide having
    /// not lowered the pre-pass's variance (the ratios are that probe's;
    /// absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gave_up_after: Option<u32>,
    /// The pre-passes' seconds (guiding's, and light sampling's where one
    /// ran for it).
    pub prepass_seconds: f64,
    /// Training iterations (1, 2, 4, ... spp).
    pub iterations: u32,
    /// Samples per pixel the training traced.
    pub train_spp: u32,
    /// Of those, samples per pixel the image holds (the last iterations'):
    /// a pixel's count is the render's samples plus these.
    pub kept_spp: u32,
    /// The training's seconds.
    pub train_seconds: f64,
    /// Rays the training traced.
    pub train_rays: u64,
    /// The guide's spatial leaves.
    pub leaves: usize,
    /// Its directional quadtree nodes.
    pub nodes: usize,
    /// The guide was read from the checkpoint the render resumed (no
    /// pre-pass, no training).
    pub from_checkpoint: bool,
}

impl GuidingSummary {
    /// The summary of `g`.
    pub fn of(g: &crate::integrator::training::GuidingReport) -> Self {
        GuidingSummary {
            mode: g.mode.to_string(),
            on: g.on,
            indirect_share: g.auto.and_then(|m| m.indirect_share),
            variance_ratio: g.auto.and_then(|m| m.variance_ratio),
            cost_ratio: g.auto.and_then(|m| m.cost_ratio),
            gave_up_after: g.auto.and_then(|m| m.gave_up_after),
            prepass_seconds: g.prepass_seconds,
            iterations: g.iterations,
            train_spp: g.train_spp,
            kept_spp: g.kept_spp,
            train_seconds: g.train_seconds,
            train_rays: g.train_rays.total(),
            leaves: g.leaves,
            nodes: g.nodes,
            from_checkpoint: g.from_checkpoint,
        }
    }
}

/// What a progressive render (`--time-limit`, `--target-error`, `-a`,
/// `--convergence`) reached.
#[derive(Debug, Clone, Serialize)]
pub struct ProgressiveReport {
    /// What ended it: "spp", "time_limit", "target_error" or "converged".
    pub stop: crate::progressive::StopReason,
    /// Samples per pixel reached (the most any pixel took).
    pub spp_reached: u32,
    /// Samples over the whole image.
    pub samples: u64,
    /// Passes rendered.
    pub passes: u32,
    /// The time limit asked for, seconds.
    pub time_limit: Option<f64>,
    /// The target error asked for.
    pub target_error: Option<f64>,
    /// The estimated relative error of the image at the end.
    pub relative_error: ErrorEstimate,
}

/// An error estimate and its confidence level.
#[derive(Debug, Clone, Serialize)]
pub struct ErrorEstimate {
    /// Half-width of the confidence interval of the image's RMS error,
    /// relative to its RMS value ([`crate::progressive::relative_error`]).
    pub estimate: f64,
    /// Confidence level of the interval.
    pub confidence: f64,
}

impl RenderReport {
    /// Assemble the report of a finished render.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &Path,
        backend: &str,
        settings: &RenderSettings,
        integrator: &IntegratorSettings,
        load_seconds: f64,
        accel_build_seconds: f64,
        out: &RenderOutput,
        output: &Path,
    ) -> Self {
        let per_second = |n: u64| {
            if out.seconds > 0.0 {
                n as f64 / out.seconds / 1e6
            } else {
                0.0
            }
        };
        RenderReport {
            scene: scene.display().to_string(),
            output: output.display().to_string(),
            backend: backend.to_string(),
            spp: settings.spp,
            max_depth: integrator.max_depth,
            light_samples: integrator.light_samples,
            direct: integrator.direct.to_string(),
            russian_roulette: match integrator.roulette {
                Roulette::Throughput => "throughput".to_string(),
                Roulette::Fixed(p) => p.to_string(),
            },
            rr_depth: integrator.rr_depth,
            resolution: settings.resolution,
            seed: settings.seed,
            sampler: settings.sampler.to_string(),
            threads: out.threads,
            simd: String::new(),
            guiding: None,
            light_sampling: None,
            load_seconds,
            accel_build_seconds,
            render_seconds: out.seconds,
            rays: RaysReport {
                camera: out.rays.camera,
                extension: out.rays.extension,
                shadow: out.rays.shadow,
                total: out.rays.total(),
            },
            mrays_per_second: per_second(out.rays.total()),
            mpaths_per_second: per_second(out.rays.camera),
            nonfinite_samples: out.nonfinite.count,
            nonfinite: NonFinitePixels {
                nan: out.nonfinite.nan,
                inf: out.nonfinite.inf,
                negative: out.nonfinite.negative,
                first_pixels: out.nonfinite.pixels.clone(),
            },
            mean_rgb: out.film.mean_rgb(),
            effects: Vec::new(),
            kernel: String::new(),
            clamp: settings.clamp.map(|max| {
                let n = (out.film.total_samples() + out.nonfinite.count).max(1) as f64;
                ClampSummary {
                    max,
                    clamped_samples: out.clamp.clamped,
                    removed_per_sample: out.clamp.removed.map(|r| r / n),
                    removed_fraction: out.clamp.removed_fraction(),
                }
            }),
            progressive: None,
            auxiliary_seconds: None,
            denoise_seconds: None,
        }
    }

    /// Key/value pairs for image metadata (EXR header attributes).
    pub fn metadata(&self) -> Vec<(String, String)> {
        vec![
            ("embertrace.spp".into(), self.spp.to_string()),
            ("embertrace.seed".into(), self.seed.to_string()),
            ("embertrace.sampler".into(), self.sampler.clone()),
            ("embertrace.backend".into(), self.backend.clone()),
            (
                "embertrace.render_seconds".into(),
                format!("{:.6}", self.render_seconds),
            ),
            ("embertrace.max_depth".into(), self.max_depth.to_string()),
            ("embertrace.direct".into(), self.direct.clone()),
            ("embertrace.scene".into(), self.scene.clone()),
            (
                "embertrace.version".into(),
                env!("CARGO_PKG_VERSION").to_string(),
            ),
        ]
    }
}

/// Fail early if a report could not be written to `path`.
pub fn check_report_path(path: &Path) -> Result<()> {
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !parent.is_dir() {
        return Err(Error::Settings(format!(
            "{}: directory {} does not exist",
            path.display(),
            parent.display()
        )));
    }
    if path.is_dir() {
        return Err(Error::Settings(format!(
            "{}: is a directory, expected a file",
            path.display()
        )));
    }
    Ok(())
}
