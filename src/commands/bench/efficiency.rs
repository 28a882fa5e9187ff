//! `embertrace bench SCENE --efficiency`: the renderer's efficiency, the
//! share of a render's time that its ray queries alone would take.
//!
//! A render on one thread is run once through a recording backend, which
//! logs every query the estimator makes (single rays and batches, in order,
//! with their coherence hints). Then, taking turns in each repetition, the
//! same render runs on the real backend (timed), and the log is replayed
//! against the real backend with nothing else (timed). Efficiency is the
//! replay's time over the render's: 1 would mean shading, sampling and
//! bookkeeping cost nothing; `1 / efficiency` is how much faster the
//! renderer could get without tracing rays faster. Both figures are the
//! median over the repetitions, measured on the same thread.

use super::throughput::median;
use crate::accel::{self, AccelOptions, Accelerator, AlphaTest, Backend, Coherence, Hit, Masked};
use crate::error::Result;
use crate::integrator::{PathTracer, RayCounts};
use crate::math::Ray;
use crate::render::{RenderSettings, render};
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::settings::IntegratorSettings;
use serde::Serialize;
use std::sync::Mutex;
use std::time::Instant;

/// What the benchmark renders.
#[derive(Debug, Clone)]
pub struct EfficiencySettings {
    /// Backend.
    pub backend: Backend,
    /// Image width and height.
    pub resolution: [u32; 2],
    /// Samples per pixel.
    pub spp: u32,
    /// Sample generator.
    pub sampler: SamplerKind,
    /// Repetitions (medians are reported).
    pub reps: usize,
    /// How the backend is built.
    pub options: AccelOptions,
}

/// The result.
#[derive(Debug, Clone, Serialize)]
pub struct EfficiencyReport {
    /// Scene file.
    pub scene: String,
    /// Backend.
    pub backend: String,
    /// Image width and height.
    pub resolution: [u32; 2],
    /// Samples per pixel.
    pub spp: u32,
    /// Sampler.
    pub sampler: String,
    /// Rays the render traced, by kind.
    pub camera_rays: u64,
    /// BSDF-sampled continuation rays.
    pub extension_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// Median seconds of the render on one thread.
    pub render_seconds: f64,
    /// Median seconds of its queries alone, on one thread.
    pub query_seconds: f64,
    /// Samples per second of the render, one thread.
    pub samples_per_second: f64,
    /// Samples per second the queries alone would allow, one thread.
    pub query_bound_samples_per_second: f64,
    /// `query_seconds / render_seconds`.
    pub efficiency: f64,
}

/// One logged query.
#[derive(Debug, Clone, Copy)]
enum Query {
    Intersect {
        start: usize,
        len: usize,
        coherence: Coherence,
    },
    Occluded {
        start: usize,
        len: usize,
        coherence: Coherence,
    },
}

#[derive(Default)]
struct Log {
    rays: Vec<Ray>,
    queries: Vec<Query>,
}

/// A backend that answers through another and logs every query.
struct Recorder<'a> {
    inner: &'a dyn Accelerator,
    log: Mutex<Log>,
}

impl Recorder<'_> {
    fn record(&self, rays: &[Ray], occlusion: bool, coherence: Coherence) {
        let mut log = self.log.lock().unwrap_or_else(|e| e.into_inner());
        let start = log.rays.len();
        log.rays.extend_from_slice(rays);
        let len = rays.len();
        log.queries.push(if occlusion {
            Query::Occluded {
                start,
                len,
                coherence,
            }
        } else {
            Query::Intersect {
                start,
                len,
                coherence,
            }
        });
    }
}

impl Accelerator for Recorder<'_> {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn memory_bytes(&self) -> usize {
        self.inner.memory_bytes()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.record(std::slice::from_ref(ray), false, Coherence::Incoherent);
        self.inner.intersect(ray)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.record(std::slice::from_ref(ray), true, Coherence::Incoherent);
        self.inner.occluded(ray)
    }

    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherence: Coherence) {
        self.record(rays, false, coherence);
        self.inner.intersect_batch(rays, hits, coherence);
    }

    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], coherence: Coherence) {
        self.record(rays, true, coherence);
        self.inner.occluded_batch(rays, occluded, coherence);
    }

    // masked queries are recorded as plain ones: the replay runs them
    // through the scene's masks again (`Masked`)
    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit> {
        self.record(std::slice::from_ref(ray), false, Coherence::Incoherent);
        self.inner.intersect_masked(ray, alpha)
    }

    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool {
        self.record(std::slice::from_ref(ray), true, Coherence::Incoherent);
        self.inner.occluded_masked(ray, alpha)
    }
}

/// Replay `log` against `accel`; returns a checksum of the answers (so the
/// work cannot be optimised away).
fn replay(accel: &dyn Accelerator, log: &Log) -> usize {
    let mut hits = Vec::new();
    let mut occluded = Vec::new();
    let mut found = 0;
    for q in &log.queries {
        match *q {
            Query::Intersect {
                start,
                len,
                coherence,
            } => {
                hits.clear();
                hits.resize(len, None);
                accel.intersect_batch(&log.rays[start..start + len], &mut hits, coherence);
                found += hits.iter().filter(|h| h.is_some()).count();
            }
            Query::Occluded {
                start,
                len,
                coherence,
            } => {
                occluded.clear();
                occluded.resize(len, false);
                accel.occluded_batch(&log.rays[start..start + len], &mut occluded, coherence);
                found += occluded.iter().filter(|&&o| o).count();
            }
        }
    }
    found
}

/// Measure the efficiency of rendering `scene` with `integrator`.
pub fn run(
    scene: &Scene,
    settings: &EfficiencySettings,
    integrator: IntegratorSettings,
    progress: &dyn Fn(&str),
) -> Result<EfficiencyReport> {
    let accel = accel::build(settings.backend, scene.soup(), settings.options)?;
    let [w, h] = settings.resolution;
    let camera = scene.make_camera(w, h);
    let rs = RenderSettings {
        total_spp: None,
        resolution: settings.resolution,
        spp: settings.spp,
        first_sample: 0,
        seed: 0,
        threads: 1,
        tile_size: 16,
        sampler: settings.sampler,
        clamp: None,
    };
    progress("recording the render's queries");
    let recorder = Recorder {
        inner: accel.as_ref(),
        log: Mutex::new(Log::default()),
    };
    let recorded: RayCounts = {
        let tracer = PathTracer::new(scene, &recorder, integrator);
        render(&tracer, &camera, &rs, &|| {})?.rays
    };
    let log = recorder.log.into_inner().unwrap_or_else(|e| e.into_inner());
    let tracer = PathTracer::new(scene, accel.as_ref(), integrator);
    // a masked scene's queries replay through its masks, as the render ran
    // them; the others go to the backend directly
    let masked = Masked {
        accel: accel.as_ref(),
        alpha: scene.alpha_test(),
    };
    let queried: &dyn Accelerator = if masked.alpha.is_some() {
        &masked
    } else {
        accel.as_ref()
    };
    let (mut render_times, mut query_times) = (Vec::new(), Vec::new());
    let reps = settings.reps.max(1);
    for rep in 0..reps {
        let out = render(&tracer, &camera, &rs, &|| {})?;
        render_times.push(out.seconds);
        let t = Instant::now();
        let found = replay(queried, &log);
        query_times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(found);
        progress(&format!("repetition {} of {reps} done", rep + 1));
    }
    let (render_seconds, query_seconds) = (median(render_times), median(query_times));
    let samples = w as f64 * h as f64 * settings.spp as f64;
    Ok(EfficiencyReport {
        scene: scene.source.display().to_string(),
        backend: settings.backend.name().to_string(),
        resolution: settings.resolution,
        spp: settings.spp,
        sampler: settings.sampler.to_string(),
        camera_rays: recorded.camera,
        extension_rays: recorded.extension,
        shadow_rays: recorded.shadow,
        render_seconds,
        query_seconds,
        samples_per_second: samples / render_seconds,
        query_bound_samples_per_second: samples / query_seconds,
        efficiency: query_seconds / render_seconds,
    })
}

impl EfficiencyReport {
    /// The summary printed on stdout.
    pub fn table(&self) -> String {
        format!(
            "efficiency: {} ({}), {}x{}, {} spp, {} sampler, one thread\n\
             rays: {} camera, {} extension, {} shadow\n\
             render {:.3} s ({:.3} M samples/s); its queries alone {:.3} s ({:.3} M samples/s)\n\
             efficiency {:.3}\n",
            self.scene,
            self.backend,
            self.resolution[0],
            self.resolution[1],
            self.spp,
            self.sampler,
            self.camera_rays,
            self.extension_rays,
            self.shadow_rays,
            self.render_seconds,
            self.samples_per_second / 1e6,
            self.query_seconds,
            self.query_bound_samples_per_second / 1e6,
            self.efficiency
        )
    }
}
